//! Analytic scenes with participating media, and their exact answers: a ray through an
//! absorbing ball (Beer's law), a furnace of white fog (every estimate 1), single scattering
//! of a point light along one ray (a 1-D quadrature), and glowing balls (emission and
//! absorption, constant or on a grid).

use super::{Probe, Surface, TestScene};
use crate::medium::{Homogeneous, Phase};
use crate::spectrum::Wavelengths;
use crate::{Light, LightTable, Medium, MediumId, MediumInterface, Ray, Rgb, SurfaceMaterial};
use glam::Vec3A;

/// A ball of radius `radius` at the origin, filled with `medium` (id 0) behind a boundary of
/// material `boundary`, lit by `lights`, probed by `camera` (which starts in the medium when
/// `inside`).
fn ball_behind(
    boundary: SurfaceMaterial,
    medium: Medium,
    radius: f32,
    lights: Vec<Light>,
    camera: Probe,
    inside: bool,
) -> TestScene {
    TestScene {
        surfaces: vec![Surface::Boundary {
            center: Vec3A::ZERO,
            radius,
            material: 0,
            interface: MediumInterface {
                inside: MediumId(0),
                outside: MediumId::VACUUM,
            },
        }],
        materials: vec![boundary],
        lights: LightTable::new(lights, radius),
        camera,
        media: vec![medium],
        camera_medium: if inside {
            MediumId(0)
        } else {
            MediumId::VACUUM
        },
    }
}

/// A unit ball seen whole from a distance of 5.
fn seen_from_outside() -> Probe {
    Probe::AtSphere {
        eye: Vec3A::new(0.0, 0.0, 5.0),
        center: Vec3A::ZERO,
        radius: 1.0,
    }
}

/// The probe ray of the balls: from `z = -5` along `+z` through the centre.
fn through_the_centre() -> Probe {
    Probe::Fixed(Ray::new(Vec3A::new(0.0, 0.0, -5.0), Vec3A::Z))
}

/// A unit ball of a purely absorbing medium of extinction `sigma_t` under a sky of `sky`,
/// probed through its centre: radiance `sky exp(-2 sigma_t)` per channel.
pub fn absorbing_ball(sigma_t: Rgb, sky: f32) -> (TestScene, Rgb) {
    let medium = Medium::Homogeneous(Homogeneous::new(
        sigma_t,
        Rgb::ZERO,
        Rgb::ZERO,
        Phase::Isotropic,
    ));
    let scene = ball_behind(
        SurfaceMaterial::null(),
        medium,
        1.0,
        vec![Light::environment(Rgb::splat(sky))],
        through_the_centre(),
        false,
    );
    let exact = crate::spectrum::rgb_of(
        crate::medium::tracking::transmittance(crate::spectrum::of_rgb(sigma_t), 2.0) * sky,
    );
    (scene, exact)
}

/// A furnace: the probe inside a unit ball of fog that scatters without absorbing (extinction
/// `sigma_t`, phase `phase`) under a sky of 1. Whatever the density, radiance is 1.
pub fn fog_furnace(sigma_t: Rgb, phase: Phase) -> TestScene {
    let medium = Medium::Homogeneous(Homogeneous::new(sigma_t, Rgb::ONE, Rgb::ZERO, phase));
    ball_behind(
        SurfaceMaterial::null(),
        medium,
        1.0,
        vec![Light::environment(Rgb::ONE)],
        Probe::Omni(Vec3A::new(0.1, -0.2, 0.3)),
        true,
    )
}

/// The same fog as [`fog_furnace`] seen from outside, at a distance of 5: radiance 1 across
/// the ball. (Light paths connect to a camera inside a medium with a variance that diverges
/// at the lens, so integrators of light paths are checked from outside.)
pub fn fog_ball_under_sky(sigma_t: Rgb, phase: Phase) -> TestScene {
    let medium = Medium::Homogeneous(Homogeneous::new(sigma_t, Rgb::ONE, Rgb::ZERO, phase));
    ball_behind(
        SurfaceMaterial::null(),
        medium,
        1.0,
        vec![Light::environment(Rgb::ONE)],
        seen_from_outside(),
        false,
    )
}

/// [`fog_ball_under_sky`] behind a thin pane of water (a thin dielectric sphere, which loses
/// nothing: what it does not transmit it reflects): radiance 1 still. Paths cross the pane
/// with its transmission or reflect off it; an integrator that counted the light through it
/// twice (a join through the pane, and a subpath with a vertex on it) would exceed 1.
pub fn fog_ball_behind_a_pane(sigma_t: Rgb, phase: Phase) -> TestScene {
    let medium = Medium::Homogeneous(Homogeneous::new(sigma_t, Rgb::ONE, Rgb::ZERO, phase));
    let pane = crate::Material::ThinDielectric(
        crate::bsdf::ThinDielectric::new(1.33, crate::Spectrum::ONE, crate::Spectrum::ONE)
            .unwrap_or_else(|e| panic!("{e}")),
    );
    ball_behind(
        pane.into(),
        medium,
        1.0,
        vec![Light::environment(Rgb::ONE)],
        seen_from_outside(),
        false,
    )
}

