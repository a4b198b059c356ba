#!/usr/bin/env python3
"""Adds a texture seam to a `tessera gen mesh --colour` PLY: u, v from a spherical mapping
around the model's centre (u = longitude, v = latitude), the vertices of every triangle that
crosses the u = 0/1 meridian copied with u + 1 (same position, other u: wedges of one vertex).
Usage: tools/seam-uv.py IN.ply OUT.ply (BENCHMARKS.md, "Wedges under a budget")"""
import sys
import numpy as np

src, dst = sys.argv[1], sys.argv[2]
data = open(src, "rb").read()
end = data.index(b"end_header\n") + len(b"end_header\n")
header = data[:end].decode()
nv = int(header.split("element vertex ")[1].split()[0])
nf = int(header.split("element face ")[1].split()[0])
vt = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("r", "u1"), ("g", "u1"), ("b", "u1")])
ft = np.dtype([("n", "u1"), ("i", "<i4", 3)])
v = np.frombuffer(data, vt, nv, end)
f = np.frombuffer(data, ft, nf, end + nv * vt.itemsize)["i"].copy()
p = np.stack([v["x"], v["y"], v["z"]], 1).astype(np.float64)
c = p - p.mean(0)
u = (np.arctan2(c[:, 1], c[:, 0]) / (2 * np.pi) + 0.5).astype(np.float32)
w = (np.arccos(np.clip(c[:, 2] / np.linalg.norm(c, axis=1), -1, 1)) / np.pi).astype(np.float32)
fu = u[f]
cross = (fu.max(1) - fu.min(1)) > 0.5
# Corners with u < 0.5 of crossing triangles get copies with u + 1.
low = cross[:, None] & (fu < 0.5)
need = np.unique(f[low])
copy_of = np.full(nv, -1, np.int64)
copy_of[need] = nv + np.arange(len(need))
f[low] = copy_of[f[low]]
out = np.zeros(nv + len(need), np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                        ("u", "<f4"), ("v", "<f4"),
                                        ("r", "u1"), ("g", "u1"), ("b", "u1")]))
for k in "xyzrgb":
    out[k][:nv] = v[k]
    out[k][nv:] = v[k][need]
out["u"][:nv], out["v"][:nv] = u, w
out["u"][nv:], out["v"][nv:] = u[need] + 1, w[need]
faces = np.zeros(nf, ft)
faces["n"] = 3
faces["i"] = f
hdr = ("ply\nformat binary_little_endian 1.0\n"
       f"comment {src} with a u seam (seam-uv.py)\nelement vertex {len(out)}\n"
       "property float x\nproperty float y\nproperty float z\nproperty float u\n"
       "property float v\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
       f"element face {nf}\nproperty list uchar int vertex_indices\nend_header\n")
with open(dst, "wb") as o:
    o.write(hdr.encode())
    o.write(out.tobytes())
    o.write(faces.tobytes())
print(f"{dst}: {len(out)} vertices ({len(need)} seam copies), {nf} triangles")
