//! `vpl`: instant radiosity (Keller 1997), the many-light method: light paths leave virtual
//! point lights (VPLs) where they scatter, and every camera sample is lit by all of them
//! (Mitsuba 0.6's `vpl`, on the CPU).
//!
//! **Estimates** the rendering equation with indirect light gathered from VPLs. Each pass
//! traces `vpl-paths` light paths (a light chosen in proportion to power, BSDF-sampled in
//! importance mode, Russian roulette from `rr-depth`); every non-specular vertex becomes a
//! VPL carrying the path's power over the path count. A camera ray follows Dirac lobes
//! (mirrors, glass, smooth coatings, each chosen as the material's sampling would) to its
//! first non-specular scattering, takes the emission it sees there, one light sample
//! for direct light, and one shadow ray to each VPL: the two BSDFs, the two cosines and the
//! inverse squared distance. Each pass has fresh VPLs, so passes are independent and the
//! image converges to what the clamped estimator's expectation is.
//!
//! **Parameters**: `max-depth` (unlimited), `rr-depth` (3), `vpl-paths` (light paths per
//! pass, 64), `clamp` (0.1: distances below `clamp` times the scene's radius count as that
//! distance; 0 turns clamping off).
//! **Bias**: the clamp. `1 / d^2` is unbounded where a VPL lies near the point it lights
//! (corners, contact), which shows as bright splotches; clamping removes them and with them
//! the short-range part of indirect light: corners come out darker than `path`'s. With
//! `clamp=0` the estimator is unbiased (and splotchy). Glossy surfaces lit by VPLs show each
//! VPL as a highlight: the method suits diffuse scenes.

use crate::bsdf::{MappedBsdf, TransportMode};
use crate::integrator::{
    emit_from_a_light, emitted_at, escaped, sample_one_light, scene_radius, Demand, PathState,
    RayCounters, RayIntegrator, ShadingPoint, Tracer, MAX_SURVIVAL,
};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, ParamKind, ParamSpec, Params, SpectralSupport,
    MAX_DEPTH, RR_DEPTH,
};
use crate::spectrum::Wavelengths;
use crate::PassContext;
use crate::{Frame, Hit, Ray, Sampler, Scene, Spectrum};
use glam::Vec3A;
use rayon::prelude::*;

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "vpl",
    summary: "instant radiosity (Keller 1997): virtual point lights from light paths, clamped",
    params: &[
        MAX_DEPTH,
        RR_DEPTH,
        ParamSpec {
            name: "vpl-paths",
            kind: ParamKind::Int,
            default: 64.0,
            min: 1.0,
            max: 1e6,
            doc: "light paths per pass, each leaving a VPL at every non-specular vertex",
        },
        ParamSpec {
            name: "clamp",
            kind: ParamKind::Float,
            default: 0.1,
            min: 0.0,
            max: 1.0,
            doc: "distances below clamp x scene radius count as that distance (the bias; 0: none)",
        },
    ],
    build: |p: &Params| {
        Box::new(Vpl {
            max_depth: p.get_depth("max-depth"),
            rr_depth: p.get_u32("rr-depth"),
            paths: p.get_u32("vpl-paths"),
            clamp: p.get("clamp") as f32,
            min_dist2: 0.0,
            lights: Vec::new(),
            lambda: Wavelengths::Rgb,
        })
    },
    analytic: Some(Analytic {
        // Unclamped, the estimator is unbiased; inside a sphere `cos cos / d^2` is constant.
        params: &[("clamp", "0")],
        furnace: expect(2.0, 40, 400),
        point_in_sphere: expect(1.0, 40, 400),
        sphere_under_sky: expect(1.2, 40, 400),
    }),
    media: MediaSupport::None,
    spectral: SpectralSupport::PerPass,
};

struct Vpl {
    max_depth: u32,
    rr_depth: u32,
    paths: u32,
    clamp: f32,
    /// This pass's clamping distance, squared.
    min_dist2: f32,
    /// This pass's VPLs, in the order of their paths.
    lights: Vec<VirtualLight>,
    /// The wavelengths of the pass, which its VPLs and every camera path carry.
    lambda: Wavelengths,
}

/// A light-path vertex kept as a light: the surface, how light arrived, and the power.
struct VirtualLight {
    hit: Hit,
    frame: Frame,
    /// Towards where the light came from (local and world).
    wo: Vec3A,
    wo_world: Vec3A,
    material: MappedBsdf<'static>,
    /// The light path's power at the vertex over the number of paths.
    power: Spectrum,
    /// Scattering events on the light path, this vertex's included.
    depth: u32,
}

/// Salt of the light paths' generators.
const VPL_SALT: u64 = 0x56_504c;

