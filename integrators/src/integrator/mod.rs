//! The integrator interface, ray accounting, helpers shared by integrators, the registry
//! ([`registry`]) and the integrators, one file each.

pub mod registry;
pub mod shading;

mod albedo_view;
pub mod bdpt;
mod bpm;
mod depth_view;
mod direct;
mod fixed_depth;
mod guided;
mod light_tracer;
pub mod media_walk;
mod metropolis;
mod mmlt;
mod normals_view;
mod path;
mod path_state;
mod photon;
mod pssmlt;
mod restir;
mod russian_roulette;
mod sppm;
mod sppm_pixel;
mod vcm;
pub(crate) mod volpath;
mod vpl;
mod wavefront;
mod whitted;

pub use path_state::PathState;
pub use shading::{Scatter, ShadingPoint};

use crate::light::{LightContext, LightSample, LightSelection};
use crate::spectrum::Wavelengths;
use crate::{Camera, Hit, Ray, Rgb, Sampler, Scene, Spectrum};
use glam::Vec2;

/// Rays cast, by kind. Every integrator counts through [`Tracer`], so rays per second are
/// reported the same way for all of them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounters {
    /// Primary rays from the camera.
    pub camera: u64,
    /// Rays that extend or branch a camera path.
    pub extension: u64,
    /// Occlusion tests towards light samples (next-event estimation).
    pub shadow: u64,
    /// Rays that extend a path from a light (photons, light paths).
    pub light: u64,
    /// Occlusion tests between two path vertices (light-path and bidirectional connections).
    pub connection: u64,
}

impl RayCounters {
    pub fn total(&self) -> u64 {
        self.camera + self.extension + self.shadow + self.light + self.connection
    }

    pub fn add(&mut self, other: &RayCounters) {
        self.camera += other.camera;
        self.extension += other.extension;
        self.shadow += other.shadow;
        self.light += other.light;
        self.connection += other.connection;
    }
}

/// A request to abandon the work in progress (Ctrl-C, a spent time budget, new settings in a
/// live session), for long work to check as it goes: photon tracing, branching recursion.
/// Abandoned work is thrown away, never used, so checking it moves no image.
#[derive(Clone, Copy)]
pub struct Stop<'a>(Option<&'a (dyn Fn() -> bool + Sync)>);

impl<'a> Stop<'a> {
    /// Work that is never abandoned.
    pub const NEVER: Stop<'static> = Stop(None);

    /// Abandon when `requested()` returns true.
    pub fn new(requested: &'a (dyn Fn() -> bool + Sync)) -> Stop<'a> {
        Stop(Some(requested))
    }

    /// Whether the work in progress should be abandoned now.
    #[inline]
    pub fn requested(&self) -> bool {
        self.0.is_some_and(|f| f())
    }
}

/// A scene with ray counters: the only way integrators cast rays.
pub struct Tracer<'a> {
    pub scene: &'a dyn Scene,
    pub counters: RayCounters,
    /// Checked by integrators whose samples can take long (see [`Stop`]).
    pub stop: Stop<'a>,
}

impl<'a> Tracer<'a> {
    pub fn new(scene: &'a dyn Scene) -> Self {
        Tracer::with_stop(scene, Stop::NEVER)
    }

