#!/usr/bin/env python3
"""Writes the seed corpora under fuzz/corpus/<target>/ (standard library only).

Seeds are cropped from the real test files (testdata/, see tools/fetch-testdata.sh): a patch
of faces of a scan re-encoded in every mesh format, a corner of each DEM re-encoded in every
grid format, real headers truncated; plus hand-made edge cases (NaN/inf coordinates, indices
out of range, counts larger than the file, empty files, polygons, truncations). Every file is
at most 64 KB. Run from the repository root: `python3 fuzz/seeds.py`; `cargo fuzz cmin` then
keeps what adds coverage.
"""

import gzip
import io
import json
import math
import os
import struct
import sys
import zipfile
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CORPUS = os.path.join(ROOT, "fuzz", "corpus")
TESTDATA = os.path.join(ROOT, "testdata")
LIMIT = 64 * 1024


def put(target, name, data):
    if isinstance(data, str):
        data = data.encode()
    data = data[:LIMIT]
    d = os.path.join(CORPUS, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "seed-" + name), "wb") as f:
        f.write(data)


def truncations(target, name, data, cuts=(0, 1, 7, 0.25, 0.5, 0.9)):
    for c in cuts:
        n = int(len(data) * c) if isinstance(c, float) else c
        put(target, f"{name}-trunc{n}", data[:n])


# ------------------------------------------------------------------------------ meshes


def read_off(path, faces_wanted):
    """The first `faces_wanted` faces of an OFF scan and the vertices they use, renumbered."""
    with open(path) as f:
        words = f.read().split()
    assert words[0] == "OFF"
    nv, nf = int(words[1]), int(words[2])
    at = 4
    verts = []
    for _ in range(nv):
        verts.append(tuple(float(w) for w in words[at : at + 3]))
        at += 3
    faces = []
    for _ in range(min(nf, faces_wanted)):
        k = int(words[at])
        faces.append([int(w) for w in words[at + 1 : at + 1 + k]])
        at += 1 + k
    used = {}
    for face in faces:
        for v in face:
            used.setdefault(v, len(used))
    positions = [None] * len(used)
    for v, i in used.items():
        positions[i] = verts[v]
    return positions, [[used[v] for v in face] for face in faces]


def off_text(p, f, extra=""):
    out = [f"OFF{extra}", f"{len(p)} {len(f)} 0"]
    out += [" ".join(repr(c) for c in v) for v in p]
    out += [f"{len(face)} " + " ".join(map(str, face)) for face in f]
    return "\n".join(out) + "\n"


def obj_text(p, f):
    out = ["# cropped scan", "o crop"]
    out += ["v " + " ".join(repr(c) for c in v) for v in p]
    out += ["f " + " ".join(str(i + 1) for i in face) for face in f]
    return "\n".join(out) + "\n"


def ply_ascii(p, f):
    head = f"ply\nformat ascii 1.0\ncomment crop\nelement vertex {len(p)}\n"
    head += "property float x\nproperty float y\nproperty float z\n"
    head += f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n"
    body = "".join(" ".join(repr(c) for c in v) + "\n" for v in p)
    body += "".join(f"{len(face)} " + " ".join(map(str, face)) + "\n" for face in f)
    return head + body


def ply_binary(p, f, big, double=False, with_normals=False):
    e = ">" if big else "<"
    fmt = "binary_big_endian" if big else "binary_little_endian"
    t = "double" if double else "float"
    head = f"ply\nformat {fmt} 1.0\nelement vertex {len(p)}\n"
    head += "".join(f"property {t} {a}\n" for a in "xyz")
    if with_normals:
        head += "property float nx\nproperty float ny\nproperty float nz\n"
        head += "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    head += f"element face {len(f)}\nproperty list uchar uint vertex_indices\n"
    head += "element junk 2\nproperty list ushort short stuff\nproperty double w\n"
    head += "end_header\n"
    out = bytearray(head.encode())
    for v in p:
        out += struct.pack(e + ("3d" if double else "3f"), *v)
        if with_normals:
            out += struct.pack(e + "3f", 0.0, 0.0, 1.0) + bytes([10, 200, 30])
    for face in f:
        out += struct.pack(e + "B", len(face)) + struct.pack(e + f"{len(face)}I", *face)
    for k in range(2):
        out += struct.pack(e + "H", k + 1) + struct.pack(e + f"{k + 1}h", *range(k + 1))
        out += struct.pack(e + "d", 1.5)
    return bytes(out)


def stl_ascii(p, f):
    out = ["solid crop"]
    for face in f:
        for k in range(1, len(face) - 1):
            out.append("  facet normal 0 0 1\n    outer loop")
            for v in (face[0], face[k], face[k + 1]):
                out.append("      vertex " + " ".join(repr(c) for c in p[v]))
            out.append("    endloop\n  endfacet")
    out.append("endsolid crop")
    return "\n".join(out) + "\n"


