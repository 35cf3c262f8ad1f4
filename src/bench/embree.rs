//! `raylab bench --embree` (the `embree` cargo feature): the same work traced by Intel Embree 3
//! (Debian's libembree3, through the safe `embree3` crate), as a yardstick for raylab's BVH.
//!
//! Per case and per thread count N:
//! - Build: an Embree device configured with `threads=N` (threads started up front) gets
//!   exactly the primitives raylab traces: the scene's flat triangles as a triangle soup
//!   (three vertices per triangle, like raylab's own storage), its spheres as one
//!   `SPHERE_POINT` geometry (x, y, z, radius), and for instancing one scene per mesh asset
//!   with one `INSTANCE` geometry per placement (Embree's two-level BVH, as raylab's). Timed:
//!   the scene commits (the mesh scenes' and the top scene's), which are Embree's BVH builds
//!   (default quality), against raylab's `RenderScene::build` on an N-thread rayon pool; best
//!   of three each. Memory: raylab's `memory_bytes` against what Embree's memory
//!   monitor callback counted on that device (geometry buffers + BVH) after the commit, and
//!   its peak during the commit.
//! - Rays: the same coherent and incoherent rays as raylab's table, traced with Embree's
//!   single-ray `rtcIntersect1` (closest hit) and `rtcOccluded1` (any hit), with the context's
//!   coherent/incoherent flag to match, through `rays_per_second`: an N-thread rayon pool,
//!   chunks of 4096, best of 3 runs of at least `MIN_RUN`. raylab is measured again right
//!   next to each Embree measurement (same function, same pool size), so the ratio compares
//!   runs seconds apart on the same, possibly busy, machine. Ratio = raylab / Embree: above 1,
//!   raylab is faster. With `--rounds N` the two are measured in turn N times: the line gives
//!   the median rates and the median of the rounds' ratios, and a second line their range.
//! - Agreement (once per case and ray kind): the fraction of rays on which raylab and Embree
//!   agree on hit or miss and, when both hit, on the distance within 1e-4 relative. Rays
//!   grazing an edge shared by two triangles, or a sphere's silhouette, may differ: the two
//!   engines round differently there.
//!
//! - Packets (once per case, ray kind and thread count, after the rounds): the same rays in
//!   consecutive packets of 16 through `rtcIntersect16` / `rtcOccluded16`, as Mitsuba 3's
//!   LLVM variant calls Embree from its wavefronts (`benches/mitsuba_cornell.py` compares
//!   raylab's `path` with it): their rates, against Embree's single rays and raylab's. Their
//!   hit counts must be the single rays' (checked; an error otherwise).
//!
//! Not done: Embree's stream APIs, raylab tracing packets (it traces single rays), flush-to-zero /
//! denormals-are-zero on the worker threads (Embree's performance advice; raylab does not set
//! it either), and the robust or compact scene flags.

use super::{batch_blocked, batch_hits, chunks_per_second, rays_per_second, Case, BATCH, MIN_RUN};
use crate::scene::components::{FileOrder, Instanced, Transform};
use crate::scene::RenderScene;
use anyhow::{anyhow, Result};
use embree3::{
    BufferUsage, Config, Device, DeviceProperty, Format, GeometryKind, IntersectContext, RayHit,
};
use glam::Mat4;
use obvhs::triangle::Triangle;
use raylab_integrators::{Ray, Scene};
use rayon::prelude::*;
use std::sync::atomic::{AtomicIsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Bytes Embree says it holds on one device, and the most it held.
#[derive(Default)]
struct Memory {
    now: AtomicIsize,
    peak: AtomicIsize,
}

/// A committed Embree scene and what its build cost.
struct Built {
    scene: embree3::Scene<'static>,
    /// The scenes of the instanced meshes, one per mesh asset (kept with the scene that
    /// instances them).
    _meshes: Vec<embree3::Scene<'static>>,
    /// The scene commit (Embree's BVH build).
    commit: Duration,
    /// Device memory after the commit and its peak (both include the geometry buffers).
    bytes: isize,
    peak: isize,
}

fn embree_err(what: &str) -> impl Fn(embree3::Error) -> anyhow::Error + '_ {
    move |e| anyhow!("Embree: {what}: {e:?}")
}

/// Bytes for people: kB below a megabyte.
fn size(bytes: f64) -> String {
    if bytes < 1e6 {
        format!("{:.1} kB", bytes / 1e3)
    } else {
        format!("{:.1} MB", bytes / 1e6)
    }
}

