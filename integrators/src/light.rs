//! Emitters: sampling of incident radiance from a reference point, densities for MIS, and the
//! light table that picks an emitter in proportion to its power.
//!
//! Units: `radiance` is W·sr⁻¹·m⁻² per channel, a point light's `intensity` is W·sr⁻¹ per
//! channel, positions and lengths are in scene units. All densities returned here are per unit
//! solid angle at the reference point (except for point lights, which are deltas).
//!
//! Sampling strategies:
//! * Triangle and parallelogram: uniform in area, converted to solid angle with
//!   `pdf = dist^2 / (|cos_l| area)`. One-sided emitters (the default) emit only on the side
//!   their normal `n = normalize(e1 x e2)` points to; from behind they yield no sample.
//! * Sphere, reference point outside: uniform in the cone of directions the sphere subtends
//!   (pbrt-v4's `Sphere::Sample`), computed with cancellation-free formulas so that distant,
//!   tiny spheres keep an accurate density. Inside (or on) the sphere: uniform in area. A
//!   sphere emits outwards only, so from inside it yields no sample.
//! * Point: the single direction to the light.
//! * Environment: uniform over the sphere of directions.

use crate::sampling::{uniform_sphere, uniform_triangle, UNIFORM_SPHERE_PDF};
use crate::{luminance, Frame, Rgb};
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// One emitter. Area lights are one primitive each (a mesh emitter is one light per triangle;
/// a quad is one parallelogram so that stratified samples cover it as a whole).
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Triangle `p0, p0 + e1, p0 + e2`; `n = normalize(e1 x e2)` is the emitting side unless
    /// `two_sided`. Build it with [`Light::triangle`] so that `n` and `area` are consistent.
    Triangle {
        /// First vertex.
        p0: Vec3A,
        /// Second vertex minus the first.
        e1: Vec3A,
        /// Third vertex minus the first.
        e2: Vec3A,
        /// Unit normal `normalize(e1 x e2)`: the emitting side of a one-sided light.
        n: Vec3A,
        /// Area, `|e1 x e2| / 2`.
        area: f32,
        /// Emitted radiance, W·sr⁻¹·m⁻² per channel.
        radiance: Rgb,
        /// Emits on both sides.
        two_sided: bool,
    },
    /// Parallelogram `p0 + s e1 + t e2`, `s, t` in `[0, 1]`; normal as for triangles. Build it
    /// with [`Light::parallelogram`].
    Parallelogram {
        /// Corner.
        p0: Vec3A,
        /// First edge from `p0`.
        e1: Vec3A,
        /// Second edge from `p0`.
        e2: Vec3A,
        /// Unit normal `normalize(e1 x e2)`: the emitting side of a one-sided light.
        n: Vec3A,
        /// Area, `|e1 x e2|`.
        area: f32,
        /// Emitted radiance, W·sr⁻¹·m⁻² per channel.
        radiance: Rgb,
        /// Emits on both sides.
        two_sided: bool,
    },
    /// Sphere emitting `radiance` outwards from its whole surface.
    Sphere {
        /// Centre.
        center: Vec3A,
        /// Radius, > 0.
        radius: f32,
        /// Emitted radiance, W·sr⁻¹·m⁻² per channel.
        radiance: Rgb,
    },
    /// Isotropic point light of `intensity` (W/sr per channel).
    Point {
        /// Position.
        position: Vec3A,
        /// Radiant intensity, W·sr⁻¹ per channel.
        intensity: Rgb,
    },
    /// Constant radiance arriving from every direction not blocked by geometry.
    Environment {
        /// Radiance arriving from every direction, W·sr⁻¹·m⁻² per channel.
        radiance: Rgb,
    },
}

/// Incident radiance sampled from one light at a reference point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the reference point towards the light.
    pub wi: Vec3A,
    /// The sampled point on the light (for shadow rays); meaningless for the environment.
    pub point: Vec3A,
    /// Distance to `point`; `f32::INFINITY` for the environment.
    pub dist: f32,
    /// Radiance arriving at the reference point along `-wi` if unoccluded (for a point light,
    /// `intensity / dist^2`).
    pub radiance: Rgb,
    /// Density per unit solid angle at the reference point; 1 for delta lights.
    pub pdf: f32,
    /// True for point lights (cannot be hit by rays, no MIS).
    pub delta: bool,
}

/// A photon (or light-path) origin sampled on an emitter by [`Light::sample_emission`].
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    /// The ray leaving the light (already pushed off its surface).
    pub ray: crate::Ray,
    /// `Le cos / (pdf_pos pdf_dir)`: the power, in watts per channel, that the sample stands
    /// for before division by the light's selection probability and the number of samples.
    /// Summed over samples, it estimates the light's emitted power.
    pub weight: Rgb,
}

/// Area-light samples seen under a smaller `|cos|` than this are dropped: their solid-angle
/// density is unbounded and their contribution vanishes (`p` on the light's plane).
const MIN_COS: f32 = 1e-6;

