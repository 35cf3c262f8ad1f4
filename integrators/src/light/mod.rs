//! Emitters: sampling of incident radiance from a reference point (next-event estimation),
//! sampling of emitted rays with their position and direction densities (photons and light
//! paths, pbrt-v4's `SampleLe`/`PDF_Le`), densities for MIS, and the light table that picks an
//! emitter in proportion to its power. One file per emitter kind; [`table`] is the light
//! sampler.
//!
//! Units: `radiance` is W·sr⁻¹·m⁻² per channel, a point light's `intensity` is W·sr⁻¹ per
//! channel, positions and lengths are in scene units. Densities of [`Light::sample_li`] are per
//! unit solid angle at the reference point (except for point lights, which are deltas); of
//! [`Light::sample_le`], per unit area on the light (per unit area of the disk facing the
//! scene for the environment) and per unit solid angle of the emitted direction.
//!
//! Sampling strategies:
//! * Triangle, parallelogram and disk ([`planar`]): uniform in area, converted to solid angle
//!   with `pdf = dist^2 / (|cos_l| area)`. One-sided emitters (the default) emit only on the
//!   side their normal `n = normalize(e1 x e2)` points to; from behind they yield no sample.
//! * Cylinder ([`cylinder`]): uniform in area too (as Mitsuba 3 and pbrt-v4 sample it),
//!   emitting outwards or, with its normals flipped, inwards.
//! * Sphere ([`sphere`]), reference point outside: uniform in the cone of directions the sphere
//!   subtends (pbrt-v4's `Sphere::Sample`), computed with cancellation-free formulas so that
//!   distant, tiny spheres keep an accurate density. Inside (or on) the sphere: uniform in
//!   area. A sphere emits outwards only, so from inside it yields no sample.
//! * Point ([`point`]): the single direction to the light.
//! * Environment ([`environment`]): uniform over the sphere of directions.
//!
//! Emitted rays leave area lights from a uniform point in a cosine-weighted direction on their
//! emitting side (a random side, each with probability 1/2, when two-sided), point lights in a
//! uniform direction, and the environment from a uniform point of the disk of the scene's
//! radius facing a uniform direction, outside the scene's bounding sphere.

pub mod bvh;
pub mod cylinder;
pub mod directional;
pub mod env_map;
pub mod environment;
pub mod planar;
pub mod point;
pub mod projector;
pub mod sphere;
pub mod spot;
pub mod table;

pub use bvh::LightContext;
pub use cylinder::CylinderLight;
pub use directional::DirectionalLight;
pub use env_map::{EnvMap, EnvMapLight};
pub use environment::EnvironmentLight;
pub use planar::{Planar, PlanarShape};
pub use point::PointLight;
pub use projector::ProjectorLight;
pub use sphere::SphereLight;
pub use spot::{Falloff, SpotLight};
pub use table::{LightSelection, LightTable};

use crate::spectrum::rgb_of;
use crate::spectrum::Wavelengths;
use crate::{Frame, Rgb, Spectrum};
use glam::{Vec2, Vec3A};

/// One emitter. Area lights are one primitive each (a mesh emitter is one light per triangle;
/// a quad is one parallelogram so that stratified samples cover it as a whole).
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// A triangle, parallelogram or disk.
    Planar(Planar),
    /// An open cylinder emitting from its outside or (normals flipped) its inside.
    Cylinder(CylinderLight),
    /// A sphere emitting outwards from its whole surface.
    Sphere(SphereLight),
    /// An isotropic point light.
    Point(PointLight),
    /// Constant radiance arriving from every direction not blocked by geometry.
    Environment(EnvironmentLight),
    /// Radiance from a latitude-longitude image, arriving from every direction not blocked.
    EnvMap(EnvMapLight),
    /// Parallel light from infinitely far away (a sun).
    Directional(DirectionalLight),
    /// A point light whose intensity falls off away from its axis.
    Spot(SpotLight),
    /// A point light throwing an image through a pinhole (boxed: every light of a scene takes
    /// the largest kind's room).
    Projector(Box<ProjectorLight>),
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
    /// `intensity / dist^2`): the light's colour as RGB mode's spectrum where a light
    /// makes it, at the sample's wavelengths once [`Light::sample_li`] returns it.
    pub radiance: Spectrum,
    /// Density per unit solid angle at the reference point; 1 for delta lights.
    pub pdf: f32,
    /// True for point lights (cannot be hit by rays, no MIS).
    pub delta: bool,
}

