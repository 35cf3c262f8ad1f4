//! A bounded property test of the scene loader and the build step, the entry point the fuzz
//! target (`fuzz/fuzz_targets/scene_loader.rs`) drives: whatever the text, `parse_scene`
//! returns a scene or an error and never panics, and every scene it returns builds (and
//! renders a few pixels with the `normals` view).
//!
//! Three kinds of input: arbitrary strings; the shipped scenes truncated or with a piece
//! replaced; and structurally plausible scenes whose numbers are drawn from a pool that
//! includes NaN, infinities, zero, negative, tiny and huge values.

use proptest::prelude::*;
use proptest::test_runner::Config;
use raylab::render::{render, RenderSettings};
use raylab::scene::parse_scene;
use raylab::scene::RenderScene;
use std::path::Path;

/// Loads, and for scenes that load, builds and renders 4x4 pixels at 1 spp.
fn load_build_render(text: &str) -> bool {
    let Ok(loaded) = parse_scene(text, Path::new("proptest.ron")) else {
        return false;
    };
    let built = RenderScene::build(&loaded);
    assert!(
        built.stats.triangles + built.stats.spheres + built.stats.quadrics + built.stats.instances
            > 0,
        "a loaded scene has geometry"
    );
    let camera = loaded.camera.with_resolution(4, 4);
    let mut normals = raylab::integrators::find("normals")
        .unwrap()
        .instantiate(&[])
        .unwrap();
    render(
        &built,
        &camera,
        normals.as_mut(),
        &RenderSettings::fixed(1, 0, Some(1)),
    )
    .unwrap();
    true
}

/// 256 cases each (about a second); set `PROPTEST_CASES` for a longer hunt.
fn config() -> Config {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|c| c.parse().ok())
        .unwrap_or(256);
    Config {
        cases,
        ..Config::default()
    }
}

/// A number as a scene file may spell it: plausible, or with probability `hostile` percent
/// one of NaN, the infinities, zero, tiny, huge or any `f32` at all.
fn num(hostile: u32) -> impl Strategy<Value = String> {
    prop_oneof![
        (100 - hostile) => prop_oneof![
            (-4i32..=4).prop_map(|i| i.to_string()),
            (-10.0f32..10.0).prop_map(|f| format!("{f:?}")),
        ],
        hostile => prop_oneof![
            3 => prop::sample::select(vec![
                "NaN", "inf", "-inf", "0", "-0", "0.0", "-1", "1e38", "-1e38", "3.4e38",
                "-3.4e38", "1e-30", "1e-45", "-1e-45", "1e20", "179.99", "360", "4294967296",
            ])
            .prop_map(str::to_string),
            1 => any::<f32>().prop_map(|f| format!("{f:?}")),
        ],
    ]
}

fn v3(h: u32) -> impl Strategy<Value = String> {
    (num(h), num(h), num(h)).prop_map(|(a, b, c)| format!("({a}, {b}, {c})"))
}

/// A colour: a reflectance in [0, 1] unless hostile.
fn colour(h: u32) -> impl Strategy<Value = String> {
    prop_oneof![
        (100 - h) => [0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0]
            .prop_map(|[r, g, b]| format!("({r:?}, {g:?}, {b:?})")),
        h => v3(100),
    ]
}

/// A small-integer point (so that quads built from it can be exact parallelograms).
fn int3() -> impl Strategy<Value = [i32; 3]> {
    [-3i32..=3, -3i32..=3, -3i32..=3]
}

fn p(a: [i32; 3]) -> String {
    format!("({}, {}, {})", a[0], a[1], a[2])
}

fn resolution(h: u32) -> impl Strategy<Value = String> {
    let side = prop_oneof![
        (100 - h) => (1u32..20).prop_map(|n| n.to_string()),
        h => prop::sample::select(vec!["0", "400", "65536", "65537", "4294967295", "-1"])
            .prop_map(str::to_string),
    ];
    prop::option::of((side.clone(), side))
        .prop_map(|r| r.map_or(String::new(), |(w, h)| format!(", resolution: ({w}, {h})")))
}

fn fov(h: u32) -> impl Strategy<Value = String> {
    prop_oneof![
        (100 - h) => (1.0f32..170.0).prop_map(|f| format!("{f:?}")),
        h => num(100),
    ]
}

