#!/usr/bin/env python3
"""Writes scenes/mitsuba/assets/meshes.serialized, the Mitsuba `.serialized` file (format
version 4) of scenes/mitsuba/meshes.xml and orthographic.xml: three meshes, each a zlib
stream after its header, and the table of their offsets at the end.

  0: an icosphere of radius 1 (2 subdivisions, 320 triangles), no normals: Mitsuba (and
     raylab's importer) shade it with normals computed from its faces;
  1: a torus (radii 1 and 0.35, 32 x 12 quads), no normals: the scene shades it flat
     (`face_normals`);
  2: a square floor of side 2 with normals and texture coordinates, in double precision.

    python3 scripts/make_serialized.py
"""
import math
import pathlib
import struct
import zlib

OUT = pathlib.Path(__file__).resolve().parent.parent / "scenes/mitsuba/assets/meshes.serialized"

HAS_NORMALS, HAS_TEXCOORDS, SINGLE, DOUBLE = 0x0001, 0x0002, 0x1000, 0x2000


def icosphere(subdivisions):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        cache, faces = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
                n = math.sqrt(sum(x * x for x in p))
                v.append(tuple(x / n for x in p))
                cache[key] = len(v) - 1
            return cache[key]

        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = faces
    return v, f


def torus(big, small, nu, nv):
    v, f = [], []
    for i in range(nu):
        for j in range(nv):
            a, b = 2 * math.pi * i / nu, 2 * math.pi * j / nv
            r = big + small * math.cos(b)
            v.append((r * math.cos(a), small * math.sin(b), r * math.sin(a)))
    for i in range(nu):
        for j in range(nv):
            k = lambda di, dj: ((i + di) % nu) * nv + (j + dj) % nv
            # Wound so that the faces look outwards.
            f += [(k(0, 0), k(0, 1), k(1, 1)), (k(0, 0), k(1, 1), k(1, 0))]
    return v, f


def mesh(name, positions, faces, normals=None, uvs=None, double=False):
    flags = (DOUBLE if double else SINGLE) | (HAS_NORMALS if normals else 0) | (HAS_TEXCOORDS if uvs else 0)
    real = "<d" if double else "<f"
    body = struct.pack("<I", flags) + name.encode() + b"\0"
    body += struct.pack("<QQ", len(positions), len(faces))
    for block in (positions, normals or [], uvs or []):
        for p in block:
            body += b"".join(struct.pack(real, x) for x in p)
    for t in faces:
        body += struct.pack("<III", *t)
    return struct.pack("<HH", 0x041C, 4) + zlib.compress(body, 9)


def main():
    floor = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)]
    parts = [
        mesh("sphere", *icosphere(2)),
        mesh("torus", *torus(1.0, 0.35, 32, 12)),
        mesh("floor", floor, [(0, 2, 1), (0, 3, 2)], normals=[(0, 1, 0)] * 4,
             uvs=[(0, 0), (1, 0), (1, 1), (0, 1)], double=True),
    ]
    data, offsets = b"", []
    for p in parts:
        offsets.append(len(data))
        data += p
    data += b"".join(struct.pack("<Q", o) for o in offsets) + struct.pack("<I", len(parts))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_bytes(data)
    print(f"wrote {OUT} ({len(data)} bytes)")


if __name__ == "__main__":
    main()
