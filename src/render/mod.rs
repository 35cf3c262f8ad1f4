//! The render loop: one parallel loop over tiles for every integrator, in passes.
//!
//! Per pixel, `spp` sub-samples are stratified on an `n x n` grid (`n = floor(sqrt(spp))`)
//! with a random jitter inside each cell; samples beyond `n^2` are uniform in the pixel (an
//! open-ended render, `spp = None`, jitters uniformly). Each sample has its own [`Sampler`]
//! seeded from (seed, pixel, sample index) only, and each pixel adds its samples in index
//! order, so images are bit-identical whatever the thread count, the tile order, or how the
//! samples are split into passes (and so across a checkpoint and resume).
//!
//! A pass takes one more sample in every pixel. Between passes the loop checks whether to
//! stop (Ctrl-C, time budget) and hands the accumulated state to a callback (checkpoints,
//! progressive output).

pub mod checkpoint;
pub mod film;

pub use film::Film;

use crate::scene::Camera;
use film::PixelAccumulator;
use glam::Vec2;
use indicatif::{ProgressBar, ProgressStyle};
use raylab_integrators::{Integrator, RayCounters, Sampler, Scene, Tracer};
use rayon::prelude::*;
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
    /// Stop after the pass during which this much time has passed.
    pub time_budget: Option<Duration>,
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

/// What a render cost (this run only: a resumed render counts from where it resumed).
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub elapsed: Duration,
    /// Camera samples taken in this run.
    pub samples: u64,
    pub rays: RayCounters,
    /// Samples dropped because they were NaN or infinite (over the whole render).
    pub dropped: u64,
    pub first_dropped: Option<BadSample>,
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
    // Accumulators 56 B, film mean + variance 24 B, tile bookkeeping and the 8-bit or f32
    // output copy <= 24 B.
    width as u64 * height as u64 * 104
}

