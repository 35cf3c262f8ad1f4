//! Every registry entry that declares an [`Analytic`](super::registry::Analytic) is checked on
//! the testing kit's three analytic scenes, against what it declares: no hand-kept list of
//! integrators can miss one. One test per scene, so they run in parallel; and once more under
//! every other sampler.

use super::registry::{Analytic, Expect, REGISTRY};
use crate::sampler::SamplerKind;
use crate::testing::{
    expect_mean_passes, expect_mean_passes_in, expect_mean_passes_sampled, furnace_sphere,
    point_in_sphere, sphere_under_sky, TestScene,
};
use glam::Vec3A;

fn check(scene: &TestScene, expected: impl Fn(&Analytic) -> Option<Expect>) {
    for_every_declaring_entry(expected, |name, a, e| {
        expect_mean_passes(name, a.params, scene, e.value, e.passes, e.per_pass)
    });
}

/// Runs `check` on every registry entry that declares what it gives (`expected`), and
/// asserts that enough do.
fn for_every_declaring_entry(
    expected: impl Fn(&Analytic) -> Option<Expect>,
    mut check: impl FnMut(&str, &Analytic, Expect),
) {
    let mut checked = 0;
    for entry in REGISTRY {
        let Some(a) = entry.analytic else { continue };
        if let Some(e) = expected(&a) {
            check(entry.name, &a, e);
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

/// In spectral mode every entry gives what it declares, which is what it gives in RGB: the
/// scenes' grey reflectances are flat spectra, their white lights D65 of luminance 1, which
/// the film turns back into white (within the CIE tables' 1e-4). A spectral white furnace
/// returns the RGB one's radiance.
fn check_spectral(scene: &TestScene, expected: Declared) {
    for_every_declaring_entry(expected, |name, a, e| {
        expect_mean_passes_in(
            name,
            a.params,
            scene,
            e.value,
            // Twice the passes: the wavelengths add colour noise to every sample.
            (2 * e.passes, e.per_pass),
            0.0,
            (SamplerKind::Independent, true),
        )
    });
}

#[test]
fn every_entry_gives_what_it_declares_in_the_furnace_in_spectral_mode() {
    check_spectral(&furnace_sphere(0.5, 1.0), |a| a.furnace);
}

#[test]
fn every_entry_gives_what_it_declares_for_a_point_light_in_spectral_mode() {
    check_spectral(&point_in_sphere(0.5), |a| a.point_in_sphere);
}

#[test]
fn every_entry_gives_what_it_declares_under_a_sky_in_spectral_mode() {
    check_spectral(&sphere_under_sky(0.6, 2.0), |a| a.sphere_under_sky);
}

/// What an entry declares for one of the testing kit's scenes.
type Declared = fn(&Analytic) -> Option<Expect>;

/// Every entry gives what it declares for the point light in a sphere (pbrt-v4's analytic
/// scene: exactly 1) and for the ball under a sky (direct light and a bounce: a smooth
/// integrand) with camera samples drawn by `kind`. The Metropolis integrators draw from their
/// chains whatever the sampler says, so they pass as they do.
fn check_sampled(kind: SamplerKind) {
    let scenes: [(TestScene, Declared); 2] = [
        (point_in_sphere(0.5), |a| a.point_in_sphere),
        (sphere_under_sky(0.6, 2.0), |a| a.sphere_under_sky),
    ];
    for (scene, expected) in &scenes {
        let mut checked = 0;
        for entry in REGISTRY {
            let Some(a) = entry.analytic else { continue };
            if let Some(e) = expected(&a) {
                expect_mean_passes_sampled(
                    entry.name,
                    a.params,
                    scene,
                    e.value,
                    // Twice the passes: some entries' declared standard errors sit close to
                    // the power bound, which a different draw of the noise may cross.
                    (2 * e.passes, e.per_pass),
                    0.0,
                    kind,
                );
                checked += 1;
            }
        }
        assert!(checked >= 4, "only {checked} entries declare this scene");
    }
}

#[test]
fn every_entry_gives_what_it_declares_under_the_stratified_sampler() {
    check_sampled(SamplerKind::Stratified);
}

#[test]
fn every_entry_gives_what_it_declares_under_the_sobol_sampler() {
    check_sampled(SamplerKind::Sobol);
}

#[test]
fn every_entry_gives_what_it_declares_under_the_zsobol_sampler() {
    check_sampled(SamplerKind::ZSobol);
}

#[test]
fn every_entry_gives_what_it_declares_under_the_halton_sampler() {
    check_sampled(SamplerKind::Halton);
}

/// Every sampler kind is checked above.
#[test]
fn every_sampler_kind_is_checked() {
    let source = include_str!("analytic_tests.rs");
    for (name, kind) in SamplerKind::ALL {
        if kind != SamplerKind::Independent {
            assert!(
                source.contains(&format!("check_sampled(SamplerKind::{kind:?})")),
                "{name} is not checked"
            );
        }
    }
}

/// Every integrator that chooses how its light samples pick a light renders the floor under
/// 48 polygon lights (Lambert's formula, summed) under each choice: uniform, by power and by
/// the light BVH (which must leave out the lights facing away, and no other).
#[test]
fn every_light_selection_gives_lamberts_irradiance_under_many_lights() {
    let (scene, expected) = crate::testing::floor_under_many_lights(0.7);
    let mut checked = 0;
    for entry in REGISTRY {
        if !entry
            .params
            .iter()
            .any(|p| p.name == crate::registry::LIGHT_SELECTION.name)
        {
            continue;
        }
        for selection in ["uniform", "power", "bvh"] {
            crate::testing::expect_mean_passes(
                entry.name,
                &[("light-selection", selection)],
                &scene,
                expected as f32,
                40,
                // Uniform selection spends most samples on dim lights: the noisiest.
                if selection == "uniform" { 1500 } else { 400 },
            );
        }
        checked += 1;
    }
    assert!(
        checked >= 5,
        "only {checked} integrators choose their lights"
    );
    // An inward-emitting sphere light (pbrt-v4's furnace): emission and one bounce of it.
    let furnace = crate::testing::furnace_emitting_sphere(0.5, 1.0);
    crate::testing::expect_mean_passes("restir", &[("candidates", "4")], &furnace, 1.5, 40, 400);
    // ReSTIR's reuse over the same light set, with and without neighbours.
    for neighbours in ["0", "4"] {
        crate::testing::expect_mean_passes(
            "restir",
            &[("neighbours", neighbours), ("candidates", "8")],
            &scene,
            expected as f32,
            40,
            400,
        );
    }
}

/// Lambert's formula against the irradiance integral `∫ cos cos' / d^2 dA` over a square
/// facing the point, summed by a fine midpoint rule; either winding gives the same.
#[test]
fn lamberts_formula_matches_a_numerical_integral() {
    let (s, h) = (0.4f32, 0.7f32);
    let square = [
        Vec3A::new(-s, -s, h),
        Vec3A::new(s, -s, h),
        Vec3A::new(s, s, h),
        Vec3A::new(-s, s, h),
    ];
    let formula = crate::testing::polygon_irradiance(Vec3A::ZERO, Vec3A::Z, &square);
    // E = integral over the square of cos_x cos_l / d^2 dA = h^2 / d^4 dA.
    let n = 2000;
    let cell = 2.0 * f64::from(s) / n as f64;
    let mut numeric = 0.0;
    for i in 0..n {
        for j in 0..n {
            let x = -f64::from(s) + (i as f64 + 0.5) * cell;
            let y = -f64::from(s) + (j as f64 + 0.5) * cell;
            let d2 = x * x + y * y + f64::from(h * h);
            numeric += f64::from(h * h) / (d2 * d2) * cell * cell;
        }
    }
    assert!(
        (formula - numeric).abs() < 1e-6 * numeric,
        "{formula} vs {numeric}"
    );
    // Either winding.
    let mut reversed = square;
    reversed.reverse();
    let again = crate::testing::polygon_irradiance(Vec3A::ZERO, Vec3A::Z, &reversed);
    assert!((formula - again).abs() < 1e-12);
}
