//! Meshes from files land where the scene puts them, facing the right way.

use glam::{Quat, Vec3A};
use raylab::scene::components::{Name, WorldShape};
use raylab::scene::load_scene;
use std::path::Path;

#[test]
fn obj_mesh_is_placed_and_oriented_by_its_transform() {
    let loaded = load_scene(Path::new("scenes/mesh_files.ron")).unwrap();
    let mut query = loaded.world.query::<(&Name, &WorldShape)>();
    let (_, shape) = query
        .iter()
        .find(|(n, _)| n.0 == "pyramid")
        .expect("the pyramid entity");
    let WorldShape::Triangles { triangles, .. } = shape else {
        panic!("a mesh")
    };
    // 1 quad base (2 triangles after triangulation) + 4 sides.
    assert_eq!(triangles.len(), 6);
    // The apex (0, 1.5, 0) scaled by 0.4 and moved down by 1: (0, -0.4, 0).
    let apex = Vec3A::new(0.0, -0.4, 0.0);
    let with_apex: Vec<&[Vec3A; 3]> = triangles
        .iter()
        .filter(|t| t.iter().any(|v| (*v - apex).length() < 1e-5))
        .collect();
    assert_eq!(with_apex.len(), 4, "four sides meet at the apex");
    // The side (-1,0,1), (1,0,1), apex faces (0, 2, 3) in the file; rotated 30 degrees about y.
    let expected =
        Quat::from_rotation_y(30f32.to_radians()) * glam::Vec3::new(0.0, 2.0, 3.0).normalize();
    let found = with_apex.iter().any(|t| {
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        (glam::Vec3::from(n) - expected).length() < 1e-4
    });
    assert!(found, "no side faces {expected}");
    // Every face points away from the pyramid's centre.
    let centre = triangles.iter().flatten().copied().sum::<Vec3A>() / 18.0;
    for t in triangles {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        assert!(n.dot((t[0] + t[1] + t[2]) / 3.0 - centre) > 0.0);
    }
}

#[test]
fn gltf_mesh_follows_its_node_hierarchy() {
    let loaded = load_scene(Path::new("scenes/mesh_files.ron")).unwrap();
    let mut query = loaded.world.query::<(&Name, &WorldShape)>();
    let (_, shape) = query
        .iter()
        .find(|(n, _)| n.0 == "panel")
        .expect("the panel entity");
    let WorldShape::Triangles {
        triangles, normals, ..
    } = shape
    else {
        panic!("a mesh")
    };
    assert_eq!(triangles.len(), 2);
    // Corner (0.5, 0.5, 0): turned 45 degrees about y by the child node, then scaled by 0.6
    // and moved down 0.3 by the parent: (0.2121, 0.0, -0.2121).
    let corner = Vec3A::new(0.212_132, 0.0, -0.212_132);
    assert!(
        triangles
            .iter()
            .flatten()
            .any(|v| (*v - corner).length() < 1e-4),
        "{triangles:?}"
    );
    // The face and its vertex normals point along (1, 0, 1) / sqrt 2.
    let expected = Vec3A::new(1.0, 0.0, 1.0).normalize();
    for t in triangles {
        assert!(((t[1] - t[0]).cross(t[2] - t[0]).normalize() - expected).length() < 1e-4);
    }
    let normals = normals.as_ref().expect("the file has normals");
    assert!(normals
        .iter()
        .flatten()
        .all(|n| (*n - expected).length() < 1e-4));
}

/// The entity named `name` of a loaded scene: its material and emitter.
fn part(
    loaded: &raylab::scene::LoadedScene,
    name: &str,
) -> (
    raylab_integrators::Material,
    Option<raylab::scene::components::Emitter>,
    WorldShape,
) {
    use raylab::scene::components::{Emitter, MaterialRef};
    let mut query = loaded
        .world
        .query::<(&Name, &MaterialRef, Option<&Emitter>, &WorldShape)>();
    let (_, m, e, s) = query
        .iter()
        .find(|(n, ..)| n.0 == name)
        .unwrap_or_else(|| panic!("no entity `{name}`"));
    (
        loaded.materials[m.0 as usize].bsdf().clone(),
        e.cloned(),
        s.clone(),
    )
}