    /// A tracer whose users abandon their work when `stop` asks.
    pub fn with_stop(scene: &'a dyn Scene, stop: Stop<'a>) -> Self {
        Tracer {
            scene,
            counters: RayCounters::default(),
            stop,
        }
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

    /// Traces a batch of rays of the same kind (camera rays when `camera`, else extension
    /// rays), into `hits`. Extension rays go to [`Scene::intersect_all`] together; camera
    /// rays, which are coherent, one by one, the faster way for them on a large tree.
    #[inline]
    pub fn trace_all(&mut self, camera: bool, rays: &[Ray], hits: &mut [Option<Hit>]) {
        match camera {
            true => {
                self.counters.camera += rays.len() as u64;
                for (ray, hit) in rays.iter().zip(hits) {
                    *hit = self.scene.intersect(ray);
                }
            }
            false => {
                self.counters.extension += rays.len() as u64;
                self.scene.intersect_all(rays, hits);
            }
        }
    }

    /// Casts a batch of shadow rays towards light samples; `blocked[k]` says whether
    /// something lies on `rays[k]`.
    #[inline]
    pub fn shadows_all(&mut self, rays: &[Ray], blocked: &mut [bool]) {
        self.counters.shadow += rays.len() as u64;
        self.scene.occluded_all(rays, blocked);
    }

    /// Traces a ray that extends a path from a light (a photon, a light path).
    #[inline]
    pub fn light(&mut self, ray: &Ray) -> Option<Hit> {
        self.counters.light += 1;
        self.scene.intersect(ray)
    }

    /// True if nothing blocks the segment from the surface at `hit` to the point `to` (a
    /// connection between two path vertices, or from a vertex to the lens).
    #[inline]
    pub fn connected(&mut self, hit: &Hit, to: glam::Vec3A) -> bool {
        self.counters.connection += 1;
        !self.scene.occluded(&hit.spawn_ray_to(to))
    }

    /// True if nothing blocks the segment between the surfaces at `hit` and `to` (a
    /// connection between two path vertices: [`Hit::spawn_ray_between`]).
    #[inline]
    pub fn connected_to(&mut self, hit: &Hit, to: &Hit) -> bool {
        self.counters.connection += 1;
        !self.scene.occluded(&hit.spawn_ray_between(to))
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

/// Where a camera sample lands: its pixel, its position on the film (pixels, `(0, 0)` the
/// top-left corner of the image) and its number within the pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelSample {
    pub x: u32,
    pub y: u32,
    pub film: Vec2,
    pub index: u32,
}

/// What one camera sample works with: where it lands, the camera, the tracer it casts rays
/// through (which counts them), its own random numbers, the splats of its work unit and the
/// wavelengths it carries (the estimate it returns is a [`Spectrum`] at them, which the
/// render loop turns into RGB with what they are at the end: a dispersive surface may leave
/// only the hero). The render loop makes one per sample; an integrator takes what it needs.
pub struct SampleContext<'s, 'a> {
    pub pixel: &'s PixelSample,
    pub camera: &'s Camera,
    pub tracer: &'s mut Tracer<'a>,
    pub sampler: &'s mut Sampler,
    pub splats: &'s mut Splats,
    pub lambda: &'s mut Wavelengths,
}

/// What the work before a pass sees ([`Integrator::prepare_pass`]): the scene and camera,
/// the render's seed, the number of the pass, the image rows this run renders (all of them,
/// or a shard's band with the rows its filter reaches), the request to abandon it, and the
/// wavelengths of the pass: in spectral mode, the integrators that share light paths between
/// pixels (photon maps, VCM's merging) trace every path of a pass at these (pbrt-v4's SPPM
/// does the same), so that photons and the camera paths that gather them agree.
#[derive(Clone)]
pub struct PassContext<'a> {
    pub scene: &'a dyn Scene,
    pub camera: &'a Camera,
    pub seed: u64,
    pub pass: u32,
    pub rows: std::ops::Range<u32>,
    pub stop: Stop<'a>,
    pub lambda: Wavelengths,
}

/// What one Markov chain's run works with ([`Integrator::run_chain`]): the camera, the
/// tracer, and the splats of the work unit it runs in. (In spectral mode each proposal draws
/// its wavelengths from its primary samples; the chains learn the mode before the pass.)
pub struct ChainContext<'s, 'a> {
    pub camera: &'s Camera,
    pub tracer: &'s mut Tracer<'a>,
    pub splats: &'s mut Splats,
}

/// The unit of work an integrator takes from the render loop, each pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Work {
    /// One camera sample per pixel, independent of the pass before ([`Integrator::sample`]).
    PixelSamples,
    /// One camera sample per pixel from state it keeps per pixel across passes (`sppm-pixel`):
    /// shards split it by rows, each keeping the state of its own.
    PixelState,
    /// `count` Markov chains per pass ([`Integrator::run_chain`]), whose visits are splats;
    /// the pixels' own estimates are zero. The loop runs chain `c` in the work unit of pixel
    /// `c * P / count` of the image's `P`, so their splats are added in a fixed order.
    Chains { count: u64 },
}

