//! Mitsuba 3 XML scenes: rendered as raylab reads them, imported to RON, and held to the RON
//! scene they were written from.

use crate::common::{raylab_in, repo_file};
use raylab::render::{render, Film, RenderSettings};
use raylab::scene::{load_scene, load_scene_defined, ImportOptions, RenderScene};
use raylab_integrators::registry;
use raylab_integrators::sampler::SamplerKind;
use std::path::Path;

fn mean_of(scene: &Path, defines: &[(String, String)], spp: u32, seed: u64) -> Film {
    let options = ImportOptions {
        defines: defines.to_vec(),
        approximate: false,
        ..ImportOptions::default()
    };
    let loaded = load_scene_defined(scene, &[], &options).unwrap();
    let built = RenderScene::build(&loaded);
    let camera = loaded.camera.with_resolution(24, 24);
    let mut path = registry::find("path")
        .unwrap()
        .instantiate(&[("max-depth".into(), "7".into())])
        .unwrap();
    let settings = RenderSettings::fixed(spp, seed, None);
    render(&built, &camera, path.as_mut(), &settings).unwrap().0
}

/// `scenes/mitsuba/cornell_box.xml` is `scenes/cornell_box.ron` written as Mitsuba XML:
/// the same image, within noise (a z-test on each channel's mean).
#[test]
fn the_xml_cornell_box_renders_as_the_ron_one() {
    let xml = mean_of(&repo_file("scenes/mitsuba/cornell_box.xml"), &[], 512, 1);
    let ron = mean_of(&repo_file("scenes/cornell_box.ron"), &[], 512, 2);
    let (a, b) = (xml.mean(), ron.mean());
    let (sa, sb) = (xml.mean_standard_error(), ron.mean_standard_error());
    for c in 0..3 {
        let z = (a[c] - b[c]) / (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
        assert!(z.abs() < 4.0, "channel {c}: {a} vs {b} (z {z})");
        assert!(sa[c] < 0.01 * a[c], "too noisy to mean anything");
    }
    // The scene's own settings came across: camera, film, filter, samples, depth.
    let loaded = load_scene(&repo_file("scenes/mitsuba/cornell_box.xml")).unwrap();
    assert_eq!((loaded.camera.width, loaded.camera.height), (256, 256));
    assert_eq!(loaded.render.spp, 64);
    assert_eq!(loaded.render.params.get("max-depth"), Some(&7.0));
    // -D overrides a <default>.
    let defined = load_scene_defined(
        &repo_file("scenes/mitsuba/cornell_box.xml"),
        &[],
        &ImportOptions {
            defines: vec![("spp".into(), "8".into()), ("max_depth".into(), "3".into())],
            approximate: false,
            ..ImportOptions::default()
        },
    )
    .unwrap();
    assert_eq!(defined.render.spp, 8);
    assert_eq!(defined.render.params.get("max-depth"), Some(&2.0));
}

/// A `<sampler>` names raylab's sampler: Mitsuba's own where raylab has it, the nearest
/// (reported) where not; an unknown one is refused at its place.
#[test]
fn the_sensor_sampler_chooses_the_sampler() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |sampler: &str| {
        format!(
            r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="45"/>
            <sampler type="{sampler}"><integer name="sample_count" value="4"/></sampler></sensor>
            <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape></scene>"#
        )
    };
    for (mitsuba, raylab, reported) in [
        ("independent", SamplerKind::Independent, false),
        ("stratified", SamplerKind::Stratified, false),
        ("multijitter", SamplerKind::Stratified, true),
        ("orthogonal", SamplerKind::Stratified, true),
        ("ldsampler", SamplerKind::Sobol, true),
        ("sobol", SamplerKind::Sobol, false),
    ] {
        let path = dir.path().join(format!("{mitsuba}.xml"));
        std::fs::write(&path, scene(mitsuba)).unwrap();
        let loaded = load_scene(&path).unwrap_or_else(|e| panic!("{mitsuba}: {e}"));
        assert_eq!(loaded.render.sampler, raylab, "{mitsuba}");
        let imported = raylab::formats::mitsuba::to_ron(&scene(mitsuba), &[]).unwrap();
        let said = imported.report.iter().any(|w| w.contains("nearest it has"));
        assert_eq!(said, reported, "{mitsuba}: {:?}", imported.report);
    }
    let path = dir.path().join("bad.xml");
    std::fs::write(&path, scene("blue")).unwrap();
    let err = format!("{:#}", load_scene(&path).err().unwrap());
    assert!(
        err.contains("bad.xml:2:") && err.contains("sampler `blue`"),
        "{err}"
    );
}

