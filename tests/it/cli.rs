//! The `raylab` program as a user runs it: rendering, listing, validating, determinism, and
//! bad input (exit code 2, a message naming the file and place, no output file left behind).

use crate::common::{raylab, s, stderr};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

const ROOM: &str = "scenes/report_room.ron";
const CORNELL: &str = "scenes/cornell_box.ron";

#[test]
fn renders_the_report_room_to_png_and_reports_rays_per_second() {
    let dir = tmp();
    let out = dir.path().join("room.png");
    let o = raylab(&[
        "render",
        ROOM,
        "-i",
        "albedo",
        "--spp",
        "1",
        "--size",
        "64x64",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(&out).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (64, 64));
    // The left wall is yellow, the right one red (as in the report's figures).
    let left = img.get_pixel(2, 32);
    let right = img.get_pixel(61, 32);
    assert!(
        left[0] > 150 && left[1] > 150 && left[2] < 100,
        "left wall {left:?}"
    );
    assert!(right[0] > 150 && right[1] < 100, "right wall {right:?}");
    let e = stderr(&o);
    assert!(
        e.contains("M rays/s") && e.contains("M samples/s") && e.contains("camera 4096"),
        "{e}"
    );
}

#[test]
fn every_integrators_exr_is_bit_identical_at_one_and_two_threads() {
    // Every registry entry. The obvhs backend finds the same first hits: the normals view is
    // the same image on it (paths that meet a ray only the BVHs' boxes decide, at an edge,
    // continue with other random numbers, so light transport agrees only statistically;
    // `accel::instance_tests` measures the hit agreement).
    let dir = tmp();
    for entry in raylab_integrators::REGISTRY {
        let integrator = entry.name;
        let mut files: Vec<Vec<u8>> = Vec::new();
        let mut runs = vec![("1", "raylab"), ("2", "raylab")];
        if integrator == "normals" {
            runs.push(("2", "obvhs"));
        }
        for (threads, accel) in runs {
            let out = dir
                .path()
                .join(format!("{integrator}-{threads}-{accel}.exr"));
            let mut args = vec!["render", CORNELL, "-i", integrator, "--spp", "4"];
            if integrator == "fixed-depth" {
                args.extend(["-p", "branching=3"]);
            }
            args.extend([
                "--size",
                "48x40",
                "--threads",
                threads,
                "--accel",
                accel,
                "-o",
                s(&out),
                "-q",
            ]);
            let o = raylab(&args);
            assert!(o.status.success(), "{integrator}: {}", stderr(&o));
            files.push(std::fs::read(&out).unwrap());
        }
        assert!(
            files[0] == files[1],
            "{integrator}: thread count changed the image"
        );
        if let Some(obvhs) = files.get(2) {
            assert!(files[1] == *obvhs, "{integrator}: obvhs gave another image");
        }
    }
}

#[test]
fn exr_holds_linear_radiance_above_one() {
    let dir = tmp();
    let out = dir.path().join("c.exr");
    let o = raylab(&[
        "render",
        CORNELL,
        "-i",
        "albedo",
        "--spp",
        "1",
        "-o",
        s(&out),
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(&out).unwrap().to_rgb32f();
    let max = img.pixels().map(|p| p[0]).fold(0.0f32, f32::max);
    // The light's radiance (18.387 in red) survives unscaled.
    assert!((max - 18.387).abs() < 1e-3, "max {max}");
}

#[test]
fn integrators_lists_every_integrator_with_parameters() {
    let o = raylab(&["integrators"]);
    assert!(o.status.success());
    let text = stdout(&o);
    // Every entry of the registry, and nothing else, in the registry's order.
    let listed: Vec<&str> = text
        .lines()
        .filter(|l| !l.is_empty() && !l.starts_with(' ') && !l.contains(' '))
        .collect();
    let registry: Vec<&str> = raylab_integrators::REGISTRY
        .iter()
        .map(|e| e.name)
        .collect();
    assert_eq!(listed, registry, "{text}");
    assert!(text.contains("-p branching=<int>  (default 20)"), "{text}");
    assert!(
        text.contains("-p max-depth=<depth>  (default unlimited)"),
        "{text}"
    );
}

#[test]
fn validate_prints_counts_and_bounds() {
    let o = raylab(&["validate", ROOM]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("triangles  26")
            && text.contains("spheres    2")
            && text.contains("emitters   1"),
        "{text}"
    );
    assert!(
        text.contains("(-3.000, -6.000, -5.000) .. (13.000, 6.000, 5.000)"),
        "{text}"
    );
    let o = raylab(&["validate", CORNELL]);
    assert!(stdout(&o).contains("triangles  36"), "{}", stdout(&o));
}

/// Runs a render that must fail: exit code 2, the expected words in the message, no panic,
/// and no output file.
fn expect_failure(args: &[&str], out: &Path, expected: &[&str]) {
    let mut all: Vec<&str> = vec!["render"];
    all.extend_from_slice(args);
    let o = raylab(&all);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
    assert!(!e.contains("panicked"), "{args:?} panicked: {e}");
    for word in expected {
        assert!(e.contains(word), "{args:?}: expected `{word}` in: {e}");
    }
    assert!(!out.exists(), "{args:?} left {}", out.display());
}

fn write_scene(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const GOOD: &str = r#"(
    camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (8, 8)),
    materials: {"w": Lambert(albedo: (0.5, 0.5, 0.5))},
    entities: [
        (name: "ball", shape: Sphere(radius: 1), material: "w"),
    ],
)"#;

#[test]
fn bad_scene_files_fail_cleanly_with_file_line_and_column() {
    let dir = tmp();
    let d = dir.path();
    let out = d.join("out.png");
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "truncated.ron",
            GOOD[..GOOD.len() / 2].to_string(),
            vec!["truncated.ron:"],
        ),
        (
            "syntax.ron",
            GOOD.replace("fov: 40,", "fov: 40,,"),
            vec!["syntax.ron:2:"],
        ),
        (
            "unknown_field.ron",
            GOOD.replace("radius: 1", "radus: 1"),
            vec!["unknown_field.ron:5:", "radus"],
        ),
        (
            "wrong_type.ron",
            GOOD.replace("radius: 1", "radius: \"big\""),
            vec!["wrong_type.ron:5:"],
        ),
        (
            "unknown_variant.ron",
            GOOD.replace("Sphere(", "Spear("),
            vec!["unknown_variant.ron:5:", "Spear"],
        ),
        (
            "missing_material.ron",
            GOOD.replace("material: \"w\"", "material: \"x\""),
            vec!["entity `ball`", "unknown material `x`"],
        ),
        (
            "negative_radius.ron",
            GOOD.replace("radius: 1", "radius: -1"),
            vec!["entity `ball`", "radius must be positive"],
        ),
        (
            "nan.ron",
            GOOD.replace("eye: (0, 0, 5)", "eye: (0, NaN, 5)"),
            vec!["camera", "finite"],
        ),
        (
            "zero_res.ron",
            GOOD.replace("(8, 8)", "(0, 8)"),
            vec!["camera", "at least 1x1"],
        ),
        (
            "huge_res.ron",
            GOOD.replace("(8, 8)", "(60000, 60000)"),
            vec!["too large"],
        ),
        (
            "no_entities.ron",
            GOOD.replace(
                "(name: \"ball\", shape: Sphere(radius: 1), material: \"w\"),",
                "",
            ),
            vec!["no entities"],
        ),
    ];
    for (name, text, expected) in cases {
        let scene = write_scene(d, name, &text);
        let mut words = vec![name];
        words.extend(expected);
        expect_failure(&[s(&scene), "-o", s(&out), "-q"], &out, &words);
    }
    expect_failure(
        &["does/not/exist.ron", "-o", s(&out)],
        &out,
        &["does/not/exist.ron", "cannot read"],
    );
}