/// Milliseconds with three significant digits or so.
fn ms(d: Duration) -> String {
    let ms = d.as_secs_f64() * 1e3;
    if ms < 10.0 {
        format!("{ms:.3} ms")
    } else {
        format!("{ms:.1} ms")
    }
}

/// The Embree version string of a device ("3.13.5").
fn version(device: &Device) -> String {
    match device.get_property(DeviceProperty::VERSION) {
        Ok(v) => format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100),
        Err(_) => "3 (unknown version)".into(),
    }
}

/// A fresh `threads`-thread device holding the case's triangles and spheres, committed.
fn build_once(case: &Case, threads: usize) -> Result<Built> {
    let device = Device::with_config(Config {
        threads: threads as u32,
        // Thread creation belongs to the device, not to the build being timed.
        start_threads: true,
        ..Config::default()
    })
    .map_err(embree_err("cannot create a device"))?;
    let memory = Arc::new(Memory::default());
    let counter = memory.clone();
    device.set_memory_monitor_function(move |bytes, _post| {
        // Embree reports allocations (> 0) before they happen and frees (< 0) after; we never
        // cancel, so every report is real.
        let now = counter.now.fetch_add(bytes, Ordering::Relaxed) + bytes;
        counter.peak.fetch_max(now, Ordering::Relaxed);
        true
    });
    let mut scene = device
        .create_scene()
        .map_err(embree_err("cannot create a scene"))?;

    let source = case.source()?;
    let tris = crate::scene::flatten::flat_triangles(source);
    if !tris.is_empty() {
        scene.attach_geometry(&triangle_geometry(&device, &tris)?);
    }
    // Instanced meshes: one scene per mesh asset, committed (its BVH built) once, and one
    // instance geometry per placement, with its local-to-world transform.
    let start = Instant::now();
    let mut meshes = Vec::with_capacity(source.meshes.len());
    for mesh in &source.meshes {
        let mut child = device
            .create_scene()
            .map_err(embree_err("cannot create a mesh scene"))?;
        let tris: Vec<Triangle> = mesh
            .triangles
            .iter()
            .map(|&[v0, v1, v2]| Triangle { v0, v1, v2 })
            .collect();
        child.attach_geometry(&triangle_geometry(&device, &tris)?);
        child.commit();
        meshes.push(child);
    }
    let mut instances = source
        .world
        .query::<(&FileOrder, &Instanced, &Transform)>()
        .iter()
        .map(|(o, i, t)| (*o, i.mesh as usize, t.matrix()))
        .collect::<Vec<_>>();
    instances.sort_by_key(|i| i.0);
    for (_, mesh, local_to_world) in instances {
        let mut g = device
            .create_geometry(GeometryKind::INSTANCE)
            .map_err(embree_err("instance geometry"))?;
        g.set_instanced_scene(&meshes[mesh]);
        g.set_transform(0, &Mat4::from(local_to_world).to_cols_array());
        scene.attach_geometry(&g.commit());
    }
    let meshes_commit = start.elapsed();

    let spheres = crate::scene::flatten::flat_spheres(source);
    if !spheres.is_empty() {
        let mut g = device
            .create_geometry(GeometryKind::SPHERE_POINT)
            .map_err(embree_err("sphere geometry"))?;
        let mut points = g
            .set_new_buffer::<[f32; 4]>(BufferUsage::VERTEX, 0, Format::FLOAT4, 16, spheres.len())
            .map_err(embree_err("sphere buffer"))?;
        for (out, (c, r)) in points.iter_mut().zip(&spheres) {
            *out = [c.x, c.y, c.z, *r];
        }
        scene.attach_geometry(&g.commit());
    }

    let start = Instant::now();
    scene.commit();
    let commit = meshes_commit + start.elapsed();
    match device.get_error() {
        embree3::Error::NONE => {}
        e => return Err(anyhow!("Embree: scene commit failed: {e:?}")),
    }
    Ok(Built {
        scene,
        _meshes: meshes,
        commit,
        bytes: memory.now.load(Ordering::Relaxed),
        peak: memory.peak.load(Ordering::Relaxed),
    })
}

