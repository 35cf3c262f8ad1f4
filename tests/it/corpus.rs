//! The bad-input corpus (`tests/corpus/`), run through the real `raylab` binary.
//!
//! * Every `tests/corpus/NN-short-name.ron` is a bad scene whose first lines say what the
//!   error must contain (`// expect: SUBSTRING`, one or more). It is rendered and validated.
//! * Every line of `tests/corpus/cli-cases.txt` is a bad command line against a good scene.
//!
//! Each case must exit with code 2, print every expected substring on stderr in a single
//! `error:` line, never panic, and leave no output file (nor any other file) behind. All cases
//! run, then every failure is reported at once. `tests/corpus/ok/` holds scenes that must
//! load: the degenerate-triangles scene renders with warnings and its triangles are never hit.

use raylab::scene::parse_scene;
use raylab::scene::RenderScene;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The corpus may grow, never shrink below this.
const MIN_CASES: usize = 40;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn corpus_dir() -> PathBuf {
    root().join("tests/corpus")
}

fn raylab(args: &[String]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("raylab runs")
}

/// One bad input: how to run it and what its message must contain.
struct Case {
    name: String,
    args: Vec<String>,
    expect: Vec<String>,
}

/// Runs `case` with a fresh temporary folder as `{tmp}`; returns what went wrong, if anything.
fn check(case: &Case) -> Option<String> {
    let tmp = tempfile::tempdir().expect("temporary folder");
    let out = tmp.path().join("out.png");
    let scene = corpus_dir().join("ok/good.ron");
    let args: Vec<String> = case
        .args
        .iter()
        .map(|a| {
            a.replace("{out}", out.to_str().unwrap())
                .replace("{tmp}", tmp.path().to_str().unwrap())
                .replace("{scene}", scene.to_str().unwrap())
        })
        .collect();
    let o = raylab(&args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    let mut problems = Vec::new();
    if o.status.code() != Some(2) {
        problems.push(format!("exit code {:?}, expected 2", o.status.code()));
    }
    if stderr.contains("panicked") {
        problems.push("panicked".to_string());
    }
    for e in &case.expect {
        if !stderr.contains(e.as_str()) {
            problems.push(format!("no `{e}` in stderr"));
        }
    }
    let errors = stderr.lines().filter(|l| l.starts_with("error")).count();
    if errors != 1 {
        problems.push(format!("{errors} lines start with `error`, expected 1"));
    }
    let left: Vec<String> = std::fs::read_dir(tmp.path())
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    if !left.is_empty() {
        problems.push(format!("left files behind: {left:?}"));
    }
    if problems.is_empty() {
        None
    } else {
        Some(format!(
            "{}: raylab {}\n    {}\n    stderr: {}",
            case.name,
            args.join(" "),
            problems.join("\n    "),
            stderr.trim_end().replace('\n', "\n            ")
        ))
    }
}

/// The bad scenes: `NN-short-name.ron` files with their `// expect:` lines, Mitsuba XML
/// ones, `NN-short-name.xml` with `<!-- expect: ... -->` lines, and pbrt-v4 ones,
/// `NN-short-name.pbrt` with `# expect: ` lines.
fn scene_cases() -> Vec<Case> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(corpus_dir())
        .expect("tests/corpus exists")
        .map(|e| e.expect("readable entry").path())
        .filter(|p| {
            p.extension()
                .is_some_and(|e| e == "ron" || e == "xml" || e == "pbrt")
        })
        .collect();
    files.sort();
    let mut cases = Vec::new();
    for path in files {
        let file = path.file_name().unwrap().to_string_lossy().into_owned();
        let digits = file.bytes().take_while(u8::is_ascii_digit).count();
        let numbered = digits >= 2 && file.as_bytes().get(digits) == Some(&b'-');
        assert!(
            numbered,
            "{file}: corpus scenes are named NN-short-name.ron (or NNN-...)"
        );
        // Bytes, not text: some cases are not valid UTF-8 on purpose.
        let bytes = std::fs::read(&path).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        let expect: Vec<String> = text
            .lines()
            .filter_map(|l| {
                l.strip_prefix("// expect: ")
                    .or_else(|| l.strip_prefix("# expect: "))
                    .or_else(|| {
                        l.strip_prefix("<!-- expect: ")
                            .and_then(|l| l.strip_suffix(" -->"))
                    })
            })
            .map(str::to_string)
            .collect();
        assert!(!expect.is_empty(), "{file}: no `// expect: ` line");
        let relative = format!("tests/corpus/{file}");
        // The loader itself must refuse the scene (validate), and so must a render.
        cases.push(Case {
            name: format!("{file} (validate)"),
            args: vec!["validate".into(), relative.clone()],
            expect: expect.clone(),
        });
        cases.push(Case {
            name: file.clone(),
            args: ["render", &relative, "-o", "{out}", "-q"]
                .map(String::from)
                .to_vec(),
            expect,
        });
    }
    cases
}

