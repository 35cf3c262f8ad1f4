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
    let allowed: [(&str, &[&str]); 8] = [
        ("accel", &[]),
        ("formats", &[]),
        ("scene", &["accel", "formats"]),
        ("output", &[]),
        ("render", &["output", "scene", "accel", "formats"]),
        (
            "compare",
            &["render", "output", "scene", "accel", "formats"],
        ),
        ("live", &["render", "output", "scene", "accel", "formats"]),
        ("bench", &["render", "output", "scene", "accel", "formats"]),
    ];
    let modules = [
        "accel", "formats", "scene", "output", "render", "compare", "live", "bench", "cli",
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

/// The files of a folder, as modules, and which of them each names (`super::NAME`, or
/// `PREFIX::NAME` for the folder's path from the crate root), outside comments and tests.
fn file_graph(dir: &Path, prefix: &str) -> Vec<(String, Vec<String>)> {
    let names: Vec<String> = sources(dir)
        .into_iter()
        .filter(|p| p.parent() == Some(dir))
        .filter_map(|p| Some(p.file_stem()?.to_string_lossy().into_owned()))
        .filter(|n| n != "mod" && n != "lib")
        .collect();
    names
        .iter()
        .map(|name| {
            let text = std::fs::read_to_string(dir.join(format!("{name}.rs"))).unwrap();
            let code: String = text
                .split("#[cfg(test)]")
                .next()
                .unwrap_or("")
                .lines()
                .filter(|l| !l.trim_start().starts_with("//"))
                .collect::<Vec<_>>()
                .join("\n");
            let names_it = |other: &String| {
                let word = |at: usize| {
                    !code[at + other.len()..].starts_with(|c: char| c.is_alphanumeric() || c == '_')
                };
                [format!("super::{other}"), format!("{prefix}::{other}")]
                    .iter()
                    .any(|needle| {
                        code.match_indices(needle.as_str())
                            .any(|(i, m)| word(i + m.len() - other.len()))
                    })
                    || code.split("use super::{").skip(1).any(|list| {
                        list.split('}')
                            .next()
                            .unwrap_or("")
                            .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                            .any(|w| w == other)
                    })
            };
            let uses = names
                .iter()
                .filter(|o| *o != name && names_it(o))
                .cloned()
                .collect();
            (name.clone(), uses)
        })
        .collect()
}

/// A cycle among the files of the graph, if there is one.
fn a_cycle(graph: &[(String, Vec<String>)]) -> Option<Vec<String>> {
    fn visit(
        at: &str,
        graph: &[(String, Vec<String>)],
        path: &mut Vec<String>,
        done: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        if let Some(i) = path.iter().position(|p| p == at) {
            return Some(path[i..].to_vec());
        }
        if done.iter().any(|d| d == at) {
            return None;
        }
        path.push(at.to_string());
        let next = graph.iter().find(|(n, _)| n == at).map(|(_, u)| u.clone());
        for n in next.unwrap_or_default() {
            if let Some(c) = visit(&n, graph, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.push(at.to_string());
        None
    }
    let mut done = Vec::new();
    graph
        .iter()
        .find_map(|(n, _)| visit(n, graph, &mut Vec::new(), &mut done))
}

/// No file of the scene or formats modules or of the integrators crate's top level imports,
/// through others, itself (issue #46: a cycle makes a room that cannot be moved out alone).
#[test]
fn no_file_imports_itself_through_others() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (dir, prefix) in [
        (root.join("src/scene"), "crate::scene"),
        (root.join("src/formats"), "crate::formats"),
        (root.join("integrators/src"), "crate"),
    ] {
        let graph = file_graph(&dir, prefix);
        assert!(graph.len() > 5, "{}: {graph:?}", dir.display());
        if let Some(cycle) = a_cycle(&graph) {
            panic!("{}: an import cycle: {}", dir.display(), cycle.join(" -> "));
        }
    }
    // The check finds one where there is one.
    let cyclic = vec![
        ("a".to_string(), vec!["b".to_string()]),
        ("b".to_string(), vec!["c".to_string()]),
        ("c".to_string(), vec!["a".to_string()]),
    ];
    assert_eq!(a_cycle(&cyclic).map(|c| c.len()), Some(3));
}
