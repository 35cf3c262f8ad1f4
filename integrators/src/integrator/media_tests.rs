//! Every registry entry that renders participating media is checked against the closed forms
//! of the testing kit's media scenes ([`crate::testing::media`]), in every colour channel and
//! with coloured (chromatic) media: no hand-kept list can miss one.

use super::registry::REGISTRY;
use crate::medium::Phase;
use crate::testing::media::*;
use crate::Rgb;

/// The entries that render media, with the parameters their analytic checks use.
fn media_entries() -> Vec<(&'static str, &'static [(&'static str, &'static str)])> {
    let entries: Vec<_> = REGISTRY
        .iter()
        .filter(|e| e.media)
        .map(|e| (e.name, e.analytic.map_or(&[][..], |a| a.params)))
        .collect();
    assert!(!entries.is_empty(), "no integrator renders media");
    entries
}

#[test]
fn beers_law_through_an_absorbing_ball() {
    let (scene, exact) = absorbing_ball(Rgb::new(0.3, 0.7, 1.5), 2.0);
    for (name, params) in media_entries() {
        expect_rgb(name, params, &scene, exact, 40_000);
    }
}

#[test]
fn a_furnace_of_white_fog_gives_one_at_any_density() {
    for (sigma_t, g) in [(Rgb::new(0.5, 2.0, 6.0), 0.5), (Rgb::splat(4.0), -0.3)] {
        let scene = fog_furnace(sigma_t, Phase::HenyeyGreenstein { g });
        for (name, params) in media_entries() {
            expect_rgb(name, params, &scene, Rgb::ONE, 40_000);
        }
    }
}

#[test]
fn a_glowing_ball_emits_what_it_does_not_absorb() {
    let (scene, exact) = glowing_ball(Rgb::new(0.4, 0.8, 1.6), Rgb::new(1.0, 2.0, 3.0));
    for (name, params) in media_entries() {
        expect_rgb(name, params, &scene, exact, 40_000);
    }
}

#[test]
fn single_scattering_of_a_point_light_matches_the_quadrature() {
    let (sigma_t, albedo) = (Rgb::new(0.3, 0.6, 1.2), Rgb::new(0.8, 0.9, 0.5));
    for phase in [Phase::Isotropic, Phase::HenyeyGreenstein { g: 0.6 }] {
        let scene = single_scattering(sigma_t, albedo, phase, 4.0);
        let exact = single_scattering_exact(sigma_t, albedo, phase, 4.0);
        for (name, _) in media_entries() {
            expect_rgb(name, &[("max-depth", "1")], &scene, exact, 40_000);
        }
    }
}
