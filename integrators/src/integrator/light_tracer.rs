//! `lighttracer`: light tracing, or particle tracing (Mitsuba 3's `ptracer`, pbrt-v4's
//! `lightpath`; Arvo and Kirk 1990, Veach's thesis section 10.2 with t = 1).
//!
//! **Estimates** the measurement equation from the lights' side. Each camera sample traces one
//! path from a light (chosen in proportion to power; a ray leaving it by `sample_le`), carrying
//! power in importance transport mode, and connects every vertex to the lens: the BSDF towards
//! the eye, the shading-normal correction, `We cos_lens / dist^2`, and an unoccluded segment.
//! Each connection is splatted at the film position it lands on; with one light path per
//! pixel sample, each splat is the path's estimate of the whole image's measurement restricted
//! to its pixel (see `camera.rs`). Emitters seen directly are one connection more per sample:
//! a point on a light chosen in proportion to power, sampled as seen from the eye. Point and
//! spot lights are not drawn (a pinhole would see one as a single lit pixel; pbrt-v4's
//! `lightpath` draws it, but no other integrator here can, `bdpt` included, so they would
//! disagree). Lights at infinity (environments, directional lights) cannot be connected to a
//! point lens: what the camera sees of an environment directly comes from the sample's camera
//! ray instead, traced only when the scene has one.
//!
//! Connections need a pinhole: an orthographic camera is refused before rendering.
//!
//! **Parameters**: `max-depth` (scattering events between light and camera, default
//! unlimited), `rr-depth` (scattering events before Russian roulette, default 3; the survival
//! probability is the path's throughput relative to what it left the light with, at most
//! 0.95).
//! **Bias**: whenever a mirror or glass is in view, light is missing: a vertex on a Dirac lobe
//! cannot be connected to the lens, so every path whose last bounce before the eye is
//! specular (`L (D|S)* S E`: a wall seen in a mirror, the room through a glass) is missed,
//! as in every light tracer. Otherwise none with unlimited `max-depth`. Caustics
//! (`L S+ D E`), which the path tracer finds slowly, come fast.

use crate::bsdf::TransportMode;
use crate::integrator::media_walk::{
    cross_null, fly, hero_channel, medium_at, transmittance, Flight,
};
use crate::integrator::{
    emit_from_a_light, escaped, Demand, Integrator, ShadingPoint, Splats, Tracer, MAX_SURVIVAL,
};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, Params, SpectralSupport, MAX_DEPTH, RR_DEPTH,
};
use crate::spectrum::{average, Wavelengths};
use crate::SampleContext;
use crate::{Camera, Hit, Ray, Sampler, Spectrum};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "lighttracer",
    summary: "light tracing: paths from the lights, each vertex connected to the camera and splatted (Mitsuba's ptracer, pbrt's lightpath)",
    params: &[MAX_DEPTH, RR_DEPTH],
    build: |p: &Params| {
        Box::new(LightTracer {
            max_depth: p.get_depth("max-depth"),
            rr_depth: p.get_u32("rr-depth"),
        })
    },
    analytic: Some(Analytic {
        params: &[],
        // Images of 80 x 80 (100 x 100) pixels per pass: light paths spread their
        // connections over the image, so a pass's mean needs many.
        furnace: expect(2.0, 40, 6400),
        point_in_sphere: expect(1.0, 40, 400),
        sphere_under_sky: expect(1.2, 40, 10000),
    }),
    media: MediaSupport::Scattering,
    spectral: SpectralSupport::PerSample,
};

struct LightTracer {
    max_depth: u32,
    rr_depth: u32,
}

impl Integrator for LightTracer {
    fn sample(&self, cx: SampleContext) -> Spectrum {
        let SampleContext {
            pixel,
            camera,
            tracer,
            sampler,
            splats,
            lambda,
        } = cx;
        // The environment seen straight through the pixel: the one path no light path reaches.
        let mut seen = Spectrum::ZERO;
        if tracer.scene.lights().environment().is_some() {
            let ray = camera.ray(pixel.film.x, pixel.film.y);
            if tracer.scene.has_media() {
                // Through the media and crossable surfaces in the way.
                let ray = Ray {
                    medium: tracer.scene.camera_medium(),
                    ..ray
                };
                seen = escaped(tracer.scene, &ray, lambda)
                    * transmittance(tracer, &ray, lambda, sampler);
            } else if tracer.camera(&ray).is_none() {
                seen = escaped(tracer.scene, &ray, lambda);
            }
        }
        if camera.is_pinhole() {
            self.emitters_seen_directly(camera, tracer, sampler, splats, lambda);
            self.light_path(camera, tracer, sampler, splats, lambda);
        }
        seen
    }

