//! Counts the chi-square tests (the `#[test]` functions named `chi2_*`) for the Šidák
//! correction of `testing::chi2`, so that the count is never kept by hand. The harness
//! refuses to run in a test not so named, so every test that runs one is counted.

use std::path::Path;

fn count(dir: &Path) -> u32 {
    let mut n = 0;
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            n += count(&path);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let text = std::fs::read_to_string(&path).unwrap_or_default();
            let mut after_test = false;
            for line in text.lines().map(str::trim) {
                if line == "#[test]" {
                    after_test = true;
                } else if after_test && line.starts_with("fn ") {
                    n += u32::from(line.starts_with("fn chi2_"));
                    after_test = false;
                } else if after_test && !line.starts_with("#[") {
                    after_test = false;
                }
            }
        }
    }
    n
}

/// The resolution of the RGB-to-spectrum table per axis, as pbrt-v4 and Mitsuba 3 fit it
/// (at 32 the fit of the darkest pure blues fails: `spectrum`'s round-trip test).
const RGB2SPEC_RESOLUTION: usize = 64;

/// Fits Jakob & Hanika's (2019) sigmoid-polynomial coefficients over the sRGB cube once per
/// build directory (40 s on one core), as pbrt-v4 and Mitsuba 3 do in their builds, rather than
/// keeping megabytes of generated numbers in the repository.
fn rgb2spec_table() {
    let out = std::path::PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"))
        .join(format!("srgb_rgb2spec_{RGB2SPEC_RESOLUTION}.bin"));
    if out.exists() {
        return;
    }
    let model =
        rgb2spec::optimize::optimize(rgb2spec::optimize::gamut::Gamut::SRGB, RGB2SPEC_RESOLUTION)
            .expect("the sRGB fit converges at this resolution");
    let partial = out.with_extension("part");
    model.save(&partial).expect("OUT_DIR is writable");
    std::fs::rename(&partial, &out).expect("OUT_DIR is writable");
}

fn main() {
    println!("cargo:rerun-if-changed=src");
    rgb2spec_table();
    println!("cargo:rustc-env=RAYLAB_RGB2SPEC_RESOLUTION={RGB2SPEC_RESOLUTION}");
    println!(
        "cargo:rustc-env=RAYLAB_CHI2_TESTS={}",
        count(Path::new("src"))
    );
}