/// A committed triangle-soup geometry of `tris` (three vertices per triangle, like raylab's
/// own storage).
fn triangle_geometry(device: &Device, tris: &[Triangle]) -> Result<embree3::Geometry<'static>> {
    let mut g = device
        .create_geometry(GeometryKind::TRIANGLE)
        .map_err(embree_err("triangle geometry"))?;
    let mut vertices = g
        .set_new_buffer::<[f32; 3]>(BufferUsage::VERTEX, 0, Format::FLOAT3, 12, 3 * tris.len())
        .map_err(embree_err("vertex buffer"))?;
    for (out, t) in vertices.chunks_exact_mut(3).zip(tris) {
        out[0] = t.v0.to_array();
        out[1] = t.v1.to_array();
        out[2] = t.v2.to_array();
    }
    let mut indices = g
        .set_new_buffer::<[u32; 3]>(BufferUsage::INDEX, 0, Format::UINT3, 12, tris.len())
        .map_err(embree_err("index buffer"))?;
    for (i, out) in indices.iter_mut().enumerate() {
        let v = 3 * i as u32;
        *out = [v, v + 1, v + 2];
    }
    Ok(g.commit())
}

/// Best of three Embree builds (the last one is kept to trace with).
fn build(case: &Case, threads: usize) -> Result<Built> {
    let mut built = build_once(case, threads)?;
    let mut best = built.commit;
    for _ in 1..3 {
        built = build_once(case, threads)?;
        best = best.min(built.commit);
    }
    built.commit = best;
    Ok(built)
}

/// Best of three raylab builds of the case on a `threads`-thread pool.
fn raylab_build(case: &Case, threads: usize) -> Result<Duration> {
    let source = case.source()?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let mut best = Duration::MAX;
    for _ in 0..3 {
        let took = pool.install(|| {
            let start = Instant::now();
            let scene = RenderScene::build(source);
            let took = start.elapsed();
            drop(scene);
            took
        });
        best = best.min(took);
    }
    Ok(best)
}

fn embree_ray(r: &Ray) -> embree3::Ray {
    embree3::Ray::segment(r.origin.to_array(), r.dir.to_array(), 0.0, r.tmax)
}

/// Embree's closest-hit distance along `r`, if it hits.
fn embree_hit(scene: &embree3::Scene, context: fn() -> IntersectContext, r: &Ray) -> Option<f32> {
    let mut rh = RayHit::from(embree_ray(r));
    scene.intersect(&mut context(), &mut rh);
    rh.hit.is_valid().then_some(rh.ray.tfar)
}

/// `rays` (at most 16) as one Embree packet, the rest of its lanes invalid.
fn packet16(rays: &[Ray]) -> (embree3::Ray16, embree3::ValidMaskN<16>) {
    let mut p = embree3::Ray16::empty();
    let mut valid = embree3::ValidMaskN::<16>::all_active();
    for (i, r) in rays.iter().enumerate() {
        (p.org_x[i], p.org_y[i], p.org_z[i]) = (r.origin.x, r.origin.y, r.origin.z);
        (p.dir_x[i], p.dir_y[i], p.dir_z[i]) = (r.dir.x, r.dir.y, r.dir.z);
        (p.tnear[i], p.tfar[i]) = (0.0, r.tmax);
    }
    for lane in &mut valid.lanes_mut()[rays.len()..] {
        *lane = embree3::ValidMask::Invalid;
    }
    (p, valid)
}

/// How many of `rays` (at most 16) hit, traced as one packet by `rtcIntersect16`.
fn embree_hits16(scene: &embree3::Scene, context: fn() -> IntersectContext, rays: &[Ray]) -> usize {
    let (ray, valid) = packet16(rays);
    let mut rh = embree3::RayHit16 {
        ray,
        hit: embree3::Hit16::new(),
    };
    scene.intersect16(&mut context(), &mut rh, &valid);
    (0..rays.len())
        .filter(|&i| rh.hit.geomID[i] != embree3::INVALID_ID)
        .count()
}

/// How many of `rays` (at most 16) are occluded, traced as one packet by `rtcOccluded16`
/// (which sets an occluded ray's `tfar` to minus infinity).
fn embree_occluded16(
    scene: &embree3::Scene,
    context: fn() -> IntersectContext,
    rays: &[Ray],
) -> usize {
    let (mut ray, valid) = packet16(rays);
    scene.occluded16(&mut context(), &mut ray, &valid);
    (0..rays.len())
        .filter(|&i| ray.tfar[i] == f32::NEG_INFINITY)
        .count()
}