impl Work {
    /// How a render with this work splits into shards.
    pub fn shard_by(self) -> ShardBy {
        match self {
            Work::PixelState => ShardBy::Rows,
            Work::PixelSamples | Work::Chains { .. } => ShardBy::Passes,
        }
    }

    /// The chain whose work unit is pixel `index` of `pixels`, if any (chain `c` at pixel
    /// `c * pixels / count`: distinct pixels, as `count <= pixels`).
    pub fn chain_at(count: u64, index: u64, pixels: u64) -> Option<u64> {
        let count = count.min(pixels);
        if count == 0 {
            return None;
        }
        let chain = (index * count).div_ceil(pixels);
        (chain < count && chain * pixels / count == index).then_some(chain)
    }
}

/// Radiance an integrator adds at film positions of its choosing (light paths that reach the
/// lens), besides the estimate it returns for its own sample. The render loop gathers them
/// per work unit and adds them to the image in a fixed order, so images stay bit-identical at
/// any thread count; they are averaged over passes (divided by the samples per pixel), as
/// pbrt-v4's film does with splats.
///
/// An integrator may also splat into images of its own beside the main one, its layers
/// ([`Integrator::layers`]: `bdpt`'s image per strategy); the render loop keeps one
/// accumulation per declared layer and the command line writes each to a file.
#[derive(Clone, Debug, Default)]
pub struct Splats {
    entries: Vec<(Vec2, Rgb)>,
    layered: Vec<(u32, Vec2, Rgb)>,
}

/// How many splats a [`Splats`] held at some moment, to drop those added since.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplatMark(usize, usize);

impl Splats {
    /// Adds `radiance`, carried at `lambda`, at film position `film` (pixels).
    #[inline]
    pub fn add(&mut self, film: Vec2, radiance: Spectrum, lambda: &Wavelengths) {
        self.entries.push((film, lambda.to_rgb(radiance)));
    }

    /// Adds `radiance`, carried at `lambda`, at film position `film` of layer `layer` (one
    /// the integrator declared).
    #[inline]
    pub fn add_to_layer(
        &mut self,
        layer: u32,
        film: Vec2,
        radiance: Spectrum,
        lambda: &Wavelengths,
    ) {
        self.layered.push((layer, film, lambda.to_rgb(radiance)));
    }

    /// The splats of the main image in the order they were added, as linear sRGB.
    pub fn entries(&self) -> &[(Vec2, Rgb)] {
        &self.entries
    }

    /// The splats of the layers in the order they were added, as linear sRGB.
    pub fn layered_entries(&self) -> &[(u32, Vec2, Rgb)] {
        &self.layered
    }

    /// Whether nothing was splatted.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty() && self.layered.is_empty()
    }

    /// Forgets every splat, keeping the memory for the next work unit.
    pub fn clear(&mut self) {
        self.entries.clear();
        self.layered.clear();
    }

    /// Where the splats stand now (see [`Splats::all_finite_since`], [`Splats::rollback`]).
    pub fn mark(&self) -> SplatMark {
        SplatMark(self.entries.len(), self.layered.len())
    }

    /// True if every splat added since `mark` has a finite position and value.
    pub fn all_finite_since(&self, mark: SplatMark) -> bool {
        self.entries[mark.0..]
            .iter()
            .all(|(p, v)| p.is_finite() && v.is_finite())
            && self.layered[mark.1..]
                .iter()
                .all(|(_, p, v)| p.is_finite() && v.is_finite())
    }

    /// Forgets the splats added since `mark` (those of a sample that is dropped).
    pub fn rollback(&mut self, mark: SplatMark) {
        self.entries.truncate(mark.0);
        self.layered.truncate(mark.1);
    }
}

