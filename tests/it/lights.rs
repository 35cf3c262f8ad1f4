//! The lights of the field through every light-transport integrator of the registry, each
//! against its closed form: a floor under a directional light, a floor under a spot light, and
//! a diffuse ball under a uniform environment map (which must equal the constant environment).

use crate::common::{render_text, render_text_with};
use raylab::accel::AccelKind;
use raylab_integrators::registry::REGISTRY;
use std::f32::consts::PI;

/// The integrators that estimate light transport (not the debug views).
fn transport_integrators() -> Vec<&'static str> {
    REGISTRY
        .iter()
        .map(|e| e.name)
        .filter(|n| !matches!(*n, "normals" | "albedo" | "depth"))
        .collect()
}

/// Parameters for these small images: the merging integrators trace one light subpath per
/// pixel (64 to 576 a pass here), too few to find one within their default radius often;
/// they merge within 10 cm instead.
fn params_for(integrator: &str) -> &'static [(&'static str, &'static str)] {
    if matches!(integrator, "bpm" | "vcm") {
        &[("radius", "0.1")]
    } else {
        &[]
    }
}

/// Renders `scene` (written to a temporary folder with `files`) with `integrator` and returns
/// the green channel's mean over the image and its standard error.
fn mean_green(scene: &str, files: &[(&str, Vec<u8>)], integrator: &str, spp: u32) -> (f32, f32) {
    let params = params_for(integrator);
    let film = render_text_with(scene, files, integrator, params, spp, 7, AccelKind::Raylab);
    (film.mean().y, film.mean_standard_error().y)
}

/// Photon density estimation blurs and is biased by its radius; everything else is unbiased.
fn tolerance(integrator: &str, expected: f32, se: f32) -> f32 {
    let bias = if matches!(integrator, "photon" | "sppm" | "sppm-pixel" | "bpm" | "vcm") {
        0.03 * expected
    } else {
        0.0
    };
    4.5 * se + bias + 1e-4 * expected
}

fn check_all(what: &str, scene: &str, files: &[(&str, Vec<u8>)], expected: f32, spp: u32) {
    check(what, scene, files, expected, spp, &transport_integrators());
}

/// [`check_all`] for a closed form at one point, seen through [`CAMERA`]'s 2-degree view: by
/// the integrators that trace paths from the camera. A light tracer would have to land its
/// paths on a spot a few centimetres wide on a 100 m floor; it is checked against `path` on
/// the same lights with a wide view instead
/// (`light_path_integrators_agree_with_path_under_every_kind_of_light`).
fn check_narrow_view(what: &str, scene: &str, expected: f32, spp: u32) {
    let camera_paths: Vec<&str> = transport_integrators()
        .into_iter()
        .filter(|n| !connects_to_the_lens(n))
        .collect();
    check(what, scene, &[], expected, spp, &camera_paths);
}

/// True for the integrators whose paths start at the lights and connect to the lens.
fn connects_to_the_lens(name: &str) -> bool {
    let entry = REGISTRY.iter().find(|e| e.name == name).unwrap();
    entry.instantiate(&[]).unwrap().demand().pinhole
}

fn check(
    what: &str,
    scene: &str,
    files: &[(&str, Vec<u8>)],
    expected: f32,
    spp: u32,
    integrators: &[&str],
) {
    for &name in integrators {
        let (mean, se) = mean_green(scene, files, name, spp);
        println!("{what}, {name}: {mean:.5} +- {se:.5} (expected {expected:.5})");
        assert!(
            (mean - expected).abs() <= tolerance(name, expected, se),
            "{what}, {name}: {mean} +- {se}, expected {expected}"
        );
    }
}

/// A camera looking straight down at the origin of a large floor (y = 0) through a narrow
/// field of view.
const CAMERA: &str = "camera: LookAt(eye: (0, 1, 0), look_at: (0, 0, 0), up: (0, 0, -1), fov: 2, resolution: (8, 8)),";
const FLOOR: &str = r#"(name: "floor", shape: Quad(vertices: [(-50, 0, 50), (50, 0, 50), (50, 0, -50), (-50, 0, -50)]), material: "grey"),"#;

