#!/usr/bin/env python3
"""Converts a binary little-endian PLY of float x, y, z vertices and uchar/int triangle lists
(what `tessera gen mesh` writes) to a binary STL or a GLB (positions as f32, u32 indices, one
node), so the out-of-core import of those formats can be measured on the same mesh
(BENCHMARKS.md, "Input formats"). Standard library only.

    tools/ply-to.py g2s.ply g2s.stl
    tools/ply-to.py g2s.ply g2s.glb
"""
import json
import struct
import sys


def read_ply(path):
    with open(path, "rb") as f:
        header = b""
        while not header.endswith(b"end_header\n"):
            byte = f.read(1)
            if not byte:
                sys.exit(f"{path}: no end_header")
            header += byte
        text = header.decode("ascii")
        if "format binary_little_endian" not in text:
            sys.exit(f"{path}: not a binary little-endian PLY")
        vertices = int(text.split("element vertex ")[1].split()[0])
        faces = int(text.split("element face ")[1].split()[0])
        positions = f.read(12 * vertices)
        records = f.read(13 * faces)
    if len(positions) != 12 * vertices or len(records) != 13 * faces:
        sys.exit(f"{path}: truncated, or not x, y, z floats and uchar/int triangles")
    indices = bytearray(12 * faces)
    for t in range(faces):
        if records[13 * t] != 3:
            sys.exit(f"{path}: face {t} is not a triangle")
        indices[12 * t : 12 * t + 12] = records[13 * t + 1 : 13 * t + 13]
    return vertices, faces, positions, bytes(indices)


def write_stl(path, faces, positions, indices):
    corner = struct.Struct("<3I")
    with open(path, "wb") as out:
        out.write(b"\0" * 80 + struct.pack("<I", faces))
        for t in range(faces):
            a, b, c = corner.unpack_from(indices, 12 * t)
            out.write(b"\0" * 12)
            for v in (a, b, c):
                out.write(positions[12 * v : 12 * v + 12])
            out.write(b"\0\0")


def write_glb(path, vertices, faces, positions, indices):
    buffer = positions + indices
    document = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(buffer)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(positions)},
            {"buffer": 0, "byteOffset": len(positions), "byteLength": len(indices)},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": vertices, "type": "VEC3",
             "min": [-1e9] * 3, "max": [1e9] * 3},
            {"bufferView": 1, "componentType": 5125, "count": 3 * faces, "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    text = json.dumps(document).encode()
    text += b" " * (-len(text) % 4)
    binary = buffer + b"\0" * (-len(buffer) % 4)
    with open(path, "wb") as out:
        out.write(b"glTF" + struct.pack("<II", 2, 12 + 8 + len(text) + 8 + len(binary)))
        out.write(struct.pack("<I", len(text)) + b"JSON" + text)
        out.write(struct.pack("<I", len(binary)) + b"BIN\0" + binary)


def main():
    if len(sys.argv) != 3 or not sys.argv[2].endswith((".stl", ".glb")):
        sys.exit("usage: ply-to.py IN.ply OUT.stl|OUT.glb")
    vertices, faces, positions, indices = read_ply(sys.argv[1])
    if sys.argv[2].endswith(".stl"):
        write_stl(sys.argv[2], faces, positions, indices)
    else:
        write_glb(sys.argv[2], vertices, faces, positions, indices)


if __name__ == "__main__":
    main()
