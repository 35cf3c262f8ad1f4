//! The unbiased integrators agree on real scenes: `path`, `russian-roulette` and
//! `fixed-depth` estimate the same truncated rendering equation at the same depth, so their
//! image means must agree within statistical error (a z-test on each channel, standard errors
//! from the film's per-pixel variances). The light-path family is checked the same way with
//! standard errors from the passes' image means, since merges correlate a pass's pixels.

use crate::common::pass_means::{assert_means_agree, assert_power, load, run};
use raylab::render::{render, Film, RenderSettings};
use raylab::scene::load_scene;
use raylab::scene::RenderScene;
use raylab_integrators::registry;
use std::path::Path;

fn render_mean(
    scene: &str,
    integrator: &str,
    params: &[(&str, &str)],
    spp: u32,
    seed: u64,
) -> Film {
    let loaded = load_scene(Path::new(scene)).unwrap();
    let built = RenderScene::build(&loaded);
    let camera = loaded.camera.with_resolution(24, 24);
    let given: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let mut integrator = registry::find(integrator)
        .unwrap()
        .instantiate(&given)
        .unwrap();
    let settings = RenderSettings::fixed(spp, seed, None);
    render(&built, &camera, integrator.as_mut(), &settings)
        .unwrap()
        .0
}

fn assert_agree(scene: &str, a: (&str, &Film), b: (&str, &Film)) {
    assert_agree_to(scene, a, b, 0.01);
}

