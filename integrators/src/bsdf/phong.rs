//! Energy-conserving normalised ("modified") Phong: Lafortune & Willems, "Using the Modified
//! Phong Reflectance Model for Physically Based Rendering" (1994).
//!
//! ```text
//! f(wo, wi) = kd / pi + ks * (n + 2) / (2 pi) * max(0, cos(alpha))^n
//! ```
//!
//! where `alpha` is the angle between `wi` and `r = (-wo.x, -wo.y, wo.z)`, the mirror
//! reflection of `wo` about the normal.
//!
//! Parameters and units:
//! * `kd`: diffuse reflectance per channel, unitless.
//! * `ks`: specular reflectance per channel, unitless: the fraction of light the lobe reflects
//!   at normal incidence.
//! * `exponent` (`n`): Phong exponent, unitless, `>= 0` (0 is a broad lobe; larger is
//!   shinier). Negative or NaN exponents are treated as 0.
//!
//! With `kd + ks <= 1` in every channel the model never reflects more energy than it receives.
//!
//! # Why not the report's equation 8
//!
//! The report's equation 8, `I = kd (N.L) + ks (N.H)^n` with an unnormalised half vector
//! `H = (L + V) / 2`, is a shading formula for the reflected *intensity*, not a BRDF:
//!
//! * **Not energy conserving.** Read as a BRDF it is `f = kd + ks (N.H)^n / (N.L)`. The
//!   diffuse part alone reflects `pi * kd` of the incident energy (no `1/pi`), so `kd = 1`
//!   creates energy by a factor of `pi`. The specular part's reflectance is
//!   `ks / (N.L) * integral (N.H)^n cos(theta_v) dv`: the `1 / (N.L)` makes it grow without
//!   bound as the light approaches grazing, so no `ks > 0` is safe, and for a fixed `ks` the
//!   integral shrinks roughly like `1 / n`, so shinier materials get darker and the
//!   highlight's brightness is tied to its width.
//! * **Not reciprocal.** Dividing out the `N.L` of the irradiance leaves a `1 / (N.L)` in the
//!   specular term, which is not symmetric under exchanging `L` and `V`; Helmholtz reciprocity
//!   `f(wo, wi) = f(wi, wo)` fails (and with the literal `H = L + V/2` even `H` itself is not
//!   symmetric).
//!
//! The modified Phong model fixes both. `cos(alpha) = dot(reflect(wo), wi) = dot(wo,
//! reflect(wi))` is symmetric, and there is no `1 / cos` factor, so `f` is reciprocal. The
//! factor `(n + 2) / (2 pi)` is the normalisation that makes the lobe's reflectance
//! `integral (n + 2) / (2 pi) cos(alpha)^n cos(theta_i) dwi` exactly 1 at normal incidence
//! (where `alpha = theta_i`), and at other incidences the lobe's cosine-weighted integral is
//! smaller (part of it points below the horizon, and `cos(theta_i) <= 1`), so the specular
//! reflectance is at most `ks`. The diffuse term `kd / pi` reflects exactly `kd`. Hence the
//! total reflectance is at most `kd + ks`, and `kd + ks <= 1` guarantees energy conservation
//! for every exponent, and the highlight's total energy no longer depends on `n`.
//!
//! # Sampling
//!
//! The specular lobe is picked with probability `p_s = lum(ks) / (lum(kd) + lum(ks))` (0 when
//! both are black), and then `cos(alpha) = u^(1 / (n + 1))` around `r` (lobe density
//! `(n + 1) / (2 pi) cos(alpha)^n`); otherwise `wi` is cosine-distributed. Samples below the
//! horizon are rejected. [`Bxdf::pdf`] is the mixture density
//! `(1 - p_s) cos(theta_i) / pi + p_s (n + 1) / (2 pi) cos(alpha)^n`, and [`Bxdf::sample`]
//! returns that same mixture density and the full `f`, so that MIS weights are consistent.

use super::{BsdfSample, Bxdf, Lobes};
use crate::sampling::cosine_hemisphere;
use crate::spectrum::rgb_of;
use crate::{luminance, Frame, Spectrum};
use glam::{Vec2, Vec3A};
use std::f32::consts::{FRAC_1_PI, PI};

/// The modified (normalised) Phong BRDF (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Phong {
    /// Diffuse reflectance per channel, unitless.
    pub kd: Spectrum,
    /// Specular reflectance per channel (at normal incidence), unitless.
    pub ks: Spectrum,
    /// Phong exponent `n >= 0`, unitless.
    pub exponent: f32,
}

/// Mirror reflection of `w` about the normal `+z`.
#[inline]
fn reflect(w: Vec3A) -> Vec3A {
    Vec3A::new(-w.x, -w.y, w.z)
}

impl Phong {
    /// The exponent, with negative and NaN values mapped to 0.
    #[inline]
    fn n(&self) -> f32 {
        self.exponent.max(0.0)
    }