fn camera(h: u32) -> impl Strategy<Value = String> {
    prop_oneof![
        4 => (int3(), fov(h), resolution(h)).prop_map(|(eye, fov, res)| format!(
            "LookAt(eye: {}, look_at: (0.5, 0.25, -10), up: (0, 1, 0), fov: {fov}{res})",
            p(eye)
        )),
        1 => (v3(h), v3(h), prop::option::of(v3(h)), fov(h), resolution(h)).prop_map(
            |(eye, at, up, fov, res)| {
                let up = up.map_or(String::new(), |u| format!(", up: {u}"));
                format!("LookAt(eye: {eye}, look_at: {at}{up}, fov: {fov}{res})")
            }
        ),
        1 => (int3(), int3(), int3(), resolution(h)).prop_map(|(e, o, u, res)| {
            // top_left o, top_right o + u, bottom_left o - z: a parallelogram (unless u is
            // zero or parallel to z, or the eye lies in its plane).
            let tr = [o[0] + u[0], o[1] + u[1], o[2] + u[2]];
            let bl = [o[0], o[1], o[2] - 1];
            let br = [tr[0], tr[1], tr[2] - 1];
            format!(
                "ImagePlane(eye: {}, top_left: {}, top_right: {}, bottom_left: {}, bottom_right: {}{res})",
                p(e), p(o), p(tr), p(bl), p(br)
            )
        }),
        1 => (v3(h), v3(h), v3(h), v3(h), v3(h), resolution(h)).prop_map(|(e, a, b, c, d, res)| format!(
            "ImagePlane(eye: {e}, top_left: {a}, top_right: {b}, bottom_left: {c}, bottom_right: {d}{res})"
        )),
    ]
}

/// A number in `[lo, hi)` unless hostile.
fn within(h: u32, lo: f32, hi: f32) -> impl Strategy<Value = String> {
    prop_oneof![
        (100 - h) => (lo..hi).prop_map(|f| format!("{f:?}")),
        h => num(100),
    ]
}

fn material(h: u32) -> impl Strategy<Value = String> {
    prop_oneof![
        3 => colour(h).prop_map(|a| format!("Lambert(albedo: {a})")),
        1 => (colour(h), within(h, 0.0, 90.0))
            .prop_map(|(a, s)| format!("OrenNayar(albedo: {a}, sigma: {s})")),
        // kd + ks <= 1: each at most a half (the ranges are exclusive).
        1 => ([0.0f32..0.5, 0.0f32..0.5, 0.0f32..0.5], [0.0f32..0.5, 0.0f32..0.5, 0.0f32..0.5], within(h, 0.0, 200.0))
            .prop_map(|(d, s, e)| format!(
                "Phong(kd: ({:?}, {:?}, {:?}), ks: ({:?}, {:?}, {:?}), exponent: {e})",
                d[0], d[1], d[2], s[0], s[1], s[2]
            )),
        1 => (colour(h), colour(h), num(h))
            .prop_map(|(d, s, e)| format!("Phong(kd: {d}, ks: {s}, exponent: {e})")),
        1 => prop::option::of(colour(h))
            .prop_map(|t| t.map_or("Mirror()".into(), |t| format!("Mirror(tint: {t})"))),
        1 => (within(h, 1.0, 4.0), prop::option::of(colour(h))).prop_map(|(i, t)| format!(
            "Glass(ior: {i}{})",
            t.map_or(String::new(), |t| format!(", tint: {t}"))
        )),
    ]
}

fn index(h: u32) -> impl Strategy<Value = String> {
    prop_oneof![
        (100 - h) => (0u32..4).prop_map(|i| i.to_string()),
        h => prop::sample::select(vec!["4", "5", "4294967295"]).prop_map(str::to_string),
    ]
}

