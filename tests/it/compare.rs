//! `raylab compare` and `raylab diff` as a user runs them, and the page in headless Chromium.

use crate::common;
use crate::common::{s, stderr};

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

const CORNELL: &str = "scenes/cornell_box.ron";

/// The page's self-test checks, each of which must pass: the embedded radiance decodes to
/// what was written; the slider shows A, then B; switching A through its menu shows the new
/// image; exposure darkens or brightens; the red-channel view is grey; the grid shows every
/// image, and a wheel event over one panel zooms all of them and a drag pans all of them,
/// each canvas showing its own image's pixel at the shared point; the table has a row per
/// render.
const PAGE_CHECKS: [&str; 10] = [
    "radiance_decodes",
    "slider_shows_a",
    "slider_shows_b",
    "switching_images",
    "exposure",
    "channel_view",
    "grid_shows_every_image",
    "wheel_zooms_every_panel",
    "drag_pans_every_panel",
    "table_rows",
];

/// Loads `index.html#selftest` in headless Chromium, which drives the page's controls through
/// their events; every check must pass, without console messages. Returns the DOM after the
/// test, or `None` (loudly) where Chromium is missing, except under CI, which installs it.
fn check_page_in_chromium(page: &Path) -> Option<String> {
    let chromium = common::chromium()?;
    let url = format!("file://{}#selftest", page.canonicalize().unwrap().display());
    let (dom, console) = common::chromium_dump_dom(chromium, &url, 20000);
    assert!(
        dom.contains("<title>selftest: ok</title>"),
        "page self-test failed: {}",
        dom.lines()
            .find(|l| l.contains("<title>"))
            .unwrap_or("no title")
    );
    let results = dom
        .split("<pre id=\"selftest\" hidden=\"\">")
        .nth(1)
        .and_then(|r| r.split("</pre>").next())
        .expect("the self-test writes its checks");
    let checks: serde_json::Value = serde_json::from_str(results).unwrap();
    for name in PAGE_CHECKS {
        assert_eq!(checks[name], true, "page check {name}: {results}");
    }
    assert!(console.is_empty(), "console messages: {console:#?}");
    assert!(dom.contains("<table id=\"metrics\">"));
    Some(dom)
}

/// The page's self-test at a default comparison's size (256x256, four integrators), where
/// a grid panel draws an image pixel on less than two screen pixels: the test drags by whole
/// screen pixels and reads the pixel the panels' centre shows, as a mouse would.
#[test]
fn the_pages_self_test_passes_on_a_full_size_comparison() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cmp");
    let args = [
        "compare",
        CORNELL,
        "-i",
        "path",
        "-i",
        "whitted",
        "-i",
        "direct",
        "-i",
        "bdpt",
        "--spp",
        "1",
        "--reference-spp",
        "2",
        "-o",
        s(&out),
        "-q",
    ];
    let o = raylab(&args, &dir.path().join("cache"));
    assert!(o.status.success(), "{}", stderr(&o));
    check_page_in_chromium(&out.join("index.html"));
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
    assert_eq!(
        rows[1]["params"],
        "max-depth=4 rr-depth=3 light-selection=scene"
    );
    // Path tracing is closer to the reference than Whitted's direct light on every metric.
    let m = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap();
    for k in ["mse", "rmse", "relmse", "flip", "hdrflip"] {
        assert!(m(&rows[1], k) < m(&rows[0], k), "{k}");
    }
    assert!(m(&rows[0], "rays_per_s") > 0.0 && m(&rows[0], "spp") == 4.0);
    // One run: no intervals, no variance or bias; the reference's noise is known.
    for k in ["mse_ci95", "variance", "bias2"] {
        assert!(rows[0][k].is_null(), "{k}");
    }
    assert_eq!(rows[0]["runs"], 1);
    assert!(json["reference_variance"].as_f64().unwrap() > 0.0);
    // The curve: log-spaced passes 1, 2, 3, 4, in time order.
    let curve = rows[1]["convergence"].as_array().unwrap();
    let spp: Vec<u64> = curve.iter().map(|p| p["spp"].as_u64().unwrap()).collect();
    assert_eq!(spp, [1, 2, 3, 4]);
    assert!(curve
        .windows(2)
        .all(|w| m(&w[0], "time") < m(&w[1], "time")));
    let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3);
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    for name in [
        "runs",
        "mse",
        "mse_ci95",
        "variance",
        "bias2",
        "relmse",
        "flip",
        "hdrflip",
        "efficiency",
        "time",
        "spp",
    ] {
        assert!(header.contains(&name), "metrics.csv lacks {name}");
    }
    let convergence = std::fs::read_to_string(out.join("convergence.csv")).unwrap();
    assert_eq!(convergence.lines().count(), 1 + 4 + 4);
    let svg = std::fs::read_to_string(out.join("convergence.svg")).unwrap();
    assert!(svg.contains("convergence: MSE against time") && svg.contains("path (slope"));
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