    /// Probability of sampling the specular lobe.
    #[inline]
    fn specular_probability(&self) -> f32 {
        let d = luminance(rgb_of(self.kd)).max(0.0);
        let s = luminance(rgb_of(self.ks)).max(0.0);
        let total = d + s;
        if total > 0.0 && total.is_finite() {
            s / total
        } else {
            0.0
        }
    }

    /// `cos(alpha)^n` for the lobe around the mirror direction, or 0 behind it.
    #[inline]
    fn lobe_cos_pow(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        let cos_alpha = reflect(wo).dot(wi);
        if cos_alpha > 0.0 {
            cos_alpha.min(1.0).powf(self.n())
        } else {
            0.0
        }
    }
}

impl Phong {
    /// Energy-conserving Phong: diffuse `kd` and specular `ks` reflectances with
    /// `kd + ks <= 1` per channel, and a lobe `exponent` in `[0, 1e5]` (beyond that `cos^n`
    /// underflows in f32 and sampling no longer matches the density: use a mirror).
    pub fn new(kd: Spectrum, ks: Spectrum, exponent: f32) -> Result<Phong, String> {
        use super::checks::{finite, reflectance};
        let (kd, ks) = (reflectance("kd", kd)?, reflectance("ks", ks)?);
        if (kd + ks).max_element() > 1.0 + 1e-6 {
            return Err(format!(
                "kd + ks must be <= 1 per channel to conserve energy, got {:?}",
                rgb_of(kd + ks).to_array()
            ));
        }
        finite("exponent", &[exponent])?;
        if !(0.0..=1e5).contains(&exponent) {
            return Err(format!(
                "exponent must be in [0, 1e5] (use Mirror for a perfect reflector), got {exponent}"
            ));
        }
        Ok(Phong { kd, ks, exponent })
    }
}

