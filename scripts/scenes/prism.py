#!/usr/bin/env python3
"""Writes scenes/prism.ron: a narrow beam of white light through a 60-degree prism of SF11
glass (a dense flint), split into a spectrum on a white wall. The prism stands at its
minimum deviation for 550 nm; the wall faces the exit beam 1.5 m away; the camera looks at
the wall from beside the beam. In RGB mode the wall shows one white spot; with --spectral,
a rainbow (the prism's dispersion: Schott's Sellmeier coefficients).

    python3 scripts/scenes/prism.py > scenes/prism.ron
"""
import math

# SF11 (Schott): Sellmeier B and C (um^2).
B = (1.73759695, 0.313747346, 1.89878101)
C = (0.013188707, 0.0623068142, 155.23629)


def n(nm):
    l2 = (nm * 1e-3) ** 2
    return math.sqrt(1 + sum(b * l2 / (l2 - c) for b, c in zip(B, C)))


APEX = math.radians(60)
N0 = n(550)
# Minimum deviation: the ray inside runs parallel to the base.
INCIDENCE = math.asin(N0 * math.sin(APEX / 2))
DEVIATION = 2 * INCIDENCE - APEX

SIDE = 0.3  # the triangle's side, m
HEIGHT = 0.3  # the prism's height, m
BEAM_Y = 0.15


def rot(angle):
    """The unit vector at `angle` from +x towards +z (radians)."""
    return (math.cos(angle), math.sin(angle))


def add(a, b, s=1.0):
    return (a[0] + s * b[0], a[1] + s * b[1])


# The beam travels along +x; it bends towards -z.
inside = rot(-(INCIDENCE - APEX / 2))
out = rot(-DEVIATION)
normal = (-inside[1], inside[0])  # the base's normal, towards the apex
centre = (0.0, 0.0)
b1 = add(centre, inside, -SIDE / 2)
b2 = add(centre, inside, SIDE / 2)
apex = add(centre, normal, SIDE * math.sqrt(3) / 2)
m1 = ((b1[0] + apex[0]) / 2, (b1[1] + apex[1]) / 2)  # where the beam enters
m2 = ((b2[0] + apex[0]) / 2, (b2[1] + apex[1]) / 2)  # and leaves
lamp = add(m1, (1.0, 0.0), -1.0)
wall = add(m2, out, 1.5)
side = (-out[1], out[0])  # across the wall, horizontal


def v(p, y):
    return f"({p[0]:.6f}, {y:.6f}, {p[1]:.6f})"


def main():
    w, h = 0.5, 0.35
    corners = [add(wall, side, -w / 2), add(wall, side, w / 2)]
    eye = add(add(wall, out, -1.0), side, 0.25)
    print(f"""// A narrow beam of white light through a 60-degree prism of SF11 glass (Schott's
// Sellmeier coefficients), split into a spectrum on a white wall 1.5 m away: the scene of
// dispersion (written by scripts/scenes/prism.py). The prism stands at its minimum
// deviation for 550 nm ({math.degrees(DEVIATION):.1f} degrees; n = {N0:.4f}). RGB rendering
// keeps the index at 587.6 nm for every colour and shows one white spot; `--spectral`
// bends each wavelength its own way and shows the rainbow. The beam is a spot light of 0.25
// degrees: only light paths find it through the glass (lighttracer, bdpt, photons).
// y is up; metres.
(
    camera: LookAt(eye: {v(eye, 0.25)}, look_at: {v(wall, BEAM_Y)}, up: (0, 1, 0), fov: 24, resolution: (320, 180)),
    render: (integrator: "lighttracer", spp: 64, params: {{"max-depth": 8}}),
    materials: {{
        "sf11": Dielectric(int_ior: {n(587.56):.4f}, ext_ior: 1.0, dispersion: Glass("SF11")),
        "wall": Lambert(albedo: (0.8, 0.8, 0.8)),
        "floor": Lambert(albedo: (0.3, 0.3, 0.3)),
    }},
    entities: [
        (name: "wall", shape: Quad(vertices: [{v(corners[0], 0.0)}, {v(corners[1], 0.0)}, {v(corners[1], h)}, {v(corners[0], h)}]), material: "wall"),
        (name: "floor", shape: Quad(vertices: [(-2, 0, -3), (-2, 0, 2), (3, 0, 2), (3, 0, -3)]), material: "floor"),
        // The prism: its two triangular ends and three rectangular faces, facing out.
        (name: "prism bottom", shape: Triangle(vertices: [{v(b1, 0.0)}, {v(b2, 0.0)}, {v(apex, 0.0)}]), material: "sf11"),
        (name: "prism top", shape: Triangle(vertices: [{v(b1, HEIGHT)}, {v(apex, HEIGHT)}, {v(b2, HEIGHT)}]), material: "sf11"),
        (name: "prism entry", shape: Quad(vertices: [{v(b1, 0.0)}, {v(apex, 0.0)}, {v(apex, HEIGHT)}, {v(b1, HEIGHT)}]), material: "sf11"),
        (name: "prism exit", shape: Quad(vertices: [{v(apex, 0.0)}, {v(b2, 0.0)}, {v(b2, HEIGHT)}, {v(apex, HEIGHT)}]), material: "sf11"),
        (name: "prism base", shape: Quad(vertices: [{v(b2, 0.0)}, {v(b1, 0.0)}, {v(b1, HEIGHT)}, {v(b2, HEIGHT)}]), material: "sf11"),
        (
            name: "beam",
            transform: (translate: {v(lamp, BEAM_Y)}),
            emitter: Spot(intensity: (400, 400, 400), look_at: {v(m1, BEAM_Y)}, cutoff_angle: 0.25),
        ),
    ],
)""")


if __name__ == "__main__":
    main()
