//! Edits of a live scene: each kind of edit rebuilds only what it should, and the scene it
//! reaches renders the bits the same file loaded fresh renders.

use super::*;
use crate::render::{self, RenderSettings};
use crate::scene::load::parse_scene_file;
use crate::scene::parse_scene;
use raylab_integrators::registry;

/// A Cornell-like room with a large mesh (81,920 triangles: a BVH of its own), a small box,
/// two instances of an asset, an area light and a point light. Every edit below replaces one
/// unique piece of this text.
const BASE: &str = r#"(
    camera: LookAt(eye: (0, 0, 3.9), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (24, 18)),
    render: (integrator: "path", params: {"max-depth": 4}),
    materials: {
        "white": Lambert(albedo: (0.8, 0.7, 0.6)),
        "red": Lambert(albedo: (0.6, 0.05, 0.05)),
        "glass": Dielectric(int_ior: 1.5),
    },
    meshes: {"ball": Icosphere(subdivisions: 2)},
    entities: [
        (name: "floor", shape: Quad(vertices: [(-1, -1, 1), (1, -1, 1), (1, -1, -1), (-1, -1, -1)]), material: "white"),
        (name: "back", shape: Quad(vertices: [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1)]), material: "white"),
        (name: "ceiling", shape: Quad(vertices: [(-1, 1, -1), (1, 1, -1), (1, 1, 1), (-1, 1, 1)]), material: "white"),
        (name: "big", transform: (translate: (0, -0.5, 0), scale: (0.4, 0.4, 0.4)), shape: Icosphere(subdivisions: 6, displacement: 0.05), material: "white"),
        (name: "block", transform: (translate: (0.6, -0.85, 0.4), scale: (0.15, 0.15, 0.15)), shape: Box(min: (-1, -1, -1), max: (1, 1, 1)), material: "red"),
        (name: "ball A", transform: (translate: (-0.6, -0.8, 0.3), scale: (0.2, 0.2, 0.2)), shape: Instance(mesh: "ball"), material: "white"),
        (name: "ball B", transform: (translate: (0.6, -0.8, -0.5), scale: (0.2, 0.2, 0.2)), shape: Instance(mesh: "ball"), material: "glass"),
        (name: "light", shape: Quad(vertices: [(-0.25, 0.99, -0.2), (0.25, 0.99, -0.2), (0.25, 0.99, 0.2), (-0.25, 0.99, 0.2)]), material: "white", emitter: Area(radiance: (15, 12, 8))),
        (name: "lamp", transform: (translate: (0.5, 0.5, 0.5)), emitter: Point(intensity: (0.5, 0.5, 0.5))),
    ],
)"#;

fn path() -> &'static Path {
    Path::new("edit.ron")
}

fn file(text: &str) -> SceneFile {
    parse_scene_file(text, path()).expect("the test's scene parses")
}

