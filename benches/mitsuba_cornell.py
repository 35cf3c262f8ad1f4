#!/usr/bin/env python3
"""raylab `path` against Mitsuba 3 on the Cornell box and two scenes of the field's materials:
samples per second, their ratio, and the two images' mean values (which must agree within
noise).

Scenes (`--scenes`, default the first three):
- `cornell`: Mitsuba renders its built-in `cornell_box()` (box filter, max_depth 8, rr_depth
  5: its `path` defaults); raylab renders scenes/cornell_box.ron (the same box);
- `textured_glossy`, `environment`: scenes/mitsuba/textured_glossy.xml (image textures, rough
  plastic and rough conductors under an area light) and scenes/mitsuba/environment.xml
  (glossy and diffuse objects under an environment map), the same XML file in both;
- `environment_2k` (only when asked for): the environment scene with its sky made at
  2048x1024, the size of the field's skies, in out/bench-sky/.

raylab renders with max-depth 7 and rr-depth 5, Mitsuba's settings in raylab's convention. Mitsuba's max_depth counts path
segments (one more than raylab's scattering events); its rr_depth, like raylab's rr-depth,
counts the scattering events after which Russian roulette may end a path (its path.cpp adds
one to the depth after each BSDF sample, then tests depth >= rr_depth). Russian roulette
decides how many bounces a sample costs, so it must match for samples per second to compare:
raylab's own default, rr-depth 3, would end paths two bounces earlier. Both at the scene's
resolution (the Cornell box 256x256, the others 256x192) on the threads the machine has.

    pip install mitsuba numpy
    apt-get install libllvm19          # for llvm_ad_rgb (libLLVM 15 crashes it)
    cargo build --release
    python3 benches/mitsuba_cornell.py [--spp 256] [--variants scalar_rgb,llvm_ad_rgb] [--repeat 2]
        [--scenes cornell,textured_glossy,environment]   # also environment_2k: a 2048x1024 sky
        [--raylab OLD_BINARY,target/release/raylab]   # several binaries: each measured in turn
        [--integrators path,path-wavefront]           # several integrators: each measured in turn

Each round measures, scene by scene, raylab, then every variant, then raylab again, so that the ratios compare
renders made minutes apart on the same (shared, noisy) machine. llvm_ad_rgb needs
DRJIT_LIBLLVM_PATH pointing at libLLVM-19.so; the script sets it when Debian's file exists.
"""
import argparse
import os
import pathlib
import re
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
DEBIAN_LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
# Mitsuba's settings, and raylab's for the same paths (see the docstring).
MAX_DEPTH, RR_DEPTH = 8, 5
RAYLAB_PARAMS = ["-p", f"max-depth={MAX_DEPTH - 1}", "-p", f"rr-depth={RR_DEPTH}"]
if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(DEBIAN_LLVM):
    os.environ["DRJIT_LIBLLVM_PATH"] = DEBIAN_LLVM


# Each scene: the file raylab renders, and the XML file Mitsuba loads (None: its Cornell box).
SCENES = {
    "cornell": ("scenes/cornell_box.ron", None),
    "textured_glossy": ("scenes/mitsuba/textured_glossy.xml", "scenes/mitsuba/textured_glossy.xml"),
    "environment": ("scenes/mitsuba/environment.xml", "scenes/mitsuba/environment.xml"),
}
# Not in the repository, and not measured by default: the environment scene under the same sky
# at 2048x1024, the size of the field's skies, made in out/ the first time it is asked for
# (scripts/make_sky.py).
BIG_SKY = ROOT / "out" / "bench-sky"
SCENES["environment_2k"] = (str(BIG_SKY / "environment.xml"), str(BIG_SKY / "environment.xml"))
DEFAULT_SCENES = ["cornell", "textured_glossy", "environment"]


def prepare(name):
    """Makes the files of a scene that is generated (environment_2k) if they are missing."""
    sky, xml = BIG_SKY / "assets" / "sky.hdr", BIG_SKY / "environment.xml"
    if name != "environment_2k":
        return
    if not xml.exists():
        xml.parent.mkdir(parents=True, exist_ok=True)
        xml.write_bytes((ROOT / SCENES["environment"][0]).read_bytes())
    if not sky.exists():
        sky.parent.mkdir(parents=True, exist_ok=True)
        subprocess.run([sys.executable, str(ROOT / "scripts" / "make_sky.py"), str(sky), "2048x1024"],
                       check=True)


