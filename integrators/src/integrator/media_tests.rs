//! Every registry entry that renders participating media is checked against the closed forms
//! of the testing kit's media scenes ([`crate::testing::media`]), in every colour channel and
//! with coloured (chromatic) media: no hand-kept list can miss one.

//!
//! Integrators that estimate radiance along a ray are checked ray by ray in every channel;
//! the others (light paths splatted onto the image) by the image means of passes (green),
//! where their probe camera sees the scene: the furnace and the absorbing ball.

use super::registry::{IntegratorEntry, MediaSupport, REGISTRY};
use crate::medium::Phase;
use crate::testing::media::*;
use crate::testing::{expect_mean_passes_within, TestScene};
use crate::Rgb;

type Params = Vec<(&'static str, &'static str)>;

/// The entries that render media (emitting ones too, with `emitting`), with the parameters
/// their analytic checks use, and whether they estimate radiance along a ray. Density
/// estimates trace more photons than on the surface scenes: a photon's power in a coloured
/// medium varies with the channel its flights were sampled by.
fn media_entries(emitting: bool) -> Vec<(&'static str, Params, bool)> {
    let entries: Vec<_> = REGISTRY
        .iter()
        .filter(|e| e.media == MediaSupport::Full || (!emitting && e.media.any()))
        .map(|e| {
            let analytic = e.analytic.map_or(&[][..], |a| a.params);
            let params = if is_density_estimate(e) {
                let has = |name| e.params.iter().any(|p| p.name == name);
                let photons = [("photons", "500000"), ("caustic-photons", "100000")];
                // Merges in media within the surfaces' radius: the kernel's darkening at the
                // ball's boundary grows with it.
                let radius = analytic.iter().find(|(k, _)| *k == "radius");
                let volume = radius.filter(|_| has("volume-radius"));
                analytic
                    .iter()
                    .copied()
                    .filter(|(k, _)| photons.iter().all(|(p, _)| p != k))
                    .chain(photons.into_iter().filter(|(k, _)| has(*k)))
                    .chain(volume.map(|(_, r)| ("volume-radius", *r)))
                    .collect()
            } else {
                analytic.to_vec()
            };
            (e.name, params, by_rays(e))
        })
        .collect();
    assert!(!entries.is_empty(), "no integrator renders media");
    entries
}

/// The largest `max-depth` integrator `name` takes (`inf` where it has no bound).
fn deepest(name: &str) -> String {
    let entry = crate::find(name).unwrap_or_else(|e| panic!("{e}"));
    let max = entry
        .params
        .iter()
        .find(|p| p.name == "max-depth")
        .map_or(f64::INFINITY, |p| p.max);
    if max.is_finite() {
        format!("{max}")
    } else {
        "inf".to_string()
    }
}

fn by_rays(e: &IntegratorEntry) -> bool {
    e.instantiate(&[])
        .is_ok_and(|i| i.as_ray_integrator().is_some())
}

/// The relative bias an integrator's estimate may show: a density estimate's (an integrator
/// with a gather `radius`) blurs radiance over its kernel, which near a medium's boundary
/// reaches past the medium, where no photon lands; exact estimators none.
fn allowed_bias(name: &str) -> f64 {
    let entry = crate::find(name).unwrap_or_else(|e| panic!("{e}"));
    if is_density_estimate(entry) {
        DENSITY_BIAS
    } else {
        0.0
    }
}

/// Whether an integrator estimates densities (has a gather `radius`).
fn is_density_estimate(e: &IntegratorEntry) -> bool {
    e.params.iter().any(|p| p.name == "radius")
}

/// What [`allowed_bias`] allows a density estimate.
const DENSITY_BIAS: f64 = 0.03;

/// [`expect_rgb`] for an integrator of rays; for one of light paths, the image means of
/// passes (green).
fn check(name: &str, params: &[(&str, &str)], rays: bool, scene: &TestScene, exact: Rgb, n: u32) {
    if rays {
        expect_rgb_within(name, params, scene, exact, n, allowed_bias(name));
    } else {
        let bias = allowed_bias(name);
        expect_mean_passes_within(name, params, scene, exact.y, 80, 10000, bias);
    }
}

#[test]
fn beers_law_through_an_absorbing_ball() {
    let (scene, exact) = absorbing_ball(Rgb::new(0.3, 0.7, 1.5), 2.0);
    for (name, params, rays) in media_entries(false) {
        check(name, &params, rays, &scene, exact, 40_000);
    }
}

#[test]
fn a_furnace_of_white_fog_gives_one_at_any_density() {
    for (sigma_t, g) in [(Rgb::new(0.3, 0.8, 2.0), 0.5), (Rgb::splat(1.5), -0.3)] {
        let phase = Phase::HenyeyGreenstein { g };
        let (inside, outside) = (
            fog_furnace(sigma_t, phase),
            fog_ball_under_sky(sigma_t, phase),
        );
        for (name, params, rays) in media_entries(false) {
            if rays {
                check(name, &params, rays, &inside, Rgb::ONE, 40_000);
            }
            check(name, &params, rays, &outside, Rgb::ONE, 40_000);
        }
        // The light tracer sees nothing through the pane: a light path's vertex behind a
        // Dirac lobe cannot be joined to the lens, with media or without.
        // Paths bounce inside the pane for long: every integrator at its deepest (the
        // coloured fog only, the costlier check).
        let pane = fog_ball_behind_a_pane(sigma_t, phase);
        for (name, params, rays) in media_entries(false) {
            if name != "lighttracer" && g > 0.0 {
                let deepest = deepest(name);
                let params: Vec<(&str, &str)> = params
                    .iter()
                    .copied()
                    .filter(|(k, _)| *k != "max-depth")
                    .chain([("max-depth", deepest.as_str())])
                    .collect();
                check(name, &params, rays, &pane, Rgb::ONE, 40_000);
            }
        }
    }
}

#[test]
fn a_glowing_ball_emits_what_it_does_not_absorb() {
    let (scene, exact) = glowing_ball(Rgb::new(0.4, 0.8, 1.6), Rgb::new(1.0, 2.0, 3.0));
    for (name, params, rays) in media_entries(true) {
        check(name, &params, rays, &scene, exact, 40_000);
    }
}

#[test]
fn a_ball_glowing_on_a_grid_emits_what_the_quadrature_sums() {
    let (scene, exact) = glowing_grid_ball();
    for (name, params, rays) in media_entries(true) {
        check(name, &params, rays, &scene, exact, 40_000);
    }
}

#[test]
fn single_scattering_of_a_point_light_matches_the_quadrature() {
    let (sigma_t, albedo) = (Rgb::new(0.3, 0.6, 1.2), Rgb::new(0.8, 0.9, 0.5));
    for phase in [Phase::Isotropic, Phase::HenyeyGreenstein { g: 0.6 }] {
        let scene = single_scattering(sigma_t, albedo, phase, 4.0);
        let exact = single_scattering_exact(sigma_t, albedo, phase, 4.0);
        // A pinhole a hair's breadth wide: only integrators of rays see it well.
        for (name, _, _) in media_entries(false).into_iter().filter(|e| e.2) {
            let bias = allowed_bias(name);
            expect_rgb_within(name, &[("max-depth", "1")], &scene, exact, 40_000, bias);
        }
    }
}
