//! `raylab bench`: rays per second (closest hit and occlusion, separately), samples per
//! second, BVH build time and memory, on standard cases, at 1 thread and at every core.
//!
//! Cases: the report's room and the Cornell box (tiny scenes: the cost is shading and
//! sampling), a procedural displaced icosphere of 1,310,720 triangles (traversal at scale) and
//! `scenes/instances.ron`, 300 instances of a 20,480-triangle mesh (two-level traversal; not
//! dumped, whose format holds flat triangles; Embree gets it as instances). Each is traced
//! with coherent rays (one camera ray through the centre of each pixel of a square image, in
//! raster order) and incoherent rays (origins uniform in the scene bounds, directions uniform
//! on the sphere), both from a fixed seed.
//!
//! `--dump DIR` writes the work so that any other engine can trace exactly the same rays:
//! `CASE.tris`: `u32` triangle count, then per triangle 9 `f32` (v0, v1, v2 xyz);
//! `CASE.spheres`: `u32` count, then per sphere 4 `f32` (centre xyz, radius);
//! `CASE-coherent.rays` and `CASE-incoherent.rays`: `u32` ray count, then per ray 8 `f32`
//! (origin xyz, unit direction xyz, tmin, tmax). All little-endian.

#[cfg(feature = "embree")]
mod embree;

use crate::accel::AccelKind;
use crate::render::{self, RenderSettings};
use crate::scene::RenderScene;
use crate::scene::{parse_scene, Camera, LoadedScene};
pub use crate::system::peak_rss;
use crate::system::{reset_peak_rss, resident_bytes};
use anyhow::{Context, Result};
use glam::Vec3A;
use raylab_integrators::sampling::uniform_sphere;
use raylab_integrators::{Ray, Sampler, Scene};
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What to measure.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Rays per measurement.
    pub rays: usize,
    /// Subdivision level of the large mesh (8: 1.31 M triangles).
    pub subdivisions: u32,
    /// Thread counts to measure at.
    pub threads: Vec<usize>,
    pub dump: Option<PathBuf>,
    /// Also run the Embree comparison (`embree` feature only; see `embree.rs`).
    pub embree: bool,
    /// Also build and trace every case with the obvhs backend.
    pub obvhs: bool,
    /// The cases to run, by name ([`CASES`]); all when empty.
    pub cases: Vec<String>,
    /// Embree comparison: rounds of raylab and Embree measured in turn, of which the medians
    /// are printed (at least 1).
    pub rounds: usize,
}

/// The standard cases' names, in the order they run.
pub const CASES: [&str; 4] = ["report-room", "cornell-box", "icosphere-1m", "instances"];

/// One benchmark scene.
pub struct Case {
    pub name: &'static str,
    pub scene: RenderScene,
    pub camera: Camera,
    pub build_time: Duration,
    /// Memory the build used at its peak beyond what was resident before it (Linux only).
    /// Memory the allocator kept from earlier cases is counted as resident and may be reused,
    /// so a case run alone (`--case`) can show a somewhat larger figure than in a full run.
    pub build_peak: Option<u64>,
    /// Whether `path` samples per second are measured (every case with a light).
    pub shade: bool,
    /// What `scene` was built from, kept only for `--dump` and the Embree comparison (which
    /// rebuilds it on each pool size), so that peak RSS is otherwise what it always was.
    pub source: Option<LoadedScene>,
}

impl Case {
    /// What the scene was built from (kept for `--dump` and `--embree` only).
    pub fn source(&self) -> Result<&LoadedScene> {
        self.source
            .as_ref()
            .ok_or_else(|| anyhow::anyhow!("bench: {}: the scene source was not kept", self.name))
    }

    /// Triangles the rays can meet: the flat ones and every instance's (an instanced mesh
    /// once per instance).
    pub fn placed_triangles(&self) -> usize {
        self.scene.stats.triangles + self.scene.stats.placed_triangles
    }

    /// Triangles held in memory: the flat ones and each instanced mesh once.
    pub fn stored_triangles(&self) -> usize {
        self.scene.stats.triangles + self.scene.stats.instanced_triangles
    }
}