#[test]
fn a_floor_under_a_directional_light_has_radiance_a_e_cos_over_pi() {
    // Irradiance 2 at 45 degrees: the floor's radiance is 0.5 / pi * 2 * cos 45.
    let scene = format!(
        r#"({CAMERA}
            materials: {{"grey": Lambert(albedo: (0.5, 0.5, 0.5))}},
            entities: [{FLOOR}
                (name: "sun", emitter: Directional(direction: (0, -1, -1), irradiance: (2, 2, 2))),
            ])"#
    );
    let expected = 0.5 / PI * 2.0 * std::f32::consts::FRAC_1_SQRT_2;
    check_narrow_view("directional", &scene, expected, 16);
}

#[test]
fn a_floor_under_a_spot_light_has_radiance_a_i_over_pi_h2() {
    // Intensity 8 from 2 m straight above, inside the beam: E = 8 / 4 at the centre.
    let scene = format!(
        r#"({CAMERA}
            materials: {{"grey": Lambert(albedo: (0.5, 0.5, 0.5))}},
            entities: [{FLOOR}
                (name: "spot", transform: (translate: (0, 2, 0)),
                 emitter: Spot(intensity: (8, 8, 8), look_at: (0, 0, 0), cutoff_angle: 30)),
            ])"#
    );
    // The 2-degree view sees the floor within 0.018 m of the centre: cos^3 > 0.9999.
    let expected = 0.5 / PI * 8.0 / 4.0;
    check_narrow_view("spot", &scene, expected, 16);
}

/// A Radiance HDR file of `w x h` texels, all of value `v` (flat scanlines).
fn uniform_hdr(w: usize, h: usize, v: f32) -> Vec<u8> {
    hdr(w, h, |_, _| v)
}

/// A Radiance HDR file of `w x h` grey texels of value `v(x, y)` (> 0; flat scanlines).
fn hdr(w: usize, h: usize, v: impl Fn(usize, usize) -> f32) -> Vec<u8> {
    let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for y in 0..h {
        for x in 0..w {
            let v = v(x, y);
            let e = v.log2().floor() as i32 + 1;
            let m = (v / 2f32.powi(e) * 256.0) as u8;
            bytes.extend_from_slice(&[m, m, m, (e + 128) as u8]);
        }
    }
    bytes
}

#[test]
fn a_uniform_environment_map_is_the_constant_environment() {
    // A convex ball of albedo 0.6 under a uniform sky of 0.5 (times the map's scale 2):
    // radiance 0.6 * 1.0, as with the constant environment.
    let scene = |sky: &str| {
        format!(
            r#"(camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 8, resolution: (8, 8)),
            {sky}
            materials: {{"ball": Lambert(albedo: (0.6, 0.6, 0.6))}},
            entities: [
                (name: "ball", shape: Sphere(radius: 1), material: "ball"),
                {}
            ])"#,
            if sky.is_empty() {
                r#"(name: "sky", transform: (rotate: (30, 40, 0)), emitter: Environment(path: "sky.hdr", scale: 2)),"#
            } else {
                ""
            }
        )
    };
    let files = [("sky.hdr", uniform_hdr(16, 8, 0.5))];
    check_all("uniform map", &scene(""), &files, 0.6, 64);
    check_all(
        "constant environment",
        &scene("environment: (1, 1, 1),"),
        &[],
        0.6,
        64,
    );
}

