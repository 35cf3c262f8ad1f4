//! The floor plan's arrows, checked in the source: each engine module names only the modules
//! below it (docs/architecture.md). Test files may reach further (accel's tests build whole
//! scenes).

use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`, but test files.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(sources(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            let name = path.file_name().unwrap().to_string_lossy();
            if name != "tests.rs" && !name.ends_with("_tests.rs") {
                out.push(path);
            }
        }
    }
    out
}

#[test]
fn modules_name_only_the_modules_below_them() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    // (module, the engine modules it may use).
    let allowed: [(&str, &[&str]); 7] = [
        ("accel", &[]),
        ("scene", &["accel"]),
        ("output", &[]),
        ("render", &["output", "scene"]),
        ("compare", &["render", "output", "scene", "accel"]),
        ("live", &["render", "output", "scene", "accel"]),
        ("bench", &["render", "output", "scene", "accel"]),
    ];
    let modules = [
        "accel", "scene", "output", "render", "compare", "live", "bench", "cli",
    ];
    let mut wrong = Vec::new();
    for (module, may) in allowed {
        for file in sources(&root.join(module)) {
            let text = std::fs::read_to_string(&file).unwrap();
            for other in modules {
                if other == module || may.contains(&other) {
                    continue;
                }
                let needle = format!("crate::{other}");
                if text
                    .lines()
                    .filter(|l| !l.trim_start().starts_with("//"))
                    .any(|l| l.contains(&needle))
                {
                    wrong.push(format!("{} names {needle}", file.display()));
                }
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "arrows pointing up:\n{}",
        wrong.join("\n")
    );
}
