//! `raylab bench` runs every case and dumps the work in the documented format.

use std::process::Command;

#[test]
fn bench_reports_every_case_and_dumps_triangles_and_rays() {
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args([
            "bench",
            "--rays",
            "5000",
            "--subdivisions",
            "3",
            "--threads",
            "1,2",
            "--dump",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for case in ["report-room", "cornell-box", "icosphere-1m", "instances"] {
        for kind in ["coherent", "incoherent"] {
            let of_kind = || {
                text.lines()
                    .filter(|l| l.starts_with(case) && l.contains(&format!(" {kind} ")))
            };
            let (batches, rows): (Vec<&str>, Vec<&str>) =
                of_kind().partition(|l| l.contains("in batches of 64"));
            assert_eq!(
                rows.len(),
                2,
                "{case} {kind}: one line per thread count\n{text}"
            );
            // The same rays in batches (the wavefront's traversal), beside each thread count.
            assert_eq!(batches.len(), 2, "{case} {kind}: batches\n{text}");
            assert!(batches.iter().all(|l| l.contains("x one by one")), "{text}");
        }
        assert!(
            text.lines()
                .any(|l| l.starts_with(case) && l.contains("BVH build")),
            "{text}"
        );
    }
    assert!(text.contains("M samples/s"));
    // Dumps: u32 count then 9 floats per triangle / 8 per ray.
    let tris = std::fs::read(dir.path().join("cornell-box.tris")).unwrap();
    assert_eq!(u32::from_le_bytes(tris[..4].try_into().unwrap()), 36);
    assert_eq!(tris.len(), 4 + 36 * 9 * 4);
    let rays = std::fs::read(dir.path().join("icosphere-1m-incoherent.rays")).unwrap();
    assert_eq!(rays.len(), 4 + 5000 * 8 * 4);
    let spheres = std::fs::read(dir.path().join("report-room.spheres")).unwrap();
    assert_eq!(spheres.len(), 4 + 2 * 4 * 4);
    // 20 * 4^3 triangles at subdivision 3.
    assert!(text.contains("1280"), "{text}");
    // The instancing case counts every placed triangle: 300 instances of 20,480, and the
    // floor's and light's 4. It is not dumped (the format is flat triangles).
    assert!(
        text.lines()
            .any(|l| l.starts_with("instances") && l.contains(" 6144004 ")),
        "{text}"
    );
    assert!(text.contains("instances      not dumped"), "{text}");
    assert!(!dir.path().join("instances.tris").exists());
}

/// Without the `embree` feature, `--embree` is a usage error that says how to get it.
#[cfg(not(feature = "embree"))]
#[test]
fn bench_embree_without_the_feature_exits_2_and_says_how_to_build_it() {
    let o = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["bench", "--embree", "--rays", "10", "--subdivisions", "1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(
            "raylab was built without the `embree` feature: cargo build --release --features embree (needs Debian's libembree-dev)"
        ),
        "{err}"
    );
    assert!(o.stdout.is_empty(), "nothing measured");
}

/// `--case` runs only the named cases; a name that is not a case is a usage error.
#[test]
fn bench_case_runs_only_the_named_cases() {
    let o = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args([
            "bench",
            "--rays",
            "1000",
            "--threads",
            "1",
            "--case",
            "cornell-box",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.lines().any(|l| l.starts_with("cornell-box")), "{text}");
    assert!(
        !text.contains("report-room")
            && !text.contains("icosphere-1m")
            && !text.contains("instances"),
        "{text}"
    );
    // The build's own peak memory is reported where Linux lets a process reset its peak.
    if std::fs::write("/proc/self/clear_refs", "5").is_ok() {
        assert!(text.contains("build peak +"), "{text}");
    }

    let o = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["bench", "--case", "sponza"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("sponza") && err.contains("icosphere-1m"),
        "{err}"
    );
    assert!(o.stdout.is_empty());
}

#[test]
fn rounds_must_be_at_least_one() {
    let o = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["bench", "--rounds", "0"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--rounds"), "{err}");
    assert!(o.stdout.is_empty());
}

/// `--obvhs` builds every case with the obvhs backend too and prints its rates beside raylab's.
#[test]
fn bench_compares_the_obvhs_backend_side_by_side() {
    let o = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args([
            "bench",
            "--rays",
            "3000",
            "--threads",
            "1",
            "--case",
            "cornell-box,instances",
            "--obvhs",
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for case in ["cornell-box", "instances"] {
        assert!(
            text.lines()
                .any(|l| l.starts_with(case) && l.contains("obvhs build")),
            "{text}"
        );
        for kind in ["coherent", "incoherent"] {
            let line = text
                .lines()
                .find(|l| l.starts_with(case) && l.contains(" obvhs ") && l.contains(kind))
                .unwrap_or_else(|| panic!("{case} {kind}: no obvhs line\n{text}"));
            // Two positive ratios on the line.
            let ratios: Vec<f64> = line
                .split("raylab/obvhs ")
                .skip(1)
                .map(|r| r[..r.find(')').unwrap()].parse().unwrap())
                .collect();
            assert!(
                ratios.len() == 2 && ratios.iter().all(|r| *r > 0.0),
                "{line}"
            );
        }
    }
}
