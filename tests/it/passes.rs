//! Rendering in passes: time budgets, Ctrl-C, checkpoint and resume, determinism.

use crate::common::Running;
use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn raylab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(args)
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

#[test]
fn every_integrator_is_bit_identical_at_1_2_and_8_threads() {
    let dir = tempfile::tempdir().unwrap();
    for integrator in [
        "whitted",
        "fixed-depth",
        "russian-roulette",
        "path",
        "photon",
        "sppm",
        "normals",
        "albedo",
        "depth",
    ] {
        let mut images: Vec<Vec<u8>> = Vec::new();
        for threads in ["1", "2", "8"] {
            let out = dir.path().join(format!("{integrator}-{threads}.exr"));
            let mut args = vec![
                "render",
                "scenes/report_room.ron",
                "-i",
                integrator,
                "--size",
                "24x20",
                "--spp",
                "3",
            ];
            match integrator {
                "fixed-depth" => args.extend(["-p", "branching=3", "-p", "shadow-grid=2"]),
                "photon" => args.extend(["-p", "photons=20000", "-p", "caustic-photons=20000"]),
                "sppm" => args.extend(["-p", "photons=20000"]),
                _ => {}
            }
            args.extend(["--threads", threads, "-o", s(&out), "-q"]);
            let o = raylab(&args);
            assert!(o.status.success(), "{integrator}: {}", stderr(&o));
            images.push(std::fs::read(&out).unwrap());
        }
        assert!(
            images[0] == images[1] && images[0] == images[2],
            "{integrator}: the thread count changed the image"
        );
    }
}