/// Every plugin the importer knows, in one scene: it loads, with the materials, lights and
/// shapes it says.
#[test]
fn every_supported_plugin_loads() {
    let dir = tempfile::tempdir().unwrap();
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
               element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    std::fs::write(dir.path().join("tri.ply"), ply).unwrap();
    std::fs::write(
        dir.path().join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let xml = r#"<scene version="3.0.0">
        <default name="r" value="0.5"/>
        <integrator type="path"><integer name="max_depth" value="-1"/></integrator>
        <sensor type="perspective">
            <float name="fov" value="45"/><string name="fov_axis" value="y"/>
            <transform name="to_world"><lookat origin="0, 1, 6" target="0, 0, 0" up="0, 1, 0"/></transform>
            <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/><rfilter type="tent"/></film>
            <sampler type="independent"><integer name="sample_count" value="5"/></sampler>
        </sensor>
        <texture type="checkerboard" id="checks"><rgb name="color0" value="0.1"/><rgb name="color1" value="0.9"/>
            <transform name="to_uv"><scale x="4" y="2"/></transform></texture>
        <bsdf type="diffuse" id="chequered"><ref name="reflectance" id="checks"/></bsdf>
        <bsdf type="twosided" id="gold"><bsdf type="roughconductor"><string name="material" value="Au"/>
            <string name="distribution" value="ggx"/><float name="alpha" value="0.2"/></bsdf></bsdf>
        <bsdf type="dielectric" id="glass"><string name="int_ior" value="bk7"/><float name="ext_ior" value="1"/></bsdf>
        <bsdf type="roughdielectric" id="frosted"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/></bsdf>
        <bsdf type="thindielectric" id="pane"/>
        <bsdf type="plastic" id="plastic"><rgb name="diffuse_reflectance" value="0.1 0.3 0.7"/><boolean name="nonlinear" value="true"/></bsdf>
        <bsdf type="roughplastic" id="rough plastic"><float name="alpha" value="0.3"/></bsdf>
        <bsdf type="conductor" id="copper"><rgb name="eta" value="0.2 0.9 1.1"/><rgb name="k" value="3.9 2.4 2.2"/></bsdf>
        <shape type="rectangle" id="floor"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="5"/></transform><ref id="chequered"/></shape>
        <shape type="cube" id="box"><transform name="to_world"><scale value="0.3"/><translate x="-2"/></transform><ref id="gold"/></shape>
        <shape type="sphere" id="ball"><point name="center" x="1" y="0.5" z="0"/><float name="radius" value="$r"/><ref id="glass"/></shape>
        <shape type="disk" id="plate"><ref id="frosted"/></shape>
        <shape type="cylinder" id="tube"><point name="p0" value="0 0 -2"/><point name="p1" value="0 1 -2"/><ref id="pane"/></shape>
        <shape type="ply" id="tri"><string name="filename" value="tri.ply"/><ref id="plastic"/></shape>
        <shape type="obj" id="tri2"><string name="filename" value="tri.obj"/><boolean name="face_normals" value="true"/><ref id="rough plastic"/></shape>
        <shape type="sphere" id="shell"><float name="radius" value="0.2"/><ref id="copper"/><boolean name="flip_normals" value="false"/></shape>
        <shape type="sphere" id="plain"><point name="center" x="3" y="0" z="0"/><float name="radius" value="0.1"/></shape>
        <shape type="rectangle" id="lamp"><transform name="to_world"><rotate x="1" angle="90"/><translate y="3"/></transform>
            <emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>
        <emitter type="point"><point name="position" x="0" y="2" z="2"/><rgb name="intensity" value="3"/></emitter>
        <emitter type="spot"><transform name="to_world"><lookat origin="0, 3, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
            <rgb name="intensity" value="10"/><float name="cutoff_angle" value="30"/></emitter>
        <emitter type="directional"><vector name="direction" x="0" y="-1" z="0"/><rgb name="irradiance" value="1"/></emitter>
        <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
    </scene>"#;
    let path = dir.path().join("all.xml");
    std::fs::write(&path, xml).unwrap();
    let loaded = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        loaded.material_names,
        [
            "chequered",
            "gold",
            "glass",
            "frosted",
            "pane",
            "plastic",
            "rough plastic",
            "copper",
            "default"
        ]
    );
    assert_eq!((loaded.camera.width, loaded.camera.height), (32, 24));
    assert_eq!(loaded.render.spp, 5);
    assert!(loaded.render.params.get("max-depth").unwrap().is_infinite());
    let built = RenderScene::build(&loaded);
    // Area light, point, spot, directional and the constant environment.
    assert_eq!(built.stats.lights, 5);
    assert_eq!((built.stats.spheres, built.stats.quadrics), (3, 2));
    // It renders with every integrator of the registry.
    let film = mean_of(&path, &[], 2, 0);
    assert!(film.mean().x.is_finite() && film.mean().x > 0.0);

    // raylab import writes the same scene as RON, and the report says what changed.
    let out = raylab_in(
        dir.path(),
        &["import", "all.xml", "-o", "all.ron", "--report"],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = String::from_utf8_lossy(&out.stdout);
    let ron = std::fs::read_to_string(dir.path().join("all.ron")).unwrap();
    assert!(
        ron.contains("Obj(path: \"tri.obj\", normals: \"flat\")"),
        "face_normals shades flat: {ron}"
    );
    assert!(
        report.contains("| default | Mitsuba's default BSDF"),
        "{report}"
    );
    // Mitsuba's opaque BSDFs are one-sided, and so are they imported.
    let ron_text = std::fs::read_to_string(dir.path().join("all.ron")).unwrap();
    assert!(ron_text.contains("\"copper\": OneSided("), "{ron_text}");
    assert!(
        report.contains("max_depth -1 is raylab's path max-depth inf"),
        "{report}"
    );
    // An emitter without a BSDF is black in Mitsuba (not its default grey): no material.
    let text = std::fs::read_to_string(dir.path().join("all.ron")).unwrap();
    let lamp = text
        .lines()
        .find(|l| l.contains("(name: \"lamp\""))
        .unwrap();
    assert!(!lamp.contains("material:"), "{lamp}");
    let ron = load_scene(&dir.path().join("all.ron")).unwrap();
    assert_eq!(ron.material_names, loaded.material_names);
    assert_eq!(RenderScene::build(&ron).stats.lights, 5);
}

#[test]
fn import_refuses_what_it_cannot_write_well() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("elsewhere")).unwrap();
    std::fs::copy(
        repo_file("scenes/mitsuba/cornell_box.xml"),
        dir.path().join("box.xml"),
    )
    .unwrap();
    // Into another folder: its relative file names would break.
    let out = raylab_in(
        dir.path(),
        &["import", "box.xml", "-o", "elsewhere/box.ron"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("into the imported scene's folder"));
    // A RON scene is not imported; a bad scene writes nothing.
    let out = raylab_in(dir.path(), &["import", "box.ron", "-o", "x.ron"]);
    assert_eq!(out.status.code(), Some(2));
    std::fs::write(
        dir.path().join("bad.xml"),
        "<scene><shape type=\"hair\"/></scene>",
    )
    .unwrap();
    let out = raylab_in(dir.path(), &["import", "bad.xml", "-o", "bad.ron"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("bad.xml:1:8: shape `hair` is not supported")
    );
    assert!(!dir.path().join("bad.ron").exists());
    // -D reaches the import.
    let out = raylab_in(
        dir.path(),
        &["import", "box.xml", "-o", "box.ron", "-D", "spp=3"],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(dir.path().join("box.ron")).unwrap();
    assert!(text.contains("spp: 3"), "{text}");
}

/// Veach's MIS scene with Mitsuba's `direct` integrator: its sample counts come across, and
/// light sampling, BSDF sampling and MIS give the image that `path` gives at depth 1
/// (direct light only).
#[test]
fn the_veach_scenes_strategies_agree_with_path_at_depth_one() {
    let scene = repo_file("scenes/mitsuba/veach_mis.xml");
    let render_with = |integrator: &str, params: &[(&str, &str)], seed: u64| {
        let loaded = load_scene(&scene).unwrap();
        let built = RenderScene::build(&loaded);
        let camera = loaded.camera.with_resolution(24, 16);
        let params: Vec<(String, String)> = params
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        let mut integrator = registry::find(integrator)
            .unwrap()
            .instantiate(&params)
            .unwrap();
        let settings = RenderSettings::fixed(256, seed, None);
        render(&built, &camera, integrator.as_mut(), &settings)
            .unwrap()
            .0
    };
    let loaded = load_scene(&scene).unwrap();
    assert_eq!(loaded.render.integrator, "direct");
    assert_eq!(loaded.render.params.get("bsdf-samples"), Some(&1.0));
    let path = render_with("path", &[("max-depth", "1")], 1);
    for (what, params) in [
        ("MIS", [("emitter-samples", "1"), ("bsdf-samples", "1")]),
        (
            "light sampling",
            [("emitter-samples", "1"), ("bsdf-samples", "0")],
        ),
        (
            "BSDF sampling",
            [("emitter-samples", "0"), ("bsdf-samples", "1")],
        ),
    ] {
        let direct = render_with("direct", &params, 2);
        let (a, b) = (direct.mean(), path.mean());
        let (sa, sb) = (direct.mean_standard_error(), path.mean_standard_error());
        for c in 0..3 {
            let z = (a[c] - b[c]) / (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
            assert!(z.abs() < 4.0, "{what}, channel {c}: {a} vs {b} (z {z})");
        }
    }
}

/// Mitsuba's `normalmap` and `bumpmap` wrap a BSDF with a texture: raylab's `NormalMap` and
/// `BumpMap` around the same material, with the texture as written.
#[test]
fn normal_and_bump_maps_wrap_their_bsdf() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([128, 128, 255]))
        .save(dir.path().join("n.png"))
        .unwrap();
    let scene = dir.path().join("maps.xml");
    std::fs::write(
        &scene,
        r#"<scene version="3.0.0">
            <sensor type="perspective"><float name="fov" value="40"/>
                <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
            <bsdf type="normalmap" id="n">
                <texture name="normalmap" type="bitmap"><string name="filename" value="n.png"/><boolean name="raw" value="true"/></texture>
                <bsdf type="roughconductor"/>
            </bsdf>
            <texture type="bitmap" id="h"><string name="filename" value="n.png"/></texture>
            <bsdf type="bumpmap" id="b"><ref id="h"/><float name="scale" value="0.5"/><bsdf type="diffuse"/></bsdf>
            <shape type="sphere"><ref id="n"/></shape>
            <shape type="rectangle"><ref id="b"/></shape>
        </scene>"#,
    )
    .unwrap();
    let text = std::fs::read_to_string(&scene).unwrap();
    let imported = raylab::formats::mitsuba::to_ron(&text, &[]).unwrap();
    for needle in [
        "\"n\": OneSided(NormalMap(texture: Image(path: \"n.png\", filter: \"bilinear\", wrap: \"repeat\", raw: true",
        "material: RoughConductor(metal: \"none\"",
        "\"b\": OneSided(BumpMap(texture: Image(path: \"n.png\"",
        "scale: 0.5, material: Lambert(albedo: (0.5, 0.5, 0.5)))",
    ] {
        assert!(imported.ron().unwrap().contains(needle), "no {needle} in\n{}", imported.ron().unwrap());
    }
    let loaded = load_scene(&scene).unwrap();
    assert_eq!(loaded.material_names.len(), 2);
}

/// A `shapegroup` placed by two `instance`s renders as the same shapes placed one by one:
/// its cube becomes one mesh asset that both instances share, its sphere an entity each.
#[test]
fn shapegroup_instances_render_as_the_shapes_they_place() {
    let dir = tempfile::tempdir().unwrap();
    let head = r#"<scene version="3.0.0">
        <sensor type="perspective"><float name="fov" value="50"/>
            <transform name="to_world"><lookat origin="0, 3, 8" target="0, 0, 0" up="0, 1, 0"/></transform>
            <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="16"/></film></sensor>
        <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
        <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.5"/></bsdf>"#;
    let cube = |t: &str| {
        format!(
            r#"<shape type="cube"><ref id="grey"/><transform name="to_world"><scale value="0.5"/>{t}</transform></shape>
                   <shape type="sphere"><float name="radius" value="0.4"/><ref id="grey"/><transform name="to_world"><translate y="1"/>{t}</transform></shape>"#
        )
    };
    let (left, right) = (
        r#"<rotate y="1" angle="30"/><translate x="-1.5"/>"#,
        r#"<translate x="1.5"/>"#,
    );
    let grouped = format!(
        r#"{head}
        <shape type="shapegroup" id="g">{}</shape>
        <shape type="instance"><ref id="g"/><transform name="to_world">{left}</transform></shape>
        <shape type="instance"><ref id="g"/><transform name="to_world">{right}</transform></shape>
        </scene>"#,
        cube("")
    );
    let flat = format!("{head}{}{}</scene>", cube(left), cube(right));
    let (a, b) = (dir.path().join("grouped.xml"), dir.path().join("flat.xml"));
    std::fs::write(&a, &grouped).unwrap();
    std::fs::write(&b, &flat).unwrap();
    let imported = raylab::formats::mitsuba::to_ron(&grouped, &[]).unwrap();
    assert!(
        imported.ron().unwrap().contains("\"g/0\": Mesh("),
        "{}",
        imported.ron().unwrap()
    );
    assert_eq!(
        imported
            .ron()
            .unwrap()
            .matches("Instance(mesh: \"g/0\")")
            .count(),
        2
    );
    let (fa, fb) = (mean_of(&a, &[], 256, 1), mean_of(&b, &[], 256, 2));
    let (ma, mb) = (fa.mean(), fb.mean());
    let (sa, sb) = (fa.mean_standard_error(), fb.mean_standard_error());
    for c in 0..3 {
        let z = (ma[c] - mb[c]) / (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
        assert!(z.abs() < 4.0, "channel {c}: {ma} vs {mb} (z {z})");
    }
}

/// `--approximate` renders what raylab does not have as the nearest thing it has, and says so.
#[test]
fn approximations_of_mitsuba_plugins_are_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("hair.xml");
    std::fs::write(
        &scene,
        r#"<scene version="3.0.0">
            <integrator type="prb"/>
            <sensor type="perspective"><float name="fov" value="40"/></sensor>
            <shape type="sphere"><bsdf type="hair"/></shape>
        </scene>"#,
    )
    .unwrap();
    let err = load_scene(&scene).err().unwrap().to_string();
    assert!(
        err.contains("integrator `prb` is not supported") && err.contains("--approximate"),
        "{err}"
    );
    let options = ImportOptions {
        defines: Vec::new(),
        approximate: true,
        ..ImportOptions::default()
    };
    let loaded = load_scene_defined(&scene, &[], &options).unwrap();
    assert_eq!(loaded.render.integrator, "path");
    let warned = loaded.warnings.join("\n");
    assert!(
        warned.contains("2:13: integrator `prb`") && warned.contains("4:34: BSDF `hair`"),
        "{warned}"
    );
}

/// `<include>` splices another file's `<scene>` in, `<path>` adds a folder to find files in,
/// and an error inside an included file names that file, line and column.
#[test]
fn includes_and_paths_are_read_and_errors_name_the_included_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("parts")).unwrap();
    std::fs::write(
        dir.path().join("parts/tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("parts/lamp.xml"),
        r#"<scene version="3.0.0">
    <shape type="obj"><string name="filename" value="tri.obj"/>
        <emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>
</scene>"#,
    )
    .unwrap();
    let main = dir.path().join("main.xml");
    std::fs::write(
        &main,
        r#"<scene version="3.0.0">
    <path value="parts"/>
    <sensor type="perspective"><float name="fov" value="40"/></sensor>
    <include filename="lamp.xml"/>
</scene>"#,
    )
    .unwrap();
    let loaded = load_scene(&main).unwrap();
    let built = RenderScene::build(&loaded);
    assert_eq!(built.stats.triangles, 1);
    std::fs::write(
        dir.path().join("parts/lamp.xml"),
        "<scene version=\"3.0.0\">\n    <shape type=\"obj\"><float name=\"bogus\" value=\"1\"/></shape>\n</scene>",
    )
    .unwrap();
    let err = load_scene(&main).err().unwrap().to_string();
    assert!(err.contains("lamp.xml:2:5:"), "{err}");
}

