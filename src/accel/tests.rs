//! The build step against brute force: thousands of random rays, closest hit and occlusion.

use super::*;
use crate::accel::AccelKind;
use crate::scene::components::WorldShape;
use crate::scene::parse_scene;
use crate::scene::RenderScene;
use glam::Vec3A;
use packet::LaneData;
use raylab_integrators::light::{Planar, SphereLight};
use raylab_integrators::Light;
use raylab_integrators::{Ray, Sampler, Scene};
use std::fmt::Write as _;
use std::path::Path;

/// The scene's accelerator, which these tests build as raylab's own.
fn wide(scene: &RenderScene) -> &WideBvh {
    match &*scene.accel {
        Accel::Raylab(w) => w,
        Accel::Obvhs(_) => unreachable!("built with RenderScene::build"),
    }
}

/// A scene of random triangles (one mesh), spheres, and disks and cylinders (alternately), as
/// RON text. The analytic shapes emit, in that order.
fn random_scene(triangles: usize, spheres: usize, quadrics: usize, seed: u64) -> String {
    let mut s = Sampler::new(seed, 0, 0);
    let mut r = |scale: f32| (s.next_1d() * 2.0 - 1.0) * scale;
    let mut positions = String::new();
    let mut indices = String::new();
    for i in 0..triangles {
        let c = Vec3A::new(r(4.0), r(4.0), r(4.0));
        for _ in 0..3 {
            let p = c + Vec3A::new(r(0.6), r(0.6), r(0.6));
            let _ = write!(positions, "({}, {}, {}),", p.x, p.y, p.z);
        }
        let _ = write!(indices, "({}, {}, {}),", 3 * i, 3 * i + 1, 3 * i + 2);
    }
    let mut entities = format!(
        r#"(name: "soup", shape: Mesh(positions: [{positions}], indices: [{indices}]), material: "m"),"#
    );
    for i in 0..spheres {
        let _ = write!(
            entities,
            r#"(name: "s{i}", transform: (translate: ({}, {}, {})), shape: Sphere(radius: {}), material: "m", emitter: Area(radiance: (1, 1, 1))),"#,
            r(4.0),
            r(4.0),
            r(4.0),
            0.1 + r(0.4).abs()
        );
    }
    for i in 0..quadrics {
        let place = format!(
            "transform: (translate: ({}, {}, {}), rotate: ({}, {}, {}), scale: {}),",
            r(4.0),
            r(4.0),
            r(4.0),
            r(180.0),
            r(180.0),
            r(180.0),
            if i % 2 == 0 {
                // Disks may be ellipses.
                format!("({}, {}, 1)", 0.2 + r(0.6).abs(), 0.2 + r(0.6).abs())
            } else {
                let s = 0.5 + r(0.4).abs();
                format!("({s}, {s}, {s})")
            }
        );
        let shape = if i % 2 == 0 {
            "Disk".to_string()
        } else {
            format!(
                "Cylinder(p0: ({}, {}, {}), p1: ({}, {}, {}), radius: {})",
                r(0.5),
                r(0.5),
                r(0.5),
                r(1.0),
                r(1.0),
                r(1.0),
                0.1 + r(0.4).abs()
            )
        };
        let _ = write!(
            entities,
            r#"(name: "q{i}", {place} shape: {shape}, material: "m", flip_normals: {}, emitter: Area(radiance: (1, 1, 1))),"#,
            i % 3 == 0
        );
    }
    format!(
        "(camera: LookAt(eye: (0, 0, 10), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40),
          materials: {{\"m\": Lambert(albedo: (0.5, 0.5, 0.5))}}, entities: [{entities}])"
    )
}

/// Brute-force closest hit over the baked world geometry: distance and position.
fn brute_force(scene: &crate::scene::LoadedScene, ray: &Ray) -> Option<(f32, Vec3A)> {
    let mut best: Option<(f32, Vec3A)> = None;
    let obvhs_ray = obvhs::ray::Ray::new(ray.origin, ray.dir, 0.0, ray.tmax);
    for shape in scene.world.query::<&WorldShape>().iter() {
        let ts: Vec<f32> = match shape {
            WorldShape::Sphere { center, radius, .. } => {
                vec![primitives::intersect_sphere(*center, *radius, &obvhs_ray)]
            }
            WorldShape::Triangles { triangles, .. } => triangles
                .iter()
                .map(|t| primitives::intersect_triangle(t, &obvhs_ray))
                .collect(),
            WorldShape::Quadric(q) => vec![q.intersect(&obvhs_ray)],
            WorldShape::Curves {
                segments,
                split_depth,
            } => {
                let c = Curves {
                    segments,
                    split_depth: *split_depth,
                };
                (0..c.pieces())
                    .map(|i| {
                        let (s, u0, u1) = c.piece(i);
                        segments[s].intersect(u0, u1, &obvhs_ray, false)
                    })
                    .collect()
            }
            WorldShape::SdfGrid(g) => g
                .occupied_voxels()
                .iter()
                .filter_map(|&(v, _)| g.intersect(v, ray.origin, ray.dir, ray.tmax))
                .collect(),
        };
        for t in ts {
            if t.is_finite() && best.is_none_or(|(b, _)| t < b) {
                best = Some((t, ray.at(t)));
            }
        }
    }
    best
}

#[test]
fn bvh_closest_hit_and_occlusion_match_brute_force() {
    let loaded = parse_scene(&random_scene(3000, 40, 40, 7), Path::new("random.ron")).unwrap();
    let scene = RenderScene::build(&loaded);
    let mut portable = RenderScene::build(&loaded);
    match std::sync::Arc::get_mut(&mut portable.accel).expect("not shared") {
        Accel::Raylab(w) => w.avx2 = None,
        Accel::Obvhs(_) => unreachable!(),
    }
    // The obvhs backend tests the same primitives with the same routines: the same hits.
    let obvhs = RenderScene::build_with(&loaded, AccelKind::Obvhs);
    assert_eq!(
        (
            obvhs.stats.triangles,
            obvhs.stats.spheres,
            obvhs.stats.quadrics
        ),
        (
            scene.stats.triangles,
            scene.stats.spheres,
            scene.stats.quadrics
        )
    );
    assert_eq!(obvhs.bounds(), scene.bounds());
    let baked_triangles: usize = loaded
        .world
        .query::<&WorldShape>()
        .iter()
        .map(|s| match s {
            WorldShape::Triangles { triangles, .. } => triangles.len(),
            WorldShape::Sphere { .. }
            | WorldShape::Quadric(_)
            | WorldShape::SdfGrid(_)
            | WorldShape::Curves { .. } => 0,
        })
        .sum();
    assert_eq!(
        (
            scene.stats.triangles,
            scene.stats.spheres,
            scene.stats.quadrics
        ),
        (baked_triangles, 40, 40)
    );
    let mut sampler = Sampler::new(99, 0, 0);
    let (mut hits, mut occluded, mut quadric_hits) = (0, 0, 0);
    for i in 0..5000 {
        let origin =
            Vec3A::new(sampler.next_1d(), sampler.next_1d(), sampler.next_1d()) * 12.0 - 6.0;
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
        let expected = brute_force(&loaded, &ray);
        let got = scene.intersect(&ray);
        // The portable build of the traversal finds the same as the AVX2 one (where the
        // processor has it and `scene` uses it), to the bit.
        let same = |a: &Option<Hit>, b: &Option<Hit>| match (a, b) {
            (Some(a), Some(b)) => {
                (a.t.to_bits(), a.p, a.ng, a.ns, a.material, a.light)
                    == (b.t.to_bits(), b.p, b.ng, b.ns, b.material, b.light)
            }
            (a, b) => a.is_none() && b.is_none(),
        };
        quadric_hits += usize::from(got.is_some_and(|h| matches!(h.light, Some(l) if l >= 40)));
        assert!(
            same(&portable.intersect(&ray), &got),
            "ray {i}: builds differ"
        );
        assert_eq!(portable.occluded(&ray), scene.occluded(&ray), "ray {i}");
        assert!(same(&obvhs.intersect(&ray), &got), "ray {i}: obvhs differs");
        assert_eq!(obvhs.occluded(&ray), scene.occluded(&ray), "ray {i}: obvhs");
        match (expected, got) {
            (None, None) => {}
            (Some((t, p)), Some(h)) => {
                hits += 1;
                assert!(
                    (t - h.t).abs() <= 1e-4 * t.max(1.0),
                    "ray {i}: t {t} vs {}",
                    h.t
                );
                assert!((p - h.p).length() <= 1e-3, "ray {i}: point {p} vs {}", h.p);
                assert!((h.ng.length() - 1.0).abs() < 1e-4);
            }
            (e, g) => panic!("ray {i}: brute force {e:?}, bvh {:?}", g.map(|h| h.t)),
        }
        let blocked = scene.occluded(&ray);
        assert_eq!(blocked, expected.is_some(), "ray {i}: occlusion disagrees");
        occluded += blocked as u32;
    }
    // The test must exercise both outcomes a fair number of times.
    assert!(hits > 1000 && hits < 4500, "hits {hits}");
    assert!(occluded > 1000);
    assert!(quadric_hits > 25, "{quadric_hits} disk and cylinder hits");
}

#[test]
fn batches_of_rays_find_what_each_ray_finds() {
    // `intersect_all` and `occluded_all` (the wavefront's traversal) against the rays one by
    // one, on every build of the traversal, walked one by one and as a stream, and on both
    // accelerators.
    let loaded = parse_scene(&random_scene(2000, 20, 20, 11), Path::new("random.ron")).unwrap();
    let variant = |avx2: bool, stream: bool| {
        let mut scene = RenderScene::build(&loaded);
        match std::sync::Arc::get_mut(&mut scene.accel).expect("not shared") {
            Accel::Raylab(w) => {
                w.avx2 = w.avx2.filter(|_| avx2);
                w.stream_from = if stream { 0 } else { usize::MAX };
            }
            Accel::Obvhs(_) => unreachable!(),
        }
        scene
    };
    let scenes = [
        variant(true, false),
        variant(true, true),
        variant(false, false),
        variant(false, true),
        RenderScene::build_with(&loaded, AccelKind::Obvhs),
    ];
    let rays = random_rays(5, 300, 6.0, 3.0);
    for scene in &scenes {
        let (found, stopped) = batches_match_single_rays(scene, &rays, rays.len());
        assert!(
            found > 50 && found < 280 && stopped > 50,
            "{found} hits, {stopped} blocked"
        );
    }
}

/// `n` rays from points in the cube of half-width `half` around the origin, in uniform
/// directions; every other ray ends at `short` (the others never).
pub(super) fn random_rays(seed: u64, n: usize, half: f32, short: f32) -> Vec<Ray> {
    let mut sampler = Sampler::new(seed, 0, 0);
    (0..n)
        .map(|i| {
            let u = Vec3A::new(sampler.next_1d(), sampler.next_1d(), sampler.next_1d());
            let dir = raylab_integrators::sampling::uniform_sphere(sampler.next_2d());
            let tmax = if i % 2 == 0 { f32::INFINITY } else { short };
            Ray {
                tmax,
                ..Ray::new(u * (2.0 * half) - half, dir)
            }
        })
        .collect()
}

/// Traces `rays` through `scene` in batches of `batch` (`intersect_all`, `occluded_all`) and
/// asserts that each ray's answers are the single ray's, bit for bit; returns how many rays
/// hit and how many were blocked.
pub(super) fn batches_match_single_rays(
    scene: &RenderScene,
    rays: &[Ray],
    batch: usize,
) -> (usize, usize) {
    let (mut hits, mut blocked) = (vec![None; rays.len()], vec![false; rays.len()]);
    for (rays, (hits, blocked)) in rays
        .chunks(batch)
        .zip(hits.chunks_mut(batch).zip(blocked.chunks_mut(batch)))
    {
        scene.intersect_all(rays, hits);
        scene.occluded_all(rays, blocked);
    }
    let (mut found, mut stopped) = (0, 0);
    for (k, ray) in rays.iter().enumerate() {
        let one = scene.intersect(ray);
        assert_eq!(
            one.map(|h| (h.t.to_bits(), h.p, h.material)),
            hits[k].map(|h| (h.t.to_bits(), h.p, h.material)),
            "ray {k}"
        );
        assert_eq!(scene.occluded(ray), blocked[k], "ray {k}");
        found += usize::from(one.is_some());
        stopped += usize::from(blocked[k]);
    }
    (found, stopped)
}

#[test]
fn every_primitive_keeps_its_material_and_light_after_reordering() {
    let loaded = parse_scene(&random_scene(200, 10, 6, 3), Path::new("random.ron")).unwrap();
    let scene = RenderScene::build(&loaded);
    // Triangles are not emitters, analytic shapes are, each its own light.
    let mut analytic_lights = Vec::new();
    for (p, d, lane) in used_lanes(&scene) {
        match p.analytic_index(lane, d) {
            None => assert_eq!(d.light(lane), None),
            Some(shape) => {
                let light = d.light(lane).expect("every analytic shape emits");
                analytic_lights.push(light);
                match (scene.lights.get(light).light, shape) {
                    (
                        Light::Sphere(SphereLight { center, radius, .. }),
                        AnalyticIndex::Sphere(i),
                    ) => assert_eq!(
                        (*center, *radius),
                        (wide(&scene).sph_center[i], wide(&scene).sph_radius[i])
                    ),
                    (Light::Planar(Planar { p0, .. }), AnalyticIndex::Quadric(i)) => {
                        let q = &wide(&scene).quadrics[i];
                        assert_eq!((q.kind, *p0), (QuadricKind::Disk, q.to_world.translation))
                    }
                    (Light::Cylinder(c), AnalyticIndex::Quadric(i)) => {
                        let q = &wide(&scene).quadrics[i];
                        assert_eq!(
                            (q.kind, c.base),
                            (QuadricKind::Cylinder, q.to_world.translation)
                        );
                        assert_eq!(c.inward, q.flipped);
                    }
                    other => panic!("{other:?}"),
                }
            }
        }
    }
    analytic_lights.sort();
    assert_eq!(analytic_lights, (0..16).collect::<Vec<u32>>());
    assert_eq!(used_lanes(&scene).count(), 216);
}

/// Every packet lane that holds a primitive, with its packet and lane data.
fn used_lanes(scene: &RenderScene) -> impl Iterator<Item = (&Packet, &LaneData, usize)> {
    wide(scene)
        .packets
        .iter()
        .flat_map(|s| (0..packet::WIDTH).map(move |lane| (&s.packet, &s.data, lane)))
        .filter(|(_, d, lane)| d.used(*lane))
}

/// A packet lane carries its triangle's material, light and smooth normals: each must come
/// back as the world had it, whatever order the BVH put the triangles in.
#[test]
fn every_triangle_lane_keeps_its_material_light_and_normals() {
    let mesh = |z: f32, normals: bool| {
        let mut positions = String::new();
        let mut extra = String::new();
        for i in 0..40 {
            let x = i as f32 * 0.1;
            let _ = write!(
                positions,
                "({x}, 0, {z}), ({}, 0, {z}), ({x}, 1, {z}),",
                x + 0.1
            );
            if normals {
                let _ = write!(extra, "({x}, 0, 1), (0, {x}, 1), (0, 0, 1),");
            }
        }
        let indices: String = (0..40)
            .map(|i| format!("({}, {}, {}),", 3 * i, 3 * i + 1, 3 * i + 2))
            .collect();
        let normals = if normals {
            format!(", normals: Some([{extra}])")
        } else {
            String::new()
        };
        format!("Mesh(positions: [{positions}], indices: [{indices}]{normals})")
    };
    let text = format!(
        r#"(camera: LookAt(eye: (0, 0, 10), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40),
          materials: {{"a": Lambert(albedo: (0.5, 0.5, 0.5)), "b": Lambert(albedo: (0.2, 0.2, 0.2)),
                       "c": Mirror(tint: (1, 1, 1))}},
          entities: [
            (name: "plain", shape: {}, material: "a"),
            (name: "lamp", shape: {}, material: "b", emitter: Area(radiance: (1, 1, 1))),
            (name: "smooth", shape: {}, material: "c"),
          ])"#,
        mesh(0.0, false),
        mesh(1.0, false),
        mesh(2.0, true)
    );
    let loaded = parse_scene(&text, Path::new("lanes.ron")).unwrap();
    let scene = RenderScene::build(&loaded);
    let (mut lit, mut smooth, mut triangles) = (0, 0, 0);
    for (p, d, lane) in used_lanes(&scene) {
        triangles += 1;
        let v0 = p.edges(lane).0;
        // The mesh is told by its z, the triangle within it by its first corner's x.
        let (mesh, i) = (v0.z as usize, (v0.x * 10.0).round() as usize);
        assert_eq!(d.material(lane), mesh as u32, "{v0:?}");
        match d.light(lane) {
            Some(l) => {
                assert_eq!(mesh, 1);
                lit += 1;
                match scene.lights.get(l).light {
                    Light::Planar(Planar { p0, .. }) => assert_eq!(*p0, v0),
                    other => panic!("{other:?}"),
                }
            }
            None => assert_ne!(mesh, 1),
        }
        match d.vertex_data(lane) {
            Some(k) => {
                assert_eq!(mesh, 2);
                smooth += 1;
                let x = i as f32 * 0.1;
                let expected = Vec3A::new(0.0, x, 1.0).normalize();
                assert!(wide(&scene).vertex_data[k].normals[1].abs_diff_eq(expected, 1e-6));
            }
            None => assert_ne!(mesh, 2),
        }
    }
    assert_eq!((triangles, lit, smooth), (120, 40, 40));
}

#[test]
fn the_build_does_not_depend_on_the_thread_count() {
    // The BVH is built in parallel on the current rayon pool (--threads sets it): the BVH and the
    // primitive order must come out the same on 1 and 2 threads (the images rely on it).
    let loaded = parse_scene(&random_scene(5000, 30, 10, 11), Path::new("random.ron")).unwrap();
    let build = |threads: usize| {
        RenderScene::build_on_threads(&loaded, AccelKind::Raylab, Some(threads)).unwrap()
    };
    let (a, b) = (build(1), build(2));
    assert_eq!(wide(&a).bvh, wide(&b).bvh);
    // Compared bit for bit: a sphere's lane holds NaNs.
    let bits = |s: &RenderScene| -> Vec<Vec<u32>> {
        wide(s).packets.iter().map(|p| p.packet.to_bits()).collect()
    };
    assert_eq!(bits(&a), bits(&b));
    let data =
        |s: &RenderScene| -> Vec<LaneData> { wide(s).packets.iter().map(|p| p.data).collect() };
    assert_eq!(data(&a), data(&b));
    // Curves' pieces too.
    let loaded = parse_scene(&curves_scene(13), Path::new("curves.ron")).unwrap();
    let build = |threads: usize| {
        RenderScene::build_on_threads(&loaded, AccelKind::Raylab, Some(threads)).unwrap()
    };
    let (a, b) = (build(1), build(2));
    assert_eq!(wide(&a).bvh, wide(&b).bvh);
    assert_eq!(wide(&a).curve_pieces, wide(&b).curve_pieces);
    assert_eq!(data(&a), data(&b));
}

/// Random triangles and curves of the three kinds (split two, three and no times), as RON.
fn curves_scene(seed: u64) -> String {
    let mut s = Sampler::new(seed, 0, 0);
    let mut r = |scale: f32| (s.next_1d() * 2.0 - 1.0) * scale;
    let mut entities = String::new();
    let mut positions = String::new();
    for _ in 0..300 {
        let c = Vec3A::new(r(4.0), r(4.0), r(4.0));
        for _ in 0..3 {
            let p = c + Vec3A::new(r(0.5), r(0.5), r(0.5));
            let _ = write!(positions, "({}, {}, {}),", p.x, p.y, p.z);
        }
    }
    let indices: String = (0..300)
        .map(|i| format!("({}, {}, {}),", 3 * i, 3 * i + 1, 3 * i + 2))
        .collect();
    let _ = write!(
        entities,
        r#"(name: "soup", shape: Mesh(positions: [{positions}], indices: [{indices}]), material: "m"),"#
    );
    for (k, (kind, depth)) in [("flat", 2), ("cylinder", 3), ("ribbon", 0)]
        .into_iter()
        .enumerate()
    {
        let mut curves = String::new();
        for _ in 0..40 {
            let start = Vec3A::new(r(4.0), r(4.0), r(4.0));
            let mut points = String::new();
            let mut normals = String::new();
            for i in 0..7 {
                let p = start + Vec3A::new(i as f32 * 0.3, r(0.4), r(0.4));
                let _ = write!(points, "({}, {}, {}),", p.x, p.y, p.z);
                if i % 3 == 0 {
                    let _ = write!(normals, "(0, {}, 1),", r(0.5));
                }
            }
            let normals = if kind == "ribbon" {
                format!(", normals: [{normals}]")
            } else {
                String::new()
            };
            let _ = write!(
                curves,
                "(points: [{points}], width: ({}, {}){normals}),",
                0.02 + r(0.1).abs(),
                0.02 + r(0.1).abs()
            );
        }
        let _ = write!(
            entities,
            r#"(name: "curves {k}", shape: Curves(type: "{kind}", split_depth: {depth}, curves: [{curves}]), material: "{}", flip_normals: {}),"#,
            ["m", "h", "m"][k],
            k == 1
        );
    }
    format!(
        "(camera: LookAt(eye: (0, 0, 10), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40),
          materials: {{\"m\": Lambert(albedo: (0.5, 0.5, 0.5)), \"h\": Hair(eumelanin: 0.5)}},
          entities: [{entities}])"
    )
}

/// Curves' pieces in the BVH: both builds of raylab's traversal and the obvhs backend find the
/// same hits, to the bit (distance, point, normal, `uv`, tangent), which are the nearest of
/// the pieces tested one by one; occlusion agrees.
#[test]
fn curve_pieces_in_the_bvh_match_the_pieces_one_by_one() {
    let loaded = parse_scene(&curves_scene(5), Path::new("curves.ron")).unwrap();
    let scene = RenderScene::build(&loaded);
    let mut portable = RenderScene::build(&loaded);
    match std::sync::Arc::get_mut(&mut portable.accel).expect("not shared") {
        Accel::Raylab(w) => w.avx2 = None,
        Accel::Obvhs(_) => unreachable!(),
    }
    let obvhs = RenderScene::build_with(&loaded, AccelKind::Obvhs);
    // 40 curves of 2 segments each: 4, 8 and 1 pieces a segment.
    assert_eq!(scene.stats.curve_pieces, 80 * (4 + 8 + 1));
    assert_eq!(obvhs.stats.curve_pieces, scene.stats.curve_pieces);
    assert_eq!(scene.stats.triangles, 300);
    assert_eq!(obvhs.bounds(), scene.bounds());
    let record = |h: &Option<Hit>| {
        h.map(|h| {
            (
                h.t.to_bits(),
                h.p,
                h.ng,
                h.uv,
                h.dpdu,
                h.dpdv,
                h.material,
                h.spawn_offset.to_bits(),
            )
        })
    };
    let mut sampler = Sampler::new(3, 0, 0);
    let (mut curve_hits, mut hits) = (0, 0);
    for i in 0..4000 {
        let target = Vec3A::new(sampler.next_1d(), sampler.next_1d(), sampler.next_1d()) * 8.0
            - Vec3A::new(2.0, 4.0, 4.0);
        let origin =
            Vec3A::new(sampler.next_1d(), sampler.next_1d(), sampler.next_1d()) * 20.0 - 10.0;
        let tmax = if i % 3 == 0 { 12.0 } else { f32::INFINITY };
        let ray = Ray {
            tmax,
            ..Ray::new(origin, (target - origin).normalize())
        };
        let got = scene.intersect(&ray);
        assert_eq!(record(&portable.intersect(&ray)), record(&got), "ray {i}");
        assert_eq!(
            record(&obvhs.intersect(&ray)),
            record(&got),
            "ray {i}: obvhs"
        );
        let expected = brute_force(&loaded, &ray);
        assert_eq!(got.map(|h| h.t), expected.map(|e| e.0), "ray {i}");
        let blocked = scene.occluded(&ray);
        assert_eq!(blocked, got.is_some(), "ray {i}: occlusion");
        assert_eq!(portable.occluded(&ray), blocked);
        assert_eq!(obvhs.occluded(&ray), blocked);
        if let Some(h) = got {
            hits += 1;
            curve_hits += usize::from(h.spawn_offset > 0.0);
            assert!(h.ng.is_finite() && (h.ng.length() - 1.0).abs() < 1e-4);
        }
    }
    assert!(
        hits > 400 && curve_hits > 100,
        "{hits} hits, {curve_hits} on curves"
    );
}
