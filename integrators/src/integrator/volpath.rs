//! `volpath`: volumetric path tracing (pbrt-v4's `VolPathIntegrator`; Mitsuba 3's `volpath`
//! and `volpathmis` estimate the same), the unidirectional baseline for participating media.
//!
//! **Estimates** the radiative transfer equation: surfaces as `path` does, and in media the
//! emission, absorption and scattering along every ray. Distances are sampled by delta
//! tracking against the medium's majorant ([`crate::medium::tracking`]); at each tentative
//! collision the path scatters (by the phase function, weighted by the albedo) or goes on (a
//! null collision), with the probabilities of one colour channel, the *hero*, chosen per
//! path; absorption is left to Russian roulette.
//! Every channel's own probabilities are carried beside the throughput (pbrt-v4's rescaled
//! path densities `r_u`, `r_l`), and the estimate divides by their average: one-sample
//! multiple importance sampling over the channels, so that a coloured medium (RGB `sigma_t`)
//! is not noisy by construction. At every scattering point, surface or medium, one light
//! sample is taken; its shadow ray passes through index-matched boundaries and thin
//! surfaces and carries the transmittance by ratio tracking; it and the emission the next
//! direction finds are weighted against each other by the balance heuristic over both
//! strategies and all channels.
//!
//! Surfaces that only bound a medium (material `Null`), a mask's null event and a thin
//! dielectric's transmission are crossings, not scattering events: they count no depth and
//! keep the last scattering point for MIS, as Mitsuba 3's `volpath` does.
//!
//! **Parameters**: `max-depth` (scattering events, surface or medium; default unlimited),
//! `rr-depth` (default 3): from there Russian roulette on the throughput where it is below 1
//! (after 1024 events on every path); `light-selection` (`scene`, the default, `uniform`,
//! `power` or `bvh`: how the light sample picks its light).
//! **Bias**: none with unlimited `max-depth`; truncation otherwise.

use crate::bsdf::TransportMode;
use crate::integrator::media_walk::{hero_channel, light_at_surface, positive, ray_from_point};
use crate::integrator::{emitted_at, escaped, RayIntegrator, ShadingPoint};
use crate::light::{LightContext, LightSelection};
use crate::medium::tracking::sample_t_maj;
use crate::medium::Phase;
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, Params, SpectralSupport, LIGHT_SELECTION,
    MAX_DEPTH, RR_DEPTH,
};
use crate::spectrum::{average, Wavelengths};
use crate::{Hit, LightSample, MediumId, Ray, Sampler, Scene, Spectrum, Tracer};
use glam::Vec3A;

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "volpath",
    summary: "volumetric path tracing: delta tracking, light samples through media by ratio tracking, MIS over strategies and colour channels",
    params: &[MAX_DEPTH, RR_DEPTH, LIGHT_SELECTION],
    build: |p: &Params| {
        Box::new(VolPath {
            max_depth: p.get_depth("max-depth"),
            rr_depth: p.get_u32("rr-depth"),
            lights: p.get_light_selection(),
        })
    },
    analytic: Some(Analytic {
        params: &[],
        furnace: expect(2.0, 40, 500),
        point_in_sphere: expect(1.0, 40, 500),
        sphere_under_sky: expect(1.2, 40, 500),
    }),
    media: MediaSupport::Full,
    spectral: SpectralSupport::PerSample,
};

/// Scattering events after which Russian roulette plays even on a path that loses nothing.
pub(crate) const LONG_PATH: u32 = 1024;

pub(crate) struct VolPath {
    pub(crate) max_depth: u32,
    pub(crate) rr_depth: u32,
    /// How light samples pick a light (`None`: the scene's choice).
    pub(crate) lights: Option<LightSelection>,
}

/// The path's state between segments.
struct Walk {
    /// Throughput over the hero channel's path density.
    beta: Spectrum,
    /// Each channel's density of the path as sampled (unidirectionally), over the hero's.
    r_u: Spectrum,
    /// Each channel's density of the path up to the last scattering point, with light
    /// sampling's density of the rest (completed where an emitter is found), over the hero's.
    r_l: Spectrum,
    /// Scattering events so far (surface or medium).
    depth: u32,
    /// Whether the last scattering was a Dirac delta (or there was none yet).
    specular: bool,
    /// Product of eta^2 over the refractions (roulette plays without their compression).
    eta_scale: f32,
    /// The last scattering point and its geometric normal (zero in a medium), for the light
    /// density of emitters the path finds.
    from: LightContext,
    /// The lanes of its spectra that hold values (`Wavelengths::lanes`).
    lanes: usize,
}

/// Where a light sample is taken.
enum Vertex<'s, 'a> {
    Surface(&'s ShadingPoint<'a>),
    Medium { p: Vec3A, wo: Vec3A, phase: Phase },
}