/// A unit ball of `medium` with no light but its own, probed through its centre.
fn glowing(medium: Medium) -> TestScene {
    ball_behind(
        SurfaceMaterial::null(),
        medium,
        1.0,
        Vec::new(),
        through_the_centre(),
        false,
    )
}

/// A unit ball of a medium that absorbs (`sigma_a`) and emits `le`, probed through its
/// centre: radiance `le (1 - exp(-2 sigma_a))`.
pub fn glowing_ball(sigma_a: Rgb, le: Rgb) -> (TestScene, Rgb) {
    let medium = Medium::Homogeneous(Homogeneous::new(sigma_a, Rgb::ZERO, le, Phase::Isotropic));
    let scene = glowing(medium);
    let tr = crate::medium::tracking::transmittance(crate::spectrum::of_rgb(sigma_a), 2.0);
    let exact = le * (Rgb::ONE - crate::spectrum::rgb_of(tr));
    (scene, exact)
}

/// [`glowing_ball`] with coefficients that vary along the probe ray (pbrt-v4's `rgbgrid`):
/// absorption and emission each on an RGB grid of 1 x 1 x 4 voxels over the box
/// `[-1, 1]^3`. The radiance through the centre is the integral over the ray of the
/// transmittance from the ball's near side, `sigma_a` and `le`, which a fine midpoint rule
/// sums.
pub fn glowing_grid_ball() -> (TestScene, Rgb) {
    use crate::medium::{Coefficients, DensityGrid, Heterogeneous, Volume};
    use std::sync::Arc;
    let to_unit = glam::Affine3A::from_scale(glam::Vec3::splat(0.5))
        * glam::Affine3A::from_translation(glam::Vec3::ONE);
    let grid = |values: Vec<f32>| Volume::Grid {
        grid: Arc::new(DensityGrid::new([1, 1, 4], 3, values).unwrap_or_else(|e| panic!("{e}"))),
        to_local: to_unit,
        scale: Rgb::ONE,
    };
    let sigma_a = grid(vec![
        0.2, 0.8, 1.6, 0.6, 0.4, 0.2, 1.2, 0.0, 0.8, 0.1, 1.0, 0.4,
    ]);
    let le = grid(vec![
        2.0, 1.0, 0.5, 0.0, 3.0, 1.0, 1.0, 1.0, 4.0, 5.0, 0.5, 2.0,
    ]);
    let medium = Medium::Heterogeneous(Box::new(Heterogeneous::new(
        Coefficients::Separate {
            sigma_a: sigma_a.clone(),
            sigma_s: Volume::Constant(Rgb::ZERO),
        },
        le.clone(),
        Phase::Isotropic,
        Some(to_unit),
    )));
    let scene = glowing(medium);
    let n = 200_000;
    let dz = 2.0 / n as f32;
    let (mut depth, mut exact) = (Rgb::ZERO, Rgb::ZERO);
    for i in 0..n {
        let p = Vec3A::new(0.0, 0.0, -1.0 + (i as f32 + 0.5) * dz);
        let a = sigma_a.at(p);
        // The transmittance to the middle of the step, then the step's own depth.
        exact += (-(depth + 0.5 * a * dz)).exp() * a * le.at(p) * dz;
        depth += a * dz;
    }
    (scene, exact)
}

/// Single scattering: a point light of intensity `intensity` at `(0.5, 0, 0)` inside a ball
/// of radius 2 of a medium (extinction `sigma_t`, albedo `albedo`, phase `phase`); the probe
/// ray runs along the `z` axis through it. With one scattering event (`max-depth` 1) the
/// radiance is the integral over the ray of transmittance in, `sigma_s`, the phase function,
/// the light's `I / d^2` and transmittance out, which [`single_scattering_exact`] sums.
pub fn single_scattering(sigma_t: Rgb, albedo: Rgb, phase: Phase, intensity: f32) -> TestScene {
    let medium = Medium::Homogeneous(Homogeneous::new(sigma_t, albedo, Rgb::ZERO, phase));
    ball_behind(
        SurfaceMaterial::null(),
        medium,
        2.0,
        vec![Light::point(LIGHT, Rgb::splat(intensity))],
        through_the_centre(),
        false,
    )
}

/// Where [`single_scattering`]'s light is.
const LIGHT: Vec3A = Vec3A::new(0.5, 0.0, 0.0);