impl LightSample {
    /// The light at `position` (a delta in position) seen from `p`: `radiance(w, dist^2)`
    /// is what arrives from it along the unit direction `w` leaving it, at that squared
    /// distance (`None`: nothing that way). `None` where `p` is the light's position.
    #[inline]
    pub fn from_position(
        p: Vec3A,
        position: Vec3A,
        radiance: impl FnOnce(Vec3A, f32) -> Option<Rgb>,
    ) -> Option<LightSample> {
        let d = position - p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0 && dist2.is_finite()) {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        let radiance = crate::spectrum::of_rgb(radiance(-wi, dist2)?);
        radiance.is_finite().then_some(LightSample {
            wi,
            point: position,
            dist,
            radiance,
            pdf: 1.0,
            delta: true,
        })
    }

    /// The point `q` of a surface light, sampled from `p` with solid-angle density
    /// `pdf(wi, dist^2)`; `None` where `p` and `q` coincide or the density vanishes.
    #[inline]
    pub fn on_surface(
        p: Vec3A,
        q: Vec3A,
        radiance: Rgb,
        pdf: impl FnOnce(Vec3A, f32) -> f32,
    ) -> Option<LightSample> {
        let d = q - p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0 && dist2.is_finite()) {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        let pdf = pdf(wi, dist2);
        (pdf > 0.0).then_some(LightSample {
            wi,
            point: q,
            dist,
            radiance: crate::spectrum::of_rgb(radiance),
            pdf,
            delta: false,
        })
    }
}

/// A ray leaving an emitter ([`Light::sample_le`]): pbrt-v4's `LightLeSample`.
#[derive(Clone, Copy, Debug)]
pub struct LeSample {
    /// The ray leaving the light (already pushed off its surface).
    pub ray: crate::Ray,
    /// Emitted radiance along the ray (a point light's intensity): as
    /// [`LightSample::radiance`].
    pub radiance: Spectrum,
    /// The emitting surface's normal on the emitting side; zero for point lights, the ray's
    /// direction for the environment.
    pub normal: Vec3A,
    /// Density of the ray's origin per unit area (1 for a point light: a delta).
    pub pdf_pos: f32,
    /// Density of the ray's direction per unit solid angle.
    pub pdf_dir: f32,
    /// `Le |cos| / (pdf_pos pdf_dir)`: the power, in watts per channel, that the sample stands
    /// for before division by the light's selection probability and the number of samples.
    /// Summed over samples, it estimates the light's emitted power.
    pub weight: Spectrum,
}

/// Area-light samples seen under a smaller `|cos|` than this are dropped: their solid-angle
/// density is unbounded and their contribution vanishes (`p` on the light's plane).
const MIN_COS: f32 = 1e-6;

/// A ray leaving a surface point `p` with normal `n` in the cosine-distributed direction
/// `u_dir` picks, pushed off the surface; and that direction's cosine.
fn leave(p: Vec3A, n: Vec3A, u_dir: Vec2) -> (crate::Ray, f32) {
    let local = crate::sampling::cosine_hemisphere(u_dir);
    let dir = Frame::from_normal(n).to_world(local);
    let surface = crate::Hit::new(0.0, p, n, 0, None);
    (surface.spawn_ray(dir), local.z)
}

