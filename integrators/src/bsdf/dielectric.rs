//! Smooth dielectric (glass, water): Fresnel-weighted specular reflection and refraction
//! (Mitsuba 3's `dielectric`; RON `Dielectric`, or `Glass`).
//!
//! Parameters and units:
//! * `ior`: index of refraction of the inside relative to the outside, unitless (`int_ior /
//!   ext_ior`; 1.5 for glass in air, below 1 for a bubble). The outside is the side the normal
//!   faces (`z > 0` in the local frame).
//! * `reflectance`, `transmittance`: per-channel multipliers of the two lobes, unitless, in
//!   `[0, 1]` (Mitsuba's `specular_reflectance` and `specular_transmittance`; the RON `Glass`
//!   sets both to its `tint`). They scale the lobes' weights, not the choice between them.
//!
//! Both lobes are Dirac deltas. [`Bxdf::sample`] picks reflection with probability `F` (the
//! exact unpolarised Fresnel reflectance, [`fresnel_dielectric`]) and refraction otherwise, so
//! the throughput weight `f |cos(wi)| / pdf` is `reflectance` for reflection and
//! `transmittance / eta^2` for refraction, `eta` being the relative IOR (transmitted side over
//! the side of `wo`). The `1 / eta^2` is the compression of solid angle on refraction: radiance
//! carried along camera paths is scaled by it (pbrt-v4's `TransportMode::Radiance`).
//!
//! Unlike the opaque models, a dielectric sees the true side of the surface: `wo.z > 0` means
//! the ray arrives from outside, `wo.z < 0` from inside.

use super::fresnel::fresnel_dielectric;
use super::{BsdfSample, Bxdf, Lobes};
use crate::Spectrum;
use glam::{Vec2, Vec3A};

/// A smooth dielectric interface (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Dielectric {
    /// Index of refraction inside relative to outside (outside = the side the normal faces).
    pub ior: f32,
    /// Per-channel multiplier of reflection, unitless.
    pub reflectance: Spectrum,
    /// Per-channel multiplier of transmission, unitless.
    pub transmittance: Spectrum,
}

/// Range of relative IORs a dielectric may have: every material of the field's tables lies
/// well inside it (diamond in air is 2.42, air in diamond 0.41).
pub const IOR_RANGE: std::ops::RangeInclusive<f32> = 0.25..=4.0;

/// The relative IOR `int_ior / ext_ior`, both finite and positive and their ratio in
/// [`IOR_RANGE`].
pub fn relative_ior(int_ior: f32, ext_ior: f32) -> Result<f32, String> {
    super::checks::finite("ior", &[int_ior, ext_ior])?;
    if !(int_ior > 0.0 && ext_ior > 0.0) {
        return Err(format!(
            "int_ior and ext_ior must be positive, got {int_ior} and {ext_ior}"
        ));
    }
    let ior = int_ior / ext_ior;
    if !IOR_RANGE.contains(&ior) {
        return Err(format!(
            "the relative ior int_ior / ext_ior must be in [0.25, 4], got {ior}"
        ));
    }
    Ok(ior)
}

impl Dielectric {
    /// A dielectric of relative index of refraction `ior` (in [`IOR_RANGE`]) whose lobes are
    /// scaled by `reflectance` and `transmittance` (each channel in `[0, 1]`).
    pub fn new(
        ior: f32,
        reflectance: Spectrum,
        transmittance: Spectrum,
    ) -> Result<Dielectric, String> {
        super::checks::finite("ior", &[ior])?;
        if !IOR_RANGE.contains(&ior) {
            return Err(format!("ior must be in [0.25, 4], got {ior}"));
        }
        Ok(Dielectric {
            ior,
            reflectance: super::checks::reflectance("specular_reflectance", reflectance)?,
            transmittance: super::checks::reflectance("specular_transmittance", transmittance)?,
        })
    }

    /// Glass of relative IOR `ior` with both lobes tinted by `tint`, unchecked: for tests and
    /// the built-in scenes.
    pub const fn unchecked(ior: f32, tint: Spectrum) -> Dielectric {
        Dielectric {
            ior,
            reflectance: tint,
            transmittance: tint,
        }
    }
}

