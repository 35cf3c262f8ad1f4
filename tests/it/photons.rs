//! Photon mapping on real scenes: `sppm` and `sppm-pixel` converge to the `path` reference as passes
//! accumulate (its error against a high-spp `path` render falls pass after pass, and its image
//! mean agrees with `path`'s within statistical error), and `photon` agrees with `path` up to
//! its density-estimation blur.
//!
//! Photon integrators share a photon map between the pixels of a pass, so their pixels'
//! errors are correlated: standard errors here come from the spread of the passes' image
//! means, not from per-pixel variances.

use raylab::compare::metrics;
use raylab::render::{render_passes, Accumulation, Film, RenderSettings};
use raylab::scene::RenderScene;
use raylab::scene::{load_scene, Camera};
use raylab_integrators::registry;
use std::path::Path;

struct Run {
    /// Images after the pass counts asked for.
    snapshots: Vec<Film>,
    /// Image mean (per channel) and its standard error, from the passes' means.
    mean: [f64; 3],
    se: [f64; 3],
}

fn load(scene: &str, width: u32, height: u32) -> (RenderScene, Camera) {
    let loaded = load_scene(Path::new(scene)).unwrap();
    let camera = loaded.camera.with_resolution(width, height);
    (RenderScene::build(&loaded), camera)
}

/// Renders `passes` passes, keeping the images after the pass counts in `keep`.
fn run(
    scene: &(RenderScene, Camera),
    integrator: &str,
    params: &[(&str, &str)],
    passes: u32,
    keep: &[u32],
) -> Run {
    let given: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let mut integrator = registry::find(integrator)
        .unwrap()
        .instantiate(&given)
        .unwrap();
    let (built, camera) = scene;
    let mut acc = Accumulation::new(camera.width, camera.height);
    let mut snapshots = Vec::new();
    let mut pass_means: Vec<[f64; 3]> = Vec::new();
    let mut previous_sum = [0.0f64; 3];
    render_passes(
        built,
        camera,
        integrator.as_mut(),
        &RenderSettings::fixed(passes, 3, None),
        &mut acc,
        &|| false,
        &mut |acc, _| {
            let film = acc.film();
            let m = film.mean();
            let n = acc.spp_done as f64;
            let sum = [m.x as f64 * n, m.y as f64 * n, m.z as f64 * n];
            pass_means.push([0, 1, 2].map(|c| sum[c] - previous_sum[c]));
            previous_sum = sum;
            if keep.contains(&acc.spp_done) {
                snapshots.push(film);
            }
            Ok(())
        },
    )
    .unwrap();
    let n = pass_means.len() as f64;
    let mean = [0, 1, 2].map(|c| pass_means.iter().map(|m| m[c]).sum::<f64>() / n);
    let se = [0, 1, 2].map(|c| {
        let var = pass_means
            .iter()
            .map(|m| (m[c] - mean[c]).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        (var / n).sqrt()
    });
    Run {
        snapshots,
        mean,
        se,
    }
}

/// Each channel's means agree within `z` combined standard errors plus `relative` of the
/// reference (for a biased method's allowance).
fn assert_means_agree(what: &str, a: &Run, b: &Run, z: f64, relative: f64) {
    for c in 0..3 {
        let diff = (a.mean[c] - b.mean[c]).abs();
        let se = (a.se[c].powi(2) + b.se[c].powi(2)).sqrt();
        assert!(
            diff < z * se + relative * b.mean[c],
            "{what}, channel {c}: {:.5} +- {:.5} vs {:.5} +- {:.5}",
            a.mean[c],
            a.se[c],
            b.mean[c],
            b.se[c]
        );
    }
}

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
