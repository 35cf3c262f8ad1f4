//! The Metropolis driver `pssmlt` and `mmlt` share (Kelemen et al. 2002; Veach's thesis,
//! chapter 11; pbrt-v4's `MLTIntegrator`): a bootstrap that estimates the image's
//! brightness, then Markov chains in primary sample space whose visits, weighted by the
//! expected-value trick, are splatted where their paths land.
//!
//! **Per pass, from nothing.** Each pass runs its own bootstrap and its own chains, seeded by
//! (seed, pass, chain), so a pass depends only on its number: images are bit-identical at any
//! thread count, across checkpoint and resume and across shards by passes. The number of
//! chains and their lengths come from the parameters and the image size, never from the
//! thread count.
//!
//! **Unbiased per pass.** A chain starts from a bootstrap sample chosen in proportion to its
//! luminance (resampling), and the pass's image is scaled by the bootstrap's mean luminance
//! `b`: the expectation of `b` times any function of a state so chosen is the function's
//! integral against the path contribution, and the chain's steps keep that distribution, so
//! every pass is an unbiased estimate of the image (no start-up bias to wait for). Within a
//! pass, a chain's visits are correlated: short chains explore little, long chains cost
//! parallelism.

use crate::integrator::{ChainContext, Work};
use crate::integrator::{Demand, Integrator, RayCounters, Splats, Stop, Tracer};
use crate::mlt::PrimarySamples;
use crate::random::{keyed_rng, unit_f32};
use crate::registry::{ParamKind, ParamSpec, Params};
use crate::spectrum::Wavelengths;
use crate::{luminance, Camera, Rgb, Sampler, Scene, Spectrum};
use crate::{PassContext, SampleContext};
use glam::Vec2;
use rayon::prelude::*;

/// What a Metropolis integrator explores: points of primary sample space, each a path whose
/// radiance lands at a film position. Paths are grouped into classes that chains never leave
/// (path depths for `mmlt`), each with its own bootstrap samples.
pub trait PathSpace: Send + Sync {
    /// Streams the numbers of a state are split into.
    fn streams(&self) -> u32;

    /// Classes of paths (1 when chains may go anywhere).
    fn classes(&self) -> u32;

    /// Whether its paths join points to the lens (only a pinhole camera can).
    fn needs_pinhole(&self) -> bool {
        false
    }

    /// The radiance of the path that the sampler's numbers make in `class`, as linear sRGB,
    /// and the film position (pixels) it lands at. With `spectral`, the path carries
    /// wavelengths drawn from the same numbers.
    fn evaluate(
        &self,
        class: u32,
        camera: &Camera,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        spectral: bool,
    ) -> (Rgb, Vec2);
}

/// The parameters every Metropolis integrator takes.
pub const PARAMS: [ParamSpec; 5] = [
    ParamSpec {
        name: "bootstrap",
        kind: ParamKind::Int,
        default: 0.0,
        min: 0.0,
        max: 1e9,
        doc: "bootstrap samples per pass (per path depth for mmlt) for the normalisation and the chains' starts; 0: a quarter of the pixel count in all (at least 16 per depth)",
    },
    ParamSpec {
        name: "chains",
        kind: ParamKind::Int,
        default: 8.0,
        min: 1.0,
        max: 1e7,
        doc: "Markov chains per pass (at most one per pixel); longer chains explore better, more run in parallel",
    },
    ParamSpec {
        name: "mutations-per-pixel",
        kind: ParamKind::Float,
        default: 4.0,
        min: 1e-3,
        max: 1e6,
        doc: "mutations per pixel in each pass, shared out between the chains",
    },
    ParamSpec {
        name: "large-step-probability",
        kind: ParamKind::Float,
        default: 0.3,
        min: 0.0,
        max: 1.0,
        doc: "probability that a mutation draws every number afresh",
    },
    ParamSpec {
        name: "sigma",
        kind: ParamKind::Float,
        default: 0.01,
        min: 1e-6,
        max: 1.0,
        doc: "standard deviation of a small step in primary sample space",
    },
];

/// Salts that keep the bootstrap's and the chains' generators apart.
const BOOTSTRAP_SALT: u64 = 0x42_4f4f_5453;
const CHAIN_SALT: u64 = 0x43_4841_494e;
/// Bootstrap samples per parallel work unit (one sampler each).
const BOOTSTRAP_CHUNK: usize = 256;
/// Memory of one splat: a film position and a colour.
const SPLAT_BYTES: usize = std::mem::size_of::<(Vec2, Rgb)>();
/// Mutations between checks of a stop request.
const STOP_CHECK: u32 = 256;