/// Measures Embree's packets of 16 on `rays` and prints them against its single rays' and
/// raylab's median rates (`[closest, occlusion]` each); an error if a packet query's hit
/// count is not its single rays'.
fn packets(
    (case, kind, threads): (&str, &str, usize),
    rays: &[Ray],
    scene: &embree3::Scene,
    context: fn() -> IntersectContext,
    single: [f64; 2],
    ours: [f64; 2],
    say: &mut dyn FnMut(String),
) -> Result<()> {
    let by_packets = |trace: &(dyn Fn(&[Ray]) -> usize + Sync)| {
        chunks_per_second(rays, threads, &|chunk| chunk.chunks(16).map(trace).sum())
    };
    let closest = by_packets(&|p| embree_hits16(scene, context, p))?;
    let occlusion = by_packets(&|p| embree_occluded16(scene, context, p))?;
    let single_hits = rays
        .par_iter()
        .filter(|r| embree_hit(scene, context, r).is_some())
        .count();
    if closest.1 != single_hits || occlusion.1 != single_hits {
        return Err(anyhow!(
            "Embree's packets of 16 found {} and {} hits on {case}'s {kind} rays, its single rays {single_hits}",
            closest.1,
            occlusion.1
        ));
    }
    let [(c, _), (o, _)] = [closest, occlusion];
    say(format!(
        "{:<6} {:<14} {kind} {threads} threads, Embree packets of 16 (rtcIntersect16 / rtcOccluded16, as Mitsuba 3's LLVM variant): closest {:.2} M/s ({:.2}x its single rays, raylab/packets {:.2}), occlusion {:.2} M/s ({:.2}x, {:.2}), same hits",
        "embree",
        case,
        c / 1e6,
        c / single[0],
        ours[0] / c,
        o / 1e6,
        o / single[1],
        ours[1] / o,
    ));
    Ok(())
}

