//! A path walked from the camera one scattering event at a time: the state the unidirectional
//! tracers (`path`, `russian-roulette`, the photon gathers) share, so that each keeps only what
//! differs between them, how it counts the emitters it meets.

use crate::integrator::{
    continue_path_with_lobe, mis_weight_for_hit, russian_roulette, ShadingPoint, Tracer,
};
use crate::light::{LightContext, LightSelection};
use crate::{Hit, Ray, Sampler, Spectrum};
use glam::Vec3A;

/// The walk's state between two segments.
pub struct PathState {
    /// The ray to trace next.
    pub ray: Ray,
    /// Throughput from the path's start to `ray`'s origin (BSDF weights over densities,
    /// divided by the roulette's survival probabilities).
    pub beta: Spectrum,
    /// Scattering events so far.
    pub bounces: u32,
    /// Whether `ray` left a specular scattering event, or is the walk's first ray.
    pub specular: bool,
    /// Solid-angle density with which the BSDF chose `ray` (0 for the first ray).
    pub pdf: f32,
    /// The scattering point `ray` leaves (before the offset that keeps it off the surface).
    pub from: Vec3A,
    /// Its geometric normal (zero before the first scattering event).
    pub from_n: Vec3A,
    /// How its light samples pick a light (`None`: the scene's choice): emitters the walk
    /// meets are weighted against next-event estimation with that choice's probabilities.
    pub lights: Option<LightSelection>,
    /// Product of eta^2 over the path's refractions: roulette plays on `beta * eta_scale`, the
    /// throughput without refraction's compression of radiance (pbrt-v4's and Mitsuba 3's
    /// `rrBeta`).
    eta_scale: f32,
    /// Product, over the vertices a caller turned along its own direction
    /// ([`PathState::turn_along`]), of that direction's density over the BSDF's where it is
    /// the larger: roulette plays on the throughput BSDF sampling would have carried. A guide
    /// that sends a path towards bright light (a large density, so a small `f |cos| / pdf`)
    /// would otherwise have the roulette end most such paths and multiply the survivors'
    /// weight. Never below 1: the roulette plays on at least the path's own throughput, so
    /// it multiplies a survivor's weight no more than `path`'s does.
    sampling_gain: f32,
    /// Whether the first ray is a camera ray (counted as one).
    from_camera: bool,
}

impl PathState {
    /// A walk that starts with the camera ray `ray`.
    pub fn from_camera(ray: Ray) -> PathState {
        PathState {
            ray,
            beta: Spectrum::ONE,
            bounces: 0,
            specular: true,
            pdf: 0.0,
            from: ray.origin,
            from_n: Vec3A::ZERO,
            lights: None,
            eta_scale: 1.0,
            sampling_gain: 1.0,
            from_camera: true,
        }
    }

    /// The walk with its light samples picking lights by `lights`.
    pub fn selecting_lights(self, lights: Option<LightSelection>) -> PathState {
        PathState { lights, ..self }
    }

    /// A walk that starts with `ray`, leaving a surface (a final-gather ray).
    pub fn from_surface(ray: Ray) -> PathState {
        PathState {
            from_camera: false,
            ..PathState::from_camera(ray)
        }
    }

    /// Traces the next segment: the camera ray first, then extension rays.
    #[inline]
    pub fn trace(&self, tracer: &mut Tracer) -> Option<Hit> {
        if self.bounces == 0 && self.from_camera {
            tracer.camera(&self.ray)
        } else {
            tracer.extend(&self.ray)
        }
    }

    /// MIS weight of emission the walk's ray finds at `hit` (or on escaping, with `None`)
    /// against next-event estimation from the previous vertex: 1 after a specular bounce and
    /// for the first ray, which light sampling cannot reproduce.
    #[inline]
    pub fn emission_weight(&self, tracer: &Tracer, hit: Option<&Hit>) -> f32 {
        if self.specular {
            1.0
        } else {
            let from = LightContext {
                p: self.from,
                n: self.from_n,
            };
            mis_weight_for_hit(tracer.scene, (&from, self.lights), &self.ray, hit, self.pdf)
        }
    }

    /// Samples the BSDF at `sp` for the next segment, then, from `rr_depth` scattering events
    /// on, plays Russian roulette. `false` ends the walk.
    #[inline]
    pub fn scatter(&mut self, sp: &ShadingPoint, rr_depth: u32, sampler: &mut Sampler) -> bool {
        let u_lobe = sampler.next_1d();
        self.scatter_with_lobe(sp, u_lobe, rr_depth, sampler)
    }

    /// [`PathState::scatter`] with the number that picks the lobe given.
    #[inline]
    pub fn scatter_with_lobe(
        &mut self,
        sp: &ShadingPoint,
        u_lobe: f32,
        rr_depth: u32,
        sampler: &mut Sampler,
    ) -> bool {
        let Some((next, bs)) = continue_path_with_lobe(sp, u_lobe, &mut self.beta, sampler) else {
            return false;
        };
        self.eta_scale *= bs.eta * bs.eta;
        self.specular = bs.specular;
        self.pdf = bs.pdf;
        self.advance(sp, next, rr_depth, sampler)
    }

    /// Turns along `wi` (unit, world), a direction a strategy of the caller's sampled with
    /// solid-angle density `pdf` at a point with no Dirac lobe (`guided`'s mixture), where
    /// the BSDF's own sampling has density `bsdf_pdf`: multiplies the throughput by
    /// `f |cos| / pdf` and counts the scattering event, without Russian roulette (the caller
    /// plays it next, [`PathState::roulette`], on the throughput BSDF sampling would have
    /// carried). False ends the path (nothing carried).
    pub fn turn_along(&mut self, sp: &ShadingPoint, wi: Vec3A, pdf: f32, bsdf_pdf: f32) -> bool {
        let f = sp.connection_factor(wi, crate::bsdf::TransportMode::Radiance);
        if pdf.is_nan() || pdf <= 0.0 || f == Spectrum::ZERO {
            return false;
        }
        self.beta *= f / pdf;
        if !self.beta.is_finite() {
            return false;
        }
        let gain = self.sampling_gain * (pdf / bsdf_pdf).max(1.0);
        if gain.is_finite() && gain > 0.0 {
            self.sampling_gain = gain;
        }
        self.specular = false;
        self.pdf = pdf;
        self.from = sp.hit.p;
        self.from_n = sp.hit.ng;
        self.ray = sp.hit.spawn_ray(wi);
        self.bounces += 1;
        true
    }

    /// What Russian roulette multiplies the throughput by before it plays (see
    /// [`PathState::roulette`]): a caller that plays it on its own (`path-wavefront`'s lane
    /// kernels) plays on the same.
    pub fn roulette_scale(&self) -> f32 {
        self.eta_scale * self.sampling_gain
    }

    /// Russian roulette from `rr_depth` scattering events on; false ends the path.
    pub fn roulette(&mut self, rr_depth: u32, sampler: &mut Sampler) -> bool {
        if self.bounces >= rr_depth {
            let rr_beta = self.beta * self.roulette_scale();
            match russian_roulette(rr_beta, sampler) {
                Some(p) => self.beta /= p,
                None => return false,
            }
        }
        true
    }

    /// The path leaves `sp` along `next`: one more scattering event, then Russian roulette.
    fn advance(
        &mut self,
        sp: &ShadingPoint,
        next: Ray,
        rr_depth: u32,
        sampler: &mut Sampler,
    ) -> bool {
        self.from = sp.hit.p;
        self.from_n = sp.hit.ng;
        self.ray = next;
        self.bounces += 1;
        self.roulette(rr_depth, sampler)
    }
}