fn albedo(m: &raylab_integrators::Material) -> Vec3A {
    match m {
        raylab_integrators::Material::Lambert(l) => raylab_integrators::spectrum::rgb_of(l.albedo),
        other => panic!("a Lambert material, got {other:?}"),
    }
}

#[test]
fn obj_materials_come_from_the_mtl_file() {
    use raylab::scene::components::Emitter;
    let loaded = load_scene(Path::new("scenes/file_materials.ron")).unwrap();
    let (body, body_emits, body_shape) = part(&loaded, "lantern/body");
    assert_eq!(albedo(&body), Vec3A::new(0.1, 0.45, 0.5));
    assert!(body_emits.is_none());
    let WorldShape::Triangles { triangles, .. } = body_shape else {
        panic!("a mesh")
    };
    assert_eq!(triangles.len(), 10, "five quads");
    let (glow, glow_emits, glow_shape) = part(&loaded, "lantern/glow");
    assert_eq!(albedo(&glow), Vec3A::splat(0.9));
    let Some(Emitter::Area {
        radiance,
        two_sided: false,
        texture: None,
        spectrum: None,
    }) = glow_emits
    else {
        panic!("the glowing top emits from its front: {glow_emits:?}")
    };
    assert_eq!(radiance, Vec3A::new(4.0, 3.2, 2.0));
    // The top face, at y = 1 in the file: scaled by 0.7 and moved down by 1, facing up.
    let WorldShape::Triangles { triangles, .. } = glow_shape else {
        panic!("a mesh")
    };
    assert_eq!(triangles.len(), 2);
    for t in &triangles {
        assert!(t.iter().all(|v| (v.y - (-0.3)).abs() < 1e-5), "{t:?}");
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        assert!((n - Vec3A::Y).length() < 1e-5, "{n}");
    }
}

#[test]
fn gltf_base_colour_and_emission_become_material_and_emitter() {
    use raylab::scene::components::Emitter;
    let loaded = load_scene(Path::new("scenes/file_materials.ron")).unwrap();
    let (base, base_emits, _) = part(&loaded, "lamp/base");
    assert_eq!(albedo(&base), Vec3A::new(0.8, 0.3, 0.1));
    assert!(base_emits.is_none());
    let (_, shade_emits, shade_shape) = part(&loaded, "lamp/shade");
    // emissiveFactor (1, 0.8, 0.5) x KHR_materials_emissive_strength 5.
    let Some(Emitter::Area {
        radiance,
        two_sided: false,
        texture: None,
        spectrum: None,
    }) = shade_emits
    else {
        panic!("{shade_emits:?}")
    };
    assert!((radiance - Vec3A::new(5.0, 4.0, 2.5)).length() < 1e-6);
    // The shade: at y = 0.6 + 0.1 (node) in the file, scaled by 0.8, moved down by 1; facing down.
    let WorldShape::Triangles { triangles, .. } = shade_shape else {
        panic!("a mesh")
    };
    for t in &triangles {
        assert!(
            t.iter().all(|v| (v.y - (0.7 * 0.8 - 1.0)).abs() < 1e-5),
            "{t:?}"
        );
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        assert!((n + Vec3A::Y).length() < 1e-5, "{n}");
    }
    // The emitting parts are the scene's lights: two triangles each.
    let built = raylab::scene::RenderScene::build(&loaded);
    assert_eq!(built.stats.lights, 4);
}

