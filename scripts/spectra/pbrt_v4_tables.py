#!/usr/bin/env python3
"""Writes integrators/src/spectrum/named/pbrt_v4.rs: pbrt-v4's measured spectra as Rust data.

The tables (metals' optical constants, CIE standard illuminants, Schott glasses) are read from
pbrt-v4's `src/pbrt/util/spectrum.cpp` (Apache-2.0; its licence is shipped beside the output)
and written as interleaved (nm, value) arrays under pbrt-v4's names. Nothing is computed:
the numbers are pbrt-v4's, in its order.

    python3 scripts/spectra/pbrt_v4_tables.py PBRT_V4_CHECKOUT/src/pbrt/util/spectrum.cpp
"""
import pathlib
import re
import sys

# pbrt-v4's C++ array -> (the name scenes use, whether pbrt normalises it to luminance 1).
TABLES = [
    ("Ag_eta", "metal-Ag-eta"), ("Ag_k", "metal-Ag-k"),
    ("Al_eta", "metal-Al-eta"), ("Al_k", "metal-Al-k"),
    ("Au_eta", "metal-Au-eta"), ("Au_k", "metal-Au-k"),
    ("Cu_eta", "metal-Cu-eta"), ("Cu_k", "metal-Cu-k"),
    ("CuZn_eta", "metal-CuZn-eta"), ("CuZn_k", "metal-CuZn-k"),
    ("MgO_eta", "metal-MgO-eta"), ("MgO_k", "metal-MgO-k"),
    ("TiO2_eta", "metal-TiO2-eta"), ("TiO2_k", "metal-TiO2-k"),
    ("GlassBK7_eta", "glass-BK7"), ("GlassBAF10_eta", "glass-BAF10"),
    ("GlassFK51A_eta", "glass-FK51A"), ("GlassLASF9_eta", "glass-LASF9"),
    ("GlassSF5_eta", "glass-F5"), ("GlassSF10_eta", "glass-F10"),
    ("GlassSF11_eta", "glass-F11"),
    ("CIE_Illum_A", "stdillum-A"), ("CIE_Illum_D5000", "stdillum-D50"),
    ("CIE_Illum_D6500", "stdillum-D65"), ("ACES_Illum_D60", "illum-acesD60"),
] + [(f"CIE_Illum_F{i}", f"stdillum-F{i}") for i in range(1, 13)]


def main() -> None:
    src = pathlib.Path(sys.argv[1]).read_text()
    out = pathlib.Path(__file__).resolve().parents[2] / "integrators/src/spectrum/named/pbrt_v4.rs"
    lines = [
        "//! pbrt-v4's measured spectra, as it names them: interleaved (nm, value) pairs.",
        "//!",
        "//! Data from pbrt-v4's `src/pbrt/util/spectrum.cpp`. pbrt is Copyright (c) 1998-2020",
        "//! Matt Pharr, Wenzel Jakob, and Greg Humphreys, licensed under the Apache License 2.0",
        "//! (`LICENSE-pbrt-v4.txt` beside this file). Changed: only the layout, written by",
        "//! `scripts/spectra/pbrt_v4_tables.py`; do not edit by hand.",
        "",
        "#[rustfmt::skip]",
        "#[allow(clippy::excessive_precision, clippy::approx_constant)]",
        "pub const TABLES: &[(&str, &[f32])] = &[",
    ]
    for array, name in TABLES:
        m = re.search(r"const Float " + re.escape(array) + r"\[\w*\] = \{(.*?)\};", src, re.S)
        if not m:
            sys.exit(f"{array} not found")
        values = [float(v) for v in m.group(1).replace("\n", " ").split(",") if v.strip()]
        if len(values) % 2:
            sys.exit(f"{array}: an odd count")
        body = ", ".join(repr(v) for v in values)
        lines.append(f'    ("{name}", &[{body}]),')
    lines.append("];")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out} ({len(TABLES)} spectra)")


if __name__ == "__main__":
    main()