def stl_binary(p, f, header=b"binary crop"):
    tris = [(face[0], face[k], face[k + 1]) for face in f for k in range(1, len(face) - 1)]
    out = bytearray(header.ljust(80, b" ")[:80])
    out += struct.pack("<I", len(tris))
    for t in tris:
        out += struct.pack("<3f", 0, 0, 1)
        for v in t:
            out += struct.pack("<3f", *p[v])
        out += b"\0\0"
    return bytes(out)


def gltf_parts(p, f, mode=4, index_type=5125, extra_nodes=True, normals=True):
    """(json dict, binary buffer) of one primitive."""
    tris = [i for face in f for k in range(1, len(face) - 1) for i in (face[0], face[k], face[k + 1])]
    pos = b"".join(struct.pack("<3f", *v) for v in p)
    fmt = {5121: "B", 5123: "H", 5125: "I"}[index_type]
    idx = b"".join(struct.pack("<" + fmt, i) for i in tris)
    while len(idx) % 4:
        idx += b"\0"
    nrm = b"".join(struct.pack("<3f", 0, 0, 1) for _ in p) if normals else b""
    buf = pos + idx + nrm
    lo = [min(v[c] for v in p) for c in range(3)]
    hi = [max(v[c] for v in p) for c in range(3)]
    views = [
        {"buffer": 0, "byteOffset": 0, "byteLength": len(pos), "target": 34962},
        {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx), "target": 34963},
    ]
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": len(p), "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": 1, "componentType": index_type, "count": len(tris), "type": "SCALAR"},
    ]
    attributes = {"POSITION": 0}
    if normals:
        views.append({"buffer": 0, "byteOffset": len(pos) + len(idx), "byteLength": len(nrm)})
        accessors.append({"bufferView": 2, "componentType": 5126, "count": len(p), "type": "VEC3"})
        attributes["NORMAL"] = 2
    nodes = [{"mesh": 0}]
    if extra_nodes:
        nodes = [
            {"children": [1], "translation": [1, 2, 3], "scale": [1, -1, 1]},
            {"mesh": 0, "matrix": [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1]},
        ]
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": attributes, "indices": 1, "mode": mode}]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(buf)}],
    }
    return doc, buf


def glb(doc, buf):
    j = json.dumps(doc, separators=(",", ":")).encode()
    while len(j) % 4:
        j += b" "
    b = bytes(buf)
    while len(b) % 4:
        b += b"\0"
    chunks = struct.pack("<II", len(j), 0x4E4F534A) + j + struct.pack("<II", len(b), 0x004E4942) + b
    return b"glTF" + struct.pack("<II", 2, 12 + len(chunks)) + chunks


def gltf_embedded(doc, buf):
    import base64

    doc = json.loads(json.dumps(doc))
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(buf).decode()
    return json.dumps(doc, indent=1)


