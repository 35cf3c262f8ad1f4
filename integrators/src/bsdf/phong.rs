//! Energy-conserving normalised Phong (Lafortune & Willems 1994).
// STUB: to be implemented (helper task). Keep the public API.

use super::{BsdfSample, Bxdf};
use crate::Rgb;
use glam::{Vec2, Vec3A};

#[derive(Clone, Debug, PartialEq)]
pub struct Phong {
    pub kd: Rgb,
    pub ks: Rgb,
    pub exponent: f32,
}

impl Bxdf for Phong {
    fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Rgb {
        todo!()
    }
    fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        todo!()
    }
    fn sample(&self, _wo: Vec3A, _u_lobe: f32, _u: Vec2) -> Option<BsdfSample> {
        todo!()
    }
    fn albedo(&self) -> Rgb {
        self.kd + self.ks
    }
}