    fn demand(&self) -> Demand {
        Demand {
            pinhole: true,
            ..Demand::default()
        }
    }
}

impl LightTracer {
    /// Paths with no scattering: a point on a light, sampled as seen from the eye, splatted
    /// where it lands on the film (`We cos_lens L / pdf`, the pdf per solid angle at the eye).
    fn emitters_seen_directly(
        &self,
        camera: &Camera,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        splats: &mut Splats,
        lambda: &Wavelengths,
    ) {
        let (u_light, u) = (sampler.next_1d(), sampler.next_2d());
        let lights = tracer.scene.lights();
        let Some((index, pmf)) = lights.sample(u_light) else {
            return;
        };
        let light = lights.get(index);
        if light.is_delta() {
            return;
        }
        let Some(ls) = light.sample_li(camera.eye, u, lambda) else {
            return;
        };
        // Lights at infinity are seen by camera rays (see `sample`).
        if !ls.dist.is_finite() || ls.pdf <= 0.0 || ls.radiance == Spectrum::ZERO {
            return;
        }
        let Some((we, raster)) = camera.importance(ls.wi) else {
            return;
        };
        let cos_lens = ls.wi.dot(camera.normal());
        let eye = Hit::new(0.0, camera.eye, glam::Vec3A::ZERO, 0, None);
        let l = ls.radiance * we * (cos_lens / (ls.pdf * pmf));
        if tracer.scene.has_media() {
            let ray = Ray {
                medium: tracer.scene.camera_medium(),
                ..eye.spawn_ray_to(ls.point)
            };
            splats.add(
                raster,
                l * transmittance(tracer, &ray, lambda, sampler),
                lambda,
            );
        } else if tracer.unoccluded(&eye, &ls) {
            splats.add(raster, l, lambda);
        }
    }

    /// One path from a light, each vertex connected to the lens.
    fn light_path(
        &self,
        camera: &Camera,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        splats: &mut Splats,
        lambda: &mut Wavelengths,
    ) {
        let scene = tracer.scene;
        // Emission: a light in proportion to power, a ray leaving it.
        let Some((_, pmf, emission)) = emit_from_a_light(scene, sampler, lambda) else {
            return;
        };
        // Power the path carries: Le cos / (pdf_pos pdf_dir pmf).
        let emitted = emission.weight / pmf;
        let mut beta = emitted;
        let mut ray = emission.ray;
        // In media: the light's medium (walked from the camera's), the hero channel and each
        // channel's density over the hero's.
        let media = scene.has_media();
        let mut walk = Walk {
            hero: 0,
            r_u: Spectrum::ONE,
            lanes: lambda.lanes(),
        };
        if media {
            walk.hero = hero_channel(sampler.next_1d(), lambda);
            ray.medium = medium_at(scene, camera.eye, scene.camera_medium(), ray.origin);
        }
        let mut bounces = 0u32;
        while bounces < self.max_depth {
            // Trace the next segment.
            let hit = tracer.light(&ray);
            if media {
                let tmax = hit.map_or(f32::INFINITY, |h| h.t);
                let flight = fly(
                    scene,
                    &ray,
                    tmax,
                    walk.hero,
                    lambda,
                    sampler,
                    &mut beta,
                    &mut walk.r_u,
                );
                match flight {
                    Flight::Ended => return,
                    Flight::Through => {}
                    Flight::Scattered(p) => {
                        bounces += 1;
                        let Some(medium) = scene.medium(ray.medium) else {
                            return;
                        };
                        let (phase, wo) = (medium.phase(), -ray.dir);
                        if let Some(l) = connect_medium_to_lens(
                            p, wo, &ray, beta, &walk, camera, tracer, lambda, sampler,
                        ) {
                            splats.add(l.0, l.1, lambda);
                        }
                        if bounces >= self.max_depth {
                            return;
                        }
                        let ps = phase.sample(wo, sampler.next_2d());
                        beta *= ps.p / ps.pdf;
                        if !self.roulette(bounces, &mut beta, emitted, &walk, sampler) {
                            return;
                        }
                        ray = Ray {
                            origin: p,
                            dir: ps.wi,
                            tmax: f32::INFINITY,
                            medium: ray.medium,
                        };
                        continue;
                    }
                }
            }
            let Some(hit) = hit else {
                return;
            };
            let sp = ShadingPoint::new(&hit, ray.dir, scene, lambda);
            if media {
                // A medium's boundary (or a mask's hole): crossed, no scattering event.
                match cross_null(&sp, &ray, TransportMode::Importance, &mut beta, sampler) {
                    Some(Some(next)) => {
                        ray = next;
                        continue;
                    }
                    Some(None) => return,
                    None => {}
                }
            }
            bounces += 1;
            // Connect this vertex to the lens.
            if !sp.material.is_specular() {
                let medium = media.then_some((&walk, &mut *sampler));
                if let Some(l) = connect_to_lens(&sp, beta, camera, tracer, medium) {
                    splats.add(l.0, l.1, lambda);
                }
            }
            if bounces >= self.max_depth {
                return;
            }
            // Scatter in importance mode (power is not compressed by refraction).
            let Some(s) = sp.sample(
                sampler.next_1d(),
                sampler.next_2d(),
                TransportMode::Importance,
            ) else {
                return;
            };
            beta = s.throughput(beta);
            if !(beta.is_finite() && beta != Spectrum::ZERO) {
                return;
            }
            if !self.roulette(bounces, &mut beta, emitted, &walk, sampler) {
                return;
            }
            ray = sp.hit.spawn_ray(s.wi);
        }
    }

