#!/usr/bin/env python3
"""Renders Mitsuba 3 XML scenes with Mitsuba 3 (PyPI, scalar_rgb; with --spectral its
scalar_spectral variant and raylab's --spectral) and with raylab at the same sample count and
filter, and says per scene whether the images agree, by Mitsuba's own
render-test method: a per-pixel z-test of the difference of the two means, at the
Sidak-corrected level for a 1% chance that any of the image's pixel channels fails by
chance; the scene passes when 99.75% of them pass.

Each renderer renders each scene RUNS times (seeds 1..RUNS) at SPP / RUNS samples per pixel;
the RUNS images give each pixel's mean (as one render at SPP) and the variance of that mean,
so both renderers' noise is measured the same way. A pixel channel whose two variances are
both 0 (a background both see exactly) passes when the means agree to 1e-5 of their value
(rounding). Also printed: the
image means and their ratio raylab / Mitsuba.

    pip install mitsuba numpy
    cargo build --release
    python3 scripts/mitsuba_crosscheck.py [SCENES or FOLDERS...] [--spp 256] [--runs 16]
        [--raylab target/release/raylab] [--out out/mitsuba-crosscheck] [-D NAME=VALUE ...]
        [--spectral]

Default: every .xml in scenes/mitsuba. Exit status 1 when a scene fails.
"""
import argparse
import math
import pathlib
import subprocess
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent


def read_exr(path):
    import mitsuba as mi

    return np.array(mi.Bitmap(str(path)), dtype=np.float64)[..., :3]


def mean_and_variance(images):
    """Per pixel: the mean of the runs and the variance of that mean."""
    stack = np.stack(images)
    return stack.mean(0), stack.var(0, ddof=1) / len(images)


def z_test(m1, v1, m2, v2, alpha=0.01):
    """Fraction of pixel channels that pass the Sidak-corrected z-test."""
    n = m1.size
    level = 1.0 - (1.0 - alpha) ** (1.0 / n)
    # Pixels both renderers see without noise (a constant sky, an emitter seen directly) differ
    # by rounding: a floor of 1e-5 of the value keeps that from failing them.
    var = v1 + v2 + (1e-5 * np.maximum(np.abs(m1), np.abs(m2))) ** 2
    diff = np.abs(m1 - m2)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(var > 0, diff / np.sqrt(var), np.where(diff == 0, 0.0, np.inf))
    p = np.vectorize(lambda x: math.erfc(x / math.sqrt(2.0)))(z)
    return float(np.mean(p > level)), level


def render_both(mi, exe, scene, out, slug, per_run, runs, defines, extra):
    """Both renderers' per-pixel means and variances of the mean over `runs` runs of `per_run`
    samples (seeds 1..runs), the scene's <default>s set by `defines`."""
    r_imgs, m_imgs = [], []
    mi_scene = mi.load_file(str(scene), **defines)
    flags = [f for name, value in defines.items() for f in ("-D", f"{name}={value}")]
    for k in range(1, runs + 1):
        exr = out / f"{slug}-raylab-{k}.exr"
        subprocess.run([str(exe), "render", str(scene), "--spp", str(per_run), "--seed", str(k),
                        "-o", str(exr), "-q", *flags, *extra], check=True, capture_output=True,
                       text=True)
        r_imgs.append(read_exr(exr))
        m_imgs.append(np.array(mi.render(mi_scene, spp=per_run, seed=k), dtype=np.float64)[..., :3])
    mr, vr = mean_and_variance(r_imgs)
    mm, vm = mean_and_variance(m_imgs)
    return mr, vr, mm, vm


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", help="XML scenes or folders of them (default scenes/mitsuba)")
    ap.add_argument("--spp", type=int, default=256, help="samples per pixel in all, per renderer (default 256)")
    ap.add_argument("--runs", type=int, default=16, help="independent runs per renderer (default 16)")
    ap.add_argument("--raylab", default="target/release/raylab", help="raylab binary")
    ap.add_argument("--spectral", action="store_true",
                    help="Mitsuba's scalar_spectral against raylab --spectral")
    ap.add_argument("--out", default="out/mitsuba-crosscheck", help="folder for the EXRs")
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                    help="a <default> parameter for both renderers (repeatable)")
    args = ap.parse_args()
    if args.runs < 2 or args.spp % args.runs:
        sys.exit("--spp must be a multiple of --runs, and --runs at least 2")

    import mitsuba as mi

    variant = "scalar_spectral" if args.spectral else "scalar_rgb"
    mi.set_variant(variant)
    extra = ["--spectral"] if args.spectral else []
    mi.set_log_level(mi.LogLevel.Warn)
    exe = pathlib.Path(args.raylab)
    exe = exe if exe.is_absolute() else ROOT / exe
    out = pathlib.Path(args.out)
    out = out if out.is_absolute() else ROOT / out
    out.mkdir(parents=True, exist_ok=True)
    scenes = []
    for s in args.scenes or [str(ROOT / "scenes" / "mitsuba")]:
        p = pathlib.Path(s)
        scenes += sorted(p.glob("*.xml")) if p.is_dir() else [p]
    per_run = args.spp // args.runs

    defines = dict(d.split("=", 1) for d in args.defines)
    rows, failed = [], False
    for scene in scenes:
        start = time.time()
        slug = scene.stem
        mr, vr, mm, vm = render_both(mi, exe, scene, out, slug, per_run, args.runs, defines,
                                     extra)
        mi.Bitmap(mm.astype(np.float32)).write(str(out / f"{slug}-mitsuba.exr"))
        mi.Bitmap(mr.astype(np.float32)).write(str(out / f"{slug}-raylab.exr"))
        passing, level = z_test(mr, vr, mm, vm)
        ok = passing >= 0.9975
        failed |= not ok
        rows.append((scene.name, mr.mean(), mm.mean(), mr.mean() / mm.mean(), passing, ok))
        print(f"{scene.name}: {passing:.4%} of pixel channels pass ({time.time() - start:.0f} s)",
              file=sys.stderr, flush=True)

    print(f"\n{args.spp} spp per renderer ({args.runs} runs of {per_run}), Mitsuba 3 {variant};"
          f" per-pixel z-test at the Sidak-corrected level of 1%, pass at 99.75% of pixel channels\n")
    print("| scene | raylab mean | Mitsuba mean | ratio | pixel channels passing | verdict |")
    print("|---|---|---|---|---|---|")
    for name, r, m, ratio, passing, ok in rows:
        print(f"| {name} | {r:.5f} | {m:.5f} | {ratio:.5f} | {passing:.2%} | {'agrees' if ok else 'DIFFERS'} |")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