impl RayIntegrator for VolPath {
    fn radiance(
        &self,
        camera_ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        let scene: &dyn Scene = tracer.scene;
        let hero = hero_channel(sampler.next_1d(), lambda);
        let mut ray = Ray {
            medium: scene.camera_medium(),
            ..*camera_ray
        };
        let mut w = Walk {
            beta: Spectrum::ONE,
            r_u: Spectrum::ONE,
            r_l: Spectrum::ONE,
            depth: 0,
            specular: true,
            eta_scale: 1.0,
            from: LightContext {
                p: ray.origin,
                n: Vec3A::ZERO,
            },
            lanes: lambda.lanes(),
        };
        let mut l = Spectrum::ZERO;
        let mut first = true;
        loop {
            let hit = if first {
                tracer.camera(&ray)
            } else {
                tracer.extend(&ray)
            };
            first = false;

            // The medium the ray travels in, up to the surface.
            if let Some(medium) = scene.medium(ray.medium) {
                let tmax = hit.map_or(f32::INFINITY, |h| h.t);
                let phase = medium.phase();
                let (mut scattered, mut terminated) = (None, false);
                let emissive = medium.is_emissive();
                let t_maj =
                    sample_t_maj(medium, &ray, tmax, hero, lambda, sampler, |c, sampler| {
                        let pt = &c.point;
                        if emissive && w.depth <= self.max_depth {
                            // Emission, by the collision estimator.
                            let pdf = c.sigma_maj[hero] * c.t_maj[hero];
                            let r_e = w.r_u * c.sigma_maj * c.t_maj / pdf;
                            if r_e != Spectrum::ZERO {
                                let beta = w.beta * c.t_maj / pdf;
                                l += beta * pt.sigma_a * pt.le / lambda.average(r_e);
                            }
                        }
                        // Real (absorption or scattering) or null, by the hero's share of the
                        // majorant; a real collision scatters with weight albedo (absorption is
                        // left to the roulette, which is kinder to a dark channel than ending
                        // every absorbed path).
                        let sigma_t = pt.sigma_a + pt.sigma_s;
                        if sampler.next_1d() < sigma_t[hero] / c.sigma_maj[hero] {
                            if w.depth >= self.max_depth {
                                terminated = true;
                                return false;
                            }
                            w.depth += 1;
                            let pdf = c.t_maj[hero] * sigma_t[hero];
                            w.beta *= c.t_maj * pt.sigma_s / pdf;
                            w.r_u *= c.t_maj * sigma_t / pdf;
                            if !(w.beta.is_finite()
                                && w.beta != Spectrum::ZERO
                                && w.r_u != Spectrum::ZERO)
                            {
                                terminated = true;
                                return false;
                            }
                            let wo = -ray.dir;
                            let vertex = Vertex::Medium { p: c.p, wo, phase };
                            l += self.light_sample(
                                &vertex, ray.medium, &w, hero, tracer, sampler, lambda,
                            );
                            let ps = phase.sample(wo, sampler.next_2d());
                            if !positive(ps.pdf) {
                                terminated = true;
                                return false;
                            }
                            w.beta *= ps.p / ps.pdf;
                            w.r_l = w.r_u / ps.pdf;
                            w.specular = false;
                            w.from = LightContext {
                                p: c.p,
                                n: Vec3A::ZERO,
                            };
                            scattered = Some(Ray {
                                origin: c.p,
                                dir: ps.wi,
                                tmax: f32::INFINITY,
                                medium: ray.medium,
                            });
                            return false;
                        }
                        // A null collision: on along the ray.
                        let sigma_n = (c.sigma_maj - pt.sigma_a - pt.sigma_s).max(Spectrum::ZERO);
                        let pdf = c.t_maj[hero] * sigma_n[hero];
                        if !positive(pdf) {
                            w.beta = Spectrum::ZERO;
                            return false;
                        }
                        w.beta *= c.t_maj * sigma_n / pdf;
                        w.r_u *= c.t_maj * sigma_n / pdf;
                        w.r_l *= c.t_maj * c.sigma_maj / pdf;
                        w.beta.is_finite() && w.beta != Spectrum::ZERO && w.r_u != Spectrum::ZERO
                    });
                if terminated
                    || !w.beta.is_finite()
                    || w.beta == Spectrum::ZERO
                    || w.r_u == Spectrum::ZERO
                {
                    break;
                }
                if let Some(next) = scattered {
                    ray = next;
                    if !self.roulette(&mut w, sampler) {
                        break;
                    }
                    continue;
                }
                let end = t_maj[hero];
                if !positive(end) {
                    break;
                }
                w.beta *= t_maj / end;
                w.r_u *= t_maj / end;
                w.r_l *= t_maj / end;
            }

            // The surface the ray reaches, or the environment.
            let Some(hit) = hit else {
                let le = escaped(scene, &ray, lambda);
                if le != Spectrum::ZERO {
                    l += self.found_emission(&w, scene, &ray, None, le);
                }
                break;
            };
            if hit.light.is_some() {
                let le = emitted_at(scene, &hit, &ray, lambda);
                if le != Spectrum::ZERO {
                    l += self.found_emission(&w, scene, &ray, Some(&hit), le);
                }
            }
            let sp = ShadingPoint::new(&hit, ray.dir, scene, lambda);
            if w.depth < self.max_depth && !sp.material.is_specular() {
                l += self.light_sample(
                    &Vertex::Surface(&sp),
                    ray.medium,
                    &w,
                    hero,
                    tracer,
                    sampler,
                    lambda,
                );
            }
            let u_lobe = sampler.next_1d();
            let Some(s) = sp.sample(u_lobe, sampler.next_2d(), TransportMode::Radiance) else {
                break;
            };
            if s.bsdf.is_straight_through(sp.wo) {
                // A crossing, not a scattering event: on in the same direction.
                w.beta = s.throughput(w.beta);
                ray = hit.spawn_ray(ray.dir);
                continue;
            }
            if w.depth >= self.max_depth {
                break;
            }
            w.depth += 1;
            w.beta = s.throughput(w.beta);
            if !(w.beta.is_finite() && w.beta != Spectrum::ZERO) {
                break;
            }
            w.specular = s.bsdf.specular;
            if !s.bsdf.specular {
                w.r_l = w.r_u / s.bsdf.pdf;
            }
            w.eta_scale *= s.bsdf.eta * s.bsdf.eta;
            w.from = LightContext {
                p: hit.p,
                n: hit.ng,
            };
            ray = hit.spawn_ray(s.wi);
            if !self.roulette(&mut w, sampler) {
                break;
            }
        }
        l
    }
}

