//! Lambertian diffuse reflection: `f = albedo / pi`.

use super::{BsdfSample, Bxdf, Lobes};
use crate::sampling::cosine_hemisphere_pdf;
use crate::Spectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug, PartialEq)]
pub struct Lambert {
    pub albedo: Spectrum,
}

impl Lambert {
    /// A Lambertian reflector of reflectance `albedo` (each channel in `[0, 1]`).
    pub fn new(albedo: Spectrum) -> Result<Lambert, String> {
        Ok(Lambert {
            albedo: super::checks::reflectance("albedo", albedo)?,
        })
    }
}

impl Bxdf for Lambert {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::DIFFUSE_REFLECTION
    }

    fn eval(&self, _wo: Vec3A, wi: Vec3A) -> Spectrum {
        if wi.z <= 0.0 {
            return Spectrum::ZERO;
        }
        self.albedo * FRAC_1_PI
    }

    fn pdf(&self, _wo: Vec3A, wi: Vec3A) -> f32 {
        cosine_hemisphere_pdf(wi.z)
    }

    fn sample(&self, _wo: Vec3A, _u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        BsdfSample::cosine_weighted(u, |_| self.albedo * FRAC_1_PI)
    }

    fn albedo(&self) -> Spectrum {
        self.albedo
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{
        assert_chi2, check_sample_matches_eval, dir, directional_albedo, Grid, SAMPLES,
    };

    #[test]
    fn chi2_cosine_hemisphere() {
        let l = Lambert {
            albedo: crate::spectrum::rgb(0.8, 0.5, 0.2),
        };
        let wo = dir(30.0, 10.0);
        assert_chi2(
            "cosine hemisphere (Lambert)",
            &Grid::hemisphere(20, 40),
            SAMPLES,
            201,
            |s| l.sample(wo, s.next_1d(), s.next_2d()).map(|b| b.wi),
            |w| l.pdf(wo, w),
        );
    }

    #[test]
    fn sample_matches_eval_and_albedo_is_exact() {
        let albedo = crate::spectrum::rgb(0.8, 0.5, 0.2);
        let l = Lambert { albedo };
        for wo in [dir(0.0, 0.0), dir(60.0, 30.0), dir(89.0, 200.0)] {
            check_sample_matches_eval(&l, wo, 10_000, 202);
            let (mean, _) = directional_albedo(&l, wo, 100_000, 203);
            for c in 0..3 {
                assert!(
                    (mean[c] - albedo[c] as f64).abs() < 1e-4,
                    "{mean} vs {albedo}"
                );
            }
        }
        assert_eq!(
            l.eval(dir(10.0, 0.0), Vec3A::new(0.6, 0.0, -0.8)),
            Spectrum::ZERO
        );
    }
}