/// [`assert_agree`] where the brightest channel's standard error may reach `power` of its
/// mean (the test then sees a difference of 4 `power`).
fn assert_agree_to(scene: &str, a: (&str, &Film), b: (&str, &Film), power: f32) {
    let (ma, sa) = (a.1.mean(), a.1.mean_standard_error());
    let (mb, sb) = (b.1.mean(), b.1.mean_standard_error());
    let brightest = if ma.x >= ma.y && ma.x >= ma.z {
        0
    } else if ma.y >= ma.z {
        1
    } else {
        2
    };
    for c in 0..3 {
        let se = (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
        let z = (ma[c] - mb[c]) / se;
        assert!(
            z.abs() < 4.0,
            "{scene}: {} {:.5} +- {:.5} vs {} {:.5} +- {:.5} in channel {c} (z = {z:.2})",
            a.0,
            ma[c],
            sa[c],
            b.0,
            mb[c],
            sb[c]
        );
        // Power: in the brightest channel, the comparison could see a 4% difference.
        if c == brightest {
            assert!(
                se < power * ma[c],
                "{scene}: standard error {se} ({} against {}) too large for the test to mean anything",
                a.0,
                b.0
            );
        }
    }
}

fn agreement(scene: &str, depth: &str) {
    let path = render_mean(scene, "path", &[("max-depth", depth)], 1024, 1);
    let rr = render_mean(scene, "russian-roulette", &[("max-depth", depth)], 1024, 2);
    let fixed = render_mean(
        scene,
        "fixed-depth",
        &[("depth", depth), ("branching", "2"), ("shadow-grid", "1")],
        1024,
        3,
    );
    assert_agree(scene, ("path", &path), ("russian-roulette", &rr));
    assert_agree(scene, ("path", &path), ("fixed-depth", &fixed));
}

#[test]
fn cornell_box_path_russian_roulette_and_fixed_depth_agree() {
    agreement("scenes/cornell_box.ron", "4");
}

#[test]
fn report_room_path_russian_roulette_and_fixed_depth_agree() {
    agreement("scenes/report_room.ron", "4");
}

/// Every material of the field (rough metals, rough glass, plastics, a thin pane): MIS
/// with the glossy lobes' densities (`path`), plain BSDF sampling (`russian-roulette`) and
/// direct light plus branching (`fixed-depth`) agree.
#[test]
fn every_material_path_russian_roulette_and_fixed_depth_agree() {
    agreement("scenes/materials.ron", "4");
}

/// Mitsuba's analytic shapes with textures, lit by a disk and a tube (an emitting cylinder):
/// their intersections, parametrisations and light sampling.
#[test]
fn analytic_shapes_path_russian_roulette_and_fixed_depth_agree() {
    agreement("scenes/shapes.ron", "4");
}

#[test]
fn unlimited_depth_path_and_russian_roulette_agree() {
    let path = render_mean(
        "scenes/cornell_box.ron",
        "path",
        &[("max-depth", "unlimited")],
        512,
        4,
    );
    let rr = render_mean(
        "scenes/cornell_box.ron",
        "russian-roulette",
        &[("max-depth", "unlimited")],
        512,
        5,
    );
    assert_agree(
        "scenes/cornell_box.ron",
        ("path", &path),
        ("russian-roulette", &rr),
    );
}

#[test]
fn the_comparison_detects_a_missing_bounce() {
    // Negative control: depth 3 against depth 4 differs by the fourth bounce (~5% here), which
    // the same z-test must see.
    let a = render_mean(
        "scenes/cornell_box.ron",
        "path",
        &[("max-depth", "3")],
        1024,
        6,
    );
    let b = render_mean(
        "scenes/cornell_box.ron",
        "path",
        &[("max-depth", "4")],
        1024,
        7,
    );
    let (ma, mb) = (a.mean(), b.mean());
    let (sa, sb) = (a.mean_standard_error(), b.mean_standard_error());
    let z = (mb.x - ma.x) / (sa.x * sa.x + sb.x * sb.x).sqrt();
    assert!(z > 4.0, "depth 3 {ma} vs depth 4 {mb}: z = {z}");
}

#[test]
fn cornell_box_matches_mitsuba_3() {
    // Mitsuba 3.9.1's converged mean of its own Cornell box (box filter, max_depth 8 = raylab
    // max-depth 7), given to 4 digits (shared/ANCHORS.md): (0.2401, 0.1411, 0.0600). The image
    // mean does not depend on the resolution, so a small render will do.
    let film = render_mean(
        "scenes/cornell_box.ron",
        "path",
        &[("max-depth", "7")],
        4096,
        11,
    );
    let (m, se) = (film.mean(), film.mean_standard_error());
    let mitsuba = [0.2401f32, 0.1411, 0.0600];
    for c in 0..3 {
        let rounding = 0.00005f32;
        let z = (m[c] - mitsuba[c]) / (se[c] * se[c] + rounding * rounding).sqrt();
        assert!(
            z.abs() < 4.0,
            "channel {c}: raylab {:.5} +- {:.5}, Mitsuba {:.4} (z = {z:.2})",
            m[c],
            se[c],
            mitsuba[c]
        );
    }
    assert!(
        se.x < 0.0025 * m.x,
        "standard error {} too large to see a 1% difference at 4 sigma",
        se.x
    );
}

#[test]
fn no_light_leaks_through_smooth_shaded_surfaces() {
    // A large plane with per-vertex normals tilted 60 degrees, seen from above, lit only by a
    // lamp underneath facing up. Shading normals put the lamp "in front" of the shading frame,
    // but no light may cross the opaque plane: every integrator must see black.
    let text = r#"(
        camera: LookAt(eye: (0, 0, 3), look_at: (0, 0, 0), up: (0, 1, 0), fov: 30, resolution: (8, 8)),
        materials: {"white": Lambert(albedo: (0.8, 0.8, 0.8))},
        entities: [
            (name: "plane", shape: Mesh(
                positions: [(-50, -50, 0), (50, -50, 0), (50, 50, 0), (-50, 50, 0)],
                indices: [(0, 1, 2), (0, 2, 3)],
                normals: [(0.866, 0, 0.5), (0.866, 0, 0.5), (0.866, 0, 0.5), (0.866, 0, 0.5)],
            ), material: "white"),
            (name: "lamp below", shape: Quad(vertices: [(-1, -1, -0.5), (1, -1, -0.5), (1, 1, -0.5), (-1, 1, -0.5)]),
             emitter: Area(radiance: (10, 10, 10))),
        ],
    )"#;
    let loaded = raylab::scene::parse_scene(text, Path::new("leak.ron")).unwrap();
    let built = RenderScene::build(&loaded);
    for name in ["path", "russian-roulette", "whitted", "fixed-depth"] {
        let mut integrator = registry::find(name).unwrap().instantiate(&[]).unwrap();
        let (film, _) = render(
            &built,
            &loaded.camera,
            integrator.as_mut(),
            &RenderSettings::fixed(16, 1, None),
        )
        .unwrap();
        assert_eq!(
            film.mean(),
            glam::Vec3::ZERO,
            "{name}: light leaked through the plane"
        );
    }
}