#[test]
fn bad_command_lines_fail_cleanly() {
    let dir = tmp();
    let out = dir.path().join("out.png");
    let o = s(&out);
    expect_failure(
        &[CORNELL, "-i", "pathh", "-o", o],
        &out,
        &["unknown integrator `pathh`", "valid integrators", "path"],
    );
    expect_failure(
        &[CORNELL, "-i", "path", "-p", "maxdepth=3", "-o", o],
        &out,
        &["no parameter `maxdepth`", "max-depth"],
    );
    expect_failure(
        &[CORNELL, "-i", "path", "-p", "max-depth=-1", "-o", o],
        &out,
        &["max-depth", "out of range"],
    );
    expect_failure(
        &[CORNELL, "-i", "path", "-p", "max-depth", "-o", o],
        &out,
        &["NAME=VALUE"],
    );
    expect_failure(
        &[CORNELL, "--spp", "0", "-o", o],
        &out,
        &["--spp must be at least 1"],
    );
    expect_failure(
        &[CORNELL, "--threads", "0", "-o", o],
        &out,
        &["--threads must be at least 1"],
    );
    expect_failure(
        &[CORNELL, "--threads", "10000", "-o", o],
        &out,
        &["--threads 10000: at most", "per core"],
    );
    expect_failure(
        &[CORNELL, "--size", "0x10", "-o", o],
        &out,
        &["at least 1x1"],
    );
    expect_failure(
        &[CORNELL, "--size", "100000x100000", "-o", o],
        &out,
        &["too large"],
    );
    expect_failure(
        &[CORNELL, "--size", "big", "-o", o],
        &out,
        &["WIDTHxHEIGHT"],
    );
    let missing = dir.path().join("no/such/folder/x.png");
    expect_failure(&[CORNELL, "-o", s(&missing)], &missing, &["does not exist"]);
    let bad_ext = dir.path().join("x.jpg");
    expect_failure(
        &[CORNELL, "-o", s(&bad_ext)],
        &bad_ext,
        &["unknown output extension"],
    );
    // Usage errors from the argument parser also exit with 2.
    expect_failure(&[CORNELL, "--bogus"], &out, &["--bogus"]);
}

