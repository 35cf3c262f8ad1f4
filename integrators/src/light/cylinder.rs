//! Cylindrical emitters (Mitsuba 3's `cylinder` without end caps): uniform area sampling, as
//! Mitsuba 3 and pbrt-v4 sample cylinders. A cylinder emits from its outside, or, with its
//! normals flipped (`inward`), from its inside only.

use super::{leave, lum, LeSample, LightSample, MIN_COS};
use crate::Rgb;
use glam::{Vec2, Vec3A};
use std::f32::consts::{PI, TAU};

/// An open cylinder of `radius` around the segment from `base` to `base + axis`, emitting
/// `radiance` from its outside or (`inward`) its inside. `u` and `v` are unit vectors across
/// the axis (with the axis' direction, a right-handed frame): the angle around it counts from
/// `u` towards `v`.
#[derive(Clone, Debug, PartialEq)]
pub struct CylinderLight {
    pub base: Vec3A,
    pub axis: Vec3A,
    pub u: Vec3A,
    pub v: Vec3A,
    /// Radius, > 0.
    pub radius: f32,
    /// Emitted radiance, W·sr⁻¹·m⁻² per channel.
    pub radiance: Rgb,
    /// Emits from the inside instead of the outside.
    pub inward: bool,
}

impl CylinderLight {
    /// Surface area `2 pi r L`.
    #[inline]
    pub fn area(&self) -> f32 {
        TAU * self.radius * self.axis.length()
    }

    /// The point `u` picks, uniformly in area, and the emitting normal there.
    #[inline]
    fn point(&self, u: Vec2) -> (Vec3A, Vec3A) {
        let (sin, cos) = (TAU * u.y).sin_cos();
        let radial = self.u * cos + self.v * sin;
        let q = self.base + self.axis * u.x + radial * self.radius;
        (q, self.emitting(radial))
    }

    /// The emitting normal where the outward normal is `radial`.
    #[inline]
    fn emitting(&self, radial: Vec3A) -> Vec3A {
        if self.inward {
            -radial
        } else {
            radial
        }
    }

    /// The emitting normal at the surface point `q`: its direction from the axis.
    #[inline]
    pub(super) fn normal_at(&self, q: Vec3A) -> Vec3A {
        let d = q - self.base;
        let along = self.axis * (d.dot(self.axis) / self.axis.length_squared());
        self.emitting((d - along).normalize_or_zero())
    }

    /// Solid-angle density at a point `dist2` away seeing the emitting normal `n` along `wi`.
    #[inline]
    fn pdf(&self, n: Vec3A, wi: Vec3A, dist2: f32) -> f32 {
        let cos = n.dot(-wi);
        if !(cos >= MIN_COS && dist2 > 0.0) {
            return 0.0;
        }
        let pdf = dist2 / (cos * self.area());
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    pub fn sample_li(&self, p: Vec3A, u: Vec2) -> Option<LightSample> {
        let (q, n) = self.point(u);
        LightSample::on_surface(p, q, self.radiance, |wi, dist2| self.pdf(n, wi, dist2))
    }

    pub fn pdf_li(&self, p: Vec3A, wi: Vec3A, q: Vec3A) -> f32 {
        self.pdf(self.normal_at(q), wi, (q - p).length_squared())
    }

    /// Radiance leaving the surface whose geometric normal (already flipped for an inward
    /// cylinder, as the hit reports it) is `n`.
    pub fn emitted(&self, n: Vec3A, w: Vec3A) -> Rgb {
        if n.dot(w) > 0.0 {
            self.radiance
        } else {
            Rgb::ZERO
        }
    }

    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2) -> LeSample {
        let (q, n) = self.point(u_pos);
        let (ray, cos) = leave(q, n, u_dir);
        let area = self.area();
        LeSample {
            ray,
            radiance: crate::spectrum::of_rgb(self.radiance),
            normal: n,
            pdf_pos: 1.0 / area,
            pdf_dir: cos / PI,
            weight: crate::spectrum::of_rgb(self.radiance * (area * PI)),
        }
    }

    /// Densities of a ray leaving the surface where its emitting normal is `n`.
    pub fn pdf_le(&self, n: Vec3A, w: Vec3A) -> (f32, f32) {
        (1.0 / self.area(), n.dot(w).max(0.0) / PI)
    }

    pub fn power(&self) -> f64 {
        use std::f64::consts::PI;
        lum(self.radiance) * self.area() as f64 * PI
    }
}