/// Light tracing and bidirectional path tracing estimate the same image as path tracing from
/// the other end: on the Cornell box (all diffuse, so the light tracer misses no `L S* E`
/// path) through the LookAt camera and through a skewed, tilted image-plane camera, where a
/// wrong importance `We` or lens density would show first.
#[test]
fn light_path_integrators_agree_with_path_through_both_cameras() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string("scenes/cornell_box.ron").unwrap();
    let (start, end) = (
        text.find("camera: LookAt(").unwrap(),
        text.find("    ),\n").unwrap(),
    );
    let skewed = format!(
        "{}camera: ImagePlane(eye: (0.1, -0.05, 3.9), top_left: (-0.35, 0.38, 2.9), \
         top_right: (0.35, 0.33, 3.0), bottom_left: (-0.3, -0.35, 2.95), \
         bottom_right: (0.4, -0.4, 3.05)),\n{}",
        &text[..start],
        &text[end + "    ),\n".len()..]
    );
    let plane = dir.path().join("cornell_image_plane.ron");
    std::fs::write(&plane, skewed).unwrap();
    for scene in ["scenes/cornell_box.ron", plane.to_str().unwrap()] {
        let data = load(scene, 24, 24);
        let path = run(&data, "path", &[("max-depth", "4")], 1024, &[]);
        for (name, params) in [
            ("lighttracer", &[("max-depth", "4")][..]),
            ("bdpt", &[("max-depth", "4")]),
            ("vcm", &[("max-depth", "4"), ("radius", "0.05")]),
            ("bpm", &[("max-depth", "4"), ("radius", "0.05")]),
        ] {
            let light = run(&data, name, params, 1024, &[]);
            let what = format!("{scene}: {name} vs path");
            assert_power(&what, &light, 0.01);
            assert_means_agree(&what, &light, &path, 4.0, 0.0);
        }
    }
}

/// Standard errors here come from the passes' image means (`common::pass_means`): the merging
/// integrators' pixels share a pass's light subpaths.
///
/// Bidirectional path tracing joins subpaths at every non-specular vertex and weights the
/// strategies by MIS; mirrors, glass and smooth coatings are followed, never joined. On
/// every material of the field and on the caustics scene (a glass ball and a mirror under a
/// small light and a sky), `bdpt` agrees with `path`, and so does `vcm`, which adds merges
/// (biased by their radius, 5 cm here, which the image mean hardly sees). `bpm`, which only
/// merges, is too noisy at this size on the materials, and is checked on the caustics, where
/// merging is at home (with a 15 cm radius: 576 light subpaths a pass).
#[test]
fn bidirectional_integrators_agree_with_path_on_every_material_and_on_caustics() {
    // The caustics scene is hard for all (the small light through the glass ball): more
    // samples, and a 2% standard error (a difference of 8% shows).
    let bdpt = ("bdpt", &[("max-depth", "4")][..]);
    let vcm = ("vcm", &[("max-depth", "4"), ("radius", "0.05")][..]);
    let bpm = ("bpm", &[("max-depth", "4"), ("radius", "0.15")][..]);
    for (scene, spp, power, integrators) in [
        ("scenes/materials.ron", 1024, 0.01, &[bdpt, vcm][..]),
        ("scenes/caustics.ron", 3072, 0.02, &[bdpt, vcm, bpm]),
    ] {
        let data = load(scene, 24, 24);
        let path = run(&data, "path", &[("max-depth", "4")], spp, &[]);
        for &(name, params) in integrators {
            let other = run(&data, name, params, spp, &[]);
            let what = format!("{scene}: {name} vs path");
            assert_power(&what, &other, power);
            assert_power(&what, &path, power);
            assert_means_agree(&what, &other, &path, 4.0, 0.0);
        }
    }
}