/// A case from scene text; the build time covers the whole `RenderScene::build` (boxes, BVH,
/// arrays in BVH order, light table), not parsing.
/// The scene is kept in the case only if `keep_source` (for `--dump` and `--embree`).
fn embedded(name: &'static str, file: &str, text: &str, keep_source: bool) -> Result<Case> {
    let loaded = parse_scene(text, Path::new(file))?;
    let resident = resident_bytes();
    let peak_reset = reset_peak_rss();
    let start = Instant::now();
    let scene = RenderScene::build(&loaded);
    let build_time = start.elapsed();
    Ok(Case {
        name,
        build_time,
        build_peak: match peak_rss() {
            peak if peak_reset && resident > 0 && peak > 0 => Some(peak.saturating_sub(resident)),
            _ => None,
        },
        scene,
        camera: loaded.camera.clone(),
        shade: true,
        source: keep_source.then_some(loaded),
    })
}

/// The displaced icosphere, asked for through the scene format like any user scene, lit by
/// nothing (traversal only).
fn large_mesh(name: &'static str, subdivisions: u32, keep_source: bool) -> Result<Case> {
    let text = format!(
        r#"(
            camera: LookAt(eye: (0, 0, 3.5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (512, 512)),
            materials: {{"grey": Lambert(albedo: (0.5, 0.5, 0.5))}},
            entities: [(name: "icosphere", shape: Icosphere(subdivisions: {subdivisions}, displacement: 0.05), material: "grey")],
        )"#
    );
    let mut case = embedded(name, "icosphere.ron", &text, keep_source)?;
    case.shade = false;
    Ok(case)
}

/// One camera ray through the centre of each pixel of a `side x side` image, raster order.
pub fn coherent_rays(camera: &Camera, count: usize) -> Vec<Ray> {
    let side = (count as f64).sqrt().ceil() as u32;
    let cam = camera.with_resolution(side, side);
    (0..count as u32)
        .map(|i| cam.ray((i % side) as f32 + 0.5, (i / side) as f32 + 0.5))
        .collect()
}

/// Origins uniform in the bounds, directions uniform on the sphere, from a fixed seed.
pub fn incoherent_rays(bounds: (Vec3A, Vec3A), count: usize) -> Vec<Ray> {
    let mut s = Sampler::new(0xbe4c, 0, 0);
    let (lo, hi) = bounds;
    (0..count)
        .map(|_| {
            let t = Vec3A::new(s.next_1d(), s.next_1d(), s.next_1d());
            Ray::new(lo + (hi - lo) * t, uniform_sphere(s.next_2d()))
        })
        .collect()
}

/// Shortest timed run of [`rays_per_second`]: a small scene traces 1 M rays in about 40 ms,
/// short enough for the shared machine's hiccups to move one figure by 20% or more (and its
/// 2-thread figure to come out anywhere from 1.2x to 2.8x the 1-thread one).
const MIN_RUN: Duration = Duration::from_millis(200);
/// Most passes over the rays in one run: a tiny ray set (in tests) stops there, under
/// [`MIN_RUN`].
const MAX_PASSES: u32 = 64;

/// Rays per second of `trace` over `rays` on `threads` threads, and how many rays hit.
fn rays_per_second(
    rays: &[Ray],
    threads: usize,
    trace: &(dyn Fn(&Ray) -> bool + Sync),
) -> Result<(f64, usize)> {
    chunks_per_second(rays, threads, &|chunk| {
        chunk.iter().filter(|r| trace(r)).count()
    })
}

/// Rays of `chunk` that hit something, traced in batches of [`BATCH`] as the wavefront
/// integrators trace them ([`Scene::intersect_all`]).
fn batch_hits(scene: &RenderScene, chunk: &[Ray]) -> usize {
    in_batches(
        chunk,
        |rays, hits| scene.intersect_all(rays, hits),
        Option::is_some,
    )
}

/// Rays of `chunk` that something blocks, in batches as [`batch_hits`] traces them
/// ([`Scene::occluded_all`]).
fn batch_blocked(scene: &RenderScene, chunk: &[Ray]) -> usize {
    in_batches(
        chunk,
        |rays, blocked| scene.occluded_all(rays, blocked),
        |&b| b,
    )
}

