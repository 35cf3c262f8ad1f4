//! Instancing against flattening: a scene of instances and the same scene with every instance
//! written out as its own mesh must give the same hits (distance, point, normals, material)
//! and the same occlusion; and 100 instances must cost about the memory of one.

use super::*;
use crate::accel::AccelKind;
use crate::scene::parse_scene;
use crate::scene::RenderScene;
use raylab_integrators::{Ray, Sampler, Scene};
use std::fmt::Write as _;
use std::path::Path;

/// A panel of two triangles with vertex normals tilted apart (smooth shading to check).
const PANEL: &str = "Mesh(positions: [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], \
    indices: [(0, 1, 2), (0, 2, 3)], \
    normals: [(-0.5, -0.5, 1), (0.5, -0.5, 1), (0.5, 0.5, 1), (-0.3, 0.6, 1)])";

/// `n` placements (rotated, non-uniformly scaled) alternating a bumpy ball and the panel, with
/// a floor and a sphere as ordinary geometry. `instanced`: as `Instance`s of `meshes`, or
/// with each shape written on its entity.
fn scene_text(n: usize, subdivisions: u32, instanced: bool, seed: u64) -> String {
    let ball = format!("Icosphere(subdivisions: {subdivisions}, displacement: 0.2)");
    let mut s = Sampler::new(seed, 0, 0);
    let mut r = |lo: f32, hi: f32| lo + (hi - lo) * s.next_1d();
    let mut entities = String::from(
        r#"(name: "floor", shape: Quad(vertices: [(-9, -9, -1), (9, -9, -1), (9, 9, -1), (-9, 9, -1)]), material: "a"),
           (name: "orb", transform: (translate: (0, 0, 3)), shape: Sphere(radius: 0.7), material: "b"),"#,
    );
    for i in 0..n {
        let shape = match (instanced, i % 2) {
            (true, 0) => r#"Instance(mesh: "ball")"#.to_string(),
            (true, _) => r#"Instance(mesh: "panel")"#.to_string(),
            (false, 0) => ball.clone(),
            (false, _) => PANEL.to_string(),
        };
        let _ = write!(
            entities,
            r#"(name: "e{i}", transform: (translate: ({}, {}, {}), rotate: ({}, {}, {}), scale: ({}, {}, {})), shape: {shape}, material: "{}"),"#,
            r(-6.0, 6.0),
            r(-6.0, 6.0),
            r(-0.5, 2.0),
            r(0.0, 360.0),
            r(0.0, 360.0),
            r(0.0, 360.0),
            r(0.3, 1.2),
            r(0.3, 1.2),
            r(0.3, 1.2),
            if i % 3 == 0 { "a" } else { "b" },
        );
    }
    let meshes = if instanced {
        format!(r#"meshes: {{"ball": {ball}, "panel": {PANEL}}},"#)
    } else {
        String::new()
    };
    format!(
        r#"(camera: LookAt(eye: (0, 0, 10), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40),
          materials: {{"a": Lambert(albedo: (0.5, 0.5, 0.5)), "b": Lambert(albedo: (0.2, 0.7, 0.2))}},
          {meshes}
          entities: [{entities}])"#
    )
}

fn build(text: &str) -> RenderScene {
    RenderScene::build(&parse_scene(text, Path::new("instances.ron")).unwrap())
}

#[test]
fn instances_hit_exactly_what_their_flattened_copies_hit() {
    let instanced = build(&scene_text(24, 2, true, 5));
    let flat = build(&scene_text(24, 2, false, 5));
    assert_eq!(instanced.stats.instances, 24);
    assert_eq!(flat.stats.instances, 0);
    assert_eq!(
        instanced.stats.placed_triangles + instanced.stats.triangles,
        flat.stats.triangles
    );
    let close = |a: Vec3A, b: Vec3A, tol: f32| (a - b).length() <= tol;
    let mut sampler = Sampler::new(17, 0, 0);
    let (mut hits, mut smooth, mut mismatches, mut occluded) = (0, 0, 0, 0);
    let rays = 20_000;
    for i in 0..rays {
        let origin =
            Vec3A::new(sampler.next_1d(), sampler.next_1d(), sampler.next_1d()) * 14.0 - 7.0;
        let dir = raylab_integrators::sampling::uniform_sphere(sampler.next_2d());
        let tmax = if i % 2 == 0 {
            f32::INFINITY
        } else {
            sampler.next_1d() * 6.0
        };
        let ray = Ray {
            tmax,
            ..Ray::new(origin, dir)
        };
        match (flat.intersect(&ray), instanced.intersect(&ray)) {
            (None, None) => {}
            (Some(f), Some(g)) if (f.t - g.t).abs() <= 1e-4 * f.t.max(1.0) => {
                hits += 1;
                assert!(close(f.p, g.p, 1e-3), "ray {i}: {} vs {}", f.p, g.p);
                assert!(close(f.ng, g.ng, 1e-3), "ray {i}: ng {} vs {}", f.ng, g.ng);
                assert!(close(f.ns, g.ns, 2e-3), "ray {i}: ns {} vs {}", f.ns, g.ns);
                assert_eq!((f.material, f.light), (g.material, g.light), "ray {i}");
                smooth += usize::from(f.ns.dot(f.ng) < 0.999);
            }
            // Rays grazing a triangle edge may hit its neighbour in one and not the other.
            _ => mismatches += 1,
        }
        let blocked = flat.occluded(&ray);
        mismatches += usize::from(blocked != instanced.occluded(&ray));
        occluded += usize::from(blocked);
    }
    assert!(mismatches <= rays / 1000, "{mismatches} mismatches");
    assert!(hits > rays / 5 && hits < rays * 9 / 10, "hits {hits}");
    assert!(smooth > 100, "smooth-shaded hits {smooth}");
    assert!(occluded > rays / 5, "occluded {occluded}");
}

