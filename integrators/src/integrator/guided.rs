//! `guided`: path tracing guided by a learned distribution of incident light (Müller, Gross,
//! Novák 2017, "Practical Path Guiding"; its Mitsuba 0.6 plug-in, Open PGL in Cycles).
//!
//! **Estimates** the full rendering equation as `path` does (next-event estimation, MIS,
//! Russian roulette), but at surfaces without Dirac lobes the next direction comes from a
//! one-sample mixture: with probability `bsdf-fraction` the BSDF's sample, otherwise a sample
//! of the SD-tree (`sd_tree.rs`), a spatial binary tree over the scene whose leaves hold
//! quadtrees over directions, learned from where light arrived. The direction's weight is
//! `f |cos|` over the mixture's density, and light samples are MIS-weighted against it. A
//! guide sample pointing into an opaque surface ends the path (its BSDF is zero), as in the
//! authors' implementation. Russian roulette plays on the throughput BSDF sampling would have
//! carried where the guide's density exceeds the BSDF's: a path the guide sends towards
//! bright light has a small `f |cos| / pdf`, and the plain roulette ended most of those and
//! multiplied the survivors' weight (measured under the reflector, 64x48, 128 spp, 8 runs,
//! training as in the guiding test: MSE 2.7e-3 against 3.6e-3, relMSE 0.046 against 0.109).
//!
//! **Training, deterministic.** Before the first pass (and again after a resume: it is a
//! function of the seed and the image), `training-passes` whole passes over the image train
//! the tree: pass `i` traces `2^i` paths per pixel guided by the tree the passes before it
//! built, and records at every guided vertex the indirect radiance its path then found
//! through the direction it took, over that direction's density (emitters hit right after
//! are next-event estimation's). Training paths play Russian roulette only from the 8th
//! scattering event on, so that the vertices deep in the room are learned too. Paths run in
//! parallel, their records are added to the tree in pixel order, and the tree is refined
//! (spatial leaves split past `spatial-threshold * sqrt(2^i)` records, quadtree cells past
//! 1% of their leaf's energy) and frozen for the next pass. Peers train with atomics in
//! whatever order threads arrive; here the tree, and so the image, is the same at any thread
//! count. The rendered passes use the last tree, frozen; the training paths are not in the
//! image (the paper's final image is its last iteration too). Training costs
//! `2^training-passes - 1` paths per pixel, counted in a `--time` budget.
//!
//! **Parameters**: `max-depth` (unlimited), `rr-depth` (3), `training-passes` (4),
//! `bsdf-fraction` (0.5; 1 is plain BSDF sampling, the baseline), `spatial-threshold`
//! (12000, the paper's c), `light-selection` (`scene`, `uniform`, `power` or `bvh`).
//! **Bias**: none (any mixture with the BSDF's share above 0 covers its support);
//! truncation with a finite `max-depth`.

