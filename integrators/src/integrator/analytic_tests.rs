//! Every registry entry that declares an [`Analytic`](super::registry::Analytic) is checked on
//! the testing kit's three analytic scenes, against what it declares: no hand-kept list of
//! integrators can miss one. One test per scene, so they run in parallel; and once more under
//! the `sobol` sampler.

use super::registry::{Analytic, Expect, REGISTRY};
use crate::sampler::SamplerKind;
use crate::testing::{
    expect_mean_passes, expect_mean_passes_sampled, furnace_sphere, point_in_sphere,
    sphere_under_sky, TestScene,
};

fn check(scene: &TestScene, expected: impl Fn(&Analytic) -> Option<Expect>) {
    let mut checked = 0;
    for entry in REGISTRY {
        let Some(a) = entry.analytic else { continue };
        if let Some(e) = expected(&a) {
            expect_mean_passes(entry.name, a.params, scene, e.value, e.passes, e.per_pass);
            checked += 1;
        }
    }
    assert!(checked >= 4, "only {checked} entries declare this scene");
}

#[test]
fn every_entry_gives_what_it_declares_in_the_furnace() {
    check(&furnace_sphere(0.5, 1.0), |a| a.furnace);
}

#[test]
fn every_entry_gives_what_it_declares_for_a_point_light_in_a_sphere() {
    check(&point_in_sphere(0.5), |a| a.point_in_sphere);
}

#[test]
fn every_entry_gives_what_it_declares_for_a_convex_ball_under_a_sky() {
    check(&sphere_under_sky(0.6, 2.0), |a| a.sphere_under_sky);
}

/// Every entry gives what it declares for the ball under a sky (direct light and a bounce:
/// a smooth integrand) with camera samples drawn from scrambled Sobol points. The Metropolis
/// integrators draw from their chains whatever the sampler says, so they pass as they do.
#[test]
fn every_entry_gives_what_it_declares_under_the_sobol_sampler() {
    let scene = sphere_under_sky(0.6, 2.0);
    let mut checked = 0;
    for entry in REGISTRY {
        let Some(a) = entry.analytic else { continue };
        if let Some(e) = a.sphere_under_sky {
            expect_mean_passes_sampled(
                entry.name,
                a.params,
                &scene,
                e.value,
                // Twice the passes: some entries' declared standard errors sit close to the
                // power bound, which a different draw of the noise may cross.
                (2 * e.passes, e.per_pass),
                0.0,
                SamplerKind::Sobol,
            );
            checked += 1;
        }
    }
    assert!(checked >= 4, "only {checked} entries declare this scene");
}
