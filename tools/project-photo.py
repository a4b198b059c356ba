#!/usr/bin/env python3
"""Colour a range scan by projecting a photograph onto it, as an RGB scanner's colour camera
does: a pinhole camera on the scan's +z side, looking down -z at the centre of its bounding
box, its field of view just holding the bounding sphere; each vertex gets the photograph's
colour where it projects (bilinear, rounded to 8 bits). Every vertex is coloured, the far side
too (one view, seen through the surface).

    tools/project-photo.py SCAN.off PHOTO.png OUT.ply

Standard library only (the PNG is decoded with zlib: 8-bit RGB or RGBA, not interlaced) and
deterministic: IEEE double arithmetic throughout, so the output's bytes (and its sha256, which
tools/fetch-testdata.sh pins) are the same on every machine. Positions and faces are copied
from the OFF file as text, so the coloured PLY has exactly the scan's geometry.
"""
import math
import struct
import sys
import zlib


def read_off(path):
    with open(path) as f:
        tokens = [t for line in f for t in line.split("#", 1)[0].split()]
    if not tokens or tokens[0] != "OFF":
        sys.exit(f"{path}: not an OFF file")
    n_vertices, n_faces = int(tokens[1]), int(tokens[2])
    at = 4
    vertices = [tokens[at + 3 * i : at + 3 * i + 3] for i in range(n_vertices)]
    at += 3 * n_vertices
    faces = []
    for _ in range(n_faces):
        k = int(tokens[at])
        faces.append(tokens[at + 1 : at + 1 + k])
        at += 1 + k
    return vertices, faces


def read_png(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        sys.exit(f"{path}: not a PNG")
    at, idat = 8, b""
    while at < len(data):
        (length,) = struct.unpack(">I", data[at : at + 4])
        kind, body = data[at + 4 : at + 8], data[at + 8 : at + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        at += 12 + length
    channels = {2: 3, 6: 4}.get(colour)
    if depth != 8 or channels is None or interlace != 0:
        sys.exit(f"{path}: only 8-bit RGB/RGBA non-interlaced PNGs are read")
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, prev = [], bytearray(stride)
    for y in range(height):
        kind = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1 : (y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if kind == 1:
                line[i] = (line[i] + a) & 255
            elif kind == 2:
                line[i] = (line[i] + b) & 255
            elif kind == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
            elif kind != 0:
                sys.exit(f"{path}: bad PNG filter {kind}")
        rows.append(bytes(line))
        prev = line
    return width, height, channels, rows


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: project-photo.py SCAN.off PHOTO.png OUT.ply")
    vertices, faces = read_off(sys.argv[1])
    width, height, channels, rows = read_png(sys.argv[2])
    points = [tuple(float(c) for c in v) for v in vertices]
    lo = [min(p[a] for p in points) for a in range(3)]
    hi = [max(p[a] for p in points) for a in range(3)]
    centre = [(lo[a] + hi[a]) / 2 for a in range(3)]
    radius = math.sqrt(sum((hi[a] - lo[a]) ** 2 for a in range(3))) / 2
    # The camera 3 radii in front of the centre; the bounding sphere just fills the shorter
    # side of the photograph.
    distance = 3 * radius
    focal = 0.5 * min(width, height) * math.sqrt(distance * distance - radius * radius) / radius

    def sample(x, y):
        # Bilinear at pixel coordinates (pixel centres at integers), clamped to the image.
        x = min(max(x, 0.0), width - 1.0)
        y = min(max(y, 0.0), height - 1.0)
        x0, y0 = min(int(x), width - 2), min(int(y), height - 2)
        fx, fy = x - x0, y - y0
        out = []
        for c in range(3):
            p00 = rows[y0][x0 * channels + c]
            p10 = rows[y0][(x0 + 1) * channels + c]
            p01 = rows[y0 + 1][x0 * channels + c]
            p11 = rows[y0 + 1][(x0 + 1) * channels + c]
            top = p00 + (p10 - p00) * fx
            bottom = p01 + (p11 - p01) * fx
            out.append(int(top + (bottom - top) * fy + 0.5))
        return out

    with open(sys.argv[3], "w", newline="\n") as out:
        out.write("ply\nformat ascii 1.0\n")
        out.write("comment coloured by tools/project-photo.py\n")
        out.write(f"element vertex {len(vertices)}\n")
        out.write("property double x\nproperty double y\nproperty double z\n")
        out.write("property uchar red\nproperty uchar green\nproperty uchar blue\n")
        out.write(f"element face {len(faces)}\n")
        out.write("property list uchar int vertex_indices\nend_header\n")
        for text, p in zip(vertices, points):
            depth = distance - (p[2] - centre[2])
            u = width / 2 + focal * (p[0] - centre[0]) / depth - 0.5
            v = height / 2 - focal * (p[1] - centre[1]) / depth - 0.5
            r, g, b = sample(u, v)
            out.write(f"{text[0]} {text[1]} {text[2]} {r} {g} {b}\n")
        for f in faces:
            out.write(f"{len(f)} {' '.join(f)}\n")


if __name__ == "__main__":
    main()
