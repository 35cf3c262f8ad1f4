//! Diffuse reflection and diffuse transmission (pbrt-v4's `diffusetransmission`, a leaf or a
//! lampshade): `f = reflectance / pi` on the side light arrives from and `transmittance / pi`
//! on the other. Sampling picks reflection or transmission in proportion to the largest
//! channel of each (as pbrt-v4), then a cosine-weighted direction on that side.

use super::{BsdfSample, Bxdf, Lobes};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::Spectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug, PartialEq)]
pub struct DiffuseTransmission {
    pub reflectance: Spectrum,
    pub transmittance: Spectrum,
}

impl DiffuseTransmission {
    /// Each channel of each in `[0, 1]`, and their sum at most 1 (no more power leaves than
    /// arrives).
    pub fn new(
        reflectance: Spectrum,
        transmittance: Spectrum,
    ) -> Result<DiffuseTransmission, String> {
        let r = super::checks::reflectance("reflectance", reflectance)?;
        let t = super::checks::reflectance("transmittance", transmittance)?;
        if (r + t).max_element() > 1.0 + 1e-6 {
            return Err(format!(
                "reflectance {:?} and transmittance {:?} sum to more than 1 in some channel",
                crate::spectrum::rgb_of(r).to_array(),
                crate::spectrum::rgb_of(t).to_array()
            ));
        }
        Ok(DiffuseTransmission {
            reflectance: r,
            transmittance: t,
        })
    }

    /// The probability of sampling reflection.
    #[inline]
    fn p_reflect(&self) -> f32 {
        let (pr, pt) = (
            self.reflectance.max_element(),
            self.transmittance.max_element(),
        );
        if pr + pt > 0.0 {
            pr / (pr + pt)
        } else {
            0.0
        }
    }
}

impl Bxdf for DiffuseTransmission {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::DIFFUSE_REFLECTION.with(Lobes::DIFFUSE_TRANSMISSION)
    }

    fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        if wo.z * wi.z > 0.0 {
            self.reflectance * FRAC_1_PI
        } else if wo.z * wi.z < 0.0 {
            self.transmittance * FRAC_1_PI
        } else {
            Spectrum::ZERO
        }
    }

    fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        let pr = self.p_reflect();
        let cos = cosine_hemisphere_pdf(wi.z.abs());
        if wo.z * wi.z > 0.0 {
            pr * cos
        } else if wo.z * wi.z < 0.0 {
            (1.0 - pr) * cos
        } else {
            0.0
        }
    }

    fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 || (self.reflectance + self.transmittance).max_element() <= 0.0 {
            return None;
        }
        let pr = self.p_reflect();
        let mut wi = cosine_hemisphere(u);
        if wi.z <= 0.0 {
            return None;
        }
        let reflect = u_lobe < pr;
        // On wo's side for reflection, the other for transmission.
        if (wo.z < 0.0) == reflect {
            wi.z = -wi.z;
        }
        let (f, p) = if reflect {
            (self.reflectance, pr)
        } else {
            (self.transmittance, 1.0 - pr)
        };
        let pdf = p * cosine_hemisphere_pdf(wi.z.abs());
        (pdf > 0.0).then_some(BsdfSample {
            wi,
            f: f * FRAC_1_PI,
            pdf,
            specular: false,
            eta: 1.0,
        })
    }

    fn albedo(&self) -> Spectrum {
        self.reflectance + self.transmittance
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{assert_chi2, dir, Grid, SAMPLES};

    fn leaf() -> DiffuseTransmission {
        DiffuseTransmission::new(
            crate::spectrum::rgb(0.5, 0.3, 0.1),
            crate::spectrum::rgb(0.2, 0.4, 0.1),
        )
        .unwrap()
    }

    #[test]
    fn chi2_diffuse_transmission() {
        let m = leaf();
        for (wo, seed) in [(dir(30.0, 10.0), 221), (-dir(70.0, 100.0), 222)] {
            assert_chi2(
                "diffuse transmission",
                &Grid::sphere(20, 40),
                SAMPLES,
                seed,
                |s| m.sample(wo, s.next_1d(), s.next_2d()).map(|b| b.wi),
                |w| m.pdf(wo, w),
            );
        }
    }

    /// The sampled value and density are the evaluated ones; the mean weight is
    /// reflectance + transmittance on either side, to the noise of the lobe choice.
    #[test]
    fn samples_match_eval_and_the_albedo_is_exact() {
        let m = leaf();
        let mut s = crate::Sampler::new(223, 0, 0);
        for wo in [dir(20.0, 0.0), -dir(60.0, 30.0)] {
            let n = 100_000;
            let mut sum = Spectrum::ZERO;
            let mut through = 0;
            for _ in 0..n {
                let b = m.sample(wo, s.next_1d(), s.next_2d()).expect("a sample");
                assert!((m.pdf(wo, b.wi) - b.pdf).abs() <= 1e-5 * b.pdf);
                assert_eq!(m.eval(wo, b.wi), b.f);
                through += (b.wi.z * wo.z < 0.0) as u32;
                sum += b.weight();
            }
            let mean = sum / n as f32;
            assert!((mean - m.albedo()).abs().max_element() < 0.01, "{mean}");
            // Reflection with probability 0.5 / (0.5 + 0.4).
            let share = through as f64 / n as f64;
            assert!((share - 0.4 / 0.9).abs() < 0.01, "{share}");
        }
        assert!(DiffuseTransmission::new(Spectrum::splat(0.6), Spectrum::splat(0.5)).is_err());
    }
}
