//! Spherical emitters: cone sampling from outside, area sampling from inside.

use super::{leave, lum, LeSample, LightSample, MIN_COS};
use crate::sampling::uniform_sphere;
use crate::{Frame, Rgb};
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// A sphere emitting `radiance` outwards from its whole surface.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereLight {
    pub center: Vec3A,
    /// Radius, > 0.
    pub radius: f32,
    /// Emitted radiance, W·sr⁻¹·m⁻² per channel.
    pub radiance: Rgb,
}

/// `1 - cos(theta_max)` of the cone subtended by a sphere, from `sin^2(theta_max) = r^2 / d^2`,
/// written without cancellation (`1 - sqrt(1 - s) = s / (1 + sqrt(1 - s))`) so that the density
/// of small, distant spheres stays accurate (pbrt-v4 uses a Taylor expansion for the same
/// reason).
#[inline]
fn one_minus_cos_max(sin2_max: f32) -> f32 {
    sin2_max / (1.0 + (1.0 - sin2_max).max(0.0).sqrt())
}

/// Geometric sample of a sphere seen from `p`: the point, its outward normal and the
/// solid-angle density at `p`. Outside: uniform in the subtended cone, the point being the
/// closest intersection of the sampled direction. Inside or on the sphere: uniform in area.
#[inline]
pub(super) fn sphere_sample(
    center: Vec3A,
    radius: f32,
    p: Vec3A,
    u: Vec2,
) -> Option<(Vec3A, Vec3A, f32)> {
    if radius.is_nan() || radius <= 0.0 {
        return None;
    }
    let to_center = center - p;
    let d2 = to_center.length_squared();
    let r2 = radius * radius;
    if d2.is_nan() || d2 <= r2 {
        // Inside or on the sphere: uniform area sampling.
        let n = uniform_sphere(u);
        let q = center + n * radius;
        let d = q - p;
        let dist2 = d.length_squared();
        if dist2.is_nan() || dist2 <= 0.0 {
            return None;
        }
        let cos = n.dot(d).abs() / dist2.sqrt();
        if cos < MIN_COS {
            return None;
        }
        let pdf = dist2 / (cos * 4.0 * PI * r2);
        return pdf.is_finite().then_some((q, n, pdf));
    }
    let d = d2.sqrt();
    let sin2_max = r2 / d2;
    let sin_max = sin2_max.sqrt();
    let omc = one_minus_cos_max(sin2_max);
    // Uniform in the cone: 1 - cos(theta) = u.x (1 - cos(theta_max)); sin^2 from the product
    // form to avoid cancellation near the axis.
    let x = u.x * omc;
    let cos_theta = 1.0 - x;
    let sin_theta = (x * (2.0 - x)).max(0.0).sqrt();
    // Angle alpha at the centre between p and the hit point, from the law of sines:
    // alpha = asin(sin(theta) / sin(theta_max)) - theta (closest intersection).
    let rho = (sin_theta / sin_max).min(1.0);
    let cos_rho = (1.0 - rho * rho).max(0.0).sqrt();
    let cos_alpha = cos_rho * cos_theta + rho * sin_theta;
    let sin_alpha = (rho * cos_theta - cos_rho * sin_theta).max(0.0);
    let (sin_phi, cos_phi) = (2.0 * PI * u.y).sin_cos();
    let frame = Frame::from_normal(to_center / d);
    let n = frame.to_world(Vec3A::new(
        sin_alpha * cos_phi,
        sin_alpha * sin_phi,
        -cos_alpha,
    ));
    let q = center + n * radius;
    let pdf = 1.0 / (2.0 * PI * omc);
    pdf.is_finite().then_some((q, n, pdf))
}

impl SphereLight {
    pub fn sample_li(&self, p: Vec3A, u: Vec2) -> Option<LightSample> {
        let (q, n, pdf) = sphere_sample(self.center, self.radius, p, u)?;
        // The sphere emits outwards only: nothing reaches points inside it.
        LightSample::on_surface(p, q, self.radiance, |wi, _| {
            if n.dot(-wi) > 0.0 {
                pdf
            } else {
                0.0
            }
        })
    }

    pub fn pdf_li(&self, p: Vec3A, wi: Vec3A, q: Vec3A) -> f32 {
        let (center, radius) = (self.center, self.radius);
        let d2 = (center - p).length_squared();
        let r2 = radius * radius;
        if !(radius > 0.0 && d2 > r2) {
            return 0.0;
        }
        // Only the side facing p emits towards it.
        if (q - center).dot(-wi) <= 0.0 {
            return 0.0;
        }
        let pdf = 1.0 / (2.0 * PI * one_minus_cos_max(r2 / d2));
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    pub fn emitted(&self, n: Vec3A, w: Vec3A) -> Rgb {
        if n.dot(w) > 0.0 {
            self.radiance
        } else {
            Rgb::ZERO
        }
    }

    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2) -> LeSample {
        let n = uniform_sphere(u_pos);
        let r = self.radius;
        let (ray, cos) = leave(self.center + n * r, n, u_dir);
        LeSample {
            ray,
            radiance: self.radiance,
            normal: n,
            pdf_pos: 1.0 / (4.0 * PI * r * r),
            pdf_dir: cos / PI,
            weight: self.radiance * (4.0 * PI * r * r * PI),
        }
    }

    /// Densities of a ray leaving the surface where its outward normal is `n`.
    pub fn pdf_le(&self, n: Vec3A, w: Vec3A) -> (f32, f32) {
        let r = self.radius;
        (1.0 / (4.0 * PI * r * r), n.dot(w).max(0.0) / PI)
    }

    pub fn power(&self) -> f64 {
        use std::f64::consts::PI;
        let r = self.radius as f64;
        lum(self.radiance) * 4.0 * PI * r * r * PI
    }
}
