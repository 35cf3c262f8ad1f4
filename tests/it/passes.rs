//! Rendering in passes: time budgets, Ctrl-C, checkpoint and resume, determinism.

use crate::common::Running;
use crate::common::{raylab, s, stderr};
use std::path::Path;
use std::time::{Duration, Instant};

const CORNELL: &str = "scenes/cornell_box.ron";

/// Every integrator of the registry (none can be forgotten) renders `extra`'s image
/// bit-identically at each of `threads`.
fn every_integrator_is_bit_identical_at(threads: &[&str], extra: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    for integrator in raylab_integrators::REGISTRY.iter().map(|e| e.name) {
        let mut images: Vec<Vec<u8>> = Vec::new();
        for &threads in threads {
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
            args.extend_from_slice(extra);
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
            images.windows(2).all(|w| w[0] == w[1]),
            "{integrator} {extra:?}: the thread count changed the image"
        );
    }
}

#[test]
fn every_integrator_is_bit_identical_at_1_2_and_8_threads() {
    every_integrator_is_bit_identical_at(&["1", "2", "8"], &[]);
}

#[test]
fn every_integrator_is_bit_identical_at_1_and_3_threads_in_spectral_mode() {
    every_integrator_is_bit_identical_at(&["1", "3"], &["--spectral"]);
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
    // The integrators with state across a pass's pixels or across passes: sppm's photon map
    // and vcm's light subpaths depend only on the seed and the pass number; lighttracer's
    // splats are part of each pass's sums; sppm-pixel rebuilds its pixels by replaying passes.
    for (integrator, size, spp, params) in [
        ("sppm", "48x48", "12", &["-p", "photons=5000"][..]),
        ("lighttracer", "96x96", "40", &[]),
        ("vcm", "48x48", "12", &[]),
        ("sppm-pixel", "48x48", "12", &["-p", "photons=5000"]),
    ] {
        let mut args = vec![
            "render", CORNELL, "--size", size, "--spp", spp, "--seed", "9", "-q", "-i", integrator,
        ];
        args.extend_from_slice(params);
        checkpoint_then_resume(&d.join(integrator), &args);
    }
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
    // A budget far shorter than one pass (fixed-depth's pass takes about a second here)
    // still gives the first pass's image, as the help promises.
    let short = dir.path().join("short.png");
    let o = raylab(&[
        "render",
        CORNELL,
        "-i",
        "fixed-depth",
        "--size",
        "96x96",
        "--time",
        "0.001",
        "-o",
        s(&short),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("time budget spent: 1 spp"),
        "{}",
        stderr(&o)
    );
    assert!(short.exists());
}

#[cfg(unix)]
#[test]
fn first_ctrl_c_writes_the_samples_so_far_and_a_second_stops_at_once() {
    let dir = tempfile::tempdir().unwrap();
    // Signals are sent once the first pass is done (its checkpoint exists), not after a
    // guessed delay.
    let start = |name: &str, integrator: &str, size: &str| {
        let (out, ck) = (
            dir.path().join(format!("{name}.png")),
            dir.path().join(name),
        );
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
                s(&out),
                "--checkpoint",
                s(&ck),
            ],
            &dir.path().join(format!("{name}.log")),
            false,
        );
        assert!(
            crate::common::eventually(|| ck.exists()),
            "no first pass: {}",
            r.stderr()
        );
        (r, out)
    };
    // One Ctrl-C: the pass in progress is abandoned and the image written with the others.
    let (r, out) = start("once", "path", "128x128");
    let status = r.interrupt();
    let e = std::fs::read_to_string(dir.path().join("once.log")).unwrap();
    assert!(status.success(), "{e}");
    assert!(
        e.contains("interrupted: wrote the image with") && e.contains("of 100000"),
        "{e}"
    );
    assert!(out.exists());

    // Two (here SIGINT, then SIGTERM, which counts the same): stop at once, exit 130, no
    // image, and no temporary file of the checkpoint being written when the second came
    // (at 2048x2048 the checkpoint is 1.7 GB before compression: its write leaves time for
    // the second signal).
    let (r, out) = start("twice", "albedo", "2048x2048");
    r.signal_interrupt();
    r.wait_stderr("the first interrupt's message", |e| {
        e.contains("interrupt: stopping")
    });
    // Later than a signal delivered twice (to the process, then its group) would come.
    std::thread::sleep(Duration::from_millis(600));
    let status = r.stop_with("TERM");
    assert_eq!(
        status.code(),
        Some(130),
        "{}",
        std::fs::read_to_string(dir.path().join("twice.log")).unwrap()
    );
    assert!(!out.exists());
    crate::common::assert_no_temporaries(dir.path());
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

/// Passes that take long stop within moments of Ctrl-C: the branching recursion of
/// `fixed-depth` and the photon tracing of `sppm` check the request as they go. Settings no
/// pass can finish, or whose photon maps cannot fit in memory, are refused before rendering.
#[cfg(unix)]
#[test]
fn long_passes_stop_at_ctrl_c_and_impossible_ones_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (name, params) in [
        ("fixed-depth", ["-p", "depth=5", "-p", "branching=64"]),
        ("sppm", ["-p", "photons=50000000", "-p", "radius=0.01"]),
    ] {
        let out = dir.path().join(format!("{name}.png"));
        let log = dir.path().join(format!("{name}.log"));
        let mut args = vec![
            "render",
            CORNELL,
            "-i",
            name,
            "--size",
            "64x64",
            "-o",
            s(&out),
        ];
        args.extend_from_slice(&params);
        let r = Running::start(&args, &log, false);
        r.wait_stderr("the start line", |e| e.contains("rendering "));
        std::thread::sleep(std::time::Duration::from_millis(300));
        let asked = std::time::Instant::now();
        let status = r.interrupt();
        let e = std::fs::read_to_string(&log).unwrap();
        assert!(
            asked.elapsed() < std::time::Duration::from_secs(5),
            "{name} took {:?} to stop: {e}",
            asked.elapsed()
        );
        assert_eq!(status.code(), Some(2), "{e}");
        assert!(e.contains("stopped before the first pass finished"), "{e}");
        assert!(!out.exists());
    }
    for (params, message) in [
        (
            [
                "-i",
                "fixed-depth",
                "-p",
                "depth=16",
                "-p",
                "branching=1024",
            ],
            "rays per camera sample",
        ),
        (
            ["-i", "sppm", "-p", "photons=1000000000", "-p", "alpha=0.5"],
            "photon maps",
        ),
    ] {
        let mut args = vec!["render", CORNELL, "--spp", "1", "-q", "-o"];
        let out = dir.path().join("never.png");
        args.push(s(&out));
        args.extend_from_slice(&params);
        let o = raylab(&args);
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains(message), "{}", stderr(&o));
        assert!(!out.exists());
    }
}