/// The radiance [`single_scattering`] gives along its probe ray, by the midpoint rule over the
/// chord (200,000 steps, in f64).
pub fn single_scattering_exact(sigma_t: Rgb, albedo: Rgb, phase: Phase, intensity: f32) -> Rgb {
    let n = 200_000;
    let dz = 4.0 / n as f64;
    let mut sum = [0.0f64; 3];
    for i in 0..n {
        let z = -2.0 + (i as f64 + 0.5) * dz;
        let p = Vec3A::new(0.0, 0.0, z as f32);
        let to_light = LIGHT - p;
        let d2 = to_light.length_squared() as f64;
        let d = d2.sqrt();
        let f = phase.eval(-Vec3A::Z, to_light / d as f32) as f64;
        for c in 0..3 {
            let st = sigma_t[c] as f64;
            let ss = st * albedo[c] as f64;
            let tr = (-st * (z + 2.0)).exp() * (-st * d).exp();
            sum[c] += tr * ss * f * intensity as f64 / d2 * dz;
        }
    }
    Rgb::new(sum[0] as f32, sum[1] as f32, sum[2] as f32)
}

/// Batches of a density estimate's samples in [`expect_rgb_within`].
const DENSITY_BATCHES: u32 = 16;

/// Asserts that integrator `name` (with `params`) matches `expected` in every channel by a
/// t-test over `n` probe rays (|t| < 4, and a standard error small enough to see a 5% bias).
pub fn expect_rgb(name: &str, params: &[(&str, &str)], scene: &TestScene, expected: Rgb, n: u32) {
    expect_rgb_within(name, params, scene, expected, n, 0.0);
}

/// [`expect_rgb`] for a density estimate, allowing besides the noise a relative bias `bias`
/// (its blur, which more samples do not shrink). Its camera samples share the photons of
/// their pass, which makes them correlated, so the samples are split into batches, each
/// with its own integrator and photons (seed), and the standard error comes from the spread
/// of the batches' means.
pub fn expect_rgb_within(
    name: &str,
    params: &[(&str, &str)],
    scene: &TestScene,
    expected: Rgb,
    n: u32,
    bias: f64,
) {
    let batches = if bias > 0.0 { DENSITY_BATCHES } else { 1 };
    let given: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let per_batch = n / batches;
    let mut means = Vec::new();
    let (mut sum, mut sum_sq) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
    for batch in 0..batches {
        let mut integrator = crate::find(name)
            .and_then(|e| e.instantiate(&given))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        // The batch's first pass (the photon integrators' maps).
        let camera = super::probe_camera(&scene.camera, 1);
        integrator.prepare_pass(&crate::PassContext {
            scene,
            camera: &camera,
            seed: 777 + batch as u64,
            pass: 0,
            rows: 0..camera.height,
            stop: crate::Stop::NEVER,
            lambda: Wavelengths::Rgb,
        });
        let rays = super::as_ray_integrator(name, integrator.as_ref());
        let mut tracer = crate::Tracer::new(scene);
        let mut batch_sum = glam::DVec3::ZERO;
        for i in batch * per_batch..(batch + 1) * per_batch {
            let mut sampler = crate::Sampler::new(777, i as u64, 0);
            let ray = super::camera_ray(&scene.camera, &mut sampler);
            let l = rays
                .radiance(&ray, &mut tracer, &mut sampler, &mut Wavelengths::Rgb)
                .truncate()
                .as_dvec3();
            assert!(l.is_finite(), "{name}: non-finite sample {l}");
            batch_sum += l;
            sum_sq += l * l;
        }
        sum += batch_sum;
        means.push(batch_sum / per_batch as f64);
    }
    let n = per_batch * batches;
    let mean = sum / n as f64;
    let se = if batches > 1 {
        let k = batches as f64;
        let var = means
            .iter()
            .map(|m| (*m - mean) * (*m - mean))
            .sum::<glam::DVec3>()
            / (k - 1.0);
        (var / k).powf(0.5)
    } else {
        let var = (sum_sq / n as f64 - mean * mean).max(glam::DVec3::ZERO)
            * (n as f64 / (n as f64 - 1.0));
        (var / n as f64).powf(0.5)
    };
    for c in 0..3 {
        let e = expected[c] as f64;
        let off = ((mean[c] - e).abs() - bias * e.abs()).max(0.0);
        let t = off / se[c].max(1e-9 * e.abs().max(1e-30));
        assert!(
            t < 4.0 || (se[c] == 0.0 && off <= 1e-5 * e.abs()),
            "{name} {params:?} channel {c}: mean {:.5} +- {:.5}, expected {e:.5} (t = {t:.2})",
            mean[c],
            se[c]
        );
        assert!(
            se[c] < e.abs() / 80.0 || e == 0.0,
            "{name} channel {c}: standard error {:.5} too large to see a 5% bias of {e:.5}",
            se[c]
        );
    }
}
