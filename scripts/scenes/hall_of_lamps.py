#!/usr/bin/env python3
"""Writes scenes/hall_of_lamps.ron: a long hall lit by 304 small lamps, the scene where the
choice of light selection matters (uniform, power, a light BVH).

Deterministic: the lamps' colours and powers come from a fixed hash of their place, so the
file is the same every run. Run from the repository root:

    python3 scripts/scenes/hall_of_lamps.py > scenes/hall_of_lamps.ron
"""


def hash01(*k):
    """A number in [0, 1) from integers, by a fixed 32-bit mix."""
    h = 0x9E3779B9
    for v in k:
        h = (h ^ (v & 0xFFFFFFFF)) * 0x85EBCA6B & 0xFFFFFFFF
        h ^= h >> 13
        h = h * 0xC2B2AE35 & 0xFFFFFFFF
        h ^= h >> 16
    return h / 2**32


# Warm and cool lamp colours (relative radiance per channel).
PALETTE = [(1.0, 0.72, 0.42), (1.0, 0.86, 0.66), (0.62, 0.78, 1.0), (1.0, 0.55, 0.3), (0.8, 1.0, 0.7)]


def colour(scale, *k):
    c = PALETTE[int(hash01(*k, 1) * len(PALETTE))]
    return "(%s)" % ", ".join("%.4g" % (scale * x) for x in c)


def quad(a, b, c, d):
    return "Quad(vertices: [%s])" % ", ".join("(%g, %g, %g)" % p for p in (a, b, c, d))


def main():
    out = []
    w = out.append
    w("// A hall 12 wide, 6 high and 42 deep, lit by 304 small lamps: 120 glowing globes hung in")
    w("// three rows, 160 sconces on the walls (small one-sided quads facing in) and 24 floor")
    w("// lights along the aisle, of five colours and powers spread over two orders of")
    w("// magnitude. Most lamps are far from most points and many face away from them: the")
    w("// scene where picking a light uniformly, by power or by a light BVH differs. Written by")
    w("// scripts/scenes/hall_of_lamps.py. y is up; the camera looks down -z.")
    w("(")
    w("    camera: LookAt(eye: (0.8, 1.7, 1.5), look_at: (-0.4, 2.2, -20), up: (0, 1, 0), fov: 55, resolution: (320, 200)),")
    w('    render: (integrator: "path", spp: 64, seed: 0, params: {"max-depth": 6}),')
    w("    materials: {")
    w('        "floor": Lambert(albedo: (0.45, 0.42, 0.38)),')
    w('        "wall": Lambert(albedo: (0.7, 0.68, 0.62)),')
    w('        "ceiling": Lambert(albedo: (0.3, 0.3, 0.32)),')
    w('        "stone": Lambert(albedo: (0.55, 0.52, 0.5)),')
    w('        "brass": RoughConductor(metal: "Au", distribution: "ggx", alpha: 0.25),')
    w('        "lamp": Lambert(albedo: (0, 0, 0)),')
    w("    },")
    w("    entities: [")
    x0, x1, z0, z1, h = -6, 6, -40, 2, 6
    w('        (name: "floor", shape: %s, material: "floor"),' % quad((x0, 0, z1), (x1, 0, z1), (x1, 0, z0), (x0, 0, z0)))
    w('        (name: "ceiling", shape: %s, material: "ceiling"),' % quad((x0, h, z0), (x1, h, z0), (x1, h, z1), (x0, h, z1)))
    w('        (name: "back wall", shape: %s, material: "wall"),' % quad((x0, 0, z0), (x1, 0, z0), (x1, h, z0), (x0, h, z0)))
    w('        (name: "left wall", shape: %s, material: "wall"),' % quad((x0, 0, z1), (x0, 0, z0), (x0, h, z0), (x0, h, z1)))
    w('        (name: "right wall", shape: %s, material: "wall"),' % quad((x1, 0, z0), (x1, 0, z1), (x1, h, z1), (x1, h, z0)))
    # Pillars every 4 units on both sides of the aisle, and a brass ball beside every other.
    for i, z in enumerate(range(-36, 0, 4)):
        for side, x in (("left", -2.6), ("right", 2.6)):
            w('        (name: "%s pillar %d", shape: Box(min: (%g, 0, %g), max: (%g, %g, %g)), material: "stone"),'
              % (side, i, x - 0.25, z - 0.25, x + 0.25, h, z + 0.25))
        if i % 2 == 0:
            w('        (name: "ball %d", shape: Sphere(center: (%g, 0.45, %g), radius: 0.45), material: "brass"),'
              % (i, -1.4 if i % 4 == 0 else 1.4, z - 2))
    # Globes: three rows, 40 deep, hung at heights between 3.6 and 4.6.
    n = 0
    for row, x in enumerate((-4.2, 0.0, 4.2)):
        for k in range(40):
            z = -39 + k
            y = 3.6 + hash01(row, k, 2)
            scale = 8 * 10 ** (2 * hash01(row, k, 3) - 1)
            w('        (name: "globe %d", shape: Sphere(center: (%g, %.3f, %g), radius: 0.07), material: "lamp", emitter: Area(radiance: %s)),'
              % (n, x, y, z, colour(scale, row, k)))
            n += 1
    # Sconces: small quads on both walls at two heights, facing into the hall.
    for side, x, dx in (("left", x0 + 0.02, 1), ("right", x1 - 0.02, -1)):
        for level, y in enumerate((1.6, 2.9)):
            for k in range(40):
                z = -39.5 + k
                s = 0.09
                scale = 5 * 10 ** (2 * hash01(level, k, dx + 5) - 1)
                if dx > 0:
                    q = quad((x, y - s, z + s), (x, y - s, z - s), (x, y + s, z - s), (x, y + s, z + s))
                else:
                    q = quad((x, y - s, z - s), (x, y - s, z + s), (x, y + s, z + s), (x, y + s, z - s))
                w('        (name: "%s sconce %d-%d", shape: %s, material: "lamp", emitter: Area(radiance: %s)),'
                  % (side, level, k, q, colour(scale, level, k, dx + 9)))
    # Floor lights along the aisle, facing up.
    for k in range(24):
        z = -38 + 1.5 * k
        for x in (-0.9, 0.9):
            if (k + (x > 0)) % 2:
                continue
            s = 0.06
            q = quad((x - s, 0.01, z + s), (x + s, 0.01, z + s), (x + s, 0.01, z - s), (x - s, 0.01, z - s))
            w('        (name: "floor light %d", shape: %s, material: "lamp", emitter: Area(radiance: %s)),'
              % (k, q, colour(20, k, 7)))
    w("    ],")
    w(")")
    print("\n".join(out))


if __name__ == "__main__":
    main()