/// Solid-angle density of uniform area sampling of a planar emitter, seen from a point at
/// squared distance `dist2` under `cos_l = dot(n, -wi)`. Zero when the sample would be
/// rejected (back of a one-sided emitter, grazing, degenerate).
#[inline]
fn planar_pdf(dist2: f32, cos_l: f32, area: f32, two_sided: bool) -> f32 {
    if !two_sided && cos_l <= 0.0 {
        return 0.0;
    }
    let cos = cos_l.abs();
    if !(cos >= MIN_COS && dist2 > 0.0 && area > 0.0) {
        return 0.0;
    }
    let pdf = dist2 / (cos * area);
    if pdf.is_finite() {
        pdf
    } else {
        0.0
    }
}

/// A sample towards the point `q` of a planar emitter.
#[inline]
fn planar_sample(
    p: Vec3A,
    q: Vec3A,
    n: Vec3A,
    area: f32,
    radiance: Rgb,
    two_sided: bool,
) -> Option<LightSample> {
    let d = q - p;
    let dist2 = d.length_squared();
    if !(dist2 > 0.0 && dist2.is_finite()) {
        return None;
    }
    let dist = dist2.sqrt();
    let wi = d / dist;
    let pdf = planar_pdf(dist2, n.dot(-wi), area, two_sided);
    (pdf > 0.0).then_some(LightSample {
        wi,
        point: q,
        dist,
        radiance,
        pdf,
        delta: false,
    })
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
fn sphere_sample(center: Vec3A, radius: f32, p: Vec3A, u: Vec2) -> Option<(Vec3A, Vec3A, f32)> {
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

impl Light {
    /// A triangle light with vertices `p0, p1, p2`; it emits on the side of
    /// `(p1 - p0) x (p2 - p0)` unless `two_sided`.
    pub fn triangle(p0: Vec3A, p1: Vec3A, p2: Vec3A, radiance: Rgb, two_sided: bool) -> Light {
        let (e1, e2) = (p1 - p0, p2 - p0);
        let c = e1.cross(e2);
        Light::Triangle {
            p0,
            e1,
            e2,
            n: c.normalize(),
            area: 0.5 * c.length(),
            radiance,
            two_sided,
        }
    }

    /// A parallelogram light `p0 + s e1 + t e2`; it emits on the side of `e1 x e2` unless
    /// `two_sided`.
    pub fn parallelogram(p0: Vec3A, e1: Vec3A, e2: Vec3A, radiance: Rgb, two_sided: bool) -> Light {
        let c = e1.cross(e2);
        Light::Parallelogram {
            p0,
            e1,
            e2,
            n: c.normalize(),
            area: c.length(),
            radiance,
            two_sided,
        }
    }

    /// True for lights that rays cannot hit (point lights).
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Point { .. })
    }

    /// Samples a direction towards the light from `p`. `None` when the sample carries no
    /// radiance (back side of a one-sided emitter, `p` on the light's plane, `p` inside a
    /// sphere light, ...). A light with black radiance still returns samples (with zero
    /// radiance).
    pub fn sample_li(&self, p: Vec3A, u: Vec2) -> Option<LightSample> {
        match *self {
            Light::Triangle {
                p0,
                e1,
                e2,
                n,
                area,
                radiance,
                two_sided,
            } => {
                let b = uniform_triangle(u);
                planar_sample(p, p0 + e1 * b.x + e2 * b.y, n, area, radiance, two_sided)
            }
            Light::Parallelogram {
                p0,
                e1,
                e2,
                n,
                area,
                radiance,
                two_sided,
            } => planar_sample(p, p0 + e1 * u.x + e2 * u.y, n, area, radiance, two_sided),
            Light::Sphere {
                center,
                radius,
                radiance,
            } => {
                let (q, n, pdf) = sphere_sample(center, radius, p, u)?;
                let d = q - p;
                let dist2 = d.length_squared();
                if dist2.is_nan() || dist2 <= 0.0 {
                    return None;
                }
                let dist = dist2.sqrt();
                let wi = d / dist;
                // The sphere emits outwards only: nothing reaches points inside it.
                if n.dot(-wi) <= 0.0 {
                    return None;
                }
                Some(LightSample {
                    wi,
                    point: q,
                    dist,
                    radiance,
                    pdf,
                    delta: false,
                })
            }
            Light::Point {
                position,
                intensity,
            } => {
                let d = position - p;
                let dist2 = d.length_squared();
                if !(dist2 > 0.0 && dist2.is_finite()) {
                    return None;
                }
                let dist = dist2.sqrt();
                let radiance = intensity / dist2;
                radiance.is_finite().then_some(LightSample {
                    wi: d / dist,
                    point: position,
                    dist,
                    radiance,
                    pdf: 1.0,
                    delta: true,
                })
            }
            Light::Environment { radiance } => {
                let wi = uniform_sphere(u);
                Some(LightSample {
                    wi,
                    point: p + wi,
                    dist: f32::INFINITY,
                    radiance,
                    pdf: UNIFORM_SPHERE_PDF,
                    delta: false,
                })
            }
        }
    }

    /// The solid-angle density with which [`Light::sample_li`] from `p` would produce the
    /// direction `wi` that reaches the light at point `q`.
    ///
    /// The light's own geometry decides which side emits (not the normal of the hit that
    /// found `q`), so this matches `sample_li` exactly: zero for point lights, for the back of
    /// one-sided emitters and for a sphere seen from inside.
    pub fn pdf_li(&self, p: Vec3A, wi: Vec3A, q: Vec3A) -> f32 {
        match *self {
            Light::Triangle {
                n, area, two_sided, ..
            }
            | Light::Parallelogram {
                n, area, two_sided, ..
            } => planar_pdf((q - p).length_squared(), n.dot(-wi), area, two_sided),
            Light::Sphere { center, radius, .. } => {
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
            Light::Point { .. } => 0.0,
            Light::Environment { .. } => UNIFORM_SPHERE_PDF,
        }
    }

    /// Radiance leaving the emitter's surface with geometric normal `n` in direction `w`
    /// (unit, pointing away from the surface). For the environment, the radiance arriving
    /// from `-w`.
    pub fn emitted(&self, n: Vec3A, w: Vec3A) -> Rgb {
        match *self {
            Light::Triangle {
                radiance,
                two_sided,
                ..
            }
            | Light::Parallelogram {
                radiance,
                two_sided,
                ..
            } => {
                if two_sided || n.dot(w) > 0.0 {
                    radiance
                } else {
                    Rgb::ZERO
                }
            }
            Light::Sphere { radiance, .. } => {
                if n.dot(w) > 0.0 {
                    radiance
                } else {
                    Rgb::ZERO
                }
            }
            Light::Point { .. } => Rgb::ZERO,
            Light::Environment { radiance } => radiance,
        }
    }

    /// Samples a ray leaving the light, for photon tracing: a uniform point on the surface and
    /// a cosine-weighted direction on its emitting side (a random side, each with probability
    /// 1/2, when two-sided); a uniform direction for point lights; for the environment, a
    /// uniform direction and a uniform point on the disk of radius `scene_radius` facing it
    /// outside the scene's bounding sphere (centre `scene_center`). `u_side` picks the side.
    pub fn sample_emission(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        u_side: f32,
        scene_center: Vec3A,
        scene_radius: f32,
    ) -> Option<EmissionSample> {
        use crate::sampling::{concentric_disk, cosine_hemisphere};
        // A ray leaving a surface point with normal `n` in the cosine-distributed direction.
        let leave = |p: Vec3A, n: Vec3A| {
            let dir = Frame::from_normal(n).to_world(cosine_hemisphere(u_dir));
            let surface = crate::Hit {
                t: 0.0,
                p,
                ng: n,
                ns: n,
                material: 0,
                light: None,
            };
            surface.spawn_ray(dir)
        };
        let side = |n: Vec3A, two_sided: bool| {
            if two_sided && u_side < 0.5 {
                -n
            } else {
                n
            }
        };
        let sides = |two_sided: bool| if two_sided { 2.0 } else { 1.0 };
        let (ray, weight) = match *self {
            Light::Triangle {
                p0,
                e1,
                e2,
                n,
                area,
                radiance,
                two_sided,
            } => {
                let b = uniform_triangle(u_pos);
                let p = p0 + e1 * b.x + e2 * b.y;
                let w = radiance * (area * PI * sides(two_sided));
                (leave(p, side(n, two_sided)), w)
            }
            Light::Parallelogram {
                p0,
                e1,
                e2,
                n,
                area,
                radiance,
                two_sided,
            } => {
                let p = p0 + e1 * u_pos.x + e2 * u_pos.y;
                let w = radiance * (area * PI * sides(two_sided));
                (leave(p, side(n, two_sided)), w)
            }
            Light::Sphere {
                center,
                radius,
                radiance,
            } => {
                let n = uniform_sphere(u_pos);
                let w = radiance * (4.0 * PI * radius * radius * PI);
                (leave(center + n * radius, n), w)
            }
            Light::Point {
                position,
                intensity,
            } => (
                crate::Ray::new(position, uniform_sphere(u_dir)),
                intensity * (4.0 * PI),
            ),
            Light::Environment { radiance } => {
                let dir = uniform_sphere(u_dir);
                let frame = Frame::from_normal(dir);
                let d = concentric_disk(u_pos) * scene_radius;
                let origin =
                    scene_center - dir * (2.0 * scene_radius) + frame.s * d.x + frame.t * d.y;
                let w = radiance * (PI * scene_radius * scene_radius * 4.0 * PI);
                (crate::Ray::new(origin, dir), w)
            }
        };
        (weight.is_finite() && weight != Rgb::ZERO).then_some(EmissionSample { ray, weight })
    }

    /// Emitted power (luminance, watts) used to choose lights; `scene_radius` bounds the
    /// environment's contribution. Never negative; NaN powers become 0.
    pub fn power(&self, scene_radius: f32) -> f64 {
        use std::f64::consts::PI;
        // In f64: radiance times area may pass f32's range in a valid scene (a bright light
        // the size of a planet), and an infinite power would drop the light from the table.
        // (Luminance itself stays in f32: it is a weighted mean, never above the largest channel.)
        let lum = |c: Rgb| luminance(c) as f64;
        let power = match *self {
            Light::Triangle {
                area,
                radiance,
                two_sided,
                ..
            }
            | Light::Parallelogram {
                area,
                radiance,
                two_sided,
                ..
            } => {
                let sides = if two_sided { 2.0 } else { 1.0 };
                lum(radiance) * area as f64 * PI * sides
            }
            Light::Sphere {
                radius, radiance, ..
            } => {
                let r = radius as f64;
                lum(radiance) * 4.0 * PI * r * r * PI
            }
            Light::Point { intensity, .. } => 4.0 * PI * lum(intensity),
            Light::Environment { radiance } => {
                // pbrt-v4's UniformInfiniteLight::Phi: the power crossing a disk of the scene's
                // radius from every direction.
                let r = scene_radius as f64;
                lum(radiance) * PI * r * r * 4.0 * PI
            }
        };
        power.max(0.0)
    }
}

/// All emitters of a scene with a power-proportional selection distribution.
#[derive(Clone, Debug, Default)]
pub struct LightTable {
    lights: Vec<Light>,
    pmf: Vec<f32>,
    cdf: Vec<f32>,
    environment: Option<u32>,
}

impl LightTable {
    /// Builds the table; selection is proportional to [`Light::power`] (uniform if every
    /// power is zero). At most one environment light: if there are several, the first one is
    /// the one [`LightTable::environment`] reports.
    pub fn new(lights: Vec<Light>, scene_radius: f32) -> LightTable {
        let powers: Vec<f64> = lights
            .iter()
            .map(|l| {
                let p = l.power(scene_radius);
                if p.is_finite() && p > 0.0 {
                    p
                } else {
                    0.0
                }
            })
            .collect();
        let total: f64 = powers.iter().sum();
        let pmf: Vec<f32> = if total > 0.0 && total.is_finite() {
            powers.iter().map(|&p| (p / total) as f32).collect()
        } else {
            vec![1.0 / lights.len().max(1) as f32; lights.len()]
        };
        // Running sum in f64; a light with zero probability gets the same cdf value as its
        // predecessor, so the search below can never land on it. Everything from the last
        // light with a non-zero probability on is pinned to exactly 1.
        let mut cdf = Vec::with_capacity(pmf.len());
        let norm = sum_or_one(&pmf);
        let mut sum = 0.0f64;
        for &p in &pmf {
            sum += p as f64;
            cdf.push((sum / norm) as f32);
        }
        if let Some(last) = pmf.iter().rposition(|&p| p > 0.0) {
            for c in &mut cdf[last..] {
                *c = 1.0;
            }
        }
        let environment = lights
            .iter()
            .position(|l| matches!(l, Light::Environment { .. }))
            .and_then(|i| u32::try_from(i).ok());
        LightTable {
            lights,
            pmf,
            cdf,
            environment,
        }
    }

    /// The emitters, in the order their indices refer to.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// Number of emitters.
    pub fn len(&self) -> usize {
        self.lights.len()
    }

    /// True if the scene has no emitters.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Light `index`. Panics if `index` is out of range (indices come from the table itself).
    pub fn get(&self, index: u32) -> &Light {
        &self.lights[index as usize]
    }

    /// Picks a light with `u` in `[0, 1)`: its index and selection probability. `None` if the
    /// table is empty; never returns a light whose probability is zero.
    pub fn sample(&self, u: f32) -> Option<(u32, f32)> {
        if self.lights.is_empty() {
            return None;
        }
        // Clamp into [0, 1) (NaN -> 0): the cdf reaches exactly 1 at the last light with a
        // non-zero probability, so the search stops there at the latest.
        let u = if u > 0.0 {
            u.min(1.0 - f32::EPSILON / 2.0)
        } else {
            0.0
        };
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.lights.len() - 1);
        Some((i as u32, self.pmf[i]))
    }

    /// Probability that [`LightTable::sample`] picks light `index`.
    pub fn pmf(&self, index: u32) -> f32 {
        self.pmf[index as usize]
    }

    /// Index of the environment light, if the scene has one.
    pub fn environment(&self) -> Option<u32> {
        self.environment
    }
}