/// The median of some rates (the mean of the middle two for an even count).
fn median(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Ray kinds and the Embree context flag that matches them.
fn context_for(kind: &str) -> fn() -> IntersectContext {
    if kind == "coherent" {
        IntersectContext::coherent
    } else {
        IntersectContext::incoherent
    }
}

/// The header of the comparison table (printed once, before the first case).
pub(super) fn header(rounds: usize) -> Vec<String> {
    let version = Device::new()
        .map(|d| version(&d))
        .unwrap_or_else(|_| "3 (no device)".into());
    let rounds = if rounds > 1 {
        format!("median rates and ratios of {rounds} rounds of both in turn")
    } else {
        "one round".to_string()
    };
    vec![
        format!(
            "embree comparison: Embree {version}, single rays (rtcIntersect1 / rtcOccluded1), the same rays, pool, chunks and timing (best of 3 runs of at least {} ms); raylab re-measured next to each; {rounds}; ratio = raylab / Embree (> 1: raylab faster)",
            MIN_RUN.as_millis(),
        ),
        format!(
            "{:<6} {:<14} {:>10} {:>8} {:>14} {:>14} {:>7} {:>14} {:>14} {:>7}",
            "embree",
            "case",
            "rays",
            "threads",
            "raylab closest",
            "Embree closest",
            "ratio",
            "raylab occl.",
            "Embree occl.",
            "ratio"
        ),
    ]
}

/// Runs the comparison for one case (raylab's own table for it has been printed).
pub(super) fn compare(
    case: &Case,
    kinds: &[(&str, &[Ray])],
    threads: &[usize],
    rounds: usize,
    say: &mut dyn FnMut(String),
) -> Result<()> {
    let ours = &case.scene;
    // Memory per triangle held (an instanced mesh counts once).
    let tris = case.stored_triangles().max(1) as f64;
    let mut last = None;
    for &t in threads {
        let built = build(case, t)?;
        let raylab_time = raylab_build(case, t)?;
        say(format!(
            "{:<6} {:<14} build, {} threads: raylab {}, Embree commit {}; memory raylab {} ({:.0} bytes/triangle), Embree {} ({:.0} bytes/triangle, peak during commit {})",
            "embree",
            case.name,
            t,
            ms(raylab_time),
            ms(built.commit),
            size(ours.memory_bytes() as f64),
            ours.memory_bytes() as f64 / tris,
            size(built.bytes as f64),
            built.bytes as f64 / tris,
            size(built.peak as f64),
        ));
        let theirs = &built.scene;
        for &(kind, rays) in kinds {
            let context = context_for(kind);
            // Per round: raylab closest, Embree closest, raylab occlusion, Embree occlusion,
            // raylab's closest and occlusion in batches.
            let mut measured: Vec<[f64; 6]> = Vec::with_capacity(rounds);
            for _ in 0..rounds {
                measured.push([
                    rays_per_second(rays, t, &|r| ours.intersect(r).is_some())?.0,
                    rays_per_second(rays, t, &|r| embree_hit(theirs, context, r).is_some())?.0,
                    rays_per_second(rays, t, &|r| ours.occluded(r))?.0,
                    rays_per_second(rays, t, &|r| {
                        theirs.occluded(&mut context(), &mut embree_ray(r))
                    })?
                    .0,
                    chunks_per_second(rays, t, &|c| batch_hits(ours, c))?.0,
                    chunks_per_second(rays, t, &|c| batch_blocked(ours, c))?.0,
                ]);
            }
            // Median rates, and the median of the rounds' ratios: each round's two figures were
            // taken seconds apart, so its ratio is the one to trust.
            let rate = |i: usize| median(measured.iter().map(|m| m[i]));
            let ratio = |i: usize| median(measured.iter().map(|m| m[i] / m[i + 1]));
            let (our_closest, their_closest) = (rate(0), rate(1));
            let (our_occl, their_occl) = (rate(2), rate(3));
            say(format!(
                "{:<6} {:<14} {:>10} {:>8} {:>14.2} {:>14.2} {:>7.2} {:>14.2} {:>14.2} {:>7.2}",
                "embree",
                case.name,
                kind,
                t,
                our_closest / 1e6,
                their_closest / 1e6,
                ratio(0),
                our_occl / 1e6,
                their_occl / 1e6,
                ratio(2),
            ));
            if rounds > 1 {
                let range = |i: usize| {
                    let ratios = measured.iter().map(|m| m[i] / m[i + 1]);
                    let lo = ratios.clone().fold(f64::INFINITY, f64::min);
                    (lo, ratios.fold(0.0, f64::max))
                };
                let ((cl, ch), (ol, oh)) = (range(0), range(2));
                say(format!(
                    "{:<6} {:<14} {kind} {t} threads, ratios over {rounds} rounds: closest {cl:.2}-{ch:.2}, occlusion {ol:.2}-{oh:.2}",
                    "embree", case.name
                ));
            }
            let batch_ratio = |i: usize, of: usize| median(measured.iter().map(|m| m[i] / m[of]));
            say(format!(
                "{:<6} {:<14} {kind} {t} threads, raylab in batches of {BATCH} (the wavefront's traversal) against Embree's single rays: closest {:.2} M/s ({:.2}x), occlusion {:.2} M/s ({:.2}x)",
                "embree",
                case.name,
                rate(4) / 1e6,
                batch_ratio(4, 1),
                rate(5) / 1e6,
                batch_ratio(5, 3),
            ));
            packets(
                (case.name, kind, t),
                rays,
                theirs,
                context,
                [their_closest, their_occl],
                [our_closest, our_occl],
                say,
            )?;
        }
        last = Some(built);
    }
    let Some(built) = last else {
        return Ok(());
    };
    for &(kind, rays) in kinds {
        let context = context_for(kind);
        // (hit/miss differ, both hit at distances more than 1e-4 relative apart)
        let (miss, far) = rays
            .par_iter()
            .map(|r| {
                match (
                    ours.intersect(r).map(|h| h.t),
                    embree_hit(&built.scene, context, r),
                ) {
                    (None, None) => (0, 0),
                    (Some(a), Some(b)) if (a - b).abs() <= 1e-4 * a.abs().max(b.abs()) => (0, 0),
                    (Some(_), Some(_)) => (0, 1),
                    _ => (1, 0),
                }
            })
            .reduce(|| (0usize, 0usize), |a, b| (a.0 + b.0, a.1 + b.1));
        let n = rays.len().max(1);
        say(format!(
            "{:<6} {:<14} agreement {}: {:.4}% of {} rays (hit/miss differ on {}, distances on {})",
            "embree",
            case.name,
            kind,
            100.0 * (n - miss - far) as f64 / n as f64,
            rays.len(),
            miss,
            far
        ));
    }
    Ok(())
}
