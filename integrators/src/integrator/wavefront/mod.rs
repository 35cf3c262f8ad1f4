//! `path-wavefront`: `path`'s estimator with the paths of a batch walked together, stage by
//! stage (a wavefront, as Mitsuba 3's LLVM variant and pbrt-v4's GPU integrator walk them),
//! instead of one path after the other.
//!
//! **Estimates** the full rendering equation exactly as `path` does: next-event estimation
//! with one light sample and BSDF sampling at every non-specular hit, both weighted by the
//! power heuristic, Russian roulette from `rr-depth` scattering events on. Each path draws
//! its random numbers in `path`'s order, so with the same sampler the two sample the same
//! paths; the arithmetic of the diffuse kernels differs in rounding (a diffuse sample's weight
//! is the albedo exactly), so the images agree statistically, not bit for bit.
//!
//! **How it walks.** The render loop hands it a tile's camera samples of a pass
//! ([`BatchIntegrator`]); it walks them [`kernels::LANES`] at a time. Each bounce runs
//! over the batch's live paths:
//! 1. traversal: every path's next segment, as one batch ([`crate::Scene::intersect_all`]);
//! 2. surfaces, path by path: emission found (MIS-weighted), escapes, the shading point, the
//!    bounce's random numbers and light sample. Diffuse points (a plain Lambert material)
//!    become rows of [`kernels::DiffuseRows`]; every other material is shaded there by the
//!    scalar code `path` uses, its shadow ray kept for stage 4;
//! 3. the diffuse kernels over the rows: the light samples' BSDF values, MIS weights and
//!    shadow rays ([`kernels::light_samples`]), then cosine sampling, the next rays and
//!    Russian roulette ([`kernels::bsdf_samples`]);
//! 4. every shadow ray of the bounce, as one batch ([`crate::Scene::occluded_all`]);
//! 5. the diffuse rows' paths that go on rejoin the live paths.
//!
//! A path's estimate depends on its own ray, sampler and wavelengths only, never on the
//! other paths of its batch: images are the same at any thread count, across checkpoints and
//! shards, and for a batch of one path ([`RayIntegrator::radiance`]).
//!
//! **`russian-roulette-wavefront`** walks `russian-roulette`'s estimator the same way: the
//! light samples unweighted, emitters reached by BSDF samples counted only after specular
//! bounces (no MIS), the same numbers in the same order as `russian-roulette`.
//!
//! **Parameters**: `max-depth` (default unlimited), `rr-depth` (default 3),
//! `light-selection` (`scene`, `uniform`, `power` or `bvh`), as `path`'s.
//! **Bias**: none with unlimited `max-depth`; truncation otherwise.

mod kernels;

use crate::bsdf::Material;
use crate::integrator::{
    emitted_at, escaped, sample_light, Batch, BatchIntegrator, PathState, RayIntegrator,
    ShadingPoint, Tracer,
};
use crate::light::{LightSample, LightSelection};
use crate::registry::{
    IntegratorEntry, MediaSupport, Params, SpectralSupport, LIGHT_SELECTION, MAX_DEPTH, RR_DEPTH,
};
use crate::spectrum::Wavelengths;
use crate::{Hit, Ray, Sampler, Spectrum};
use glam::{Vec2, Vec3A};
use kernels::{get, set, DiffuseRows, ScatterRows, ShadowRows, LANES};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "path-wavefront",
    summary: "path's estimator, its paths walked together stage by stage, diffuse shading in lane kernels",
    params: &[MAX_DEPTH, RR_DEPTH, LIGHT_SELECTION],
    build: |p: &Params| Box::new(WavefrontPath::new(p, true)),
    // `path`'s estimator: `path`'s analytic expectations.
    analytic: super::path::ENTRY.analytic,
    media: MediaSupport::None,
    spectral: SpectralSupport::PerSample,
};