/// How many answers of `trace`, run on `chunk` in batches of [`BATCH`], are `yes`.
fn in_batches<T: Copy + Default>(
    chunk: &[Ray],
    mut trace: impl FnMut(&[Ray], &mut [T]),
    yes: impl Fn(&T) -> bool,
) -> usize {
    let mut answers = [T::default(); BATCH];
    chunk
        .chunks(BATCH)
        .map(|rays| {
            let answers = &mut answers[..rays.len()];
            trace(rays, answers);
            answers.iter().filter(|a| yes(a)).count()
        })
        .sum()
}

/// Rays per batch in [`batch_hits`]: the wavefront's lanes.
const BATCH: usize = 64;

/// Rays per second of `trace`, which traces a chunk of `rays` and says how many hit, on
/// `threads` threads (chunks of 4096 shared out by rayon): a warm-up pass (whose count of hits
/// is returned with the rate), then the best of three runs, each of passes over the rays until
/// it has lasted [`MIN_RUN`] (or made [`MAX_PASSES`]).
fn chunks_per_second(
    rays: &[Ray],
    threads: usize,
    trace: &(dyn Fn(&[Ray]) -> usize + Sync),
) -> Result<(f64, usize)> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let pass = || pool.install(|| rays.par_chunks(4096).map(trace).sum::<usize>());
    let hits = pass();
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let start = Instant::now();
        let mut passes = 0;
        while passes < MAX_PASSES && (passes == 0 || start.elapsed() < MIN_RUN) {
            pass();
            passes += 1;
        }
        best = best.min(start.elapsed().as_secs_f64() / f64::from(passes));
    }
    Ok((rays.len() as f64 / best, hits))
}

fn write_f32s(path: &Path, count: usize, values: impl Iterator<Item = f32>) -> Result<()> {
    crate::output::atomic::write_atomic(path, |file| {
        let mut w = std::io::BufWriter::new(file);
        let write_all = || -> std::io::Result<()> {
            w.write_all(&(count as u32).to_le_bytes())?;
            for v in values {
                w.write_all(&v.to_le_bytes())?;
            }
            w.flush()
        };
        write_all().with_context(|| format!("{}: cannot write", path.display()))
    })
}

fn dump(dir: &Path, case: &Case, coherent: &[Ray], incoherent: &[Ray]) -> Result<()> {
    let source = case.source()?;
    let tris = crate::scene::flatten::flat_triangles(source);
    write_f32s(
        &dir.join(format!("{}.tris", case.name)),
        tris.len(),
        tris.iter()
            .flat_map(|t| [t.v0, t.v1, t.v2].into_iter().flat_map(|v| v.to_array())),
    )?;
    let spheres = crate::scene::flatten::flat_spheres(source);
    write_f32s(
        &dir.join(format!("{}.spheres", case.name)),
        spheres.len(),
        spheres.iter().flat_map(|(c, r)| [c.x, c.y, c.z, *r]),
    )?;
    for (kind, rays) in [("coherent", coherent), ("incoherent", incoherent)] {
        write_f32s(
            &dir.join(format!("{}-{kind}.rays", case.name)),
            rays.len(),
            rays.iter().flat_map(|r| {
                let (o, d) = (r.origin, r.dir);
                [o.x, o.y, o.z, d.x, d.y, d.z, 0.0, r.tmax]
            }),
        )?;
    }
    Ok(())
}

