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

/// Bytes of memory a render of `width x height` needs (film, tiles and the 8-bit copy).
pub fn memory_needed(width: u32, height: u32) -> u64 {
    // Film: mean + variance (2 x 12 B); tile results (24 B); PNG or EXR buffer (<= 12 B).
    width as u64 * height as u64 * 64
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
            entities: [(shape: Sphere(radius: 1), material: "w")])"#;
        let loaded = parse_scene(text, std::path::Path::new("t.ron")).unwrap();
        (RenderScene::build(&loaded), loaded.camera)
    }

    fn settings(spp: u32, threads: usize) -> RenderSettings {
        RenderSettings {
            spp,
            seed: 3,
            threads: Some(threads),
            progress: false,
        }
    }

    #[test]
    fn counts_every_camera_ray_and_averages_samples() {
        let (s, cam) = scene();
        let (film, stats) = render(&s, &cam, &One, &settings(5, 2)).unwrap();
        assert_eq!(stats.samples, 20 * 10 * 5);
        assert_eq!(stats.rays.camera, 1000);
        assert_eq!(stats.dropped, 0);
        assert!(film.pixels.iter().all(|p| *p == glam::Vec3::ONE));
        assert!(film.variance.iter().all(|v| *v == glam::Vec3::ZERO));
    }

    #[test]
    fn non_finite_samples_are_dropped_counted_and_located() {
        let (s, cam) = scene();
        let (film, stats) = render(&s, &cam, &Poisoned, &settings(4, 2)).unwrap();
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
        let path = raylab_integrators::find("path")
            .unwrap()
            .instantiate(&[])
            .unwrap();
        let (a, _) = render(&s, &cam, path.as_ref(), &settings(3, 1)).unwrap();
        let (b, _) = render(&s, &cam, path.as_ref(), &settings(3, 2)).unwrap();
        let (c, _) = render(&s, &cam, path.as_ref(), &settings(3, 5)).unwrap();
        assert_eq!(a, b);
        assert_eq!(a, c);
    }

    #[test]
    fn samples_are_stratified_within_the_pixel() {
        let mut positions = Vec::new();
        for s in 0..16 {
            let mut sampler = Sampler::new(0, 0, s);
            positions.push(sample_position(0, 0, s as u32, 16, &mut sampler));
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