#[test]
fn inside_a_sphere_with_flipped_normals_the_furnace_holds() {
    // pbrt-v4's analytic furnace: a diffuse sphere (albedo 0.5) emitting 1 into its inside.
    // Radiance everywhere: the series 1 + a + a^2 + ... as far as each integrator sums it.
    let scene = r#"(camera: LookAt(eye: (0.1, -0.2, 0.3), look_at: (1, 0.4, 0), up: (0, 0, 1), fov: 60, resolution: (8, 8)),
        materials: {"white": Lambert(albedo: (0.5, 0.5, 0.5))},
        entities: [
            (name: "furnace", shape: Sphere(radius: 1), material: "white", flip_normals: true,
             emitter: Area(radiance: (1, 1, 1))),
        ])"#;
    for name in transport_integrators() {
        let expected = match name {
            // Le and one bounce.
            "whitted" | "direct" | "restir" => 1.5,
            "fixed-depth" => 1.75, // depth 2
            _ => 2.0,
        };
        let (mean, se) = mean_green(scene, &[], name, 32);
        println!("furnace, {name}: {mean:.5} +- {se:.5} (expected {expected})");
        assert!(
            (mean - expected).abs() <= tolerance(name, expected, se),
            "furnace, {name}: {mean} +- {se}, expected {expected}"
        );
    }
}

#[test]
fn a_floor_under_a_disk_light_has_radiance_a_l_r2_over_h2_plus_r2() {
    // A disk of radius 0.5 emitting 4 downwards from 2 m above the floor's centre: the
    // irradiance there is pi L r^2 / (h^2 + r^2). Once facing down by its rotation, once
    // facing up and turned around by flip_normals: the same light.
    let expected = 0.5 / PI * PI * 4.0 * 0.25 / (4.0 + 0.25);
    for (what, rotate, flip) in [
        ("disk", "(90, 0, 0)", false),
        ("flipped disk", "(-90, 0, 0)", true),
    ] {
        let scene = format!(
            r#"({CAMERA}
                materials: {{"grey": Lambert(albedo: (0.5, 0.5, 0.5))}},
                entities: [{FLOOR}
                    (name: "lamp", shape: Disk, transform: (translate: (0, 2, 0), scale: (0.5, 0.5, 1), rotate: {rotate}),
                     flip_normals: {flip}, emitter: Area(radiance: (4, 4, 4))),
                ])"#
        );
        check_narrow_view(what, &scene, expected, 16);
    }
}

#[test]
fn inside_a_cylinder_with_flipped_normals_under_a_matching_sky_the_furnace_holds() {
    // An open tube (albedo 0.5) emitting 1 into its inside, under a sky of 2 = 1 / (1 - 0.5):
    // radiance 2 everywhere, seen on the walls and through the ends. The walls light
    // themselves (next-event estimation from inside) and the sky through the ends. The report's
    // whitted and fixed-depth tracers, direct and restir truncate the series, so their answers depend
    // on the view.
    let scene = r#"(camera: LookAt(eye: (0.1, -0.2, 0.3), look_at: (0.6, 0.4, 2), up: (0, 0, 1), fov: 70, resolution: (8, 8)),
        environment: (2, 2, 2),
        materials: {"white": Lambert(albedo: (0.5, 0.5, 0.5))},
        entities: [
            (name: "tube", shape: Cylinder(p0: (0, 0, -1.5), p1: (0, 0, 1.5), radius: 1), material: "white",
             flip_normals: true, emitter: Area(radiance: (1, 1, 1))),
        ])"#;
    for name in transport_integrators() {
        if matches!(name, "whitted" | "fixed-depth" | "direct" | "restir") {
            continue;
        }
        let (mean, se) = mean_green(scene, &[], name, 32);
        println!("tube furnace, {name}: {mean:.5} +- {se:.5} (expected 2)");
        assert!(
            (mean - 2.0).abs() <= tolerance(name, 2.0, se),
            "tube furnace, {name}: {mean} +- {se}, expected 2"
        );
    }
}

#[test]
fn a_disk_light_placed_by_a_mirroring_matrix_faces_its_normal() {
    // The disk of the test above, radius 0.5 at 2 m, placed by a matrix that mirrors x: its
    // normal (the inverse transpose's +z) points down, and so must its light, whichever way
    // its axes turn.
    let expected = 0.5 / PI * PI * 4.0 * 0.25 / (4.0 + 0.25);
    let scene = format!(
        r#"({CAMERA}
            materials: {{"grey": Lambert(albedo: (0.5, 0.5, 0.5))}},
            entities: [{FLOOR}
                (name: "lamp", shape: Disk, transform: (matrix: [-0.5, 0, 0, 0,  0, 0, -1, 2,  0, 0.5, 0, 0]),
                 emitter: Area(radiance: (4, 4, 4))),
            ])"#
    );
    check_narrow_view("mirrored disk", &scene, expected, 16);
}