impl Bxdf for Phong {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::DIFFUSE_REFLECTION.with(Lobes::GLOSSY_REFLECTION)
    }

    fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        if wi.z <= 0.0 || wo.z < 0.0 {
            return Spectrum::ZERO;
        }
        let lobe = (self.n() + 2.0) * (0.5 * FRAC_1_PI) * self.lobe_cos_pow(wo, wi);
        self.kd * FRAC_1_PI + self.ks * lobe
    }

    fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if wi.z <= 0.0 || wo.z < 0.0 {
            return 0.0;
        }
        let ps = self.specular_probability();
        let diffuse = (1.0 - ps) * wi.z * FRAC_1_PI;
        if ps > 0.0 {
            diffuse + ps * (self.n() + 1.0) * (0.5 * FRAC_1_PI) * self.lobe_cos_pow(wo, wi)
        } else {
            diffuse
        }
    }

    fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z < 0.0 {
            return None;
        }
        let wi = if u_lobe < self.specular_probability() {
            let cos_alpha = u.x.powf(1.0 / (self.n() + 1.0));
            let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
            let (sin_phi, cos_phi) = (2.0 * PI * u.y).sin_cos();
            let local = Vec3A::new(sin_alpha * cos_phi, sin_alpha * sin_phi, cos_alpha);
            Frame::from_normal(reflect(wo)).to_world(local)
        } else {
            cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        BsdfSample::evaluated(self, wo, wi)
    }

    fn albedo(&self) -> Spectrum {
        self.kd + self.ks
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{
        assert_chi2, assert_energy_conserving, check_sample_matches_eval, dir, directional_albedo,
        Grid, SAMPLES,
    };
    use crate::Sampler;

    fn phong(kd: f32, ks: f32, exponent: f32) -> Phong {
        Phong {
            kd: Spectrum::splat(kd),
            ks: Spectrum::splat(ks),
            exponent,
        }
    }

    #[test]
    fn eval_is_the_normalised_lobe_and_reciprocal() {
        let p = Phong {
            kd: crate::spectrum::rgb(0.3, 0.2, 0.1),
            ks: crate::spectrum::rgb(0.5, 0.6, 0.7),
            exponent: 20.0,
        };
        let mut s = Sampler::new(401, 0, 0);
        for _ in 0..5000 {
            let wo = crate::sampling::uniform_hemisphere(s.next_2d());
            let wi = crate::sampling::uniform_hemisphere(s.next_2d());
            let f = p.eval(wo, wi);
            assert!(
                (f - p.eval(wi, wo)).abs().max_element() <= 1e-5 * f.max_element(),
                "not reciprocal"
            );
            // Independent formula: alpha from acos of the angle to the mirror direction.
            let r = Vec3A::new(-wo.x, -wo.y, wo.z);
            let alpha = r.dot(wi).clamp(-1.0, 1.0).acos();
            let lobe = if alpha < 0.5 * PI {
                22.0 / (2.0 * PI) * alpha.cos().powi(20)
            } else {
                0.0
            };
            let expected = p.kd / PI + p.ks * lobe;
            assert!(
                (f - expected).abs().max_element() <= 1e-3 * expected.max_element() + 1e-6,
                "{f} vs {expected}"
            );
        }
        assert_eq!(
            p.eval(dir(20.0, 0.0), Vec3A::new(0.0, 0.6, -0.8)),
            Spectrum::ZERO
        );
        assert_eq!(p.pdf(dir(20.0, 0.0), Vec3A::new(0.0, 0.6, -0.8)), 0.0);
    }

    #[test]
    fn specular_lobe_reflects_exactly_ks_at_normal_incidence() {
        for n in [0.0, 1.0, 10.0, 100.0, 1000.0] {
            let p = phong(0.0, 1.0, n);
            let (mean, err) = directional_albedo(&p, Vec3A::Z, 200_000, 402);
            assert!(
                (mean.x - 1.0).abs() < 5.0 * err.x + 1e-4,
                "n {n}: {mean} +- {err}"
            );
        }
    }

    #[test]
    fn conserves_energy_with_kd_plus_ks_at_most_one() {
        for (kd, ks) in [(0.0, 1.0), (0.5, 0.5), (0.9, 0.1), (0.2, 0.7)] {
            for n in [0.0, 1.0, 10.0, 100.0] {
                for theta in [0.0, 45.0, 80.0, 89.0] {
                    let p = phong(kd, ks, n);
                    assert_energy_conserving(
                        "Phong",
                        &p,
                        dir(theta, 15.0),
                        Spectrum::splat(kd + ks),
                        50_000,
                        403,
                    );
                }
            }
        }
    }

    #[test]
    fn sample_matches_eval_and_pdf() {
        for (kd, ks, n, theta) in [
            (0.5, 0.5, 0.0, 30.0),
            (0.2, 0.7, 1.0, 60.0),
            (0.3, 0.6, 10.0, 0.0),
            (0.1, 0.9, 100.0, 85.0),
            (0.0, 1.0, 1000.0, 89.0),
            (0.7, 0.0, 5.0, 40.0),
        ] {
            check_sample_matches_eval(&phong(kd, ks, n), dir(theta, 250.0), 20_000, 404);
        }
        // Coloured: lobe selection by luminance.
        let p = Phong {
            kd: crate::spectrum::rgb(0.6, 0.1, 0.0),
            ks: crate::spectrum::rgb(0.0, 0.3, 0.9),
            exponent: 30.0,
        };
        check_sample_matches_eval(&p, dir(50.0, 10.0), 20_000, 405);
    }

    #[test]
    fn black_material_samples_without_nans() {
        let p = phong(0.0, 0.0, 10.0);
        let mut s = Sampler::new(406, 0, 0);
        for _ in 0..1000 {
            if let Some(b) = p.sample(dir(30.0, 0.0), s.next_1d(), s.next_2d()) {
                assert!(b.weight() == Spectrum::ZERO && b.pdf > 0.0);
            }
        }
        let neg = phong(0.5, 0.5, -3.0);
        assert!(neg.eval(dir(10.0, 0.0), dir(10.0, 180.0)).is_finite());
    }

    fn chi2(name: &str, p: &Phong, wo: Vec3A, grid: &Grid, seed: u64) {
        assert_chi2(
            name,
            grid,
            SAMPLES,
            seed,
            |s| p.sample(wo, s.next_1d(), s.next_2d()).map(|b| b.wi),
            |w| p.pdf(wo, w),
        );
    }

    #[test]
    fn chi2_n1() {
        chi2(
            "Phong n 1 wo 30 kd .5 ks .5",
            &phong(0.5, 0.5, 1.0),
            dir(30.0, 60.0),
            &Grid::hemisphere(20, 40),
            411,
        );
    }

    #[test]
    fn chi2_n10() {
        chi2(
            "Phong n 10 wo 60 kd .2 ks .7",
            &phong(0.2, 0.7, 10.0),
            dir(60.0, 100.0),
            &Grid::hemisphere(20, 40),
            412,
        );
    }

    #[test]
    fn chi2_n100_around_the_mirror_direction() {
        let wo = dir(10.0, 300.0);
        let r = Vec3A::new(-wo.x, -wo.y, wo.z);
        // A cap around the mirror direction out to cos(alpha) = 0.9 (0.9^100 ~ 3e-5) holds the
        // lobe; the diffuse rest lands in the overflow cell.
        chi2(
            "Phong n 100 wo 10 kd .3 ks .6",
            &phong(0.3, 0.6, 100.0),
            wo,
            &Grid::new(r, 0.1, 20, 40),
            413,
        );
    }

    #[test]
    fn chi2_n100_grazing() {
        chi2(
            "Phong n 100 wo 85 kd .1 ks .9",
            &phong(0.1, 0.9, 100.0),
            dir(85.0, 10.0),
            &Grid::hemisphere(40, 80),
            414,
        );
    }

    #[test]
    fn chi2_n10_grazing_pure_specular() {
        chi2(
            "Phong n 10 wo 89 kd 0 ks 1",
            &phong(0.0, 1.0, 10.0),
            dir(89.0, 200.0),
            &Grid::hemisphere(20, 40),
            415,
        );
    }

    #[test]
    fn chi2_n0() {
        chi2(
            "Phong n 0 wo 45 kd .4 ks .4",
            &phong(0.4, 0.4, 0.0),
            dir(45.0, 0.0),
            &Grid::hemisphere(20, 40),
            416,
        );
    }
}
