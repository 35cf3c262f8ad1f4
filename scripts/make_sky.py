#!/usr/bin/env python3
"""Writes scenes/assets/sky.hdr: a small procedural latitude-longitude sky (Radiance HDR, flat
scanlines) for the scenes that use an environment map. Pure Python, no dependencies; raylab's
repository holds its output, and this script says how it was made.

The map follows Mitsuba 3's convention (+y up, the top row straight up, u = 0 at -z): a blue
sky brightening towards the horizon, a grey-brown ground, and a sun 30 degrees above the
horizon towards +x (u = 0.25), about 2 degrees across.

    python3 scripts/make_sky.py [OUT] [WIDTHxHEIGHT]

The size defaults to the repository's 128x64; a larger one (2048x1024, the size of the field's
skies) measures what sampling a big map costs (docs/performance.md).
"""
import math
import sys

W, H = 128, 64
SUN_ELEVATION, SUN_AZIMUTH_U, SUN_RADIUS = math.radians(30), 0.25, math.radians(1.0)


def direction(u, v):
    theta, phi = math.pi * v, 2 * math.pi * u
    return (math.sin(theta) * math.sin(phi), math.cos(theta), -math.sin(theta) * math.cos(phi))


def radiance(x, y):
    u, v = (x + 0.5) / W, y / (H - 1)
    d = direction(u, v)
    up = d[1]
    if up < 0:
        return (0.18, 0.15, 0.12)
    t = 1 - up
    sky = (0.25 + 0.55 * t ** 3, 0.45 + 0.45 * t ** 3, 0.95 + 0.05 * t ** 3)
    sun = direction(SUN_AZIMUTH_U - 0.5 / W, 0.5 - SUN_ELEVATION / math.pi)
    cos = sum(a * b for a, b in zip(d, sun))
    if cos > math.cos(3 * SUN_RADIUS):
        return (300.0, 280.0, 240.0)
    return sky


def rgbe(r, g, b):
    m = max(r, g, b)
    if m < 1e-32:
        return bytes(4)
    e = math.frexp(m)[1]
    s = 256.0 / 2 ** e
    return bytes([int(r * s), int(g * s), int(b * s), e + 128])


def main():
    global W, H
    out = sys.argv[1] if len(sys.argv) > 1 else "scenes/assets/sky.hdr"
    if len(sys.argv) > 2:
        try:
            W, H = (int(v) for v in sys.argv[2].split("x"))
        except ValueError:
            sys.exit(f"size must be WIDTHxHEIGHT, got {sys.argv[2]!r}")
        if W < 2 or H < 2:
            sys.exit(f"the sky needs at least 2x2 texels, got {W}x{H}")
    with open(out, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(f"-Y {H} +X {W}\n".encode())
        for y in range(H):
            f.write(b"".join(rgbe(*radiance(x, y)) for x in range(W)))


if __name__ == "__main__":
    main()