/// Light paths start where next-event estimation ends: at each light's emission sampling
/// (`sample_le`: positions, directions, densities and power), and bidirectional weights need
/// those densities again (`pdf_le`). Under every kind of light, a floor and a box seen
/// through a wide view render the same in every integrator that traces light paths to the
/// lens (`lighttracer`, `bdpt`) as in `path` (a z-test on the image mean, standard errors
/// from the films).
#[test]
fn light_path_integrators_agree_with_path_under_every_kind_of_light() {
    let lights = [
        (
            "directional",
            r#"(name: "sun", emitter: Directional(direction: (1, -2, -1), irradiance: (2, 2, 2)))"#,
        ),
        (
            "spot",
            r#"(name: "spot", transform: (translate: (0.5, 2, 0.5)), emitter: Spot(intensity: (8, 8, 8), look_at: (0, 0, 0), cutoff_angle: 40))"#,
        ),
        // In view: no integrator draws the point itself.
        (
            "point",
            r#"(name: "bulb", transform: (translate: (-0.5, 1.5, 0.5)), emitter: Point(intensity: (3, 3, 3)))"#,
        ),
        (
            "disk",
            r#"(name: "lamp", shape: Disk, transform: (translate: (0, 2, 0), scale: (0.5, 0.5, 1), rotate: (90, 0, 0)), emitter: Area(radiance: (4, 4, 4)))"#,
        ),
        (
            "sphere",
            r#"(name: "ball lamp", shape: Sphere(center: (0.8, 1.2, -0.5), radius: 0.2), emitter: Area(radiance: (6, 6, 6)))"#,
        ),
        (
            "tube",
            r#"(name: "tube", shape: Cylinder(p0: (-1, 1.5, -1), p1: (1, 1.5, -1), radius: 0.05), emitter: Area(radiance: (10, 10, 10)))"#,
        ),
        ("sky", ""),
        // A map 50 times brighter in one patch of its upper half than elsewhere: light paths
        // start where it is bright, camera paths sample it by its importance.
        (
            "sky map",
            r#"(name: "sky", transform: (rotate: (0, 30, 0)), emitter: Environment(path: "sky.hdr"))"#,
        ),
    ];
    let map = hdr(32, 16, |x, y| {
        if (4..8).contains(&y) && (8..14).contains(&x) {
            10.0
        } else {
            0.2
        }
    });
    for (what, light) in lights {
        let files = if what == "sky map" {
            vec![("sky.hdr", map.clone())]
        } else {
            vec![]
        };
        let light = if light.is_empty() {
            String::new()
        } else {
            format!("{light},")
        };
        let sky = if what == "sky" {
            "environment: (0.5, 0.6, 0.7),"
        } else {
            ""
        };
        let scene = format!(
            r#"(camera: LookAt(eye: (0, 2.5, 4), look_at: (0, 0.3, 0), up: (0, 1, 0), fov: 45, resolution: (24, 24)),
                {sky}
                materials: {{"grey": Lambert(albedo: (0.5, 0.5, 0.5)), "red": Lambert(albedo: (0.7, 0.2, 0.1))}},
                entities: [
                    (name: "floor", shape: Quad(vertices: [(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)]), material: "grey"),
                    (name: "box", shape: Box(min: (-0.4, 0, -0.4), max: (0.4, 0.8, 0.4)), material: "red"),
                    {light}
                ])"#
        );
        let path = render_text(&scene, &files, "path", 1024, 1, AccelKind::Raylab);
        let (a, sa) = (path.mean().y, path.mean_standard_error().y);
        for name in transport_integrators() {
            // Metropolis chains splat clusters, so per-pixel variances understate the image
            // mean's error: `mmlt` is checked on the sky's directional light, spot and
            // environment with standard errors from pass means (agreement.rs).
            if !connects_to_the_lens(name) || name == "mmlt" {
                continue;
            }
            let light = render_text_with(
                &scene,
                &files,
                name,
                params_for(name),
                1024,
                2,
                AccelKind::Raylab,
            );
            let (b, sb) = (light.mean().y, light.mean_standard_error().y);
            let se = (sa * sa + sb * sb).sqrt();
            println!("{what}: path {a:.5} +- {sa:.5}, {name} {b:.5} +- {sb:.5}");
            assert!(
                se < 0.02 * a,
                "{what}, {name}: too noisy to mean anything ({se} of {a})"
            );
            assert!(
                (a - b).abs() < 4.5 * se,
                "{what}: path {a} +- {sa}, {name} {b} +- {sb}"
            );
        }
    }
}