pub const RUSSIAN_ROULETTE_ENTRY: IntegratorEntry = IntegratorEntry {
    name: "russian-roulette-wavefront",
    summary: "russian-roulette's estimator (no MIS), its paths walked together stage by stage, diffuse shading in lane kernels",
    params: &[RR_DEPTH, MAX_DEPTH, LIGHT_SELECTION],
    build: |p: &Params| Box::new(WavefrontPath::new(p, false)),
    analytic: super::russian_roulette::ENTRY.analytic,
    media: MediaSupport::None,
    spectral: SpectralSupport::PerSample,
};

pub(crate) struct WavefrontPath {
    max_depth: u32,
    rr_depth: u32,
    /// How light samples pick a light (`None`: the scene's choice).
    lights: Option<LightSelection>,
    /// `path`'s estimator (light samples and emitters reached weighted by the power
    /// heuristic), or, without, `russian-roulette`'s.
    mis: bool,
}

/// What the surface stage decided for a path.
enum Next {
    /// The path ended.
    Done,
    /// The scalar code shaded it; it goes on along its new ray.
    GoesOn,
    /// It waits in the diffuse rows.
    Diffuse,
}

/// A diffuse row's random numbers for its BSDF sample and roulette, drawn in `path`'s order
/// (the lobe's number too, which one lobe does not use).
struct Numbers {
    u_bsdf: Vec2,
    u_rr: f32,
    /// Whether Russian roulette plays after this bounce.
    plays: bool,
}

/// A shadow ray waiting for stage 4: the path, the ray, the contribution if unoccluded.
type PendingShadow = (u16, Ray, Spectrum);

/// The per-batch scratch of the walk: on the stack, nothing allocated per path.
struct Scratch {
    lanes: [PathState; LANES],
    live: [u16; LANES],
    /// The rays of a batch traced together, and what they found.
    rays: [Ray; LANES],
    hits: [Option<Hit>; LANES],
    blocked: [bool; LANES],
    pending: [PendingShadow; LANES],
    diffuse: DiffuseRows,
    shadows: ShadowRows,
    scatters: ScatterRows,
}

impl Scratch {
    fn new() -> Box<Scratch> {
        let idle = Ray::new(Vec3A::ZERO, Vec3A::Z);
        Box::new(Scratch {
            lanes: std::array::from_fn(|_| PathState::from_camera(idle)),
            live: [0; LANES],
            rays: [idle; LANES],
            hits: [None; LANES],
            blocked: [false; LANES],
            pending: [(0, idle, Spectrum::ZERO); LANES],
            diffuse: DiffuseRows::new(),
            shadows: ShadowRows::new(),
            scatters: ScatterRows::new(),
        })
    }
}

thread_local! {
    /// Each thread's walk scratch, made once: about 40 kB, too much to build per batch.
    static SCRATCH: std::cell::RefCell<Option<Box<Scratch>>> = const { std::cell::RefCell::new(None) };
}

impl WavefrontPath {
    fn new(p: &Params, mis: bool) -> WavefrontPath {
        WavefrontPath {
            max_depth: p.get_depth("max-depth"),
            rr_depth: p.get_u32("rr-depth"),
            lights: p.get_light_selection(),
            mis,
        }
    }

    /// The weight of emission the path's last segment reached (escaping when `hit` is
    /// `None`): `path`'s MIS weight, or 1 after a specular bounce and 0 otherwise without MIS.
    fn emission_weight(&self, lane: &PathState, tracer: &Tracer, hit: Option<&Hit>) -> f32 {
        match (self.mis, lane.specular) {
            (true, _) => lane.emission_weight(tracer, hit),
            (false, true) => 1.0,
            (false, false) => 0.0,
        }
    }
}

impl RayIntegrator for WavefrontPath {
    /// A batch of one path.
    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        let mut out = [Spectrum::ZERO];
        self.radiance_batch(
            Batch {
                rays: std::slice::from_ref(ray),
                samplers: std::slice::from_mut(sampler),
                lambdas: std::slice::from_mut(lambda),
                out: &mut out,
            },
            tracer,
        );
        out[0]
    }

    fn as_batch(&self) -> Option<&dyn BatchIntegrator> {
        Some(self)
    }
}