/// A ray travelling along `dir` into the scene from infinitely far away: from a uniform
/// point (`u_pos`) of the disk of radius `scene_radius` across `dir`, placed outside the
/// scene's bounding sphere. How lights at infinity (environments, directional lights) emit.
fn ray_from_afar(dir: Vec3A, u_pos: Vec2, scene_center: Vec3A, scene_radius: f32) -> crate::Ray {
    let frame = Frame::from_normal(dir);
    let d = crate::sampling::concentric_disk(u_pos) * scene_radius;
    let origin = scene_center - dir * (2.0 * scene_radius) + frame.s * d.x + frame.t * d.y;
    crate::Ray::new(origin, dir)
}

macro_rules! dispatch {
    ($self:expr, $l:ident => $e:expr) => {
        match $self {
            Light::Planar($l) => $e,
            Light::Cylinder($l) => $e,
            Light::Sphere($l) => $e,
            Light::Point($l) => $e,
            Light::Environment($l) => $e,
            Light::EnvMap($l) => $e,
            Light::Directional($l) => $e,
            Light::Spot($l) => $e,
            Light::Projector($l) => $e,
        }
    };
}

impl Light {
    /// A triangle light with vertices `p0, p1, p2`; it emits on the side of
    /// `(p1 - p0) x (p2 - p0)` unless `two_sided`.
    pub fn triangle(p0: Vec3A, p1: Vec3A, p2: Vec3A, radiance: Rgb, two_sided: bool) -> Light {
        Light::Planar(Planar::new(
            PlanarShape::Triangle,
            p0,
            p1 - p0,
            p2 - p0,
            radiance,
            two_sided,
        ))
    }

    /// A parallelogram light `p0 + s e1 + t e2`; it emits on the side of `e1 x e2` unless
    /// `two_sided`.
    pub fn parallelogram(p0: Vec3A, e1: Vec3A, e2: Vec3A, radiance: Rgb, two_sided: bool) -> Light {
        Light::Planar(Planar::new(
            PlanarShape::Parallelogram,
            p0,
            e1,
            e2,
            radiance,
            two_sided,
        ))
    }

    /// A disk (an ellipse if `e1` and `e2` differ) centred on `center` with placed axes `e1`,
    /// `e2`; it emits on the side of `e1 x e2` unless `two_sided`.
    pub fn disk(center: Vec3A, e1: Vec3A, e2: Vec3A, radiance: Rgb, two_sided: bool) -> Light {
        Light::Planar(Planar::new(
            PlanarShape::Disk,
            center,
            e1,
            e2,
            radiance,
            two_sided,
        ))
    }

    /// A sphere emitting `radiance` outwards.
    pub fn sphere(center: Vec3A, radius: f32, radiance: Rgb) -> Light {
        Light::Sphere(SphereLight {
            center,
            radius,
            radiance,
            inward: false,
        })
    }

    /// A sphere emitting `radiance` into its inside (its normals flipped).
    pub fn sphere_inward(center: Vec3A, radius: f32, radiance: Rgb) -> Light {
        Light::Sphere(SphereLight {
            center,
            radius,
            radiance,
            inward: true,
        })
    }

    /// A point light of `intensity` (W/sr per channel).
    pub fn point(position: Vec3A, intensity: Rgb) -> Light {
        Light::Point(PointLight {
            position,
            intensity,
        })
    }

    /// A constant environment of `radiance`.
    pub fn environment(radiance: Rgb) -> Light {
        Light::Environment(EnvironmentLight { radiance })
    }

