//! Oren–Nayar rough diffuse reflection (the report's equations 9 and 10): the "qualitative"
//! model of Oren & Nayar, "Generalization of Lambert's Reflectance Model" (SIGGRAPH 1994).
//!
//! The surface is a collection of long symmetric V-cavities whose sides are Lambertian; the
//! facet slope angles are normally distributed with standard deviation `sigma`. Rough surfaces
//! look flatter than Lambertian ones and brighter towards the light source (back-scatter).
//!
//! ```text
//! f(wo, wi) = albedo / pi * (A + B * max(0, cos(phi_i - phi_o)) * sin(alpha) * tan(beta))
//! alpha = max(theta_i, theta_o),  beta = min(theta_i, theta_o)
//! A = 1 - 0.5 * sigma^2 / (sigma^2 + 0.33),  B = 0.45 * sigma^2 / (sigma^2 + 0.09)
//! ```
//!
//! Parameters and units:
//! * `albedo`: diffuse reflectance per channel, unitless, in `[0, 1]`.
//! * `sigma`: roughness, the standard deviation of the facet slope angle. The constructor
//!   [`OrenNayar::new`] takes it in **degrees** (the scene format's unit) and the struct stores
//!   it in **radians**, which is the unit the `A`/`B` formulas expect. `sigma = 0` is Lambert.
//!
//! **`tan(beta)`, not `sin(beta)`.** The report's equation 9 writes `sin(alpha) sin(beta)`.
//! Oren & Nayar's qualitative model (their equation 30, and pbrt's `OrenNayar`) has
//! `sin(alpha) tan(beta)`: the `A`, `B` constants were fitted to the full model with that
//! functional form. `sin(beta)` lacks the `1 / cos(beta)` factor, which only matters when both
//! directions are far from the normal, i.e. exactly in the back-scattering configurations that
//! distinguish a rough surface from a Lambertian one, so it would under-predict the effect the
//! model exists for. This file implements `tan(beta)`.
//!
//! **Evaluation without trigonometry.** With `cos(phi_i - phi_o) sin(theta_i) sin(theta_o) =
//! wi.x wo.x + wi.y wo.y`, `sin(alpha) sin(beta) = sin(theta_i) sin(theta_o)` and
//! `cos(beta) = max(cos theta_i, cos theta_o)`:
//!
//! ```text
//! max(0, cos(phi_i - phi_o)) sin(alpha) tan(beta) = max(0, wi.x wo.x + wi.y wo.y) / max(wi.z, wo.z)
//! ```
//!
//! which needs no `acos`/`atan2`, and is well defined at `theta = 0` (the numerator vanishes,
//! as the azimuth term must).
//!
//! **Energy.** The directional albedo is `albedo * A` at normal incidence and rises to
//! `albedo * (A + B/2)` at grazing incidence. The qualitative fit is not exactly energy
//! conserving: `A + B/2` exceeds 1 for `0 < sigma < ~20°` (at most by 1.5%, near
//! `sigma = 11.4°`, and only for `wo` beyond about 70° from the normal; the albedo grows
//! monotonically towards grazing). For `sigma >= 20°` it stays below 1. This is a property of
//! the published model and is left as is.
//!
//! Sampling is cosine-weighted over the hemisphere (`pdf = cos(theta_i) / pi`).

use super::{BsdfSample, Bxdf, Lobes};
use crate::sampling::cosine_hemisphere_pdf;
use crate::Spectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// The qualitative Oren–Nayar rough diffuse BRDF (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct OrenNayar {
    /// Diffuse reflectance per channel, unitless, in `[0, 1]`.
    pub albedo: Spectrum,
    /// Roughness: standard deviation of the facet slope angle, in radians.
    pub sigma: f32,
    a: f32,
    b: f32,
}

impl OrenNayar {
    /// `sigma_degrees`: facet slope standard deviation in degrees (the scene format's unit);
    /// it is stored in radians in [`OrenNayar::sigma`].
    /// Oren–Nayar of reflectance `albedo` (in `[0, 1]`) and roughness `sigma_degrees` (the
    /// standard deviation of the facet angle, in `[0, 90]` degrees).
    pub fn checked(albedo: Spectrum, sigma_degrees: f32) -> Result<Self, String> {
        super::checks::finite("sigma", &[sigma_degrees])?;
        if !(0.0..=90.0).contains(&sigma_degrees) {
            return Err(format!(
                "sigma is in degrees and must be in [0, 90], got {sigma_degrees}"
            ));
        }
        let albedo = super::checks::reflectance("albedo", albedo)?;
        Ok(Self::new(albedo, sigma_degrees))
    }