impl Bxdf for Dielectric {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::DELTA_REFLECTION.with(Lobes::DELTA_TRANSMISSION)
    }

    fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Spectrum {
        Spectrum::ZERO
    }

    fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        0.0
    }

    fn sample(&self, wo: Vec3A, u_lobe: f32, _u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.z.is_finite() || !(self.ior > 0.0 && self.ior.is_finite()) {
            return None;
        }
        let fresnel = fresnel_dielectric(wo.z, self.ior);
        if u_lobe < fresnel {
            let wi = Vec3A::new(-wo.x, -wo.y, wo.z);
            return Some(BsdfSample {
                wi,
                f: self.reflectance * (fresnel / wi.z.abs()),
                pdf: fresnel,
                specular: true,
                eta: 1.0,
            });
        }
        let transmit = 1.0 - fresnel;
        if transmit <= 0.0 {
            return None;
        }
        // Relative IOR (transmitted side over the side of wo) and the normal on wo's side.
        let (eta, side) = if wo.z > 0.0 {
            (self.ior, 1.0)
        } else {
            (1.0 / self.ior, -1.0)
        };
        let cos_i = wo.z.abs();
        let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
        if sin2_t >= 1.0 {
            return None; // total internal reflection: fresnel was 1, unreachable for u_lobe < 1
        }
        let cos_t = (1.0 - sin2_t).sqrt();
        // Snell's law: wi = -wo / eta + (cos_i / eta - cos_t) n, with n = (0, 0, side).
        let wi = Vec3A::new(-wo.x / eta, -wo.y / eta, -side * cos_t);
        if cos_t <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: self.transmittance * (transmit / (cos_t * eta * eta)),
            pdf: transmit,
            specular: true,
            eta,
        })
    }

    fn albedo(&self) -> Spectrum {
        self.reflectance
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::dir;
    use crate::Sampler;

    const GLASS: Dielectric = Dielectric::unchecked(1.5, crate::spectrum::rgb(1.0, 0.9, 0.8));

    #[test]
    fn normal_incidence_reflectance_is_four_percent() {
        let r = fresnel_dielectric(1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-6, "{r}");
        assert!(
            (fresnel_dielectric(-1.0, 1.5) - 0.04).abs() < 1e-6,
            "same from inside"
        );
        // Sampling frequency of reflection: binomial, 5 standard errors.
        let n = 1_000_000;
        let mut s = Sampler::new(501, 0, 0);
        let reflected = (0..n)
            .filter_map(|_| GLASS.sample(Vec3A::Z, s.next_1d(), s.next_2d()))
            .filter(|b| b.wi.z > 0.0)
            .count();
        let freq = reflected as f64 / n as f64;
        let sd = (0.04 * 0.96 / n as f64).sqrt();
        println!(
            "glass: reflection frequency at normal incidence {freq:.5} (expected 0.04 +- {sd:.5})"
        );
        assert!((freq - 0.04).abs() < 5.0 * sd, "{freq}");
    }

    #[test]
    fn fresnel_limits_and_symmetry() {
        assert_eq!(fresnel_dielectric(0.0, 1.5), 1.0, "grazing");
        assert!(fresnel_dielectric(0.7, 1.0) < 1e-12, "index matched");
        // Textbook value: 45 degrees into glass n = 1.5: Rs = 0.0920, Rp = 0.0085.
        let r45 = fresnel_dielectric(std::f32::consts::FRAC_1_SQRT_2, 1.5);
        assert!((r45 - 0.5 * (0.092_0 + 0.008_5)).abs() < 2e-4, "{r45}");
        // The reflectance is the same from both sides for a refracted pair of angles.
        for theta_i in [5.0f32, 30.0, 60.0, 85.0] {
            let (si, ci) = theta_i.to_radians().sin_cos();
            let ct = (1.0 - (si / 1.5) * (si / 1.5)).sqrt();
            let (outside, inside) = (fresnel_dielectric(ci, 1.5), fresnel_dielectric(-ct, 1.5));
            assert!(
                (outside - inside).abs() < 1e-5,
                "{theta_i}: {outside} vs {inside}"
            );
        }
        // Monotone towards grazing incidence from outside (above Brewster's angle).
        assert!(fresnel_dielectric(0.2, 1.5) > fresnel_dielectric(0.5, 1.5));
    }

    #[test]
    fn total_internal_reflection_past_the_critical_angle() {
        let critical = (1.0f32 / 1.5).asin().to_degrees(); // 41.8 degrees
        for theta in [critical + 0.5, 60.0, 89.0] {
            let (s, c) = theta.to_radians().sin_cos();
            assert_eq!(fresnel_dielectric(-c, 1.5), 1.0, "{theta}");
            let wo = Vec3A::new(s, 0.0, -c); // inside the glass
            for u in [0.0, 0.5, 0.999_999_9] {
                let b = GLASS.sample(wo, u, Vec2::ZERO).expect("reflects");
                assert!(b.specular && b.pdf == 1.0 && b.wi.z < 0.0);
                assert!((b.weight() - GLASS.reflectance).abs().max_element() < 1e-5);
            }
        }
        // Just inside the critical angle some light still leaves.
        let (s, c) = (critical - 1.0).to_radians().sin_cos();
        assert!(fresnel_dielectric(-c, 1.5) < 1.0);
        assert!(GLASS
            .sample(Vec3A::new(s, 0.0, -c), 0.9999, Vec2::ZERO)
            .is_some_and(|b| b.wi.z > 0.0));
    }

    #[test]
    fn refraction_obeys_snell_and_carries_one_over_eta_squared() {
        for (theta, phi) in [(0.0f32, 0.0f32), (30.0, 20.0), (60.0, 135.0), (85.0, 270.0)] {
            // From outside: refract into the glass.
            let wo = dir(theta, phi);
            let f = fresnel_dielectric(wo.z, 1.5);
            let b = GLASS.sample(wo, 0.999, Vec2::ZERO).expect("refracts");
            assert!(b.specular && b.wi.z < 0.0 && (b.wi.length() - 1.0).abs() < 1e-5);
            assert!((b.pdf - (1.0 - f)).abs() < 1e-6);
            let (sin_i, sin_t) = (wo.truncate().length(), b.wi.truncate().length());
            assert!(
                (sin_i - 1.5 * sin_t).abs() < 1e-5,
                "Snell: {sin_i} vs 1.5 * {sin_t}"
            );
            if theta > 0.0 {
                // Same plane of incidence, on the other side of the normal.
                assert!(wo.truncate().normalize().dot(b.wi.truncate().normalize()) < -0.9999);
            }
            assert!(
                (b.weight() - GLASS.reflectance / 2.25).abs().max_element() < 1e-5,
                "{}",
                b.weight()
            );
            // Reversed, from inside (wo = the transmitted direction): the path refracts back
            // out along the original wo, with weight tint * eta^2.
            let back = GLASS.sample(b.wi, 0.999, Vec2::ZERO).expect("refracts out");
            assert!((back.wi - wo).length() < 1e-4, "{:?} vs {wo:?}", back.wi);
            assert!(
                (back.weight() - GLASS.reflectance * 2.25)
                    .abs()
                    .max_element()
                    < 1e-4,
                "{}",
                back.weight()
            );
            // Reflection: mirror direction, weight tint.
            let r = GLASS.sample(wo, 0.0, Vec2::ZERO).expect("reflects");
            assert!((r.wi - Vec3A::new(-wo.x, -wo.y, wo.z)).length() < 1e-6 && r.pdf == f);
            assert!((r.weight() - GLASS.reflectance).abs().max_element() < 1e-5);
        }
        assert!(
            GLASS.sample(Vec3A::X, 0.5, Vec2::ZERO).is_none(),
            "wo.z == 0"
        );
        assert_eq!(GLASS.eval(Vec3A::Z, -Vec3A::Z), Spectrum::ZERO);
        assert_eq!(GLASS.pdf(Vec3A::Z, -Vec3A::Z), 0.0);
    }

    #[test]
    fn expected_weight_from_outside_is_f_plus_t_over_eta_squared() {
        let wo = dir(50.0, 0.0);
        let f = fresnel_dielectric(wo.z, 1.5) as f64;
        let n = 200_000;
        let mut s = Sampler::new(502, 0, 0);
        let mut sum = 0.0f64;
        for _ in 0..n {
            if let Some(b) = GLASS.sample(wo, s.next_1d(), s.next_2d()) {
                sum += b.weight().x as f64;
            }
        }
        let expected = f + (1.0 - f) / 2.25;
        // Weights are 1 or 1/2.25: standard deviation < 0.3.
        assert!(
            (sum / n as f64 - expected).abs() < 5.0 * 0.3 / (n as f64).sqrt(),
            "{} vs {expected}",
            sum / n as f64
        );
    }
}
