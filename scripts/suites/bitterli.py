#!/usr/bin/env python3
"""Bitterli's "Rendering Resources" (32 scenes, pbrt-v4 form, each with Tungsten's reference
render `TungstenRender.exr`), tried with raylab: which load, and, for those whose public files
are complete, how the image's mean per channel compares with Tungsten's.

The public copy (github.com/gonsolo/bitterli: `<scene>/pbrt/scene-v4.pbrt`) lacks its files of
4 MiB or more when fetched as a mirror; a scene missing a file is listed with them. With
`--stand-ins`, each missing texture, environment map or mesh is replaced by a small stand-in
(a grey TGA, a grey PFM, one triangle, one curve for an included `.pbrt` model such as the
hair scenes' hair, an empty file) in a copy, to show that the scene loads once its files are
there; those are never compared.

    python3 -m venv venv && venv/bin/pip install mitsuba numpy   # reads the EXRs
    venv/bin/python scripts/suites/bitterli.py SOURCE [--raylab BIN] [--stand-ins]
        [--render SPP] [--param NAME=VALUE] [--only NAME] [--out DIR] [-- EXTRA OPTIONS]

SOURCE is a git directory of the mirror (bare, as `fetch` brings it) or a folder of the
scenes as `<scene>/scene-v4.pbrt`. Renders are at the reference's resolution, `--spp SPP`.
"""
import argparse
import pathlib
import re
import shutil
import struct
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent.parent
REFERENCE = "TungstenRender.exr"


def materialize(git_dir, out):
    """Copies every `<scene>/pbrt/` file the mirror holds into `out/<scene>/`."""
    tree = subprocess.run(["git", f"--git-dir={git_dir}", "ls-tree", "-r", "-z", "HEAD"],
                          capture_output=True, check=True).stdout
    for entry in tree.split(b"\0"):
        if not entry:
            continue
        meta, path = entry.split(b"\t", 1)
        _, kind, oid = meta.split()
        path = path.decode()
        parts = path.split("/")
        if kind != b"blob" or len(parts) < 3 or parts[1] != "pbrt":
            continue
        blob = subprocess.run(["git", f"--git-dir={git_dir}", "cat-file", "blob", oid.decode()],
                              capture_output=True)
        if blob.returncode != 0:
            continue  # absent from the mirror
        dst = out / parts[0] / "/".join(parts[2:])
        dst.parent.mkdir(parents=True, exist_ok=True)
        dst.write_bytes(blob.stdout)


def referenced(scene_file):
    """The files a pbrt scene (and its includes) names, relative to its folder."""
    names, seen, todo = set(), set(), [scene_file]
    while todo:
        f = todo.pop()
        if f in seen or not f.exists():
            continue
        seen.add(f)
        directive = ""
        for line in f.read_text(errors="replace").splitlines():
            head = re.match(r'\s*([A-Z][A-Za-z]*)\b(?:\s+"([^"]+)")?', line)
            if head:
                directive = head.group(1)
                if directive in ("Include", "Import") and head.group(2):
                    names.add(head.group(2))
                    todo.append(scene_file.parent / head.group(2))
            # The film's file is what pbrt writes, not what it reads.
            if directive != "Film":
                for m in re.finditer(r'"string (?:filename|mapname)"\s*\[?\s*"([^"]+)"', line):
                    names.add(m.group(1))
    return sorted(names)


def stand_in(path):
    path.parent.mkdir(parents=True, exist_ok=True)
    ext = path.suffix.lower()
    if ext == ".tga":
        # 2 x 2 grey, uncompressed true colour.
        header = struct.pack("<BBBHHBHHHHBB", 0, 0, 2, 0, 0, 0, 0, 0, 2, 2, 24, 0)
        path.write_bytes(header + bytes([128] * 12))
    elif ext == ".pfm":
        # Square: pbrt-v4 environment maps are equal-area octahedral images.
        path.write_bytes(b"PF\n4 4\n-1.0\n" + struct.pack("<f", 0.5) * 48)
    elif ext == ".ply":
        path.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                        "property float y\nproperty float z\nelement face 1\n"
                        "property list uchar int vertex_indices\nend_header\n"
                        "0 0 -1000\n0.001 0 -1000\n0 0.001 -1000\n3 0 1 2\n")
    elif ext == ".pbrt":
        # An included model (the hair scenes' curves): one short curve far below.
        path.write_text('Shape "curve" "string type" "cylinder" "float width" 0.0001\n'
                        '    "point3 P" [0 0 -1000  0.001 0 -1000  0.002 0 -1000  0.003 0 -1000]\n')
    else:
        path.write_text("")


