//! Oren–Nayar rough diffuse reflection (the report's equations 9 and 10).
// STUB: to be implemented (helper task). Keep the public API.

use super::{BsdfSample, Bxdf};
use crate::Rgb;
use glam::{Vec2, Vec3A};

#[derive(Clone, Debug, PartialEq)]
pub struct OrenNayar {
    pub albedo: Rgb,
    /// Roughness: standard deviation of the facet slope angle, in radians.
    pub sigma: f32,
    a: f32,
    b: f32,
}

impl OrenNayar {
    /// `sigma_degrees`: facet slope standard deviation in degrees (the scene format's unit).
    pub fn new(albedo: Rgb, sigma_degrees: f32) -> Self {
        let sigma = sigma_degrees.to_radians();
        let s2 = sigma * sigma;
        OrenNayar { albedo, sigma, a: 1.0 - s2 / (2.0 * (s2 + 0.33)), b: 0.45 * s2 / (s2 + 0.09) }
    }
}

impl Bxdf for OrenNayar {
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
        self.albedo
    }
}
