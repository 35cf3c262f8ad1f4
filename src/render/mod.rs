//! The render loop: one parallel loop over tiles for every integrator, in passes.
//!
//! Per pixel, `spp` sub-samples are stratified on an `n x n` grid (`n = floor(sqrt(spp))`)
//! with a random jitter inside each cell; samples beyond `n^2` are uniform in the pixel (an
//! open-ended render, `spp = None`, jitters uniformly). Each sample has its own [`Sampler`]
//! seeded from (seed, pixel, sample index) only, and each pixel adds its samples in index
//! order, so images are bit-identical whatever the thread count, the tile order, or how the
//! samples are split into passes (and so across a checkpoint and resume).
//!
//! A pass takes one more sample in every pixel. The pixel reconstruction filter ([`Filter`])
//! shares each sample between the pixels around it; integrators may also add radiance at any
//! film position (splats). Both are gathered per tile during the pass and added to the image
//! after it in tile order, so the sums do not depend on which thread finished first. Between
//! passes the loop checks whether to stop (Ctrl-C, time budget) and hands the accumulated
//! state to a callback (checkpoints, progressive output).

mod accumulator;
pub mod checkpoint;
pub mod exact;
pub mod job;
pub mod shard;
pub mod shard_file;

pub use crate::output::Film;
pub use raylab_integrators::Filter;

use crate::output::plan::FilePlan;
use crate::scene::Camera;
use accumulator::NarrowTotals;
use accumulator::PassPixel;
pub use accumulator::{PixelAccumulator, PixelTotals, BLOCK};
use glam::{DVec3, Vec2, Vec3A};
use indicatif::{ProgressBar, ProgressStyle};
pub use job::{Job, Request, Target};
use raylab_integrators::random::permute;
use raylab_integrators::sampler::{SampleSite, SamplerKind};
use raylab_integrators::spectrum::Wavelengths;
use raylab_integrators::{
    Batch, BatchIntegrator, ChainContext, Integrator, PassContext, PixelSample, RayCounters,
    SampleContext, Sampler, Scene, Splats, Stop, Tracer, Work,
};
use rayon::prelude::*;
pub use shard::{Part, ShardBy, ShardSpec};
use std::time::{Duration, Instant};

/// Tile side in pixels.
pub const TILE: u32 = 16;

/// What to render.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Samples per pixel to reach; `None` renders until stopped (needs a time budget or a
    /// stop signal).
    pub spp: Option<u32>,
    pub seed: u64,
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
    /// Show a progress bar on stderr (only drawn on a terminal).
    pub progress: bool,
    /// Stop when this much time has passed, abandoning the pass in progress (the first of a
    /// render gets ten times as long and ten seconds more, to give an image).
    pub time_budget: Option<Duration>,
    /// The pixel reconstruction filter.
    pub filter: Filter,
    /// How camera samples draw their numbers.
    pub sampler: SamplerKind,
    /// Spectral rendering: every camera sample carries sampled wavelengths, and the film
    /// turns its spectrum into XYZ and linear sRGB (`--spectral`).
    pub spectral: bool,
    /// The part of the render this run does, for a shard (`render --shard`); `None` for all
    /// of it. Samples are placed for the whole render's `spp` either way.
    pub part: Option<Part>,
}

impl RenderSettings {
    /// A render of exactly `spp` samples per pixel, no time limit, no progress bar.
    pub fn fixed(spp: u32, seed: u64, threads: Option<usize>) -> Self {
        RenderSettings {
            spp: Some(spp),
            seed,
            threads,
            progress: false,
            time_budget: None,
            filter: Filter::Box,
            sampler: SamplerKind::Independent,
            spectral: false,
            part: None,
        }
    }

    /// The pass this run ends at when nothing stops it (`None`: open-ended).
    fn last_pass(&self) -> Option<u32> {
        match &self.part {
            Some(Part::Passes(r)) => Some(r.end),
            _ => self.spp,
        }
    }
}

/// Where the first non-finite sample occurred.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BadSample {
    pub x: u32,
    pub y: u32,
    pub sample: u32,
}

/// Samples dropped because their estimate (or a splat) was NaN or infinite: they count as
/// black, and the first in raster order is reported.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Dropped {
    pub count: u64,
    pub first: Option<BadSample>,
}

impl Dropped {
    /// Counts a dropped sample.
    fn note(&mut self, bad: BadSample) {
        self.count += 1;
        self.first.get_or_insert(bad);
    }

