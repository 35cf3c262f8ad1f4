//! Textures, normal maps and bump maps through every light-transport integrator of the
//! registry, each against its closed form: a checkerboard under a uniform sky shows its two
//! albedos; a constant normal map and a linear bump both tilt a floor under a sun by 45
//! degrees, which dims it by cos 45.

use crate::common::render_text;
use raylab::accel::AccelKind;
use raylab_integrators::registry::REGISTRY;
use std::f32::consts::{FRAC_1_SQRT_2, PI};

/// The integrators that estimate light transport (not the debug views), and `albedo`, which
/// shows the texture itself.
fn integrators() -> Vec<&'static str> {
    REGISTRY
        .iter()
        .map(|e| e.name)
        .filter(|n| !matches!(*n, "normals" | "depth"))
        .collect()
}

/// Renders `scene` (written to a temporary folder with `files`) at 16 x 16 pixels with
/// `integrator`; returns the green channel's mean and standard error over each of `regions`
/// (x, y, width, height in pixels).
fn region_means(
    scene: &str,
    files: &[(&str, Vec<u8>)],
    integrator: &str,
    spp: u32,
    regions: &[(u32, u32, u32, u32)],
) -> Vec<(f32, f32)> {
    let film = render_text(scene, files, integrator, spp, 11, AccelKind::Raylab);
    regions
        .iter()
        .map(|&(x, y, w, h)| {
            let c = film.crop(x, y, w, h).unwrap();
            (c.mean().y, c.mean_standard_error().y)
        })
        .collect()
}

/// Photon density estimation is biased by its radius; the rest is unbiased.
fn tolerance(integrator: &str, expected: f32, se: f32) -> f32 {
    let bias = if matches!(integrator, "photon" | "sppm") {
        0.04 * expected
    } else {
        0.0
    };
    4.5 * se + bias + 1e-4 * expected
}

/// The camera straight in front of the unit rectangle (`[-1, 1]^2` of the xy plane), seeing
/// `[-0.8, 0.8]^2` of it over 16 x 16 pixels.
const CAMERA: &str = "camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 18.2, resolution: (16, 16)),";

#[test]
fn a_checkerboard_under_a_uniform_sky_shows_its_albedos() {
    // uv = ((x + 1) / 2, (y + 1) / 2), v up the rectangle's y; the quadrants where u and v are
    // both below or both above one half are color0 (0.7), the others color1 (0.2). Under a
    // uniform sky of 1 with nothing else, a Lambert surface's radiance is its albedo.
    let scene = format!(
        r#"({CAMERA}
            environment: (1, 1, 1),
            materials: {{"board": Lambert(albedo: Checkerboard(color0: 0.7, color1: 0.2))}},
            entities: [(name: "board", shape: Rectangle, material: "board")])"#
    );
    // Pixel rows run down the image (y decreasing): the top-left quadrant is u < 1/2, v > 1/2.
    // Each region is a quadrant without the two pixel lines along the centre.
    let regions = [(0, 0, 7, 7), (9, 0, 7, 7), (0, 9, 7, 7), (9, 9, 7, 7)];
    let expected = [0.2, 0.7, 0.7, 0.2];
    for name in integrators() {
        let means = region_means(&scene, &[], name, 256, &regions);
        for ((mean, se), want) in means.into_iter().zip(expected) {
            println!("checkerboard, {name}: {mean:.5} +- {se:.5} (expected {want})");
            assert!(
                (mean - want).abs() <= tolerance(name, want, se),
                "checkerboard, {name}: {mean} +- {se}, expected {want}"
            );
        }
    }
}

/// A PNG of `w x 1` grey texels of the given 8-bit values.
fn grey_png(values: &[u8]) -> Vec<u8> {
    let img = image::GrayImage::from_raw(values.len() as u32, 1, values.to_vec()).unwrap();
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .unwrap();
    bytes
}