fn shape(h: u32) -> impl Strategy<Value = String> {
    prop_oneof![
        (v3(h), num(h)).prop_map(|(c, r)| format!("Sphere(center: {c}, radius: {r})")),
        (int3(), 1i32..3).prop_map(|(c, r)| format!("Sphere(center: {}, radius: {r})", p(c))),
        Just("Disk".to_string()),
        (v3(h), v3(h), num(h))
            .prop_map(|(a, b, r)| format!("Cylinder(p0: {a}, p1: {b}, radius: {r})")),
        (int3(), int3(), 1i32..3).prop_map(|(a, b, r)| format!(
            "Cylinder(p0: {}, p1: {}, radius: {r})",
            p(a),
            p(b)
        )),
        prop::collection::vec(v3(h), 3..=3)
            .prop_map(|v| format!("Triangle(vertices: [{}])", v.join(", "))),
        (int3(), int3(), int3()).prop_map(|(a, b, c)| format!(
            "Triangle(vertices: [{}, {}, {}])",
            p(a),
            p(b),
            p(c)
        )),
        prop::collection::vec(v3(h), 4..=4)
            .prop_map(|v| format!("Quad(vertices: [{}])", v.join(", "))),
        (int3(), int3(), int3()).prop_map(|(o, e1, e2)| {
            let add = |a: [i32; 3], b: [i32; 3]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
            format!(
                "Quad(vertices: [{}, {}, {}, {}])",
                p(o),
                p(add(o, e1)),
                p(add(add(o, e1), e2)),
                p(add(o, e2))
            )
        }),
        prop::collection::vec(v3(h), 4..=4)
            .prop_map(|v| format!("Tetrahedron(vertices: [{}])", v.join(", "))),
        (v3(h), v3(h)).prop_map(|(a, b)| format!("Box(min: {a}, max: {b})")),
        // An instance of the scene's mesh asset `k0` (when it has one), or of an unknown name.
        prop::sample::select(vec!["k0", "k0", "k0", "k1"])
            .prop_map(|k| format!("Instance(mesh: \"{k}\")")),
        (int3(), 1i32..4).prop_map(|(a, s)| format!(
            "Box(min: {}, max: ({}, {}, {}))",
            p(a),
            a[0] + s,
            a[1] + s,
            a[2] + s
        )),
        (
            prop::collection::vec(v3(h), 4..=4),
            prop::collection::vec((index(h), index(h), index(h)), 1..5),
            prop::option::weighted(0.3, prop::collection::vec(v3(h), 4..=4)),
        )
            .prop_map(|(pos, idx, normals)| {
                let idx: Vec<String> = idx
                    .into_iter()
                    .map(|(a, b, c)| format!("({a}, {b}, {c})"))
                    .collect();
                let normals =
                    normals.map_or(String::new(), |n| format!(", normals: [{}]", n.join(", ")));
                format!(
                    "Mesh(positions: [{}], indices: [{}]{normals})",
                    pos.join(", "),
                    idx.join(", ")
                )
            }),
    ]
}

fn transform(h: u32) -> impl Strategy<Value = String> {
    let positive = prop_oneof![
        (100 - h) => (0.01f32..10.0).prop_map(|s| format!("{s:?}")),
        h => num(100),
    ];
    (
        prop::option::of(v3(h)),
        prop::option::of(prop_oneof![
            3 => v3(h),
            1 => (-1000.0f32..1000.0, -1000.0f32..1000.0, -1000.0f32..1000.0)
                .prop_map(|(a, b, c)| format!("({a:?}, {b:?}, {c:?})")),
        ]),
        prop::option::of(prop_oneof![
            positive.clone().prop_map(|s| format!("({s}, {s}, {s})")),
            (positive.clone(), positive.clone(), positive)
                .prop_map(|(a, b, c)| format!("({a}, {b}, {c})")),
        ]),
    )
        .prop_map(|(t, r, s)| {
            let parts: Vec<String> = [("translate", t), ("rotate", r), ("scale", s)]
                .into_iter()
                .filter_map(|(k, v)| v.map(|v| format!("{k}: {v}")))
                .collect();
            format!("({})", parts.join(", "))
        })
}

fn radiance(h: u32) -> impl Strategy<Value = String> {
    prop_oneof![
        (100 - h) => [0.0f32..50.0, 0.0f32..50.0, 0.0f32..50.0]
            .prop_map(|[r, g, b]| format!("({r:?}, {g:?}, {b:?})")),
        h => v3(100),
    ]
}

/// An entity: usually a shaped one with a material (an area emitter now and then) or a point
/// light; with probability `h` percent one of the mistakes the loader must catch.
fn entity(h: u32) -> impl Strategy<Value = String> {
    let kind = prop_oneof![
        (100 - h) => prop::sample::select(vec!["shaped", "shaped", "shaped", "area", "point"]),
        h => prop::sample::select(vec!["nothing", "area without shape", "point with shape", "no material", "unknown material"]),
    ];
    (
        prop::option::of(prop::sample::select(vec!["a", "b", "lamp", ""])),
        prop::option::of(transform(h)),
        shape(h),
        prop::sample::select(vec!["m0", "m1"]),
        radiance(h),
        any::<bool>(),
        kind,
    )
        .prop_map(|(name, t, shape, m, rad, two_sided, kind)| {
            let mut parts = Vec::new();
            if let Some(n) = name {
                parts.push(format!("name: \"{n}\""));
            }
            if let Some(t) = t {
                parts.push(format!("transform: {t}"));
            }
            let area = format!("emitter: Area(radiance: {rad}, two_sided: {two_sided})");
            let point = format!("emitter: Point(intensity: {rad})");
            let (shape, material) = (format!("shape: {shape}"), format!("material: \"{m}\""));
            parts.extend(match kind {
                "shaped" => vec![shape, material],
                "area" => vec![shape, area],
                "point" => vec![point],
                "area without shape" => vec![area],
                "point with shape" => vec![shape, material, point],
                "no material" => vec![shape],
                "unknown material" => vec![shape, "material: \"nope\"".to_string()],
                _ => vec![],
            });
            format!("({})", parts.join(", "))
        })
}

