//! Shards (`render --shard I/N`) merged (`raylab merge`) into the single run's image, byte for
//! byte; the refusals of parts that do not make one render; and the schedulers that run the
//! shards: GNU parallel, and a real Slurm cluster (`scripts/slurm/render.sh`).
//!
//! The scheduler tests need their tools: `.ci/run` installs them, starts a three-node Slurm
//! cluster (`scripts/slurm/local-cluster.sh`) and sets `RAYLAB_CLUSTER_TESTS=1`, which makes a missing tool a failure. Without it
//! (a developer's machine) they say what they skipped.

use crate::common::{raylab, s, stderr};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The report's room at 12x100 (seven rows of tiles, for seven shards by rows), 49 passes
/// (seven blocks of eight, for seven shards by passes), with cheap settings for the
/// integrators that cast many rays.
fn render_args<'a>(integrator: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "render",
        "scenes/report_room.ron",
        "-i",
        integrator,
        "--size",
        "12x100",
        "--spp",
        "49",
        "-q",
    ];
    let entry = raylab_integrators::find(integrator).unwrap();
    for p in entry.params {
        match p.name {
            "photons" => args.extend(["-p", "photons=2000"]),
            "caustic-photons" => args.extend(["-p", "caustic-photons=2000"]),
            _ => {}
        }
    }
    if integrator == "fixed-depth" {
        args.extend(["-p", "depth=2", "-p", "branching=2", "-p", "shadow-grid=1"]);
    }
    args.extend_from_slice(extra);
    args
}

/// Renders shards `0..n` of `args` into `dir` (shard `i` on `1 + i % 3` threads) and returns
/// their paths.
fn render_shards(dir: &Path, args: &[&str], n: u32) -> Vec<PathBuf> {
    (0..n)
        .map(|i| {
            let part = dir.join(format!("part-{i}of{n}.exr"));
            let (spec, threads) = (format!("{i}/{n}"), (1 + i % 3).to_string());
            let o = raylab(
                &[
                    args,
                    &["--shard", &spec, "--threads", &threads, "-o", s(&part)],
                ]
                .concat(),
            );
            assert!(o.status.success(), "{args:?} {spec}: {}", stderr(&o));
            part
        })
        .collect()
}