    /// Adds `other`'s, keeping the first in raster order whatever order they come in.
    pub fn add(&mut self, other: Dropped) {
        self.count += other.count;
        self.first = match (self.first, other.first) {
            (Some(a), Some(b)) => Some(if (b.y, b.x, b.sample) < (a.y, a.x, a.sample) {
                b
            } else {
                a
            }),
            (a, b) => a.or(b),
        };
    }
}

/// What a render cost (this run only: a resumed render counts from where it resumed).
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub elapsed: Duration,
    /// Camera samples taken in this run.
    pub samples: u64,
    pub rays: RayCounters,
    /// Over the whole render.
    pub dropped: Dropped,
    pub threads: usize,
    /// Samples per pixel reached, over the whole render.
    pub spp_done: u32,
    /// Why the render ended before its target, if it did.
    pub stopped: Option<StopReason>,
}

/// Why a render ended early.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    Interrupted,
    TimeBudget,
}

impl RenderStats {
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }

    pub fn rays_per_second(&self) -> f64 {
        self.rays.total() as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// Bytes of memory a render of `width x height` needs (accumulators, film, output buffer).
pub fn memory_needed(width: u32, height: u32) -> u64 {
    // The block's sums 104 B and the exact totals 208 B (the few pixels whose sums need a
    // third limb hold it beside), a pass's sums 56 B, film mean + variance 24 B, tile
    // bookkeeping and the 8-bit or f32 output copy <= 24 B.
    width as u64 * height as u64 * 416
}

/// Refuses a camera the integrator `name` cannot use: light-path integrators connect points
/// to the lens, which an orthographic camera does not have.
pub fn check_camera(
    camera: &raylab_integrators::Camera,
    demand: &raylab_integrators::integrator::Demand,
    name: &str,
) -> anyhow::Result<()> {
    if demand.pinhole && !camera.is_pinhole() {
        anyhow::bail!(
            "integrator `{name}` connects light paths to the lens, which an orthographic camera \
             does not have; use a LookAt or ImagePlane camera, or a camera-path integrator \
             (path)"
        );
    }
    Ok(())
}

/// Refuses a render whose buffers would not fit in the memory this process may still
/// allocate (Linux: the least of the machine's available memory, the cgroup's limit and
/// `ulimit -v`), so an absurd resolution or photon count is an error before anything is
/// allocated, not an abort. `integrator` is the integrator's own demand (photon maps, light
/// paths, Metropolis splats).
pub fn check_memory(width: u32, height: u32, integrator: u64) -> anyhow::Result<()> {
    let film = memory_needed(width, height);
    let needed = film.saturating_add(integrator);
    if let Some((room, what)) = crate::system::memory_limit() {
        if needed > room {
            let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
            let maps = if integrator > 0 {
                format!(
                    " and its integrator's own buffers (photon maps, light paths or Metropolis \
                     splats) about {:.1} GiB",
                    gib(integrator)
                )
            } else {
                String::new()
            };
            anyhow::bail!(
                "a {width}x{height} image needs {:.1} GiB of memory{maps}; only {:.1} GiB is {what}",
                gib(film),
                gib(room)
            );
        }
    }
    Ok(())
}

/// Film position of sample `s` in pixel `(x, y)` of a render of `spp` samples per pixel.
#[inline]
fn sample_position(
    x: u32,
    y: u32,
    s: u32,
    spp: Option<u32>,
    seed: u64,
    sampler: &mut Sampler,
) -> Vec2 {
    // A low-discrepancy sampler's first two numbers are stratified over the pixel's samples
    // already.
    if sampler.stratifies_pixels() {
        return Vec2::new(x as f32, y as f32) + sampler.next_2d();
    }
    let n = spp.map_or(1, |spp| (spp as f64).sqrt().floor() as u32);
    let jitter = sampler.next_2d();
    let offset = if s < n * n {
        // Strata are visited in an order scrambled per pixel, so a render stopped early
        // (Ctrl-C, a time budget) still covers the whole pixel.
        let key = (seed as u32) ^ (y.wrapping_mul(0x9e37_79b9) ^ x.wrapping_mul(0x85eb_ca6b));
        let cell = permute(s, n * n, key);
        (Vec2::new((cell % n) as f32, (cell / n) as f32) + jitter) / n as f32
    } else {
        jitter
    };
    Vec2::new(x as f32, y as f32) + offset
}

/// The running sums of one tile's pixels.
#[derive(Clone, Debug)]
pub struct TileAccumulator {
    pub x0: u32,
    pub y0: u32,
    pub w: u32,
    pub h: u32,
    /// Per pixel, the sums of the block of passes in progress ...
    pub pixels: Vec<PixelAccumulator>,
    /// ... and the exact sums of the blocks before, narrow ([`accumulator::NarrowTotals`]),
    totals: Vec<NarrowTotals>,
    /// with the top limbs of the pixels whose sums need them, by pixel index, in order.
    wide: Vec<(u32, [u64; 13])>,
}

impl TileAccumulator {
    /// An empty tile of `w x h` pixels at `(x0, y0)`.
    fn new(x0: u32, y0: u32, w: u32, h: u32) -> TileAccumulator {
        TileAccumulator {
            x0,
            y0,
            w,
            h,
            pixels: vec![PixelAccumulator::default(); (w * h) as usize],
            totals: vec![NarrowTotals::default(); (w * h) as usize],
            wide: Vec::new(),
        }
    }

    /// Pixel `k`'s exact sums over the finished blocks.
    pub fn totals(&self, k: usize) -> PixelTotals {
        let top = match self.wide.binary_search_by_key(&(k as u32), |(i, _)| *i) {
            Ok(at) => Some(&self.wide[at].1),
            Err(_) => None,
        };
        PixelTotals::widen(&self.totals[k], top)
    }

    /// Sets pixel `k`'s exact sums over the finished blocks.
    pub fn set_totals(&mut self, k: usize, totals: &PixelTotals) {
        let (narrow, top) = totals.narrow();
        self.totals[k] = narrow;
        let at = self.wide.binary_search_by_key(&(k as u32), |(i, _)| *i);
        match (at, top) {
            (Ok(at), Some(top)) => self.wide[at].1 = top,
            (Ok(at), None) => {
                self.wide.remove(at);
            }
            (Err(at), Some(top)) => self.wide.insert(at, (k as u32, top)),
            (Err(_), None) => {}
        }
    }

    /// Pixel `k`'s exact sums over every pass so far.
    pub fn pixel_totals(&self, k: usize) -> PixelTotals {
        self.totals(k).with_block(&self.pixels[k])
    }

    /// Ends the block of passes in pixel `k`: adds its sums to the exact ones and empties it.
    /// False, adding nothing, when a sum is beyond what exact sums hold.
    fn absorb(&mut self, k: usize) -> bool {
        if self.pixels[k].is_empty() {
            return true;
        }
        let mut totals = self.totals(k);
        let added = totals.absorb(&mut self.pixels[k]);
        if added {
            self.set_totals(k, &totals);
        }
        added
    }
}

/// What a tile's pass produces before it is added to the image: the sums of its own pixels,
/// filter weights that fall on other tiles' pixels, and the integrator's splats. Reused from
/// pass to pass.
#[derive(Clone, Debug, Default)]
struct TileScratch {
    pass: Vec<PassPixel>,
    /// (pixel index in the image, weight times radiance, weight) for pixels of other tiles.
    spill: Vec<(u32, DVec3, f32)>,
    splats: Splats,
}

/// The state of a render between passes: per-pixel running sums (tile by tile) and counts.
#[derive(Clone, Debug)]
pub struct Accumulation {
    pub width: u32,
    pub height: u32,
    pub tiles: Vec<TileAccumulator>,
    /// Passes done so far, counted from the render's first (samples taken in every pixel,
    /// for a render that began at pass 0).
    pub spp_done: u32,
    /// The pass this accumulation began at: 0, or the first of a shard's pass range.
    pub first_pass: u32,
    pub dropped: Dropped,
    /// Per tile, the pass in progress (empty between passes).
    scratch: Vec<TileScratch>,
    /// The integrator's layers (see [`Accumulation::with_layers`]): per layer, its id and the
    /// sum of its splats in every pixel, row by row.
    layers: Vec<(u32, Vec<DVec3>)>,
}

impl Accumulation {
    /// An empty accumulation for an image of `width x height`.
    pub fn new(width: u32, height: u32) -> Accumulation {
        let mut tiles = Vec::new();
        for y0 in (0..height).step_by(TILE as usize) {
            for x0 in (0..width).step_by(TILE as usize) {
                let (w, h) = (TILE.min(width - x0), TILE.min(height - y0));
                tiles.push(TileAccumulator::new(x0, y0, w, h));
            }
        }
        Accumulation {
            width,
            height,
            tiles,
            spp_done: 0,
            first_pass: 0,
            dropped: Dropped::default(),
            scratch: Vec::new(),
            layers: Vec::new(),
        }
    }

    /// The same accumulation also gathering the splats of the integrator's layers `ids`
    /// (not kept by checkpoints).
    pub fn with_layers(mut self, ids: &[u32]) -> Accumulation {
        let pixels = self.width as usize * self.height as usize;
        self.layers = ids
            .iter()
            .map(|&id| (id, vec![DVec3::ZERO; pixels]))
            .collect();
        self
    }

    /// The image of layer `id` so far: its splats averaged over passes (with the box filter,
    /// the layers of an integrator that splats its whole estimate into them add up to the
    /// image). `None` for a layer it does not gather.
    pub fn layer_film(&self, id: u32) -> Option<Film> {
        let (_, sums) = self.layers.iter().find(|(i, _)| *i == id)?;
        let mut film = Film::new(self.width, self.height);
        let n = self.passes().max(1) as f64;
        for (pixel, sum) in film.pixels.iter_mut().zip(sums) {
            let mean = *sum / n;
            *pixel = glam::Vec3::new(mean.x as f32, mean.y as f32, mean.z as f32);
        }
        Some(film)
    }

    /// The same accumulation, empty, for a shard's passes from `first` on.
    pub fn starting_at(mut self, first: u32) -> Accumulation {
        self.first_pass = first;
        self.spp_done = first;
        self
    }

    /// The samples dropped so far: those counted as their passes or blocks closed, and the
    /// pixels whose unfinished block is beyond what exact sums hold (left out of any image
    /// made now, as a finished block would be: a render of fewer passes than a block must
    /// say so too).
    pub fn dropped_so_far(&self) -> Dropped {
        let mut dropped = self.dropped;
        let block_start = self.spp_done - self.spp_done % BLOCK;
        for t in &self.tiles {
            for (k, block) in t.pixels.iter().enumerate() {
                if !block.fits() {
                    let (x, y) = (t.x0 + k as u32 % t.w, t.y0 + k as u32 / t.w);
                    dropped.note(BadSample {
                        x,
                        y,
                        sample: block_start,
                    });
                }
            }
        }
        dropped
    }

    /// Pixel `(x, y)`'s exact sums over every pass so far.
    pub fn pixel_totals(&self, x: u32, y: u32) -> PixelTotals {
        let (t, k) = self.locate(x, y);
        self.tiles[t].pixel_totals(k)
    }

    /// Passes this accumulation holds.
    pub fn passes(&self) -> u32 {
        self.spp_done - self.first_pass
    }

    /// The tile holding pixel `(x, y)` and the pixel's index within it.
    #[inline]
    fn locate(&self, x: u32, y: u32) -> (usize, usize) {
        let tiles_x = self.width.div_ceil(TILE);
        let t = ((y / TILE) * tiles_x + x / TILE) as usize;
        let tile = &self.tiles[t];
        (t, ((y - tile.y0) * tile.w + (x - tile.x0)) as usize)
    }

    /// Adds what every tile's pass left for pixels of other tiles (filter weights and
    /// splats) to those pixels, tile after tile in order, then closes the pass in every pixel.
    fn finish_pass(&mut self, filter: Filter) {
        let splat_norm = 1.0 / (filter.integral_1d() as f64).powi(2);
        for t in 0..self.scratch.len() {
            let spill = std::mem::take(&mut self.scratch[t].spill);
            for &(index, wl, w) in &spill {
                let (x, y) = (index % self.width, index / self.width);
                let (tt, k) = self.locate(x, y);
                let p = &mut self.scratch[tt].pass[k];
                p.sum += wl;
                p.weight += w as f64;
            }
            self.scratch[t].spill = spill;
            self.scratch[t].spill.clear();
            let splats = std::mem::take(&mut self.scratch[t].splats);
            for &(pos, l) in splats.entries() {
                let d = DVec3::new(l.x as f64, l.y as f64, l.z as f64);
                filter.footprint(pos.x, pos.y, self.width, self.height, |x, y, w| {
                    let (tt, k) = self.locate(x, y);
                    self.scratch[tt].pass[k].splat += d * (w as f64 * splat_norm);
                });
            }
            for &(id, pos, l) in splats.layered_entries() {
                let Some(layer) = self.layers.iter_mut().find(|(i, _)| *i == id) else {
                    continue;
                };
                let d = DVec3::new(l.x as f64, l.y as f64, l.z as f64);
                let width = self.width;
                filter.footprint(pos.x, pos.y, self.width, self.height, |x, y, w| {
                    layer.1[(y * width + x) as usize] += d * (w as f64 * splat_norm);
                });
            }
            self.scratch[t].splats = splats;
            self.scratch[t].splats.clear();
        }
        // The pass is closed in every pixel; a pass that ends a block of passes moves the
        // block's sums into the exact totals (a pixel whose block is beyond what they hold is
        // dropped like a non-finite sample).
        let pass = self.spp_done;
        let ends_block = (pass + 1).is_multiple_of(BLOCK);
        let out_of_range: Vec<Dropped> = self
            .tiles
            .par_iter_mut()
            .zip(self.scratch.par_iter_mut())
            .map(|(tile, scratch)| {
                let mut dropped = Dropped::default();
                for (acc, p) in tile.pixels.iter_mut().zip(scratch.pass.iter_mut()) {
                    acc.close_pass(p);
                    *p = PassPixel::default();
                }
                if ends_block {
                    let (w, x0, y0) = (tile.w, tile.x0, tile.y0);
                    for k in 0..tile.pixels.len() {
                        if !tile.absorb(k) {
                            let (x, y) = (x0 + k as u32 % w, y0 + k as u32 / w);
                            let sample = pass + 1 - BLOCK;
                            dropped.note(BadSample { x, y, sample });
                        }
                    }
                }
                dropped
            })
            .collect();
        for d in out_of_range {
            self.dropped.add(d);
        }
    }

    /// Forgets the pass in progress: what it left in the tiles' scratch.
    fn abandon_pass(&mut self) {
        for scratch in &mut self.scratch {
            scratch.pass.fill(PassPixel::default());
            scratch.spill.clear();
            scratch.splats.clear();
        }
    }

    /// The image so far: the mean of the samples taken (dropped ones count as zero).
    pub fn film(&self) -> Film {
        let mut film = Film::new(self.width, self.height);
        let n = self.passes();
        film.has_variance = n >= 2;
        film.variance_samples = n;
        for t in &self.tiles {
            for j in 0..t.h {
                for i in 0..t.w {
                    let (mean, var) = t.pixel_totals((j * t.w + i) as usize).finish(n);
                    let idx = ((t.y0 + j) * self.width + t.x0 + i) as usize;
                    film.pixels[idx] = mean;
                    film.variance[idx] = var;
                }
            }
        }
        film
    }
}

/// What one tile's pass produced besides its pixels.
struct TilePass {
    rays: RayCounters,
    dropped: Dropped,
}

/// The wavelengths of pass `pass` (see [`PassContext::lambda`]): only the hero where a
/// material disperses, as the pass's photons and camera paths must agree on them.
fn pass_wavelengths(scene: &dyn Scene, settings: &RenderSettings, pass: u32) -> Wavelengths {
    Wavelengths::of_pass(settings.spectral, settings.seed, pass, scene.disperses())
}

/// Camera sample number `pass` of pixel `(x, y)`: its own sampler, its stratified film
/// position and the wavelengths it carries.
fn camera_sample(
    camera: &Camera,
    settings: &RenderSettings,
    x: u32,
    y: u32,
    pass: u32,
) -> (Sampler, Vec2, Wavelengths) {
    let site = SampleSite {
        seed: settings.seed,
        x,
        y,
        width: camera.width,
        height: camera.height,
        sample: pass as u64,
        spp: settings.spp,
    };
    let mut sampler = Sampler::camera(settings.sampler, &site);
    let film = sample_position(x, y, pass, settings.spp, settings.seed, &mut sampler);
    // The wavelengths it carries (Mitsuba 3 draws them after the film position too).
    let lambda = match settings.spectral {
        true => Wavelengths::sample(sampler.next_1d()),
        false => Wavelengths::Rgb,
    };
    (sampler, film, lambda)
}

/// Adds one camera sample's estimate `l` (linear sRGB) at film position `film` to the tile's
/// scratch, shared between the pixels around it; a sample with a non-finite estimate or
/// splat (`splats_finite` false) is dropped (it counts as black) and counted.
#[allow(clippy::too_many_arguments)]
fn record_sample(
    camera: &Camera,
    settings: &RenderSettings,
    tile: &TileAccumulator,
    scratch: &mut TileScratch,
    (i, j): (u32, u32),
    pass: u32,
    (film, l, splats_finite): (Vec2, Vec3A, bool),
    out: &mut TilePass,
) {
    let (x, y) = (tile.x0 + i, tile.y0 + j);
    let mut l = l;
    if !(l.is_finite() && splats_finite) {
        l = Vec3A::ZERO;
        out.dropped.note(BadSample { x, y, sample: pass });
    }
    if settings.filter == Filter::Box {
        scratch.pass[(j * tile.w + i) as usize].add(l, 1.0);
        return;
    }
    let d = DVec3::new(l.x as f64, l.y as f64, l.z as f64);
    settings
        .filter
        .footprint(film.x, film.y, camera.width, camera.height, |px, py, w| {
            let inside = (tile.x0..tile.x0 + tile.w).contains(&px)
                && (tile.y0..tile.y0 + tile.h).contains(&py);
            if inside {
                let k = ((py - tile.y0) * tile.w + (px - tile.x0)) as usize;
                scratch.pass[k].add(l, w);
            } else {
                scratch
                    .spill
                    .push((py * camera.width + px, d * w as f64, w));
            }
        });
}

/// Takes sample number `pass` of every pixel of `tile` from an integrator that estimates
/// them together ([`BatchIntegrator`]): the tile's camera samples set up in pixel order, one
/// batch, then each estimate recorded in pixel order.
#[allow(clippy::too_many_arguments)]
fn render_tile_batch(
    batch: &dyn BatchIntegrator,
    camera: &Camera,
    settings: &RenderSettings,
    tile: &TileAccumulator,
    scratch: &mut TileScratch,
    pass: u32,
    tracer: &mut Tracer,
    out: &mut TilePass,
) {
    let n = (tile.w * tile.h) as usize;
    let (mut samplers, mut lambdas) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let (mut rays, mut films) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for j in 0..tile.h {
        for i in 0..tile.w {
            let (sampler, film, lambda) =
                camera_sample(camera, settings, tile.x0 + i, tile.y0 + j, pass);
            rays.push(camera.ray(film.x, film.y));
            samplers.push(sampler);
            films.push(film);
            lambdas.push(lambda);
        }
    }
    let mut estimates = vec![raylab_integrators::Spectrum::ZERO; n];
    batch.radiance_batch(
        Batch {
            rays: &rays,
            samplers: &mut samplers,
            lambdas: &mut lambdas,
            out: &mut estimates,
        },
        tracer,
    );
    for (k, (l, lambda)) in estimates.iter().zip(&lambdas).enumerate() {
        let (i, j) = (k as u32 % tile.w, k as u32 / tile.w);
        let sample = (films[k], lambda.to_rgb(*l), true);
        record_sample(camera, settings, tile, scratch, (i, j), pass, sample, out);
    }
}

/// Takes sample number `pass` of every pixel of `tile`, into the tile's scratch.
#[allow(clippy::too_many_arguments)]
fn render_tile_pass(
    scene: &dyn Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    tile: &TileAccumulator,
    scratch: &mut TileScratch,
    pass: u32,
    stop: Stop,
) -> TilePass {
    let mut tracer = Tracer::with_stop(scene, stop);
    let chains = match integrator.work(camera) {
        Work::Chains { count } => Some(count),
        Work::PixelSamples | Work::PixelState => None,
    };
    let pixels = camera.width as u64 * camera.height as u64;
    let mut out = TilePass {
        rays: RayCounters::default(),
        dropped: Dropped::default(),
    };
    scratch.pass.resize(tile.pixels.len(), PassPixel::default());
    if let Some(batch) = integrator.as_batch() {
        render_tile_batch(
            batch,
            camera,
            settings,
            tile,
            scratch,
            pass,
            &mut tracer,
            &mut out,
        );
        out.rays = tracer.counters;
        return out;
    }
    for j in 0..tile.h {
        // An abandoned pass is thrown away: no need to finish it.
        if stop.requested() {
            break;
        }
        for i in 0..tile.w {
            let (x, y) = (tile.x0 + i, tile.y0 + j);
            let pixel_index = y as u64 * camera.width as u64 + x as u64;
            // One camera sample: its own sampler, a stratified film position, the
            // integrator's estimate; a sample with a non-finite estimate or splat is dropped
            // (it counts as black) and counted.
            let (mut sampler, film, mut lambda) = camera_sample(camera, settings, x, y, pass);
            let sample = PixelSample {
                x,
                y,
                film,
                index: pass,
            };
            let splats_before = scratch.splats.mark();
            // A chain integrator's pixels estimate nothing themselves; the chain whose work
            // unit this pixel is runs here.
            let l = match chains {
                None => integrator.sample(SampleContext {
                    pixel: &sample,
                    camera,
                    tracer: &mut tracer,
                    sampler: &mut sampler,
                    splats: &mut scratch.splats,
                    lambda: &mut lambda,
                }),
                Some(count) => {
                    if let Some(chain) = Work::chain_at(count, pixel_index, pixels) {
                        let cx = ChainContext {
                            camera,
                            tracer: &mut tracer,
                            splats: &mut scratch.splats,
                        };
                        integrator.run_chain(chain, cx);
                    }
                    raylab_integrators::Spectrum::ZERO
                }
            };
            // The estimate as linear sRGB, at the wavelengths it ends with.
            let l = lambda.to_rgb(l);
            let splats_finite = scratch.splats.all_finite_since(splats_before);
            if !(l.is_finite() && splats_finite) {
                scratch.splats.rollback(splats_before);
            }
            let sample = (film, l, splats_finite);
            record_sample(
                camera,
                settings,
                tile,
                scratch,
                (i, j),
                pass,
                sample,
                &mut out,
            );
        }
    }
    out.rays = tracer.counters;
    out
}

fn progress_bar(settings: &RenderSettings, start_spp: u32, tiles: usize) -> ProgressBar {
    if !settings.progress {
        return ProgressBar::hidden();
    }
    let (len, template) = match (settings.last_pass(), settings.time_budget) {
        (Some(spp), _) => (
            (spp.saturating_sub(start_spp)) as u64 * tiles as u64,
            "{spinner} rendering [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta} {msg}",
        ),
        (None, Some(budget)) => (
            budget.as_millis() as u64,
            "{spinner} rendering [{bar:40}] {elapsed_precise} {msg}",
        ),
        (None, None) => (0, "{spinner} rendering {elapsed_precise} {msg}"),
    };
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template(template)
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar
}

/// Renders pass after pass into `acc` until `settings.spp` is reached, `stop()` returns
/// true, or the time budget is spent. After each pass `after_pass` sees the accumulation (for
/// checkpoints) and the statistics so far (elapsed time, samples, rays, spp: for live
/// displays); an error from it ends the render.
pub fn render_passes(
    scene: &dyn Scene,
    camera: &Camera,
    integrator: &mut dyn Integrator,
    settings: &RenderSettings,
    acc: &mut Accumulation,
    stop: &(dyn Fn() -> bool + Sync),
    after_pass: &mut dyn FnMut(&Accumulation, &RenderStats) -> anyhow::Result<()>,
) -> anyhow::Result<RenderStats> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = settings.threads {
        builder = builder.num_threads(n);
    }
    let pool = builder.build()?;
    let mut stats = RenderStats {
        threads: pool.current_num_threads(),
        ..Default::default()
    };
    let progress = progress_bar(settings, acc.spp_done, acc.tiles.len());
    let first_pass = acc.spp_done;
    let last_pass = settings.last_pass();
    // A shard of rows renders the tiles of its rows and of those its filter reaches into.
    let rows = match &settings.part {
        Some(Part::Rows(rows)) => Some(shard::rendered_rows(rows, settings.filter, acc.height)),
        _ => None,
    };
    let active: Vec<bool> = acc
        .tiles
        .iter()
        .map(|t| rows.as_ref().is_none_or(|r| r.contains(&t.y0)))
        .collect();
    if acc.scratch.len() != acc.tiles.len() {
        acc.scratch = acc
            .tiles
            .iter()
            .map(|t| TileScratch {
                pass: vec![PassPixel::default(); t.pixels.len()],
                ..TileScratch::default()
            })
            .collect();
    }
    let start = Instant::now();
    loop {
        if last_pass.is_some_and(|end| acc.spp_done >= end) || acc.spp_done == u32::MAX {
            break;
        }
        if stop() {
            stats.stopped = Some(StopReason::Interrupted);
            break;
        }
        if settings.time_budget.is_some_and(|b| start.elapsed() >= b) {
            stats.stopped = Some(StopReason::TimeBudget);
            break;
        }
        // The pass in progress is abandoned when `stop` asks, or when the time budget is
        // spent. The first pass of a render, or of a resumed one (which may first rebuild
        // state from the passes before: `sppm-pixel`), gets longer, to give the image the
        // budget promises: until ten times the budget and ten seconds more (a pass still
        // running then would take hours). Long work inside the pass checks the same question.
        let deadline = settings.time_budget.map(|b| {
            if acc.spp_done == first_pass {
                b * 10 + Duration::from_secs(10)
            } else {
                b
            }
        });
        let abandon = || stop() || deadline.is_some_and(|d| start.elapsed() >= d);
        let abandon_pass = Stop::new(&abandon);
        let abandoned = |acc: &mut Accumulation, stats: &mut RenderStats| {
            acc.abandon_pass();
            stats.stopped = Some(if stop() {
                StopReason::Interrupted
            } else {
                StopReason::TimeBudget
            });
        };
        // Work shared by the pass's pixels (photon maps), then one more sample in every
        // pixel, tiles in parallel.
        let pass = acc.spp_done;
        stats.rays.add(&pool.install(|| {
            integrator.prepare_pass(&PassContext {
                scene,
                camera,
                seed: settings.seed,
                pass,
                rows: rows.clone().unwrap_or(0..acc.height),
                stop: abandon_pass,
                lambda: pass_wavelengths(scene, settings, pass),
            })
        }));
        if abandon() {
            abandoned(acc, &mut stats);
            break;
        }
        let integrator: &dyn Integrator = integrator;
        let results: Vec<TilePass> = pool.install(|| {
            acc.tiles
                .par_iter()
                .zip(acc.scratch.par_iter_mut())
                .zip(active.par_iter())
                .filter(|(_, active)| **active)
                .map(|((tile, scratch), _)| {
                    let r = render_tile_pass(
                        scene,
                        camera,
                        integrator,
                        settings,
                        tile,
                        scratch,
                        pass,
                        abandon_pass,
                    );
                    if settings.spp.is_some() {
                        progress.inc(1);
                    }
                    r
                })
                .collect()
        });
        // Stop requests stay: if one came during the pass, some samples may have been cut
        // short, and the pass goes.
        if abandon() {
            for r in &results {
                stats.rays.add(&r.rays);
            }
            abandoned(acc, &mut stats);
            break;
        }
        if rows.is_some() && acc.scratch.iter().any(|s| !s.splats.is_empty()) {
            anyhow::bail!("the integrator splats radiance anywhere in the image, which a shard of rows cannot hold; it must shard by passes");
        }
        // Filter weights and splats that crossed tiles, in tile order; then the pass is
        // closed in every pixel.
        pool.install(|| acc.finish_pass(settings.filter));
        acc.spp_done += 1;
        for r in results {
            stats.rays.add(&r.rays);
            acc.dropped.add(r.dropped);
        }
        stats.samples += acc.width as u64 * acc.height as u64;
        if settings.spp.is_none() {
            if let Some(b) = settings.time_budget {
                progress.set_position(start.elapsed().as_millis().min(b.as_millis()) as u64);
            }
        }
        progress.set_message(format!("{} spp", acc.spp_done));
        stats.elapsed = start.elapsed();
        stats.spp_done = acc.spp_done;
        after_pass(acc, &stats)?;
    }
    progress.finish_and_clear();
    stats.elapsed = start.elapsed();
    stats.spp_done = acc.spp_done;
    stats.dropped = acc.dropped_so_far();
    Ok(stats)
}

/// The files a loaded scene read (the scene, included files, meshes, textures, maps), as
/// the inputs of a [`FilePlan`]. The caller adds its outputs and checks the plan.
pub fn scene_inputs(inputs: &crate::scene::SceneInputs) -> anyhow::Result<FilePlan> {
    let mut plan = FilePlan::new();
    plan.input("the scene", &inputs.scene)?;
    for file in &inputs.files {
        if file.exists() {
            plan.input("a file the scene reads", file)?;
        }
    }
    Ok(plan)
}

/// Renders `scene` through `camera` with `integrator` to completion.
pub fn render(
    scene: &dyn Scene,
    camera: &Camera,
    integrator: &mut dyn Integrator,
    settings: &RenderSettings,
) -> anyhow::Result<(Film, RenderStats)> {
    let mut acc = Accumulation::new(camera.width, camera.height);
    let stats = render_passes(
        scene,
        camera,
        integrator,
        settings,
        &mut acc,
        &|| false,
        &mut |_, _| Ok(()),
    )?;
    Ok((acc.film(), stats))
}

#[cfg(test)]
mod tests;
