//! Image means whose standard errors come from the spread of the passes' image means (each
//! pass one sample per pixel), not from per-pixel variances: honest for integrators whose
//! pixels share a pass's photons or light subpaths (`sppm`, `vcm`, `bpm`), whose pixels'
//! errors are correlated, and valid for every other.

use raylab::render::{render_passes, Accumulation, Film, RenderSettings};
use raylab::scene::RenderScene;
use raylab::scene::{load_scene, Camera};
use raylab_integrators::registry;
use std::path::Path;

/// A render's images at chosen pass counts, and its image mean with the standard error from
/// the passes' means.
pub struct Run {
    /// Images after the pass counts asked for.
    pub snapshots: Vec<Film>,
    /// Image mean (per channel) and its standard error, from the passes' means.
    pub mean: [f64; 3],
    pub se: [f64; 3],
}

pub fn load(scene: &str, width: u32, height: u32) -> (RenderScene, Camera) {
    let loaded = load_scene(Path::new(scene)).unwrap();
    let camera = loaded.camera.with_resolution(width, height);
    (RenderScene::build(&loaded), camera)
}

/// Renders `passes` passes, keeping the images after the pass counts in `keep`.
pub fn run(
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
pub fn assert_means_agree(what: &str, a: &Run, b: &Run, z: f64, relative: f64) {
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

/// The brightest channel's standard error is below `power` of its mean: the comparison could
/// see a difference of about 4 `power`.
pub fn assert_power(what: &str, run: &Run, power: f64) {
    let c = (0..3)
        .max_by(|&a, &b| run.mean[a].total_cmp(&run.mean[b]))
        .unwrap_or(0);
    assert!(
        run.se[c] < power * run.mean[c],
        "{what}: standard error {:.5} of {:.5}, too large for the test to mean anything",
        run.se[c],
        run.mean[c]
    );
}