    /// True for lights that rays cannot hit (point, spot, projector and directional lights).
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Light::Point(_) | Light::Spot(_) | Light::Directional(_) | Light::Projector(_)
        )
    }

    /// True when points of the light's own surface may receive its light (a concave
    /// emitter: a sphere or cylinder emitting inwards). Flat and convex emitters cannot light
    /// themselves, and shading points on them skip their own light exactly.
    pub fn lights_itself(&self) -> bool {
        match self {
            Light::Sphere(s) => s.lights_itself(),
            Light::Cylinder(c) => c.inward,
            _ => false,
        }
    }

    /// True for the lights at infinity that escaping rays see (constant or mapped).
    pub fn is_environment(&self) -> bool {
        matches!(self, Light::Environment(_) | Light::EnvMap(_))
    }

    /// Samples a direction towards the light from `p`. `None` when the sample carries no
    /// radiance (back side of a one-sided emitter, `p` on the light's plane, `p` inside a
    /// sphere light, ...). A light with black radiance still returns samples (with zero
    /// radiance).
    #[inline]
    pub fn sample_li(&self, p: Vec3A, u: Vec2, lambda: &Wavelengths) -> Option<LightSample> {
        let mut s = dispatch!(self, l => l.sample_li(p, u))?;
        s.radiance = match self {
            Light::EnvMap(l) if lambda.is_spectral() => l.map.radiance_at(s.wi, lambda),
            _ => lambda.illuminant(rgb_of(s.radiance)),
        };
        Some(s)
    }

    /// The solid-angle density with which [`Light::sample_li`] from `p` would produce the
    /// direction `wi` that reaches the light at point `q`.
    ///
    /// The light's own geometry decides which side emits (not the normal of the hit that
    /// found `q`), so this matches `sample_li` exactly: zero for point lights, for the back of
    /// one-sided emitters and for a sphere seen from inside.
    #[inline]
    pub fn pdf_li(&self, p: Vec3A, wi: Vec3A, q: Vec3A) -> f32 {
        dispatch!(self, l => l.pdf_li(p, wi, q))
    }

    /// Radiance leaving the emitter's surface with geometric normal `n` in direction `w`
    /// (unit, pointing away from the surface). For the environment, the radiance arriving
    /// from `-w`.
    #[inline]
    pub fn emitted(&self, n: Vec3A, w: Vec3A, lambda: &Wavelengths) -> Spectrum {
        match self {
            Light::EnvMap(l) if lambda.is_spectral() => l.map.radiance_at(-w, lambda),
            _ => lambda.illuminant(self.emitted_rgb(n, w)),
        }
    }

    /// [`Light::emitted`] as the colour the scene gives.
    #[inline]
    fn emitted_rgb(&self, n: Vec3A, w: Vec3A) -> Rgb {
        dispatch!(self, l => l.emitted(n, w))
    }

    /// [`Light::emitted`] from the point `q` of the emitter's surface: what a textured
    /// emitter gives there.
    #[inline]
    pub fn emitted_at(&self, q: Vec3A, n: Vec3A, w: Vec3A, lambda: &Wavelengths) -> Spectrum {
        match self {
            Light::Planar(l) => lambda.illuminant(l.emitted_at(q, n, w)),
            _ => self.emitted(n, w, lambda),
        }
    }

    /// Samples a ray leaving the light (see the module docs): `u_pos` places its origin,
    /// `u_dir` its direction, `u_side` picks the side of a two-sided light. The environment's
    /// rays start outside the scene's bounding sphere (`scene_center`, `scene_radius`).
    #[inline]
    pub fn sample_le(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        u_side: f32,
        scene_center: Vec3A,
        scene_radius: f32,
        lambda: &Wavelengths,
    ) -> Option<LeSample> {
        let mut s = match self {
            Light::Planar(l) => l.sample_le(u_pos, u_dir, u_side),
            Light::Cylinder(l) => l.sample_le(u_pos, u_dir),
            Light::Sphere(l) => l.sample_le(u_pos, u_dir),
            Light::Point(l) => l.sample_le(u_dir),
            Light::Environment(l) => l.sample_le(u_pos, u_dir, scene_center, scene_radius),
            Light::EnvMap(l) => l.sample_le(u_pos, u_dir, scene_center, scene_radius),
            Light::Directional(l) => l.sample_le(u_pos, scene_center, scene_radius),
            Light::Spot(l) => l.sample_le(u_dir),
            Light::Projector(l) => l.sample_le(u_dir),
        };
        if !(s.weight.is_finite() && s.weight != Spectrum::ZERO) {
            return None;
        }
        // The colours scale by the positive factors between them, and so do their spectra.
        if let (Light::EnvMap(l), true) = (self, lambda.is_spectral()) {
            s.radiance = l.map.radiance_at(-s.ray.dir, lambda);
            s.weight = s.radiance / (s.pdf_pos * s.pdf_dir);
            return Some(s);
        }
        s.radiance = lambda.illuminant(rgb_of(s.radiance));
        s.weight = lambda.illuminant(rgb_of(s.weight));
        Some(s)
    }

    /// Position and direction densities with which [`Light::sample_le`] produces a ray leaving
    /// the surface normal `n` (the light's normal at the origin; ignored by point lights and
    /// the environment) in direction `w`. The position density of a point light is 0 (a
    /// delta, as in pbrt-v4).
    #[inline]
    pub fn pdf_le(&self, n: Vec3A, w: Vec3A, scene_radius: f32) -> (f32, f32) {
        match self {
            Light::Planar(l) => l.pdf_le(w),
            Light::Cylinder(l) => l.pdf_le(n, w),
            Light::Sphere(l) => l.pdf_le(n, w),
            Light::Point(l) => l.pdf_le(),
            Light::Environment(l) => l.pdf_le(scene_radius),
            Light::EnvMap(l) => l.pdf_le(w, scene_radius),
            Light::Directional(l) => l.pdf_le(scene_radius),
            Light::Spot(l) => l.pdf_le(w),
            Light::Projector(l) => l.pdf_le(w),
        }
    }

    /// Radiance leaving point `q` of the light's surface towards `w`: [`Light::emitted_at`]
    /// with the normal a ray's hit at `q` reports (a sphere's outward one, whichever side it
    /// emits from; the emitting normal of the others), for a point found by sampling.
    pub fn emitted_from(&self, q: Vec3A, w: Vec3A, lambda: &Wavelengths) -> Spectrum {
        let n = match self {
            Light::Sphere(l) => (q - l.center).normalize_or_zero(),
            _ => self.emitting_normal_at(q),
        };
        self.emitted_at(q, n, w, lambda)
    }

    /// The emitting normal at the point `q` of the light's surface (what [`Light::pdf_le`]
    /// takes): a flat light's normal, a sphere's or cylinder's normal there on its emitting
    /// side; zero for point, spot and lights at infinity.
    pub fn emitting_normal_at(&self, q: Vec3A) -> Vec3A {
        match self {
            Light::Planar(l) => l.n,
            Light::Cylinder(l) => l.normal_at(q),
            Light::Sphere(l) => l.emitting_normal((q - l.center).normalize_or_zero()),
            _ => Vec3A::ZERO,
        }
    }

    /// Emitted power (luminance, watts) used to choose lights; `scene_radius` bounds the
    /// environment's contribution. Never negative; NaN powers become 0.
    pub fn power(&self, scene_radius: f32) -> f64 {
        let power = match self {
            Light::Environment(l) => l.power(scene_radius),
            Light::EnvMap(l) => l.power(scene_radius),
            Light::Directional(l) => l.power(scene_radius),
            Light::Spot(l) => l.power(),
            Light::Projector(l) => l.power(),
            Light::Planar(l) => l.power(),
            Light::Cylinder(l) => l.power(),
            Light::Sphere(l) => l.power(),
            Light::Point(l) => l.power(),
        };
        power.max(0.0)
    }
}

/// Luminance of `c` in f64: radiance times area may pass f32's range in a valid scene (a
/// bright light the size of a planet), and an infinite power would drop the light from the
/// table. (Luminance itself stays in f32: it is a weighted mean, never above the largest
/// channel.)
fn lum(c: Rgb) -> f64 {
    crate::luminance(c) as f64
}

#[cfg(test)]
mod tests;
