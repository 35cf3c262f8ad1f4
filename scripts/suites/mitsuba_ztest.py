#!/usr/bin/env python3
"""Mitsuba 3's render tests, run on raylab: every scene of mitsuba-data's `tests/scenes/*/`
that has a reference (`refs/<name>_ref_rgb.exr`, or with `--spectral` the spectral variant's
`refs/<name>_ref_spectral.exr`) and a variance image (`..._var.exr`) is
rendered by raylab from its own XML, and judged by the test Mitsuba applies to itself
(`src/render/tests/test_renders.py`):

- the sample budget is 2e6 samples per image: spp = 2,000,000 // (width * height), passed as
  the scene's `spp` parameter (`-D spp=N`), the integrator as `-D integrator=TYPE` (the
  suffix of the file name, as Mitsuba's harness does);
- images compared in CIE XYZ; the reference's per-sample variance floored at 1e-4;
- z = |mean - reference| * sqrt(spp / variance), p = 2 (1 - Phi(z)) per pixel channel;
- alpha = 1 - (1 - 0.01)^(1 / pixels) (Sidak);
- the scene passes when the channels with p > alpha, divided by 3, are at least 99.75% of
  the pixels.

A scene raylab refuses is listed with the first line it said. Prints a Markdown table
(scene, verdict, pixels passing, means) and exits 1 when a scene that loads fails.

    python3 -m venv venv && venv/bin/pip install mitsuba numpy   # reads the EXRs
    venv/bin/python scripts/suites/mitsuba_ztest.py MITSUBA_DATA [--raylab BIN]
        [--only SUBSTRING] [--out DIR] [--spectral] [-- EXTRA RAYLAB OPTIONS]

MITSUBA_DATA is a checkout of github.com/mitsuba-renderer/mitsuba-data (its `common/` is the
search folder, `-a`, as Mitsuba's resolver has it; the scenes may read files anywhere in it:
`--allow-path`).
"""
import argparse
import math
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent.parent
SAMPLE_BUDGET = 2_000_000
SIGNIFICANCE = 0.01
PASS_SHARE = 0.9975


def read_xyz(path):
    """The image's RGB as XYZ, the conversion Mitsuba's harness makes (linear sRGB primaries)."""
    import mitsuba as mi

    bmp = mi.Bitmap(str(path))
    names = [bmp.struct_()[i].name for i in range(bmp.channel_count())]
    rgb = np.array(bmp, dtype=np.float64).reshape(bmp.height(), bmp.width(), -1)
    rgb = rgb[..., [names.index(c) for c in ("R", "G", "B")]]
    m = np.array(
        [
            [0.412453, 0.357580, 0.180423],
            [0.212671, 0.715160, 0.072169],
            [0.019334, 0.119193, 0.950227],
        ]
    )
    return rgb @ m.T


def stdnormal_cdf(x):
    erf = np.vectorize(math.erf)
    return 0.5 * (1.0 + erf(x / math.sqrt(2.0)))


def z_test(img, spp, ref, ref_var):
    ref_var = np.maximum(ref_var, 1e-4)
    z = np.abs(img - ref) * np.sqrt(spp / ref_var)
    return 2.0 * (1.0 - stdnormal_cdf(z))


def scenes(data):
    # As Mitsuba's harness: tests/scenes/*/*.xml
    return sorted((data / "tests" / "scenes").glob("*/*.xml"))


def refs_of(scene, variant="rgb"):
    stem = scene.stem.rsplit("_", 1)[0]
    ref = scene.parent / "refs" / f"{stem}_ref_{variant}.exr"
    return ref, ref.with_name(ref.stem + "_var.exr")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data", type=pathlib.Path)
    ap.add_argument("--raylab", default=str(ROOT / "target" / "release" / "raylab"))
    ap.add_argument("--only", default="", help="only scenes whose path contains this")
    ap.add_argument("--out", type=pathlib.Path, help="keep raylab's images here")
    ap.add_argument("--spectral", action="store_true",
                    help="render with --spectral, against the spectral references")
    ap.add_argument("--spp-factor", type=float, default=1.0,
                    help="render this many times the test's samples (the z-test keeps the "
                         "test's count): a diagnostic that tells variance from bias")
    ap.add_argument("extra", nargs="*", help="more raylab options (after --)")
    args = ap.parse_args()
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    out = args.out or pathlib.Path(tempfile.mkdtemp())
    out.mkdir(parents=True, exist_ok=True)
    print("| scene | verdict | pixels passing | mean Y raylab / Mitsuba | min p |")
    print("|---|---|---|---|---|")
    counts = {"pass": 0, "FAIL": 0, "does not load": 0, "no reference": 0}
    for scene in scenes(args.data):
        name = scene.relative_to(args.data / "tests" / "scenes")
        if args.only not in str(name):
            continue
        ref_path, var_path = refs_of(scene, "spectral" if args.spectral else "rgb")
        if not (ref_path.exists() and var_path.exists()):
            counts["no reference"] += 1
            print(f"| {name} | no reference | | | |")
            continue
        ref = read_xyz(ref_path)
        ref_var = read_xyz(var_path)
        pixels = ref.shape[0] * ref.shape[1]
        spp = SAMPLE_BUDGET // pixels
        integrator = scene.stem.rsplit("_", 1)[-1]
        image = out / (str(name).replace("/", "__") + ".exr")
        # The scenes read files across the repository (tests/obj, docs/scenes/sdfgrid).
        cmd = [args.raylab, "render", str(scene), "-a", str(args.data / "common"),
               "--allow-path", str(args.data),
               "-D", f"spp={spp}", "-D", f"integrator={integrator}",
               "--spp", str(max(1, round(spp * args.spp_factor))),
               "-o", str(image), *(["--spectral"] if args.spectral else []), *args.extra]
        run = subprocess.run(cmd, capture_output=True, text=True)
        if run.returncode != 0:
            counts["does not load"] += 1
            said = next((l for l in run.stderr.splitlines() if l.strip()), "")
            said = said.replace(str(args.data) + "/", "").replace("|", "/")[:160]
            print(f"| {name} | does not load | | | {said} |")
            continue
        img = read_xyz(image)
        if img.shape != ref.shape:
            counts["FAIL"] += 1
            print(f"| {name} | FAIL (size {img.shape[:2]} vs {ref.shape[:2]}) | | | |")
            continue
        p = z_test(img, spp, ref, ref_var)
        alpha = 1.0 - (1.0 - SIGNIFICANCE) ** (1.0 / pixels)
        passing = np.count_nonzero(p > alpha) / 3
        ok = passing >= PASS_SHARE * pixels
        counts["pass" if ok else "FAIL"] += 1
        ratio = img[..., 1].mean() / max(ref[..., 1].mean(), 1e-30)
        print(f"| {name} | {'pass' if ok else 'FAIL'} | {passing / pixels:.2%} "
              f"| {ratio:.4f} | {p.min():.1e} |", flush=True)
    print()
    print(", ".join(f"{v} {k}" for k, v in counts.items()))
    sys.exit(1 if counts["FAIL"] else 0)


if __name__ == "__main__":
    main()