/// The bad command lines of `cli-cases.txt`.
fn cli_cases() -> Vec<Case> {
    let text = std::fs::read_to_string(corpus_dir().join("cli-cases.txt")).unwrap();
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|line| {
            let fields: Vec<&str> = line.split(" | ").map(str::trim).collect();
            assert_eq!(
                fields.len(),
                3,
                "cli-cases.txt: `{line}` is not NAME | ARGUMENTS | EXPECTED"
            );
            Case {
                name: format!("cli-cases.txt: {}", fields[0]),
                args: fields[1].split_whitespace().map(String::from).collect(),
                expect: fields[2]
                    .split(";;")
                    .map(|e| e.trim().to_string())
                    .collect(),
            }
        })
        .collect()
}

#[test]
fn every_bad_input_fails_cleanly_with_its_message() {
    let scenes = scene_cases();
    let cli = cli_cases();
    let bad_scenes = scenes.len() / 2;
    assert!(
        bad_scenes >= MIN_CASES,
        "the corpus shrank: {bad_scenes} bad scenes, expected at least {MIN_CASES}"
    );
    assert!(!cli.is_empty(), "cli-cases.txt has no cases");
    let failures: Vec<String> = scenes.iter().chain(&cli).filter_map(check).collect();
    assert!(
        failures.is_empty(),
        "{} of {} corpus runs failed ({bad_scenes} scenes, {} command lines):\n\n{}",
        failures.len(),
        scenes.len() + cli.len(),
        cli.len(),
        failures.join("\n\n")
    );
}

/// The `// warning: ` lines of a scene in `tests/corpus/ok/`.
fn expected_warnings(text: &str) -> Vec<&str> {
    text.lines()
        .filter_map(|l| l.strip_prefix("// warning: "))
        .collect()
}

#[test]
fn degenerate_triangles_are_dropped_with_a_warning_and_never_hit() {
    let path = corpus_dir().join("ok/degenerate-triangles.ron");
    let text = std::fs::read_to_string(&path).unwrap();
    let warnings = expected_warnings(&text);
    assert_eq!(warnings.len(), 5);

    // The library: the loader reports them, the build keeps only the good primitives.
    let loaded = parse_scene(&text, &path).unwrap();
    assert_eq!(loaded.warnings, warnings);
    let built = RenderScene::build(&loaded);
    assert_eq!(built.stats.triangles, 1, "only the far backdrop triangle");
    assert_eq!(built.stats.spheres, 1);

    // The program: exit 0, every warning on stderr, and a depth image of far hits only.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("depth.exr");
    let o = raylab(
        &[
            "render",
            "tests/corpus/ok/degenerate-triangles.ron",
            "-i",
            "depth",
            "--spp",
            "4",
            "-o",
            out.to_str().unwrap(),
            "-q",
        ]
        .map(String::from),
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    for w in &warnings {
        assert!(
            stderr.contains(&format!(
                "warning: tests/corpus/ok/degenerate-triangles.ron: {w}"
            )),
            "no warning `{w}` in: {stderr}"
        );
    }
    assert!(!stderr.contains("panicked"), "{stderr}");
    // Depth is distance / diagonal of the bounds (600 x 600 x 70 -> 851.4). The backdrop
    // fills the view, so every pixel is a hit: the sphere at 85 or more (0.0998) or the
    // backdrop at 155 or more (0.182). A degenerate triangle would be at 4 to 5 (< 0.006).
    let img = image::open(&out).unwrap().to_rgb32f();
    assert_eq!(img.dimensions(), (16, 16));
    let depths: Vec<f32> = img.pixels().map(|p| p[0]).collect();
    let nearest = depths.iter().copied().fold(f32::INFINITY, f32::min);
    let farthest = depths.iter().copied().fold(0.0, f32::max);
    assert!(nearest > 0.09, "something near the eye was hit: {nearest}");
    assert!(
        farthest > 0.18 && farthest < 0.25,
        "the backdrop is missing: {farthest}"
    );
}

#[test]
fn the_good_scene_of_the_command_line_cases_renders() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("good.png");
    let o = raylab(
        &[
            "render",
            "tests/corpus/ok/good.ron",
            "-o",
            out.to_str().unwrap(),
            "-q",
        ]
        .map(String::from),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.exists());
}