/// A light-transport algorithm, as the render loop drives it: one call per camera sample
/// (pbrt-v4's `Integrator::EvaluatePixelSample`).
///
/// During a pass an integrator is shared, immutably, between threads; all per-sample state
/// lives in the [`Sampler`], the [`Tracer`] and the [`Splats`]. Between passes the render loop
/// calls [`Integrator::prepare_pass`] with exclusive access, for work shared by every pixel of
/// the pass (photon maps).
///
/// Most integrators estimate the radiance along a camera ray: they implement
/// [`RayIntegrator`], and this trait follows.
pub trait Integrator: Send + Sync {
    /// One camera sample ([`SampleContext`]): the estimate for the film position
    /// `cx.pixel.film` (the film filters it into the pixels around it), and any radiance for
    /// other film positions added to `cx.splats`. May return non-finite values only through bugs; the render loop drops and
    /// counts them.
    fn sample(&self, cx: SampleContext) -> Spectrum;

    /// Called before the pass in which every pixel of `cx.camera`'s image takes sample number
    /// `cx.pass` ([`PassContext`]). Whatever it computes must depend only on the context's
    /// scene, camera, seed and pass,
    /// so that images stay the same
    /// whatever the thread count and across a checkpoint and resume. It may use rayon: the
    /// render loop calls it inside its own thread pool. Long work checks `stop` and may end
    /// early when it asks (the pass is then abandoned). Returns the rays it cast.
    fn prepare_pass(&mut self, _cx: &PassContext) -> RayCounters {
        RayCounters::default()
    }

    /// What it demands of the machine, for refusing a configuration that cannot run.
    fn demand(&self) -> Demand {
        Demand::default()
    }

    /// The unit of work it takes from the render loop for an image of `camera`: camera
    /// samples (the default), camera samples from per-pixel state, or Markov chains. Sharding
    /// follows from it ([`Work::shard_by`]).
    fn work(&self, _camera: &Camera) -> Work {
        Work::PixelSamples
    }

    /// Runs chain `chain` of the pass (with [`Work::Chains`]), splatting its visits. What it
    /// computes must depend only on the chain's number, the pass's preparation and the
    /// scene.
    fn run_chain(&self, _chain: u64, _cx: ChainContext) {}

    /// The images it splats into beside the main one ([`Splats::add_to_layer`]), each with a
    /// name for its file (`s2_t3`); none by default.
    fn layers(&self) -> Vec<(u32, String)> {
        Vec::new()
    }

    /// The integrator as an estimator of radiance along a ray, if it is one (for tests that
    /// probe it with rays of their own).
    fn as_ray_integrator(&self) -> Option<&dyn RayIntegrator> {
        None
    }

    /// The integrator as one that estimates many camera rays at once, if it is one: the render
    /// loop then hands it a tile's camera samples of a pass together ([`BatchIntegrator`]).
    fn as_batch(&self) -> Option<&dyn BatchIntegrator> {
        None
    }
}

/// Camera samples estimated together ([`BatchIntegrator::radiance_batch`]): sample `k` is the
/// camera ray `rays[k]` with its own sampler and wavelengths; its estimate goes to `out[k]`.
/// All four slices have the same length.
pub struct Batch<'s> {
    pub rays: &'s [Ray],
    pub samplers: &'s mut [Sampler],
    pub lambdas: &'s mut [Wavelengths],
    pub out: &'s mut [Spectrum],
}

/// An integrator that walks many camera paths together, stage by stage (a wavefront), rather
/// than one after the other. Each sample's estimate must depend on its own ray, sampler and
/// wavelengths only, never on which other samples share its batch, so that images do not
/// depend on how the render loop groups samples (tiles, shards, thread counts).
pub trait BatchIntegrator: Send + Sync {
    /// Estimates every sample of `batch`, casting rays through `tracer`.
    fn radiance_batch(&self, batch: Batch, tracer: &mut Tracer);
}