    /// [`OrenNayar::checked`] without the checks, for parameters known to be valid.
    pub fn new(albedo: Spectrum, sigma_degrees: f32) -> Self {
        let sigma = sigma_degrees.to_radians();
        let s2 = sigma * sigma;
        OrenNayar {
            albedo,
            sigma,
            a: 1.0 - s2 / (2.0 * (s2 + 0.33)),
            b: 0.45 * s2 / (s2 + 0.09),
        }
    }
}

impl Bxdf for OrenNayar {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::DIFFUSE_REFLECTION
    }

    fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        if wi.z <= 0.0 || wo.z < 0.0 {
            return Spectrum::ZERO;
        }
        // max(0, cos(dphi)) sin(alpha) tan(beta); the denominator is >= wi.z > 0.
        let azimuth = (wi.x * wo.x + wi.y * wo.y).max(0.0) / wi.z.max(wo.z);
        self.albedo * (FRAC_1_PI * (self.a + self.b * azimuth))
    }

    fn pdf(&self, _wo: Vec3A, wi: Vec3A) -> f32 {
        cosine_hemisphere_pdf(wi.z)
    }

    fn sample(&self, wo: Vec3A, _u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        BsdfSample::cosine_weighted(u, |wi| self.eval(wo, wi))
    }

    fn albedo(&self) -> Spectrum {
        self.albedo
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{
        assert_chi2, assert_energy_conserving, check_sample_matches_eval, dir, Grid, SAMPLES,
    };
    use crate::Sampler;

    /// The textbook formula with explicit angles, independent of the trig-free rewrite.
    fn reference(albedo: Spectrum, sigma_deg: f64, wo: Vec3A, wi: Vec3A) -> Spectrum {
        let s2 = sigma_deg.to_radians().powi(2);
        let a = 1.0 - 0.5 * s2 / (s2 + 0.33);
        let b = 0.45 * s2 / (s2 + 0.09);
        let (ti, to) = ((wi.z as f64).acos(), (wo.z as f64).acos());
        let (pi, po) = (
            (wi.y as f64).atan2(wi.x as f64),
            (wo.y as f64).atan2(wo.x as f64),
        );
        let (alpha, beta) = (ti.max(to), ti.min(to));
        let v =
            (a + b * (pi - po).cos().max(0.0) * alpha.sin() * beta.tan()) / std::f64::consts::PI;
        albedo * v as f32
    }

    /// `integral f cos dwi` by a deterministic midpoint rule in (cos theta, phi).
    fn albedo_quadrature(on: &OrenNayar, wo: Vec3A) -> f64 {
        let (nz, np) = (400, 800);
        let mut sum = 0.0f64;
        for i in 0..nz {
            let z = (i as f64 + 0.5) / nz as f64;
            let r = (1.0 - z * z).sqrt();
            for j in 0..np {
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                let wi = Vec3A::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                sum += on.eval(wo, wi).x as f64 * z;
            }
        }
        sum * 2.0 * std::f64::consts::PI / (nz * np) as f64
    }

    #[test]
    fn matches_the_formula_with_tan_beta() {
        let albedo = crate::spectrum::rgb(0.9, 0.6, 0.3);
        let mut s = Sampler::new(301, 0, 0);
        for sigma in [0.0f32, 10.0, 30.0, 60.0] {
            let on = OrenNayar::new(albedo, sigma);
            assert!(
                (on.sigma - sigma.to_radians()).abs() < 1e-7,
                "sigma is stored in radians"
            );
            for _ in 0..2000 {
                let wo = crate::sampling::uniform_hemisphere(s.next_2d());
                let wi = crate::sampling::uniform_hemisphere(s.next_2d());
                let (f, r) = (on.eval(wo, wi), reference(albedo, sigma as f64, wo, wi));
                assert!(
                    (f - r).abs().max_element() <= 2e-4 * r.max_element() + 1e-6,
                    "{f} vs {r}"
                );
                // Reciprocity.
                assert!((f - on.eval(wi, wo)).abs().max_element() <= 1e-5 * f.max_element());
            }
        }
        // sigma = 0 is Lambert; theta = 0 is well defined.
        let lambert = OrenNayar::new(albedo, 0.0);
        assert!(
            (lambert.eval(dir(70.0, 0.0), dir(70.0, 180.0)) - albedo * FRAC_1_PI).length() < 1e-6
        );
        let on = OrenNayar::new(albedo, 30.0);
        let f = on.eval(Vec3A::Z, Vec3A::Z);
        assert!(f.is_finite() && (f - albedo * (on.a * FRAC_1_PI)).length() < 1e-6);
        assert_eq!(
            on.eval(dir(30.0, 0.0), Vec3A::new(0.6, 0.0, -0.8)),
            Spectrum::ZERO
        );
    }

    #[test]
    fn directional_albedo_is_a_at_normal_and_a_plus_half_b_at_grazing_incidence() {
        for sigma in [15.0f32, 30.0, 60.0] {
            let on = OrenNayar::new(Spectrum::ONE, sigma);
            let normal = albedo_quadrature(&on, Vec3A::Z);
            assert!(
                (normal - on.a as f64).abs() < 1e-4,
                "sigma {sigma}: {normal} vs A = {}",
                on.a
            );
            let grazing = albedo_quadrature(&on, Vec3A::X);
            let expected = (on.a + 0.5 * on.b) as f64;
            assert!(
                (grazing - expected).abs() < 1e-4,
                "sigma {sigma}: {grazing} vs {expected}"
            );
        }
    }

    #[test]
    fn conserves_energy_for_sigma_of_20_degrees_and_more() {
        let albedo = crate::spectrum::rgb(1.0, 0.7, 0.2);
        for sigma in [20.0f32, 30.0, 60.0, 90.0] {
            let on = OrenNayar::new(albedo, sigma);
            for theta in [0.0f32, 30.0, 60.0, 80.0, 89.0] {
                assert_energy_conserving("Oren-Nayar", &on, dir(theta, 40.0), albedo, 100_000, 302);
            }
        }
        // The documented limitation: below ~20 degrees the qualitative fit reflects up to 1.5%
        // too much at grazing incidence, never more.
        let worst = (1..=900)
            .map(|i| OrenNayar::new(Spectrum::ONE, i as f32 * 0.1))
            .map(|on| on.a + 0.5 * on.b)
            .fold(0.0f32, f32::max);
        assert!(worst > 1.01 && worst < 1.016, "{worst}");
    }

    #[test]
    fn sample_matches_eval() {
        for (sigma, theta) in [(20.0, 0.0), (20.0, 75.0), (60.0, 45.0), (60.0, 89.5)] {
            check_sample_matches_eval(
                &OrenNayar::new(crate::spectrum::rgb(0.8, 0.5, 0.3), sigma),
                dir(theta, 33.0),
                20_000,
                303,
            );
        }
    }

    fn chi2(name: &str, sigma: f32, theta: f32, seed: u64) {
        let on = OrenNayar::new(crate::spectrum::rgb(0.8, 0.5, 0.3), sigma);
        let wo = dir(theta, 20.0);
        assert_chi2(
            name,
            &Grid::hemisphere(20, 40),
            SAMPLES,
            seed,
            |s| on.sample(wo, s.next_1d(), s.next_2d()).map(|b| b.wi),
            |w| on.pdf(wo, w),
        );
    }

    #[test]
    fn chi2_sigma20_wo30() {
        chi2("Oren-Nayar sigma 20 wo 30", 20.0, 30.0, 311);
    }

    #[test]
    fn chi2_sigma20_wo80() {
        chi2("Oren-Nayar sigma 20 wo 80", 20.0, 80.0, 312);
    }

    #[test]
    fn chi2_sigma60_wo0() {
        chi2("Oren-Nayar sigma 60 wo 0", 60.0, 0.0, 313);
    }

    #[test]
    fn chi2_sigma60_wo80() {
        chi2("Oren-Nayar sigma 60 wo 80", 60.0, 80.0, 314);
    }
}