/// A Metropolis integrator over a path space.
pub struct Metropolis<S> {
    pub space: S,
    bootstrap: u32,
    chains: u32,
    mutations_per_pixel: f64,
    large_step_probability: f32,
    sigma: f32,
    /// This pass's bootstrap: the running sums of its samples' luminances (one list over
    /// every class, sample `i` of class `i % classes`), and the key its samples came from.
    cdf: Vec<f64>,
    key: u64,
    /// Whether paths carry sampled wavelengths (the render's mode, learnt before each pass).
    spectral: bool,
}

impl<S: PathSpace> Metropolis<S> {
    pub fn new(space: S, p: &Params) -> Self {
        Metropolis {
            space,
            bootstrap: p.get_u32("bootstrap"),
            chains: p.get_u32("chains"),
            mutations_per_pixel: p.get("mutations-per-pixel"),
            large_step_probability: p.get("large-step-probability") as f32,
            sigma: p.get("sigma") as f32,
            cdf: Vec::new(),
            key: 0,
            spectral: false,
        }
    }

    fn fresh_state(&self, rng: rand::rngs::SmallRng) -> Sampler {
        Sampler::primary(PrimarySamples::new(
            rng,
            self.sigma,
            self.large_step_probability,
            self.space.streams(),
        ))
    }

    /// The bootstrap of the pass: every sample's luminance, summed in order. The samples run
    /// in parallel in fixed chunks, so the sums do not depend on the thread count.
    fn bootstrap_pass(
        &mut self,
        scene: &dyn Scene,
        camera: &Camera,
        seed: u64,
        pass: u32,
        stop: Stop,
    ) -> RayCounters {
        self.key = seed ^ (pass as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let classes = self.space.classes();
        let n = self.bootstrap_samples(camera) as usize * classes as usize;
        let mut weights = vec![0.0f64; n];
        let key = self.key ^ BOOTSTRAP_SALT;
        let counters = weights
            .par_chunks_mut(BOOTSTRAP_CHUNK)
            .enumerate()
            .map(|(chunk, out)| {
                let mut tracer = Tracer::with_stop(scene, stop);
                let mut sampler = self.fresh_state(keyed_rng(key, 0));
                for (k, w) in out.iter_mut().enumerate() {
                    if tracer.stop.requested() {
                        break;
                    }
                    let i = chunk * BOOTSTRAP_CHUNK + k;
                    if let Some(p) = sampler.primary_samples() {
                        p.restart(keyed_rng(key, i as u64));
                    }
                    let class = i as u32 % classes;
                    let (l, _) = self.space.evaluate(
                        class,
                        camera,
                        &mut tracer,
                        &mut sampler,
                        self.spectral,
                    );
                    let y = luminance(l) as f64;
                    *w = if y.is_finite() && y > 0.0 { y } else { 0.0 };
                }
                tracer.counters
            })
            .reduce(RayCounters::default, |mut a, b| {
                a.add(&b);
                a
            });
        let mut total = 0.0f64;
        for w in &mut weights {
            total += *w;
            *w = total;
        }
        self.cdf = weights;
        counters
    }

    /// Bootstrap samples per pass (per class) for `camera`'s image.
    fn bootstrap_samples(&self, camera: &Camera) -> u64 {
        match self.bootstrap {
            0 => (camera.width as u64 * camera.height as u64 / 4 / self.space.classes() as u64)
                .max(16),
            n => n as u64,
        }
    }

    /// The bootstrap's estimate of the image's mean luminance, `b`.
    fn normalisation(&self, camera: &Camera) -> f64 {
        self.cdf.last().copied().unwrap_or(0.0) / self.bootstrap_samples(camera) as f64
    }

    /// The chains of a pass: as many as asked, at most one per pixel.
    fn chain_count(&self, camera: &Camera) -> u64 {
        (self.chains as u64).min(camera.width as u64 * camera.height as u64)
    }

    /// Runs chain `chain` of the pass with its share of the pass's mutations, splatting its
    /// visits.
    fn run_chain_of_pass(
        &self,
        chain: u64,
        camera: &Camera,
        tracer: &mut Tracer,
        splats: &mut Splats,
    ) {
        let pixels = camera.width as u64 * camera.height as u64;
        let chains = self.chain_count(camera);
        let b = self.normalisation(camera);
        if chains == 0 || b <= 0.0 || !b.is_finite() {
            return;
        }
        // This chain's share of the pass's mutations.
        let total = (self.mutations_per_pixel * pixels as f64).round().max(1.0) as u64;
        let mutations = (chain + 1) * total / chains - chain * total / chains;
        // Every visit's radiance over its luminance, times b over the mutations per pixel.
        let scale = (b * pixels as f64 / total as f64) as f32;
        self.walk_chain(chain, mutations, scale, camera, tracer, splats);
    }

    /// One chain: its start resampled from the bootstrap, then `mutations` proposals, each
    /// splatting the proposal and the current state weighted by the acceptance probability
    /// (the expected-value trick of Veach's thesis, 11.3.3).
    fn walk_chain(
        &self,
        chain: u64,
        mutations: u64,
        scale: f32,
        camera: &Camera,
        tracer: &mut Tracer,
        splats: &mut Splats,
    ) {
        let classes = self.space.classes() as usize;
        let mut rng = keyed_rng(self.key ^ CHAIN_SALT, chain);
        let total = self.cdf.last().copied().unwrap_or(0.0);
        // The start: a bootstrap sample chosen in proportion to its luminance, re-evaluated.
        let target = unit_f32(&mut rng) as f64 * total;
        let start = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len().saturating_sub(1));
        let class = (start % classes) as u32;
        let mut sampler = self.fresh_state(keyed_rng(self.key ^ BOOTSTRAP_SALT, start as u64));
        let (mut current, mut film) =
            self.space
                .evaluate(class, camera, tracer, &mut sampler, self.spectral);
        let mut y = luminance(current);
        if !(y > 0.0 && y.is_finite()) {
            return;
        }
        let Some(state) = sampler.primary_samples() else {
            return;
        };
        state.reseed(keyed_rng(self.key ^ CHAIN_SALT ^ 1, chain));
        for m in 0..mutations {
            if m % STOP_CHECK as u64 == 0 && tracer.stop.requested() {
                return;
            }
            // Propose.
            if let Some(state) = sampler.primary_samples() {
                state.start_iteration();
            }
            let (proposed, proposed_film) =
                self.space
                    .evaluate(class, camera, tracer, &mut sampler, self.spectral);
            let py = luminance(proposed);
            let py = if py.is_finite() && proposed.is_finite() {
                py.max(0.0)
            } else {
                0.0
            };
            // Splat both, by the probability of each being the next state.
            let accept = (py / y).min(1.0);
            if accept > 0.0 {
                splats.add(
                    proposed_film,
                    crate::spectrum::of_rgb(proposed * (accept * scale / py)),
                    &Wavelengths::Rgb,
                );
            }
            if accept < 1.0 {
                splats.add(
                    film,
                    crate::spectrum::of_rgb(current * ((1.0 - accept) * scale / y)),
                    &Wavelengths::Rgb,
                );
            }
            // Accept or reject.
            let Some(state) = sampler.primary_samples() else {
                return;
            };
            if unit_f32(&mut rng) < accept {
                state.accept();
                (current, film, y) = (proposed, proposed_film, py);
            } else {
                state.reject();
            }
        }
    }
}