impl BatchIntegrator for WavefrontPath {
    fn radiance_batch(&self, batch: Batch, tracer: &mut Tracer) {
        let Batch {
            rays,
            samplers,
            lambdas,
            out,
        } = batch;
        SCRATCH.with(|cell| {
            // A batch inside a batch (nothing does that today) takes a scratch of its own.
            let mut own = None;
            let mut guard = cell.try_borrow_mut().ok();
            let scratch = match guard.as_deref_mut() {
                Some(slot) => slot.get_or_insert_with(Scratch::new),
                None => own.insert(Scratch::new()),
            };
            let chunks = rays
                .chunks(LANES)
                .zip(samplers.chunks_mut(LANES))
                .zip(lambdas.chunks_mut(LANES))
                .zip(out.chunks_mut(LANES));
            for (((rays, samplers), lambdas), out) in chunks {
                self.walk(scratch, rays, samplers, lambdas, out, tracer);
            }
        });
    }
}

impl WavefrontPath {
    /// Walks up to [`LANES`] paths to their ends, adding each one's radiance to `out`.
    fn walk(
        &self,
        w: &mut Scratch,
        rays: &[Ray],
        samplers: &mut [Sampler],
        lambdas: &mut [Wavelengths],
        out: &mut [Spectrum],
        tracer: &mut Tracer,
    ) {
        let mut live = rays.len();
        for (i, ray) in rays.iter().enumerate() {
            w.lanes[i] = PathState::from_camera(*ray).selecting_lights(self.lights);
            w.live[i] = i as u16;
            out[i] = Spectrum::ZERO;
        }
        let mut camera = true;
        while live > 0 {
            // 1. Every live path's next segment, traced as one batch.
            for k in 0..live {
                w.rays[k] = w.lanes[w.live[k] as usize].ray;
            }
            tracer.trace_all(camera, &w.rays[..live], &mut w.hits[..live]);
            camera = false;
            // 2. Surfaces, path by path; the scalar code's shadow rays wait in `shadows`.
            w.diffuse.len = 0;
            let mut shadows = 0;
            let mut next_live = 0;
            for k in 0..live {
                let i = w.live[k] as usize;
                let next = self.surface(
                    tracer,
                    &mut w.lanes[i],
                    w.hits[k].as_ref(),
                    (i as u16, &mut samplers[i], &mut lambdas[i]),
                    &mut out[i],
                    (&mut w.diffuse, &mut w.pending, &mut shadows),
                );
                if let Next::GoesOn = next {
                    // `live` is read up to `k`, written up to `next_live <= k`.
                    w.live[next_live] = i as u16;
                    next_live += 1;
                }
            }
            // 3. The diffuse kernels.
            kernels::light_samples(&w.diffuse, self.mis, &mut w.shadows);
            kernels::bsdf_samples(&w.diffuse, &mut w.scatters);
            // 4. The bounce's shadow rays (at most one per path), traced as one batch.
            let (d, sh) = (&w.diffuse, &w.shadows);
            for m in 0..d.len {
                if get(&sh.live, m) == 0.0 {
                    continue;
                }
                let ray = Ray {
                    tmax: get(&sh.tmax, m),
                    ..Ray::new(
                        Vec3A::new(
                            get(&sh.origin[0], m),
                            get(&sh.origin[1], m),
                            get(&sh.origin[2], m),
                        ),
                        Vec3A::new(get(&sh.dir[0], m), get(&sh.dir[1], m), get(&sh.dir[2], m)),
                    )
                };
                let c = Spectrum::new(
                    get(&sh.contrib[0], m),
                    get(&sh.contrib[1], m),
                    get(&sh.contrib[2], m),
                    get(&sh.contrib[3], m),
                );
                w.pending[shadows] = (d.lane[m], ray, c);
                shadows += 1;
            }
            for (k, (_, ray, _)) in w.pending[..shadows].iter().enumerate() {
                w.rays[k] = *ray;
            }
            tracer.shadows_all(&w.rays[..shadows], &mut w.blocked[..shadows]);
            for (&(i, _, contrib), &blocked) in w.pending[..shadows].iter().zip(&w.blocked) {
                if !blocked {
                    out[i as usize] += contrib;
                }
            }
            // 5. The diffuse paths that go on.
            let s = &w.scatters;
            for m in 0..d.len {
                if get(&s.alive, m) == 0.0 {
                    continue;
                }
                let i = d.lane[m] as usize;
                let lane = &mut w.lanes[i];
                lane.ray = Ray::new(
                    Vec3A::new(
                        get(&s.origin[0], m),
                        get(&s.origin[1], m),
                        get(&s.origin[2], m),
                    ),
                    Vec3A::new(get(&s.dir[0], m), get(&s.dir[1], m), get(&s.dir[2], m)),
                );
                lane.beta = Spectrum::new(
                    get(&s.beta[0], m),
                    get(&s.beta[1], m),
                    get(&s.beta[2], m),
                    get(&s.beta[3], m),
                );
                lane.pdf = get(&s.pdf, m);
                lane.specular = false;
                lane.from = Vec3A::new(get(&d.p[0], m), get(&d.p[1], m), get(&d.p[2], m));
                lane.from_n = Vec3A::new(get(&d.ng[0], m), get(&d.ng[1], m), get(&d.ng[2], m));
                lane.bounces += 1;
                w.live[next_live] = i as u16;
                next_live += 1;
            }
            live = next_live;
        }
    }