impl VolPath {
    /// Russian roulette from `rr-depth` scattering events on, on the throughput without
    /// refraction's compression (pbrt-v4's `rrBeta`): a path whose throughput is below 1
    /// survives with that probability. One that keeps a throughput of 1 (scattering without
    /// absorption, as in a white fog) is not played on until [`LONG_PATH`] events, then with
    /// the survival capped as every other integrator's, so that every path ends: the cap
    /// would multiply such a path's weight at each of its thousands of scattering events.
    /// False ends the path.
    fn roulette(&self, w: &mut Walk, sampler: &mut Sampler) -> bool {
        if w.depth < self.rr_depth {
            return true;
        }
        let rr = (w.beta * w.eta_scale / average(w.r_u, w.lanes)).max_element();
        let survive = if rr < 1.0 {
            rr
        } else if w.depth >= LONG_PATH {
            crate::integrator::MAX_SURVIVAL
        } else {
            return true;
        };
        if sampler.next_1d() < survive {
            w.beta /= survive;
            true
        } else {
            false
        }
    }

    /// Emission `le` the walk's ray finds at `hit` (or escaping), weighted against the light
    /// sample of the last scattering point.
    fn found_emission(
        &self,
        w: &Walk,
        scene: &dyn Scene,
        ray: &Ray,
        hit: Option<&Hit>,
        le: Spectrum,
    ) -> Spectrum {
        if w.depth == 0 || w.specular {
            return w.beta * le / average(w.r_u, w.lanes);
        }
        let lights = scene.lights();
        let light_pdf = match hit {
            Some(h) => h.light.map_or(0.0, |i| {
                lights.pmf_for(self.lights, &w.from, i)
                    * lights.get(i).pdf_li(w.from.p, ray.dir, h.p)
            }),
            None => lights.environment().map_or(0.0, |i| {
                lights.pmf_for(self.lights, &w.from, i)
                    * lights.get(i).pdf_li(w.from.p, ray.dir, w.from.p)
            }),
        };
        let r_l = w.r_l * light_pdf;
        w.beta * le / average(w.r_u + r_l, w.lanes)
    }