use crate::integrator::{
    emitted_at, escaped, sample_one_light, sample_one_light_against, Demand, PathState,
    RayCounters, RayIntegrator, ShadingPoint, Stop, Tracer,
};
use crate::registry::{
    expect, Analytic, IntegratorEntry, MediaSupport, ParamKind, ParamSpec, Params, SpectralSupport,
    LIGHT_SELECTION, MAX_DEPTH, RR_DEPTH,
};
use crate::sd_tree::{Guide, Record, SdTree};
use crate::spectrum::Wavelengths;
use crate::PassContext;
use crate::{luminance, Camera, Ray, Sampler, Scene, Spectrum};
use arrayvec::ArrayVec;
use glam::{Vec2, Vec3A};
use rayon::prelude::*;

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "guided",
    summary: "practical path guiding (Müller et al. 2017): an SD-tree trained over whole passes, mixed with BSDF sampling",
    params: &[
        MAX_DEPTH,
        RR_DEPTH,
        LIGHT_SELECTION,
        ParamSpec {
            name: "training-passes",
            kind: ParamKind::Int,
            default: 4.0,
            min: 0.0,
            max: 12.0,
            doc: "training passes before rendering, pass i tracing 2^i paths per pixel",
        },
        ParamSpec {
            name: "bsdf-fraction",
            kind: ParamKind::Float,
            default: 0.5,
            min: 0.01,
            max: 1.0,
            doc: "probability of sampling the BSDF rather than the learned distribution",
        },
        ParamSpec {
            name: "spatial-threshold",
            kind: ParamKind::Float,
            default: 12000.0,
            min: 1.0,
            max: 1e9,
            doc: "records a spatial leaf takes before it splits (times sqrt(2^pass))",
        },
    ],
    build: |p: &Params| {
        Box::new(Guided {
            max_depth: p.get_depth("max-depth"),
            rr_depth: p.get_u32("rr-depth"),
            training_passes: p.get_u32("training-passes"),
            bsdf_fraction: p.get("bsdf-fraction") as f32,
            spatial_threshold: p.get("spatial-threshold") as f32,
            lights: p.get_light_selection(),
            tree: None,
        })
    },
    analytic: Some(Analytic {
        params: &[],
        furnace: expect(2.0, 40, 500),
        point_in_sphere: expect(1.0, 40, 500),
        sphere_under_sky: expect(1.2, 40, 500),
    }),
    media: MediaSupport::None,
    spectral: SpectralSupport::PerSample,
};

/// A quadtree cell is split past this share of its leaf's energy (the paper's 1%).
const FLUX_THRESHOLD: f32 = 0.01;
/// Emission that the segment leaving a guided vertex found (`c`, already in the path's sum)
/// is left out of what the vertex records: light sampling finds emitters, and a guide that
/// learned them would spend its samples where next-event estimation already looks, and raise
/// the MIS weight of its own hits (the tree learns indirect light only).
fn leave_to_light_sampling(visits: Option<&mut Visits>, guided_last: bool, c: Spectrum) {
    if let (true, Some(last)) = (guided_last, visits.and_then(|v| v.last_mut())) {
        last.found_before += c;
    }
}

/// Guided vertices a training path records, at the most.
const MAX_RECORDED: usize = 32;
/// Image rows whose training paths run before their records are added to the tree.
const ROWS_PER_BATCH: u32 = 16;
/// Scattering events before a training path plays Russian roulette (at least `rr-depth`).
/// Measured under the reflector (64x48, 128 spp, 8 runs, training as in the guiding test):
/// rouletted from the third event on, the training paths learned a tree whose images had MSE
/// 3.4e-3 (relMSE 0.069) against 2.7e-3 (0.046) from the eighth.
const TRAINING_RR_DEPTH: u32 = 8;
/// Salt of the training paths' generators.
const TRAINING_SALT: u64 = 0x4755_4944_4544;

struct Guided {
    max_depth: u32,
    rr_depth: u32,
    training_passes: u32,
    bsdf_fraction: f32,
    spatial_threshold: f32,
    /// How light samples pick a light (`None`: the scene's choice).
    lights: Option<crate::light::LightSelection>,
    /// The trained tree, frozen (`None` before training).
    tree: Option<SdTree>,
}

/// A guided vertex of a training path: where, which way the path left, with what density,
/// its throughput after leaving, and the radiance the path had found before it left.
struct Visit {
    p: Vec3A,
    wi: Vec3A,
    pdf: f32,
    beta: Spectrum,
    found_before: Spectrum,
}

type Visits = ArrayVec<Visit, MAX_RECORDED>;