/// The film's bits of `scene` rendered with `integrator` (4 spp, seed 3, one thread).
fn film_bits(loaded: &LoadedScene, scene: &RenderScene, integrator: &str) -> Vec<u32> {
    let entry = registry::find(integrator).unwrap();
    let mut integrator = entry.build_checked(&entry.resolve(&[]).unwrap()).unwrap();
    let (film, _) = render::render(
        scene,
        &loaded.camera,
        integrator.as_mut(),
        &RenderSettings::fixed(4, 3, Some(1)),
    )
    .unwrap();
    film.pixels
        .iter()
        .flat_map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

/// Applies `text` to `state`, checks what was rebuilt, and that the result renders as the same
/// text loaded fresh does.
fn edit_to(state: &mut SceneState, text: &str, expected: Rebuilt) -> EditReport {
    let report = state.apply(file(text)).unwrap();
    let (edited, rebuilt) = state.render_scene(AccelKind::Raylab, Some(1)).unwrap();
    assert_eq!(rebuilt, expected, "{}", report.describe());
    assert!(
        state
            .loaded
            .world
            .query::<&Changed>()
            .iter()
            .next()
            .is_none(),
        "the build clears the marks"
    );
    let fresh = parse_scene(text, path()).unwrap();
    assert_as_fresh(&state.loaded, &edited, &fresh, &report.describe());
    report
}

/// Checks that `edited` (built of `loaded`) holds what the build of `fresh` holds and renders
/// its bits, with `path` and `bdpt`; `after` names the edit in messages.
fn assert_as_fresh(loaded: &LoadedScene, edited: &RenderScene, fresh: &LoadedScene, after: &str) {
    let built = RenderScene::build(fresh);
    assert_eq!(
        edited.stats.triangles, built.stats.triangles,
        "after {after}"
    );
    assert_eq!(edited.stats.lights, built.stats.lights, "after {after}");
    for integrator in ["path", "bdpt"] {
        assert!(
            film_bits(loaded, edited, integrator) == film_bits(fresh, &built, integrator),
            "{integrator} after {after} differs from a fresh load"
        );
    }
}

/// Writes `text` to the file `scene`, applies it to `state` (or loads it, the first time),
/// checks that the result renders as the file loaded fresh, and returns what was rebuilt.
fn save_and_check(state: &mut Option<SceneState>, scene: &Path, text: &str) -> Rebuilt {
    std::fs::write(scene, text).unwrap();
    let file = parse_scene_file(text, scene).unwrap();
    let s = match state {
        Some(s) => {
            s.apply(file).unwrap();
            s
        }
        None => state.insert(SceneState::new(file, scene, SceneFiles::new(scene, &[])).unwrap()),
    };
    let (edited, rebuilt) = s.render_scene(AccelKind::Raylab, Some(1)).unwrap();
    let fresh = super::super::load_scene(scene).unwrap();
    assert_as_fresh(&s.loaded, &edited, &fresh, &format!("{rebuilt:?}"));
    rebuilt
}

fn replaced(text: &str, from: &str, to: &str) -> String {
    assert_eq!(text.matches(from).count(), 1, "`{from}` must be unique");
    text.replace(from, to)
}

#[test]
fn every_kind_of_edit_rebuilds_only_what_it_changed_and_renders_as_a_fresh_load() {
    let mut state = SceneState::new(file(BASE), path(), SceneFiles::new(path(), &[])).unwrap();
    let (_, rebuilt) = state.render_scene(AccelKind::Raylab, Some(1)).unwrap();
    assert_eq!(rebuilt, Rebuilt::Everything);
    let two = |kept| Rebuilt::Geometry { kept, meshes: 2 };

    // A material's colour: the accelerator and light table are kept.
    let text = replaced(BASE, "(0.6, 0.05, 0.05)", "(0.1, 0.5, 0.1)");
    let r = edit_to(&mut state, &text, Rebuilt::Nothing);
    assert_eq!(r.materials, ["red"]);
    assert!(r.changed.is_empty() && r.added.is_empty() && r.removed.is_empty());
    assert_eq!(r.kept, 9, "every entity kept");

    // The render defaults (an integrator parameter): nothing.
    let text = replaced(&text, r#""max-depth": 4"#, r#""max-depth": 6"#);
    let r = edit_to(&mut state, &text, Rebuilt::Nothing);
    assert!(r.render && r.describe() == "render settings changed");

    // A moved small entity: the flat BVH and the top level; both mesh BVHs kept.
    let text = replaced(&text, "(0.6, -0.85, 0.4)", "(0.5, -0.85, 0.3)");
    let r = edit_to(&mut state, &text, two(2));
    assert_eq!(r.describe(), "1 entity changed (transform)");

    // A moved instance.
    let text = replaced(&text, "(-0.6, -0.8, 0.3)", "(-0.5, -0.7, 0.3)");
    edit_to(&mut state, &text, two(2));

    // An added sphere, before the lights: they change place in the file.
    let text = replaced(
        &text,
        "        (name: \"light\"",
        "        (name: \"new\", shape: Sphere(center: (0, 0.2, 0), radius: 0.1), material: \"glass\"),\n        (name: \"light\"",
    );
    let r = edit_to(&mut state, &text, two(2));
    assert_eq!(r.added, ["new"]);
    assert!(
        r.describe().contains("place in the file"),
        "{}",
        r.describe()
    );

    // An emitter's radiance: the light table only.
    let text = replaced(&text, "radiance: (15, 12, 8)", "radiance: (9, 9, 9)");
    let r = edit_to(&mut state, &text, Rebuilt::Lights);
    assert_eq!(r.describe(), "1 entity changed (emitter)");

    // Which material an entity uses: the material indices in the BVH change.
    let text = replaced(
        &text,
        "Box(min: (-1, -1, -1), max: (1, 1, 1)), material: \"red\"",
        "Box(min: (-1, -1, -1), max: (1, 1, 1)), material: \"glass\"",
    );
    let r = edit_to(&mut state, &text, two(2));
    assert_eq!(r.describe(), "1 entity changed (material)");

    // A removed entity.
    let text = replaced(
        &text,
        "        (name: \"ball B\", transform: (translate: (0.6, -0.8, -0.5), scale: (0.2, 0.2, 0.2)), shape: Instance(mesh: \"ball\"), material: \"glass\"),\n",
        "",
    );
    let r = edit_to(&mut state, &text, two(2));
    assert_eq!(r.removed, ["ball B"]);

    // A save that breaks the scene leaves the world as it was; the one that fixes it applies.
    let entities = state.loaded.world.len();
    let broken = replaced(
        &text,
        "material: \"glass\"),\n        (name: \"light\"",
        "material: \"steel\"),\n        (name: \"light\"",
    );
    let e = state.apply(file(&broken)).unwrap_err().to_string();
    assert!(
        e.contains("entity `new`") && e.contains("unknown material `steel`"),
        "{e}"
    );
    assert_eq!(state.loaded.world.len(), entities);
    let e = state
        .apply(file(&replaced(&text, "radius: 0.1)", "radius: -0.1)")))
        .unwrap_err();
    assert!(e.to_string().contains("radius must be positive"), "{e}");
    // Nothing of the failed saves stayed: the last good text again changes nothing and
    // renders as its fresh load.
    edit_to(&mut state, &text, Rebuilt::Nothing);
    let fixed = replaced(&text, "radius: 0.1)", "radius: 0.15)");
    edit_to(&mut state, &fixed, two(2));

    // The large mesh's shape: its own BVH is built again, the asset's kept.
    let text = replaced(&fixed, "displacement: 0.05", "displacement: 0.02");
    let r = edit_to(&mut state, &text, two(1));
    assert_eq!(r.describe(), "1 entity changed (shape)");

    // The asset the instances place: their BVH is built again, the large mesh's kept.
    let text = replaced(
        &text,
        "Icosphere(subdivisions: 2)",
        "Icosphere(subdivisions: 3)",
    );
    let r = edit_to(&mut state, &text, two(1));
    assert_eq!(r.describe(), "1 entity changed (shape)");

    // Saving the same file again: nothing.
    let r = edit_to(&mut state, &text, Rebuilt::Nothing);
    assert_eq!(r.describe(), "nothing changed");
}

#[test]
fn entities_are_matched_by_name_then_by_order_among_the_unnamed() {
    let text = r#"(
        camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (8, 8)),
        materials: {"w": Lambert(albedo: (0.5, 0.5, 0.5))},
        entities: [
            (shape: Sphere(radius: 1), material: "w"),
            (name: "a", shape: Sphere(center: (2, 0, 0), radius: 1), material: "w"),
            (shape: Sphere(center: (-2, 0, 0), radius: 1), material: "w"),
            (emitter: Point(intensity: (1, 1, 1))),
        ],
    )"#;
    let mut state = SceneState::new(file(text), path(), SceneFiles::new(path(), &[])).unwrap();
    state.render_scene(AccelKind::Raylab, None).unwrap();
    // The named entity moves to the end: matched by its name, it changes place, and the
    // unnamed ones after it change place too; nothing is added or removed.
    let moved = text.replace(
        "            (name: \"a\", shape: Sphere(center: (2, 0, 0), radius: 1), material: \"w\"),\n",
        "",
    );
    let moved = moved.replace(
        "            (emitter: Point",
        "            (name: \"a\", shape: Sphere(center: (2, 0, 0), radius: 1), material: \"w\"),\n            (emitter: Point",
    );
    let r = state.apply(file(&moved)).unwrap();
    assert!(
        r.added.is_empty() && r.removed.is_empty(),
        "{}",
        r.describe()
    );
    let changed: Vec<&str> = r.changed.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(changed, ["entity #1", "a"], "{}", r.describe());
    assert!(r.changed.iter().all(|(_, c)| c.order && !c.shape));
}