fn render_desc(h: u32) -> impl Strategy<Value = String> {
    (
        prop::sample::select(vec!["path", "normals", "whitted", "depth"]),
        1u32..64,
        prop::option::of(prop_oneof![
            (100 - h) => (0u32..10).prop_map(|d| d.to_string()),
            h => num(100),
        ]),
    )
        .prop_map(|(i, spp, depth)| {
            let params = match (i, depth) {
                ("path" | "whitted", Some(d)) => format!(", params: {{\"max-depth\": {d}}}"),
                _ => String::new(),
            };
            format!("render: (integrator: \"{i}\", spp: {spp}{params}),")
        })
}

/// A whole scene file with hostility `h` (percent): the chance that any one number, or any
/// one entity's structure, is one the loader must refuse.
fn plausible_scene_with(h: u32) -> impl Strategy<Value = String> {
    (
        camera(h),
        prop::option::of(render_desc(h)),
        prop::collection::vec(material(h), 2..=2),
        prop::option::weighted((f64::from(h) / 100.0).max(0.001), material(h)),
        prop::option::weighted(0.2, radiance(h)),
        prop::collection::vec(entity(h), 1..5),
        prop::option::weighted(0.7, shape(h)),
    )
        .prop_map(
            |(camera, render, mut materials, duplicate, env, entities, asset)| {
                materials.extend(duplicate);
                let mut s = format!("(\n    camera: {camera},\n");
                if let Some(r) = render {
                    s += &format!("    {r}\n");
                }
                // Names m0, m1, then m0 again: a third material is a duplicate name.
                let materials: Vec<String> = materials
                    .iter()
                    .enumerate()
                    .map(|(i, m)| format!("\"m{}\": {m}", i % 2))
                    .collect();
                s += &format!("    materials: {{{}}},\n", materials.join(", "));
                if let Some(e) = env {
                    s += &format!("    environment: {e},\n");
                }
                if let Some(a) = asset {
                    s += &format!("    meshes: {{\"k0\": {a}}},\n");
                }
                s += &format!(
                    "    entities: [\n        {}\n    ],\n)\n",
                    entities.join(",\n        ")
                );
                s
            },
        )
}

/// Scenes from harmless to hostile.
fn plausible_scene() -> impl Strategy<Value = String> {
    prop::sample::select(vec![0u32, 0, 1, 3, 10, 50]).prop_flat_map(plausible_scene_with)
}

const SCENES: [&str; 3] = [
    include_str!("../../scenes/cornell_box.ron"),
    include_str!("../../scenes/report_room.ron"),
    include_str!("../../scenes/instances.ron"),
];

/// A shipped scene, truncated, or with a piece cut out or replaced by a token.
fn mangled_scene() -> impl Strategy<Value = String> {
    let token = prop_oneof![
        Just(String::new()),
        num(100),
        prop::sample::select(vec![
            "(", ")", "[", "]", ",", ":", "\"", "//", "Sphere", "radius"
        ])
        .prop_map(str::to_string),
    ];
    (
        0..SCENES.len(),
        any::<prop::sample::Index>(),
        0usize..40,
        token,
    )
        .prop_map(|(which, at, len, token)| {
            let text = SCENES[which];
            let mut start = at.index(text.len() + 1);
            while !text.is_char_boundary(start) {
                start -= 1;
            }
            let mut end = (start + len).min(text.len());
            while !text.is_char_boundary(end) {
                end -= 1;
            }
            if len == 0 {
                text[..start].to_string() // truncated
            } else {
                format!("{}{token}{}", &text[..start], &text[end..])
            }
        })
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn arbitrary_text_never_panics(text in any::<String>()) {
        load_build_render(&text);
    }

    #[test]
    fn ron_like_text_never_panics(text in "[(){}\\[\\]:,\" a-zA-Z0-9._-]{0,120}") {
        load_build_render(&text);
    }

    #[test]
    fn mangled_shipped_scenes_never_panic(text in mangled_scene()) {
        load_build_render(&text);
    }

    #[test]
    fn plausible_scenes_with_hostile_numbers_load_or_fail_cleanly(text in plausible_scene()) {
        load_build_render(&text);
    }
}

/// The generator of plausible scenes must reach the build step often, or the property above
/// says little about it.
#[test]
fn plausible_scenes_often_load() {
    use proptest::strategy::ValueTree;
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    let strategy = plausible_scene();
    let loaded = (0..256)
        .filter(|_| load_build_render(&strategy.new_tree(&mut runner).unwrap().current()))
        .count();
    eprintln!("{loaded} of 256 plausible scenes loaded");
    assert!(loaded >= 40, "only {loaded} of 256 plausible scenes loaded");
}
