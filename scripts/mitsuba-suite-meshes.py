#!/usr/bin/env python3
"""Writes the meshes of the Mitsuba agreement suite (tests/data/mitsuba-suite/): an icosphere
with vertex normals (OBJ), a box without normals (OBJ), a gently bumpy terrain near y = 0
without normals (ASCII PLY) and a torus with vertex normals (binary little-endian PLY).
Deterministic; no third-party modules. Run from the repository root."""
import math, os, struct

OUT = os.path.join("tests", "data", "mitsuba-suite")


def icosphere(subdiv):
    p = (1 + 5 ** 0.5) / 2
    v = [(-1, p, 0), (1, p, 0), (-1, -p, 0), (1, -p, 0), (0, -1, p), (0, 1, p), (0, -1, -p),
         (0, 1, -p), (p, 0, -1), (p, 0, 1), (-p, 0, -1), (-p, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in q)) for c in q) for q in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdiv):
        mid = {}

        def m(a, b):
            k = (min(a, b), max(a, b))
            if k not in mid:
                q = [(v[a][i] + v[b][i]) / 2 for i in range(3)]
                n = math.sqrt(sum(x * x for x in q))
                v.append(tuple(x / n for x in q))
                mid[k] = len(v) - 1
            return mid[k]

        nf = []
        for a, b, c in f:
            ab, bc, ca = m(a, b), m(b, c), m(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return v, f


def fmt(x):
    return repr(round(x, 7))


def write_icosphere():
    v, f = icosphere(3)
    with open(os.path.join(OUT, "icosphere-normals.obj"), "w") as o:
        o.write("# unit icosphere (3 subdivisions) with its vertex normals\n")
        for q in v:
            o.write("v %s %s %s\n" % tuple(map(fmt, q)))
        for q in v:
            o.write("vn %s %s %s\n" % tuple(map(fmt, q)))
        for a, b, c in f:
            o.write("f %d//%d %d//%d %d//%d\n" % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1))


def write_box():
    with open(os.path.join(OUT, "box.obj"), "w") as o:
        o.write("# box [-1, 1]^3, faces outwards, no normals\n")
        for i in range(8):
            o.write("v %d %d %d\n" % tuple(1 if i & b else -1 for b in (1, 2, 4)))
        for q in [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]:
            o.write("f %d %d %d %d\n" % q)


def write_terrain():
    n = 24
    verts = []
    for j in range(n + 1):
        for i in range(n + 1):
            x, z = -3 + 6 * i / n, -3 + 6 * j / n
            y = 0.04 * math.sin(2.1 * x + 0.3) * math.cos(1.7 * z) + 1e-7 * x
            verts.append((x, y, z))
    faces = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            b, c, d = a + 1, a + n + 2, a + n + 1
            # Counter-clockwise seen from above (+y), as two triangles (Mitsuba's PLY reader
            # takes triangles only).
            faces += [(a, d, c), (a, c, b)]
    with open(os.path.join(OUT, "terrain.ply"), "w") as o:
        o.write("ply\nformat ascii 1.0\ncomment gently bumpy terrain near y = 0, no normals\n")
        o.write("element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % len(verts))
        o.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(faces))
        for q in verts:
            o.write("%s %s %s\n" % tuple(map(fmt, q)))
        for q in faces:
            o.write("3 %d %d %d\n" % q)


def write_torus():
    R, r, nu, nv = 0.7, 0.28, 48, 24
    verts, norms = [], []
    for i in range(nu):
        a = 2 * math.pi * i / nu
        for j in range(nv):
            b = 2 * math.pi * j / nv
            n = (math.cos(a) * math.cos(b), math.sin(b), math.sin(a) * math.cos(b))
            c = (R * math.cos(a), 0.0, R * math.sin(a))
            verts.append(tuple(c[k] + r * n[k] for k in range(3)))
            norms.append(n)
    faces = []
    for i in range(nu):
        for j in range(nv):
            a = i * nv + j
            b = ((i + 1) % nu) * nv + j
            c = ((i + 1) % nu) * nv + (j + 1) % nv
            d = i * nv + (j + 1) % nv
            faces += [(a, d, c), (a, c, b)]
    with open(os.path.join(OUT, "torus-normals.ply"), "wb") as o:
        o.write(b"ply\nformat binary_little_endian 1.0\ncomment torus with vertex normals\n")
        o.write(b"element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % len(verts))
        o.write(b"property float nx\nproperty float ny\nproperty float nz\n")
        o.write(b"element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(faces))
        for p, n in zip(verts, norms):
            o.write(struct.pack("<6f", *p, *n))
        for q in faces:
            o.write(struct.pack("<B3i", 3, *q))


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    write_icosphere()
    write_box()
    write_terrain()
    write_torus()