#[test]
fn a_saved_mesh_file_rebuilds_the_bvh_of_that_mesh_alone() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.ron");
    let obj = dir.path().join("m.obj");
    let pyramid = |h: f32| {
        format!(
            "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv 0 {h} 0\n\
             f 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n"
        )
    };
    std::fs::write(&obj, pyramid(1.0)).unwrap();
    let text = r#"(
        camera: LookAt(eye: (0, 1, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (16, 12)),
        materials: {"w": Lambert(albedo: (0.5, 0.5, 0.5))},
        meshes: {"pyramid": Obj(path: "m.obj"), "ball": Icosphere(subdivisions: 1)},
        entities: [
            (name: "floor", shape: Quad(vertices: [(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)]), material: "w"),
            (name: "p", shape: Instance(mesh: "pyramid"), material: "w"),
            (name: "b", transform: (translate: (2, 0.5, 0)), shape: Instance(mesh: "ball"), material: "w"),
            (name: "lamp", transform: (translate: (0, 3, 2)), emitter: Point(intensity: (20, 20, 20))),
        ],
    )"#;
    std::fs::write(&scene, text).unwrap();
    let parse = || parse_scene_file(text, &scene).unwrap();
    let mut state = SceneState::new(parse(), &scene, SceneFiles::new(&scene, &[])).unwrap();
    state.render_scene(AccelKind::Raylab, Some(1)).unwrap();

    // The same text, the OBJ file grown (a different length: its stamp changes).
    std::fs::write(&obj, pyramid(2.5)).unwrap();
    let r = state.apply(parse()).unwrap();
    assert_eq!(r.describe(), "1 entity changed (shape)");
    let (edited, rebuilt) = state.render_scene(AccelKind::Raylab, Some(1)).unwrap();
    assert_eq!(rebuilt, Rebuilt::Geometry { kept: 1, meshes: 2 });
    let fresh = super::super::load_scene(&scene).unwrap();
    assert_as_fresh(&state.loaded, &edited, &fresh, "the OBJ's save");
}

