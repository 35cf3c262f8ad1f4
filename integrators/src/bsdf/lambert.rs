//! Lambertian diffuse reflection: `f = albedo / pi`.

use super::{BsdfSample, Bxdf};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::Rgb;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug, PartialEq)]
pub struct Lambert {
    pub albedo: Rgb,
}

impl Bxdf for Lambert {
    fn eval(&self, _wo: Vec3A, wi: Vec3A) -> Rgb {
        if wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.albedo * FRAC_1_PI
    }

    fn pdf(&self, _wo: Vec3A, wi: Vec3A) -> f32 {
        cosine_hemisphere_pdf(wi.z)
    }

    fn sample(&self, _wo: Vec3A, _u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let wi = cosine_hemisphere(u);
        let pdf = cosine_hemisphere_pdf(wi.z);
        (pdf > 0.0).then(|| BsdfSample { wi, f: self.albedo * FRAC_1_PI, pdf, specular: false })
    }

    fn albedo(&self) -> Rgb {
        self.albedo
    }
}
