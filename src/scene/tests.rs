//! ECS unit tests: spawning, querying, and each system (validate, bake, collect emitters).

use super::components::{Emitter, FileOrder, MaterialRef, Name, Shape, Transform, WorldShape};
use super::systems::{bake_shape, bake_transforms, collect_emitters, validate};
use super::{parse_scene, LoadedScene, RenderScene, SceneError};
use glam::{Vec3, Vec3A};
use hecs::{Entity, World};
use raylab_integrators::light::{PlanarShape, PointLight, SphereLight};
use raylab_integrators::{Light, Rgb};
use std::path::Path;

const CAMERA: &str = "camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (8, 8)),";

fn scene(body: &str) -> String {
    format!("({CAMERA} materials: {{\"w\": Lambert(albedo: (0.5, 0.5, 0.5))}}, entities: [{body}])")
}

fn load(text: &str) -> Result<super::LoadedScene, SceneError> {
    parse_scene(text, Path::new("test.ron"))
}

fn err(text: &str) -> String {
    match load(text) {
        Ok(_) => panic!("expected an error for {text}"),
        Err(e) => e.to_string(),
    }
}

fn by_name(world: &World, name: &str) -> Entity {
    world
        .query::<(Entity, &Name)>()
        .iter()
        .find(|(_, n)| n.0 == name)
        .map(|(e, _)| e)
        .unwrap_or_else(|| panic!("no entity {name}"))
}

#[test]
fn spawn_creates_one_entity_per_object_with_its_components() {
    let s = load(&scene(
        r#"(name: "ball", shape: Sphere(radius: 1), material: "w"),
           (name: "lamp", shape: Quad(vertices: [(0,0,0), (1,0,0), (1,1,0), (0,1,0)]), emitter: Area(radiance: (5, 5, 5))),
           (name: "bulb", transform: (translate: (0, 2, 0)), emitter: Point(intensity: (1, 2, 3))),
           (shape: Triangle(vertices: [(0,0,0), (1,0,0), (0,1,0)]), material: "w")"#,
    ))
    .unwrap();
    let w = &s.world;
    assert_eq!(w.len(), 4);
    // Query: every entity has a name and a transform; shapes, materials and emitters as given.
    assert_eq!(w.query::<(&Name, &Transform)>().iter().count(), 4);
    assert_eq!(w.query::<&Shape>().iter().count(), 3);
    assert_eq!(
        w.query::<&MaterialRef>().iter().count(),
        3,
        "the pure emitter gets the black material"
    );
    assert_eq!(w.query::<&Emitter>().iter().count(), 2);
    let ball = by_name(w, "ball");
    assert_eq!(
        *w.get::<&Shape>(ball).unwrap(),
        Shape::Sphere {
            center: Vec3A::ZERO,
            radius: 1.0
        }
    );
    assert_eq!(w.get::<&MaterialRef>(ball).unwrap().0, 0);
    let bulb = by_name(w, "bulb");
    assert!(w.get::<&Shape>(bulb).is_err());
    assert_eq!(
        *w.get::<&Emitter>(bulb).unwrap(),
        Emitter::Point {
            intensity: Rgb::new(1.0, 2.0, 3.0),
            spectrum: None,
        }
    );
    // Unnamed entities are named by their position in the file.
    by_name(w, "entity #3");
    // The black material was appended for the lamp.
    assert_eq!(s.materials.len(), 2);
    assert_eq!(
        s.materials[1].bsdf().albedo(),
        raylab_integrators::Spectrum::ZERO
    );
}