/// `bdpt`'s strategies, one at a time (`strategy-s`, `strategy-t`): MIS-weighted, their
/// images add up to the full image (the same random numbers, so up to rounding); unweighted,
/// each is an estimator of its own: every strategy of `d` scattering events estimates the
/// light of exactly `d` bounces, `path` at depth `d` less `path` at depth `d - 1`.
#[test]
fn bdpt_strategies_add_up_and_each_alone_estimates_its_path_length() {
    let scene = "scenes/cornell_box.ron";
    let depth2 = [("max-depth", "2")];
    let full = render_mean(scene, "bdpt", &depth2, 64, 3).mean();
    let mut sum = glam::Vec3::ZERO;
    for t in 1..=4usize {
        for s in 0..=3usize {
            let d = s as i64 + t as i64 - 2;
            if (s, t) == (1, 1) || !(0..=2).contains(&d) {
                continue;
            }
            let (s, t) = (s.to_string(), t.to_string());
            let params = [("max-depth", "2"), ("strategy-s", &s), ("strategy-t", &t)];
            sum += render_mean(scene, "bdpt", &params, 64, 3).mean();
        }
    }
    for c in 0..3 {
        assert!(
            (sum[c] - full[c]).abs() <= 1e-4 * full[c],
            "the strategies add up to {sum}, the image is {full}"
        );
    }

    // Depth 2 alone, from path tracing at depths 2 and 1 (the same paths: the same seed).
    let (p2, p1) = (
        render_mean(scene, "path", &depth2, 512, 4),
        render_mean(scene, "path", &[("max-depth", "1")], 512, 4),
    );
    let expected = p2.mean() - p1.mean();
    let se_expected = p2.mean_standard_error() + p1.mean_standard_error();
    for (s, t) in [("0", "4"), ("1", "3"), ("2", "2"), ("3", "1")] {
        let params = [
            ("max-depth", "2"),
            ("strategy-s", s),
            ("strategy-t", t),
            ("mis", "0"),
        ];
        let alone = render_mean(scene, "bdpt", &params, 512, 5);
        let (m, se) = (alone.mean(), alone.mean_standard_error());
        let c = 0; // red: the brightest channel of the box
        let z = (m[c] - expected[c]) / (se[c] * se[c] + se_expected[c] * se_expected[c]).sqrt();
        println!("({s}, {t}) alone: {m} +- {se}, depth 2 of path: {expected}");
        assert!(
            z.abs() < 4.5,
            "strategy ({s}, {t}) alone: {m} +- {se}, expected {expected} (z = {z:.2})"
        );
        assert!(
            se[c] < 0.05 * expected[c],
            "({s}, {t}): too noisy to mean anything"
        );
    }
}

/// The Markov-chain, many-light and guided integrators agree with `path` (standard errors
/// from pass means: a Metropolis pass's chains splat clusters of correlated pixels). On the
/// Cornell box (an area light) and on the sky scene (an environment map, a spot light and a
/// directional light, which `mmlt` joins through all of bdpt's strategies). `vpl` is biased
/// by its clamp: here 0.1% of the scene's radius (the sky scene's floor is wide: 1% of its
/// radius is half a metre, and its image mean is 3% darker).
#[test]
fn markov_chain_many_light_and_guided_integrators_agree_with_path() {
    let depth = ("max-depth", "4");
    for (scene, passes, power) in [
        ("scenes/cornell_box.ron", 1024, 0.01),
        ("scenes/sky.ron", 1024, 0.015),
    ] {
        let data = load(scene, 24, 24);
        let path = run(&data, "path", &[depth], passes, &[]);
        assert_power(scene, &path, power);
        for (name, params) in [
            // A Metropolis pass's image mean is exactly its bootstrap's estimate b: four
            // bootstrap samples per pixel give the test its power.
            ("pssmlt", &[depth, ("bootstrap", "2304")][..]),
            ("mmlt", &[depth, ("bootstrap", "500")]),
            ("vpl", &[depth, ("vpl-paths", "8"), ("clamp", "0.001")]),
            ("guided", &[depth, ("spatial-threshold", "500")]),
        ] {
            let other = run(&data, name, params, passes, &[]);
            let what = format!("{scene}: {name} vs path");
            assert_power(&what, &other, power);
            assert_means_agree(&what, &other, &path, 4.0, 0.0);
        }
    }
}