    /// Russian roulette from `rr-depth` scattering events on, on the throughput relative to
    /// the emitted power; false ends the path.
    fn roulette(
        &self,
        bounces: u32,
        beta: &mut Spectrum,
        emitted: Spectrum,
        walk: &Walk,
        sampler: &mut Sampler,
    ) -> bool {
        if bounces < self.rr_depth {
            return true;
        }
        let carried = beta.max_element() / average(walk.r_u, walk.lanes);
        let survive = (carried / emitted.max_element()).min(MAX_SURVIVAL);
        if survive.is_nan() || sampler.next_1d() >= survive {
            return false;
        }
        *beta /= survive;
        true
    }
}

/// A light path's state in media: its hero channel and each channel's density over the
/// hero's (all ones without media).
struct Walk {
    hero: usize,
    r_u: Spectrum,
    /// The lanes of its spectra that hold values (`Wavelengths::lanes`).
    lanes: usize,
}

/// The light-path vertex in a medium at `p` (reached along `ray`, `wo` back along it) seen
/// by the camera: the phase function towards the eye and the transmittance to it.
#[allow(clippy::too_many_arguments)]
fn connect_medium_to_lens(
    p: glam::Vec3A,
    wo: glam::Vec3A,
    ray: &Ray,
    beta: Spectrum,
    walk: &Walk,
    camera: &Camera,
    tracer: &mut Tracer,
    lambda: &Wavelengths,
    sampler: &mut Sampler,
) -> Option<(glam::Vec2, Spectrum)> {
    let cs = camera.sample_wi(p)?;
    let phase = tracer.scene.medium(ray.medium)?.phase();
    let f = phase.eval(wo, cs.wi);
    let to_eye = Ray {
        origin: p,
        dir: cs.wi,
        tmax: cs.dist * (1.0 - 1e-4),
        medium: ray.medium,
    };
    let tr = transmittance(tracer, &to_eye, lambda, sampler);
    let l = beta * tr * (f * cs.we / cs.pdf) / lambda.average(walk.r_u);
    (l != Spectrum::ZERO && l.is_finite()).then_some((cs.raster, l))
}

/// The light-path vertex `sp`, reached with power `beta`, seen by the camera: where it lands
/// on the film and the radiance it sends there, `beta f |wi.ns| corr We cos_lens / dist^2`
/// with Veach's shading-normal correction `corr = |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|)` (`wo`
/// back towards the light, `wi` towards the eye). `None` when the eye cannot see it.
/// In media (`medium`: the path's walk and the sampler), the connection carries the
/// transmittance to the eye instead of a visibility test.
fn connect_to_lens(
    sp: &ShadingPoint,
    beta: Spectrum,
    camera: &Camera,
    tracer: &mut Tracer,
    medium: Option<(&Walk, &mut Sampler)>,
) -> Option<(glam::Vec2, Spectrum)> {
    let cs = camera.sample_wi(sp.hit.p)?;
    let l = beta * sp.connection_factor(cs.wi, TransportMode::Importance) * (cs.we / cs.pdf);
    if l == Spectrum::ZERO {
        return None;
    }
    match medium {
        None => tracer
            .connected(&sp.hit, cs.point)
            .then_some((cs.raster, l)),
        Some((walk, sampler)) => {
            let ray = sp.hit.spawn_ray_to(cs.point);
            let tr = transmittance(tracer, &ray, &sp.lambda, sampler);
            let l = l * tr / average(walk.r_u, walk.lanes);
            (l != Spectrum::ZERO && l.is_finite()).then_some((cs.raster, l))
        }
    }
}