#[test]
fn a_mesh_file_split_by_its_materials_and_back_renders_as_a_fresh_load() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.ron");
    std::fs::write(
        dir.path().join("m.obj"),
        "mtllib m.mtl\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv 0 1 0\n\
         usemtl a\nf 1 2 5\nf 2 3 5\nusemtl b\nf 3 4 5\nf 4 1 5\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl a\nKd 0.8 0.1 0.1\nnewmtl b\nKd 0.1 0.1 0.8\nKe 2 2 2\n",
    )
    .unwrap();
    let text = |material: &str| {
        format!(
            r#"(
        camera: LookAt(eye: (0, 1, 4), look_at: (0, 0.3, 0), up: (0, 1, 0), fov: 40, resolution: (16, 12)),
        materials: {{"w": Lambert(albedo: (0.5, 0.5, 0.5))}},
        entities: [
            (shape: Quad(vertices: [(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)]), material: "w"),
            (name: "p", shape: Obj(path: "m.obj"), material: "{material}"),
            (transform: (translate: (0, 3, 2)), emitter: Point(intensity: (20, 20, 20))),
        ],
    )"#
        )
    };
    let mut state = None;
    // Split, then one entity of one material, then split again.
    for material in ["from-file", "w", "from-file"] {
        save_and_check(&mut state, &scene, &text(material));
    }
}

#[test]
fn edits_of_an_environment_map_and_other_lights_render_as_a_fresh_load() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    std::fs::create_dir(dir.path().join("assets")).unwrap();
    std::fs::copy(
        scenes.join("assets/sky.hdr"),
        dir.path().join("assets/sky.hdr"),
    )
    .unwrap();
    let scene = dir.path().join("sky.ron");
    let base = std::fs::read_to_string(scenes.join("sky.ron"))
        .unwrap()
        .replace("resolution: (400, 240)", "resolution: (20, 12)");
    let mut state = None;
    let sky = r#"(name: "sky", emitter: Environment(path: "assets/sky.hdr"))"#;
    // Each step edits the one before.
    let scaled = replaced(
        &base,
        sky,
        r#"(name: "sky", emitter: Environment(path: "assets/sky.hdr", scale: 2))"#,
    );
    let turned = replaced(
        &scaled,
        "(name: \"sky\", emitter",
        "(name: \"sky\", transform: (rotate: (0, 40, 0)), emitter",
    );
    let others = replaced(
        &replaced(
            &turned,
            "intensity: (60, 50, 40)",
            "intensity: (20, 50, 40)",
        ),
        "direction: (0.2, -0.3, 1)",
        "direction: (-0.2, -0.5, 1)",
    );
    let steps = [
        (base.clone(), Rebuilt::Everything),
        // The map's scale: the light table.
        (scaled, Rebuilt::Lights),
        // The map turned: made again (its rotation is baked into it); a transform changed.
        (turned, Rebuilt::Geometry { kept: 0, meshes: 0 }),
        // A spot's intensity and the moon's direction: the light table.
        (others, Rebuilt::Lights),
    ];
    for (text, expected) in steps {
        assert_eq!(
            save_and_check(&mut state, &scene, &text),
            expected,
            "{text}"
        );
    }
}