#[test]
fn normal_and_bump_maps_tilt_the_shading_normal() {
    // A sun of irradiance 2 straight at the rectangle: flat, its radiance is 0.5 * 2 / pi.
    let scene = |material: &str| {
        format!(
            r#"({CAMERA}
                materials: {{"m": {material}, "black": Lambert(albedo: 0)}},
                entities: [
                    (name: "floor", shape: Rectangle, material: "m"),
                    (name: "sun", emitter: Directional(direction: (0, 0, -1), irradiance: (2, 2, 2))),
                ])"#
        )
    };
    let flat = 0.5 * 2.0 / PI;
    let tilted = flat * FRAC_1_SQRT_2;
    // A constant normal map of rgb (1, 0.5, 1): the tangent-space normal (1, 0, 1), 45
    // degrees towards dpdu, everywhere.
    let normal_map = scene("NormalMap(texture: (1, 0.5, 1), material: Lambert(albedo: 0.5))");
    // A bump map of two texels, 0 and 1 (raw), clamped: between the texel centres (u from
    // 1/4 to 3/4) the height rises by 1 over half a unit of u, a slope of 2 per unit u;
    // dpdu is 2 (the rectangle is 2 wide), so the normal leans by atan(2 / 2) = 45 degrees.
    // Outside, the height is flat.
    let bump = scene(
        r#"BumpMap(texture: Image(path: "ramp.png", wrap: "clamp"), scale: 1, material: Lambert(albedo: 0.5))"#,
    );
    let files = [("ramp.png", grey_png(&[0, 255]))];
    // Columns of x in (-0.4, 0.4) (u in (0.3, 0.7)) and the outer columns (u < 0.2, u > 0.8).
    let (middle, left, right) = ((4, 0, 8, 16), (0, 0, 2, 16), (14, 0, 2, 16));
    for name in integrators().into_iter().filter(|n| *n != "albedo") {
        let [(n, n_se)] = region_means(&normal_map, &[], name, 16, &[middle])[..] else {
            unreachable!()
        };
        println!("normal map, {name}: {n:.5} +- {n_se:.5} (expected {tilted:.5})");
        assert!(
            (n - tilted).abs() <= tolerance(name, tilted, n_se),
            "normal map, {name}: {n}"
        );
        let means = region_means(&bump, &files, name, 16, &[middle, left, right]);
        for ((mean, se), want) in means.into_iter().zip([tilted, flat, flat]) {
            println!("bump map, {name}: {mean:.5} +- {se:.5} (expected {want:.5})");
            assert!(
                (mean - want).abs() <= tolerance(name, want, se),
                "bump map, {name}: {mean} +- {se}, expected {want}"
            );
        }
    }
}

#[test]
fn a_tilted_normal_map_sees_the_sky_view_factor() {
    // A ball of albedo 0.5 under a uniform sky of 1, its normals tilted 30 degrees by a
    // constant normal map: a shading point sees the sky over the directions above both its
    // surface and its tilted normal, and reflects 0.5 (1 + cos 30) / 2 (the view factor of a
    // tilted plane). The camera sees the middle of the ball, where nothing else is in view.
    // That is the map without Mitsuba 3.7's corrections; with them (the default), a direction
    // must lie above the unperturbed normal too and the value carries Estevez's shadowing
    // term, and the ball gives Mitsuba 3.9.1's 0.4389 (its `normalmap` here, 256 spp).
    let scene = |options: &str| {
        format!(
            r#"(camera: LookAt(eye: (5, 0, 0), look_at: (0, 0, 0), up: (0, 0, 1), fov: 4, resolution: (16, 16)),
        environment: (1, 1, 1),
        materials: {{"m": NormalMap(texture: (0.75, 0.5, 0.9330127), material: Lambert(albedo: 0.5){options})}},
        entities: [(name: "ball", shape: Sphere(radius: 1), material: "m")])"#
        )
    };
    let plain = scene(", flip_invalid_normals: false, shadowing: false");
    let cases = [
        (
            plain.as_str(),
            0.5 * (1.0 + 30f32.to_radians().cos()) / 2.0,
            "plain",
        ),
        (&scene(""), 0.4389, "as Mitsuba 3.7"),
    ];
    for (text, expected, what) in cases {
        for name in integrators().into_iter().filter(|n| *n != "albedo") {
            let [(mean, se)] = region_means(text, &[], name, 256, &[(4, 4, 8, 8)])[..] else {
                unreachable!()
            };
            println!(
                "sky view factor {what}, {name}: {mean:.5} +- {se:.5} (expected {expected:.5})"
            );
            // Mitsuba's figure is itself an estimate (to about 0.001).
            let slack = if what == "plain" { 0.0 } else { 0.002 };
            assert!(
                (mean - expected).abs() <= tolerance(name, expected, se) + slack,
                "sky view factor {what}, {name}: {mean} +- {se}, expected {expected}"
            );
        }
    }
}

/// The unit rectangle as a shape of its own or as an instance of a mesh asset: the scene's
/// `meshes` line and the entity's shape.
fn rectangle(instanced: bool) -> (&'static str, &'static str) {
    if instanced {
        (
            r#"meshes: {"board": Rectangle},"#,
            r#"Instance(mesh: "board")"#,
        )
    } else {
        ("", "Rectangle")
    }
}

