//! Smooth dielectric: Fresnel-weighted specular reflection and refraction.
// STUB: to be implemented (helper task). Keep the public API.

use super::{BsdfSample, Bxdf};
use crate::Rgb;
use glam::{Vec2, Vec3A};

#[derive(Clone, Debug, PartialEq)]
pub struct Glass {
    /// Index of refraction inside relative to outside (outside = the side the normal faces).
    pub ior: f32,
    pub tint: Rgb,
}

/// Unpolarised Fresnel reflectance of a dielectric interface. `cos_i` is the cosine of the
/// incident angle measured against the normal on the incident side's convention (positive:
/// arriving from outside); `eta` = inside IOR / outside IOR. Returns 1 on total internal
/// reflection.
pub fn fresnel_dielectric(_cos_i: f32, _eta: f32) -> f32 {
    todo!()
}

impl Bxdf for Glass {
    fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Rgb {
        Rgb::ZERO
    }
    fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        0.0
    }
    fn sample(&self, _wo: Vec3A, _u_lobe: f32, _u: Vec2) -> Option<BsdfSample> {
        todo!()
    }
    fn albedo(&self) -> Rgb {
        self.tint
    }
}