/// Renders `args` whole into `dir/single.exr`.
fn render_single(dir: &Path, args: &[&str]) -> PathBuf {
    let single = dir.join("single.exr");
    let o = raylab(&[args, &["-o", s(&single)]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    single
}

fn merge(out: &Path, parts: &[PathBuf]) -> Output {
    let mut args = vec!["merge", "-q", "-o", s(out)];
    args.extend(parts.iter().map(|p| s(p)));
    raylab(&args)
}

#[test]
fn every_integrator_merges_into_the_single_run_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    // Every integrator of the registry: none can be forgotten.
    for entry in raylab_integrators::REGISTRY {
        let name = entry.name;
        let args = render_args(name, &[]);
        let single = dir.path().join(format!("{name}.exr"));
        let o = raylab(&[&args[..], &["--threads", "2", "-o", s(&single)]].concat());
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let single_bytes = std::fs::read(&single).unwrap();
        for n in [1, 2, 3, 7] {
            let parts = render_shards(dir.path(), &args, n);
            let merged = dir.path().join(format!("{name}-merged-{n}.exr"));
            let o = merge(&merged, &parts);
            assert!(o.status.success(), "{name}, {n} shards: {}", stderr(&o));
            assert!(
                std::fs::read(&merged).unwrap() == single_bytes,
                "{name}: {n} shards merged differ from the single run"
            );
        }
    }
}

/// In spectral mode too: each sample's wavelengths, and each pass's, are the render's.
#[test]
fn every_integrator_merges_byte_for_byte_in_spectral_mode() {
    let dir = tempfile::tempdir().unwrap();
    for entry in raylab_integrators::REGISTRY {
        let name = entry.name;
        let args = render_args(name, &["--spectral"]);
        let single = dir.path().join(format!("{name}.exr"));
        let o = raylab(&[&args[..], &["--threads", "2", "-o", s(&single)]].concat());
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let parts = render_shards(dir.path(), &args, 3);
        let merged = dir.path().join(format!("{name}-merged.exr"));
        let o = merge(&merged, &parts);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert!(
            std::fs::read(&merged).unwrap() == std::fs::read(&single).unwrap(),
            "{name}: spectral shards merged differ from the single run"
        );
    }
    // A spectral shard is not a part of an RGB render.
    let rgb = render_shards(dir.path(), &render_args("path", &[]), 2);
    let spectral = dir.path().join("spectral-part.exr");
    let args = render_args("path", &["--spectral"]);
    let o = raylab(&[&args[..], &["--shard", "1/2", "-o", s(&spectral)]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = merge(&dir.path().join("mixed.exr"), &[rgb[0].clone(), spectral]);
    assert!(!o.status.success(), "an RGB and a spectral shard merged");
}

#[test]
fn shards_merge_exactly_with_wider_filters_and_into_png() {
    let dir = tempfile::tempdir().unwrap();
    for (name, filter) in [
        ("path", "gaussian"),
        ("sppm-pixel", "tent"),
        ("bdpt", "tent"),
    ] {
        let args = render_args(name, &["--filter", filter, "--exposure", "1"]);
        for ext in ["exr", "png"] {
            let single = dir.path().join(format!("{name}.{ext}"));
            let o = raylab(&[&args[..], &["-o", s(&single)]].concat());
            assert!(o.status.success(), "{name}: {}", stderr(&o));
            let parts = render_shards(dir.path(), &args, 3);
            let merged = dir.path().join(format!("{name}-merged.{ext}"));
            let o = merge(&merged, &parts);
            assert!(o.status.success(), "{name}: {}", stderr(&o));
            assert!(
                std::fs::read(&merged).unwrap() == std::fs::read(&single).unwrap(),
                "{name}, {filter}, {ext}: merged differs from single"
            );
        }
    }
}

#[test]
fn a_stopped_shard_resumes_its_own_part_and_no_other() {
    let dir = tempfile::tempdir().unwrap();
    // Big enough that shard 1 is still rendering when its first checkpoint is written.
    let mut args = render_args("path", &[]);
    args[5] = "240x100";
    let direct = render_shards(dir.path(), &args, 3);
    let ck = dir.path().join("shard1.ck");
    let part = dir.path().join("stopped.exr");
    // A time budget and a shard do not mix: refused before anything renders.
    let o = raylab(
        &[
            &args[..],
            &["--shard", "1/3", "--time", "0.001", "-o", s(&part)],
        ]
        .concat(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("time budget"), "{}", stderr(&o));
    // Shard 1 preempted (SIGTERM, as Slurm sends) after its first checkpoint.
    let mut child = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(&args[..])
        .args(["--shard", "1/3", "--threads", "1", "--checkpoint", s(&ck)])
        .args(["-o", s(&part)])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while !ck.exists() && start.elapsed() < std::time::Duration::from_secs(60) {
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    assert!(ck.exists(), "no checkpoint was written");
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    // It writes its part of the passes done and exits 75 (not done: a scheduler retries it);
    // merge refuses the part.
    assert_eq!(child.wait().unwrap().code(), Some(75));
    let merged = dir.path().join("merged.exr");
    let o = merge(
        &merged,
        &[direct[0].clone(), part.clone(), direct[2].clone()],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("stopped after pass"), "{}", stderr(&o));
    // Resumed as another shard: refused.
    let other = dir.path().join("other.exr");
    let o = raylab(
        &[
            &args[..],
            &[
                "--shard",
                "2/3",
                "--checkpoint",
                s(&ck),
                "--resume",
                "-o",
                s(&other),
            ],
        ]
        .concat(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("changed"), "{}", stderr(&o));
    // Resumed as itself: the same bytes as the shard rendered at once, and it merges.
    let o = raylab(
        &[
            &args[..],
            &[
                "--shard",
                "1/3",
                "--checkpoint",
                s(&ck),
                "--resume",
                "-o",
                s(&part),
            ],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read(&part).unwrap() == std::fs::read(&direct[1]).unwrap());
    let o = merge(&merged, &[direct[0].clone(), part, direct[2].clone()]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Rewrites the line `key=...` of the shard file's description (its `raylabShard` header
/// attribute) as `key=value`.
fn set_attribute(path: &Path, key: &str, value: &str) {
    use exr::prelude::*;
    let mut image = read_all_data_from_file(path).unwrap();
    let other = &mut image.layer_data[0].attributes.other;
    let Some(AttributeValue::Text(text)) = other.get(&Text::from("raylabShard")) else {
        panic!("{} is not a shard", path.display());
    };
    let edited: String = String::from_utf8_lossy(text.bytes())
        .lines()
        .map(|l| match l.split_once('=') {
            Some((k, _)) if k == key => format!("{key}={value}\n"),
            _ => format!("{l}\n"),
        })
        .collect();
    other.insert(
        Text::from("raylabShard"),
        AttributeValue::Text(Text::from(edited.as_str())),
    );
    image.write().to_file(path).unwrap();
}

#[test]
fn merge_refuses_parts_that_are_not_one_whole_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let args = render_args("path", &[]);
    let parts = render_shards(d, &args, 3);
    let copy = |from: &Path, name: &str| {
        let to = d.join(name);
        std::fs::copy(from, &to).unwrap();
        to
    };
    let render_to = |name: &str, extra: &[&str]| {
        let out = d.join(name);
        let o = raylab(&[&args[..], extra, &["-o", s(&out)]].concat());
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        out
    };
    let other_scene = {
        let out = d.join("other-scene.exr");
        let mut a = args.clone();
        a[1] = "scenes/cornell_box.ron";
        let o = raylab(&[&a[..], &["--shard", "1/3", "-o", s(&out)]].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        out
    };
    let other_seed = render_to("other-seed.exr", &["--shard", "1/3", "--seed", "9"]);
    let other_split = render_to("other-split.exr", &["--shard", "1/4"]);
    let plain = render_to("plain.exr", &[]);
    let png = render_to("plain.png", &[]);
    let old = copy(&parts[1], "old-version.exr");
    set_attribute(&old, "version", "0.0.1");
    let edited = copy(&parts[1], "edited.exr");
    set_attribute(&edited, "part", "passes 8..24");
    let cut_short = copy(&parts[1], "cut-short.exr");
    set_attribute(&cut_short, "passes-done", "20");
    // A header that claims a 4096x4096 image in a file of a few kilobytes: its windows'
    // corners rewritten in place.
    let forged = copy(&parts[1], "forged.exr");
    let mut bytes = std::fs::read(&forged).unwrap();
    for name in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
        let at = bytes.windows(name.len()).position(|w| w == name).unwrap() + name.len() + 4;
        for (k, v) in [0i32, 0, 4095, 4095].into_iter().enumerate() {
            bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(&forged, bytes).unwrap();
    let [p0, p1, p2] = [&parts[0], &parts[1], &parts[2]].map(|p| p.clone());
    let missing = d.join("nowhere.exr");
    let out = d.join("merged.exr");
    let cases: Vec<(&str, Vec<PathBuf>, Vec<&str>)> = vec![
        (
            "another scene",
            vec![p0.clone(), other_scene, p2.clone()],
            vec!["other-scene.exr", "another scene", "cornell_box.ron"],
        ),
        (
            "other settings",
            vec![p0.clone(), other_seed, p2.clone()],
            vec!["other-seed.exr", "seed=9 where it has seed=0"],
        ),
        (
            "another split",
            vec![p0.clone(), p1.clone(), other_split],
            vec!["other-split.exr", "split in 4"],
        ),
        (
            "another version",
            vec![p0.clone(), old, p2.clone()],
            vec!["old-version.exr", "raylab 0.0.1"],
        ),
        (
            "an edited part",
            vec![p0.clone(), edited, p2.clone()],
            vec!["edited.exr", "passes 8..24", "passes 16..32"],
        ),
        (
            "a part cut short",
            vec![p0.clone(), cut_short, p2.clone()],
            vec!["cut-short.exr", "stopped after pass 20", "--resume"],
        ),
        (
            "a header claiming more than the file holds",
            vec![p0.clone(), forged, p2.clone()],
            vec!["forged.exr", "4096x4096", "more than a file of"],
        ),
        (
            "a missing shard",
            vec![p0.clone(), p2.clone()],
            vec!["1 of 3 shards missing", "1/3 (passes 16..32)"],
        ),
        (
            "a duplicate shard",
            vec![p0.clone(), p1.clone(), copy(&p1, "again.exr"), p2.clone()],
            vec!["again.exr", "both shard 1/3"],
        ),
        (
            "the same file twice",
            vec![p0.clone(), p1.clone(), p1.clone(), p2.clone()],
            vec!["given twice"],
        ),
        (
            "a render that is no shard",
            vec![p0.clone(), plain, p2.clone()],
            vec!["plain.exr", "not a raylab shard"],
        ),
        (
            "a PNG",
            vec![p0.clone(), png, p2.clone()],
            vec!["plain.png", "not an EXR"],
        ),
        (
            "a file that does not exist",
            vec![p0.clone(), missing, p2.clone()],
            vec!["nowhere.exr"],
        ),
        (
            "the output among the parts",
            vec![p0.clone(), p1.clone(), p2.clone(), out.clone()],
            vec!["merged.exr"],
        ),
    ];
    std::fs::write(&out, b"not yet").unwrap();
    for (what, case, expected) in cases {
        let o = merge(&out, &case);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{what}: {e}");
        for x in expected {
            assert!(e.contains(x), "{what}: `{x}` not in: {e}");
        }
        assert_eq!(
            std::fs::read(&out).unwrap(),
            b"not yet",
            "{what}: output touched"
        );
    }
    // The parts themselves merge.
    std::fs::remove_file(&out).unwrap();
    let o = merge(&out, &[p2, p0, p1]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A merge keeps every part open: one of more parts than the process may open files is refused
/// before any is read, saying which limit to raise.
#[test]
fn a_merge_past_the_open_files_limit_says_so() {
    if !cfg!(target_os = "linux") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let parts = render_shards(dir.path(), &render_args("path", &[]), 7);
    let out = dir.path().join("merged.exr");
    let o = Command::new("sh")
        .arg("-c")
        .arg("ulimit -n 20 && exec \"$0\" merge -o \"$@\"")
        .arg(env!("CARGO_BIN_EXE_raylab"))
        .arg(&out)
        .args(&parts)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("merging 7 parts") && e.contains("ulimit -n 23"),
        "{e}"
    );
    assert!(!out.exists());
}

#[test]
fn a_merged_render_is_a_reference() {
    let dir = tempfile::tempdir().unwrap();
    let args = render_args("path", &[]);
    let parts = render_shards(dir.path(), &args, 2);
    let reference = dir.path().join("reference.exr");
    assert!(merge(&reference, &parts).status.success());
    let out = dir.path().join("cmp");
    let o = raylab(&[
        "compare",
        "scenes/report_room.ron",
        "--reference",
        s(&reference),
        "-i",
        "path",
        "-i",
        "direct",
        "--size",
        "12x100",
        "--spp",
        "4",
        "-o",
        s(&out),
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = std::fs::read_to_string(out.join("metrics.json")).unwrap();
    // The merged reference carries its noise, which compare reads and subtracts.
    let value: serde_json::Value = serde_json::from_str(&report).unwrap();
    let variance = value["reference_variance"].as_f64().unwrap();
    assert!(variance > 0.0, "{report}");
}

/// Whether the scheduler tests must run (CI), else they may skip.
fn cluster_tests_required() -> bool {
    std::env::var("RAYLAB_CLUSTER_TESTS").is_ok_and(|v| v == "1")
}

fn have(tool: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {tool}")])
        .output()
        .is_ok_and(|o| o.status.success())
}

#[test]
fn gnu_parallel_renders_the_shards() {
    if !have("parallel") {
        assert!(!cluster_tests_required(), "GNU parallel is not installed");
        eprintln!("skipped: GNU parallel is not installed");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let args = render_args("path", &[]);
    let single = render_single(dir.path(), &args);
    // The documented command: parallel raylab render ... --shard {}/N -o part-{}.exr ::: 0..N-1
    let o = Command::new("parallel")
        .args(["--halt", "now,fail=1", env!("CARGO_BIN_EXE_raylab")])
        .args(&args[..])
        .args(["--threads", "1", "--shard", "{}/3"])
        .arg("-o")
        .arg(dir.path().join("part-{}.exr"))
        .args([":::", "0", "1", "2"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let parts: Vec<PathBuf> = (0..3)
        .map(|i| dir.path().join(format!("part-{i}.exr")))
        .collect();
    let merged = dir.path().join("merged.exr");
    assert!(merge(&merged, &parts).status.success());
    assert!(std::fs::read(&merged).unwrap() == std::fs::read(&single).unwrap());
}

#[test]
fn a_slurm_job_array_renders_and_merges_the_shards() {
    if !have("sbatch")
        || !Command::new("sinfo")
            .output()
            .is_ok_and(|o| o.status.success())
    {
        assert!(
            !cluster_tests_required(),
            "no Slurm cluster answers (scripts/slurm/local-cluster.sh start)"
        );
        eprintln!("skipped: no Slurm cluster (scripts/slurm/local-cluster.sh start)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let args = render_args("path", &[]);
    let single = render_single(dir.path(), &args);
    let out = dir.path().join("cluster.exr");
    // scripts/slurm/render.sh [--wait] SCENE N OUT [raylab render flags]: four shards and a
    // merge that depends on them.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = root.join("scenes/report_room.ron");
    let flags: Vec<&str> = args[4..].iter().copied().filter(|a| *a != "-q").collect();
    let o = Command::new(root.join("scripts/slurm/render.sh"))
        .args(["--wait", s(&scene), "4", s(&out)])
        .args(&flags)
        .env("RAYLAB", env!("CARGO_BIN_EXE_raylab"))
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        stderr(&o)
    );
    assert!(
        std::fs::read(&out).unwrap() == std::fs::read(&single).unwrap(),
        "the cluster's merged image differs from the single run"
    );
}