#[test]
fn the_obvhs_backend_hits_what_raylabs_bvh_hits_through_instances() {
    // Both test the same triangles with the same routines and move rays into instance space
    // alike: the same hits, bit for bit, and the same occlusion, but for rays that only the
    // BVHs' boxes decide (obvhs quantises its boxes: a ray starting 7e-5 above the floor's
    // flat box misses it there).
    let loaded = parse_scene(&scene_text(24, 2, true, 5), Path::new("instances.ron")).unwrap();
    let ours = RenderScene::build(&loaded);
    let obvhs = RenderScene::build_with(&loaded, AccelKind::Obvhs);
    assert_eq!(obvhs.accel_kind(), AccelKind::Obvhs);
    let (a, b) = (&ours.stats, &obvhs.stats);
    assert_eq!(
        (
            a.triangles,
            a.spheres,
            a.instances,
            a.placed_triangles,
            a.instanced_triangles
        ),
        (
            b.triangles,
            b.spheres,
            b.instances,
            b.placed_triangles,
            b.instanced_triangles
        )
    );
    assert_eq!(ours.bounds(), obvhs.bounds());
    let mut sampler = Sampler::new(23, 0, 0);
    let (mut hits, mut instance_hits, mut mismatches) = (0, 0, 0);
    let rays = 20_000;
    for i in 0..rays {
        let origin =
            Vec3A::new(sampler.next_1d(), sampler.next_1d(), sampler.next_1d()) * 14.0 - 7.0;
        let dir = raylab_integrators::sampling::uniform_sphere(sampler.next_2d());
        let tmax = [f32::INFINITY, sampler.next_1d() * 6.0][i % 2];
        let ray = Ray {
            tmax,
            ..Ray::new(origin, dir)
        };
        let (x, y) = (ours.intersect(&ray), obvhs.intersect(&ray));
        match (x, y) {
            (None, None) => {}
            (Some(x), Some(y)) => {
                assert_eq!(
                    (x.t.to_bits(), x.p, x.ng, x.ns, x.material, x.light),
                    (y.t.to_bits(), y.p, y.ng, y.ns, y.material, y.light),
                    "ray {i}"
                );
                hits += 1;
                // Neither on the floor (z = -1) nor on the orb (radius 0.7 at z = 3): an instance.
                let on_orb = ((x.p - Vec3A::new(0.0, 0.0, 3.0)).length() - 0.7).abs() < 1e-3;
                instance_hits += usize::from((x.p.z + 1.0).abs() > 1e-4 && !on_orb);
            }
            _ => mismatches += 1,
        }
        mismatches += usize::from(ours.occluded(&ray) != obvhs.occluded(&ray));
    }
    assert!(mismatches <= rays / 2000, "{mismatches} mismatches");
    assert!(
        hits > 4000 && instance_hits > 500,
        "{hits} hits, {instance_hits} on instances"
    );
}

