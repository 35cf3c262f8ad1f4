use super::*;
use crate::testing::*;

/// Estimates of `n` camera samples of `scene`'s probe camera, all in one batch (or each in a
/// batch of its own), each from its own sampler.
fn estimates(scene: &TestScene, n: u32, one_by_one: bool, mis: bool) -> Vec<Spectrum> {
    let integrator = WavefrontPath {
        max_depth: u32::MAX,
        rr_depth: 3,
        lights: None,
        mis,
    };
    let mut samplers: Vec<Sampler> = (0..n).map(|i| Sampler::new(7, i as u64, 0)).collect();
    let rays: Vec<Ray> = samplers
        .iter_mut()
        .map(|s| camera_ray(&scene.camera, s))
        .collect();
    let mut lambdas = vec![Wavelengths::Rgb; n as usize];
    let mut out = vec![Spectrum::ZERO; n as usize];
    let mut tracer = Tracer::new(scene);
    if one_by_one {
        for k in 0..n as usize {
            out[k] = integrator.radiance(&rays[k], &mut tracer, &mut samplers[k], &mut lambdas[k]);
        }
    } else {
        let batch = Batch {
            rays: &rays,
            samplers: &mut samplers,
            lambdas: &mut lambdas,
            out: &mut out,
        };
        integrator.radiance_batch(batch, &mut tracer);
    }
    out
}

#[test]
fn a_path_estimate_does_not_depend_on_its_batch() {
    // Diffuse rows, scalar glass and a light mixed in one batch: each path's estimate is the
    // same bit for bit alone or among 300 others (five walks of up to 64), with MIS
    // (`path-wavefront`) and without (`russian-roulette-wavefront`).
    for (scene, mis) in [
        furnace_with_glass(0.5, 1.0),
        floor_under_sphere_light(0.5, 4.0, 0.5, 2.0),
    ]
    .iter()
    .flat_map(|s| [(s, true), (s, false)])
    {
        let together = estimates(scene, 300, false, mis);
        let alone = estimates(scene, 300, true, mis);
        assert!(together.iter().any(|l| *l != Spectrum::ZERO));
        for (k, (a, b)) in together.iter().zip(&alone).enumerate() {
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits),
                "sample {k}"
            );
        }
    }
}

#[test]
fn it_agrees_with_path_where_depth_truncates() {
    // Depth 2 in the furnace: Le (1 + a + a^2), as `path`.
    expect_mean(
        "path-wavefront",
        &[("max-depth", "2")],
        &furnace_sphere(0.5, 1.0),
        1.75,
        8000,
    );
    for name in ["path-wavefront", "russian-roulette-wavefront"] {
        expect_mean(
            name,
            &[],
            &floor_under_sphere_light(0.5, 4.0, 0.5, 2.0),
            0.125,
            4000,
        );
    }
    // Without MIS, as `russian-roulette`: a glass ball in the furnace is invisible.
    expect_mean(
        "russian-roulette-wavefront",
        &[],
        &furnace_with_glass(0.5, 1.0),
        2.0,
        30000,
    );
}