    /// One light sample at `vertex` (in `medium` for a medium vertex), its shadow ray through
    /// media and crossable surfaces, weighted against the path's own sampling.
    #[allow(clippy::too_many_arguments)]
    fn light_sample(
        &self,
        vertex: &Vertex,
        medium: MediumId,
        w: &Walk,
        hero: usize,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &Wavelengths,
    ) -> Spectrum {
        let scene: &dyn Scene = tracer.scene;
        let u_light = sampler.next_1d();
        let u = sampler.next_2d();
        let ctx = match vertex {
            Vertex::Surface(sp) => sp.light_context(),
            Vertex::Medium { p, .. } => LightContext {
                p: *p,
                n: Vec3A::ZERO,
            },
        };
        let Some((index, pmf)) = scene.lights().sample_for(self.lights, &ctx, u_light) else {
            return Spectrum::ZERO;
        };
        let light = scene.lights().get(index);
        let (ls, f, scatter_pdf, mut ray) = match vertex {
            Vertex::Surface(sp) => {
                let Some((ls, ray)) = light_at_surface(sp, index, u, scene) else {
                    return Spectrum::ZERO;
                };
                let wi = sp.frame.to_local(ls.wi);
                let (f, pdf) = sp.material.eval_pdf(sp.wo, wi);
                (ls, f * wi.z.abs(), pdf, ray)
            }
            Vertex::Medium { p, wo, phase } => {
                let Some(ls) = light.sample_li(*p, u, lambda) else {
                    return Spectrum::ZERO;
                };
                let value = phase.eval(*wo, ls.wi);
                (
                    ls,
                    Spectrum::splat(value),
                    value,
                    ray_from_point(*p, &ls, medium),
                )
            }
        };
        if !positive(ls.pdf) || ls.radiance == Spectrum::ZERO || f == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let Some((t_ray, r_u, r_l)) =
            shadow_transmittance(&mut ray, &ls, hero, tracer, sampler, lambda)
        else {
            return Spectrum::ZERO;
        };
        let light_pdf = pmf * ls.pdf;
        let r_l = r_l * w.r_u * light_pdf;
        let r_u = r_u * w.r_u * scatter_pdf;
        let denom = if ls.delta {
            lambda.average(r_l)
        } else {
            lambda.average(r_l + r_u)
        };
        if !positive(denom) {
            return Spectrum::ZERO;
        }
        w.beta * f * t_ray * ls.radiance / denom
    }
}

/// The transmittance along a shadow ray towards light sample `ls`, through media (ratio
/// tracking at the hero's rate) and the surfaces it can cross (index-matched boundaries, a
/// mask's null event, a thin dielectric), with the channels' densities of the unidirectional
/// and light strategies along it (pbrt-v4's `T_ray`, `r_u`, `r_l`). `None`: blocked.
fn shadow_transmittance(
    ray: &mut Ray,
    ls: &LightSample,
    hero: usize,
    tracer: &mut Tracer,
    sampler: &mut Sampler,
    lambda: &Wavelengths,
) -> Option<(Spectrum, Spectrum, Spectrum)> {
    let scene: &dyn Scene = tracer.scene;
    let (mut t_ray, mut r_u, mut r_l) = (Spectrum::ONE, Spectrum::ONE, Spectrum::ONE);
    loop {
        tracer.counters.shadow += 1;
        let hit = scene.intersect(ray);
        let crossing = match &hit {
            Some(h) => {
                // Most surfaces block outright, unshaded.
                if !scene.material(h.material).may_pass_straight() {
                    return None;
                }
                // (A shadow ray changes nothing of the path's wavelengths.)
                let sp = ShadingPoint::new(h, ray.dir, scene, &mut { *lambda });
                let pass = sp.material.null_transmission(sp.wo);
                if pass == Spectrum::ZERO {
                    return None;
                }
                pass
            }
            None => Spectrum::ONE,
        };
        if let Some(medium) = scene.medium(ray.medium) {
            let tmax = hit.map_or(ray.tmax, |h| h.t);
            let t_maj = sample_t_maj(medium, ray, tmax, hero, lambda, sampler, |c, sampler| {
                let pt = &c.point;
                let sigma_n = (c.sigma_maj - pt.sigma_a - pt.sigma_s).max(Spectrum::ZERO);
                let pdf = c.t_maj[hero] * c.sigma_maj[hero];
                t_ray *= c.t_maj * sigma_n / pdf;
                r_l *= c.t_maj * c.sigma_maj / pdf;
                r_u *= c.t_maj * sigma_n / pdf;
                // Roulette where little is left, so that dense media end shadow rays early.
                let left = t_ray / lambda.average(r_l + r_u);
                if left.max_element() < 0.05 {
                    if sampler.next_1d() < 0.75 {
                        t_ray = Spectrum::ZERO;
                    } else {
                        t_ray /= 0.25;
                    }
                }
                t_ray != Spectrum::ZERO && t_ray.is_finite()
            });
            let end = t_maj[hero];
            if !positive(end) || t_ray == Spectrum::ZERO || !t_ray.is_finite() {
                return None;
            }
            t_ray *= t_maj / end;
            r_l *= t_maj / end;
            r_u *= t_maj / end;
        }
        if t_ray == Spectrum::ZERO {
            return None;
        }
        let Some(h) = hit else {
            return Some((t_ray, r_u, r_l));
        };
        t_ray *= crossing;
        *ray = if ls.dist.is_finite() {
            h.spawn_ray_to(ls.point)
        } else {
            h.spawn_ray(ray.dir)
        };
    }
}