def meshes():
    p, f = read_off(os.path.join(TESTDATA, "mesh", "bunny00.off"), 120)
    p = [tuple(float(struct.unpack("f", struct.pack("f", c))[0]) for c in v) for v in p]
    quad_p = [(0.0, 0, 0), (1.0, 0, 0), (1.0, 1, 0), (0.0, 1, 0), (0.5, 0.5, 1)]
    quad_f = [[0, 1, 2, 3], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]

    # OFF: the scans' own headers and a cropped patch; variants and edge cases.
    with open(os.path.join(TESTDATA, "mesh", "armadillo.off"), "rb") as fh:
        head = fh.read(3000)
    put("off", "armadillo-head", head)
    off = off_text(p, f)
    put("off", "bunny-crop", off)
    truncations("off", "bunny-crop", off.encode(), (0, 5, 0.3, 0.7))
    put("off", "quads", off_text(quad_p, quad_f))
    put("off", "no-keyword", off_text(quad_p, quad_f)[4:])
    put("off", "comments", "# c\nOFF # x\n# y\n4 2 0\n0 0 0\n1 0 0\n0 1 0 # z\n1 1 1\n3 0 1 2\n3 1 3 2 255 0 0\n")
    put("off", "coff", "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2\n")
    put("off", "stcnoff", "STCNOFF\n3 1 0\n0 0 0 0 0 1 0 0 0.5 0.5 0.5\n1 0 0 0 0 1 1 0 1 0 0\n0 1 0 0 0 1 0 1 0 1 0\n3 0 1 2\n")
    put("off", "nan", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n")
    put("off", "inf", "OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 -1e999\n3 0 1 2\n")
    put("off", "index-range", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n")
    put("off", "negative-index", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n")
    put("off", "huge-counts", "OFF\n4294967295 18446744073709551615 0\n0 0 0\n")
    put("off", "count-past-file", "OFF\n30 10 0\n0 0 0\n1 0 0\n")
    put("off", "binary", "OFF BINARY\n3 1 0\n")
    put("off", "4off", "4OFF\n3 1 0\n")
    put("off", "face-count-huge", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n99999999999 0 1 2\n")
    put("off", "empty", "")

    # OBJ.
    obj = obj_text(p, f)
    put("obj", "bunny-crop", obj)
    truncations("obj", "bunny-crop", obj.encode(), (0, 0.4))
    put("obj", "quads", obj_text(quad_p, quad_f))
    put("obj", "attributes", "mtllib x.mtl\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1 0.5\nvt 0 0\nvt 1 0\nvt 0 1 0\nvn 0 0 1\ng a\ns off\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nl 1 2\n")
    put("obj", "relative", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf -4 -3 -2\nf -3//1 -1//1 -2//1\nvn 0 0 1\n")
    put("obj", "nan", "v 0 0 0\nv NaN 0 0\nv 0 1 0\nf 1 2 3\n")
    put("obj", "inf", "v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n")
    put("obj", "index-range", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")
    put("obj", "index-zero", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")
    put("obj", "index-huge", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9223372036854775808\nf 99999999999999999999 1 2\n")
    put("obj", "vt-range", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n")
    put("obj", "continuation", "v 0 0 0\nv 1 0 0 \\\n\nv 0 1 0\nf 1 2 3\r\n")
    put("obj", "empty", "")
    # Materials: the fuzz target reads the OBJ as its own library (newmtl/Kd/d/Tr/map_Kd
    # are skipped by the OBJ reader, v/f by the MTL one).
    put("obj", "materials", "mtllib self.mtl\nnewmtl red\nKd 1 0 0\nd 0.5\nnewmtl green\n"
        "Kd 0 1\nTr 0.25\nmap_Kd -s 1 1 1 .\\tex\\g.png\nnewmtl spectral\nKd spectral x.rfl\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl red\nf 1 2 3\nusemtl green\nf 1 3 4\n"
        "usemtl none\nf 2 3 4\nusemtl spectral\nf 1 2 4\n")
    put("obj", "materials-bad-kd", "mtllib a b\nnewmtl m\nKd 1 nan 0\nv 0 0 0\nv 1 0 0\n"
        "v 0 1 0\nusemtl m\nf 1 2 3\n")

    # PLY.
    with gzip.open(os.path.join(TESTDATA, "mesh", "dragon_vrip_res4.ply.gz")) as fh:
        dragon = fh.read(40000)
    put("ply", "dragon-res4-head", dragon)
    put("ply", "ascii-crop", ply_ascii(p, f))
    put("ply", "binary-le", ply_binary(p, f, False))
    put("ply", "binary-be-double", ply_binary(p, f, True, double=True))
    put("ply", "binary-le-attributes", ply_binary(quad_p, quad_f, False, with_normals=True))
    truncations("ply", "binary-le", ply_binary(p, f, False), (0, 20, 0.5, 0.95))
    put("ply", "quads", ply_ascii(quad_p, quad_f))
    put("ply", "tristrips", "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 2 0\n7 0 1 2 3 -1 2 3 4\n")
    put("ply", "nan", "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n")
    put("ply", "inf-binary", b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" + struct.pack("<9f", 0, 0, 0, math.inf, 0, 0, 0, 1, 0) + bytes([3]) + struct.pack("<3i", 0, 1, 2))
    put("ply", "index-range", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    put("ply", "counts-past-file", b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 99999999999\nproperty list uchar int vertex_indices\nend_header\n" + bytes(40))
    put("ply", "ascii-counts-past-file", "ply\nformat ascii 1.0\nelement vertex 4294967295\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n")
    put("ply", "list-length-huge", b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n" + bytes(36) + struct.pack(">I", 0xFFFFFFFF) + bytes(12))
    put("ply", "empty", "")
    put("ply", "no-format", "ply\nelement vertex 0\nend_header\n")

    # STL.
    put("stl", "ascii-crop", stl_ascii(p, f))
    put("stl", "binary-crop", stl_binary(p, f))
    put("stl", "binary-solid-header", stl_binary(quad_p, quad_f, header=b"solid but binary"))
    truncations("stl", "binary-crop", stl_binary(p, f), (0, 83, 84, 0.5))
    put("stl", "ascii-quad-facet", "solid q\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid q\nsolid r\nendsolid r\n")
    put("stl", "ascii-nan", "solid n\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n")
    put("stl", "binary-inf", stl_binary([(0, 0, 0), (math.inf, 0, 0), (0, 1, 0)], [[0, 1, 2]]))
    put("stl", "binary-count-past-file", b"x" * 80 + struct.pack("<I", 0xFFFFFFFF) + bytes(50))
    put("stl", "ascii-truncated", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1")
    put("stl", "empty", "")
    # Facet colours in the attribute bytes: VisCAM/SolidView (bit 15 marks a colour) and
    # Materialise (the header's COLOR= is the object colour; bit 15 clear: the facet's own).
    viscam = bytearray(stl_binary(quad_p, quad_f, header=b"viscam colours"))
    materialise = bytearray(stl_binary(quad_p, quad_f, header=b"COLOR=\x10\x20\x30\xff MATERIAL="))
    for t, word in enumerate([0x801F, 0x0000, 0xFC00, 0x83E0, 0x7FFF, 0x8000]):
        at = 84 + 50 * t + 48
        if at + 2 <= len(viscam):
            viscam[at:at + 2] = struct.pack("<H", word)
            materialise[at:at + 2] = struct.pack("<H", word)
    put("stl", "binary-viscam-colours", bytes(viscam))
    put("stl", "binary-materialise-colours", bytes(materialise))
    put("stl", "binary-colour-header-cut", b"COLOR=" + b" " * 74 + struct.pack("<I", 0))

    # glTF / GLB.
    doc, buf = gltf_parts(p, f)
    put("gltf", "glb-crop", glb(doc, buf))
    put("gltf", "embedded-crop", gltf_embedded(doc, buf))
    truncations("gltf", "glb-crop", glb(doc, buf), (0, 12, 20, 0.5, 0.9))
    d2, b2 = gltf_parts(quad_p, quad_f, mode=5, index_type=5121, extra_nodes=False, normals=False)
    put("gltf", "glb-strip-u8", glb(d2, b2))
    d3, b3 = gltf_parts(quad_p, quad_f, mode=6, index_type=5123, normals=False)
    put("gltf", "glb-fan-u16", glb(d3, b3))
    d4 = json.loads(json.dumps(d2))
    d4["accessors"][1]["count"] = 1000
    put("gltf", "glb-count-past-view", glb(d4, b2))
    d5 = json.loads(json.dumps(d2))
    d5["buffers"][0]["byteLength"] = 1 << 40
    put("gltf", "glb-buffer-too-long", glb(d5, b2))
    d6 = json.loads(json.dumps(d2))
    d6["buffers"][0]["uri"] = "external.bin"
    put("gltf", "external-uri", json.dumps(d6))
    d7 = json.loads(json.dumps(d2))
    d7["accessors"].append({"componentType": 5126, "count": 100000000, "type": "VEC3",
                            "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5121},
                                       "values": {"bufferView": 0}}})
    d7["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 2
    put("gltf", "glb-sparse-huge", glb(d7, b2))
    d8 = json.loads(json.dumps(d2))
    d8["nodes"] = [{"children": [1]}, {"children": [0], "mesh": 0}]
    put("gltf", "glb-cycle", glb(d8, b2))
    b9 = bytearray(b2)
    b9[0:4] = struct.pack("<f", math.nan)
    put("gltf", "glb-nan", glb(d2, bytes(b9)))
    d10 = json.loads(json.dumps(d2))
    d10["nodes"][0]["matrix"] = [1e300, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
    put("gltf", "glb-overflowing-matrix", glb(d10, b2))
    b11 = bytearray(b2)
    b11[len(quad_p) * 12] = 200  # an index out of range
    put("gltf", "glb-index-range", glb(d2, bytes(b11)))
    # baseColorFactor: two primitives, two materials, one with COLOR_0.
    d12 = json.loads(json.dumps(d2))
    prim = d12["meshes"][0]["primitives"][0]
    d12["meshes"][0]["primitives"] = [dict(prim, material=0), dict(prim, material=1)]
    d12["materials"] = [{"pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 0, 0.5]}},
                        {"pbrMetallicRoughness": {"baseColorFactor": [2, -1, 0.25, 1]}}]
    put("gltf", "glb-base-color-factors", glb(d12, b2))
    b13 = bytes(b2) + bytes([255, 128, 0, 255] * len(quad_p))
    d13 = json.loads(json.dumps(d12))
    d13["bufferViews"].append({"buffer": 0, "byteOffset": len(b2), "byteLength": 4 * len(quad_p)})
    d13["accessors"].append({"bufferView": len(d13["bufferViews"]) - 1, "componentType": 5121,
                             "normalized": True, "count": len(quad_p), "type": "VEC4"})
    d13["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = len(d13["accessors"]) - 1
    d13["buffers"][0]["byteLength"] = len(b13)
    put("gltf", "glb-color-times-factor", glb(d13, b13))
    put("gltf", "empty", "")


# ---------------------------------------------------------------------------- height fields


def netcdf(dims, gatts, variables, version=1):
    """A netCDF-3 file. dims: [(name, length)]; variables: [(name, dimids, atts, type, data)];
    atts: [(name, type, payload bytes, count)]."""

    def name(s):
        b = s.encode()
        return struct.pack(">I", len(b)) + b + b"\0" * (-len(b) % 4)

    def atts(lst):
        if not lst:
            return struct.pack(">II", 0, 0)
        out = struct.pack(">II", 12, len(lst))
        for n, t, payload, count in lst:
            out += name(n) + struct.pack(">II", t, count) + payload + b"\0" * (-len(payload) % 4)
        return out

    off = ">Q" if version == 2 else ">I"

    def header(begins):
        h = b"CDF" + bytes([version]) + struct.pack(">I", 0)
        h += struct.pack(">II", 10, len(dims)) if dims else struct.pack(">II", 0, 0)
        for n, length in dims:
            h += name(n) + struct.pack(">I", length)
        h += atts(gatts)
        h += struct.pack(">II", 11, len(variables))
        for (n, ids, a, t, data), b in zip(variables, begins):
            h += name(n) + struct.pack(">I", len(ids)) + b"".join(struct.pack(">I", i) for i in ids)
            h += atts(a) + struct.pack(">II", t, len(data)) + struct.pack(off, b)
        return h

    size = len(header([0] * len(variables)))
    begins, at = [], size
    for v in variables:
        begins.append(at)
        at += len(v[4])
    return header(begins) + b"".join(v[4] for v in variables)


def text_att(n, s):
    return (n, 2, s.encode(), len(s.encode()))


def etopo20_crop(cols, rows):
    """A corner of ETOPO20 with its own variable names, attributes and values."""
    with open(os.path.join(TESTDATA, "dem", "etopo20.cdf"), "rb") as fh:
        data = fh.read()
    nx, ny = 1081, 540
    x0 = 0x23A0F0 - 0  # begin of ROSE (from the file's header), checked below
    lon = [20 + k / 3 for k in range(cols)]
    lat = [-89.833 + k / 3 for k in range(rows)]
    rose_begin = struct.unpack(">I", data[0x240:0x244])[0]
    assert rose_begin == x0, hex(rose_begin)
    values = b"".join(data[rose_begin + 4 * (r * nx) : rose_begin + 4 * (r * nx + cols)] for r in range(100, 100 + rows))
    fill = struct.pack(">f", -1e34)
    return netcdf(
        [("ETOPO20X1_1081", cols), ("ETOPO20Y", rows)],
        [text_att("history", "FERRET V4.45 (GUI) 22-May-97")],
        [
            ("ETOPO20X1_1081", [0], [text_att("units", "degrees_east"), ("modulo", 2, b" ", 1), text_att("point_spacing", "even")], 6, b"".join(struct.pack(">d", v) for v in lon)),
            ("ETOPO20Y", [1], [text_att("units", "degrees_north"), text_att("point_spacing", "even")], 6, b"".join(struct.pack(">d", v) for v in lat)),
            ("ROSE", [1, 0], [("missing_value", 5, fill, 1), ("_FillValue", 5, fill, 1), text_att("long_name", "RELIEF OF THE SURFACE OF THE EARTH"), text_att("units", "METERS")], 5, values),
        ],
    )


def grids():
    # netCDF.
    with open(os.path.join(TESTDATA, "dem", "etopo20.cdf"), "rb") as fh:
        head = fh.read(LIMIT)
    put("netcdf", "etopo20-head", head)
    put("netcdf", "etopo20-header-only", head[:0x248])
    crop = etopo20_crop(24, 16)
    put("netcdf", "etopo20-crop", crop)
    truncations("netcdf", "etopo20-crop", crop, (4, 40, 0.3, 0.99))
    shorts = b"".join(struct.pack(">h", v) for v in [10, 20, -32768, 40, 50, 60])
    put("netcdf", "short-scaled-v2", netcdf(
        [("y", 2), ("x", 3)], [],
        [("z", [0, 1], [("scale_factor", 6, struct.pack(">d", 0.5), 1), ("add_offset", 5, struct.pack(">f", 100), 1), ("missing_value", 3, struct.pack(">h", -32768), 1)], 3, shorts + b"\0\0")],
        version=2))
    put("netcdf", "record-dim", netcdf([("t", 0), ("x", 3)], [], [("z", [0, 1], [], 5, bytes(12))]))
    put("netcdf", "bad-dim-id", netcdf([("x", 3)], [], [("z", [0, 7], [], 5, bytes(12))]))
    put("netcdf", "huge-dims", netcdf([("y", 0xFFFFFFFF), ("x", 0xFFFFFFFF)], [], [("z", [0, 1], [], 6, bytes(16))]))
    put("netcdf", "inf-coords", netcdf(
        [("y", 2), ("x", 2)], [],
        [("x", [1], [text_att("units", "degree")], 6, struct.pack(">2d", -1e308, 1e308)),
         ("y", [0], [text_att("units", "degree")], 6, struct.pack(">2d", 0, math.inf)),
         ("z", [0, 1], [], 5, struct.pack(">4f", 1, 2, math.inf, math.nan))]))
    put("netcdf", "far-coords", netcdf(
        [("y", 2), ("x", 2)], [],
        [("x", [1], [], 6, struct.pack(">2d", 1e308, 1.7e308)),
         ("y", [0], [], 6, struct.pack(">2d", 0, 1)),
         ("z", [0, 1], [], 1, b"\1\2\3\4")]))
    put("netcdf", "byte-int-double", netcdf(
        [("y", 2), ("x", 2)], [("title", 4, struct.pack(">i", 5), 1)],
        [("a", [0, 1], [], 1, b"\1\2\3\4"), ("b", [0, 1], [], 4, struct.pack(">4i", 1, 2, 3, 4)), ("c", [0, 1], [], 6, struct.pack(">4d", 1, 2, 3, 4))]))
    put("netcdf", "empty", "")

    # npy / npz.
    with zipfile.ZipFile(os.path.join(TESTDATA, "dem", "jacksboro_fault_dem.npz")) as z:
        entries = {n: z.read(n) for n in z.namelist()}
    elev = entries["elevation.npy"]
    hl = struct.unpack("<H", elev[8:10])[0]
    rows, cols = 344, 403
    data = elev[10 + hl :]
    cr, cc = 40, 50
    crop = b"".join(data[2 * (r * cols) : 2 * (r * cols + cc)] for r in range(cr))

    def npy(descr, shape, payload, fortran=False, version=1):
        h = "{'descr': '%s', 'fortran_order': %s, 'shape': %s, }" % (descr, fortran, shape)
        pre = 10 if version == 1 else 12
        while (pre + len(h) + 1) % 64:
            h += " "
        h += "\n"
        ln = struct.pack("<H", len(h)) if version == 1 else struct.pack("<I", len(h))
        return b"\x93NUMPY" + bytes([version, 0]) + ln + h.encode() + payload

    jack = npy("<i2", f"({cr}, {cc})", crop)
    put("npy", "jacksboro-crop", jack)
    put("npy", "jacksboro-head", elev[:LIMIT])
    truncations("npy", "jacksboro-crop", jack, (6, 11, 0.5))
    put("npy", "f4-be", npy(">f4", "(2, 3)", struct.pack(">6f", 1, 2, math.nan, 4, 5, 6)))
    put("npy", "f8-fortran", npy("<f8", "(3, 2)", struct.pack("<6d", 1, 2, 3, 4, 5, 6), fortran=True))
    put("npy", "u1-v2", npy("|u1", "(2, 2)", b"\1\2\3\4", version=2))
    put("npy", "i4-v3", npy("<i4", "(2,2)", struct.pack("<4i", -1, 2, 3, 4), version=3))
    put("npy", "u2-u4", npy("<u4", "(2, 2)", struct.pack("<4I", 1, 2, 3, 0xFFFFFFFF)))
    put("npy", "inf", npy("<f4", "(2, 2)", struct.pack("<4f", 1, math.inf, 3, 4)))
    put("npy", "all-nan", npy("<f8", "(2, 2)", struct.pack("<4d", *[math.nan] * 4)))
    put("npy", "huge-shape", npy("<i2", "(18446744073709551615, 18446744073709551615)", b"\0" * 8))
    put("npy", "1d", npy("<i2", "(4,)", b"\0" * 8))
    put("npy", "3d", npy("<i2", "(2, 2, 2)", b"\0" * 16))
    put("npy", "scalar", entries["dx.npy"])
    put("npy", "header-past-end", b"\x93NUMPY\x02\x00\xff\xff\xff\xff{}")
    put("npy", "empty", "")
    put("npy", "object", npy("|O", "(2, 2)", b"\0" * 32))

    def npz(files, method=zipfile.ZIP_DEFLATED):
        out = io.BytesIO()
        with zipfile.ZipFile(out, "w", method) as z:
            for n, d in files.items():
                z.writestr(n, d)
        return out.getvalue()

    small = {n: d for n, d in entries.items() if n != "elevation.npy"}
    put("npz", "jacksboro-crop", npz(dict(small, **{"elevation.npy": jack})))
    put("npz", "jacksboro-crop-stored", npz(dict(small, **{"elevation.npy": jack}), zipfile.ZIP_STORED))
    truncations("npz", "jacksboro-crop", npz(dict(small, **{"elevation.npy": jack})), (0, 30, 0.5, 0.98))
    put("npz", "two-grids", npz({"a.npy": npy("<f4", "(2, 2)", struct.pack("<4f", 1, 2, 3, 4)), "b.npy": npy("<i2", "(3, 3)", bytes(18))}))
    put("npz", "no-grid", npz({"dx.npy": entries["dx.npy"]}))
    put("npz", "not-npy", npz({"x.npy": b"hello"}))
    put("npz", "bomb", npz({"a.npy": npy("|u1", "(4000, 4000)", bytes(16_000_000))}))
    put("npz", "empty", "")

    # GeoTIFF.
    def tiff(width, height, bps, fmt, pixels, tags_extra=(), compression=1, spp=1, photometric=1, big=False):
        e = ">" if big else "<"
        tags = {
            256: (3, [width]), 257: (3, [height]), 258: (3, [bps] * spp), 259: (3, [compression]),
            262: (3, [photometric]), 277: (3, [spp]), 278: (3, [height]), 339: (3, [fmt] * spp),
        }
        data = pixels if compression == 1 else zlib.compress(pixels)
        for t, ty, vals in tags_extra:
            tags[t] = (ty, vals)
        tags[273] = (4, [0])
        tags[279] = (4, [len(data)])
        sizes = {1: 1, 2: 1, 3: 2, 4: 4, 12: 8, 16: 8}
        codes = {1: "B", 2: "B", 3: "H", 4: "I", 12: "d", 16: "Q"}
        ifd_at = 8
        n = len(tags)
        extra_at = ifd_at + 2 + 12 * n + 4
        extra = bytearray()
        entries = bytearray()
        data_at = None
        order = sorted(tags)
        # Out-of-line values go after the IFD, then the pixel data.
        payloads = {}
        for t in order:
            ty, vals = tags[t]
            raw = vals if isinstance(vals, bytes) else struct.pack(e + codes[ty] * len(vals), *vals)
            payloads[t] = raw
            if len(raw) > 4:
                payloads[t] = (extra_at + len(extra), raw)
                extra += raw + (b"\0" if len(raw) % 2 else b"")
        data_at = extra_at + len(extra)
        for t in order:
            ty, vals = tags[t]
            count = len(vals)
            if t == 273:
                raw = struct.pack(e + "I", data_at)
            else:
                raw = payloads[t]
            if isinstance(raw, tuple):
                field = struct.pack(e + "I", raw[0])
            else:
                field = raw.ljust(4, b"\0")
            entries += struct.pack(e + "HHI", t, ty, count) + field
        head = (b"MM" if big else b"II") + struct.pack(e + "HI", 42, ifd_at)
        return head + struct.pack(e + "H", n) + bytes(entries) + struct.pack(e + "I", 0) + bytes(extra) + data

    geo = [
        (33550, 12, [30.0, 30.0, 0.0]),
        (33922, 12, [0.0, 0.0, 0.0, 500000.0, 4000000.0, 0.0]),
        (34735, 3, [1, 1, 0, 1, 1024, 0, 1, 2]),
        (42113, 2, b"-9999\0"),
    ]
    cr2, cc2 = 24, 30
    jcrop = b"".join(data[2 * (r * cols) : 2 * (r * cols + cc2)] for r in range(cr2))
    put("geotiff", "jacksboro-i16", tiff(cc2, cr2, 16, 2, jcrop, geo))
    put("geotiff", "jacksboro-i16-deflate", tiff(cc2, cr2, 16, 2, jcrop, geo, compression=8))
    be = b"".join(struct.pack(">h", struct.unpack("<h", jcrop[i : i + 2])[0]) for i in range(0, len(jcrop), 2))
    put("geotiff", "jacksboro-i16-big-endian", tiff(cc2, cr2, 16, 2, be, geo, big=True))
    t = tiff(cc2, cr2, 16, 2, jcrop, geo)
    truncations("geotiff", "jacksboro-i16", t, (0, 8, 60, 0.5))
    put("geotiff", "f32-nodata-nan", tiff(2, 2, 32, 3, struct.pack("<4f", 1, math.nan, -9999, 4), geo))
    put("geotiff", "f64-inf", tiff(2, 2, 64, 3, struct.pack("<4d", 1, math.inf, 3, 4)))
    put("geotiff", "u8", tiff(3, 2, 8, 1, bytes([1, 2, 3, 4, 5, 6])))
    put("geotiff", "u32", tiff(2, 2, 32, 1, struct.pack("<4I", 1, 2, 3, 4)))
    put("geotiff", "rgb", tiff(2, 2, 8, 1, bytes(12), spp=3, photometric=2))
    put("geotiff", "huge-dims", tiff(0xFFFF, 0xFFFF, 16, 2, bytes(8)))
    put("geotiff", "one-row", tiff(4, 1, 8, 1, bytes(4)))
    put("geotiff", "empty", "")

    # PNG / PGM.
    def png(width, height, depth, rows_bytes, color=0):
        def chunk(t, d):
            return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
        raw = b"".join(b"\0" + r for r in rows_bytes)
        return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth, color, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))

    jrows = [b"".join(struct.pack(">H", struct.unpack("<h", data[2 * (r * cols + c) : 2 * (r * cols + c) + 2])[0] & 0xFFFF) for c in range(cc)) for r in range(cr)]
    p16 = png(cc, cr, 16, jrows)
    put("png", "jacksboro-16bit", p16)
    truncations("png", "jacksboro-16bit", p16, (0, 8, 33, 0.5))
    put("png", "8bit", png(3, 2, 8, [bytes([1, 2, 3]), bytes([4, 5, 6])]))
    put("png", "rgb", png(2, 2, 8, [bytes(6), bytes(6)], color=2))
    put("png", "1bit", png(8, 2, 1, [b"\xaa", b"\x55"]))
    put("png", "huge-dims", png(0x7FFFFFFF, 0x7FFFFFFF, 16, []))
    put("png", "one-column", png(1, 4, 8, [b"\1"] * 4))
    put("png", "empty", "")

    pgm16 = f"P5\n# jacksboro crop\n{cc} {cr}\n65535\n".encode() + b"".join(jrows)
    put("pgm", "jacksboro-16bit", pgm16)
    truncations("pgm", "jacksboro-16bit", pgm16, (0, 2, 0.5))
    with open(os.path.join(TESTDATA, "dem", "volcano.json")) as fh:
        volcano = json.load(fh)
    vw, vh, vv = volcano["width"], volcano["height"], volcano["values"]
    put("pgm", "volcano-ascii", f"P2\n{vw} {vh}\n255\n" + "\n".join(" ".join(str(v) for v in vv[r * vw : (r + 1) * vw]) for r in range(vh)) + "\n")
    put("pgm", "volcano-8bit", f"P5 {vw} {vh} 255\n".encode() + bytes(vv))
    put("pgm", "huge-dims", "P5 18446744073709551615 2 255\n\0\0")
    put("pgm", "maxval-zero", "P2 2 2 0\n0 0 0 0\n")
    put("pgm", "ascii-short", "P2 3 3 255\n1 2\n")
    put("pgm", "empty", "")

    # Raw f32 (first 4 bytes: columns, rows as u16 LE) and JSON grids.
    def raw(w, h, values):
        return struct.pack("<HH", w, h) + b"".join(struct.pack("<f", v) for v in values)

    put("raw_f32", "volcano-crop", raw(20, 16, [float(vv[r * vw + c]) for r in range(16) for c in range(20)]))
    put("raw_f32", "nan-inf", raw(2, 2, [1, math.nan, math.inf, 2]))
    put("raw_f32", "all-nan", raw(2, 2, [math.nan] * 4))
    put("raw_f32", "size-mismatch", raw(3, 3, [0] * 4))
    put("raw_f32", "huge", raw(0xFFFF, 0xFFFF, [0] * 4))
    put("raw_f32", "one-row", raw(4, 1, [0] * 4))
    put("raw_f32", "short", b"\1\0")

    with open(os.path.join(TESTDATA, "dem", "volcano.json"), "rb") as fh:
        put("json_grid", "volcano", fh.read())
    put("json_grid", "holes-spacing", '{"width": 3, "height": 2, "values": [1, null, 3, 4.5, 5, -6e3], "spacing": 30}')
    put("json_grid", "bad-spacing", '{"width": 2, "height": 2, "values": [1, 2, 3, 4], "spacing": -1}')
    put("json_grid", "huge-dims", '{"width": 18446744073709551615, "height": 2, "values": [1, 2]}')
    put("json_grid", "overflowing-value", '{"width": 2, "height": 2, "values": [1e39, 2, 3, 4]}')
    put("json_grid", "wrong-count", '{"width": 2, "height": 3, "values": [1, 2]}')
    put("json_grid", "string-value", '{"width": 2, "height": 1, "values": [1, "x"]}')
    put("json_grid", "deep", "[" * 200 + "]" * 200)
    put("json_grid", "empty", "")


if __name__ == "__main__":
    meshes()
    grids()
    total = 0
    for d in sorted(os.listdir(CORPUS)):
        files = os.listdir(os.path.join(CORPUS, d))
        size = sum(os.path.getsize(os.path.join(CORPUS, d, f)) for f in files)
        total += size
        print(f"{d:10} {len(files):4} files {size:8} bytes")
    print(f"total {total} bytes", file=sys.stderr)