impl<S: PathSpace> Integrator for Metropolis<S> {
    /// Never asked: its work is chains ([`Work::Chains`]), and a pixel's own estimate zero.
    fn sample(&self, _cx: SampleContext) -> Spectrum {
        Spectrum::ZERO
    }

    fn work(&self, camera: &Camera) -> Work {
        Work::Chains {
            count: self.chain_count(camera),
        }
    }

    fn run_chain(&self, chain: u64, cx: ChainContext) {
        self.run_chain_of_pass(chain, cx.camera, cx.tracer, cx.splats);
    }

    fn prepare_pass(&mut self, cx: &PassContext) -> RayCounters {
        let PassContext {
            scene,
            camera,
            seed,
            pass,
            stop,
            lambda,
            ..
        } = *cx;
        self.spectral = lambda.is_spectral();
        self.bootstrap_pass(scene, camera, seed, pass, stop)
    }

    fn demand(&self) -> Demand {
        Demand {
            rays_per_sample: 2.0,
            // The bootstrap's running sums.
            memory: self.bootstrap as u64 * self.space.classes() as u64 * 8,
            // A pass's splats (two per mutation, held until the pass adds them in order),
            // and the bootstrap's sums when it is sized by the image.
            memory_per_pixel: (2.0 * self.mutations_per_pixel * SPLAT_BYTES as f64) as u64
                + if self.bootstrap == 0 { 2 } else { 0 },
            pinhole: self.space.needs_pinhole(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::registry::find;
    use crate::testing::furnace_sphere;
    use glam::Vec3A;

    /// A path space with a known image: the film position is the first two numbers, and the
    /// radiance is 4 where the third number is below 1/4 on the image's left half, else 1/2
    /// (left half: 4/4 + 3/4 * 1/2 = 1.375 on average; right half: 1/2).
    struct Steps;

    impl PathSpace for Steps {
        fn streams(&self) -> u32 {
            1
        }
        fn classes(&self) -> u32 {
            1
        }
        fn evaluate(
            &self,
            _class: u32,
            camera: &Camera,
            _tracer: &mut Tracer,
            sampler: &mut Sampler,
            _spectral: bool,
        ) -> (Rgb, Vec2) {
            sampler.start_stream(0);
            let u = sampler.next_2d();
            let bright = u.x < 0.5 && sampler.next_1d() < 0.25;
            let film = Vec2::new(u.x * camera.width as f32, u.y * camera.height as f32);
            (Rgb::splat(if bright { 4.0 } else { 0.5 }), film)
        }
    }

    fn camera() -> Camera {
        Camera::look_at(Vec3A::ZERO, Vec3A::Z, Vec3A::Y, 40.0, (16, 8))
    }

    /// One pass: every pixel's chains run, and the splats' sums on each half of the image
    /// per pixel.
    fn pass(m: &mut Metropolis<Steps>, pass: u32) -> (f64, f64) {
        let scene = furnace_sphere(0.5, 1.0);
        let camera = camera();
        m.prepare_pass(&PassContext {
            scene: &scene,
            camera: &camera,
            seed: 7,
            pass,
            rows: 0..camera.height,
            stop: Stop::NEVER,
            lambda: Wavelengths::Rgb,
        });
        let mut tracer = Tracer::new(&scene);
        let mut splats = Splats::default();
        let Work::Chains { count } = m.work(&camera) else {
            panic!("Metropolis runs chains");
        };
        for chain in 0..count {
            m.run_chain(
                chain,
                ChainContext {
                    camera: &camera,
                    tracer: &mut tracer,
                    splats: &mut splats,
                },
            );
        }
        let half = (camera.width * camera.height / 2) as f64;
        let (mut left, mut right) = (0.0, 0.0);
        for (film, l) in splats.entries() {
            if film.x < camera.width as f32 / 2.0 {
                left += l.y as f64 / half;
            } else {
                right += l.y as f64 / half;
            }
        }
        (left, right)
    }

    fn steps(params: &[(&str, &str)]) -> Metropolis<Steps> {
        let given: Vec<(String, String)> = params
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        let p = find("pssmlt").unwrap().resolve(&given).unwrap();
        Metropolis::new(Steps, &p)
    }

    #[test]
    fn a_pass_splats_exactly_the_bootstrap_normalisation() {
        // Every mutation splats weights adding to one, so the pass's image mean is b.
        let mut m = steps(&[("bootstrap", "300"), ("chains", "5")]);
        let (left, right) = pass(&mut m, 0);
        let b = m.normalisation(&camera());
        let mean = (left + right) / 2.0;
        assert!((mean - b).abs() < 1e-4 * b, "image mean {mean} vs b {b}");
        // b itself estimates the image mean (1.375 + 0.5) / 2.
        assert!((b - 0.9375).abs() < 0.15, "b = {b}");
    }

    #[test]
    fn chains_visit_the_image_in_proportion_to_its_brightness() {
        // Pass means are independent and unbiased: a t-test on each half against the exact
        // values, with short chains and few bootstrap samples (where a start-up bias would
        // show) and with long ones.
        for params in [
            &[("bootstrap", "20"), ("chains", "32")][..],
            &[
                ("bootstrap", "200"),
                ("chains", "2"),
                ("mutations-per-pixel", "4"),
            ],
        ] {
            let mut m = steps(params);
            let passes = 400;
            let halves: Vec<(f64, f64)> = (0..passes).map(|p| pass(&mut m, p)).collect();
            for (side, expected) in [(0, 1.375), (1, 0.5)] {
                let v: Vec<f64> = halves
                    .iter()
                    .map(|h| if side == 0 { h.0 } else { h.1 })
                    .collect();
                let mean = v.iter().sum::<f64>() / passes as f64;
                let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (passes - 1) as f64;
                let se = (var / passes as f64).sqrt();
                assert!(
                    (mean - expected).abs() < 4.0 * se && se < expected / 40.0,
                    "{params:?} half {side}: {mean:.4} +- {se:.4}, expected {expected}"
                );
            }
        }
    }

    #[test]
    fn passes_depend_on_their_number_only() {
        let mut a = steps(&[("bootstrap", "50"), ("chains", "4")]);
        let mut b = steps(&[("bootstrap", "50"), ("chains", "4")]);
        let first = pass(&mut a, 3);
        pass(&mut b, 0);
        assert_eq!(pass(&mut b, 3), first);
        assert_ne!(pass(&mut b, 4), first);
    }
}
