#!/usr/bin/env python3
"""Veach's MIS figure (thesis, fig. 9.2) from scenes/mitsuba/veach_mis.xml, rendered by
raylab's `direct` and Mitsuba 3's `direct` (scalar_rgb) with light sampling alone, BSDF sampling
alone and both combined by MIS, at the same samples per pixel: raylab's row above Mitsuba's,
written to docs/images/veach_mis.png. Each image is one run (seed 1) of --spp samples; the
two renderers' agreement per strategy is Mitsuba's render test (scripts/mitsuba_crosscheck.py)
over --runs runs, printed as a table.

    pip install mitsuba numpy
    cargo build --release
    python3 scripts/veach_mis_figure.py [--spp 8] [--runs 96] [--out docs/images/veach_mis.png]
"""
import argparse
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from mitsuba_crosscheck import ROOT, render_both, z_test  # noqa: E402

STRATEGIES = [
    ("light sampling", {"emitter_samples": "1", "bsdf_samples": "0"}),
    ("BSDF sampling", {"emitter_samples": "0", "bsdf_samples": "1"}),
    ("MIS (power heuristic)", {"emitter_samples": "1", "bsdf_samples": "1"}),
]


def srgb(img):
    c = np.clip(img, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", type=int, default=8, help="samples per pixel of each image (default 8)")
    ap.add_argument("--runs", type=int, default=96, help="runs for the render test (default 96)")
    ap.add_argument("--raylab", default="target/release/raylab")
    ap.add_argument("--out", default="docs/images/veach_mis.png")
    args = ap.parse_args()

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    mi.set_log_level(mi.LogLevel.Warn)
    scene = ROOT / "scenes" / "mitsuba" / "veach_mis.xml"
    exe = ROOT / args.raylab
    work = ROOT / "out" / "veach-mis"
    work.mkdir(parents=True, exist_ok=True)
    rows, tiles = [], [[], []]
    for name, defines in STRATEGIES:
        slug = "veach-" + defines["emitter_samples"] + defines["bsdf_samples"]
        mr, vr, mm, vm = render_both(mi, exe, scene, work, slug, args.spp, args.runs, defines)
        # The pictures: each renderer's first run (seed 1).
        first_r = np.array(mi.Bitmap(str(work / f"{slug}-raylab-1.exr")), dtype=np.float64)[..., :3]
        first_m = np.array(mi.render(mi.load_file(str(scene), **defines), spp=args.spp, seed=1),
                           dtype=np.float64)[..., :3]
        tiles[0].append(first_r)
        tiles[1].append(first_m)
        passing, _ = z_test(mr, vr, mm, vm)
        # The image means' difference in their standard errors (pixels independent).
        z = (mr.mean() - mm.mean()) / np.sqrt((vr.sum() + vm.sum()) / mr.size**2)
        rows.append((name, mr.mean(), mm.mean(), z, passing))
        print(f"{name}: {passing:.4%} of pixel channels pass", file=sys.stderr, flush=True)
    gap = 4
    h, w, _ = tiles[0][0].shape
    canvas = np.ones((2 * h + gap, 3 * w + 2 * gap, 3))
    for r in range(2):
        for c in range(3):
            canvas[r * (h + gap):r * (h + gap) + h, c * (w + gap):c * (w + gap) + w] = srgb(tiles[r][c])
    out = ROOT / args.out
    mi.util.write_bitmap(str(out), (canvas * 255 + 0.5).astype(np.uint8), write_async=False)
    print(f"\n{args.spp} spp per image; render test over {args.runs} runs of {args.spp}\n")
    print("| strategy | raylab mean | Mitsuba 3.9.1 mean | ratio | z of the means | pixel channels passing |")
    print("|---|---|---|---|---|---|")
    for name, r, m, z, passing in rows:
        print(f"| {name} | {r:.5f} | {m:.5f} | {r / m:.5f} | {z:+.2f} | {passing:.2%} |")
    print(f"\nwrote {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