impl Guided {
    /// One path from `camera_ray`, guided by `tree` where there is one; with `visits`, its
    /// guided vertices are kept for training.
    fn trace(
        &self,
        tree: Option<&SdTree>,
        camera_ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
        mut visits: Option<&mut Visits>,
    ) -> Spectrum {
        let mut l = Spectrum::ZERO;
        let mut path = PathState::from_camera(*camera_ray).selecting_lights(self.lights);
        // Whether the segment being traced left a guided vertex.
        let mut guided_last = false;
        loop {
            // Trace the next segment.
            let Some(hit) = path.trace(tracer) else {
                // Escaped: environment light, MIS-weighted against the density that chose it.
                let le = escaped(tracer.scene, &path.ray, lambda);
                if le != Spectrum::ZERO {
                    let c = path.beta * le * path.emission_weight(tracer, None);
                    l += c;
                    leave_to_light_sampling(visits.as_deref_mut(), guided_last, c);
                }
                break;
            };
            // Emission found by the sampled direction (or the camera).
            if hit.light.is_some() {
                let le = emitted_at(tracer.scene, &hit, &path.ray, lambda);
                if le != Spectrum::ZERO {
                    let c = path.beta * le * path.emission_weight(tracer, Some(&hit));
                    l += c;
                    leave_to_light_sampling(visits.as_deref_mut(), guided_last, c);
                }
            }
            guided_last = false;
            if path.bounces >= self.max_depth {
                break;
            }
            let sp = ShadingPoint::new(&hit, path.ray.dir, tracer.scene, lambda);
            let guided_here = !sp.material.has_delta_lobe() && self.bsdf_fraction < 1.0;
            let guide = tree.filter(|_| guided_here).and_then(|t| t.at(sp.hit.p));
            let Some(guide) = guide else {
                // Dirac lobes (or no tree): `path`'s step.
                if !sp.material.is_specular() {
                    l += path.beta * sample_one_light(&sp, true, self.lights, tracer, sampler);
                }
                if !path.scatter(&sp, self.rr_depth, sampler) {
                    break;
                }
                continue;
            };
            // Next-event estimation, MIS-weighted against the mixture.
            let mixture = |wi: Vec3A| self.mixture_pdf(guide, &sp, wi);
            l += path.beta
                * sample_one_light_against(&sp, Some(mixture), self.lights, tracer, sampler);
            // The next direction from the mixture: the BSDF's sample or the tree's.
            let (u_pick, u) = (sampler.next_1d(), sampler.next_2d());
            let wi = if u_pick < self.bsdf_fraction {
                let u_lobe = u_pick / self.bsdf_fraction;
                match sp.sample(u_lobe, u, crate::bsdf::TransportMode::Radiance) {
                    Some(s) => s.wi,
                    None => break,
                }
            } else {
                // (A direction into an opaque surface ends the path: its BSDF is zero there.)
                match guide.sample(u) {
                    Some((wi, _)) => wi,
                    None => break,
                }
            };
            let bsdf_pdf = sp.material.pdf(sp.wo, sp.frame.to_local(wi));
            let pdf = self.mix(guide, wi, bsdf_pdf);
            if !path.turn_along(&sp, wi, pdf, bsdf_pdf) {
                break;
            }
            // The vertex records with its throughput before the roulette: what the path
            // finds after it carries the roulette's 1 / q, and a path the roulette ends
            // records nothing found (so the records average the radiance, not q times it).
            if let Some(v) = visits.as_deref_mut() {
                let _ = v.try_push(Visit {
                    p: sp.hit.p,
                    wi,
                    pdf,
                    beta: path.beta,
                    found_before: l,
                });
            }
            // Training paths play the roulette later: records of deep vertices are what
            // the tree learns the room's far corners from.
            let rr_depth = match visits {
                Some(_) => self.rr_depth.max(TRAINING_RR_DEPTH),
                None => self.rr_depth,
            };
            if !path.roulette(rr_depth, sampler) {
                break;
            }
            guided_last = true;
        }
        l
    }

    /// The mixture's density towards `wi` (world) at `sp`.
    fn mixture_pdf(&self, guide: Guide, sp: &ShadingPoint, wi: Vec3A) -> f32 {
        let bsdf = sp.material.pdf(sp.wo, sp.frame.to_local(wi));
        self.mix(guide, wi, bsdf)
    }

    /// The mixture's density towards `wi`, the BSDF's being `bsdf_pdf`.
    fn mix(&self, guide: Guide, wi: Vec3A, bsdf_pdf: f32) -> f32 {
        let a = self.bsdf_fraction;
        a * bsdf_pdf + (1.0 - a) * guide.pdf(wi)
    }