/// A contestant is an integrator and its sampler: `NAME@SAMPLER` puts one integrator under
/// two samplers on one page (`NAME@SAMPLER.key` scoping a parameter to one of them), and
/// `--sweep sampler=...` renders one per sampler, without a sweep plot. Each row says which
/// sampler drew its samples. A sampler's images differ; the reference is the same.
#[test]
fn contestants_carry_their_own_sampler() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("samplers");
    let args = |extra: &[&str], out: &Path| {
        let mut a = vec![
            "compare",
            CORNELL,
            "--size",
            "24x24",
            "--spp",
            "4",
            "--reference-spp",
            "16",
            "-o",
            s(out),
            "-q",
        ];
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let raylab_owned = |a: &[String], cache: &Path| {
        raylab(&a.iter().map(String::as_str).collect::<Vec<_>>(), cache)
    };
    let o = raylab_owned(
        &args(
            &[
                "-i",
                "direct",
                "-i",
                "direct@zsobol",
                "-p",
                "direct@zsobol.bsdf-samples=2",
                "--runs",
                "2",
            ],
            &out,
        ),
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    let rows = json["rows"].as_array().unwrap();
    let row = |label: &str| {
        rows.iter()
            .find(|r| r["label"] == label)
            .unwrap_or_else(|| panic!("{label}: {json}"))
    };
    assert_eq!(row("direct")["sampler"], "independent");
    // The sampling literature's figures beside the others: relMSE without the 0.1% worst
    // pixels (no larger than with them), time to unit variance (two runs), the error
    // spectrum at its frequencies, and its plot.
    let frequencies = json["spectrum_frequencies"].as_array().unwrap().len();
    for r in rows {
        assert!(
            r["relmse_robust"].as_f64().unwrap() <= r["relmse"].as_f64().unwrap() + 1e-12,
            "{r}"
        );
        assert!(r["time_to_unit_variance"].as_f64().unwrap() > 0.0, "{r}");
        let spectrum = r["error_spectrum"].as_array().unwrap();
        assert_eq!(spectrum.len(), frequencies);
        // Rings below one cycle per image have no frequency in a 24-pixel image: null.
        assert!(spectrum
            .iter()
            .all(|p| p.is_null() || p.as_f64().unwrap() >= 0.0));
        assert!(spectrum.iter().filter(|p| !p.is_null()).count() > frequencies / 2);
    }
    assert!(out.join("spectrum.svg").exists() && out.join("spectrum.png").exists());
    assert!(std::fs::read_to_string(out.join("index.html"))
        .unwrap()
        .contains("<h2>Error spectrum</h2>"));
    assert_eq!(row("direct@zsobol")["sampler"], "zsobol");
    assert!(row("direct@zsobol")["params"]
        .as_str()
        .unwrap()
        .contains("bsdf-samples=2"));
    assert!(row("direct")["params"]
        .as_str()
        .unwrap()
        .contains("bsdf-samples=1"));
    assert_ne!(
        std::fs::read(out.join("direct.exr")).unwrap(),
        std::fs::read(out.join("direct@zsobol.exr")).unwrap()
    );

    let swept = dir.path().join("swept");
    let o = raylab_owned(
        &args(
            &["-i", "direct", "--sweep", "sampler=stratified,halton"],
            &swept,
        ),
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(swept.join("direct-sampler-halton.exr").exists());
    assert!(!swept.join("sweep.svg").exists());
    let csv = std::fs::read_to_string(swept.join("metrics.csv")).unwrap();
    assert!(
        csv.starts_with("label,integrator,params,sampler,") && csv.contains(",stratified,"),
        "{csv}"
    );

    for (extra, expected) in [
        (vec!["-i", "direct@pmj"], "no sampler `pmj`"),
        (
            vec!["-i", "direct@sobol", "-i", "direct@sobol"],
            "each contestant may be named once",
        ),
        (
            vec!["-i", "direct@sobol", "--sweep", "sampler=halton"],
            "names its sampler already",
        ),
        (
            vec!["-i", "direct", "--sweep", "sampler=halton,nope"],
            "no sampler `nope`",
        ),
    ] {
        let o = raylab_owned(&args(&extra, &dir.path().join("bad")), dir.path());
        assert_eq!(o.status.code(), Some(2), "{extra:?}");
        assert!(stderr(&o).contains(expected), "{extra:?}: {}", stderr(&o));
    }
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
        assert!(r["spp"].as_f64().unwrap() >= 1.0);
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
        // The reference: its integrator, parameters and budget.
        (
            vec!["-i", "path", "--reference-integrator", "nope"],
            "unknown integrator `nope`",
        ),
        (
            vec!["-i", "path", "-p", "reference.bogus=1"],
            "no parameter `bogus`",
        ),
        (
            vec![
                "-i",
                "path",
                "--reference-spp",
                "4",
                "--reference-time",
                "1",
            ],
            "either --reference-spp or --reference-time",
        ),
        (
            vec!["-i", "path", "--reference", "x.exr", "--reference-spp", "4"],
            "give one or the other",
        ),
        (
            vec!["-i", "path", "--reference-time", "0"],
            "--reference-time must be a positive",
        ),
        (
            vec!["-i", "path", "--runs", "0"],
            "--runs must be between 1",
        ),
        (
            vec!["-i", "path", "--target-error", "0"],
            "--target-error must be a positive",
        ),
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

/// pbrt-v4's furnace (radiance 2 everywhere), small.
const FURNACE: &str = r#"(camera: LookAt(eye: (0.1, -0.2, 0.3), look_at: (1, 0.4, 0), up: (0, 0, 1), fov: 60, resolution: (24, 24)),
    materials: {"white": Lambert(albedo: (0.5, 0.5, 0.5))},
    entities: [
        (name: "furnace", shape: Sphere(radius: 1), material: "white", flip_normals: true,
         emitter: Area(radiance: (1, 1, 1))),
    ])"#;

/// The statistics on a case where the answers are known. The furnace's radiance is 2; the
/// reference is that plus Gaussian noise of variance 0.09, which its variance layer states.
/// `whitted` is biased on purpose (it sums emission and one bounce: 1.5, so bias^2 = 0.25
/// per channel, and its answer is exact, so its variance is 0); `path` is unbiased. Over 4
/// runs the squared bias and variance must come out as those, and the reference's noise
/// (0.09, a third of whitted's error) must not be in the MSE.
#[test]
fn bias_and_variance_come_out_as_known_and_the_references_noise_is_subtracted() {
    use rand::{Rng, SeedableRng};
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("furnace.ron");
    // 48x48: the reference's noise averages over 6912 values (its cross term with whitted's
    // bias has a standard deviation of 0.0036).
    common::save(&scene, &FURNACE.replace("(24, 24)", "(48, 48)"));
    let reference = dir.path().join("noisy-reference.exr");
    let mut film = raylab::output::Film::new(48, 48);
    let mut rng = rand::rngs::StdRng::seed_from_u64(4);
    for (p, v) in film.pixels.iter_mut().zip(&mut film.variance) {
        // Box-Muller, sigma 0.3.
        let mut normal = || {
            let (u, w): (f32, f32) = (1.0 - rng.random::<f32>(), rng.random());
            (-2.0 * u.ln()).sqrt() * (std::f32::consts::TAU * w).cos()
        };
        *p = glam::Vec3::new(
            2.0 + 0.3 * normal(),
            2.0 + 0.3 * normal(),
            2.0 + 0.3 * normal(),
        );
        *v = glam::Vec3::splat(0.09);
    }
    film.has_variance = true;
    raylab::output::write_image(&reference, &film, Default::default()).unwrap();
    let out = dir.path().join("stats");
    let o = raylab(
        &[
            "compare",
            s(&scene),
            "-i",
            "whitted",
            "-i",
            "path",
            "--spp",
            "16",
            "--runs",
            "4",
            "--reference",
            s(&reference),
            "-o",
            s(&out),
            "-q",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    let m = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap_or(f64::NAN);
    let (whitted, path) = (&json["rows"][0], &json["rows"][1]);
    println!("whitted: {whitted:#}\npath: {path:#}");
    assert!((m(&json, "reference_variance") - 0.09).abs() < 1e-6);
    // The reference's noise is a third of whitted's error: left in, the MSE would be 0.34.
    assert!((m(whitted, "mse") - 0.25).abs() < 0.015, "whitted MSE");
    assert!((m(whitted, "bias2") - 0.25).abs() < 0.015, "whitted bias^2");
    assert!(m(whitted, "variance") < 1e-9, "whitted's answer is exact");
    assert!(m(whitted, "mse_ci95") < 1e-6, "the same error every run");
    // path: no bias beyond what the reference's noise allows, a variance of its own, and an
    // MSE that is its variance over... its own runs: MSE = variance + bias^2.
    assert!(m(path, "bias2").abs() < 0.015, "path bias^2");
    assert!(m(path, "variance") > 0.005, "path has noise");
    assert!(
        (m(path, "mse") - m(path, "variance") - m(path, "bias2")).abs() < 0.02,
        "MSE = variance + bias^2"
    );
    assert!(m(path, "mse_ci95") > 0.0);
    // MSE against time falls as 1/t for path, not at all for whitted.
    assert!((-1.5..-0.5).contains(&m(path, "slope")), "path slope");
    assert!(m(whitted, "slope").abs() < 0.1, "whitted slope");
    // The target is the best final MSE (path's): whitted never reaches it.
    assert!(whitted["time_to_target"].is_null());
    assert!(m(path, "time_to_target") > 0.0 && m(path, "efficiency") > 0.0);
    // The reference is far noisier than path's error: the page and the log say so.
    assert!(json["reference_warning"]
        .as_str()
        .unwrap()
        .contains("too noisy"));
    assert!(stderr(&o).contains("too noisy"));
    if let Some(dom) = check_page_in_chromium(&out.join("index.html")) {
        assert!(dom.contains("id=\"warning\""));
        // The table shows the intervals.
        assert!(dom.contains(" ± "));
    }
}

/// `diff --ztest`: two independent renders of the same scene agree within their noise; an
/// integrator that misses light fails, with the failing pixels drawn.
#[test]
fn the_z_test_passes_independent_renders_and_fails_a_biased_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = d.join("furnace.ron");
    common::save(&scene, FURNACE);
    let render = |name: &str, integrator: &str, seed: &str| {
        let file = d.join(name);
        let o = raylab(
            &[
                "render",
                s(&scene),
                "-i",
                integrator,
                "--spp",
                "256",
                "--seed",
                seed,
                "-o",
                s(&file),
                "-q",
            ],
            d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        file
    };
    let (a, b) = (render("a.exr", "path", "1"), render("b.exr", "path", "2"));
    let biased = render("w.exr", "whitted", "1");
    let map = d.join("z.png");
    let o = raylab(&["diff", "--ztest", s(&a), s(&b), "-o", s(&map)], d);
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(out.contains("z-test  0 of 576 pixels fail"), "{out}");
    let o = raylab(&["diff", "--ztest", s(&biased), s(&b), "-o", s(&map)], d);
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(
        out.contains("z-test  576 of 576 pixels fail") && out.contains("differs: pixel (0, 0)"),
        "{out}"
    );
    // Every pixel failed: the map is all red.
    let img = image::open(&map).unwrap().to_rgb8();
    assert!(img.pixels().all(|p| p.0 == [255, 32, 32]));
    // Without any variance layer there is nothing to test against.
    // One pass measures no variance: there is nothing to test against; and a PNG is no
    // radiance at all.
    let (one, png) = (d.join("one.exr"), d.join("b.png"));
    for file in [&one, &png] {
        let o = raylab(&["render", s(&scene), "--spp", "1", "-o", s(file), "-q"], d);
        assert!(o.status.success());
    }
    for (a, b, expected) in [
        (&one, &one, "neither image has a variance layer"),
        (&png, &b, "give EXR files"),
    ] {
        let o = raylab(&["diff", "--ztest", s(a), s(b)], d);
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains(expected), "{}", stderr(&o));
    }
    let o = raylab(
        &["diff", "--ztest", "--significance", "1.5", s(&a), s(&b)],
        d,
    );
    assert_eq!(o.status.code(), Some(2));
}

/// The reference can come from another integrator, sized by time, with its own parameters
/// (contradictory or bad reference flags are refused in `compare_rejects_bad_requests`).
#[test]
fn the_reference_integrator_and_its_budget_are_chosen_by_flags() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let o = raylab(
        &[
            "compare",
            CORNELL,
            "-i",
            "path",
            "--size",
            "16x16",
            "--spp",
            "2",
            "--reference-integrator",
            "sppm",
            "-p",
            "reference.photons=2000",
            "--reference-time",
            "0.5",
            "-o",
            s(&out),
            "-q",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    let what = json["reference"].as_str().unwrap();
    assert!(
        what.starts_with("sppm (photons=2000") && what.contains("0.500 s"),
        "{what}"
    );
}

/// `raylab suite`: a matrix from one file, a page per entry and a summary of who wins where;
/// mistakes in the file are refused, naming the file and where, before anything renders.
#[test]
fn a_suite_writes_a_page_per_entry_and_a_summary() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::save(&d.join("furnace.ron"), FURNACE);
    let cornell = common::repo_file(CORNELL);
    let suite = d.join("suite.ron");
    common::save(
        &suite,
        &format!(
            r#"(
    title: "a test",
    budget: Spp(4),
    runs: 2,
    integrators: ["path", "whitted"],
    params: ["path.max-depth=4", "bdpt.max-depth=3"],
    reference: (integrator: "path", spp: 16),
    rank_by: RelMse,
    scenes: [
        (scene: "{}", size: (16, 16)),
        (scene: "furnace.ron", name: "furnace-bdpt", integrators: ["path", "bdpt"], budget: Spp(2)),
    ],
)"#,
            cornell.display()
        ),
    );
    let out = d.join("out");
    let o = raylab(&["suite", s(&suite), "-o", s(&out), "-q"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("cornell_box") && stdout.contains("furnace-bdpt"),
        "{stdout}"
    );
    for page in [
        "index.html",
        "cornell_box/index.html",
        "furnace-bdpt/index.html",
    ] {
        assert!(out.join(page).exists(), "{page}");
    }
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("<a href=\"furnace-bdpt/index.html\">") && html.contains("a test"));
    assert!(html.contains("1 / (relMSE x time)"), "ranked by relMSE");
    // One line per entry and integrator, ranked, the winner at efficiency ratio 1.
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(lines.len(), 4, "{csv}");
    for entry in ["cornell_box", "furnace-bdpt"] {
        let winner = lines
            .iter()
            .find(|l| l.starts_with(&format!("{entry},")) && l.split(',').nth(4) == Some("1"))
            .unwrap_or_else(|| panic!("{entry} has a winner: {csv}"));
        assert_eq!(winner.split(',').nth(12), Some("1.0000"), "{winner}");
    }
    // The entry's settings reached its comparison.
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("furnace-bdpt/metrics.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(json["runs"], 2);
    assert_eq!(
        json["rows"][1]["params"]
            .as_str()
            .unwrap()
            .split(' ')
            .next(),
        Some("max-depth=3")
    );
    assert!(json["budget"].as_str().unwrap().contains("2 spp"));

    // Mistakes, each refused with exit 2 before anything renders.
    for (text, expected) in [
        ("(budget: Spp(1), scenes: [(scene: \"furnace.ron\")], colour: 1)", "suite.ron:1:"),
        ("(budget: Spp(1), scenes: [])", "names no scenes"),
        ("(budget: Spp(1), scenes: [(scene: \"nope.ron\")])", "no such scene file"),
        (
            "(budget: Spp(1), integrators: [\"nope\"], scenes: [(scene: \"furnace.ron\")])",
            "scenes[0] (furnace.ron): unknown integrator `nope`",
        ),
        (
            "(budget: Spp(1), integrators: [\"path\"], scenes: [(scene: \"furnace.ron\"), (scene: \"furnace.ron\")])",
            "the name `furnace` is used twice",
        ),
        (
            "(budget: Time(-1), integrators: [\"path\"], scenes: [(scene: \"furnace.ron\")])",
            "Time must be a positive",
        ),
        (
            "(budget: Spp(1), integrators: [\"path\"], scenes: [(scene: \"furnace.ron\", params: [\"bdpt.max-depth=2\"])])",
            "does not compare",
        ),
        // A region outside the second entry's image: refused before the first renders.
        (
            "(budget: Spp(1), integrators: [\"path\"], scenes: [(scene: \"furnace.ron\"), (scene: \"furnace.ron\", name: \"far\", region: (100, 0, 4, 4))])",
            "region 4x4 at (100, 0) is not inside",
        ),
    ] {
        common::save(&suite, text);
        let bad_out = d.join("bad");
        let o = raylab(&["suite", s(&suite), "-o", s(&bad_out), "-q"], d);
        assert_eq!(o.status.code(), Some(2), "{text}");
        assert!(stderr(&o).contains(expected), "{text}: {}", stderr(&o));
        assert!(!bad_out.exists(), "{text}: nothing is written");
    }
}

/// The cached reference belongs to everything the scene read and how it was read: a `-D`
/// value renders a new one. The cache is tried before anything renders, and an entry that
/// is not a good image (NaN inside) is not used.
#[test]
fn the_reference_cache_is_keyed_by_the_scene_identity_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let scene = repo_file_str("scenes/mitsuba/cornell_box.xml");
    let out = dir.path().join("out");
    let run = |cache: &Path, defines: &[&str]| {
        let mut args = vec![
            "compare",
            &scene,
            "-i",
            "path",
            "--spp",
            "1",
            "--reference-spp",
            "2",
            "--size",
            "16x16",
            "-o",
            s(&out),
            "-q",
        ];
        args.extend_from_slice(defines);
        raylab(&args, cache)
    };
    let rendered = |o: &Output| {
        assert!(o.status.success(), "{}", stderr(o));
        stderr(o).contains("rendering the reference")
    };
    assert!(rendered(&run(&cache, &[])));
    assert!(!rendered(&run(&cache, &[])), "the cached reference is used");
    assert!(
        rendered(&run(&cache, &["-D", "max_depth=3"])),
        "-D is part of the key"
    );
    assert!(!rendered(&run(&cache, &["-D", "max_depth=3"])));
    // Every entry poisoned with a NaN: refused with a warning, rendered anew.
    for entry in std::fs::read_dir(cache.join("raylab")).unwrap() {
        let path = entry.unwrap().path();
        let mut film = raylab::output::Film::new(16, 16);
        film.pixels[5] = glam::Vec3::splat(f32::NAN);
        raylab::output::write_image(&path, &film, Default::default()).unwrap();
    }
    let o = run(&cache, &[]);
    assert!(rendered(&o));
    assert!(
        stderr(&o).contains("not using the cached reference"),
        "{}",
        stderr(&o)
    );
    // A cache that cannot be made: refused before the reference renders.
    let blocked = dir.path().join("blocked");
    std::fs::write(&blocked, "a file where the cache folder should be").unwrap();
    let o = run(&blocked, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("cache folder"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("rendering the reference"));
}

fn repo_file_str(path: &str) -> String {
    common::repo_file(path).to_str().unwrap().to_string()
}