/// The image mean of `scene` (24x24) by `integrator` with `params`, its standard error per
/// channel beside it.
fn mean_with(
    built: &raylab::scene::RenderScene,
    loaded: &raylab::scene::LoadedScene,
    integrator: &str,
    params: &[(&str, &str)],
    seed: u64,
) -> ([f64; 3], [f64; 3]) {
    let camera = loaded.camera.with_resolution(24, 24);
    let given: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let mut it = raylab_integrators::registry::find(integrator)
        .unwrap()
        .instantiate(&given)
        .unwrap();
    let settings = raylab::render::RenderSettings::fixed(64, seed, None);
    let film = raylab::render::render(built, &camera, it.as_mut(), &settings)
        .unwrap()
        .0;
    let (m, s) = (film.mean(), film.mean_standard_error());
    (
        [m[0] as f64, m[1] as f64, m[2] as f64],
        [s[0] as f64, s[1] as f64, s[2] as f64],
    )
}

/// Every light selection agrees with `power` by a z-test on the image mean of every shipped
/// scene (`path`, or `volpath` where there are media), and ReSTIR (with and without reuse)
/// with `direct`'s light samples on the hall of lamps.
#[test]
fn every_light_selection_agrees_with_power_on_every_shipped_scene() {
    let z_ok = |a: ([f64; 3], [f64; 3]), b: ([f64; 3], [f64; 3]), what: &str| {
        for c in 0..3 {
            let se = (a.1[c] * a.1[c] + b.1[c] * b.1[c]).sqrt();
            let z = (a.0[c] - b.0[c]) / se.max(1e-12);
            assert!(
                z.abs() < 4.5,
                "{what}, channel {c}: {} vs {} (z {z:.2})",
                a.0[c],
                b.0[c]
            );
        }
    };
    let mut scenes: Vec<_> = std::fs::read_dir(crate::common::repo_file("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron") && !p.ends_with("suite.ron"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 15, "{scenes:?}");
    for path in &scenes {
        let loaded =
            raylab::scene::load_scene(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let built = raylab::scene::RenderScene::build(&loaded);
        let integrator = if built.has_media() { "volpath" } else { "path" };
        let power = mean_with(
            &built,
            &loaded,
            integrator,
            &[("max-depth", "5"), ("light-selection", "power")],
            1,
        );
        for selection in ["uniform", "bvh"] {
            let other = mean_with(
                &built,
                &loaded,
                integrator,
                &[("max-depth", "5"), ("light-selection", selection)],
                2,
            );
            z_ok(
                power,
                other,
                &format!("{} {integrator} {selection}", path.display()),
            );
        }
    }
    let hall =
        raylab::scene::load_scene(&crate::common::repo_file("scenes/hall_of_lamps.ron")).unwrap();
    let built = raylab::scene::RenderScene::build(&hall);
    let direct = mean_with(
        &built,
        &hall,
        "direct",
        &[("bsdf-samples", "0"), ("light-selection", "bvh")],
        3,
    );
    for neighbours in ["0", "4"] {
        let restir = mean_with(&built, &hall, "restir", &[("neighbours", neighbours)], 4);
        z_ok(direct, restir, &format!("restir, {neighbours} neighbours"));
    }
}