/// An `hdrfilm` crop renders its part of the full image: the same rays through its pixels.
#[test]
fn a_film_crop_renders_its_part_of_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |crop: &str| {
        format!(
            r#"<scene version="3.0.0">
            <sensor type="perspective"><float name="fov" value="50"/>
                <transform name="to_world"><lookat origin="1, 2, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
                <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="30"/>{crop}</film></sensor>
            <shape type="sphere"/>
        </scene>"#
        )
    };
    let load = |name: &str, text: String| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        load_scene(&path).unwrap().camera
    };
    let full = load("full.xml", scene(""));
    let cropped = load(
        "crop.xml",
        scene(
            r#"<integer name="crop_offset_x" value="10"/><integer name="crop_offset_y" value="3"/><integer name="crop_width" value="14"/><integer name="crop_height" value="12"/>"#,
        ),
    );
    assert_eq!((cropped.width, cropped.height), (14, 12));
    for (x, y) in [(0.0, 0.0), (14.0, 12.0), (3.5, 7.25)] {
        let (a, b) = (cropped.ray(x, y), full.ray(x + 10.0, y + 3.0));
        assert!(
            (a.dir - b.dir).length() < 1e-5,
            "{x},{y}: {:?} vs {:?}",
            a.dir,
            b.dir
        );
        assert!((a.origin - b.origin).length() < 1e-5);
    }
}