def mitsuba(variant, spp, xml):
    import mitsuba as mi
    import numpy as np

    mi.set_variant(variant)
    mi.set_log_level(mi.LogLevel.Warn)
    if xml is None:
        d = mi.cornell_box()
        d["sensor"]["film"]["rfilter"] = {"type": "box"}
        d["integrator"]["max_depth"] = MAX_DEPTH
        d["integrator"]["rr_depth"] = RR_DEPTH
        scene = mi.load_dict(d)
    else:
        scene = mi.load_file(str(ROOT / xml), max_depth=MAX_DEPTH)
    width, height = scene.sensors()[0].film().size()
    mi.render(scene, spp=4)  # warm-up (and JIT compilation for the llvm variants)
    start = time.time()
    img = np.array(mi.render(scene, spp=spp))
    seconds = time.time() - start
    return width * height * spp / seconds, img.reshape(-1, 3).mean(0)


def raylab(spp, run, scene):
    exe, integrator = run
    out = ROOT / "out" / "bench-mitsuba.exr"
    out.parent.mkdir(exist_ok=True)
    r = subprocess.run(
        [str(exe), "render", scene, "-i", integrator, "--spp", str(spp), *RAYLAB_PARAMS,
         "-o", str(out)],
        cwd=ROOT, capture_output=True, text=True, check=True,
    )
    line = r.stderr.strip().splitlines()[-1]
    rate = float(re.search(r"([0-9.]+) M samples/s", line).group(1)) * 1e6
    mean = [float(v) for v in re.search(r"mean radiance \(([^)]*)\)", line).group(1).split(",")]
    return rate, mean


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--variants", default="scalar_rgb,llvm_ad_rgb")
    ap.add_argument("--repeat", type=int, default=1, help="rounds to run")
    ap.add_argument("--raylab", default="target/release/raylab",
                    help="raylab binaries to measure in turn, comma-separated (old and new, say)")
    ap.add_argument("--integrators", default="path",
                    help="raylab integrators to measure in turn, comma-separated (path, path-wavefront)")
    ap.add_argument("--scenes", default=",".join(DEFAULT_SCENES),
                    help=f"scenes to measure, comma-separated, of {', '.join(SCENES)}")
    args = ap.parse_args()
    scenes = args.scenes.split(",")
    unknown = [s for s in scenes if s not in SCENES]
    if unknown:
        ap.error(f"unknown scene {unknown[0]!r} (known: {', '.join(SCENES)})")
    for round_, name in ((r, n) for r in range(args.repeat) for n in scenes):
        prepare(name)
        ours_file, xml = SCENES[name]
        exes = [(pathlib.Path(e).resolve(), i) for e in args.raylab.split(",")
                for i in args.integrators.split(",")]
        before = {e: raylab(args.spp, e, ours_file) for e in exes}
        theirs = {}
        for variant in args.variants.split(","):
            try:
                theirs[variant] = mitsuba(variant, args.spp, xml)
            except Exception as e:  # a variant that cannot load (no LLVM) is reported, not fatal
                print(f"mitsuba {variant}: not measured ({e})")
        after = {e: raylab(args.spp, e, ours_file) for e in reversed(exes)}
        print(f"round {round_ + 1}, {name}: {args.spp} spp, max_depth {MAX_DEPTH} rr_depth {RR_DEPTH}"
              f" (raylab {' '.join(RAYLAB_PARAMS[1::2])})")
        for e in exes:
            ours = (before[e][0] + after[e][0]) / 2
            our_mean = before[e][1]
            name = e[0].name if len(args.raylab.split(",")) == 1 else str(e[0])
            print(f"  raylab {e[1]} {name}: {ours / 1e6:8.3f} M samples/s (before {before[e][0] / 1e6:.3f}, after {after[e][0] / 1e6:.3f})  mean {tuple(round(v, 4) for v in our_mean)}")
            for variant, (rate, mean) in theirs.items():
                print(f"    against mitsuba {variant:<14} {rate / 1e6:8.3f} M samples/s  mean {tuple(round(float(v), 4) for v in mean)}  raylab/mitsuba {ours / rate:5.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