/// How a render splits into shards.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShardBy {
    /// Each shard takes a contiguous range of passes over the whole image.
    Passes,
    /// Each shard takes every pass over a band of rows of tiles (no splats allowed).
    Rows,
}

/// What an integrator's configuration demands, known before it runs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Demand {
    /// Rays a camera sample casts at the least (a branching tracer's grow combinatorially).
    pub rays_per_sample: f64,
    /// Memory it holds during a pass beyond the film (photon maps), bytes, about.
    pub memory: u64,
    /// Memory it holds during a pass per pixel of the image, bytes, about (light paths
    /// stored one per pixel).
    pub memory_per_pixel: u64,
    /// It connects points of the scene to the lens ([`Camera::sample_wi`]), which only a
    /// pinhole camera has: an orthographic one is refused before rendering.
    pub pinhole: bool,
}

impl Demand {
    /// The memory it holds during a pass of an image of `pixels` pixels, bytes, about.
    pub fn memory_for(&self, pixels: u64) -> u64 {
        self.memory
            .saturating_add(pixels.saturating_mul(self.memory_per_pixel))
    }
}

/// An integrator that estimates the radiance arriving along a camera ray (Nori's and
/// pbrt-v4's `RayIntegrator`): the camera ray through the sample's film position, one
/// estimate, no splats.
pub trait RayIntegrator: Send + Sync {
    /// One sample of the radiance arriving along `ray` (a camera ray), at the wavelengths
    /// `lambda`.
    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum;

    /// As [`Integrator::demand`].
    fn demand(&self) -> Demand {
        Demand::default()
    }

    /// As [`Integrator::prepare_pass`].
    fn prepare_pass(&mut self, _cx: &PassContext) -> RayCounters {
        RayCounters::default()
    }

    /// As [`Integrator::as_batch`].
    fn as_batch(&self) -> Option<&dyn BatchIntegrator> {
        None
    }
}

impl<T: RayIntegrator> Integrator for T {
    #[inline]
    fn sample(&self, cx: SampleContext) -> Spectrum {
        let SampleContext {
            pixel,
            camera,
            tracer,
            sampler,
            lambda,
            ..
        } = cx;
        let ray = camera.ray(pixel.film.x, pixel.film.y);
        self.radiance(&ray, tracer, sampler, lambda)
    }

    fn prepare_pass(&mut self, cx: &PassContext) -> RayCounters {
        RayIntegrator::prepare_pass(self, cx)
    }

    fn demand(&self) -> Demand {
        RayIntegrator::demand(self)
    }

    fn as_ray_integrator(&self) -> Option<&dyn RayIntegrator> {
        Some(self)
    }

    fn as_batch(&self) -> Option<&dyn BatchIntegrator> {
        RayIntegrator::as_batch(self)
    }
}

/// Half the diagonal of the scene's bounding box (at least 1e-3): the radius of the disk that
/// lights at infinity emit from.
pub fn scene_radius(scene: &dyn Scene) -> f32 {
    let (lo, hi) = scene.bounds();
    ((hi - lo).length() * 0.5).max(1e-3)
}

/// How photons and light paths start: a light chosen in proportion to power and a ray leaving
/// it (`sample_le`); the light's index, its selection probability and the sample. `None`
/// when the scene has no light or the sample carries nothing.
pub fn emit_from_a_light(
    scene: &dyn Scene,
    sampler: &mut Sampler,
    lambda: &Wavelengths,
) -> Option<(u32, f32, crate::LeSample)> {
    let (index, pmf) = scene.lights().sample(sampler.next_1d())?;
    let (u_pos, u_dir, u_side) = (sampler.next_2d(), sampler.next_2d(), sampler.next_1d());
    let (lo, hi) = scene.bounds();
    let le = scene.lights().get(index).sample_le(
        u_pos,
        u_dir,
        u_side,
        (lo + hi) * 0.5,
        scene_radius(scene),
        lambda,
    )?;
    Some((index, pmf, le))
}