def exr_rgb(path):
    import mitsuba as mi
    import numpy as np

    bmp = mi.Bitmap(str(path))
    names = [bmp.struct_()[i].name for i in range(bmp.channel_count())]
    a = np.array(bmp, dtype=np.float64).reshape(bmp.height(), bmp.width(), -1)
    return a[..., [names.index(c) for c in ("R", "G", "B")]]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source", type=pathlib.Path)
    ap.add_argument("--raylab", default=str(ROOT / "target" / "release" / "raylab"))
    ap.add_argument("--stand-ins", action="store_true")
    ap.add_argument("--render", type=int, metavar="SPP")
    ap.add_argument("--only", default="")
    ap.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                    help="an integrator parameter for the renders (raylab render -p)")
    ap.add_argument("--out", type=pathlib.Path)
    ap.add_argument("extra", nargs="*")
    args = ap.parse_args()
    work = pathlib.Path(tempfile.mkdtemp())
    if (args.source / "HEAD").exists():
        materialize(args.source, work)
    else:
        shutil.copytree(args.source, work, dirs_exist_ok=True)
    out = args.out or work / "renders"
    out.mkdir(parents=True, exist_ok=True)
    if args.render:
        import mitsuba as mi

        mi.set_variant("scalar_rgb")
    print("| scene | files | loads | raylab says | mean R, G, B raylab / Tungsten |")
    print("|---|---|---|---|---|")
    loaded = 0
    scenes = sorted(p.parent for p in work.glob("*/scene-v4.pbrt"))
    for folder in scenes:
        name = folder.name
        if args.only and args.only != name:
            continue
        scene = folder / "scene-v4.pbrt"
        missing = [n for n in referenced(scene) if not (folder / n).exists()]
        if missing and args.stand_ins:
            for n in missing:
                stand_in(folder / n)
        files = "complete" if not missing else (
            ("stand-ins for " if args.stand_ins else "lacks ") + ", ".join(missing))
        run = subprocess.run([args.raylab, "validate", str(scene), *args.extra],
                             capture_output=True, text=True)
        said = next((l for l in run.stderr.splitlines() if l.startswith("error")), "")
        said = said.replace(str(work) + "/", "").replace("|", "/")[:150]
        ratio = ""
        if run.returncode == 0:
            loaded += 1
            reference = folder / REFERENCE
            if args.render and not missing and reference.exists():
                ref = exr_rgb(reference)
                h, w = ref.shape[:2]
                image = out / f"{name}.exr"
                r = subprocess.run([args.raylab, "render", str(scene), "--spp", str(args.render),
                                    "--size", f"{w}x{h}", "-o", str(image), *args.extra,
                                    *[a for p in args.param for a in ("-p", p)]],
                                   capture_output=True, text=True)
                if r.returncode == 0:
                    import numpy as np

                    img = exr_rgb(image)
                    # Half floats overflow on the brightest pixels of some references (a
                    # lamp seen edge-on): those pixels are left out of both means, and said.
                    ok = np.isfinite(ref).all(-1) & np.isfinite(img).all(-1)
                    ratio = ", ".join(f"{img[ok][:, c].mean() / ref[ok][:, c].mean():.3f}"
                                      for c in range(3))
                    if not ok.all():
                        ratio += f" ({(~ok).sum()} pixels not finite in the reference, left out)"
                else:
                    ratio = "render failed: " + r.stderr.strip().splitlines()[-1][:80]
        print(f"| {name} | {files} | {'yes' if run.returncode == 0 else 'no'} | {said} | {ratio} |",
              flush=True)
    print()
    print(f"{loaded} of {len(scenes)} scenes load")


if __name__ == "__main__":
    sys.exit(main())
