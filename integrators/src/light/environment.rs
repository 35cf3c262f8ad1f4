//! The constant environment: radiance from every direction that leaves the scene.

use super::{lum, LeSample, LightSample};
use crate::sampling::{uniform_sphere, UNIFORM_SPHERE_PDF};
use crate::Rgb;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// Constant radiance arriving from every direction not blocked by geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentLight {
    /// Radiance arriving from every direction, W·sr⁻¹·m⁻² per channel.
    pub radiance: Rgb,
}

impl EnvironmentLight {
    pub fn sample_li(&self, p: Vec3A, u: Vec2) -> Option<LightSample> {
        let wi = uniform_sphere(u);
        Some(LightSample {
            wi,
            point: p + wi,
            dist: f32::INFINITY,
            radiance: crate::spectrum::of_rgb(self.radiance),
            pdf: UNIFORM_SPHERE_PDF,
            delta: false,
        })
    }

    pub fn pdf_li(&self, _p: Vec3A, _wi: Vec3A, _q: Vec3A) -> f32 {
        UNIFORM_SPHERE_PDF
    }

    pub fn emitted(&self, _n: Vec3A, _w: Vec3A) -> Rgb {
        self.radiance
    }

    /// A uniform direction, from a uniform point of the disk of radius `scene_radius` facing
    /// it, outside the scene's bounding sphere.
    pub fn sample_le(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        scene_center: Vec3A,
        scene_radius: f32,
    ) -> LeSample {
        let dir = uniform_sphere(u_dir);
        let ray = super::ray_from_afar(dir, u_pos, scene_center, scene_radius);
        LeSample {
            ray,
            radiance: crate::spectrum::of_rgb(self.radiance),
            normal: dir,
            pdf_pos: 1.0 / (PI * scene_radius * scene_radius),
            pdf_dir: UNIFORM_SPHERE_PDF,
            weight: crate::spectrum::of_rgb(
                self.radiance * (PI * scene_radius * scene_radius * 4.0 * PI),
            ),
        }
    }

    pub fn pdf_le(&self, scene_radius: f32) -> (f32, f32) {
        (1.0 / (PI * scene_radius * scene_radius), UNIFORM_SPHERE_PDF)
    }

    /// pbrt-v4's `UniformInfiniteLight::Phi`: the power crossing a disk of the scene's radius
    /// from every direction.
    pub fn power(&self, scene_radius: f32) -> f64 {
        use std::f64::consts::PI;
        let r = scene_radius as f64;
        lum(self.radiance) * PI * r * r * 4.0 * PI
    }
}