/// Radiance emitted by the surface at `hit` towards the ray's origin, at `lambda`.
#[inline]
pub fn emitted_at(scene: &dyn Scene, hit: &Hit, ray: &Ray, lambda: &Wavelengths) -> Spectrum {
    match hit.light {
        Some(i) => scene
            .lights()
            .get(i)
            .emitted_at(hit.p, hit.ng, -ray.dir, lambda),
        None => Spectrum::ZERO,
    }
}

/// Radiance arriving along a ray that escaped the scene, at `lambda`.
#[inline]
pub fn escaped(scene: &dyn Scene, ray: &Ray, lambda: &Wavelengths) -> Spectrum {
    match scene.lights().environment() {
        Some(i) => scene
            .lights()
            .get(i)
            .emitted(glam::Vec3A::ZERO, -ray.dir, lambda),
        None => Spectrum::ZERO,
    }
}

/// The deterministic lobes of a specular material, each with its weight `f * |cos|`: for a
/// mirror its one reflection, for glass the Fresnel-weighted reflection and refraction (either
/// may be missing: no refraction under total internal reflection). Whitted-style tracers
/// follow every lobe instead of choosing one at random.
pub fn specular_lobes(
    material: &crate::bsdf::MappedBsdf,
    wo: glam::Vec3A,
) -> [Option<(glam::Vec3A, Spectrum)>; 2] {
    let lobe = |u: f32| {
        material
            .sample(wo, u, glam::Vec2::ZERO)
            .filter(|s| s.specular)
            .map(|s| (s.wi, s.f * s.wi.z.abs()))
    };
    let first = lobe(0.0);
    let second = lobe(1.0 - f32::EPSILON)
        .filter(|(wi, _)| first.is_none_or(|(w, _)| (w - *wi).length_squared() > 1e-12));
    [first, second]
}

/// False when `wi` would cross an opaque surface. Shading normals can put a direction on the
/// viewer's side of the shading frame yet behind the geometry (near the silhouettes of smooth
/// meshes); following it would leak light through the surface.
#[inline]
pub fn stays_on_viewer_side(
    material: &crate::bsdf::MappedBsdf,
    ng: glam::Vec3A,
    wo: glam::Vec3A,
    wi: glam::Vec3A,
) -> bool {
    material.is_transmissive() || ng.dot(wo) * ng.dot(wi) > 0.0
}

/// Next-event estimation with one light chosen in proportion to power: the radiance
/// reflected at the shading point towards `wo` from one sample on that light, divided by both
/// probabilities. With `mis`, the sample is weighted by the power heuristic against BSDF
/// sampling (the caller must then weight emitters hit by BSDF samples with
/// [`mis_weight_for_hit`]).
pub fn sample_one_light(
    sp: &ShadingPoint,
    mis: bool,
    lights: Option<LightSelection>,
    tracer: &mut Tracer,
    sampler: &mut Sampler,
) -> Spectrum {
    let against = match mis {
        true => Against::<fn(glam::Vec3A) -> f32>::Bsdf,
        false => Against::Nothing,
    };
    one_light(sp, against, lights, tracer, sampler)
}

/// [`sample_one_light`] weighted by the power heuristic against a strategy of the caller's
/// whose solid-angle density towards `wi` (world) is `pdf(wi)` (`None`: unweighted).
pub fn sample_one_light_against(
    sp: &ShadingPoint,
    pdf: Option<impl Fn(glam::Vec3A) -> f32>,
    lights: Option<LightSelection>,
    tracer: &mut Tracer,
    sampler: &mut Sampler,
) -> Spectrum {
    let against = match pdf {
        Some(pdf) => Against::Strategy(pdf),
        None => Against::Nothing,
    };
    one_light(sp, against, lights, tracer, sampler)
}