#[test]
fn both_accelerators_and_instances_give_the_same_texture_coordinates() {
    // The checkerboard's quadrants, seen through the albedo view (exact), on the rectangle as
    // a shape and as an instance of a mesh asset, through each accelerator.
    let scene = |instanced: bool| {
        let (meshes, shape) = rectangle(instanced);
        format!(
            r#"({CAMERA}
                {meshes}
                materials: {{"board": Lambert(albedo: Checkerboard(color0: 0.7, color1: 0.2))}},
                entities: [(name: "board", transform: (rotate: (0, 0, 30)), shape: {shape}, material: "board")])"#
        )
    };
    let mut images = Vec::new();
    for instanced in [false, true] {
        for kind in [AccelKind::Raylab, AccelKind::Obvhs] {
            images.push(render_text(&scene(instanced), &[], "albedo", 1, 1, kind));
        }
    }
    // The rectangle is turned 30 degrees about z: every pixel shows one of the two colours
    // (or, in the corners, the black background), both colours are seen, and every render
    // agrees with the first on every pixel.
    let pixel = |i: usize, x: u32, y: u32| images[i].crop(x, y, 1, 1).unwrap().mean().y;
    let mut seen = [false; 2];
    for y in 0..16 {
        for x in 0..16 {
            let g = pixel(0, x, y);
            assert!(
                [0.0, 0.2, 0.7].iter().any(|c| (g - c).abs() < 1e-6),
                "({x}, {y}): {g}"
            );
            seen[0] |= (g - 0.2).abs() < 1e-6;
            seen[1] |= (g - 0.7).abs() < 1e-6;
            for i in 1..images.len() {
                assert_eq!(pixel(i, x, y), g, "render {i}, pixel ({x}, {y})");
            }
        }
    }
    assert_eq!(seen, [true, true]);
}

#[test]
fn normal_maps_tilt_towards_u_on_shapes_and_instances_through_both_accelerators() {
    // A sun from +x and +z at 45 degrees (irradiance 2 facing it) over the rectangle facing
    // +z. A normal map of rgb (1, 0.5, 1) tilts the normal 45 degrees towards dpdu: +x on
    // the rectangle as it is (the normal then faces the sun: 0.5 * 2 / pi), +y once the
    // rectangle is turned 90 degrees about z (60 degrees from the sun: half that). A flat
    // normal would give cos 45, a normal tilted the wrong way nothing. The turned rectangle
    // is also stretched, placed as an instance and traced by both accelerators.
    let scene = |transform: &str, instanced: bool| {
        let (meshes, shape) = rectangle(instanced);
        format!(
            r#"({CAMERA}
                {meshes}
                materials: {{"m": NormalMap(texture: (1, 0.5, 1), material: Lambert(albedo: 0.5), flip_invalid_normals: false, shadowing: false)}},
                entities: [
                    (name: "floor", transform: {transform}, shape: {shape}, material: "m"),
                    (name: "sun", emitter: Directional(direction: (-1, 0, -1), irradiance: (2, 2, 2))),
                ])"#
        )
    };
    let facing = 0.5 * 2.0 / PI;
    let turned = "(rotate: (0, 0, 90), scale: (1.5, 3, 1))";
    let cases = [
        ("as it is", scene("()", false), facing),
        ("turned", scene(turned, false), facing * 0.5),
        ("turned instance", scene(turned, true), facing * 0.5),
    ];
    for (what, text, expected) in cases {
        for kind in [AccelKind::Raylab, AccelKind::Obvhs] {
            let film = render_text(&text, &[], "path", 4, 3, kind);
            let got = film.crop(4, 4, 8, 8).unwrap().mean().y;
            println!("{what}, {kind}: {got:.5} (expected {expected:.5})");
            assert!(
                (got - expected).abs() < 1e-3 * expected,
                "{what}, {kind}: {got}, expected {expected}"
            );
        }
    }
}

