//! The Mitsuba importer's tests: what each plugin becomes, and mangled files.

use super::*;
use proptest::prelude::*;

const CORNELL: &str = include_str!("../../../../scenes/mitsuba/cornell_box.xml");

proptest! {
    #![proptest_config(proptest::test_runner::Config::with_cases(300))]
    /// The shipped XML scene cut short, or with a piece cut out or replaced by a token:
    /// an error, or RON that the loader takes or refuses, never a panic.
    #[test]
    fn mangled_xml_never_panics(
        at in any::<proptest::sample::Index>(),
        len in 0usize..40,
        token in prop::sample::select(vec![
            "", "<", ">", "/>", "\"", "$", "$spp", "type=\"cube\"", "<ref id=\"white\"/>",
            "<transform name=\"to_world\">", "value=\"1e39\"", "NaN", "-1", "&amp;", "<!--",
        ]),
    ) {
        let mut start = at.index(CORNELL.len() + 1);
        while !CORNELL.is_char_boundary(start) {
            start -= 1;
        }
        let mut end = (start + len).min(CORNELL.len());
        while !CORNELL.is_char_boundary(end) {
            end -= 1;
        }
        let text = if len == 0 {
            CORNELL[..start].to_string()
        } else {
            format!("{}{token}{}", &CORNELL[..start], &CORNELL[end..])
        };
        if let Ok(imported) = to_ron(&text, &[]) {
            let _ = crate::scene::parse_scene(&imported.ron().unwrap(), std::path::Path::new("mangled.xml"));
        }
    }
}

#[test]
fn the_ron_names_what_the_xml_names() {
    let imported = to_ron(CORNELL, &[("spp".into(), "9".into())]).unwrap();
    for needle in [
        // Mitsuba's diffuse is one-sided; its cube is its own mesh of 24 vertices.
        "\"white\": OneSided(Lambert(albedo: (0.885809, 0.698859, 0.666422)))",
        "(name: \"small-box\", transform: (matrix: [",
        "shape: Mesh(positions: [(1.0, -1.0, -1.0), (1.0, -1.0, 1.0), (-1.0, -1.0, 1.0), (-1.0, -1.0, -1.0),",
        "emitter: Area(radiance: (18.387, 13.9873, 6.75357), two_sided: false)",
        "spp: 9,",
        "filter: \"gaussian\"",
        "\"max-depth\": 7.0",
    ] {
        assert!(
            imported.ron().unwrap().contains(needle),
            "no {needle} in\n{}",
            imported.ron().unwrap()
        );
    }
}

/// Mitsuba's `moment` wrapper (every scene of its render tests has one) renders with its
/// inner integrator; a second <integrator> is still refused.
#[test]
fn a_moment_wrapper_renders_with_its_inner_integrator() {
    let scene = |integrators: &str| {
        format!(
            r#"<scene version="3.0.0">{integrators}
            <sensor type="perspective"><float name="fov" value="40"/></sensor>
            <shape type="sphere"/></scene>"#
        )
    };
    let wrapped = r#"<integrator type="moment"><integrator type="path"><integer name="max_depth" value="3"/></integrator></integrator>"#;
    let render = to_ron(&scene(wrapped), &[]).unwrap().scene.render;
    assert_eq!(render.integrator, "path");
    assert_eq!(render.params.get("max-depth"), Some(&2.0));
    let twice = format!("{wrapped}<integrator type=\"path\"/>");
    let err = to_ron(&scene(&twice), &[]).unwrap_err();
    assert!(err.2.contains("a second <integrator>"), "{err:?}");
}