    /// Stage 2 for one path: what its segment found, then its shading point, shaded by
    /// `path`'s scalar code or set out as a diffuse row.
    #[allow(clippy::type_complexity)]
    fn surface(
        &self,
        tracer: &Tracer,
        lane: &mut PathState,
        hit: Option<&Hit>,
        (index, sampler, lambda): (u16, &mut Sampler, &mut Wavelengths),
        out: &mut Spectrum,
        (diffuse, pending, n_pending): (&mut DiffuseRows, &mut [PendingShadow], &mut usize),
    ) -> Next {
        let scene = tracer.scene;
        let counts = self.mis || lane.specular;
        let Some(hit) = hit else {
            // Escaped: environment light, MIS-weighted unless seen through specular.
            let le = match counts {
                true => escaped(scene, &lane.ray, lambda),
                false => Spectrum::ZERO,
            };
            if le != Spectrum::ZERO {
                *out += lane.beta * le * self.emission_weight(lane, tracer, None);
            }
            return Next::Done;
        };
        if hit.light.is_some() && counts {
            let le = emitted_at(scene, hit, &lane.ray, lambda);
            if le != Spectrum::ZERO {
                *out += lane.beta * le * self.emission_weight(lane, tracer, Some(hit));
            }
        }
        if lane.bounces >= self.max_depth {
            return Next::Done;
        }
        let sp = ShadingPoint::new(hit, lane.ray.dir, scene, lambda);
        // The bounce's numbers, in `path`'s order: the light sample's, then the BSDF
        // sample's and the roulette's.
        let light = match sp.material.is_specular() {
            true => None,
            false => sample_light(&sp, self.lights, scene, sampler),
        };
        let plain = sp.material.map.is_none() && sp.material.opacity == 1.0;
        if let (Material::Lambert(l), true) = (&*sp.material, plain) {
            let _lobe = sampler.next_1d();
            let u_bsdf = sampler.next_2d();
            let plays = lane.bounces + 1 >= self.rr_depth;
            let u_rr = if plays { sampler.next_1d() } else { 0.0 };
            let numbers = Numbers {
                u_bsdf,
                u_rr,
                plays,
            };
            push_diffuse(diffuse, index, lane, &sp, l.albedo, light, &numbers);
            return Next::Diffuse;
        }
        if let Some((ls, pmf)) = light {
            if let Some(shadow) = shadow_of(&sp, &ls, (pmf * ls.pdf, self.mis), lane.beta) {
                pending[*n_pending] = (index, shadow.0, shadow.1);
                *n_pending += 1;
            }
        }
        match lane.scatter(&sp, self.rr_depth, sampler) {
            true => Next::GoesOn,
            false => Next::Done,
        }
    }
}

