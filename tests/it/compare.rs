//! `raylab compare` and `raylab diff` as a user runs them, and the page in headless Chromium.

use crate::common;

use std::path::Path;
use std::process::{Command, Output};

fn raylab(args: &[&str], cache: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(args)
        .env("XDG_CACHE_HOME", cache)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("raylab runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

const CORNELL: &str = "scenes/cornell_box.ron";

/// Loads `index.html#selftest` in headless Chromium: the page must run without console
/// messages and report that its slider changes the shown image. Skipped (loudly) where
/// Chromium is missing, except under CI, which installs it.
fn check_page_in_chromium(page: &Path) {
    let Some(chromium) = common::chromium() else {
        return;
    };
    let url = format!("file://{}#selftest", page.canonicalize().unwrap().display());
    let (dom, console) = common::chromium_dump_dom(chromium, &url, 20000);
    assert!(
        dom.contains("<title>selftest: ok</title>"),
        "page self-test failed: {}",
        dom.lines()
            .find(|l| l.contains("<title>"))
            .unwrap_or("no title")
    );
    assert!(console.is_empty(), "console messages: {console:#?}");
    assert!(dom.contains("<table id=\"metrics\">"));
}

#[test]
fn compare_writes_images_metrics_mosaic_and_a_working_page() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cmp");
    let cache = dir.path().join("cache");
    let args = [
        "compare",
        CORNELL,
        "-i",
        "whitted",
        "-i",
        "path",
        "-p",
        "path.max-depth=4",
        "--size",
        "40x32",
        "--spp",
        "4",
        "--reference-spp",
        "16",
        "-o",
        s(&out),
        "-q",
        "--note",
        "a <small> test",
    ];
    let o = raylab(&args, &cache);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("rendering the reference"));
    for f in [
        "index.html",
        "mosaic.png",
        "metrics.json",
        "metrics.csv",
        "reference.exr",
        "reference.png",
        "whitted.exr",
        "whitted.png",
        "whitted-error.png",
        "path.exr",
        "path.png",
        "path-error.png",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[1]["params"], "max-depth=4 rr-depth=3");
    // Path tracing is closer to the reference than Whitted's direct light on every metric.
    let m = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap();
    assert!(m(&rows[1], "rmse") < m(&rows[0], "rmse") && m(&rows[1], "flip") < m(&rows[0], "flip"));
    assert!(m(&rows[0], "rays_per_s") > 0.0 && rows[0]["spp"] == 4);
    let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3);
    assert!(csv.starts_with("label,integrator,params"));
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        html.contains("a &lt;small&gt; test"),
        "the note is shown, escaped"
    );
    assert!(
        !html.contains("http://") && !html.contains("https://"),
        "the page loads nothing from the network"
    );
    // Pages and metrics never print a path of the machine that made them (the reference's
    // cache folder, the temporary folder the test runs in).
    let json_text = std::fs::read_to_string(out.join("metrics.json")).unwrap();
    for text in [&html, &json_text] {
        assert!(!text.contains(s(dir.path())), "a machine path is printed");
    }
    assert!(json_text.contains("cached as reference-"), "{json_text}");
    check_page_in_chromium(&out.join("index.html"));

    // A second run reuses the cached reference.
    let o = raylab(&args, &cache);
    assert!(
        o.status.success() && !stderr(&o).contains("rendering the reference"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn sweeps_write_one_image_per_value_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let o = raylab(
        &[
            "compare",
            CORNELL,
            "-i",
            "fixed-depth",
            "--sweep",
            "depth=1,2,3",
            "-p",
            "fixed-depth.branching=2",
            "-p",
            "fixed-depth.shadow-grid=1",
            "--size",
            "24x24",
            "--spp",
            "2",
            "--reference-spp",
            "8",
            "-o",
            s(&out),
            "-q",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for f in [
        "fixed-depth-depth-1.png",
        "fixed-depth-depth-2.exr",
        "fixed-depth-depth-3-error.png",
        "sweep.svg",
        "sweep.png",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let svg = std::fs::read_to_string(out.join("sweep.svg")).unwrap();
    assert!(svg.contains("error against time") && svg.contains("time against depth"));
    assert!(std::fs::read_to_string(out.join("index.html"))
        .unwrap()
        .contains("<h2>Sweep</h2>"));
}

#[test]
fn equal_time_gives_every_integrator_at_least_one_pass() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t");
    let o = raylab(
        &[
            "compare",
            CORNELL,
            "-i",
            "path",
            "-i",
            "whitted",
            "--time",
            "0.3",
            "--size",
            "32x32",
            "--reference-spp",
            "8",
            "-o",
            s(&out),
            "-q",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    assert!(json["budget"].as_str().unwrap().starts_with("equal time"));
    for r in json["rows"].as_array().unwrap() {
        assert!(r["spp"].as_u64().unwrap() >= 1);
    }
}

#[test]
fn compare_rejects_bad_requests() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x");
    for (args, expected) in [
        (vec!["-i", "nope"], "unknown integrator `nope`"),
        (
            vec!["-i", "path", "-p", "path.maxdepth=3"],
            "no parameter `maxdepth`",
        ),
        (
            vec!["-i", "path", "-p", "whitted.max-depth=3"],
            "not compared",
        ),
        (
            vec!["-i", "path", "--sweep", "bogus=1,2"],
            "no parameter `bogus`",
        ),
        (
            vec!["-i", "path", "--spp", "4", "--time", "1"],
            "either --spp or --time",
        ),
        (vec!["-i", "path", "-i", "path"], "named once"),
    ] {
        let mut all = vec!["compare", CORNELL, "-o", s(&out), "-q"];
        all.extend(args);
        let o = raylab(&all, dir.path());
        assert_eq!(o.status.code(), Some(2), "{all:?}");
        assert!(stderr(&o).contains(expected), "{all:?}: {}", stderr(&o));
    }
}

#[test]
fn diff_prints_metrics_and_exits_by_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (a, b) = (d.join("a.exr"), d.join("b.exr"));
    for (file, spp) in [(&a, "1"), (&b, "64")] {
        let o = raylab(
            &[
                "render",
                CORNELL,
                "--size",
                "32x32",
                "--spp",
                spp,
                "-o",
                s(file),
                "-q",
            ],
            d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = raylab(&["diff", s(&a), s(&a)], d);
    assert_eq!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stdout).contains("RMSE    0.000000"));
    let map = d.join("err.png");
    let o = raylab(
        &[
            "diff",
            s(&a),
            s(&b),
            "-o",
            s(&map),
            "--metric",
            "rmse",
            "--tolerance",
            "1e-6",
        ],
        d,
    );
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(map.exists());
    let o = raylab(
        &[
            "diff",
            s(&a),
            s(&b),
            "--metric",
            "rmse",
            "--tolerance",
            "100",
        ],
        d,
    );
    assert_eq!(o.status.code(), Some(0));
    let o = raylab(&["diff", s(&a), s(&d.join("missing.exr"))], d);
    assert_eq!(o.status.code(), Some(2));
    let small = d.join("small.exr");
    raylab(
        &[
            "render",
            CORNELL,
            "--size",
            "16x16",
            "--spp",
            "1",
            "-o",
            s(&small),
            "-q",
        ],
        d,
    );
    let o = raylab(&["diff", s(&a), s(&small)], d);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("differ in size"), "{}", stderr(&o));
}

/// `--sweep max-depth=1,inf` (a documented value) finishes, with the unlimited value drawn
/// at a labelled place on the plot (the plotting library loops forever on an infinite axis).
#[test]
fn a_sweep_to_unlimited_depth_finishes_and_labels_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let reference = dir.path().join("ref.exr");
    let o = raylab(
        &[
            "render",
            CORNELL,
            "--size",
            "24x24",
            "--spp",
            "4",
            "-q",
            "-o",
            s(&reference),
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let run = common::Running::start(
        &[
            "compare",
            CORNELL,
            "-i",
            "path",
            "--sweep",
            "max-depth=1,inf",
            "--spp",
            "1",
            "--size",
            "24x24",
            "-q",
            "--reference",
            s(&reference),
            "-o",
            s(&out),
        ],
        &dir.path().join("log"),
        false,
    );
    let mut run = run;
    assert!(
        common::eventually(|| matches!(run.child.try_wait(), Ok(Some(_)))),
        "still running: {}",
        run.stderr()
    );
    assert!(run.child.wait().unwrap().success(), "{}", run.stderr());
    let svg = std::fs::read_to_string(out.join("sweep.svg")).unwrap();
    assert!(svg.contains("unlimited"), "the unlimited value is labelled");
}
