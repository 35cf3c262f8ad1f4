//! Emitters: sampling of incident radiance from a reference point, densities for MIS, and the
//! light table that picks an emitter in proportion to its power.
// STUB bodies: to be implemented (helper task). Keep the public API.

use crate::Rgb;
use glam::{Vec2, Vec3A};

/// One emitter. Area lights are one primitive each (a mesh emitter is one light per triangle;
/// a quad is one parallelogram so that stratified samples cover it as a whole).
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Triangle `p0, p0 + e1, p0 + e2`; `n = normalize(e1 x e2)` is the emitting side unless
    /// `two_sided`.
    Triangle { p0: Vec3A, e1: Vec3A, e2: Vec3A, n: Vec3A, area: f32, radiance: Rgb, two_sided: bool },
    /// Parallelogram `p0 + s e1 + t e2`, `s, t` in `[0, 1]`; normal as for triangles.
    Parallelogram { p0: Vec3A, e1: Vec3A, e2: Vec3A, n: Vec3A, area: f32, radiance: Rgb, two_sided: bool },
    /// Sphere emitting `radiance` outwards from its whole surface.
    Sphere { center: Vec3A, radius: f32, radiance: Rgb },
    /// Isotropic point light of `intensity` (W/sr per channel).
    Point { position: Vec3A, intensity: Rgb },
    /// Constant radiance arriving from every direction not blocked by geometry.
    Environment { radiance: Rgb },
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

impl Light {
    pub fn triangle(p0: Vec3A, p1: Vec3A, p2: Vec3A, radiance: Rgb, two_sided: bool) -> Light {
        let (e1, e2) = (p1 - p0, p2 - p0);
        let c = e1.cross(e2);
        Light::Triangle { p0, e1, e2, n: c.normalize(), area: 0.5 * c.length(), radiance, two_sided }
    }

    pub fn parallelogram(p0: Vec3A, e1: Vec3A, e2: Vec3A, radiance: Rgb, two_sided: bool) -> Light {
        let c = e1.cross(e2);
        Light::Parallelogram { p0, e1, e2, n: c.normalize(), area: c.length(), radiance, two_sided }
    }

    /// True for lights that rays cannot hit (point lights).
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Point { .. })
    }

    /// Samples a direction towards the light from `p`. `None` when the sample carries no
    /// radiance (back side of a one-sided emitter, `p` on the light's plane, ...).
    pub fn sample_li(&self, _p: Vec3A, _u: Vec2) -> Option<LightSample> {
        todo!()
    }

    /// The solid-angle density with which [`Light::sample_li`] from `p` would produce the
    /// direction `wi` that reaches the light at point `q` with geometric normal `nq`.
    pub fn pdf_li(&self, _p: Vec3A, _wi: Vec3A, _q: Vec3A, _nq: Vec3A) -> f32 {
        todo!()
    }

    /// Radiance leaving the emitter's surface with geometric normal `n` in direction `w`
    /// (unit, pointing away from the surface). For the environment, the radiance arriving
    /// from `-w`.
    pub fn emitted(&self, _n: Vec3A, _w: Vec3A) -> Rgb {
        todo!()
    }

    /// Emitted power (luminance, watts) used to choose lights; `scene_radius` bounds the
    /// environment's contribution.
    pub fn power(&self, _scene_radius: f32) -> f32 {
        todo!()
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
    /// power is zero). At most one environment light.
    pub fn new(_lights: Vec<Light>, _scene_radius: f32) -> LightTable {
        todo!()
    }

    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    pub fn len(&self) -> usize {
        self.lights.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    pub fn get(&self, index: u32) -> &Light {
        &self.lights[index as usize]
    }

    /// Picks a light with `u` in `[0, 1)`: its index and selection probability.
    pub fn sample(&self, _u: f32) -> Option<(u32, f32)> {
        todo!()
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