#[test]
fn a_hundred_instances_cost_about_one_copy_of_the_mesh() {
    // 20,480 triangles a ball.
    let mesh = |n: usize| {
        let mut entities = String::new();
        for i in 0..n {
            let _ = write!(
                entities,
                r#"(transform: (translate: ({}, {}, 0), rotate: (0, 0, {i})), shape: Instance(mesh: "ball"), material: "m"),"#,
                (i % 10) as f32 * 2.5,
                (i / 10) as f32 * 2.5
            );
        }
        build(&format!(
            r#"(camera: LookAt(eye: (0, 0, 30), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40),
              materials: {{"m": Lambert(albedo: (0.5, 0.5, 0.5))}},
              meshes: {{"ball": Icosphere(subdivisions: 5), "unused": Icosphere(subdivisions: 9)}},
              entities: [{entities}])"#
        ))
    };
    let (one, hundred) = (mesh(1), mesh(100));
    assert_eq!(hundred.stats.placed_triangles, 100 * 20_480);
    assert_eq!(hundred.stats.instanced_triangles, 20_480);
    let (a, b) = (one.memory_bytes(), hundred.memory_bytes());
    // One copy is ~57 bytes a triangle (1.2 MB); an instance adds a few dozen bytes (its
    // transform, mesh, material and its share of the top-level BVH).
    assert!(a > 20_480 * 40, "one instance: {a} bytes");
    assert!(
        b < a + a / 50 + 100 * 200,
        "100 instances: {b} bytes, one: {a}"
    );
}

#[test]
fn the_instance_build_does_not_depend_on_the_thread_count() {
    let loaded = parse_scene(&scene_text(40, 3, true, 9), Path::new("instances.ron")).unwrap();
    let build = |threads: usize| {
        RenderScene::build_on_threads(&loaded, AccelKind::Raylab, Some(threads)).unwrap()
    };
    let (a, b) = (build(1), build(2));
    let mut sampler = Sampler::new(3, 0, 0);
    for _ in 0..2000 {
        let origin = Vec3A::new(sampler.next_1d(), sampler.next_1d(), 9.0) * 10.0 - 5.0;
        let dir = raylab_integrators::sampling::uniform_sphere(sampler.next_2d());
        let ray = Ray::new(origin, dir);
        let (x, y) = (a.intersect(&ray), b.intersect(&ray));
        assert_eq!(
            x.map(|h| (h.t, h.ng, h.material)),
            y.map(|h| (h.t, h.ng, h.material))
        );
    }
}

#[test]
fn bounds_of_a_scene_of_far_instances_do_not_reach_the_origin() {
    // A scene without instances once had instance bounds of a zero box at the origin, so every
    // scene's bounds (the environment light's radius, the bench's rays) took the origin in.
    let text = format!(
        r#"(camera: LookAt(eye: (0, 0, 30), look_at: (20, 20, 20), up: (0, 1, 0), fov: 40),
          materials: {{"a": Lambert(albedo: (0.5, 0.5, 0.5))}},
          meshes: {{"panel": {PANEL}}},
          entities: [(name: "p", transform: (translate: (20, 20, 20)), shape: Instance(mesh: "panel"), material: "a"),
                     (name: "q", transform: (translate: (22, 20, 20)), shape: Quad(vertices: [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]), material: "a")])"#
    );
    let scene = RenderScene::build(&parse_scene(&text, Path::new("far.ron")).unwrap());
    let (lo, hi) = scene.bounds();
    assert_eq!(
        (lo, hi),
        (Vec3A::new(19.0, 19.0, 20.0), Vec3A::new(23.0, 21.0, 20.0))
    );
    // Only instances, and only flat geometry.
    for entities in [
        r#"(name: "p", transform: (translate: (20, 20, 20)), shape: Instance(mesh: "panel"), material: "a")"#,
        r#"(name: "q", transform: (translate: (22, 20, 20)), shape: Quad(vertices: [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]), material: "a")"#,
    ] {
        let text = format!(
            r#"(camera: LookAt(eye: (0, 0, 30), look_at: (20, 20, 20), up: (0, 1, 0), fov: 40),
              materials: {{"a": Lambert(albedo: (0.5, 0.5, 0.5))}},
              meshes: {{"panel": {PANEL}}},
              entities: [{entities}])"#
        );
        let (lo, hi) =
            RenderScene::build(&parse_scene(&text, Path::new("far.ron")).unwrap()).bounds();
        assert!(
            lo.min_element() >= 19.0 && hi.max_element() <= 23.0,
            "{lo} {hi}"
        );
    }
}

#[test]
fn batches_through_instances_find_what_each_ray_finds() {
    // A stream of rays walks the flat tree, then the instances ray by ray: the same answers
    // as one ray at a time, bit for bit.
    let mut scene = build(&scene_text(24, 2, true, 5));
    match std::sync::Arc::get_mut(&mut scene.accel).expect("not shared") {
        crate::accel::Accel::Raylab(w) => w.stream_from = 0,
        crate::accel::Accel::Obvhs(_) => unreachable!(),
    }
    let rays = super::tests::random_rays(23, 2000, 7.0, 4.0);
    let (found, stopped) = super::tests::batches_match_single_rays(&scene, &rays, 64);
    assert!(
        found > 400 && stopped > 400,
        "{found} hits, {stopped} blocked"
    );
}
