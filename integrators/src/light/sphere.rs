//! Spherical emitters: cone sampling from outside, area sampling from inside. A sphere emits
//! outwards, or, with its normals flipped (`inward`), into its inside only: the camera inside
//! an emitting sphere, pbrt-v4's analytic furnace.

use super::{leave, lum, LeSample, LightSample, MIN_COS};
use crate::sampling::uniform_sphere;
use crate::{Frame, Rgb};
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// A sphere emitting `radiance` from its whole surface, outwards or (`inward`) inwards.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereLight {
    pub center: Vec3A,
    /// Radius, > 0.
    pub radius: f32,
    /// Emitted radiance, W·sr⁻¹·m⁻² per channel.
    pub radiance: Rgb,
    /// Emits into the sphere instead of out of it.
    pub inward: bool,
}

impl SphereLight {
    /// True when a point of this light may be lit by the light itself: only a sphere that
    /// emits inwards is concave.
    #[inline]
    pub fn lights_itself(&self) -> bool {
        self.inward
    }
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
        return area_sample(center, radius, p, u);
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

/// A uniform point of the sphere, its outward normal and its solid-angle density at `p`.
#[inline]
fn area_sample(center: Vec3A, radius: f32, p: Vec3A, u: Vec2) -> Option<(Vec3A, Vec3A, f32)> {
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
    let pdf = dist2 / (cos * 4.0 * PI * radius * radius);
    pdf.is_finite().then_some((q, n, pdf))
}

/// Relative margin by which a point on an inward sphere still counts as inside it: hit
/// points lie on the surface up to rounding, and the inside of the surface lights them.
const ON_SURFACE: f32 = 1e-4;

impl SphereLight {
    /// True when `p` is inside the sphere, or on it (within rounding) for an inward one.
    #[inline]
    fn sees_inside(&self, p: Vec3A) -> bool {
        let d2 = (self.center - p).length_squared();
        let r2 = self.radius * self.radius;
        if self.inward {
            d2 <= r2 * (1.0 + ON_SURFACE)
        } else {
            d2 < r2
        }
    }

    /// The emitting normal at the surface point whose outward normal is `n`.
    #[inline]
    pub(super) fn emitting_normal(&self, n: Vec3A) -> Vec3A {
        if self.inward {
            -n
        } else {
            n
        }
    }

    pub fn sample_li(&self, p: Vec3A, u: Vec2) -> Option<LightSample> {
        if self.inward != self.sees_inside(p) {
            // Outwards, nothing reaches the inside; inwards, nothing the outside.
            return None;
        }
        let (q, n, pdf) = if self.inward {
            area_sample(self.center, self.radius, p, u)?
        } else {
            sphere_sample(self.center, self.radius, p, u)?
        };
        let n = self.emitting_normal(n);
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
        if radius.is_nan() || radius <= 0.0 {
            return 0.0;
        }
        let pdf = if self.inward {
            // From inside, uniform in area: dist^2 / (cos area), the inner face towards p.
            let n = (q - center) / radius;
            let d = q - p;
            let dist2 = d.length_squared();
            let cos = n.dot(d) / dist2.sqrt();
            if !self.sees_inside(p) || cos < MIN_COS {
                return 0.0;
            }
            dist2 / (cos * 4.0 * PI * r2)
        } else {
            // From outside, uniform in the cone; only the side facing p emits towards it.
            if d2 <= r2 || (q - center).dot(-wi) <= 0.0 {
                return 0.0;
            }
            1.0 / (2.0 * PI * one_minus_cos_max(r2 / d2))
        };
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    pub fn emitted(&self, n: Vec3A, w: Vec3A) -> Rgb {
        if self.emitting_normal(n).dot(w) > 0.0 {
            self.radiance
        } else {
            Rgb::ZERO
        }
    }

    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2) -> LeSample {
        let outward = uniform_sphere(u_pos);
        let n = self.emitting_normal(outward);
        let r = self.radius;
        let (ray, cos) = leave(self.center + outward * r, n, u_dir);
        LeSample {
            ray,
            radiance: crate::spectrum::of_rgb(self.radiance),
            normal: n,
            pdf_pos: 1.0 / (4.0 * PI * r * r),
            pdf_dir: cos / PI,
            weight: crate::spectrum::of_rgb(self.radiance * (4.0 * PI * r * r * PI)),
        }
    }

    /// Densities of a ray leaving the surface where its emitting normal is `n`.
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