/// Runs every case and returns the report as text (also printed as it goes).
/// The obvhs backend on the same case and rays: its build and memory, and per ray kind and
/// thread count its rates with the raylab/obvhs ratios (measured right after raylab's).
fn compare_obvhs(
    case: &Case,
    rays: &[(&str, &Vec<Ray>)],
    threads: &[usize],
    say: &mut dyn FnMut(String),
) -> Result<()> {
    let start = Instant::now();
    let obvhs = RenderScene::build_with(case.source()?, AccelKind::Obvhs);
    let build = start.elapsed();
    let tris = case.stored_triangles().max(1);
    say(format!(
        "{:<14} obvhs build {:.1} ms (raylab/obvhs time {:.2}), geometry + BVH {:.1} MB ({:.0} bytes/triangle)",
        case.name,
        build.as_secs_f64() * 1e3,
        case.build_time.as_secs_f64() / build.as_secs_f64().max(1e-9),
        obvhs.memory_bytes() as f64 / 1e6,
        obvhs.memory_bytes() as f64 / tris as f64
    ));
    let ours = &case.scene;
    for (kind, rays) in rays {
        for &t in threads {
            let (c0, _) = rays_per_second(rays, t, &|r| ours.intersect(r).is_some())?;
            let (c1, _) = rays_per_second(rays, t, &|r| obvhs.intersect(r).is_some())?;
            let (o0, _) = rays_per_second(rays, t, &|r| ours.occluded(r))?;
            let (o1, _) = rays_per_second(rays, t, &|r| obvhs.occluded(r))?;
            say(format!(
                "{:<14} obvhs {:>10} {:>2} threads: closest {:.2} M/s (raylab/obvhs {:.2}), occlusion {:.2} M/s (raylab/obvhs {:.2})",
                case.name,
                kind,
                t,
                c1 / 1e6,
                c0 / c1,
                o1 / 1e6,
                o0 / o1
            ));
        }
    }
    Ok(())
}

