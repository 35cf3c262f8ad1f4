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

fn main() {
    println!("cargo:rerun-if-changed=src");
    println!(
        "cargo:rustc-env=RAYLAB_CHI2_TESTS={}",
        count(Path::new("src"))
    );
}
