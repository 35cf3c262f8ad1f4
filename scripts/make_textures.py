#!/usr/bin/env python3
"""Writes the textures of scenes/textures.ron (no dependencies beyond the standard library):

* scenes/assets/tiles.png      256 x 256 sRGB colour: warm tiles with dark grout
* scenes/assets/bumps.png      256 x 256 grey height field (raw): round bumps on a grid
* scenes/assets/bumps_normal.png  the normal map of the same height field (raw, tangent space)
* scenes/assets/roughness.png  256 x 256 grey roughness (raw): stripes from 0.05 to 0.5

Run from the repository root: python3 scripts/make_textures.py
"""
import math
import struct
import zlib

N = 256


def write_png(path, width, height, rows):
    """rows: list of bytes objects, each width*3 RGB bytes."""
    raw = b"".join(b"\x00" + r for r in rows)
    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    png = b"\x89PNG\r\n\x1a\n"
    png += chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9))
    png += chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def byte(x):
    return max(0, min(255, int(round(x * 255))))


def height(x, y):
    """Round bumps, 8 per side, 0 between them and 1 at their centres."""
    cells = 8
    u, v = (x + 0.5) / N * cells, (y + 0.5) / N * cells
    du, dv = u - math.floor(u) - 0.5, v - math.floor(v) - 0.5
    r = math.sqrt(du * du + dv * dv) / 0.4
    return math.cos(r * math.pi / 2) ** 2 if r < 1 else 0.0


tiles = []
for y in range(N):
    row = bytearray()
    for x in range(N):
        grout = (x % 64) < 4 or (y % 64) < 4
        k = (x // 64 + y // 64) % 2
        rgb = (0.15, 0.13, 0.12) if grout else ((0.85, 0.55, 0.3) if k == 0 else (0.7, 0.72, 0.75))
        row += bytes(byte(c) for c in rgb)
    tiles.append(bytes(row))
write_png("scenes/assets/tiles.png", N, N, tiles)

heights = [[height(x, y) for x in range(N)] for y in range(N)]
write_png("scenes/assets/bumps.png", N, N,
          [bytes(byte(h) for h in heights[y] for _ in range(3)) for y in range(N)])

# Normal map of the height field scaled to 0.02 of the texture's width, by central
# differences (u along x, v down the image): n = (-dh/du, -dh/dv, 1), stored as (n + 1) / 2.
amp = 0.02 * N
normal_rows = []
for y in range(N):
    row = bytearray()
    for x in range(N):
        dhdx = (heights[y][(x + 1) % N] - heights[y][(x - 1) % N]) / 2 * amp
        dhdy = (heights[(y + 1) % N][x] - heights[(y - 1) % N][x]) / 2 * amp
        n = (-dhdx, -dhdy, 1.0)
        length = math.sqrt(sum(c * c for c in n))
        row += bytes(byte((c / length + 1) / 2) for c in n)
    normal_rows.append(bytes(row))
write_png("scenes/assets/bumps_normal.png", N, N, normal_rows)

rough = []
for y in range(N):
    a = 0.05 + 0.45 * ((y // 32) / 7)
    rough.append(bytes(byte(a) for _ in range(N * 3)))
write_png("scenes/assets/roughness.png", N, N, rough)
