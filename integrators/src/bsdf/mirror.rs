//! A perfect specular mirror: `wi` is `wo` reflected about the normal, weighted by `tint`.

use super::{BsdfSample, Bxdf};
use crate::Rgb;
use glam::{Vec2, Vec3A};

#[derive(Clone, Debug, PartialEq)]
pub struct Mirror {
    pub tint: Rgb,
}

impl Bxdf for Mirror {
    fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Rgb {
        Rgb::ZERO
    }

    fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        0.0
    }

    fn sample(&self, wo: Vec3A, _u_lobe: f32, _u: Vec2) -> Option<BsdfSample> {
        let wi = Vec3A::new(-wo.x, -wo.y, wo.z);
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample { wi, f: self.tint / wi.z, pdf: 1.0, specular: true })
    }

    fn albedo(&self) -> Rgb {
        self.tint
    }
}