/// A perspective sensor without `fov` has Mitsuba 3's focal length: `focal_length` (default
/// 50 mm) of a 36 x 24 mm frame, spanning its diagonal; with `fov` too it is refused.
#[test]
fn focal_lengths_are_read_as_mitsuba_reads_them() {
    let scene = |sensor: &str| {
        format!(
            r#"<scene version="3.0.0"><sensor type="perspective">{sensor}
            <film type="hdrfilm"><integer name="width" value="400"/><integer name="height" value="300"/></film>
            </sensor><shape type="sphere"/></scene>"#
        )
    };
    // The vertical field of view of a lens of `f` mm on a 400 x 300 film.
    let vertical = |f: f64| {
        let half_diagonal = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * f);
        2.0 * (half_diagonal * 300.0 / 500.0).atan().to_degrees()
    };
    for (sensor, f) in [
        (r#"<string name="focal_length" value="35mm"/>"#, 35.0),
        ("", 50.0),
    ] {
        let camera = to_ron(&scene(sensor), &[]).unwrap().scene.camera;
        let crate::formats::schema::CameraDesc::LookAt { fov, .. } = camera else {
            panic!("{camera:?}");
        };
        assert!((fov as f64 - vertical(f)).abs() < 1e-4, "{f} mm: {fov}");
    }
    let both = r#"<float name="fov" value="40"/><string name="focal_length" value="35mm"/>"#;
    assert!(to_ron(&scene(both), &[])
        .unwrap_err()
        .2
        .contains("not both"));
    let bad = r#"<string name="focal_length" value="wide"/>"#;
    assert!(to_ron(&scene(bad), &[])
        .unwrap_err()
        .2
        .contains("positive length"));
}

/// What Mitsuba's render tests use: a `rawconstant` normal map (a constant), roughness given
/// as textures, and a bitmap's storage `format` (ignored: a precision, not a look-up).
#[test]
fn raw_constants_textured_roughness_and_bitmap_formats_import() {
    use crate::formats::schema::{ColorDesc, FloatDesc, MaterialDesc};
    let scene = |bsdf: &str| {
        format!(
            r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/></sensor>
            <shape type="sphere"><bsdf type="twosided" id="m">{bsdf}</bsdf></shape></scene>"#
        )
    };
    let material = |bsdf: &str| {
        let s = to_ron(&scene(bsdf), &[]).unwrap().scene;
        let MaterialDesc::TwoSided(inner) = s.materials.0[0].1.clone() else {
            panic!("{:?}", s.materials);
        };
        *inner
    };
    let normal = material(
        r#"<bsdf type="normalmap"><texture name="normalmap" type="rawconstant"><vector name="value" value="0.5, 0.5, 1"/></texture><bsdf type="diffuse"/></bsdf>"#,
    );
    assert!(
        matches!(normal, MaterialDesc::NormalMap { texture: ColorDesc::Constant(c), .. } if c == [0.5, 0.5, 1.0]),
        "{normal:?}"
    );
    let rough = material(
        r#"<bsdf type="roughconductor"><texture name="alpha_u" type="checkerboard"><float name="color0" value="0.05"/></texture><float name="alpha_v" value="0.3"/></bsdf>"#,
    );
    let MaterialDesc::RoughConductor {
        alpha_u, alpha_v, ..
    } = rough
    else {
        panic!("{rough:?}");
    };
    // Read as a scalar, Mitsuba's checkerboard swaps its colours (its `eval_1`).
    assert!(
        matches!(&alpha_u, Some(FloatDesc::Texture(crate::formats::texture_desc::TextureDesc::Checkerboard(c)))
            if c.color0 == [0.2; 3] && c.color1 == [0.05; 3]),
        "{alpha_u:?}"
    );
    assert_eq!(alpha_v, Some(FloatDesc::Constant(0.3)));
    let image = material(
        r#"<bsdf type="diffuse"><texture name="reflectance" type="bitmap"><string name="filename" value="a.png"/><string name="format" value="variant"/></texture></bsdf>"#,
    );
    assert!(
        matches!(
            image,
            MaterialDesc::Lambert {
                albedo: ColorDesc::Texture(_)
            }
        ),
        "{image:?}"
    );
}