/// What a light sample is weighted against.
enum Against<F> {
    /// Nothing: unweighted.
    Nothing,
    /// BSDF sampling, whose density comes with the BSDF's value
    /// ([`ShadingPoint::connect_light_with`]).
    Bsdf,
    /// A strategy of the caller's, with density `F(wi)` towards `wi` (world).
    Strategy(F),
}

/// One light sample at `sp`, weighted as `against` says (see [`sample_one_light`]).
#[inline]
fn one_light<F: Fn(glam::Vec3A) -> f32>(
    sp: &ShadingPoint,
    against: Against<F>,
    lights: Option<LightSelection>,
    tracer: &mut Tracer,
    sampler: &mut Sampler,
) -> Spectrum {
    let Some((ls, pmf)) = sample_light(sp, lights, tracer.scene, sampler) else {
        return Spectrum::ZERO;
    };
    let with_pdf = matches!(against, Against::Bsdf);
    let Some((f, cos, bsdf_pdf)) = sp.reflect(&ls, with_pdf) else {
        return Spectrum::ZERO;
    };
    if !tracer.unoccluded(&sp.hit, &ls) {
        return Spectrum::ZERO;
    }
    let light_pdf = pmf * ls.pdf;
    let weight = match against {
        _ if ls.delta => 1.0,
        Against::Nothing => 1.0,
        Against::Bsdf => crate::sampling::power_heuristic(light_pdf, bsdf_pdf),
        Against::Strategy(pdf) => crate::sampling::power_heuristic(light_pdf, pdf(ls.wi)),
    };
    f * ls.radiance * (cos * weight / light_pdf)
}

/// The light sample of next-event estimation at `sp`, before its shadow ray: a light picked
/// as `lights` says (`None`: the scene's choice), a point on it, and the light's selection
/// probability. `None` when it carries nothing: no light, the emitter the point lies on (flat
/// or convex), no sample, a zero density. Draws one number and a pair from `sampler`.
#[inline]
pub fn sample_light(
    sp: &ShadingPoint,
    lights: Option<LightSelection>,
    scene: &dyn Scene,
    sampler: &mut Sampler,
) -> Option<(LightSample, f32)> {
    let u_light = sampler.next_1d();
    let u = sampler.next_2d();
    let table = scene.lights();
    let (index, pmf) = table.sample_for(lights, &sp.light_context(), u_light)?;
    if !sp.can_receive(index, table) {
        return None;
    }
    let ls = table.get(index).sample_li(sp.hit.p, u, &sp.lambda)?;
    (ls.pdf > 0.0).then_some((ls, pmf))
}

/// MIS weight of emission found by a BSDF-sampled ray (density `bsdf_pdf`) leaving `from`
/// and arriving at `hit` (or escaping, when `hit` is `None`), against [`sample_one_light`]
/// picking lights by `choice` for `from`.
pub fn mis_weight_for_hit(
    scene: &dyn Scene,
    (from, choice): (&LightContext, Option<LightSelection>),
    ray: &Ray,
    hit: Option<&Hit>,
    bsdf_pdf: f32,
) -> f32 {
    let lights = scene.lights();
    let p = from.p;
    let light_pdf = match hit {
        Some(h) => match h.light {
            Some(i) => lights.pmf_for(choice, from, i) * lights.get(i).pdf_li(p, ray.dir, h.p),
            None => return 1.0,
        },
        None => match lights.environment() {
            Some(i) => lights.pmf_for(choice, from, i) * lights.get(i).pdf_li(p, ray.dir, p),
            None => return 1.0,
        },
    };
    crate::sampling::power_heuristic(bsdf_pdf, light_pdf)
}

/// Largest survival probability of [`russian_roulette`]: even a path whose throughput never
/// drops (a ray trapped between perfect mirrors, or inside a mirror sphere) ends after about
/// 20 more bounces on average, so every estimate terminates (as in Mitsuba 3).
pub const MAX_SURVIVAL: f32 = 0.95;