/// Renders `common` directly, then stopped after its first pass with a checkpoint, then
/// resumed: the resumed image must be bit-identical to the direct one. Returns the checkpoint.
fn checkpoint_then_resume(d: &Path, common: &[&str]) -> std::path::PathBuf {
    std::fs::create_dir_all(d).unwrap();
    let direct = d.join("direct.exr");
    let o = raylab(&[common, &["-o", s(&direct)]].concat());
    assert!(o.status.success(), "{}", stderr(&o));

    // Stop part-way through with a tiny time budget, leaving a checkpoint...
    let partial = d.join("partial.exr");
    let ck = d.join("render.ck");
    let o = raylab(
        &[
            common,
            &["--time", "0.02", "--checkpoint", s(&ck), "-o", s(&partial)],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("time budget spent"), "{e}");
    assert!(ck.exists());
    assert_ne!(
        std::fs::read(&partial).unwrap(),
        std::fs::read(&direct).unwrap()
    );

    // ... then resume to the end: the image is bit-identical to the direct render.
    let resumed = d.join("resumed.exr");
    let o = raylab(
        &[
            common,
            &["--checkpoint", s(&ck), "--resume", "-o", s(&resumed)],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(&resumed).unwrap(),
        std::fs::read(&direct).unwrap()
    );
    ck
}

#[test]
fn checkpoint_then_resume_equals_a_direct_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // sppm too: each pass's photon map depends only on the seed and the pass number.
    let sppm = [
        "render",
        CORNELL,
        "--size",
        "48x48",
        "--spp",
        "12",
        "--seed",
        "9",
        "-q",
        "-i",
        "sppm",
        "-p",
        "photons=5000",
    ];
    checkpoint_then_resume(&d.join("sppm"), &sppm);
    let common = [
        "render", CORNELL, "--size", "96x96", "--spp", "40", "--seed", "9", "-q",
    ];
    let ck = checkpoint_then_resume(d, &common);

    // Resuming with other settings is refused, and nothing is written.
    let other = d.join("other.exr");
    let o = raylab(&[
        "render",
        CORNELL,
        "--size",
        "96x96",
        "--spp",
        "40",
        "--seed",
        "10",
        "-q",
        "--checkpoint",
        s(&ck),
        "--resume",
        "-o",
        s(&other),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("changed since the checkpoint"),
        "{}",
        stderr(&o)
    );
    assert!(!other.exists());
    let o = raylab(&["render", CORNELL, "--resume", "-o", s(&other)]);
    assert!(
        stderr(&o).contains("--resume needs --checkpoint"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn time_budget_stops_an_open_ended_render() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.png");
    let start = Instant::now();
    let o = raylab(&[
        "render",
        CORNELL,
        "--size",
        "64x64",
        "--time",
        "0.5",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(start.elapsed() < Duration::from_secs(20));
    assert!(stderr(&o).contains("time budget spent"), "{}", stderr(&o));
    assert!(out.exists());
    for bad in ["0", "-1", "nan"] {
        let o = raylab(&["render", CORNELL, "--time", bad, "-o", s(&out)]);
        assert_eq!(o.status.code(), Some(2), "--time {bad}");
    }
}

#[cfg(unix)]
#[test]
fn first_ctrl_c_writes_the_samples_so_far_and_a_second_stops_at_once() {
    let dir = tempfile::tempdir().unwrap();
    // Signals are sent once raylab says it is rendering (its handler is installed by then),
    // not after a guessed delay.
    let start = |out: &Path, integrator: &str, size: &str, log: &str| {
        let r = Running::start(
            &[
                "render",
                CORNELL,
                "-i",
                integrator,
                "--size",
                size,
                "--spp",
                "100000",
                "-o",
                s(out),
            ],
            &dir.path().join(log),
            false,
        );
        r.wait_stderr("the start line", |e| e.contains("rendering "));
        r
    };
    // One Ctrl-C: the current pass ends and the image is written with what it has.
    let out = dir.path().join("once.png");
    let r = start(&out, "path", "128x128", "once.log");
    let status = r.interrupt();
    let e = std::fs::read_to_string(dir.path().join("once.log")).unwrap();
    assert!(status.success(), "{e}");
    assert!(
        e.contains("interrupted: wrote the image with") && e.contains("of 100000"),
        "{e}"
    );
    assert!(out.exists());

    // Two: stop at once, nothing written. (fixed-depth's passes take seconds here, so the
    // second signal, sent once the first is acknowledged, arrives before the pass ends.)
    let out = dir.path().join("twice.png");
    let r = start(&out, "fixed-depth", "768x768", "twice.log");
    r.signal_interrupt();
    r.wait_stderr("the first interrupt's message", |e| {
        e.contains("interrupt: finishing this pass")
    });
    let status = r.interrupt();
    assert_eq!(
        status.code(),
        Some(130),
        "{}",
        std::fs::read_to_string(dir.path().join("twice.log")).unwrap()
    );
    assert!(!out.exists());
}

/// A checkpoint is tied to the mesh files the scene names, not only to the scene file: after
/// an edit to the OBJ, resuming is refused. How the scene's path is spelled does not matter.
#[test]
fn editing_a_mesh_file_invalidates_the_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("assets")).unwrap();
    for f in ["assets/pyramid.obj", "assets/panel.gltf"] {
        std::fs::copy(Path::new("scenes").join(f), d.join(f)).unwrap();
    }
    let scene = d.join("mesh_files.ron");
    std::fs::copy("scenes/mesh_files.ron", &scene).unwrap();
    let ck = d.join("ck.bin");
    let render = |scene: &Path, out: &str, resume: bool| {
        let out = d.join(out);
        let mut args = vec![
            "render",
            s(scene),
            "--size",
            "32x32",
            "--spp",
            "4",
            "-q",
            "--checkpoint",
            s(&ck),
        ];
        if resume {
            args.push("--resume");
        }
        args.extend(["-o", s(&out)]);
        raylab(&args)
    };
    // A first render writes the checkpoint; resuming it works, through another spelling of
    // the same path (the hash is of contents, not paths).
    let first = render(&scene, "first.exr", false);
    assert!(first.status.success(), "{}", stderr(&first));
    let respelled = d.join(".").join("mesh_files.ron");
    let o = render(&respelled, "resumed.exr", true);
    assert!(o.status.success(), "{}", stderr(&o));
    // Edit the OBJ (a comment is enough: the hash is of its bytes); the scene file is unchanged.
    let obj = d.join("assets/pyramid.obj");
    let text = std::fs::read_to_string(&obj).unwrap();
    std::fs::write(&obj, format!("{text}\n# edited\n")).unwrap();
    let o = render(&scene, "after-edit.exr", true);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("changed since the checkpoint"),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("after-edit.exr").exists());
}
