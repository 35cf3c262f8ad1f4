//! The render loop: one parallel loop over tiles for every integrator.
//!
//! Per pixel, `spp` sub-samples are stratified on an `n x n` grid (`n = floor(sqrt(spp))`)
//! with a random jitter inside each cell; samples beyond `n^2` are uniform in the pixel. Each
//! sample has its own [`Sampler`] seeded from (seed, pixel, sample index) only, so images are
//! bit-identical whatever the thread count or tile order.

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
    pub spp: u32,
    pub seed: u64,
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
    /// Show a progress bar on stderr (only drawn on a terminal).
    pub progress: bool,
}

/// Where the first non-finite sample occurred.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BadSample {
    pub x: u32,
    pub y: u32,
    pub sample: u32,
}

/// What a render cost.
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub elapsed: Duration,
    pub samples: u64,
    pub rays: RayCounters,
    /// Samples dropped because they were NaN or infinite.
    pub dropped: u64,
    pub first_dropped: Option<BadSample>,
    pub threads: usize,
}

impl RenderStats {
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }

    pub fn rays_per_second(&self) -> f64 {
        self.rays.total() as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// Film position of sample `s` of `spp` in pixel `(x, y)`.
#[inline]
fn sample_position(x: u32, y: u32, s: u32, spp: u32, sampler: &mut Sampler) -> Vec2 {
    let n = (spp as f64).sqrt().floor() as u32;
    let jitter = sampler.next_2d();
    let offset = if s < n * n {
        (Vec2::new((s % n) as f32, (s / n) as f32) + jitter) / n as f32
    } else {
        jitter
    };
    Vec2::new(x as f32, y as f32) + offset
}

struct TileResult {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    pixels: Vec<(glam::Vec3, glam::Vec3)>,
    rays: RayCounters,
    dropped: u64,
    first_dropped: Option<BadSample>,
}

fn render_tile(
    scene: &dyn Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    (x0, y0): (u32, u32),
) -> TileResult {
    let w = TILE.min(camera.width - x0);
    let h = TILE.min(camera.height - y0);
    let mut tracer = Tracer::new(scene);
    let mut pixels = Vec::with_capacity((w * h) as usize);
    let mut dropped = 0;
    let mut first_dropped = None;
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let pixel_index = y as u64 * camera.width as u64 + x as u64;
            let mut acc = PixelAccumulator::default();
            for s in 0..settings.spp {
                let mut sampler = Sampler::new(settings.seed, pixel_index, s as u64);
                let pos = sample_position(x, y, s, settings.spp, &mut sampler);
                let ray = camera.ray(pos.x, pos.y);
                let l = integrator.radiance(&ray, &mut tracer, &mut sampler);
                if l.is_finite() {
                    acc.add(l);
                } else {
                    dropped += 1;
                    first_dropped.get_or_insert(BadSample { x, y, sample: s });
                }
            }
            pixels.push(acc.finish(settings.spp));
        }
    }
    TileResult {
        x0,
        y0,
        w,
        h,
        pixels,
        rays: tracer.counters,
        dropped,
        first_dropped,
    }
}

/// Renders `scene` through `camera` with `integrator`.
pub fn render(
    scene: &dyn Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
) -> anyhow::Result<(Film, RenderStats)> {
    let tiles: Vec<(u32, u32)> = (0..camera.height.div_ceil(TILE))
        .flat_map(|ty| (0..camera.width.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    let progress = if settings.progress {
        let bar = ProgressBar::new(tiles.len() as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} rendering [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar
    } else {
        ProgressBar::hidden()
    };

    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = settings.threads {
        builder = builder.num_threads(n);
    }
    let pool = builder.build()?;
    let threads = pool.current_num_threads();

    let start = Instant::now();
    let results: Vec<TileResult> = pool.install(|| {
        tiles
            .par_iter()
            .map(|&origin| {
                let r = render_tile(scene, camera, integrator, settings, origin);
                progress.inc(1);
                r
            })
            .collect()
    });
    let elapsed = start.elapsed();
    progress.finish_and_clear();

    // Assemble the film in tile order (deterministic), and the statistics.
    let mut film = Film::new(camera.width, camera.height);
    let mut stats = RenderStats {
        elapsed,
        samples: camera.width as u64 * camera.height as u64 * settings.spp as u64,
        threads,
        ..Default::default()
    };
    for t in results {
        for j in 0..t.h {
            for i in 0..t.w {
                let (mean, var) = t.pixels[(j * t.w + i) as usize];
                let idx = ((t.y0 + j) * camera.width + t.x0 + i) as usize;
                film.pixels[idx] = mean;
                film.variance[idx] = var;
            }
        }
        stats.rays.add(&t.rays);
        stats.dropped += t.dropped;
        // The first in raster order, whatever the tile order.
        stats.first_dropped = match (stats.first_dropped, t.first_dropped) {
            (Some(a), Some(b)) => Some(if (b.y, b.x, b.sample) < (a.y, a.x, a.sample) {
                b
            } else {
                a
            }),
            (a, b) => a.or(b),
        };
    }
    Ok((film, stats))
}