    /// Training: whole passes over `camera`'s image, each guided by the tree the passes
    /// before it built, their records added in pixel order. `None` if stopped.
    fn train(
        &self,
        scene: &dyn Scene,
        camera: &Camera,
        seed: u64,
        stop: Stop,
        counters: &mut RayCounters,
    ) -> Option<SdTree> {
        let (lo, hi) = scene.bounds();
        // The first pass is guided by a uniform distribution (the new tree's).
        let mut gathering = SdTree::new(lo, hi);
        let mut guide = gathering.clone();
        for pass in 0..self.training_passes {
            let paths = 1u64 << pass;
            let mut row = 0;
            while row < camera.height {
                let rows = row..(row + ROWS_PER_BATCH).min(camera.height);
                // The batch's rows in parallel, each row's records in pixel order.
                let traced: Vec<(Vec<Record>, RayCounters)> = rows
                    .into_par_iter()
                    .map(|y| self.train_row(&guide, scene, camera, seed, pass, paths, y, stop))
                    .collect();
                for (records, c) in &traced {
                    gathering.record(records);
                    counters.add(c);
                }
                if stop.requested() {
                    return None;
                }
                row += ROWS_PER_BATCH;
            }
            // Freeze what this pass learned for the next; keep gathering on the refined tree.
            gathering.refine(pass, self.spatial_threshold, FLUX_THRESHOLD);
            guide = gathering.clone();
        }
        Some(guide)
    }

    /// The training paths of one image row and their records.
    #[allow(clippy::too_many_arguments)]
    fn train_row(
        &self,
        guide: &SdTree,
        scene: &dyn Scene,
        camera: &Camera,
        seed: u64,
        pass: u32,
        paths: u64,
        y: u32,
        stop: Stop,
    ) -> (Vec<Record>, RayCounters) {
        let mut tracer = Tracer::with_stop(scene, stop);
        let mut records = Vec::new();
        let mut visits = Visits::new();
        for x in 0..camera.width {
            if tracer.stop.requested() {
                break;
            }
            let pixel = y as u64 * camera.width as u64 + x as u64;
            for k in 0..paths {
                let mut sampler = Sampler::new(seed ^ TRAINING_SALT ^ pass as u64, pixel, k);
                let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                let ray = camera.ray(film.x, film.y);
                visits.clear();
                let l = self.trace(
                    Some(guide),
                    &ray,
                    &mut tracer,
                    &mut sampler,
                    // The guide learns from RGB radiance in either mode.
                    &mut Wavelengths::Rgb,
                    Some(&mut visits),
                );
                // The radiance that arrived through each guided direction: what the path
                // found after it left, over its throughput then, over the direction's density.
                for v in &visits {
                    let lit = v.beta.cmpgt(Spectrum::ZERO);
                    let arrived =
                        Spectrum::select(lit, (l - v.found_before) / v.beta, Spectrum::ZERO);
                    let value = luminance(crate::spectrum::rgb_of(arrived)) / v.pdf;
                    if value.is_finite() && value >= 0.0 {
                        records.push(Record {
                            p: v.p,
                            dir: v.wi,
                            value,
                        });
                    }
                }
            }
        }
        (records, tracer.counters)
    }
}

impl RayIntegrator for Guided {
    fn radiance(
        &self,
        camera_ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        self.trace(
            self.tree.as_ref(),
            camera_ray,
            tracer,
            sampler,
            lambda,
            None,
        )
    }

    /// Trains the tree before the first pass (and the first after a resume).
    fn prepare_pass(&mut self, cx: &PassContext) -> RayCounters {
        let PassContext {
            scene,
            camera,
            seed,
            pass,
            stop,
            ..
        } = *cx;
        let mut counters = RayCounters::default();
        if pass == 0 || self.tree.is_none() {
            self.tree = None;
            if self.training_passes > 0 && self.bsdf_fraction < 1.0 {
                self.tree = self.train(scene, camera, seed, stop, &mut counters);
            }
        }
        counters
    }

    fn demand(&self) -> Demand {
        Demand {
            rays_per_sample: 2.0,
            ..Demand::default()
        }
    }
}
