//! A directional light (a sun): parallel rays from infinitely far away (Mitsuba 3's
//! `directional`, RON `Directional`). A delta in direction: rays cannot hit it, and a surface
//! facing it receives `irradiance` (W m^-2 per channel, measured perpendicular to the beam).

use super::{lum, LeSample, LightSample};
use crate::Rgb;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// Parallel light travelling along `direction` (unit).
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionalLight {
    pub direction: Vec3A,
    pub irradiance: Rgb,
}

impl DirectionalLight {
    pub fn sample_li(&self, p: Vec3A, _u: Vec2) -> Option<LightSample> {
        let wi = -self.direction;
        Some(LightSample {
            wi,
            point: p + wi,
            dist: f32::INFINITY,
            radiance: crate::spectrum::of_rgb(self.irradiance),
            pdf: 1.0,
            delta: true,
        })
    }

    pub fn pdf_li(&self, _p: Vec3A, _wi: Vec3A, _q: Vec3A) -> f32 {
        0.0
    }

    pub fn emitted(&self, _n: Vec3A, _w: Vec3A) -> Rgb {
        Rgb::ZERO
    }

    /// A ray of the beam from a uniform point of the disk of radius `scene_radius` across it,
    /// outside the scene's bounding sphere.
    pub fn sample_le(&self, u_pos: Vec2, scene_center: Vec3A, scene_radius: f32) -> LeSample {
        let dir = self.direction;
        let ray = super::ray_from_afar(dir, u_pos, scene_center, scene_radius);
        let area = PI * scene_radius * scene_radius;
        LeSample {
            ray,
            radiance: crate::spectrum::of_rgb(self.irradiance),
            normal: dir,
            pdf_pos: 1.0 / area,
            pdf_dir: 1.0,
            weight: crate::spectrum::of_rgb(self.irradiance * area),
        }
    }

    pub fn pdf_le(&self, scene_radius: f32) -> (f32, f32) {
        (1.0 / (PI * scene_radius * scene_radius), 0.0)
    }

    /// The power crossing a disk of the scene's radius.
    pub fn power(&self, scene_radius: f32) -> f64 {
        let r = scene_radius as f64;
        std::f64::consts::PI * r * r * lum(self.irradiance)
    }
}