/// Refuses a render whose buffers would not fit in the memory available now (Linux), so an
/// absurd resolution is an error before anything is allocated, not an abort.
pub fn check_memory(width: u32, height: u32) -> anyhow::Result<()> {
    let needed = memory_needed(width, height);
    let available = std::fs::read_to_string("/proc/meminfo").ok().and_then(|m| {
        m.lines()
            .find(|l| l.starts_with("MemAvailable:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
            .map(|kb| kb * 1024)
    });
    if let Some(available) = available {
        if needed > available {
            anyhow::bail!(
                "a {width}x{height} image needs {:.1} GiB of memory, only {:.1} GiB is available",
                needed as f64 / (1u64 << 30) as f64,
                available as f64 / (1u64 << 30) as f64
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

/// A pseudo-random permutation of `[0, len)` selected by `key`: Kensler's hash-based
/// permutation ("Correlated Multi-Jittered Sampling", 2013), by cycle walking.
fn permute(mut i: u32, len: u32, key: u32) -> u32 {
    if len <= 1 {
        return 0;
    }
    let mut w = len - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= key;
        i = i.wrapping_mul(0xe170_893d);
        i ^= key >> 16;
        i ^= (i & w) >> 4;
        i ^= key >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= key >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | key >> 27);
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < len {
            return (i.wrapping_add(key)) % len;
        }
    }
}

/// The running sums of one tile's pixels.
#[derive(Clone, Debug)]
pub struct TileAccumulator {
    pub x0: u32,
    pub y0: u32,
    pub w: u32,
    pub h: u32,
    pub pixels: Vec<PixelAccumulator>,
}

/// The state of a render between passes: per-pixel running sums (tile by tile) and counts.
#[derive(Clone, Debug)]
pub struct Accumulation {
    pub width: u32,
    pub height: u32,
    pub tiles: Vec<TileAccumulator>,
    /// Samples taken in every pixel so far.
    pub spp_done: u32,
    pub dropped: u64,
    pub first_dropped: Option<BadSample>,
}

impl Accumulation {
    /// An empty accumulation for an image of `width x height`.
    pub fn new(width: u32, height: u32) -> Accumulation {
        let mut tiles = Vec::new();
        for y0 in (0..height).step_by(TILE as usize) {
            for x0 in (0..width).step_by(TILE as usize) {
                let (w, h) = (TILE.min(width - x0), TILE.min(height - y0));
                tiles.push(TileAccumulator {
                    x0,
                    y0,
                    w,
                    h,
                    pixels: vec![PixelAccumulator::default(); (w * h) as usize],
                });
            }
        }
        Accumulation {
            width,
            height,
            tiles,
            spp_done: 0,
            dropped: 0,
            first_dropped: None,
        }
    }

    /// The image so far: the mean of the samples taken (dropped ones count as zero).
    pub fn film(&self) -> Film {
        let mut film = Film::new(self.width, self.height);
        for t in &self.tiles {
            for j in 0..t.h {
                for i in 0..t.w {
                    let (mean, var) = t.pixels[(j * t.w + i) as usize].finish(self.spp_done);
                    let idx = ((t.y0 + j) * self.width + t.x0 + i) as usize;
                    film.pixels[idx] = mean;
                    film.variance[idx] = var;
                }
            }
        }
        film
    }

    fn note_dropped(&mut self, bad: Option<BadSample>, count: u64) {
        self.dropped += count;
        // The first in raster order, whatever the tile order.
        self.first_dropped = match (self.first_dropped, bad) {
            (Some(a), Some(b)) => Some(if (b.y, b.x, b.sample) < (a.y, a.x, a.sample) {
                b
            } else {
                a
            }),
            (a, b) => a.or(b),
        };
    }
}

/// What one tile's pass produced besides its pixels.
struct TilePass {
    rays: RayCounters,
    dropped: u64,
    first_dropped: Option<BadSample>,
}

/// Adds samples `samples` of every pixel of `tile`.
fn render_tile_pass(
    scene: &dyn Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    tile: &mut TileAccumulator,
    samples: std::ops::Range<u32>,
) -> TilePass {
    let mut tracer = Tracer::new(scene);
    let mut out = TilePass {
        rays: RayCounters::default(),
        dropped: 0,
        first_dropped: None,
    };
    for j in 0..tile.h {
        for i in 0..tile.w {
            let (x, y) = (tile.x0 + i, tile.y0 + j);
            let pixel_index = y as u64 * camera.width as u64 + x as u64;
            let acc = &mut tile.pixels[(j * tile.w + i) as usize];
            for s in samples.clone() {
                // One camera sample: its own sampler, a stratified film position, a radiance
                // estimate; non-finite estimates are dropped and counted.
                let mut sampler = Sampler::new(settings.seed, pixel_index, s as u64);
                let pos = sample_position(x, y, s, settings.spp, settings.seed, &mut sampler);
                let ray = camera.ray(pos.x, pos.y);
                let l = integrator.radiance(&ray, &mut tracer, &mut sampler);
                if l.is_finite() {
                    acc.add(l);
                } else {
                    out.dropped += 1;
                    out.first_dropped
                        .get_or_insert(BadSample { x, y, sample: s });
                }
            }
        }
    }
    out.rays = tracer.counters;
    out
}

fn progress_bar(settings: &RenderSettings, start_spp: u32, tiles: usize) -> ProgressBar {
    if !settings.progress {
        return ProgressBar::hidden();
    }
    let (len, template) = match (settings.spp, settings.time_budget) {
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
/// true, or the time budget is spent. After each pass `after_pass` sees the accumulation
/// (for checkpoints); an error from it ends the render.
pub fn render_passes(
    scene: &dyn Scene,
    camera: &Camera,
    integrator: &mut dyn Integrator,
    settings: &RenderSettings,
    acc: &mut Accumulation,
    stop: &dyn Fn() -> bool,
    after_pass: &mut dyn FnMut(&Accumulation) -> anyhow::Result<()>,
) -> anyhow::Result<RenderStats> {
    render_passes_with_stats(
        scene,
        camera,
        integrator,
        settings,
        acc,
        stop,
        &mut |acc, _| after_pass(acc),
    )
}

/// [`render_passes`] whose callback also sees the statistics so far (elapsed time, samples,
/// rays, spp), for live displays of samples and rays per second.
pub fn render_passes_with_stats(
    scene: &dyn Scene,
    camera: &Camera,
    integrator: &mut dyn Integrator,
    settings: &RenderSettings,
    acc: &mut Accumulation,
    stop: &dyn Fn() -> bool,
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
    let start = Instant::now();
    loop {
        if settings.spp.is_some_and(|spp| acc.spp_done >= spp) || acc.spp_done == u32::MAX {
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
        // Work shared by the pass's pixels (photon maps), then one more sample in every
        // pixel, tiles in parallel.
        let pass = acc.spp_done;
        stats
            .rays
            .add(&pool.install(|| integrator.prepare_pass(scene, settings.seed, pass)));
        let integrator: &dyn Integrator = integrator;
        let samples = pass..pass + 1;
        let results: Vec<TilePass> = pool.install(|| {
            acc.tiles
                .par_iter_mut()
                .map(|tile| {
                    let r = render_tile_pass(
                        scene,
                        camera,
                        integrator,
                        settings,
                        tile,
                        samples.clone(),
                    );
                    if settings.spp.is_some() {
                        progress.inc(1);
                    }
                    r
                })
                .collect()
        });
        acc.spp_done += 1;
        for r in results {
            stats.rays.add(&r.rays);
            acc.note_dropped(r.first_dropped, r.dropped);
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
    stats.dropped = acc.dropped;
    stats.first_dropped = acc.first_dropped;
    Ok(stats)
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
        &mut |_| Ok(()),
    )?;
    Ok((acc.film(), stats))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::RenderScene;
    use crate::scene::parse_scene;
    use raylab_integrators::{Ray, Rgb};

    /// Returns 1 everywhere.
    struct One;

    impl Integrator for One {
        fn radiance(&self, ray: &Ray, tracer: &mut Tracer, sampler: &mut Sampler) -> Rgb {
            let _ = (tracer.camera(ray), sampler.next_1d());
            Rgb::ONE
        }
    }

    /// Returns NaN for rays well right of the image centre, 1 elsewhere.
    struct Poisoned;

    impl Integrator for Poisoned {
        fn radiance(&self, ray: &Ray, tracer: &mut Tracer, _sampler: &mut Sampler) -> Rgb {
            tracer.camera(ray);
            if ray.dir.x > 0.2 {
                Rgb::splat(f32::NAN)
            } else {
                Rgb::ONE
            }
        }
    }

    fn scene() -> (RenderScene, Camera) {
        let text = r#"(camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (20, 10)),
            materials: {"w": Lambert(albedo: (0.5, 0.5, 0.5))},
            environment: (1, 0.5, 0.25),
            entities: [(shape: Sphere(radius: 1), material: "w")])"#;
        let loaded = parse_scene(text, std::path::Path::new("t.ron")).unwrap();
        (RenderScene::build(&loaded), loaded.camera)
    }

    fn settings(spp: u32, threads: usize) -> RenderSettings {
        RenderSettings::fixed(spp, 3, Some(threads))
    }

    #[test]
    fn counts_every_camera_ray_and_averages_samples() {
        let (s, cam) = scene();
        let (film, stats) = render(&s, &cam, &mut One, &settings(5, 2)).unwrap();
        assert_eq!(stats.samples, 20 * 10 * 5);
        assert_eq!(stats.rays.camera, 1000);
        assert_eq!(stats.dropped, 0);
        assert!(film.pixels.iter().all(|p| *p == glam::Vec3::ONE));
        assert!(film.variance.iter().all(|v| *v == glam::Vec3::ZERO));
    }

    #[test]
    fn non_finite_samples_are_dropped_counted_and_located() {
        let (s, cam) = scene();
        let (film, stats) = render(&s, &cam, &mut Poisoned, &settings(4, 2)).unwrap();
        assert!(
            stats.dropped > 0 && stats.dropped < 800,
            "{}",
            stats.dropped
        );
        let first = stats.first_dropped.unwrap();
        // The first in raster order is on the top row, right of centre.
        assert_eq!(first.y, 0);
        assert!(first.x > 10);
        assert!(film.pixels.iter().all(|p| p.is_finite()));
        // Dropped samples count as zero in the average: the far right column is black.
        assert_eq!(film.pixels[19], glam::Vec3::ZERO);
    }

    #[test]
    fn image_does_not_depend_on_thread_count() {
        let (s, cam) = scene();
        let mut path = raylab_integrators::find("path")
            .unwrap()
            .instantiate(&[])
            .unwrap();
        let (a, _) = render(&s, &cam, path.as_mut(), &settings(3, 1)).unwrap();
        let (b, _) = render(&s, &cam, path.as_mut(), &settings(3, 2)).unwrap();
        let (c, _) = render(&s, &cam, path.as_mut(), &settings(3, 5)).unwrap();
        assert!(
            a.pixels.iter().any(|p| p.x > 0.0),
            "the scene must be lit for the test to mean anything"
        );
        assert_eq!(a, b);
        assert_eq!(a, c);
    }

    #[test]
    fn strata_are_visited_in_a_scrambled_order_that_covers_the_pixel_early() {
        // With 10000 spp (100 x 100 strata), the first 16 samples must already spread over
        // the pixel's height, not sit in its top row of strata.
        for (x, y) in [(0, 0), (5, 9), (1000, 3)] {
            let ys: Vec<f32> = (0..16)
                .map(|s| {
                    let mut sampler = Sampler::new(1, 0, s as u64);
                    sample_position(x, y, s, Some(10_000), 1, &mut sampler).y - y as f32
                })
                .collect();
            assert!(
                ys.iter().any(|v| *v > 0.5) && ys.iter().any(|v| *v < 0.5),
                "{ys:?}"
            );
        }
        // And the order is a permutation: every stratum exactly once.
        let mut seen = vec![false; 10_000];
        for s in 0..10_000 {
            let c = permute(s, 10_000, 77) as usize;
            assert!(!seen[c]);
            seen[c] = true;
        }
    }

    #[test]
    fn samples_are_stratified_within_the_pixel() {
        let mut positions = Vec::new();
        for s in 0..16 {
            let mut sampler = Sampler::new(0, 0, s);
            positions.push(sample_position(0, 0, s as u32, Some(16), 0, &mut sampler));
        }
        // 16 spp: one sample in each cell of a 4x4 grid.
        for j in 0..4 {
            for i in 0..4 {
                let n = positions
                    .iter()
                    .filter(|p| (p.x * 4.0) as u32 == i && (p.y * 4.0) as u32 == j)
                    .count();
                assert_eq!(n, 1, "cell ({i}, {j})");
            }
        }
    }
}
