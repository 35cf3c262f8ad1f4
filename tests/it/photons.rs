//! Photon mapping on real scenes: `sppm` and `sppm-pixel` converge to the `path` reference as passes
//! accumulate (its error against a high-spp `path` render falls pass after pass, and its image
//! mean agrees with `path`'s within statistical error), and `photon` agrees with `path` up to
//! its density-estimation blur.
//!
//! Photon integrators share a photon map between the pixels of a pass, so their pixels'
//! errors are correlated: standard errors here come from the spread of the passes' image
//! means, not from per-pixel variances.

use crate::common::pass_means::{assert_means_agree, load, run};
use raylab::compare::metrics;

/// Both forms of SPPM: one radius for all pixels (`sppm`), a radius per pixel
/// (`sppm-pixel`).
const SPPMS: [&str; 2] = ["sppm", "sppm-pixel"];

#[test]
fn sppm_error_falls_pass_after_pass_on_the_caustics_scene() {
    let scene = load("scenes/caustics.ron", 40, 30);
    let reference = run(&scene, "path", &[], 8192, &[8192]);
    // The reference's own noise: the RMSE a perfect image would show against it.
    let reference_noise = {
        let v = &reference.snapshots[0].variance;
        (v.iter().map(|p| p.x + p.y + p.z).sum::<f32>() as f64 / (3 * v.len()) as f64).sqrt()
    };
    let checkpoints = [1, 4, 16, 64, 256];
    for name in SPPMS {
        let sppm = run(&scene, name, &[("photons", "20000")], 256, &checkpoints);
        let rmse: Vec<f64> = sppm
            .snapshots
            .iter()
            .map(|f| metrics::compare(f, &reference.snapshots[0]).unwrap().0.rmse)
            .collect();
        println!(
            "{name} RMSE after {checkpoints:?} passes: {rmse:?}; the reference's noise: {reference_noise}"
        );
        for w in rmse.windows(2) {
            assert!(w[1] < w[0], "{name}: RMSE did not fall: {rmse:?}");
        }
        // Its own error, once the reference's noise is taken out, has fallen by half or more.
        let own = |r: f64| (r * r - reference_noise * reference_noise).max(0.0).sqrt();
        assert!(
            own(rmse[rmse.len() - 1]) < 0.5 * own(rmse[0]),
            "{name}: {rmse:?} (reference noise {reference_noise})"
        );
        // Consistent: the image mean agrees with the path tracer's.
        assert_means_agree(
            &format!("caustics, {name} vs path"),
            &sppm,
            &reference,
            4.0,
            0.0,
        );
    }
}

#[test]
fn sppm_agrees_with_path_on_the_cornell_box() {
    let scene = load("scenes/cornell_box.ron", 24, 24);
    let depth = [("max-depth", "7")];
    let reference = run(&scene, "path", &depth, 2048, &[]);
    for name in SPPMS {
        let sppm = run(
            &scene,
            name,
            &[("photons", "10000"), ("max-depth", "7")],
            256,
            &[],
        );
        assert_means_agree(
            &format!("Cornell box, {name} vs path"),
            &sppm,
            &reference,
            4.0,
            0.0,
        );
    }
}

#[test]
fn photon_mapping_agrees_with_path_up_to_its_blur() {
    let scene = load("scenes/cornell_box.ron", 24, 24);
    let depth = [("max-depth", "7")];
    let reference = run(&scene, "path", &depth, 1024, &[]);
    let photon = run(
        &scene,
        "photon",
        &[
            ("photons", "100000"),
            ("caustic-photons", "10000"),
            ("gather", "8"),
            ("max-depth", "7"),
        ],
        64,
        &[],
    );
    // Its maps are built once, so its passes share their error: allow 2% for the blur
    // (and the maps' noise) on top of the statistical error.
    assert_means_agree(
        "Cornell box, photon vs path",
        &photon,
        &reference,
        4.0,
        0.02,
    );
}

/// On every material of the field, and on a plastic floor filling the view, whose camera
/// paths either follow the coating's reflection or land on the base by the coating's
/// probability (a landing that forgot to divide by that probability is 5% too dark here).
#[test]
fn sppm_agrees_with_path_on_the_new_materials() {
    let scene = load("scenes/materials.ron", 24, 24);
    let depth = [("max-depth", "6")];
    let reference = run(&scene, "path", &depth, 2048, &[]);
    let sppm = run(
        &scene,
        "sppm",
        &[("photons", "10000"), ("max-depth", "6")],
        256,
        &[],
    );
    assert_means_agree("materials, sppm vs path", &sppm, &reference, 4.0, 0.01);

    let dir = tempfile::tempdir().unwrap();
    let floor = dir.path().join("plastic.ron");
    std::fs::write(
        &floor,
        r#"(camera: LookAt(eye: (0, 1, 3), look_at: (0, 0, 0), up: (0, 1, 0), fov: 20, resolution: (16, 16)),
            environment: (0.2, 0.25, 0.3),
            materials: {"plastic": Plastic(diffuse_reflectance: (0.6, 0.6, 0.6))},
            entities: [
                (name: "floor", shape: Quad(vertices: [(-9, 0, 9), (9, 0, 9), (9, 0, -9), (-9, 0, -9)]), material: "plastic"),
                (name: "light", shape: Quad(vertices: [(-1, 3, -1), (-1, 3, 1), (1, 3, 1), (1, 3, -1)]), emitter: Area(radiance: (5, 5, 5))),
            ])"#,
    )
    .unwrap();
    let scene = load(floor.to_str().unwrap(), 16, 16);
    let reference = run(&scene, "path", &depth, 1024, &[]);
    let sppm = run(
        &scene,
        "sppm",
        &[("photons", "10000"), ("max-depth", "6")],
        128,
        &[],
    );
    assert_means_agree("plastic floor, sppm vs path", &sppm, &reference, 4.0, 0.01);
}