/// The same entity placed by translate, rotate and scale and by the equivalent matrix: the
/// same world geometry, the same lights, the same rotation for what turns with it.
#[test]
fn a_transform_matrix_places_entities_as_the_equivalent_trs() {
    let trs = Transform {
        translate: Vec3::new(1.0, -2.0, 0.5),
        rotate_degrees: Vec3::new(30.0, -40.0, 75.0),
        scale: Vec3::new(2.0, 0.5, 1.5),
        matrix: None,
    };
    let m = trs.matrix();
    let rows: Vec<String> = (0..3)
        .flat_map(|r| {
            let row = m.matrix3.row(r);
            [row.x, row.y, row.z, m.translation[r]]
        })
        .map(|v| format!("{v:e}"))
        .collect();
    let scene = |placement: &str| {
        format!(
            r#"(camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40),
            materials: {{"m": Lambert(albedo: 0.5)}},
            entities: [
                (name: "box", transform: {placement}, shape: Box(min: (-1, -1, -1), max: (1, 2, 1)), material: "m"),
                (name: "lamp", transform: {placement}, shape: Disk, emitter: Area(radiance: (1, 1, 1))),
                (name: "sun", transform: {placement}, emitter: Directional(direction: (0, 0, -1), irradiance: (1, 1, 1))),
            ])"#
        )
    };
    let a = parse_scene(
        &scene("(translate: (1, -2, 0.5), rotate: (30, -40, 75), scale: (2, 0.5, 1.5))"),
        Path::new("trs.ron"),
    )
    .unwrap();
    let b = parse_scene(
        &scene(&format!("(matrix: [{}])", rows.join(", "))),
        Path::new("matrix.ron"),
    )
    .unwrap();
    let shapes = |s: &LoadedScene| {
        let mut v: Vec<(u32, WorldShape)> = s
            .world
            .query::<(hecs::Entity, &WorldShape)>()
            .iter()
            .map(|(e, w)| (e.id(), w.clone()))
            .collect();
        v.sort_by_key(|(e, _)| *e);
        v.into_iter().map(|(_, w)| w).collect::<Vec<_>>()
    };
    let (sa, sb) = (shapes(&a), shapes(&b));
    let WorldShape::Triangles { triangles: ta, .. } = &sa[0] else {
        panic!()
    };
    let WorldShape::Triangles { triangles: tb, .. } = &sb[0] else {
        panic!()
    };
    for (x, y) in ta.iter().flatten().zip(tb.iter().flatten()) {
        assert!((*x - *y).length() < 1e-5, "{x} vs {y}");
    }
    let (WorldShape::Quadric(qa), WorldShape::Quadric(qb)) = (&sa[1], &sb[1]) else {
        panic!()
    };
    assert!(qa.to_world.abs_diff_eq(qb.to_world, 1e-5));
    // The sun turns by the rotation alone: the matrix's, made orthonormal, is the TRS's.
    let (ra, rb) = (
        RenderScene::build(&a).lights.get(1).light.clone(),
        RenderScene::build(&b).lights.get(1).light.clone(),
    );
    match (ra, rb) {
        (Light::Directional(x), Light::Directional(y)) => {
            assert!(
                (x.direction - y.direction).length() < 1e-5,
                "{:?} vs {:?}",
                x.direction,
                y.direction
            )
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn transform_matrix_scales_then_rotates_then_translates() {
    let t = Transform {
        translate: Vec3::new(1.0, 2.0, 3.0),
        rotate_degrees: Vec3::new(0.0, 0.0, 90.0),
        scale: Vec3::splat(2.0),
        matrix: None,
    };
    let p = t.matrix().transform_point3(Vec3::X);
    // (1,0,0) -> scale (2,0,0) -> rotate 90 about z (0,2,0) -> translate (1,4,3).
    assert!((p - Vec3::new(1.0, 4.0, 3.0)).length() < 1e-5, "{p}");
    // Rotation order: x first, then y, then z (fixed axes).
    let t = Transform {
        rotate_degrees: Vec3::new(90.0, 90.0, 0.0),
        ..Default::default()
    };
    let p = t.matrix().transform_point3(Vec3::Y);
    // Y -> (x 90) Z -> (y 90) X.
    assert!((p - Vec3::X).length() < 1e-5, "{p}");
}

#[test]
fn bake_applies_transforms_and_orients_closed_shapes_outwards() {
    let mut s = load(&scene(
        r#"(name: "ball", transform: (translate: (1, 2, 3), scale: (2, 2, 2)), shape: Sphere(radius: 0.5), material: "w"),
           (name: "tet", shape: Tetrahedron(vertices: [(0,0,0), (0,1,0), (1,0,0), (0,0,1)]), material: "w"),
           (name: "box", transform: (rotate: (10, 20, 30)), shape: Box(min: (-1,-1,-1), max: (1,2,3)), material: "w")"#,
    ))
    .unwrap();
    // Baking again is idempotent (the loader already ran it).
    bake_transforms(&mut s.world, 0).unwrap();
    let w = &s.world;
    let ball = by_name(w, "ball");
    assert_eq!(
        *w.get::<&WorldShape>(ball).unwrap(),
        WorldShape::Sphere {
            center: Vec3A::new(1.0, 2.0, 3.0),
            radius: 1.0,
            frame: glam::Mat3A::IDENTITY
        }
    );
    for name in ["tet", "box"] {
        let e = by_name(w, name);
        let shape = w.get::<&WorldShape>(e).unwrap();
        let WorldShape::Triangles { triangles, .. } = &*shape else {
            panic!()
        };
        let centroid = triangles
            .iter()
            .map(|t| (t[0] + t[1] + t[2]) / 3.0)
            .sum::<Vec3A>()
            / triangles.len() as f32;
        for t in triangles {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            assert!(
                n.dot((t[0] + t[1] + t[2]) / 3.0 - centroid) > 0.0,
                "{name}: face points inwards"
            );
        }
        assert_eq!(triangles.len(), if name == "tet" { 4 } else { 12 });
    }
    // Box area is preserved by a rotation: 2 * (3*4 + 3*2 + 4*2) = 52.
    let shape = w.get::<&WorldShape>(by_name(w, "box")).unwrap();
    assert!((shape.area() - 52.0).abs() < 1e-3);
}

#[test]
fn bake_transforms_mesh_normals_with_the_inverse_transpose() {
    let shape = Shape::Mesh {
        positions: vec![Vec3A::ZERO, Vec3A::X, Vec3A::Y],
        indices: vec![[0, 1, 2]],
        normals: Some(vec![Vec3A::new(1.0, 1.0, 0.0).normalize(); 3]),
        uvs: None,
        attribute: None,
    };
    let t = Transform {
        scale: Vec3::new(2.0, 1.0, 1.0),
        ..Default::default()
    };
    let WorldShape::Triangles {
        normals: Some(n), ..
    } = bake_shape(&shape, &t.matrix())
    else {
        panic!()
    };
    // A stretch along x tilts normals away from x: (1,1,0) -> (1/2, 1, 0) normalised.
    assert!((n[0][0] - Vec3A::new(0.5, 1.0, 0.0).normalize()).length() < 1e-5);
}

#[test]
fn bake_drops_degenerate_triangles_with_a_warning() {
    let s = load(&scene(
        r#"(name: "m", shape: Mesh(positions: [(0,0,0), (1,0,0), (0,1,0), (2,0,0)], indices: [(0,1,2), (0,1,3)]), material: "w")"#,
    ))
    .unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("dropped 1 degenerate"));
    let shape = s.world.get::<&WorldShape>(by_name(&s.world, "m")).unwrap();
    let WorldShape::Triangles { triangles, .. } = &*shape else {
        panic!()
    };
    assert_eq!(triangles.len(), 1);
}

#[test]
fn collect_emitters_makes_one_light_per_sphere_quad_triangle_and_point() {
    let s = load(&scene(
        r#"(name: "sun", shape: Sphere(radius: 1), material: "w", emitter: Area(radiance: (1,1,1))),
           (name: "panel", shape: Quad(vertices: [(0,0,0), (2,0,0), (2,1,0), (0,1,0)]), emitter: Area(radiance: (2,2,2), two_sided: true)),
           (name: "tet", shape: Tetrahedron(vertices: [(0,0,0), (0,1,0), (1,0,0), (0,0,1)]), material: "w", emitter: Area(radiance: (3,3,3))),
           (name: "bulb", transform: (translate: (0, 4, 0)), emitter: Point(intensity: (4,4,4)))"#,
    ))
    .unwrap();
    let lights = collect_emitters(&s.world);
    let counts: Vec<usize> = lights.iter().map(|(_, l)| l.len()).collect();
    assert_eq!(counts, vec![1, 1, 4, 1]);
    assert!(matches!(lights[0].1[0], Light::Sphere(SphereLight { radius, .. }) if radius == 1.0));
    match &lights[1].1[0] {
        Light::Planar(l) => assert!(
            l.shape == PlanarShape::Parallelogram && (l.area - 2.0).abs() < 1e-6 && l.two_sided
        ),
        other => panic!("{other:?}"),
    }
    assert!(
        matches!(lights[3].1[0], Light::Point(PointLight { position, .. }) if position == Vec3A::new(0.0, 4.0, 0.0))
    );
}

#[test]
fn validate_rejects_bad_components_and_names_the_entity() {
    let cases: &[(&str, &str)] = &[
        (
            r#"(name: "a", shape: Sphere(radius: -1), material: "w")"#,
            "radius must be positive",
        ),
        (
            r#"(name: "a", shape: Sphere(radius: 0), material: "w")"#,
            "radius must be positive",
        ),
        (
            r#"(name: "a", shape: Sphere(radius: NaN), material: "w")"#,
            "must be finite",
        ),
        (
            r#"(name: "a", transform: (scale: (1, 0, 1)), shape: Sphere(radius: 1), material: "w")"#,
            "scale must be positive",
        ),
        (
            r#"(name: "a", transform: (scale: (1, 2, 1)), shape: Sphere(radius: 1), material: "w")"#,
            "uniform scale",
        ),
        (
            r#"(name: "a", transform: (translate: (inf, 0, 0)), shape: Sphere(radius: 1), material: "w")"#,
            "must be finite",
        ),
        (
            r#"(name: "a", shape: Quad(vertices: [(0,0,0), (1,0,0), (1,1,0), (0,2,0)]), material: "w")"#,
            "parallelogram",
        ),
        (
            r#"(name: "a", shape: Quad(vertices: [(0,0,0), (1,0,0), (1,1,0)]), material: "w")"#,
            "exactly 4 vertices",
        ),
        (
            r#"(name: "a", shape: Box(min: (0,0,0), max: (1,0,1)), material: "w")"#,
            "max must exceed min",
        ),
        (
            r#"(name: "a", shape: Mesh(positions: [(0,0,0), (1,0,0), (0,1,0)], indices: [(0,1,3)]), material: "w")"#,
            "out of range",
        ),
        (
            r#"(name: "a", shape: Mesh(positions: [], indices: []), material: "w")"#,
            "no triangles",
        ),
        (
            r#"(name: "a", emitter: Area(radiance: (1,1,1)))"#,
            "needs a shape",
        ),
        (
            r#"(name: "a", shape: Sphere(radius: 1), material: "w", emitter: Area(radiance: (-1,1,1)))"#,
            "must not be negative",
        ),
        (
            r#"(name: "a", shape: Sphere(radius: 1), material: "w", emitter: Point(intensity: (1,1,1)))"#,
            "point light has no shape",
        ),
        (r#"(name: "a", shape: Sphere(radius: 1))"#, "no material"),
        (
            r#"(name: "a", shape: Sphere(radius: 1), material: "nope")"#,
            "unknown material `nope`; defined materials: w",
        ),
        (r#"(name: "a")"#, "neither a shape nor an emitter"),
        (
            r#"(name: "a", shape: Triangle(vertices: [(0,0,0), (1,0,0), (2,0,0)]), emitter: Area(radiance: (1,1,1)))"#,
            "zero area",
        ),
    ];
    for (body, expected) in cases {
        let e = err(&scene(body));
        assert!(
            e.contains("test.ron: entity `a`") && e.contains(expected),
            "{body}\n  gave: {e}\n  wanted: {expected}"
        );
    }
}

#[test]
fn validate_system_runs_on_a_hand_built_world() {
    let mut world = World::new();
    world.spawn((
        FileOrder { entity: 0, part: 0 },
        Name("ok".into()),
        Transform::default(),
        Shape::Sphere {
            center: Vec3A::ZERO,
            radius: 1.0,
        },
    ));
    assert!(validate(&world).is_ok());
    world.spawn((
        FileOrder { entity: 1, part: 0 },
        Name("bad".into()),
        Transform::default(),
        Shape::Sphere {
            center: Vec3A::ZERO,
            radius: -2.0,
        },
    ));
    let (entity, message) = validate(&world).unwrap_err();
    assert_eq!(entity, "bad");
    assert!(message.contains("radius"));
}

#[test]
fn parse_errors_carry_file_line_and_column() {
    let text = format!("({CAMERA}\n entities: [\n (shape: Sphere(radus: 1))])");
    let e = err(&text);
    assert!(e.starts_with("test.ron:3:"), "{e}");
    assert!(e.contains("radus"), "{e}");
    let e = err(&format!("({CAMERA} entities: [], bogus: 1)"));
    assert!(e.contains("bogus"), "{e}");
    let e = err("(camera: ");
    assert!(e.starts_with("test.ron:1:"), "{e}");
    let e = err(&format!(
        "({CAMERA} materials: {{\"w\": Lambert(albedo: (1,1,1)), \"w\": Mirror()}}, entities: [])"
    ));
    assert!(e.contains("duplicate material name `w`"), "{e}");
    let e = err(&format!(
        "({CAMERA} materials: {{\"w\": Lambert(albedo: \"red\")}}, entities: [])"
    ));
    assert!(e.starts_with("test.ron:1:"), "{e}");
}

#[test]
fn scene_level_checks() {
    assert!(err(&format!("({CAMERA} entities: [])")).contains("no entities"));
    assert!(err(&format!(
        "({CAMERA} entities: [(emitter: Point(intensity: (1,1,1)))])"
    ))
    .contains("no geometry"));
    let bad_cam =
        "(camera: LookAt(eye: (0,0,0), look_at: (0,0,0), up: (0,1,0), fov: 40), entities: [])";
    assert!(err(bad_cam).contains("camera: eye and look_at must differ"));
    let zero = "(camera: LookAt(eye: (0,0,1), look_at: (0,0,0), up: (0,1,0), fov: 40, resolution: (0, 10)), entities: [])";
    assert!(err(zero).contains("at least 1x1"));
    let huge = "(camera: LookAt(eye: (0,0,1), look_at: (0,0,0), up: (0,1,0), fov: 40, resolution: (4000000000, 4000000000)), entities: [])";
    assert!(err(huge).contains("too large"));
    let m = format!("({CAMERA} materials: {{\"p\": Phong(kd: (0.6,0.6,0.6), ks: (0.6,0.6,0.6), exponent: 10)}}, entities: [])");
    assert!(err(&m).contains("material `p`: kd + ks must be <= 1"));
}

#[test]
fn instances_share_one_loaded_copy_of_their_mesh() {
    let text = r#"(camera: LookAt(eye: (0, 0, 10), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40),
        materials: {"m": Lambert(albedo: (0.5, 0.5, 0.5))},
        meshes: {"ball": Icosphere(subdivisions: 2), "spare": Box(min: (0, 0, 0), max: (1, 1, 1))},
        entities: [
            (name: "a", shape: Instance(mesh: "ball"), material: "m"),
            (name: "b", transform: (translate: (3, 0, 0)), shape: Instance(mesh: "ball"), material: "m"),
        ])"#;
    let s = parse_scene(text, Path::new("i.ron")).unwrap();
    assert_eq!(s.meshes.len(), 1, "only the used asset is loaded");
    assert_eq!(s.meshes[0].triangles.len(), 320);
    let mut q = s.world.query::<&super::components::Instanced>();
    let all: Vec<_> = q.iter().collect();
    assert_eq!(all.len(), 2);
    assert!(all
        .iter()
        .all(|i| i.mesh == 0 && std::sync::Arc::ptr_eq(&i.asset, &s.meshes[0])));
    // Two instances + the table's own reference.
    assert_eq!(std::sync::Arc::strong_count(&s.meshes[0]), 3);
    assert!(s
        .warnings
        .iter()
        .any(|w| w.contains("mesh `spare` is not used")));
}

/// Every scene of `scenes/` written out by [`crate::formats::import::write_ron`] reads back as the same
/// description: what `raylab import` writes is what the importer built.
#[test]
fn scene_descriptions_round_trip_through_ron() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).expect("scenes/") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|e| e != "ron") || path.ends_with("suite.ron") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("read");
        let file = super::load::parse_scene_file(&text, &path).expect("parses");
        let written = crate::formats::import::write_ron(&file, "round trip").unwrap();
        let again = super::load::parse_scene_file(&written, &path)
            .unwrap_or_else(|e| panic!("{}: {e}\n{written}", path.display()));
        assert_eq!(file, again, "{}\n{written}", path.display());
        seen += 1;
    }
    assert!(seen >= 10, "{seen} scenes");
}

/// Every Mitsuba and pbrt-v4 scene of `scenes/`, imported, written as `raylab import` writes
/// it and read back, is the description the importer built.
#[test]
fn imported_scenes_round_trip_through_ron() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut seen = 0;
    for dir in ["mitsuba", "pbrt"] {
        for entry in std::fs::read_dir(root.join(dir)).expect("folder") {
            let path = entry.expect("entry").path();
            if !super::load::is_imported(&path) {
                continue;
            }
            let files = crate::formats::access::SceneFiles::new(&path, &[]);
            let imported = super::load::import_scene(&files, &Default::default())
                .expect("imports")
                .expect("another format");
            let written = imported.ron().unwrap();
            let again = super::load::parse_scene_file(&written, &path)
                .unwrap_or_else(|e| panic!("{}: {e}\n{written}", path.display()));
            assert_eq!(imported.scene, again, "{}\n{written}", path.display());
            seen += 1;
        }
    }
    assert!(seen >= 8, "{seen} scenes");
}
