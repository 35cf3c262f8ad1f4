//! The pbrt-v4 importer's tests: what each directive becomes, and mangled files.

use super::*;
use crate::formats::schema::{
    CurveType, GridEdgeDesc, MediumDesc, MediumInterfaceDesc, PhaseDesc, VolumeDesc,
};
use proptest::prelude::*;

const CORNELL: &str = include_str!("../../../../scenes/pbrt/cornell_box.pbrt");

fn convert(text: &str, approximate: bool) -> Result<Imported, PbrtError> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/pbrt/mangled.pbrt");
    let files = SceneFiles::new(&path, &[]);
    let options = ImportOptions {
        approximate,
        ..ImportOptions::default()
    };
    to_ron(&path, text, &files, &options)
}

proptest! {
    #![proptest_config(proptest::test_runner::Config::with_cases(300))]
    /// The shipped pbrt scene cut short, or with a piece cut out or replaced by a token:
    /// an error, or RON that the loader takes or refuses, never a panic.
    #[test]
    fn mangled_pbrt_never_panics(
        at in any::<proptest::sample::Index>(),
        len in 0usize..40,
        approximate in any::<bool>(),
        token in prop::sample::select(vec![
            "", "[", "]", "\"", "#", "1e39", "-1", "nan", "AttributeEnd", "ObjectEnd",
            "\"float radius\"", "Scale 0 0 0", "ReverseOrientation", "Include \"cornell_box.pbrt\"",
            "Shape \"sphere\"", "Camera \"perspective\"", "WorldBegin", "\"integer indices\" [9]",
            "Shape \"curve\" \"point3 P\" [0 0 0 1 0 0 2 1 0 3 1 0] \"float width\" 0.1",
            "Material \"hair\" \"float eumelanin\" 2",
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
        if let Ok(imported) = convert(&text, approximate) {
            let _ = crate::scene::parse_scene(&imported.ron().unwrap(), Path::new("mangled.pbrt"));
        }
    }
}

#[test]
fn the_ron_names_what_the_pbrt_file_names() {
    let imported = convert(CORNELL, false).unwrap();
    for needle in [
        "\"white\": Lambert(albedo: (0.885809, 0.698859, 0.666422))",
        "\"cube/0\": Mesh(positions: [",
        "transform: (matrix: [",
        "shape: Instance(mesh: \"cube/0\"), material: \"white\"",
        "emitter: Area(radiance: (18.387, 13.9873, 6.75357), two_sided: false)",
        "spp: 64,",
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

#[test]
fn textures_follow_pbrts_coordinates() {
    let scene = |texture: &str| {
        format!("WorldBegin\n{texture}\nMaterial \"diffuse\" \"texture reflectance\" \"t\"\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n")
    };
    // pbrt-v4 looks an image up at (s, 1 - t); raylab from the top row at (u, v).
    let image = convert(&scene(r#"Texture "t" "spectrum" "imagemap" "string filename" "a.png" "float uscale" 2 "float vdelta" 0.25"#), false).unwrap();
    assert!(image.ron().unwrap().contains(r#"Image(path: "a.png", filter: "bilinear", wrap: "repeat", raw: false, uv_scale: (2.0, -1.0), uv_offset: (0.0, 0.75))"#), "{}", image.ron().unwrap());
    // pbrt-v4's squares are a unit wide, Mitsuba's half a unit.
    let checks = convert(&scene(r#"Texture "t" "spectrum" "checkerboard" "rgb tex1" [1 0 0] "float uscale" 8 "float vscale" 4"#), false).unwrap();
    assert!(checks.ron().unwrap().contains("Checkerboard(color0: (1.0, 0.0, 0.0), color1: (0.0, 0.0, 0.0), uv_scale: (4.0, 2.0), uv_offset: (0.0, 0.0))"), "{}", checks.ron().unwrap());
}

/// Bitterli's scenes: diffuse transmission (its `scale` over a texture too), a scale
/// texture of a texture, a named `interface`, bdpt deeper than 30 and sppm's settings.
#[test]
fn diffuse_transmission_interfaces_and_integrator_settings_map() {
    let ron = |text: &str| convert(text, false).unwrap().ron().unwrap();
    let shape = "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]";
    let leaf = ron(&format!(
        r#"WorldBegin
Texture "t" "spectrum" "imagemap" "string filename" "leaf.png"
Texture "s" "spectrum" "scale" "texture tex" "t" "float scale" 0.8
Material "diffusetransmission" "texture reflectance" "t" "texture transmittance" "s" "float scale" 0.5
{shape}
"#
    ));
    assert!(
        leaf.contains("DiffuseTransmission(reflectance: Image(path: \"leaf.png\""),
        "{leaf}"
    );
    assert!(leaf.contains("scale: 0.5)"), "{leaf}");
    assert!(leaf.contains("scale: 0.4)"), "{leaf}");
    let plain = ron(&format!("WorldBegin\nMaterial \"diffusetransmission\" \"rgb reflectance\" [0.3 0.25 0.2]\n{shape}\n"));
    assert!(
        plain.contains(
            "DiffuseTransmission(reflectance: (0.3, 0.25, 0.2), transmittance: (0.25, 0.25, 0.25))"
        ),
        "{plain}"
    );
    // A named interface leaves its shapes out, as an anonymous one does (with --approximate).
    let text = format!("WorldBegin\nMakeNamedMaterial \"i\" \"string type\" \"interface\"\nNamedMaterial \"i\"\n{shape}\n");
    assert!(convert(&text, false).unwrap_err().3.contains("interface"));
    let with_sphere = format!("{text}Material \"diffuse\"\nShape \"sphere\"\n");
    let kept = convert(&with_sphere, true).unwrap().ron().unwrap();
    assert!(
        !kept.contains("trianglemesh") && kept.contains("Sphere"),
        "{kept}"
    );
    // A normal map, as pbrt-v4 reads it: a PNG as linear, at (u, 1 - v), no Mitsuba terms.
    let mapped = ron(&format!(
        "WorldBegin\nMaterial \"diffuse\" \"string normalmap\" \"nm.png\"\n{shape}\n"
    ));
    assert!(mapped.contains(r#"NormalMap(texture: Image(path: "nm.png", filter: "bilinear", wrap: "repeat", raw: true, uv_scale: (1.0, -1.0), uv_offset: (0.0, 1.0)), material: Lambert(albedo: (0.5, 0.5, 0.5)), flip_invalid_normals: false, shadowing: false)"#), "{mapped}");
    let bdpt = ron(&format!(
        "Integrator \"bdpt\" \"integer maxdepth\" 33\nWorldBegin\n{shape}\n"
    ));
    assert!(bdpt.contains("\"max-depth\": 33.0"), "{bdpt}");
    let sppm = ron(&format!("Integrator \"sppm\" \"integer maxdepth\" 6 \"float radius\" 0.05\nFilm \"rgb\" \"integer xresolution\" 40 \"integer yresolution\" 30\nWorldBegin\n{shape}\n"));
    for needle in [
        "\"max-depth\": 6.0",
        "\"photon-depth\": 5.0",
        "\"radius\": 0.05",
        "\"photons\": 1200.0",
    ] {
        assert!(sppm.contains(needle), "no {needle} in {sppm}");
    }
}

#[test]
fn materials_map_with_pbrts_defaults() {
    for (material, expected) in [
        ("\"conductor\"", "Conductor(metal: \"Cu\", specular_reflectance: (1.0, 1.0, 1.0))"),
        ("\"conductor\" \"float roughness\" 0.04", "RoughConductor(metal: \"Cu\", specular_reflectance: (1.0, 1.0, 1.0), distribution: \"ggx\", alpha: 0.2)"),
        ("\"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\" \"bool remaproughness\" false \"float uroughness\" 0.1 \"float vroughness\" 0.3", "RoughConductor(metal: \"Au\", specular_reflectance: (1.0, 1.0, 1.0), distribution: \"ggx\", alpha_u: 0.1, alpha_v: 0.3)"),
        ("\"conductor\" \"rgb reflectance\" [0.5 0.5 0.5]", "Conductor(eta: (1.0, 1.0, 1.0), k: (2.0, 2.0, 2.0), specular_reflectance: (1.0, 1.0, 1.0))"),
        ("\"dielectric\"", "Dielectric(int_ior: 1.5, ext_ior: 1.0, specular_reflectance: (1.0, 1.0, 1.0), specular_transmittance: (1.0, 1.0, 1.0))"),
        ("\"thindielectric\" \"float eta\" 1.33", "ThinDielectric(int_ior: 1.33, ext_ior: 1.0, specular_reflectance: (1.0, 1.0, 1.0), specular_transmittance: (1.0, 1.0, 1.0))"),
        ("\"coateddiffuse\" \"float roughness\" 0", "Plastic(diffuse_reflectance: (0.5, 0.5, 0.5), specular_reflectance: (1.0, 1.0, 1.0), int_ior: 1.5, ext_ior: 1.0, nonlinear: true)"),
    ] {
        let text = format!("WorldBegin\nMaterial {material}\nShape \"sphere\"\n");
        let imported = convert(&text, false).unwrap();
        assert!(imported.ron().unwrap().contains(expected), "{material}: no {expected} in\n{}", imported.ron().unwrap());
    }
}

#[test]
fn states_lights_samplers_and_uvs_follow_pbrt_v4() {
    let quad = r#"Shape "bilinearmesh" "point3 P" [0 0 0  2 0 0  0 1 0  2 1 0]"#;
    // TransformBegin/End restore everything, as AttributeBegin/End.
    let text = format!("WorldBegin\nTransformBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\nTransformEnd\n{quad}\n");
    assert!(!convert(&text, false)
        .unwrap()
        .ron()
        .unwrap()
        .contains("emitter"));
    // `power` over each primitive's own area: a 2 x 1 patch, 2 pi W -> 1.
    let text =
        format!("WorldBegin\nAreaLightSource \"diffuse\" \"float power\" 6.2831853\n{quad}\n");
    let ron = convert(&text, false).unwrap().ron().unwrap();
    assert!(ron.contains("Area(radiance: (1.0, 1.0, 1.0)"), "{ron}");
    // The shutter's open time scales the image.
    let text = format!("Camera \"perspective\" \"float shutterclose\" 0.5\nWorldBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\n{quad}\n");
    assert!(convert(&text, false)
        .unwrap()
        .ron()
        .unwrap()
        .contains("Area(radiance: (2.0, 2.0, 2.0)"));
    // A spectrum on a light is normalised to luminance 1 by pbrt-v4, and kept as one: a
    // flat spectrum's values become about 1 (its luminance was 8), the radiance its scale.
    let text =
        format!("WorldBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [300 8 800 8]\n{quad}\n");
    let ron = convert(&text, false).unwrap().ron().unwrap();
    assert!(ron.contains("Area(radiance: (1.0, 1.0, 1.0)"), "{ron}");
    let at_300 = ron
        .split("spectrum: [(300.0, ")
        .nth(1)
        .unwrap()
        .split(')')
        .next()
        .unwrap();
    assert!((at_300.parse::<f64>().unwrap() - 1.0).abs() < 0.01, "{ron}");
    // A blackbody is kept as a spectrum of luminance 1 (the intensity its scale), whose
    // colour at 2700 K is warm (red over green over blue); named illuminants come from
    // pbrt-v4's tables, unknown names are refused.
    let point = |l: &str| convert(&format!("WorldBegin\nLightSource \"point\" {l}\n"), false);
    let imported = point("\"blackbody I\" 2700").unwrap();
    let emitter = imported
        .scene
        .entities
        .iter()
        .find_map(|e| e.emitter.clone());
    let Some(EmitterDesc::Point {
        intensity,
        spectrum: Some(pairs),
    }) = emitter
    else {
        panic!("a point light with a spectrum: {emitter:?}")
    };
    assert_eq!(intensity, [1.0; 3]);
    let rgb =
        crate::formats::spectra::to_srgb(&pairs, crate::formats::spectra::Use::Emission).unwrap();
    assert!(
        rgb[0] > rgb[1] && rgb[1] > rgb[2] && rgb[2] > 0.0,
        "{rgb:?}"
    );
    let y = 0.212_671 * rgb[0] + 0.715_160 * rgb[1] + 0.072_169 * rgb[2];
    assert!((y - 1.0).abs() < 0.01, "{rgb:?}");
    assert!(point("\"spectrum I\" \"stdillum-F4\"").is_ok());
    assert!(point("\"spectrum I\" \"stdillum-X\"")
        .unwrap_err()
        .3
        .contains("stdillum-X"));
    // A spot light falls off as pbrt-v4's: a smoothstep in the cosine.
    let text = "WorldBegin\nLightSource \"spot\" \"float coneangle\" 40 \"float conedeltaangle\" 10\nShape \"sphere\"\n";
    let ron = convert(text, false).unwrap().ron().unwrap();
    assert!(
        ron.contains("cutoff_angle: 40.0, beam_width: 30.0, falloff: \"smoothstep\""),
        "{ron}"
    );
    // A float texture that names another reads the float textures.
    let text = "WorldBegin\nTexture \"a\" \"float\" \"constant\" \"float value\" 0.3\nTexture \"b\" \"float\" \"constant\" \"texture value\" \"a\"\nMaterial \"conductor\" \"bool remaproughness\" false \"texture roughness\" \"b\"\nShape \"sphere\"\n";
    let ron = convert(text, false).unwrap().ron().unwrap();
    assert!(ron.contains("alpha: 0.3"), "{ron}");
    // The stratified sampler takes xsamples x ysamples.
    let text = format!("Sampler \"stratified\" \"integer xsamples\" 8 \"integer ysamples\" 8\nWorldBegin\n{quad}\n");
    let ron = convert(&text, false).unwrap().ron().unwrap();
    assert!(
        ron.contains("spp: 64") && ron.contains("sampler: \"stratified\""),
        "{ron}"
    );
    // Without a Sampler, pbrt-v4's default, zsobol; pbrt's samplers by their raylab names,
    // and an unknown one refused at its place.
    let ron = convert(&format!("WorldBegin\n{quad}\n"), false)
        .unwrap()
        .ron()
        .unwrap();
    assert!(ron.contains("sampler: \"zsobol\""), "{ron}");
    // So is its light sampler, the BVH; an Integrator's lightsampler chooses another.
    assert!(ron.contains("light_selection: bvh"), "{ron}");
    let text =
        format!("Integrator \"path\" \"string lightsampler\" \"power\"\nWorldBegin\n{quad}\n");
    let ron = convert(&text, false).unwrap().ron().unwrap();
    assert!(!ron.contains("light_selection"), "{ron}");
    let text =
        format!("Integrator \"path\" \"string lightsampler\" \"random\"\nWorldBegin\n{quad}\n");
    let err = convert(&text, false).unwrap_err();
    assert!(
        err.1 == 1 && err.3.contains("lightsampler \"random\""),
        "{err:?}"
    );
    for (pbrt, raylab) in [
        ("halton", "halton"),
        ("paddedsobol", "sobol"),
        ("sobol", "sobol"),
    ] {
        let text = format!("Sampler \"{pbrt}\"\nWorldBegin\n{quad}\n");
        let ron = convert(&text, false).unwrap().ron().unwrap();
        assert!(
            ron.contains(&format!("sampler: \"{raylab}\"")),
            "{pbrt}: {ron}"
        );
    }
    let text = format!("Sampler \"lowdiscrepancy\"\nWorldBegin\n{quad}\n");
    let err = convert(&text, false).unwrap_err();
    assert!(
        (err.1, err.2) == (1, 1) && err.3.contains("no such sampler"),
        "{err:?}"
    );
    // A textured patch without uv gets pbrt's (u, v) at its corners.
    let text = format!("WorldBegin\nTexture \"c\" \"spectrum\" \"checkerboard\"\nMaterial \"diffuse\" \"texture reflectance\" \"c\"\n{quad}\n");
    let ron = convert(&text, false).unwrap().ron().unwrap();
    assert!(
        ron.contains("uvs: [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]"),
        "{ron}"
    );
    // A mesh of an object definition keeps its own winding under a mirroring transform
    // (an instance turns its normals as normals).
    let text = "WorldBegin\nObjectBegin \"o\"\nScale 1 1 -1\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\nObjectEnd\nObjectInstance \"o\"\n";
    assert!(convert(text, false)
        .unwrap()
        .ron()
        .unwrap()
        .contains("indices: [(0, 1, 2)]"));
    let text =
        "WorldBegin\nScale 1 1 -1\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n";
    assert!(convert(text, false)
        .unwrap()
        .ron()
        .unwrap()
        .contains("indices: [(0, 2, 1)]"));
}

/// Consecutive curves that agree (material, transform, orientation, type, split depth) make
/// one `Curves` entity; a change of any starts another. B-splines become Bézier chains.
#[test]
fn consecutive_curves_gather_into_one_entity() {
    let curve = |extra: &str| {
        format!("Shape \"curve\" \"point3 P\" [0 0 0  1 0 0  2 1 0  3 1 0] \"float width\" 0.1 {extra}\n")
    };
    let text = format!(
        "Camera \"perspective\"\nWorldBegin\nMaterial \"hair\"\n{}{}{}{}Material \"diffuse\"\n{}\
         AttributeBegin\nTranslate 1 0 0\n{}AttributeEnd\n{}{}",
        curve(""),
        curve("\"string basis\" \"bspline\""),
        curve("\"float width0\" 0.2"),
        curve("\"string type\" \"cylinder\""),
        curve(""),
        curve(""),
        curve(""),
        curve("\"integer splitdepth\" 1"),
    );
    let imported = convert(&text, false).unwrap();
    let shapes: Vec<(&str, usize, CurveType, u32)> = imported
        .scene
        .entities
        .iter()
        .map(|e| match &e.shape {
            Some(ShapeDesc::Curves {
                kind,
                split_depth,
                curves,
            }) => (
                e.material.as_deref().unwrap_or(""),
                curves.len(),
                *kind,
                *split_depth,
            ),
            other => panic!("{other:?}"),
        })
        .collect();
    let hair = shapes[0].0;
    assert!(hair.starts_with("hair"), "{hair}");
    use CurveType::{Cylinder, Flat};
    assert_eq!(
        shapes.iter().map(|s| (s.1, s.2, s.3)).collect::<Vec<_>>(),
        [
            (3, Flat, 3),
            (1, Cylinder, 3),
            (1, Flat, 3),
            (1, Flat, 3),
            (1, Flat, 3),
            (1, Flat, 1)
        ]
    );
    assert_ne!(shapes[2].0, hair);
    let Some(ShapeDesc::Curves { curves, .. }) = &imported.scene.entities[0].shape else {
        unreachable!()
    };
    // A cubic B-spline of 4 points is one segment, from (p0 + 4 p1 + p2) / 6.
    assert_eq!(curves[1].points.len(), 4);
    let start = curves[1].points[0];
    assert!((start[0] - 1.0).abs() < 1e-6 && (start[1] - 1.0 / 6.0).abs() < 1e-6);
    assert_eq!((curves[0].width, curves[2].width), ((0.1, 0.1), (0.2, 0.1)));
    // The one under the translation is placed by it; the RON loads.
    assert!(imported.scene.entities[3].transform.matrix.is_some());
    assert!(imported.scene.entities[4].transform.matrix.is_none());
    crate::scene::parse_scene(&imported.ron().unwrap(), Path::new("curves.pbrt")).unwrap();
}

/// pbrt-v4's hair takes its absorption from `sigma_a`, else `reflectance`, else the melanins;
/// the ones left out are noted; numbers clamped as pbrt-v4 clamps them.
#[test]
fn hair_takes_one_absorption_as_pbrt_v4_does() {
    let hair = |params: &str| {
        let text = format!(
            "Camera \"perspective\"\nWorldBegin\nMaterial \"hair\" {params}\nShape \"sphere\"\n"
        );
        let imported = convert(&text, false).unwrap();
        let (_, desc) = imported.scene.materials.0[0].clone();
        (desc, imported.report.join("\n"))
    };
    let (desc, report) = hair(
        "\"rgb sigma_a\" [0.1 0.2 -0.3] \"float eumelanin\" 3 \"rgb reflectance\" [0.5 0.5 0.5]",
    );
    assert_eq!(
        desc,
        MaterialDesc::Hair {
            sigma_a: Some([0.1, 0.2, 0.0]),
            reflectance: None,
            eumelanin: None,
            pheomelanin: None,
            eta: 1.55,
            beta_m: 0.3,
            beta_n: 0.3,
            alpha: 2.0,
        }
    );
    for needle in [
        "`reflectance` ignored since `sigma_a` is given",
        "`eumelanin` ignored since `sigma_a` is given",
        "`sigma_a` -0.3 clamped to 0",
    ] {
        assert!(report.contains(needle), "{needle}: {report}");
    }
    let (desc, report) = hair("\"rgb color\" [0.6 0.5 0.4] \"float pheomelanin\" 1 \"float beta_m\" 2 \"float eta\" 1.6 \"float alpha\" -3");
    let MaterialDesc::Hair {
        reflectance,
        pheomelanin,
        beta_m,
        eta,
        alpha,
        ..
    } = desc
    else {
        panic!("{desc:?}")
    };
    assert_eq!(
        (reflectance, pheomelanin, beta_m, eta, alpha),
        (Some([0.6, 0.5, 0.4]), None, 1.0, 1.6, -3.0)
    );
    assert!(
        report.contains("`pheomelanin` ignored since `color` is given"),
        "{report}"
    );
    let (desc, _) = hair("\"float pheomelanin\" 0.5");
    assert!(matches!(
        desc,
        MaterialDesc::Hair {
            eumelanin: None,
            pheomelanin: Some(0.5),
            sigma_a: None,
            ..
        }
    ));
    // None: the description's default, pbrt's brown (eumelanin 1.3).
    let (desc, _) = hair("");
    assert!(matches!(
        desc,
        MaterialDesc::Hair {
            eumelanin: None,
            pheomelanin: None,
            sigma_a: None,
            reflectance: None,
            ..
        }
    ));
}

/// The media a scene defines, by name.
fn media_of(text: &str) -> Vec<(String, MediumDesc)> {
    convert(text, false)
        .unwrap_or_else(|e| panic!("{e:?}"))
        .scene
        .media
        .0
}

const SPHERE: &str = "Shape \"sphere\"";

/// pbrt-v4's `homogeneous`: sigma_a and sigma_s of 1 unless given, sigma_t their sum and
/// the albedo their ratio (0 where both are 0), `g` as Henyey-Greenstein's (0 isotropic,
/// clamped as pbrt clamps it), `Le` times `Lescale` (and the exposure) as the emission, a
/// `preset` from pbrt's table.
#[test]
fn homogeneous_media_take_pbrts_defaults_and_coefficients() {
    let one = |params: &str| {
        let text = format!(
            "MakeNamedMedium \"m\" \"string type\" \"homogeneous\" {params}\nWorldBegin\n{SPHERE}\n"
        );
        media_of(&text).remove(0)
    };
    let (name, defaults) = one("");
    assert_eq!(name, "m");
    assert_eq!(
        defaults,
        MediumDesc::Homogeneous {
            sigma_t: [2.0; 3],
            albedo: [0.5; 3],
            scale: 1.0,
            phase: PhaseDesc::Isotropic,
            emission: [0.0; 3],
        }
    );
    let (_, given) = one("\"rgb sigma_a\" [0.125 0.25 0.5] \"rgb sigma_s\" [0.375 0.25 0] \"float scale\" 2 \"float g\" 0.5 \"rgb Le\" [1 2 3] \"float Lescale\" 0.5");
    assert_eq!(
        given,
        MediumDesc::Homogeneous {
            sigma_t: [0.5, 0.5, 0.5],
            albedo: [0.75, 0.5, 0.0],
            scale: 2.0,
            phase: PhaseDesc::HenyeyGreenstein(0.5),
            emission: [0.5, 1.0, 1.5],
        }
    );
    let (_, empty) = one("\"rgb sigma_a\" [0 0 0] \"float sigma_s\" 0");
    assert!(
        matches!(
            empty,
            MediumDesc::Homogeneous {
                sigma_t: [0.0, 0.0, 0.0],
                albedo: [0.0, 0.0, 0.0],
                ..
            }
        ),
        "{empty:?}"
    );
    let (_, milk) = one("\"string preset\" \"Skimmilk\" \"float scale\" 10");
    let MediumDesc::Homogeneous {
        sigma_t,
        albedo,
        scale,
        ..
    } = milk
    else {
        panic!("{milk:?}")
    };
    assert_eq!(scale, 10.0);
    let expected_t = [0.70 + 0.0014, 1.22 + 0.0025, 1.90 + 0.0142];
    for c in 0..3 {
        assert!(
            (f64::from(sigma_t[c]) - expected_t[c]).abs() < 1e-6,
            "{sigma_t:?}"
        );
    }
    assert!((f64::from(albedo[0]) - 0.70 / (0.70 + 0.0014)).abs() < 1e-6);
    let clamped = convert(&format!("MakeNamedMedium \"m\" \"string type\" \"homogeneous\" \"float g\" -1.5\nWorldBegin\n{SPHERE}\n"), false).unwrap();
    assert!(matches!(
        clamped.scene.media.0[0].1,
        MediumDesc::Homogeneous { phase: PhaseDesc::HenyeyGreenstein(g), .. } if g == -0.99
    ));
    assert!(clamped.report.join("\n").contains("clamped to -0.99"));
    // The shutter's open time scales the medium's emission as every emitter's.
    let text = format!("Camera \"perspective\" \"float shutterclose\" 0.5\nMakeNamedMedium \"m\" \"string type\" \"homogeneous\" \"rgb Le\" [4 4 4]\nWorldBegin\n{SPHERE}\n");
    assert!(matches!(
        media_of(&text)[0].1,
        MediumDesc::Homogeneous {
            emission: [2.0, 2.0, 2.0],
            ..
        }
    ));
    // A preset replaces sigma_a and sigma_s: giving them too is an error, as in pbrt-v4.
    let text = format!("WorldBegin\nMakeNamedMedium \"m\" \"string type\" \"homogeneous\" \"string preset\" \"Ketchup\" \"rgb sigma_a\" [1 1 1]\n{SPHERE}\n");
    let e = convert(&text, false).unwrap_err();
    assert!(
        e.3.contains("`sigma_a` is not read with a `preset`"),
        "{e:?}"
    );
}

/// pbrt-v4's `uniformgrid`: its densities as an inline grid read with zero past its voxel
/// centres, in the box p0..p1 placed by the transform at the directive, times
/// `scale (sigma_a + sigma_s)` (a tint where that is not grey).
#[test]
fn uniform_grids_become_value_grids_in_their_box() {
    let text = format!(
        "WorldBegin\nAttributeBegin\nTranslate 1 2 3\nScale 2 2 2\n\
         MakeNamedMedium \"g\" \"string type\" \"uniformgrid\" \"integer nx\" 2 \"float density\" [0.5 1]\n\
         \"point3 p0\" [1 0 0] \"point3 p1\" [0 2 1] \"rgb sigma_a\" [1 1 1] \"rgb sigma_s\" [1 2 3] \"float scale\" 0.5 \"float g\" 0.25\n\
         AttributeEnd\n{SPHERE}\n"
    );
    let imported = convert(&text, false).unwrap();
    let (_, grid) = &imported.scene.media.0[0];
    assert_eq!(
        *grid,
        MediumDesc::Heterogeneous {
            sigma_t: Some(VolumeDesc::Values {
                size: (2, 1, 1),
                values: vec![0.5, 1.0],
                edge: GridEdgeDesc::Zero,
            }),
            albedo: Some(VolumeDesc::Constant([0.5, 2.0 / 3.0, 0.75])),
            sigma_a: None,
            sigma_s: None,
            scale: 0.5,
            tint: [2.0, 3.0, 4.0],
            phase: PhaseDesc::HenyeyGreenstein(0.25),
            emission: [0.0; 3],
            emission_grid: None,
            transform: TransformDesc {
                matrix: Some(vec![
                    2.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 2.0, 0.0, 0.0, 2.0, 3.0
                ]),
                ..TransformDesc::default()
            },
            bounds: ([0.0; 3], [1.0, 2.0, 1.0]),
        }
    );
    // The RON loads, and the grey default folds sigma_a + sigma_s = 2 into `scale`.
    crate::scene::parse_scene(&imported.ron().unwrap(), Path::new("grid.pbrt")).unwrap();
    let grey = media_of(&format!("WorldBegin\nMakeNamedMedium \"g\" \"string type\" \"uniformgrid\" \"float density\" [3]\n{SPHERE}\n"));
    assert!(
        matches!(&grey[0].1, MediumDesc::Heterogeneous { scale, tint: [1.0, 1.0, 1.0], transform, .. } if *scale == 2.0 && *transform == TransformDesc::default()),
        "{grey:?}"
    );
    // Made before the camera, a grid is placed in pbrt-v4's render space: the world moved
    // by the camera's position (here the transform is the camera's, which takes the medium's
    // origin to (0, 0, 5), and the eye is at (0, 0, 5)).
    let before = media_of(&format!("LookAt 0 0 5  0 0 0  0 1 0\nMakeNamedMedium \"g\" \"string type\" \"uniformgrid\" \"float density\" [1]\nCamera \"perspective\"\nWorldBegin\n{SPHERE}\n"));
    let MediumDesc::Heterogeneous { transform, .. } = &before[0].1 else {
        panic!("{before:?}")
    };
    let m = transform.matrix.as_ref().unwrap();
    let origin = [m[3], m[7], m[11]];
    assert!(
        (0..3).all(|i| (origin[i] - [0.0, 0.0, 10.0][i]).abs() < 1e-5),
        "{m:?}"
    );
    // Counts checked as pbrt-v4 checks them; blackbody emission is not supported.
    let bad = |params: &str| {
        let text = format!("WorldBegin\nMakeNamedMedium \"g\" \"string type\" \"uniformgrid\" {params}\n{SPHERE}\n");
        convert(&text, false).unwrap_err().3
    };
    assert!(bad("\"integer nx\" 2 \"float density\" [1]")
        .contains("1 density values for a grid of 2 x 1 x 1"));
    assert!(bad("").contains("needs \"float density\""));
    assert!(bad("\"float density\" [1] \"float temperature\" [1000]").contains("--approximate"));
    assert!(bad(
        "\"integer nx\" 2 \"float density\" [1 1] \"rgb Le\" [1 1 1] \"float Lescale\" [1]"
    )
    .contains("1 `Lescale` values for 2 voxels"));
    assert!(bad("\"float density\" [1] \"point3 p1\" [0 1 1]").contains("bound no volume"));
}

/// A `uniformgrid`'s emission is `Le` times its `Lescale` grid; without one, times pbrt-v4's
/// grid of one voxel of 1, which fades towards the box's faces.
#[test]
fn uniform_grid_emission_is_le_times_its_lescale_grid() {
    let emission_of = |params: &str| {
        let media = media_of(&format!("WorldBegin\nMakeNamedMedium \"g\" \"string type\" \"uniformgrid\" \"integer nx\" 2 \"float density\" [1 1] {params}\n{SPHERE}\n"));
        let MediumDesc::Heterogeneous {
            emission,
            emission_grid,
            ..
        } = media[0].1.clone()
        else {
            panic!("{media:?}")
        };
        (emission, emission_grid)
    };
    assert_eq!(
        emission_of("\"rgb Le\" [1 2 3] \"float Lescale\" [0.5 4]"),
        (
            [1.0, 2.0, 3.0],
            Some(VolumeDesc::Values {
                size: (2, 1, 1),
                values: vec![0.5, 4.0],
                edge: GridEdgeDesc::Zero,
            })
        )
    );
    assert_eq!(
        emission_of("\"rgb Le\" [2 2 2]"),
        (
            [2.0; 3],
            Some(VolumeDesc::Values {
                size: (1, 1, 1),
                values: vec![1.0],
                edge: GridEdgeDesc::Zero,
            })
        )
    );
    assert_eq!(emission_of(""), ([0.0; 3], None));
}

/// pbrt-v4's `rgbgrid`: `sigma_a` and `sigma_s` as RGB grids (1 where one is left out) times
/// `scale`, `Le` as an RGB grid times `Lescale` and pbrt-v4's unnormalised illuminant; the
/// counts checked as pbrt-v4 checks them.
#[test]
fn rgb_grids_become_two_coefficient_grids_with_an_emission_grid() {
    let text = |params: &str| {
        format!("WorldBegin\nMakeNamedMedium \"g\" \"string type\" \"rgbgrid\" \"integer nz\" 2 \"point3 p1\" [2 1 1] {params}\n{SPHERE}\n")
    };
    let media = media_of(&text(
        "\"rgb sigma_a\" [1 2 3 4 5 6] \"rgb Le\" [0 1 0 2 0 0] \"float Lescale\" 0.5 \"float scale\" 3 \"float g\" -0.5",
    ));
    let values = |v: &[f32]| {
        Some(VolumeDesc::Values {
            size: (1, 1, 2),
            values: v.to_vec(),
            edge: GridEdgeDesc::Zero,
        })
    };
    assert_eq!(
        media[0].1,
        MediumDesc::Heterogeneous {
            sigma_t: None,
            albedo: None,
            sigma_a: values(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
            sigma_s: Some(VolumeDesc::Constant([1.0; 3])),
            scale: 3.0,
            tint: [1.0; 3],
            phase: PhaseDesc::HenyeyGreenstein(-0.5),
            emission: [(0.5 * 106.856895) as f32; 3],
            emission_grid: values(&[0.0, 1.0, 0.0, 2.0, 0.0, 0.0]),
            transform: TransformDesc::default(),
            bounds: ([0.0; 3], [2.0, 1.0, 1.0]),
        }
    );
    let imported = convert(&text("\"rgb sigma_s\" [1 1 1 1 1 1]"), false).unwrap();
    crate::scene::parse_scene(&imported.ron().unwrap(), Path::new("grid.pbrt")).unwrap();
    let bad = |params: &str| convert(&text(params), false).unwrap_err().3;
    assert!(bad("").contains("needs `sigma_a` or `sigma_s`"));
    assert!(
        bad("\"rgb sigma_s\" [1 1 1 1 1 1] \"rgb Le\" [1 1 1 1 1 1]")
            .contains("`Le` needs `sigma_a`")
    );
    assert!(bad("\"rgb sigma_a\" [1 1 1]")
        .contains("1 `sigma_a` RGB values for a grid of 1 x 1 x 2 = 2"));
    assert!(bad("\"rgb sigma_a\" [1 1 1 1 -1 1]").contains("a negative `sigma_a`"));
}

/// `MediumInterface` is part of the graphics state: AttributeEnd restores it, WorldBegin
/// does not reset it, one name means the same medium on both sides (no boundary), "" is
/// vacuum. The camera sits in the outside medium at `Camera`; instances keep their shapes'.
#[test]
fn medium_interfaces_scope_with_attributes_and_follow_shapes() {
    let text = format!(
        "MakeNamedMedium \"a\" \"string type\" \"homogeneous\"\n\
         MakeNamedMedium \"b\" \"string type\" \"homogeneous\"\n\
         MediumInterface \"a\" \"b\"\nCamera \"perspective\"\nWorldBegin\n\
         {SPHERE}\nAttributeBegin\nMediumInterface \"b\"\n{SPHERE}\nMediumInterface \"\" \"a\"\n{SPHERE}\n\
         ObjectBegin \"o\"\nMediumInterface \"b\" \"\"\n{SPHERE}\nObjectEnd\nAttributeEnd\n{SPHERE}\nObjectInstance \"o\"\n"
    );
    let imported = convert(&text, false).unwrap();
    assert_eq!(imported.scene.camera_medium.as_deref(), Some("b"));
    let side = |s: &str| (!s.is_empty()).then(|| s.to_string());
    let sides = |inside: &str, outside: &str| {
        Some(MediumInterfaceDesc {
            inside: side(inside),
            outside: side(outside),
        })
    };
    let media: Vec<_> = imported
        .scene
        .entities
        .iter()
        .map(|e| e.medium.clone())
        .collect();
    assert_eq!(
        media,
        [
            sides("a", "b"),
            None,
            sides("", "a"),
            sides("a", "b"),
            sides("b", "")
        ]
    );
    // pbrt-v4 looks shapes' media up once the scene is read: defined later is defined.
    let later = format!("WorldBegin\nMediumInterface \"late\" \"\"\n{SPHERE}\nMakeNamedMedium \"late\" \"string type\" \"homogeneous\"\n");
    assert_eq!(
        convert(&later, false).unwrap().scene.entities[0].medium,
        sides("late", "")
    );
}

/// The camera's medium must be defined by WorldBegin; a medium nobody defines is an error at
/// the `MediumInterface` that names it.
#[test]
fn undefined_media_are_errors_where_they_are_named() {
    let camera = "MediumInterface \"\" \"fog\"\nCamera \"perspective\"\nWorldBegin\nMakeNamedMedium \"fog\" \"string type\" \"homogeneous\"\nShape \"sphere\"\n";
    let e = convert(camera, false).unwrap_err();
    assert_eq!((e.1, e.2), (1, 1), "{e:?}");
    assert!(
        e.3.contains("\"fog\" is not defined before WorldBegin"),
        "{e:?}"
    );
    let shape = format!("WorldBegin\n{SPHERE}\n  MediumInterface \"smoke\" \"\"\n{SPHERE}\n");
    let e = convert(&shape, false).unwrap_err();
    assert_eq!((e.1, e.2), (3, 3), "{e:?}");
    assert!(e.3.contains("no medium is named \"smoke\""), "{e:?}");
    // A light looks its (outside) medium up too.
    let light = "WorldBegin\nMediumInterface \"\" \"smoke\"\nLightSource \"point\"\n";
    assert!(convert(light, false).unwrap_err().3.contains("\"smoke\""));
}

/// Bad media: a type pbrt-v4 lacks, a parameter it does not read (names are
/// case-sensitive), a name defined twice; types raylab lacks are vacuum with --approximate.
#[test]
fn bad_media_are_errors_at_their_place() {
    let medium = |params: &str| {
        format!(
            "WorldBegin\nMakeNamedMedium \"m\" {params}\nMediumInterface \"m\" \"\"\n{SPHERE}\n"
        )
    };
    let e = convert(&medium("\"string type\" \"heterogeneous\""), false).unwrap_err();
    assert_eq!((e.1, e.2), (2, 1));
    assert!(
        e.3.contains("`heterogeneous` is not a pbrt-v4 medium") && e.3.contains("uniformgrid"),
        "{e:?}"
    );
    let text = medium("\"string type\" \"homogeneous\" \"rgb Le\" [1 1 1] \"float LeScale\" 2");
    let e = convert(&text, false).unwrap_err();
    let col = text
        .lines()
        .nth(1)
        .and_then(|l| l.find("\"float LeScale\""))
        .unwrap()
        + 1;
    assert_eq!((e.1, e.2 as usize), (2, col), "{e:?}");
    assert!(
        e.3.contains("parameter `float LeScale` is not supported"),
        "{e:?}"
    );
    assert!(convert(&medium(""), false)
        .unwrap_err()
        .3
        .contains("needs \"string type\""));
    let twice = format!(
        "MakeNamedMedium \"m\" \"string type\" \"homogeneous\"\n{}",
        medium("\"string type\" \"homogeneous\"")
    );
    assert!(convert(&twice, false)
        .unwrap_err()
        .3
        .contains("defined twice"));
    let cloud = medium("\"string type\" \"cloud\" \"float wispiness\" 2");
    let e = convert(&cloud, false).unwrap_err();
    assert!(
        e.3.contains("`cloud` medium is not supported") && e.3.contains("--approximate"),
        "{e:?}"
    );
    // As vacuum: no medium, and the sphere bounds none.
    let vacuum = convert(&cloud, true).unwrap();
    assert!(vacuum.scene.media.0.is_empty());
    assert_eq!(vacuum.scene.entities[0].medium, None);
    assert_eq!(vacuum.scene.render.integrator, "path");
}

/// A shape of the `interface` material (or "none") that bounds a medium is a `Null`
/// surface; one that bounds none is left out (with --approximate), and an area light on it
/// is dropped, as pbrt-v4 drops it.
#[test]
fn interface_shapes_bound_media_as_null_surfaces() {
    let text = format!(
        "WorldBegin\nMakeNamedMedium \"fog\" \"string type\" \"homogeneous\"\n\
         AttributeBegin\nMediumInterface \"fog\" \"\"\nMaterial \"interface\"\n\
         AreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n{SPHERE}\nMaterial \"none\"\n{SPHERE}\nAttributeEnd\n\
         Material \"diffuse\"\n{SPHERE}\n"
    );
    let imported = convert(&text, false).unwrap();
    let e = &imported.scene.entities;
    assert_eq!(e.len(), 3);
    for boundary in &e[..2] {
        assert_eq!(boundary.material.as_deref(), Some("interface"));
        assert!(boundary.emitter.is_none());
        assert_eq!(
            boundary.medium.as_ref().and_then(|m| m.inside.as_deref()),
            Some("fog")
        );
    }
    assert_eq!(
        imported
            .scene
            .materials
            .0
            .iter()
            .filter(|(_, m)| *m == MaterialDesc::Null)
            .count(),
        1
    );
    assert!(e[2].medium.is_none());
    let report = imported.report.join("\n");
    assert!(
        report.contains("area light on a shape with the `interface` material ignored"),
        "{report}"
    );
    assert!(
        report.contains("\"none\" is read as `interface`"),
        "{report}"
    );
    crate::scene::parse_scene(&imported.ron().unwrap(), Path::new("fog.pbrt")).unwrap();
    // Bounding nothing (the same medium both sides): left out, as before.
    let same = format!("WorldBegin\nMakeNamedMedium \"fog\" \"string type\" \"homogeneous\"\nMediumInterface \"fog\"\nMaterial \"interface\"\n{SPHERE}\nMaterial \"diffuse\"\n{SPHERE}\n");
    assert!(convert(&same, false).unwrap_err().3.contains("left out"));
    assert_eq!(convert(&same, true).unwrap().scene.entities.len(), 1);
}

/// pbrt-v4's volpath (its default too) is raylab's volpath on a scene with media and path
/// on one without (the same image); other integrators keep their mapping.
#[test]
fn volumetric_integrators_map_to_volpath_when_the_scene_has_media() {
    let fog = "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\"\n";
    let render = |integrator: &str, media: &str| {
        let text = format!("{integrator}\n{media}WorldBegin\n{SPHERE}\n");
        convert(&text, false).unwrap().scene.render
    };
    let with = render("Integrator \"volpath\" \"integer maxdepth\" 7", fog);
    assert_eq!(
        (with.integrator.as_str(), with.params.get("max-depth")),
        ("volpath", Some(&7.0))
    );
    assert_eq!(render("Integrator \"volpath\"", "").integrator, "path");
    assert_eq!(
        render("Integrator \"simplevolpath\"", fog).integrator,
        "volpath"
    );
    let default = render("", fog);
    assert_eq!(
        (default.integrator.as_str(), default.params.get("max-depth")),
        ("volpath", Some(&5.0))
    );
    assert_eq!(render("", "").integrator, "path");
    assert_eq!(render("Integrator \"path\"", fog).integrator, "path");
    assert_eq!(render("Integrator \"bdpt\"", fog).integrator, "bdpt");
}