/// `scenes/mitsuba/meshes.xml` and `orthographic.xml`: three meshes of one `.serialized`
/// file (by `shape_index`; normals computed where the file has none, flat with
/// `face_normals`), a blend of two diffuse BSDFs as one diffuse, an opaque mask as its BSDF,
/// and an orthographic sensor whose size is its `to_world` scale.
#[test]
fn serialized_meshes_blends_masks_and_orthographic_sensors() {
    let scene = repo_file("scenes/mitsuba/meshes.xml");
    let text = std::fs::read_to_string(&scene).unwrap();
    let imported = raylab::formats::mitsuba::to_ron(&text, &[]).unwrap();
    for needle in [
        "Serialized(path: \"assets/meshes.serialized\", shape_index: 0, normals: \"smooth\")",
        "Serialized(path: \"assets/meshes.serialized\", shape_index: 1, normals: \"flat\")",
        "Lambert(albedo: (0.83, 0.41, 0.34))",
        "RoughPlastic(diffuse_reflectance: (0.1, 0.3, 0.7)",
    ] {
        assert!(
            imported.ron().unwrap().contains(needle),
            "no {needle} in\n{}",
            imported.ron().unwrap()
        );
    }
    let loaded = load_scene(&scene).unwrap();
    let built = RenderScene::build(&loaded);
    // Icosphere 320, torus 32 x 12 x 2 = 768, floor 2.
    assert_eq!(built.stats.triangles, 320 + 768 + 2);

    let ortho = load_scene(&repo_file("scenes/mitsuba/orthographic.xml")).unwrap();
    let camera = &ortho.camera;
    assert_eq!((camera.width, camera.height), (200, 150));
    let (a, b) = (camera.ray(0.0, 0.0), camera.ray(200.0, 150.0));
    assert!((a.dir - b.dir).length() < 1e-6, "parallel rays");
    // x spans 2 x 3.2 across the width, y 2 x 3.2 / (200 / 150) down the height.
    let span = b.origin - a.origin;
    let along = |v: glam::Vec3A| span.dot(v.normalize()).abs();
    let up = glam::Vec3A::Y - a.dir * a.dir.y;
    let right = a.dir.cross(up);
    assert!((along(right) - 6.4).abs() < 1e-3, "{}", along(right));
    assert!((along(up) - 4.8).abs() < 1e-3, "{}", along(up));
}

