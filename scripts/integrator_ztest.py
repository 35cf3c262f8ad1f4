#!/usr/bin/env python3
"""Says whether two of raylab's integrators render the same images, scene by scene, by the
per-pixel z-test `scripts/mitsuba_crosscheck.py` uses (Mitsuba 3's render-test method): each
integrator renders each scene RUNS times (seeds 1..RUNS) at SPP / RUNS samples per pixel; the
runs give each pixel's mean and the variance of that mean; a pixel channel fails when the two
means differ at the Sidak-corrected level for a 1% chance that any channel of the image fails
by chance; a scene passes when 99.75% of its channels pass.

Made for `path-wavefront` against `path` (#52): two estimators of the same integral must
agree on every scene they both render. Scenes that the integrators refuse (media for the
surface tracers) are listed as refused.

    pip install mitsuba numpy          # mitsuba only reads the EXRs
    cargo build --release
    python3 scripts/integrator_ztest.py [SCENES...] [--a path] [--b path-wavefront]
        [--spp 256] [--runs 8] [--size 96x72] [-p NAME=VALUE ...] [--spectral]

Default scenes: every scenes/*.ron but the suite, and scenes/mitsuba/*.xml. Exit status 1
when a scene differs.
"""
import argparse
import pathlib
import subprocess
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
from mitsuba_crosscheck import mean_and_variance, read_exr, z_test  # noqa: E402


def renders(exe, scene, integrator, params, args, out):
    """The integrator's per-pixel means and variances of the mean, and the parameters it ran
    with (as its summary line prints them: the scene's own where it is the scene's
    integrator); or None and the reason it refused the scene."""
    images, settings = [], []
    per_run = args.spp // args.runs
    for k in range(1, args.runs + 1):
        exr = out / f"{scene.stem}-{integrator}-{k}.exr"
        cmd = [str(exe), "render", str(scene), "-i", integrator, "--spp", str(per_run),
               "--seed", str(k), "--size", args.size, "-o", str(exr), "--threads", "2"]
        cmd += [f for p in params for f in ("-p", p)]
        cmd += ["--spectral"] if args.spectral else []
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode == 2:
            return None, r.stderr.strip().splitlines()[-1]
        r.check_returncode()
        images.append(read_exr(exr))
        summary = r.stderr.strip().splitlines()[-1]
        settings = summary.split(f": {integrator} ", 1)[1].split(" |", 1)[0].split()
    return mean_and_variance(images), settings


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--a", default="path")
    ap.add_argument("--b", default="path-wavefront")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--size", default="96x72")
    ap.add_argument("-p", dest="params", action="append", default=[], metavar="NAME=VALUE",
                    help="a parameter for both integrators (repeatable)")
    ap.add_argument("--spectral", action="store_true")
    ap.add_argument("--raylab", default="target/release/raylab")
    ap.add_argument("--out", default="out/integrator-ztest")
    args = ap.parse_args()
    if args.runs < 2 or args.spp % args.runs:
        sys.exit("--spp must be a multiple of --runs, and --runs at least 2")
    exe = ROOT / args.raylab if not pathlib.Path(args.raylab).is_absolute() else pathlib.Path(args.raylab)
    out = ROOT / args.out
    out.mkdir(parents=True, exist_ok=True)
    scenes = [pathlib.Path(s) for s in args.scenes]
    if not scenes:
        scenes = sorted(p for p in (ROOT / "scenes").glob("*.ron") if p.name != "suite.ron")
        scenes += sorted((ROOT / "scenes" / "mitsuba").glob("*.xml"))
    rows, failed = [], False
    for scene in scenes:
        start = time.time()
        (ra, why) = renders(exe, scene, args.a, args.params, args, out)
        if ra is None:
            rows.append((scene.name, None, None, None, f"refused: {why}"))
            continue
        # The second integrator runs with the first one's settings.
        (rb, why) = renders(exe, scene, args.b, why, args, out)
        if rb is None:
            rows.append((scene.name, None, None, None, f"{args.b} refused: {why}"))
            failed = True
            continue
        (ma, va), (mb, vb) = ra, rb
        passing, _ = z_test(ma, va, mb, vb)
        ok = passing >= 0.9975
        failed |= not ok
        rows.append((scene.name, ma.mean(), mb.mean(), passing, "agrees" if ok else "DIFFERS"))
        print(f"{scene.name}: {passing:.4%} ({time.time() - start:.0f} s)", file=sys.stderr,
              flush=True)
    print(f"\n`{args.a}` against `{args.b}`, {args.size}, {args.spp} spp each ({args.runs} runs);"
          f" per-pixel z-test at the Sidak-corrected level of 1%, pass at 99.75% of channels\n")
    print(f"| scene | {args.a} mean | {args.b} mean | pixel channels passing | verdict |")
    print("|---|---|---|---|---|")
    for name, a, b, passing, verdict in rows:
        if a is None:
            print(f"| {name} | | | | {verdict} |")
        else:
            print(f"| {name} | {a:.5f} | {b:.5f} | {passing:.2%} | {verdict} |")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
