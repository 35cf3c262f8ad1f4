//! Isotropic point lights: a delta in position.

use super::{lum, LeSample, LightSample};
use crate::sampling::uniform_sphere;
use crate::Rgb;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// An isotropic point light.
#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3A,
    /// Radiant intensity, W·sr⁻¹ per channel.
    pub intensity: Rgb,
}

impl PointLight {
    pub fn sample_li(&self, p: Vec3A, _u: Vec2) -> Option<LightSample> {
        LightSample::from_position(p, self.position, |_, dist2| Some(self.intensity / dist2))
    }

    pub fn pdf_li(&self, _p: Vec3A, _wi: Vec3A, _q: Vec3A) -> f32 {
        0.0
    }

    pub fn emitted(&self, _n: Vec3A, _w: Vec3A) -> Rgb {
        Rgb::ZERO
    }

    pub fn sample_le(&self, u_dir: Vec2) -> LeSample {
        LeSample {
            ray: crate::Ray::new(self.position, uniform_sphere(u_dir)),
            radiance: crate::spectrum::of_rgb(self.intensity),
            normal: Vec3A::ZERO,
            pdf_pos: 1.0,
            pdf_dir: 1.0 / (4.0 * PI),
            weight: crate::spectrum::of_rgb(self.intensity * (4.0 * PI)),
        }
    }

    pub fn pdf_le(&self) -> (f32, f32) {
        (0.0, 1.0 / (4.0 * PI))
    }

    pub fn power(&self) -> f64 {
        4.0 * std::f64::consts::PI * lum(self.intensity)
    }
}