/// At their default parameters the Metropolis integrators agree with `path` at its defaults
/// (unlimited depth), channel by channel, over several seeds, in a closed Cornell box with a
/// mirror ball and a glass ball: light keeps bouncing, and what arrives after 10 bounces is
/// mostly red (the white walls keep 89% of red, 70% of green, 67% of blue), so `path` at
/// max-depth 10 is 4% short in red and 0.8% in green. Each seed's first statistic is a
/// channel over the image's luminance: a Metropolis pass's image luminance is exactly its
/// bootstrap's `b`, so the ratio is free of `b`'s noise and sees how the chains' splats share
/// out between the channels. With `mmlt`'s former default (max-depth 10), red over luminance
/// was 3.0% low (z = -6.9) and green 1.7% high (z = 7.0).
#[test]
fn metropolis_integrators_at_their_defaults_agree_with_path_in_every_channel() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string("scenes/cornell_box.ron").unwrap();
    let (start, end) = (
        text.find("        // Mitsuba's unit cubes").unwrap(),
        text.find("        // The light:").unwrap(),
    );
    let balls = [
        r#"        (name: "front", shape: Quad(vertices: [(-1, -1, 1), (-1, 1, 1), (1, 1, 1), (1, -1, 1)]), material: "white"),"#,
        r#"        (name: "mirror ball", shape: Sphere(center: (-0.45, -0.6, -0.3), radius: 0.4), material: "mirror"),"#,
        r#"        (name: "glass ball", shape: Sphere(center: (0.45, -0.6, 0.3), radius: 0.4), material: "glass"),"#,
    ]
    .join("\n");
    let closed = format!("{}{balls}\n{}", &text[..start], &text[end..])
        // The camera inside the box, just behind its new front wall.
        .replace("eye: (0, 0, 3.9)", "eye: (0, 0, 0.98)")
        .replace(
            "materials: {",
            "materials: {\n        \"mirror\": Mirror(),\n        \"glass\": Glass(ior: 1.5),",
        );
    let file = dir.path().join("closed_box_with_balls.ron");
    std::fs::write(&file, closed).unwrap();
    let scene = file.to_str().unwrap();

    // Each seed's image mean; no parameters: every integrator at its defaults.
    let means = |name: &str, spp: u32| -> Vec<[f64; 3]> {
        (1..=16u64)
            .map(|seed| {
                let m = render_mean(scene, name, &[], spp, seed).mean();
                [m.x as f64, m.y as f64, m.z as f64]
            })
            .collect()
    };
    let mean_se = |v: Vec<f64>| {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, (var / n).sqrt())
    };
    let luminance = |m: &[f64; 3]| 0.2126 * m[0] + 0.7152 * m[1] + 0.0722 * m[2];
    let path = means("path", 1024);
    for (name, spp) in [("mmlt", 512), ("pssmlt", 256)] {
        let other = means(name, spp);
        for c in 0..3 {
            let ratio =
                |runs: &[[f64; 3]]| mean_se(runs.iter().map(|m| m[c] / luminance(m)).collect());
            let plain = |runs: &[[f64; 3]]| mean_se(runs.iter().map(|m| m[c]).collect());
            for (what, (a, sa), (b, sb)) in [
                ("over luminance", ratio(&other), ratio(&path)),
                ("mean", plain(&other), plain(&path)),
            ] {
                let z = (a - b) / (sa * sa + sb * sb).sqrt();
                assert!(
                    z.abs() < 4.0,
                    "{name} vs path, channel {c} {what}: {a:.5} +- {sa:.5} vs {b:.5} +- {sb:.5} (z = {z:.2})"
                );
            }
            let (a, sa) = ratio(&other);
            assert!(
                sa < 0.006 * a,
                "{name}: channel {c} over luminance {a:.5} +- {sa:.5}, too noisy to see a 2.5% shift"
            );
        }
    }
}