#[test]
fn instanced_and_file_material_scenes_render_the_same_at_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    for scene in ["scenes/instances.ron", "scenes/file_materials.ron"] {
        let images: Vec<Vec<u8>> = ["1", "2"]
            .iter()
            .map(|threads| {
                let out = dir.path().join(format!("image-{threads}.exr"));
                let o = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
                    .args(["render", scene, "--size", "32x24", "--spp", "2"])
                    .args(["--threads", threads, "-q", "-o"])
                    .arg(&out)
                    .current_dir(env!("CARGO_MANIFEST_DIR"))
                    .output()
                    .unwrap();
                assert!(o.status.success(), "{scene}: {o:?}");
                std::fs::read(&out).unwrap()
            })
            .collect();
        assert!(
            images[0] == images[1],
            "{scene}: the thread count changed the image"
        );
    }
}

/// A `.vol` file of `n^3` values of `f` over the unit cube, as Mitsuba writes them.
fn volume_file(n: usize, f: impl Fn(Vec3A) -> f32) -> Vec<u8> {
    let mut b = b"VOL\x03".to_vec();
    for v in [1i32, n as i32, n as i32, n as i32, 1] {
        b.extend(v.to_le_bytes());
    }
    for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0] {
        b.extend(v.to_le_bytes());
    }
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let p = Vec3A::new(x as f32, y as f32, z as f32) / (n - 1) as f32;
                b.extend(f(p).to_le_bytes());
            }
        }
    }
    b
}

/// Mitsuba's `sdfgrid` from a RON scene: a sphere's distance function on a grid, placed by a
/// transform, is hit where the sphere is (within the interpolation's error), through both
/// accelerators, and shadows what is behind it.
#[test]
fn an_sdf_grid_is_hit_where_its_surface_is() {
    let dir = tempfile::tempdir().unwrap();
    let vol = volume_file(24, |p| (p - Vec3A::splat(0.5)).length() - 0.35);
    std::fs::write(dir.path().join("ball.vol"), vol).unwrap();
    let scene = r#"(
        camera: LookAt(eye: (0, 0, 8), look_at: (0, 0, 0), up: (0, 1, 0), fov: 30, resolution: (8, 8)),
        materials: {"grey": Lambert(albedo: 0.5)},
        entities: [(name: "ball", shape: SdfGrid(path: "ball.vol"), material: "grey",
                    transform: (translate: (-1, -1, -1), scale: (2, 2, 2)))],
    )"#;
    std::fs::write(dir.path().join("s.ron"), scene).unwrap();
    let Ok(loaded) = load_scene(&dir.path().join("s.ron")) else {
        panic!("the SDF grid scene loads");
    };
    use raylab_integrators::{Ray, Scene};
    for kind in [
        raylab::accel::AccelKind::Raylab,
        raylab::accel::AccelKind::Obvhs,
    ] {
        let built = raylab::scene::RenderScene::build_with(&loaded, kind);
        // The sphere of radius 0.7 (0.35 scaled by 2) around the origin.
        for i in 0..50 {
            let a = i as f32 * 0.37;
            let origin = Vec3A::new(a.cos() * 5.0, (a * 0.7).sin() * 3.0, a.sin() * 5.0);
            let aim = Vec3A::new((a * 1.3).sin(), (a * 2.1).cos(), (a * 0.9).sin()) * 0.3;
            let d = (aim - origin).normalize();
            let hit = built
                .intersect(&Ray::new(origin, d))
                .expect("aimed at the ball");
            assert!(
                (hit.p.length() - 0.7).abs() < 0.01,
                "{kind:?}: hit at radius {}",
                hit.p.length()
            );
            assert!(hit.ng.dot(hit.p.normalize()) > 0.99);
            let mut past = Ray::new(origin, d);
            past.tmax = hit.t * 0.999;
            assert!(!built.occluded(&past), "{kind:?}: nothing before the hit");
            past.tmax = hit.t * 1.001;
            assert!(built.occluded(&past), "{kind:?}: the ball occludes");
        }
    }
}