/// Sum of the (f32) probabilities in f64, or 1 when it is not positive.
fn sum_or_one(pmf: &[f32]) -> f64 {
    let s: f64 = pmf.iter().map(|&p| p as f64).sum();
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{assert_chi2, assert_chi2_discrete, Grid, SAMPLES};
    use crate::Sampler;
    use glam::DVec3;

    fn d(v: Vec3A) -> DVec3 {
        DVec3::new(v.x as f64, v.y as f64, v.z as f64)
    }

    fn f(v: DVec3) -> Vec3A {
        Vec3A::new(v.x as f32, v.y as f32, v.z as f32)
    }

    /// Where the ray `p + t w` first reaches the light (f64 ray casting, independent of the
    /// sampling code): the point and the light's geometric normal there.
    fn hit_light(light: &Light, p: Vec3A, w: Vec3A) -> Option<(Vec3A, Vec3A)> {
        let (o, w) = (d(p), d(w).normalize());
        match *light {
            Light::Triangle { p0, e1, e2, n, .. } | Light::Parallelogram { p0, e1, e2, n, .. } => {
                // Moller-Trumbore.
                let (e1, e2) = (d(e1), d(e2));
                let pv = w.cross(e2);
                let det = e1.dot(pv);
                if det.abs() < 1e-15 {
                    return None;
                }
                let tv = o - d(p0);
                let b1 = tv.dot(pv) / det;
                let qv = tv.cross(e1);
                let b2 = w.dot(qv) / det;
                let t = e2.dot(qv) / det;
                let inside = if matches!(light, Light::Triangle { .. }) {
                    b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0
                } else {
                    (0.0..=1.0).contains(&b1) && (0.0..=1.0).contains(&b2)
                };
                (inside && t > 0.0).then(|| (f(o + w * t), n))
            }
            Light::Sphere { center, radius, .. } => {
                let oc = o - d(center);
                let b = oc.dot(w);
                let c = oc.length_squared() - (radius as f64).powi(2);
                let disc = b * b - c;
                if disc < 0.0 {
                    return None;
                }
                let (t0, t1) = (-b - disc.sqrt(), -b + disc.sqrt());
                let t = if t0 > 0.0 { t0 } else { t1 };
                (t > 0.0).then(|| {
                    let q = o + w * t;
                    (f(q), f((q - d(center)).normalize()))
                })
            }
            Light::Environment { .. } => Some((p + f(w), -f(w))),
            Light::Point { .. } => None,
        }
    }

    /// The density `pdf_li` claims for direction `w` from `p`, found by ray casting.
    fn pdf_by_ray(light: &Light, p: Vec3A) -> impl Fn(Vec3A) -> f32 + '_ {
        move |w| match hit_light(light, p, w) {
            Some((q, _)) => light.pdf_li(p, w, q),
            None => 0.0,
        }
    }

    /// A histogram window around the light as seen from `p` (from 10^4 points on it).
    fn polygon_grid(p: Vec3A, light: &Light) -> Grid {
        let n = 100;
        let (p0, e1, e2, tri) = match *light {
            Light::Triangle { p0, e1, e2, .. } => (p0, e1, e2, true),
            Light::Parallelogram { p0, e1, e2, .. } => (p0, e1, e2, false),
            _ => unreachable!(),
        };
        let mut points = Vec::new();
        for i in 0..=n {
            for j in 0..=n {
                if !tri || i + j <= n {
                    points.push(p0 + e1 * (i as f32 / n as f32) + e2 * (j as f32 / n as f32));
                }
            }
        }
        let centroid = points.iter().copied().sum::<Vec3A>() / points.len() as f32;
        Grid::around_points(p, centroid - p, &points, 30, 30)
    }

    fn vertices(light: &Light) -> Vec<Vec3A> {
        match *light {
            Light::Triangle { p0, e1, e2, .. } => vec![p0, p0 + e1, p0 + e2],
            Light::Parallelogram { p0, e1, e2, .. } => vec![p0, p0 + e1, p0 + e2, p0 + e1 + e2],
            _ => unreachable!(),
        }
    }

    /// Every sample agrees with `pdf_li`, `emitted` and the ray-cast hit point.
    fn check_samples(light: &Light, p: Vec3A, n: usize, seed: u64) -> usize {
        let mut s = Sampler::new(seed, 0, 0);
        let mut accepted = 0;
        for _ in 0..n {
            let Some(ls) = light.sample_li(p, s.next_2d()) else {
                continue;
            };
            accepted += 1;
            assert!((ls.wi.length() - 1.0).abs() < 1e-5 && ls.pdf > 0.0 && ls.pdf.is_finite());
            let (q, nq) = hit_light(light, p, ls.wi).expect("the sampled direction hits the light");
            let pdf = light.pdf_li(p, ls.wi, q);
            assert!(
                (pdf - ls.pdf).abs() <= 1e-3 * pdf,
                "pdf_li {pdf} vs sampled {}",
                ls.pdf
            );
            assert_eq!(light.emitted(nq, -ls.wi), ls.radiance);
            if ls.dist.is_finite() {
                let hit_dist = (q - p).length();
                assert!(
                    (hit_dist - ls.dist).abs() <= 1e-3 * ls.dist,
                    "closest hit at {hit_dist}, sample at {}",
                    ls.dist
                );
                assert!((ls.point - p - ls.wi * ls.dist).length() <= 1e-4 * ls.dist.max(1.0));
            }
        }
        accepted
    }

    fn chi2_light(name: &str, light: &Light, p: Vec3A, grid: &Grid, seed: u64) {
        assert!(check_samples(light, p, 20_000, seed + 1000) > 0);
        assert_chi2(
            name,
            grid,
            SAMPLES,
            seed,
            |s| light.sample_li(p, s.next_2d()).map(|ls| ls.wi),
            pdf_by_ray(light, p),
        );
    }

    const L: Rgb = Rgb::new(1.0, 2.0, 3.0);

    fn triangle(two_sided: bool) -> Light {
        Light::triangle(
            Vec3A::ZERO,
            Vec3A::new(1.0, 0.0, 0.0),
            Vec3A::new(0.2, 1.0, 0.1),
            L,
            two_sided,
        )
    }

    fn quad(two_sided: bool) -> Light {
        // Faces down (-z, tilted): e1 x e2 = (0.3, 0, -1).
        Light::parallelogram(
            Vec3A::new(-0.5, -0.5, 1.0),
            Vec3A::new(0.0, 1.0, 0.0),
            Vec3A::new(1.0, 0.0, 0.3),
            L,
            two_sided,
        )
    }

    #[test]
    fn chi2_triangle_one_sided() {
        let (light, p) = (triangle(false), Vec3A::new(0.9, -0.3, 0.4));
        chi2_light(
            "triangle one-sided",
            &light,
            p,
            &polygon_grid(p, &light),
            701,
        );
    }

    #[test]
    fn chi2_triangle_two_sided_from_behind() {
        let (light, p) = (triangle(true), Vec3A::new(0.2, 0.6, -0.5));
        chi2_light(
            "triangle two-sided, back",
            &light,
            p,
            &polygon_grid(p, &light),
            702,
        );
    }

    #[test]
    fn chi2_parallelogram_one_sided() {
        let (light, p) = (quad(false), Vec3A::new(0.3, 0.2, 0.0));
        chi2_light(
            "parallelogram one-sided",
            &light,
            p,
            &polygon_grid(p, &light),
            703,
        );
    }

    #[test]
    fn chi2_parallelogram_two_sided_from_behind_near_grazing() {
        let (light, p) = (quad(true), Vec3A::new(2.5, 0.3, 2.0));
        assert!(
            p.dot(Vec3A::new(0.3, 0.0, -1.0)) < 0.0,
            "p is behind the light"
        );
        chi2_light(
            "parallelogram two-sided, back, grazing",
            &light,
            p,
            &polygon_grid(p, &light),
            704,
        );
    }

    fn sphere_grid(light: &Light, p: Vec3A) -> Grid {
        let Light::Sphere { center, radius, .. } = *light else {
            unreachable!()
        };
        let (dc, r) = (d(center - p), radius as f64);
        let sin2 = r * r / dc.length_squared();
        let t_edge = sin2 / (1.0 + (1.0 - sin2).sqrt());
        Grid::cap_with_edge(f(dc.normalize()), t_edge, 20, 40)
    }

    #[test]
    fn chi2_sphere_near() {
        let light = Light::Sphere {
            center: Vec3A::new(0.2, -0.1, 2.0),
            radius: 1.2,
            radiance: L,
        };
        let p = Vec3A::new(0.0, 0.3, 0.1);
        chi2_light("sphere near", &light, p, &sphere_grid(&light, p), 705);
    }

    #[test]
    fn chi2_sphere_far() {
        // sin^2(theta_max) = 4e-4: pbrt's small-angle regime.
        let light = Light::Sphere {
            center: Vec3A::new(30.0, -40.0, 0.0),
            radius: 1.0,
            radiance: L,
        };
        let p = Vec3A::new(0.0, 0.0, 0.0);
        chi2_light("sphere far", &light, p, &sphere_grid(&light, p), 706);
    }

    #[test]
    fn chi2_sphere_inside_area_sampling() {
        // From inside nothing is emitted towards p (sample_li is None), so this tests the
        // geometric area sampling against an independent density: dist^2 / (|cos| 4 pi r^2).
        let (center, radius) = (Vec3A::new(1.0, 0.0, 0.0), 2.0f32);
        let light = Light::Sphere {
            center,
            radius,
            radiance: L,
        };
        let p = Vec3A::new(2.2, 0.5, -0.3);
        let mut s = Sampler::new(707, 0, 0);
        for _ in 0..1000 {
            assert!(light.sample_li(p, s.next_2d()).is_none());
            let w = crate::sampling::uniform_sphere(s.next_2d());
            let (q, n) = hit_light(&light, p, w).expect("inside");
            assert_eq!(light.pdf_li(p, w, q), 0.0);
            assert_eq!(light.emitted(n, -w), Rgb::ZERO);
        }
        let pdf = |w: Vec3A| {
            let (q, n) = hit_light(&light, p, w).expect("inside");
            let dist2 = (q - p).length_squared();
            dist2 / (n.dot(w).abs() * 4.0 * PI * radius * radius)
        };
        assert_chi2(
            "sphere inside (area sampling)",
            &Grid::sphere(20, 40),
            SAMPLES,
            708,
            |s| {
                let (q, _, _) = sphere_sample(center, radius, p, s.next_2d())?;
                Some((q - p).normalize())
            },
            pdf,
        );
        // And the density sphere_sample reports is that one.
        for _ in 0..1000 {
            let (q, n, pdf_s) = sphere_sample(center, radius, p, s.next_2d()).expect("sample");
            assert!(
                ((q - center).length() - radius).abs() < 1e-5 && (n.length() - 1.0).abs() < 1e-5
            );
            let expected = pdf((q - p).normalize());
            assert!(
                (pdf_s - expected).abs() <= 1e-3 * expected,
                "{pdf_s} vs {expected}"
            );
        }
    }

    #[test]
    fn chi2_environment() {
        let light = Light::Environment { radiance: L };
        let p = Vec3A::new(3.0, 1.0, -2.0);
        chi2_light("environment", &light, p, &Grid::sphere(20, 40), 709);
    }

    #[test]
    fn one_sided_emitters_are_dark_from_behind() {
        let mut s = Sampler::new(710, 0, 0);
        for (light, p) in [
            (triangle(false), Vec3A::new(0.2, 0.6, -0.5)),
            (quad(false), Vec3A::new(2.5, 0.3, 2.0)),
        ] {
            for _ in 0..1000 {
                assert!(light.sample_li(p, s.next_2d()).is_none());
            }
            let verts = vertices(&light);
            let q = verts.iter().copied().sum::<Vec3A>() / verts.len() as f32;
            let (wi, n) = ((q - p).normalize(), light_normal(&light));
            assert_eq!(light.pdf_li(p, wi, q), 0.0);
            assert_eq!(light.emitted(n, -wi), Rgb::ZERO);
            assert_eq!(light.emitted(n, wi), L, "front side");
            // On the light's plane: no sample, no density.
            let on_plane = verts[0] + (verts[1] - verts[0]) * 2.0;
            assert!(light.sample_li(on_plane, Vec2::splat(0.3)).is_none());
        }
    }

    fn light_normal(light: &Light) -> Vec3A {
        match *light {
            Light::Triangle { n, .. } | Light::Parallelogram { n, .. } => n,
            _ => unreachable!(),
        }
    }

    #[test]
    fn sphere_samples_are_on_the_visible_cap_and_far_densities_are_accurate() {
        for dist in [1.5f32, 10.0, 1e3, 1e5] {
            let light = Light::Sphere {
                center: Vec3A::new(0.0, dist, 0.0),
                radius: 1.0,
                radiance: L,
            };
            let p = Vec3A::ZERO;
            check_samples(&light, p, 2000, 711);
            let ls = light.sample_li(p, Vec2::new(0.999, 0.3)).expect("visible");
            // Density against the f64 formula 1 / (2 pi (1 - cos_max)).
            let sin2 = 1.0 / (dist as f64 * dist as f64);
            let expected =
                1.0 / (2.0 * std::f64::consts::PI * (sin2 / (1.0 + (1.0 - sin2).sqrt())));
            assert!(
                (ls.pdf as f64 - expected).abs() < 1e-5 * expected,
                "d {dist}: {} vs {expected}",
                ls.pdf
            );
            // The sample is on the sphere, on the side facing p.
            let Light::Sphere { center, .. } = light else {
                unreachable!()
            };
            assert!(((ls.point - center).length() - 1.0).abs() < 1e-4 * dist.max(1.0));
            assert!((ls.point - center).dot(p - ls.point) >= 0.0);
        }
    }

    #[test]
    fn point_light_is_a_delta_with_inverse_square_falloff() {
        let light = Light::Point {
            position: Vec3A::new(0.0, 0.0, 2.0),
            intensity: Rgb::splat(8.0),
        };
        let ls = light.sample_li(Vec3A::ZERO, Vec2::ZERO).expect("sample");
        assert!(ls.delta && light.is_delta() && ls.pdf == 1.0 && ls.dist == 2.0);
        assert_eq!(ls.wi, Vec3A::Z);
        assert_eq!(ls.radiance, Rgb::splat(2.0));
        assert_eq!(light.pdf_li(Vec3A::ZERO, Vec3A::Z, ls.point), 0.0);
        assert_eq!(light.emitted(Vec3A::Z, Vec3A::Z), Rgb::ZERO);
        assert!(
            light
                .sample_li(Vec3A::new(0.0, 0.0, 2.0), Vec2::ZERO)
                .is_none(),
            "at the light"
        );
    }

    #[test]
    fn emitted_radiance_by_side() {
        let sphere = Light::Sphere {
            center: Vec3A::ZERO,
            radius: 1.0,
            radiance: L,
        };
        assert_eq!(sphere.emitted(Vec3A::Z, Vec3A::new(0.0, 0.6, 0.8)), L);
        assert_eq!(sphere.emitted(Vec3A::Z, -Vec3A::Z), Rgb::ZERO);
        assert_eq!(triangle(true).emitted(Vec3A::Z, -Vec3A::Z), L);
        let env = Light::Environment { radiance: L };
        assert_eq!(env.emitted(Vec3A::ZERO, Vec3A::X), L);
        let ls = env
            .sample_li(Vec3A::ONE, Vec2::new(0.3, 0.7))
            .expect("sample");
        assert!(
            ls.dist.is_infinite()
                && !ls.delta
                && (ls.pdf - 0.25 / PI).abs() < 1e-9
                && ls.radiance == L
        );
    }

    #[test]
    fn power_formulas() {
        let lum = crate::luminance(L) as f64;
        let pi = std::f64::consts::PI;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * b.abs();
        let tri = triangle(false);
        let Light::Triangle { area, .. } = tri else {
            unreachable!()
        };
        assert!(close(tri.power(1.0), lum * area as f64 * pi));
        assert!(close(
            triangle(true).power(1.0),
            2.0 * lum * area as f64 * pi
        ));
        let q = quad(false);
        assert!(close(q.power(1.0), lum * (1.0f64 + 0.09).sqrt() * pi));
        let s = Light::Sphere {
            center: Vec3A::ZERO,
            radius: 2.0,
            radiance: L,
        };
        assert!(close(s.power(1.0), lum * 16.0 * pi * pi));
        let p = Light::Point {
            position: Vec3A::ZERO,
            intensity: L,
        };
        assert!(close(p.power(1.0), 4.0 * pi * lum));
        let e = Light::Environment { radiance: L };
        assert!(close(e.power(3.0), lum * 36.0 * pi * pi));
        let black = Light::Point {
            position: Vec3A::ZERO,
            intensity: Rgb::new(-1.0, f32::NAN, 0.0),
        };
        assert_eq!(black.power(1.0), 0.0);
    }

    /// A light whose power passes f32's range is still chosen (in proportion to its power),
    /// not dropped as infinite.
    #[test]
    fn a_light_beyond_f32_power_is_still_sampled() {
        let huge = Light::Sphere {
            center: Vec3A::ZERO,
            radius: 1e15,
            radiance: Rgb::splat(1e10),
        };
        assert!(huge.power(1.0) > f32::MAX as f64 && huge.power(1.0).is_finite());
        let table = LightTable::new(vec![point(1.0), huge], 1.0);
        assert!(table.pmf(1) > 0.999, "{}", table.pmf(1));
    }

    fn point(intensity: f32) -> Light {
        Light::Point {
            position: Vec3A::ZERO,
            intensity: Rgb::splat(intensity),
        }
    }

    #[test]
    fn chi2_light_table_selection_follows_power() {
        let intensities = [1.0f32, 0.0, 3.0, 0.5, 0.0, 2.5, 0.0];
        let table = LightTable::new(intensities.iter().map(|&i| point(i)).collect(), 1.0);
        let total: f32 = intensities.iter().sum();
        for (i, &x) in intensities.iter().enumerate() {
            assert!((table.pmf(i as u32) - x / total).abs() < 1e-6);
        }
        let mut counts = vec![0u64; intensities.len()];
        let mut s = Sampler::new(712, 0, 0);
        for _ in 0..SAMPLES {
            let (i, pmf) = table.sample(s.next_1d()).expect("non-empty");
            assert_eq!(pmf, table.pmf(i));
            counts[i as usize] += 1;
        }
        for (i, &x) in intensities.iter().enumerate() {
            if x == 0.0 {
                assert_eq!(counts[i], 0, "zero-power light {i} chosen");
            }
        }
        let expected: Vec<f64> = intensities
            .iter()
            .map(|&x| (x / total) as f64 * SAMPLES as f64)
            .collect();
        assert_chi2_discrete("light table selection", &counts, &expected, SAMPLES);
    }

    #[test]
    fn light_table_edge_cases() {
        let empty = LightTable::new(Vec::new(), 1.0);
        assert!(empty.is_empty() && empty.sample(0.5).is_none() && empty.environment().is_none());
        assert!(LightTable::default().sample(0.3).is_none());

        // All black: uniform.
        let black = LightTable::new(vec![point(0.0), point(0.0), point(0.0), point(0.0)], 1.0);
        for i in 0..4 {
            assert_eq!(black.pmf(i), 0.25);
        }
        assert_eq!(black.sample(0.0).map(|x| x.0), Some(0));
        assert_eq!(black.sample(0.6).map(|x| x.0), Some(2));
        assert_eq!(black.sample(0.999_999_9).map(|x| x.0), Some(3));

        // Zero-power lights at both ends and in the middle are never returned, whatever u.
        let table = LightTable::new(
            vec![point(0.0), point(1.0), point(0.0), point(3.0), point(0.0)],
            1.0,
        );
        let us = (0..=10_000).map(|i| i as f32 / 10_000.0).chain([
            -1.0,
            1.0,
            2.0,
            f32::NAN,
            f32::INFINITY,
            1.0 - f32::EPSILON / 2.0,
        ]);
        for u in us {
            let (i, pmf) = table.sample(u).expect("non-empty");
            assert!(pmf > 0.0 && (i == 1 || i == 3), "u {u} -> {i}");
        }
        assert_eq!(table.sample(0.0).map(|x| x.0), Some(1));
        assert_eq!(table.sample(0.2499).map(|x| x.0), Some(1));
        assert_eq!(table.sample(0.2501).map(|x| x.0), Some(3));

        // The environment light is found (the first, if several).
        let env = Light::Environment { radiance: L };
        let t = LightTable::new(vec![point(1.0), env.clone(), triangle(false), env], 10.0);
        assert_eq!(t.environment(), Some(1));
        assert_eq!(t.len(), 4);
        assert_eq!(t.get(1), &Light::Environment { radiance: L });
    }
}