pub fn run(opts: &BenchOptions) -> Result<String> {
    let mut out = String::new();
    let mut say = |line: String| {
        say!("{line}");
        out.push_str(&line);
        out.push('\n');
    };
    if let Some(dir) = &opts.dump {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create", dir.display()))?;
    }
    say(format!(
        "raylab bench: {} rays per measurement, best of 3 runs of at least {} ms; threads {:?}",
        opts.rays,
        MIN_RUN.as_millis(),
        opts.threads
    ));
    say(format!(
        "{:<14} {:>10} {:>10} {:>8} {:>14} {:>16} {:>10}",
        "case", "triangles", "rays", "threads", "closest M/s", "occlusion M/s", "hit rate"
    ));
    #[cfg(feature = "embree")]
    let mut embree_header = opts.embree.then(|| embree::header(opts.rounds));
    let keep = opts.embree || opts.obvhs || opts.dump.is_some();
    // In the order of CASES, whose names they are given.
    let cases: Vec<Box<dyn Fn(&'static str) -> Result<Case>>> = vec![
        Box::new(|name| {
            embedded(
                name,
                "scenes/report_room.ron",
                include_str!("../../scenes/report_room.ron"),
                keep,
            )
        }),
        Box::new(|name| {
            embedded(
                name,
                "scenes/cornell_box.ron",
                include_str!("../../scenes/cornell_box.ron"),
                keep,
            )
        }),
        Box::new(|name| large_mesh(name, opts.subdivisions, keep)),
        // Two-level traversal: 300 instances of a 20,480-triangle mesh (6.1 M placed).
        Box::new(|name| {
            embedded(
                name,
                "scenes/instances.ron",
                include_str!("../../scenes/instances.ron"),
                opts.embree || opts.obvhs,
            )
        }),
    ];
    let mut process_peak = 0;
    for (name, make) in CASES.into_iter().zip(cases) {
        if !opts.cases.is_empty() && !opts.cases.iter().any(|c| c == name) {
            continue;
        }
        // A case's build resets the process's peak (for its build peak): keep the maximum.
        process_peak = process_peak.max(peak_rss());
        let case = make(name)?;
        let instanced = case.scene.stats.instances > 0;
        let coherent = coherent_rays(&case.camera, opts.rays);
        let incoherent = incoherent_rays(case.scene.bounds(), opts.rays);
        match &opts.dump {
            Some(_) if instanced => say(format!(
                "{:<14} not dumped: the dump format holds flat triangles, not instances",
                case.name
            )),
            Some(dir) => dump(dir, &case, &coherent, &incoherent)?,
            None => {}
        }
        let scene = &case.scene;
        for (kind, rays) in [("coherent", &coherent), ("incoherent", &incoherent)] {
            for &t in &opts.threads {
                let (closest, hits) = rays_per_second(rays, t, &|r| scene.intersect(r).is_some())?;
                let (occlusion, _) = rays_per_second(rays, t, &|r| scene.occluded(r))?;
                let (batched, batch_hit) = chunks_per_second(rays, t, &|c| batch_hits(scene, c))?;
                let (batched_occl, blocked) =
                    chunks_per_second(rays, t, &|c| batch_blocked(scene, c))?;
                if batch_hit != hits || blocked != hits {
                    return Err(anyhow::anyhow!(
                        "{}: {batch_hit} and {blocked} of the {kind} rays hit in batches, {hits} one by one",
                        case.name
                    ));
                }
                say(format!(
                    "{:<14} {kind} {t} threads, in batches of {BATCH}: closest {:.2} M/s ({:.2}x one by one), occlusion {:.2} M/s ({:.2}x)",
                    case.name,
                    batched / 1e6,
                    batched / closest,
                    batched_occl / 1e6,
                    batched_occl / occlusion,
                ));
                say(format!(
                    "{:<14} {:>10} {:>10} {:>8} {:>14.2} {:>16.2} {:>9.1}%",
                    case.name,
                    case.placed_triangles(),
                    kind,
                    t,
                    closest / 1e6,
                    occlusion / 1e6,
                    100.0 * hits as f64 / rays.len() as f64
                ));
            }
        }
        let tris = case.stored_triangles().max(1);
        // Per triangle only where triangles dominate: a tiny scene's peak is the allocator's.
        let build_peak = match case.build_peak {
            Some(bytes) if tris >= 10_000 => format!(
                ", build peak +{:.1} MB ({:.0} bytes/triangle)",
                bytes as f64 / 1e6,
                bytes as f64 / tris as f64
            ),
            Some(bytes) => format!(", build peak +{:.1} MB", bytes as f64 / 1e6),
            None => String::new(),
        };
        process_peak = process_peak.max(peak_rss());
        say(format!(
            "{:<14} BVH build {:.1} ms, geometry + BVH {:.1} MB ({:.0} bytes/triangle){build_peak}, peak RSS so far {:.0} MB",
            case.name,
            case.build_time.as_secs_f64() * 1e3,
            scene.memory_bytes() as f64 / 1e6,
            scene.memory_bytes() as f64 / tris as f64,
            process_peak as f64 / 1e6
        ));
        let s = &scene.stats;
        if s.bvh_leaves > 0 && s.instances == 0 {
            // Every child of a node is a node or a leaf, and every node but the root a child.
            say(format!(
                "{:<14} BVH {} nodes of {:.2} children on average, {} leaves of {:.2} primitives",
                case.name,
                s.bvh_nodes,
                (s.bvh_nodes - 1 + s.bvh_leaves) as f64 / s.bvh_nodes as f64,
                s.bvh_leaves,
                (s.triangles + s.spheres) as f64 / s.bvh_leaves as f64
            ));
        }
        if opts.obvhs {
            compare_obvhs(
                &case,
                &[("coherent", &coherent), ("incoherent", &incoherent)],
                &opts.threads,
                &mut say,
            )?;
        }
        if case.shade {
            let mut integrator = raylab_integrators::find("path")?.instantiate(&[])?;
            let camera = case.camera.with_resolution(256, 256);
            for &t in &opts.threads {
                let (_, stats) = render::render(
                    scene,
                    &camera,
                    integrator.as_mut(),
                    &RenderSettings::fixed(8, 0, Some(t)),
                )?;
                say(format!(
                    "{:<14} path 256x256 8 spp, {} threads: {:.3} M samples/s, {:.2} M rays/s",
                    case.name,
                    t,
                    stats.samples_per_second() / 1e6,
                    stats.rays_per_second() / 1e6
                ));
            }
        }
        #[cfg(feature = "embree")]
        if opts.embree {
            for line in embree_header.take().into_iter().flatten() {
                say(line);
            }
            embree::compare(
                &case,
                &[("coherent", &coherent), ("incoherent", &incoherent)],
                &opts.threads,
                opts.rounds,
                &mut say,
            )?;
        }
    }
    Ok(out)
}