/// What raylab's materials cannot hold is an error at its place, or with `--approximate` the
/// nearest material and a warning: a blend of unlike BSDFs. A see-through mask is a `Mask`.
#[test]
fn unlike_blends_are_approximations_and_masks_cut_out() {
    let scene = |bsdf: &str| {
        format!(
            r#"<scene version="3.0.0">
            <sensor type="perspective"><float name="fov" value="40"/></sensor>
            <shape type="sphere">{bsdf}</shape>
        </scene>"#
        )
    };
    let cases = [(
        r#"<bsdf type="blendbsdf"><float name="weight" value="0.75"/><bsdf type="diffuse"/><bsdf type="conductor"/></bsdf>"#,
        "blendbsdf",
        "Conductor(metal: \"none\", specular_reflectance: (1.0, 1.0, 1.0))",
    )];
    let mask = raylab::formats::mitsuba::to_ron(
        &scene(r#"<bsdf type="mask"><float name="opacity" value="0.25"/><bsdf type="diffuse"/></bsdf>"#),
        &[],
    )
    .unwrap();
    assert!(
        mask.ron()
            .unwrap()
            .contains("Mask(opacity: 0.25, material: Lambert(albedo: (0.5, 0.5, 0.5)))"),
        "{}",
        mask.ron().unwrap()
    );
    for (bsdf, what, nearest) in cases {
        let text = scene(bsdf);
        let err = raylab::formats::mitsuba::to_ron(&text, &[]).unwrap_err();
        assert!(
            err.2.contains(what) && err.2.contains("--approximate") && err.0 == 3,
            "{err:?}"
        );
        let options = ImportOptions {
            defines: Vec::new(),
            approximate: true,
            ..ImportOptions::default()
        };
        let imported = raylab::formats::mitsuba::to_ron_with(&text, &options).unwrap();
        assert!(
            imported.ron().unwrap().contains(nearest),
            "{}",
            imported.ron().unwrap()
        );
        assert_eq!(
            imported.approximated.len(),
            1,
            "{:?}",
            imported.approximated
        );
    }
    // A blend that picks one side, or of one BSDF twice, is exact.
    let exact = scene(
        r#"<bsdf type="blendbsdf"><float name="weight" value="1"/><bsdf type="diffuse"/><bsdf type="conductor"/></bsdf>"#,
    );
    let imported = raylab::formats::mitsuba::to_ron(&exact, &[]).unwrap();
    assert!(imported
        .ron()
        .unwrap()
        .contains("Conductor(metal: \"none\", "));
}

/// A Mitsuba 0.6 scene is read through Mitsuba 3's upgrade rules: camelCase names become
/// snake_case, `<lookAt>` is `<lookat>`, diffuse's `diffuseReflectance` its `reflectance`, and
/// `uscale`/`voffset`... a `to_uv` transform. It imports as the same scene written for 3.0.
#[test]
fn mitsuba_0_6_scenes_are_upgraded_as_mitsuba_3_does() {
    let old = r#"<scene version="0.6.0">
        <integrator type="path"><integer name="maxDepth" value="4"/></integrator>
        <sensor type="perspective"><float name="fov" value="40"/><string name="fovAxis" value="y"/>
            <transform name="toWorld"><lookAt origin="0, 1, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
            <sampler type="independent"><integer name="sampleCount" value="8"/></sampler></sensor>
        <shape type="sphere"><bsdf type="dielectric"><float name="intIOR" value="1.33"/></bsdf></shape>
        <shape type="rectangle"><bsdf type="diffuse"><texture name="diffuseReflectance" type="checkerboard">
            <float name="uscale" value="4"/><float name="vscale" value="2"/><float name="uoffset" value="0.5"/><float name="voffset" value="0.25"/>
        </texture></bsdf></shape>
    </scene>"#;
    let new = r#"<scene version="3.0.0">
        <integrator type="path"><integer name="max_depth" value="4"/></integrator>
        <sensor type="perspective"><float name="fov" value="40"/><string name="fov_axis" value="y"/>
            <transform name="to_world"><lookat origin="0, 1, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
            <sampler type="independent"><integer name="sample_count" value="8"/></sampler></sensor>
        <shape type="sphere"><bsdf type="dielectric"><float name="int_ior" value="1.33"/></bsdf></shape>
        <shape type="rectangle"><bsdf type="diffuse"><texture name="reflectance" type="checkerboard">
            <transform name="to_uv"><translate x="0.5" y="0.25"/><scale x="4" y="2"/></transform>
        </texture></bsdf></shape>
    </scene>"#;
    let (a, b) = (
        raylab::formats::mitsuba::to_ron(old, &[]).unwrap(),
        raylab::formats::mitsuba::to_ron(new, &[]).unwrap(),
    );
    let body = |ron: &str| ron.lines().skip(1).collect::<Vec<_>>().join("\n");
    assert_eq!(body(&a.ron().unwrap()), body(&b.ron().unwrap()));
    assert!(
        a.ron().unwrap().contains("int_ior: 1.33") && a.ron().unwrap().contains("spp: 8"),
        "{}",
        a.ron().unwrap()
    );
    // A 3.0 scene keeps its names: camelCase there is an unknown parameter.
    let err = raylab::formats::mitsuba::to_ron(&old.replace("0.6.0", "3.0.0"), &[]).unwrap_err();
    assert!(err.2.contains("maxDepth"), "{err:?}");
}

/// Mitsuba's `ptracer` is raylab's `lighttracer` (its max_depth one more than raylab's), and
/// pbrt-v4's `lightpath` is too (its maxdepth the same as raylab's).
#[test]
fn light_tracers_of_both_formats_are_raylabs_lighttracer() {
    let xml = r#"<scene version="3.0.0">
        <integrator type="ptracer"><integer name="max_depth" value="4"/><integer name="samples_per_pass" value="8"/></integrator>
        <sensor type="perspective"><float name="fov" value="40"/></sensor>
        <shape type="sphere"/>
    </scene>"#;
    let render = raylab::formats::mitsuba::to_ron(xml, &[])
        .unwrap()
        .scene
        .render;
    assert_eq!(render.integrator, "lighttracer");
    assert_eq!(render.params.get("max-depth"), Some(&3.0));
    assert_eq!(render.params.get("rr-depth"), Some(&5.0));
    let dir = tempfile::tempdir().unwrap();
    let pbrt = dir.path().join("light.pbrt");
    std::fs::write(
        &pbrt,
        "Integrator \"lightpath\" \"integer maxdepth\" 3\nCamera \"perspective\"\nWorldBegin\nShape \"sphere\"\n",
    )
    .unwrap();
    let loaded = load_scene(&pbrt).unwrap();
    assert_eq!(loaded.render.integrator, "lighttracer");
    assert_eq!(loaded.render.params.get("max-depth"), Some(&3.0));
}

/// Hostile XML a probe sent: each is refused with its place, exit 2, in the time it takes to
/// read it; none overflows the stack, allocates without end or takes quadratic time.
#[test]
fn hostile_xml_is_refused_before_it_costs_anything() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sensor = r#"<sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>"#;
    let refused = |name: &str, text: String, expect: &str| {
        std::fs::write(d.join(name), text).unwrap();
        for command in ["validate", "render"] {
            let o = raylab_in(d, &[command, name]);
            let e = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{name} {command}: {e}");
            assert!(e.contains(expect) && !e.contains("panicked"), "{name}: {e}");
        }
    };
    // 10,000 BSDFs each inside the next.
    let mut deep = String::from(r#"<bsdf type="diffuse"/>"#);
    for _ in 0..10_000 {
        deep = format!(r#"<bsdf type="twosided">{deep}</bsdf>"#);
    }
    refused(
        "deep.xml",
        format!(r#"<scene version="3.0.0">{sensor}<shape type="sphere">{deep}</shape></scene>"#),
        "deep.xml:1:",
    );
    // The probe's cycle: a two-sided BSDF holding a reference to itself.
    refused(
        "cycle.xml",
        format!(
            r#"<scene version="3.0.0">{sensor}<bsdf type="twosided" id="a"><ref id="a"/></bsdf><shape type="sphere"><ref id="a"/></shape></scene>"#
        ),
        "cycle.xml:1:",
    );
    // Forty BSDFs, each blending the one before with itself: converted once each, not
    // 2^40 times (it loads).
    let mut chain = String::from(r#"<bsdf type="diffuse" id="b0"/>"#);
    for k in 1..=40 {
        chain += &format!(
            r#"<bsdf type="blendbsdf" id="b{k}"><float name="weight" value="0.5"/><ref id="b{}"/><ref id="b{}"/></bsdf>"#,
            k - 1,
            k - 1
        );
    }
    std::fs::write(
        d.join("chain.xml"),
        format!(r#"<scene version="3.0.0">{sensor}{chain}<shape type="sphere"><ref id="b40"/></shape></scene>"#),
    )
    .unwrap();
    let o = raylab_in(d, &["validate", "chain.xml"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // 100,000 attributes on one element.
    let attributes: String = (0..100_000).map(|i| format!(" a{i}=\"1\"")).collect();
    refused(
        "attributes.xml",
        format!(r#"<scene version="3.0.0">{sensor}<shape type="sphere"{attributes}/></scene>"#),
        "attributes, more than the 256 raylab reads",
    );
    // Sixteen files, each including the next ten times: 10^15 includes asked for.
    for k in 0..16 {
        let body: String = (0..10)
            .map(|_| format!(r#"<include filename="f{}.xml"/>"#, k + 1))
            .collect();
        let body = if k == 15 { String::new() } else { body };
        std::fs::write(
            d.join(format!("f{k}.xml")),
            format!(r#"<scene version="3.0.0">{body}</scene>"#),
        )
        .unwrap();
    }
    refused(
        "fanout.xml",
        format!(r#"<scene version="3.0.0">{sensor}<include filename="f0.xml"/></scene>"#),
        "more than 10000 includes",
    );
}

/// An `<include>` of something that is not a regular file (a FIFO) says so, at its place:
/// not "no such file", and without blocking on the pipe.
#[test]
fn an_include_of_a_fifo_says_what_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let made = std::process::Command::new("mkfifo")
        .arg(d.join("pipe.xml"))
        .status()
        .unwrap();
    assert!(made.success());
    std::fs::write(
        d.join("s.xml"),
        r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/></sensor>
<include filename="pipe.xml"/></scene>"#,
    )
    .unwrap();
    let o = raylab_in(d, &["validate", "s.xml"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("s.xml:2:1:") && e.contains("not a regular file"),
        "{e}"
    );
}

/// `-a DIR` searches a folder for the files a Mitsuba scene names (as `mitsuba -a`, which
/// Mitsuba's own test scenes need for mitsuba-data's `common/`), and lets the scene read
/// them; without it the file is not found, and a RON scene refuses the flag.
#[test]
fn search_folders_find_what_a_mitsuba_scene_names() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("scene")).unwrap();
    std::fs::create_dir_all(d.join("common/meshes")).unwrap();
    std::fs::write(
        d.join("common/meshes/tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        d.join("scene/s.xml"),
        r#"<scene version="3.0.0">
            <sensor type="perspective"><float name="fov" value="40"/></sensor>
            <shape type="obj"><string name="filename" value="meshes/tri.obj"/></shape>
        </scene>"#,
    )
    .unwrap();
    let without = raylab_in(d, &["validate", "scene/s.xml"]);
    assert_eq!(without.status.code(), Some(2));
    let with = raylab_in(d, &["validate", "scene/s.xml", "-a", "common"]);
    let e = String::from_utf8_lossy(&with.stderr);
    assert!(with.status.success(), "{e}");
    std::fs::write(d.join("scene/s.ron"), "(camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), fov: 40), entities: [(shape: Sphere(radius: 1), material: \"m\")], materials: {\"m\": Lambert(albedo: 0.5)})").unwrap();
    let ron = raylab_in(d, &["validate", "scene/s.ron", "-a", "common"]);
    let e = String::from_utf8_lossy(&ron.stderr);
    assert!(ron.status.code() == Some(2) && e.contains("-a DIR"), "{e}");
}