/// The shadow ray of light sample `ls` (density `light_pdf`) at `sp` and what it carries if
/// unoccluded: the BSDF's value, weighted by the power heuristic against BSDF sampling with
/// `mis`, times the throughput `beta`; `None` where nothing would arrive.
fn shadow_of(
    sp: &ShadingPoint,
    ls: &LightSample,
    (light_pdf, mis): (f32, bool),
    beta: Spectrum,
) -> Option<(Ray, Spectrum)> {
    let (f, cos, bsdf_pdf) = sp.reflect(ls, mis)?;
    let weight = match ls.delta || !mis {
        true => 1.0,
        false => crate::sampling::power_heuristic(light_pdf, bsdf_pdf),
    };
    let ray = match ls.dist.is_finite() {
        true => sp.hit.spawn_ray_to(ls.point),
        false => sp.hit.spawn_ray(ls.wi),
    };
    Some((ray, beta * (f * ls.radiance * (cos * weight / light_pdf))))
}

/// Sets out a diffuse shading point as a row of the kernels.
fn push_diffuse(
    d: &mut DiffuseRows,
    index: u16,
    lane: &PathState,
    sp: &ShadingPoint,
    albedo: Spectrum,
    light: Option<(LightSample, f32)>,
    n: &Numbers,
) {
    let m = d.len;
    d.len += 1;
    d.lane[m] = index;
    let (hit, frame) = (&sp.hit, &sp.frame);
    for k in 0..3 {
        set(&mut d.p[k], m, hit.p[k]);
        set(&mut d.ng[k], m, hit.ng[k]);
        set(&mut d.s[k], m, frame.s[k]);
        set(&mut d.t[k], m, frame.t[k]);
        set(&mut d.n[k], m, frame.n[k]);
    }
    set(&mut d.eps, m, hit.spawn_epsilon());
    set(&mut d.wo_z, m, sp.wo.z);
    set(&mut d.wo_ng, m, hit.ng.dot(sp.wo_world));
    set(
        &mut d.front_only,
        m,
        if sp.material.one_sided { 1.0 } else { 0.0 },
    );
    for c in 0..4 {
        set(&mut d.albedo[c], m, albedo[c]);
        set(&mut d.beta[c], m, lane.beta[c]);
    }
    set(&mut d.eta_scale, m, lane.roulette_scale());
    set(&mut d.roulette, m, if n.plays { 1.0 } else { 0.0 });
    set(&mut d.u[0], m, n.u_bsdf.x);
    set(&mut d.u[1], m, n.u_bsdf.y);
    set(&mut d.u_rr, m, n.u_rr);
    match light {
        Some((ls, pmf)) => {
            for k in 0..3 {
                set(&mut d.ls_wi[k], m, ls.wi[k]);
                set(&mut d.ls_point[k], m, ls.point[k]);
            }
            for c in 0..4 {
                set(&mut d.ls_le[c], m, ls.radiance[c]);
            }
            set(&mut d.ls_dist, m, ls.dist);
            set(&mut d.ls_pdf, m, pmf * ls.pdf);
            set(&mut d.ls_delta, m, if ls.delta { 1.0 } else { 0.0 });
        }
        None => {
            set(&mut d.ls_pdf, m, 0.0);
            set(&mut d.ls_dist, m, 1.0);
            set(&mut d.ls_delta, m, 0.0);
            for k in 0..3 {
                set(&mut d.ls_wi[k], m, 0.0);
                set(&mut d.ls_point[k], m, 0.0);
            }
            for c in 0..4 {
                set(&mut d.ls_le[c], m, 0.0);
            }
        }
    }
}

#[cfg(test)]
mod tests;