#[cfg(unix)]
#[test]
fn unwritable_output_folder_fails_and_an_existing_file_survives() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tmp();
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    let out = locked.join("old.png");
    std::fs::write(&out, b"old image").unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    // Root ignores permissions: only check where the folder is really read-only.
    if tempfile::NamedTempFile::new_in(&locked).is_err() {
        let o = raylab(&["render", CORNELL, "--spp", "1", "-o", s(&out), "-q"]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("cannot write"), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read(&out).unwrap(), b"old image");
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn the_readmes_integrator_table_is_the_registry() {
    // One row per registry entry, in order, with the summary `raylab integrators` prints.
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let rows: Vec<(String, String)> = readme
        .lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.strip_prefix("| `")?.splitn(2, "` | ").collect();
            let summary = cells.get(1)?.trim_end().strip_suffix(" |")?;
            Some((cells[0].to_string(), summary.to_string()))
        })
        .collect();
    let registry: Vec<(String, String)> = raylab_integrators::REGISTRY
        .iter()
        .map(|e| (e.name.to_string(), e.summary.to_string()))
        .collect();
    assert_eq!(rows, registry, "README.md's integrator table");
}

#[test]
fn photon_rays_are_counted_as_light_rays() {
    // The summary counts rays by kind; photons are traced from the lights.
    let dir = tmp();
    let count = |integrator: &str, kind: &str| -> u64 {
        let out = dir.path().join(format!("{integrator}.exr"));
        let o = raylab(&[
            "render",
            CORNELL,
            "-i",
            integrator,
            "--spp",
            "2",
            "--size",
            "24x24",
            "-o",
            s(&out),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let e = stderr(&o);
        let at = e.find(&format!("{kind} ")).unwrap_or_else(|| panic!("{e}"));
        e[at + kind.len() + 1..]
            .split(|c: char| !c.is_ascii_digit())
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    assert!(count("sppm", "light") > 1000);
    assert_eq!(count("path", "light"), 0);
    assert_eq!(count("path", "connection"), 0);
    assert!(count("path", "extension") > 0);
}

/// A reader that goes away before the output is written (`raylab integrators | head -1`)
/// neither panics the program nor changes its exit status.
#[test]
fn a_closed_output_pipe_is_not_a_panic() {
    for args in [
        &["integrators"][..],
        &["validate", "scenes/cornell_box.ron"],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_raylab"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Close the reading end before the program writes.
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        assert!(
            o.status.success(),
            "{args:?}: {:?} {}",
            o.status,
            stderr(&o)
        );
        assert!(!stderr(&o).contains("panicked"), "{args:?}: {}", stderr(&o));
    }
}

/// `bdpt -p write-strategies=1` writes one image per strategy `(s, t)` of at most
/// `max-depth` scattering events beside the output; with the box filter they add up to the
/// image, pixel by pixel. Checkpoints do not keep them: asking for both is refused.
#[test]
fn bdpt_writes_its_strategies_images_and_they_add_up_to_the_image() {
    let d = tmp();
    let out = d.path().join("b.exr");
    let o = raylab(&[
        "render",
        CORNELL,
        "-i",
        "bdpt",
        "-p",
        "max-depth=3",
        "-p",
        "write-strategies=1",
        "--spp",
        "8",
        "--size",
        "32x32",
        "-q",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let image = raylab::output::read_image(&out).unwrap();
    let mut sum = vec![glam::Vec3::ZERO; image.pixels.len()];
    let mut count = 0;
    for depth in 0..=3 {
        for st in 0..=depth + 1 {
            let t = depth + 2 - st;
            if st == 1 && t == 1 {
                continue;
            }
            let layer = raylab::output::read_image(&d.path().join(format!("b_s{st}_t{t}.exr")))
                .unwrap_or_else(|e| panic!("s{st}_t{t}: {e}"));
            for (a, b) in sum.iter_mut().zip(&layer.pixels) {
                *a += *b;
            }
            count += 1;
        }
    }
    assert_eq!(count, 13);
    for (i, (a, b)) in sum.iter().zip(&image.pixels).enumerate() {
        assert!(
            (*a - *b).abs().max_element() <= 1e-4 * (1.0 + b.max_element()),
            "pixel {i}: strategies add up to {a}, the image is {b}"
        );
    }
    let ck = d.path().join("ck");
    let o = raylab(&[
        "render",
        CORNELL,
        "-i",
        "bdpt",
        "-p",
        "write-strategies=1",
        "--spp",
        "2",
        "--size",
        "8x8",
        "--checkpoint",
        s(&ck),
        "-o",
        s(&d.path().join("c.exr")),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("checkpoints do not keep"),
        "{}",
        stderr(&o)
    );
    assert!(!d.path().join("c.exr").exists());
}