/// A textured square from a PLY file and from an OBJ file: Mitsuba 3 reads PLY's `v` as it is
/// and OBJ's `v` flipped, so the PLY's `v` must be the OBJ's `1 - v` for the two to match,
/// and then the images are the same to the bit (the same triangles in the same order).
#[test]
fn ply_texture_coordinates_are_read_unflipped_as_mitsuba_reads_them() {
    let obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0.2\nvt 0.7 0.1\nvt 1 1\nvt 0.1 0.9\nf 1/1 2/2 3/3 4/4\n";
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
               property float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
               -1 -1 0 0 0.8\n1 -1 0 0.7 0.9\n1 1 0 1 0\n-1 1 0 0.1 0.1\n4 0 1 2 3\n";
    let scene = |shape: &str| {
        format!(
            r#"(camera: LookAt(eye: (0, 0, 4), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (24, 24)),
            environment: (1, 1, 1),
            materials: {{"c": Lambert(albedo: Checkerboard(color0: (0.9, 0.5, 0.1), color1: (0.1, 0.2, 0.6), uv_scale: (5, 5)))}},
            entities: [(name: "square", shape: {shape}, material: "c")])"#
        )
    };
    let files = [
        ("sq.obj", obj.as_bytes().to_vec()),
        ("sq.ply", ply.as_bytes().to_vec()),
    ];
    let render =
        |shape: &str| render_text(&scene(shape), &files, "albedo", 4, 1, AccelKind::Raylab);
    let (a, b) = (
        render(r#"Obj(path: "sq.obj")"#),
        render(r#"Ply(path: "sq.ply")"#),
    );
    assert_eq!(
        a.mean().to_array().map(f32::to_bits),
        b.mean().to_array().map(f32::to_bits)
    );
    // With the PLY's v flipped like the OBJ's, the image changes.
    let flipped = ply
        .replace("0 0.8\n", "0 0.2\n")
        .replace("0.7 0.9\n", "0.7 0.1\n");
    let files = [("sq.ply", flipped.into_bytes())];
    let c = render_text(
        &scene(r#"Ply(path: "sq.ply")"#),
        &files,
        "albedo",
        4,
        1,
        AccelKind::Raylab,
    );
    assert_ne!(a.mean(), c.mean());
}

/// Mitsuba 3's mesh attributes from a PLY: a face's value over its triangle, a vertex colour
/// interpolated, and a blend of two colours by a face value, the same through both
/// accelerators. The square's lower-right triangle has `weight_0` 0, the upper-left 1; the
/// vertices' `r g b` run from red 0 on the left to 1 on the right.
#[test]
fn mesh_attributes_from_a_ply_reach_the_material() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
               property float r\nproperty float g\nproperty float b\nelement face 2\nproperty list uchar int vertex_indices\n\
               property float weight_0\nend_header\n\
               -1 -1 0 0 0.5 0.25\n1 -1 0 1 0.5 0.25\n1 1 0 1 0.5 0.25\n-1 1 0 0 0.5 0.25\n3 0 1 2 0\n3 0 2 3 1\n";
    let files = [("sq.ply", ply.as_bytes().to_vec())];
    let scene = |attribute: &str, albedo: &str| {
        format!(
            r#"({CAMERA}
            environment: (1, 1, 1),
            materials: {{"m": Lambert(albedo: {albedo})}},
            entities: [(name: "square", shape: Ply(path: "sq.ply", attribute: "{attribute}"), material: "m")])"#
        )
    };
    let cases = [
        (
            scene("face_weight", r#"Attribute(name: "face_weight")"#),
            [[0.0; 3], [1.0; 3]],
        ),
        (
            scene(
                "face_weight",
                r#"Mix(tex0: (0, 0.5, 0.5), tex1: (1, 1, 0), amount: Attribute(name: "face_weight"))"#,
            ),
            [[0.0, 0.5, 0.5], [1.0, 1.0, 0.0]],
        ),
    ];
    for accel in [AccelKind::Raylab, AccelKind::Obvhs] {
        for (text, [lower_right, upper_left]) in &cases {
            let film = render_text(text, &files, "albedo", 4, 1, accel);
            // Corners well inside each triangle.
            for ((x, y), want) in [((12, 12), lower_right), ((1, 1), upper_left)] {
                let got = film.crop(x, y, 3, 3).unwrap().mean();
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() < 1e-4,
                        "{accel:?}: at ({x}, {y}) {got} vs {want:?}\n{text}"
                    );
                }
            }
        }
        // The vertex colour, interpolated: red is (x + 1) / 2, so the columns over x in
        // [-0.8, -0.4] and [0.4, 0.8] average 0.2 and 0.8.
        let film = render_text(
            &scene("vertex_color", r#"Attribute(name: "vertex_color")"#),
            &files,
            "albedo",
            16,
            1,
            accel,
        );
        for (x, want) in [(0, 0.2), (12, 0.8)] {
            let got = film.crop(x, 0, 4, 16).unwrap().mean();
            assert!((got.x - want).abs() < 0.01, "{accel:?}: column {x}: {got}");
            assert!((got.y - 0.5).abs() < 1e-4 && (got.z - 0.25).abs() < 1e-4);
        }
    }
    // A material reading an attribute on a shape that carries none is refused.
    let bare = format!(
        r#"({CAMERA}
        materials: {{"m": Lambert(albedo: Attribute(name: "face_weight"))}},
        entities: [(name: "square", shape: Ply(path: "sq.ply"), material: "m")])"#
    );
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("sq.ply"), ply).unwrap();
    std::fs::write(dir.path().join("s.ron"), bare).unwrap();
    let Err(err) = raylab::scene::load_scene(&dir.path().join("s.ron")) else {
        panic!("a material reading an attribute of a shape without one loaded");
    };
    assert!(
        format!("{err:#}").contains("reads a mesh attribute, but the shape carries none"),
        "{err:#}"
    );
}
