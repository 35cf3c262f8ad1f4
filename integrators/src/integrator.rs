//! The integrator interface, ray accounting, and helpers shared by integrators.

use crate::light::LightSample;
use crate::{Hit, Ray, Rgb, Sampler, Scene};

/// Rays cast, by kind. Every integrator counts through [`Tracer`], so rays per second are
/// reported the same way for all of them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounters {
    pub camera: u64,
    pub extension: u64,
    pub shadow: u64,
}

impl RayCounters {
    pub fn total(&self) -> u64 {
        self.camera + self.extension + self.shadow
    }

    pub fn add(&mut self, other: &RayCounters) {
        self.camera += other.camera;
        self.extension += other.extension;
        self.shadow += other.shadow;
    }
}

/// A scene with ray counters: the only way integrators cast rays.
pub struct Tracer<'a> {
    pub scene: &'a dyn Scene,
    pub counters: RayCounters,
}

impl<'a> Tracer<'a> {
    pub fn new(scene: &'a dyn Scene) -> Self {
        Tracer { scene, counters: RayCounters::default() }
    }

    /// Traces a primary ray from the camera.
    #[inline]
    pub fn camera(&mut self, ray: &Ray) -> Option<Hit> {
        self.counters.camera += 1;
        self.scene.intersect(ray)
    }

    /// Traces a secondary ray that extends a path (or branches it).
    #[inline]
    pub fn extend(&mut self, ray: &Ray) -> Option<Hit> {
        self.counters.extension += 1;
        self.scene.intersect(ray)
    }

    /// Casts a shadow ray from `hit` towards a light sample; true if nothing blocks it.
    #[inline]
    pub fn unoccluded(&mut self, hit: &Hit, ls: &LightSample) -> bool {
        self.counters.shadow += 1;
        let ray = if ls.dist.is_finite() {
            hit.spawn_ray_to(ls.point)
        } else {
            hit.spawn_ray(ls.wi)
        };
        !self.scene.occluded(&ray)
    }
}

/// A light-transport algorithm: estimates the radiance arriving at the camera along a ray.
///
/// Implementations are immutable and shared between threads; all per-sample state lives in
/// the [`Sampler`] and the [`Tracer`].
pub trait Integrator: Send + Sync {
    /// One sample of the radiance arriving along `ray` (a camera ray). May return non-finite
    /// values only through bugs; the render loop drops and counts them.
    fn radiance(&self, ray: &Ray, tracer: &mut Tracer, sampler: &mut Sampler) -> Rgb;
}

/// Radiance emitted by the surface at `hit` towards the ray's origin.
#[inline]
pub fn emitted_at(scene: &dyn Scene, hit: &Hit, ray: &Ray) -> Rgb {
    match hit.light {
        Some(i) => scene.lights().get(i).emitted(hit.ng, -ray.dir),
        None => Rgb::ZERO,
    }
}

/// Radiance arriving along a ray that escaped the scene.
#[inline]
pub fn escaped(scene: &dyn Scene, ray: &Ray) -> Rgb {
    match scene.lights().environment() {
        Some(i) => scene.lights().get(i).emitted(glam::Vec3A::ZERO, -ray.dir),
        None => Rgb::ZERO,
    }
}