impl Vpl {
    /// One light path's VPLs.
    fn light_path(
        &self,
        scene: &dyn Scene,
        sampler: &mut Sampler,
        out: &mut Vec<VirtualLight>,
    ) -> RayCounters {
        let mut tracer = Tracer::new(scene);
        let mut lambda = self.lambda;
        let lambda = &mut lambda;
        let Some((_, pmf, emission)) = emit_from_a_light(scene, sampler, lambda) else {
            return tracer.counters;
        };
        let emitted = emission.weight / pmf;
        let mut beta = emitted;
        let mut ray = emission.ray;
        let mut depth = 0u32;
        // A VPL at depth d lights paths of d + 1 events at the least.
        while depth < self.max_depth.saturating_sub(1) {
            // Trace the next segment.
            let Some(hit) = tracer.light(&ray) else {
                break;
            };
            depth += 1;
            let sp = ShadingPoint::new(&hit, ray.dir, scene, lambda);
            // Keep the vertex as a light.
            if !sp.material.is_specular() {
                out.push(VirtualLight {
                    hit: sp.hit,
                    frame: sp.frame,
                    wo: sp.wo,
                    wo_world: sp.wo_world,
                    material: sp.material.clone().into_owned(),
                    power: beta / self.paths as f32,
                    depth,
                });
            }
            // Scatter in importance mode, then Russian roulette against the emitted power.
            let Some(s) = sp.sample(
                sampler.next_1d(),
                sampler.next_2d(),
                TransportMode::Importance,
            ) else {
                break;
            };
            beta = s.throughput(beta);
            if !(beta.is_finite() && beta != Spectrum::ZERO) {
                break;
            }
            if depth >= self.rr_depth {
                let survive = (beta.max_element() / emitted.max_element()).min(MAX_SURVIVAL);
                if survive.is_nan() || sampler.next_1d() >= survive {
                    break;
                }
                beta /= survive;
            }
            ray = sp.hit.spawn_ray(s.wi);
        }
        tracer.counters
    }

    /// The light of every VPL that may light `sp` (paths of at most `max-depth` events when
    /// the point is reached after `bounces`): BSDF at the point, BSDF at the VPL, clamped
    /// inverse squared distance, a shadow ray each.
    fn gather(&self, sp: &ShadingPoint, bounces: u32, tracer: &mut Tracer) -> Spectrum {
        let mut l = Spectrum::ZERO;
        for v in &self.lights {
            if bounces.saturating_add(1).saturating_add(v.depth) > self.max_depth {
                continue;
            }
            let to = v.hit.p - sp.hit.p;
            let d2 = to.length_squared();
            if d2.is_nan() || d2 <= 0.0 {
                continue;
            }
            let w = to / d2.sqrt();
            let here = sp.connection_factor(w, TransportMode::Radiance);
            if here == Spectrum::ZERO {
                continue;
            }
            let there = ShadingPoint {
                hit: v.hit,
                frame: v.frame,
                wo: v.wo,
                wo_world: v.wo_world,
                material: v.material.borrowed(),
                lambda: sp.lambda,
            }
            .connection_factor(-w, TransportMode::Importance);
            if there == Spectrum::ZERO {
                continue;
            }
            let c = here * there * v.power / d2.max(self.min_dist2);
            if c.is_finite() && tracer.connected_to(&sp.hit, &v.hit) {
                l += c;
            }
        }
        l
    }
}

impl RayIntegrator for Vpl {
    fn radiance(
        &self,
        camera_ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        // The pass's wavelengths, which the VPLs carry.
        *lambda = self.lambda;
        let mut l = Spectrum::ZERO;
        let mut path = PathState::from_camera(*camera_ray);
        loop {
            // Trace the next segment; what it sees is found only through specular bounces.
            let Some(hit) = path.trace(tracer) else {
                l += path.beta * escaped(tracer.scene, &path.ray, lambda);
                break;
            };
            l += path.beta * emitted_at(tracer.scene, &hit, &path.ray, lambda);
            if path.bounces >= self.max_depth {
                break;
            }
            let sp = ShadingPoint::new(&hit, path.ray.dir, tracer.scene, lambda);
            // A Dirac lobe (a mirror, glass, a smooth coating) is followed, chosen with the
            // probability the material's sampling gives it; the rest of the BSDF gathers.
            let p_delta = sp.material.delta_probability(sp.wo);
            let u_lobe = sampler.next_1d();
            if u_lobe < p_delta {
                if !path.scatter_with_lobe(&sp, u_lobe, self.rr_depth, sampler) {
                    break;
                }
                continue;
            }
            // Direct light by one light sample, indirect light from every VPL.
            let gathered = sample_one_light(&sp, false, None, tracer, sampler)
                + self.gather(&sp, path.bounces, tracer);
            l += path.beta * gathered / (1.0 - p_delta);
            break;
        }
        l
    }

    /// This pass's VPLs: `vpl-paths` light paths traced in parallel, kept in path order.
    fn prepare_pass(&mut self, cx: &PassContext) -> RayCounters {
        let PassContext {
            scene,
            seed,
            pass,
            stop,
            lambda,
            ..
        } = *cx;
        self.lambda = lambda;
        let radius = scene_radius(scene) * self.clamp;
        self.min_dist2 = radius * radius;
        let traced: Vec<(Vec<VirtualLight>, RayCounters)> = (0..self.paths)
            .into_par_iter()
            .map(|i| {
                let mut out = Vec::new();
                if stop.requested() {
                    return (out, RayCounters::default());
                }
                let mut sampler = Sampler::new(seed ^ VPL_SALT, i as u64, pass as u64);
                let counters = self.light_path(scene, &mut sampler, &mut out);
                (out, counters)
            })
            .collect();
        let mut counters = RayCounters::default();
        self.lights.clear();
        for (lights, c) in traced {
            self.lights.extend(lights);
            counters.add(&c);
        }
        counters
    }

    fn demand(&self) -> Demand {
        Demand {
            // A camera ray, a light sample, and a shadow ray per VPL (about two per path).
            rays_per_sample: 2.0 + 2.0 * self.paths as f64,
            memory: self.paths as u64 * 4 * std::mem::size_of::<VirtualLight>() as u64,
            ..Demand::default()
        }
    }
}