/// One BSDF-sampled continuation of a camera path at the shading point: multiplies the
/// throughput `beta` by the sample's weight and returns the next ray and the sample. `None`
/// ends the path: no sample, no throughput left (pure emitters are black), or a direction that
/// would cross an opaque surface.
#[inline]
pub fn continue_path(
    sp: &ShadingPoint,
    beta: &mut Spectrum,
    sampler: &mut Sampler,
) -> Option<(Ray, crate::BsdfSample)> {
    let u_lobe = sampler.next_1d();
    continue_path_with_lobe(sp, u_lobe, beta, sampler)
}

/// [`continue_path`] with the number that picks the lobe given.
#[inline]
pub fn continue_path_with_lobe(
    sp: &ShadingPoint,
    u_lobe: f32,
    beta: &mut Spectrum,
    sampler: &mut Sampler,
) -> Option<(Ray, crate::BsdfSample)> {
    let s = sp.sample(
        u_lobe,
        sampler.next_2d(),
        crate::bsdf::TransportMode::Radiance,
    )?;
    *beta = s.throughput(*beta);
    if *beta == Spectrum::ZERO {
        return None;
    }
    Some((sp.hit.spawn_ray(s.wi), s.bsdf))
}

/// Russian roulette on the path throughput `beta`: survives with probability
/// `min(0.95, max component of beta)`; returns the probability to divide `beta` by, or `None`
/// when the path ends. Unbiased: E[beta'] = beta. Camera paths pass their throughput times
/// the product of `eta^2` over their refractions (pbrt-v4's and Mitsuba 3's `rrBeta`), so that
/// the `1 / eta^2` compression of radiance inside glass does not end paths early.
#[inline]
pub fn russian_roulette(beta: Spectrum, sampler: &mut Sampler) -> Option<f32> {
    let survive = beta.max_element().min(MAX_SURVIVAL);
    (sampler.next_1d() < survive).then_some(survive)
}

#[cfg(test)]
mod analytic_tests;
#[cfg(test)]
mod media_tests;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Conductor, Dielectric, MappedBsdf};
    use crate::Material;
    use glam::Vec3A;

    #[test]
    fn specular_lobes_of_glass_split_energy_by_fresnel() {
        let glass = Material::Dielectric(Dielectric::unchecked(1.5, Spectrum::ONE));
        let glass = MappedBsdf::plain(std::borrow::Cow::Owned(glass));
        let [r, t] = specular_lobes(&glass, Vec3A::Z);
        let (r, t) = (r.unwrap(), t.unwrap());
        assert!(
            (r.0 - Vec3A::Z).length() < 1e-6 && (r.1.x - 0.04).abs() < 1e-4,
            "{r:?}"
        );
        // Refraction straight through, (1 - F) / eta^2 for radiance.
        assert!(
            (t.0 + Vec3A::Z).length() < 1e-6 && (t.1.x - 0.96 / 2.25).abs() < 1e-4,
            "{t:?}"
        );
        // From inside past the critical angle: total internal reflection, one lobe of weight 1.
        let wo = Vec3A::new(0.9, 0.0, -(1.0f32 - 0.81).sqrt());
        let [r, t] = specular_lobes(&glass, wo);
        assert!((r.unwrap().1.x - 1.0).abs() < 1e-5 && t.is_none());
    }

    #[test]
    fn specular_lobes_of_a_mirror_is_one_tinted_reflection() {
        let mirror = Material::Conductor(Conductor::perfect_mirror(crate::spectrum::rgb(
            0.9, 0.5, 0.1,
        )));
        let mirror = MappedBsdf::plain(std::borrow::Cow::Owned(mirror));
        let wo = Vec3A::new(0.6, 0.0, 0.8);
        let [r, t] = specular_lobes(&mirror, wo);
        let r = r.unwrap();
        assert!((r.0 - Vec3A::new(-0.6, 0.0, 0.8)).length() < 1e-6);
        assert!((r.1 - crate::spectrum::rgb(0.9, 0.5, 0.1)).length() < 1e-5);
        assert!(t.is_none());
    }
}
