//! Spectral rendering from the command line: spectra given by wavelength in scene files
//! (RON and Mitsuba's), and what RGB mode makes of them.

use crate::common::{raylab, s, save, stderr};
use raylab::formats::texture_desc::ColorDesc;

const ALBEDO: &str = "[(400, 0.1), (500, 0.3), (600, 0.9), (700, 0.7)]";
const EMISSION: &str = "[(400, 0), (500, 8), (600, 15.6), (700, 18.4)]";

/// A floor under an area light, the floor's albedo and the light's emission as given.
fn scene(albedo: &str, emitter: &str) -> String {
    format!(
        r#"(
    camera: LookAt(eye: (0, 3, 3), look_at: (0, 0, 0), up: (0, 1, 0), fov: 50, resolution: (32, 24)),
    render: (integrator: "path", spp: 8),
    materials: {{ "floor": Lambert(albedo: {albedo}), "lamp": Lambert(albedo: 0.5) }},
    entities: [
        (shape: Quad(vertices: [(-2, 0, 2), (2, 0, 2), (2, 0, -2), (-2, 0, -2)]), material: "floor"),
        (shape: Quad(vertices: [(-0.5, 2, -0.5), (0.5, 2, -0.5), (0.5, 2, 0.5), (-0.5, 2, 0.5)]),
         material: "lamp", emitter: {emitter}),
    ],
)"#
    )
}

fn pairs(text: &str) -> Vec<(f64, f64)> {
    ron::from_str(text).unwrap()
}

fn mean(path: &std::path::Path) -> [f64; 3] {
    let img = image::open(path).unwrap().into_rgb32f();
    let mut m = [0.0f64; 3];
    for p in img.pixels() {
        for c in 0..3 {
            m[c] += p[c] as f64;
        }
    }
    m.map(|x| x / (img.width() * img.height()) as f64)
}

#[test]
fn spectra_are_their_colours_in_rgb_mode_and_themselves_in_spectral_mode() {
    let dir = tempfile::tempdir().unwrap();
    let spectral = dir.path().join("spectral.ron");
    save(
        &spectral,
        &scene(
            &format!("Spectrum({ALBEDO})"),
            &format!("Area(radiance: (1, 1, 1), spectrum: {EMISSION})"),
        ),
    );
    // The same scene with the colours the spectra are in RGB (as a reflectance; as an
    // emission, which D65 does not weigh).
    let albedo = ColorDesc::spectrum_colour(&pairs(ALBEDO));
    let emission: Vec<f32> = raylab::formats::spectra::to_srgb(
        &pairs(EMISSION),
        raylab::formats::spectra::Use::Emission,
    )
    .unwrap()
    .iter()
    .map(|&c| c as f32)
    .collect();
    let rgb = dir.path().join("rgb.ron");
    save(
        &rgb,
        &scene(
            &format!("({:?}, {:?}, {:?})", albedo[0], albedo[1], albedo[2]),
            &format!(
                "Area(radiance: ({:?}, {:?}, {:?}))",
                emission[0], emission[1], emission[2]
            ),
        ),
    );
    let render = |scene: &std::path::Path, out: &str, extra: &[&str]| {
        let out = dir.path().join(out);
        let o = raylab(&[&["render", s(scene), "-q", "-o", s(&out)], extra].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        out
    };
    // RGB mode: exactly the colours.
    let a = render(&spectral, "a.exr", &[]);
    let b = render(&rgb, "b.exr", &[]);
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    // Spectral mode: the spectra, whose product is not the product of their colours; the
    // image's colour is near the RGB one but not it (red and green: the light has almost no
    // blue).
    let c = render(&spectral, "c.exr", &["--spectral", "--spp", "256"]);
    let (rgb_mean, spectral_mean) = (mean(&a), mean(&c));
    for k in 0..2 {
        let ratio = spectral_mean[k] / rgb_mean[k];
        assert!(
            (0.7..1.3).contains(&ratio),
            "channel {k}: {spectral_mean:?} vs {rgb_mean:?}"
        );
    }
    assert_ne!(std::fs::read(&a).unwrap(), std::fs::read(&c).unwrap());
    // A spectrum must be a spectrum.
    save(
        &spectral,
        &scene("Spectrum([(400, 0.1)])", "Area(radiance: (1, 1, 1))"),
    );
    let o = raylab(&[
        "render",
        s(&spectral),
        "-q",
        "-o",
        s(&dir.path().join("x.exr")),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("at least two"), "{}", stderr(&o));
    // A reflectance's spectrum lies in [0, 1], an emitter's is not negative and takes no
    // texture; a narrow band (a sodium line, outside sRGB) is light all the same.
    for (albedo, emitter, error) in [
        (
            "Spectrum([(400, 0.5), (700, 1.5)])",
            "Area(radiance: (1, 1, 1))",
            "[0, 1]",
        ),
        (
            "0.5",
            "Area(radiance: (1, 1, 1), spectrum: [(400, 1), (700, -1)])",
            "negative",
        ),
        (
            "0.5",
            "Area(radiance: (1, 1, 1), texture: Checkerboard(color0: (1, 0, 0), color1: (0, 1, 0)), spectrum: [(400, 1), (700, 1)])",
            "no texture",
        ),
    ] {
        save(&spectral, &scene(albedo, emitter));
        let o = raylab(&[
            "render",
            s(&spectral),
            "-q",
            "-o",
            s(&dir.path().join("x.exr")),
        ]);
        assert_eq!(o.status.code(), Some(2), "{emitter}");
        assert!(stderr(&o).contains(error), "{}", stderr(&o));
    }
    save(
        &spectral,
        &scene(
            "0.5",
            "Area(radiance: (1, 1, 1), spectrum: [(585, 0), (589, 100), (593, 0)])",
        ),
    );
    for mode in ["--rgb", "--spectral"] {
        let out = dir.path().join("sodium.exr");
        let o = raylab(&["render", s(&spectral), mode, "-q", "-o", s(&out)]);
        assert!(o.status.success(), "{mode}: {}", stderr(&o));
        assert!(
            mean(&out)[0] > 0.0,
            "{mode}: the sodium lamp lights nothing"
        );
    }
    // --spectral and --rgb contradict each other.
    let o = raylab(&["render", s(&rgb), "--spectral", "--rgb", "-o", "x.exr"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn mitsuba_spectra_are_imported_as_spectra() {
    let dir = tempfile::tempdir().unwrap();
    let xml = dir.path().join("scene.xml");
    save(
        &xml,
        r#"<scene version="3.0.0">
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
    <shape type="rectangle">
        <bsdf type="diffuse"><spectrum name="reflectance" value="400:0.78, 700:0.78"/></bsdf>
        <emitter type="area"><spectrum name="radiance" value="400:0, 500:8, 600:15.6, 700:18.4"/></emitter>
    </shape>
</scene>"#,
    );
    let ron = dir.path().join("scene.ron");
    let o = raylab(&["import", s(&xml), "-o", s(&ron)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&ron).unwrap();
    assert!(
        text.contains("Spectrum([(400.0, 0.78), (700.0, 0.78)])"),
        "{text}"
    );
    assert!(
        text.contains("spectrum: [(400.0, 0.0), (500.0, 8.0)"),
        "{text}"
    );
    // And the written scene renders in both modes.
    for mode in ["--rgb", "--spectral"] {
        let out = dir.path().join(format!("{mode}.exr"));
        let o = raylab(&["render", s(&ron), mode, "--spp", "2", "-q", "-o", s(&out)]);
        assert!(o.status.success(), "{mode}: {}", stderr(&o));
    }
}

/// The prism of `scenes/prism.ron` (SF11, apex 60 degrees) bends the beam at each
/// wavelength as Snell's law with Schott's Sellmeier formula says: the beam's central ray,
/// traced through the scene at one wavelength, leaves the prism deviated by
/// `D = i + asin(n sin(A - asin(sin i / n))) - A`; and a path through the glass goes on with
/// its hero wavelength alone.
#[test]
fn the_prism_deviates_each_wavelength_by_snells_law() {
    use glam::{Vec2, Vec3A};
    use raylab_integrators::bsdf::TransportMode;
    use raylab_integrators::integrator::ShadingPoint;
    use raylab_integrators::spectrum::curve::Curve;
    use raylab_integrators::spectrum::Wavelengths;
    use raylab_integrators::{Ray, Scene};
    let loaded = raylab::scene::load_scene(std::path::Path::new("scenes/prism.ron")).unwrap();
    let built = raylab::scene::RenderScene::build(&loaded);
    let scene: &dyn Scene = &built;
    let sf11 = raylab_integrators::bsdf::ior::glass("SF11").unwrap();
    let Curve::Sellmeier { .. } = sf11 else {
        panic!("SF11 by Sellmeier's formula")
    };
    // The beam: from the lamp, along +x, at the prism's entry face (see the script).
    let lights = scene.lights();
    let lamp = (0..lights.len() as u32)
        .find_map(|i| match *lights.get(i) {
            raylab_integrators::Light::Spot(ref s) => Some(s.position),
            _ => None,
        })
        .expect("a spot");
    let incidence = (sf11.at(550.0) * 0.5f32).asin();
    let apex = 60f32.to_radians();
    let mut deviations = Vec::new();
    for nm in [420.0f32, 480.0, 550.0, 620.0, 680.0] {
        let mut lambda = Wavelengths::Sampled {
            nm: glam::Vec4::splat(nm),
            pdf: glam::Vec4::splat(1.0),
        };
        let mut ray = Ray::new(lamp, Vec3A::X);
        // Into the glass and out: two refractions (the transmitted lobe: u_lobe near 1).
        for _ in 0..2 {
            let hit = scene.intersect(&ray).expect("the beam meets the prism");
            let sp = ShadingPoint::new(&hit, ray.dir, scene, &mut lambda);
            let s = sp
                .sample(0.999_999, Vec2::ZERO, TransportMode::Radiance)
                .expect("a refraction");
            ray = sp.hit.spawn_ray(s.wi);
        }
        assert!(
            lambda.secondary_terminated(),
            "{nm} nm: the secondaries go on"
        );
        // The deviation in the horizontal plane, from +x.
        let measured = (-ray.dir.z).atan2(ray.dir.x);
        let n = sf11.at(nm);
        let inner = apex - (incidence.sin() / n).asin();
        let expected = incidence + (n * inner.sin()).asin() - apex;
        assert!(
            (measured - expected).abs() < 2e-4,
            "{nm} nm: deviation {} degrees, Snell's law {}",
            measured.to_degrees(),
            expected.to_degrees()
        );
        deviations.push(measured);
    }
    // Violet bends most.
    assert!(deviations.windows(2).all(|w| w[0] > w[1]), "{deviations:?}");
}

/// A smooth gold floor seen straight down under a white ceiling of radiance 1: each
/// wavelength is reflected by the Fresnel factor of gold's measured `eta` and `k` there
/// (pbrt-v4's and Mitsuba 3's data), so the image is `integral F(l) D65(l) xyz-bar(l)` of
/// the measured spectra in spectral mode, and the Fresnel factor of the RGB constants in RGB
/// mode.
#[test]
fn a_named_metal_reflects_by_its_measured_spectra() {
    use glam::Vec3A;
    use raylab_integrators::bsdf::fresnel::fresnel_conductor;
    use raylab_integrators::spectrum::{cie, named, rgb_of, xyz_to_srgb};
    use raylab_integrators::Spectrum;
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("gold.ron");
    save(
        &scene,
        r#"(
    camera: LookAt(eye: (0, 1, 0), look_at: (0, 0, 0), up: (0, 0, 1), fov: 8, resolution: (16, 16)),
    render: (integrator: "path", spp: 64),
    materials: { "gold": Conductor(metal: "Au"), "ceiling": Lambert(albedo: 0) },
    entities: [
        (shape: Quad(vertices: [(-5, 0, -5), (-5, 0, 5), (5, 0, 5), (5, 0, -5)]), material: "gold"),
        (shape: Quad(vertices: [(-5, 2, -5), (5, 2, -5), (5, 2, 5), (-5, 2, 5)]),
         material: "ceiling", emitter: Area(radiance: (1, 1, 1))),
    ],
)"#,
    );
    // The closed forms, at normal incidence.
    let (eta, k) = named::metal("Au").unwrap();
    let d65 = named::pbrt("stdillum-D65").unwrap();
    let mut xyz = Vec3A::ZERO;
    for nm in 360..=830 {
        let nm = nm as f32;
        let f = fresnel_conductor(1.0, Spectrum::splat(eta.at(nm)), Spectrum::splat(k.at(nm))).x;
        xyz += Vec3A::from(cie::xyz_bar(nm)) * (f * d65.at(nm));
    }
    let spectral = xyz_to_srgb(xyz / cie::Y_INTEGRAL as f32);
    let gold = raylab_integrators::bsdf::ior::metal("Au").unwrap().unwrap();
    let rgb = rgb_of(fresnel_conductor(1.0, gold.eta, gold.k));
    for (mode, expected, spp) in [("--rgb", rgb, "4"), ("--spectral", spectral, "64")] {
        let out = dir.path().join("gold.exr");
        let o = raylab(&["render", s(&scene), mode, "--spp", spp, "-q", "-o", s(&out)]);
        assert!(o.status.success(), "{mode}: {}", stderr(&o));
        let m = mean(&out);
        for c in 0..3 {
            let e = expected[c] as f64;
            assert!((m[c] - e).abs() < 0.015 * e, "{mode}: {m:?} vs {expected}");
        }
    }
    // The measured spectra are not the RGB constants: the colours differ by 5% in red.
    assert!((spectral.x - rgb.x).abs() > 0.03, "{spectral} vs {rgb}");
}

/// `--xyz` writes the image as CIE XYZ: channels X, Y, Z, Y the luminance of the sRGB image
/// of the same render; only as EXR.
#[test]
fn xyz_output_is_the_srgb_image_in_xyz() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("floor.ron");
    save(
        &scene,
        &self::scene(&format!("Spectrum({ALBEDO})"), "Area(radiance: (1, 1, 1))"),
    );
    let (rgb, xyz) = (dir.path().join("rgb.exr"), dir.path().join("xyz.exr"));
    for (out, extra) in [(&rgb, None), (&xyz, Some("--xyz"))] {
        let mut args = vec!["render", s(&scene), "--spectral", "-q", "-o", s(out)];
        args.extend(extra);
        let o = raylab(&args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let image = exr::prelude::read_first_flat_layer_from_file(&xyz).unwrap();
    let channel = |name: &str| -> Vec<f32> {
        let c = image
            .layer_data
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .unwrap_or_else(|| panic!("no channel {name}"));
        c.sample_data.values_as_f32().collect()
    };
    let y = channel("Y");
    assert_eq!((channel("X").len(), channel("Z").len()), (y.len(), y.len()));
    let srgb = image::open(&rgb).unwrap().into_rgb32f();
    let mut lit = 0;
    for (p, y) in srgb.pixels().zip(&y) {
        let lum = 0.212_671 * p[0] + 0.715_160 * p[1] + 0.072_169 * p[2];
        assert!((lum - y).abs() <= 1e-5 * lum.abs().max(1.0), "{lum} vs {y}");
        lit += (lum > 0.0) as u32;
    }
    assert!(lit > 0);
    // Only as EXR.
    let o = raylab(&[
        "render",
        s(&scene),
        "--xyz",
        "-o",
        s(&dir.path().join("x.png")),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("EXR"), "{}", stderr(&o));
}

/// Point, spot and directional emitters take a spectrum as area emitters do: a grey scale
/// times the spectrum, its colour in RGB mode; a coloured scale is refused.
#[test]
fn point_spot_and_directional_emitters_take_spectra() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lamps.ron");
    let scene = |emitter: &str| {
        format!(
            r#"(
    camera: LookAt(eye: (0, 3, 3), look_at: (0, 0, 0), up: (0, 1, 0), fov: 50, resolution: (24, 18)),
    render: (integrator: "path", spp: 4),
    materials: {{ "floor": Lambert(albedo: 0.5) }},
    entities: [
        (shape: Quad(vertices: [(-2, 0, 2), (2, 0, 2), (2, 0, -2), (-2, 0, -2)]), material: "floor"),
        (transform: (translate: (0, 1, 0)), emitter: {emitter}),
    ],
)"#
        )
    };
    for emitter in [
        format!("Point(intensity: (2, 2, 2), spectrum: {EMISSION})"),
        format!("Spot(intensity: (2, 2, 2), look_at: (0, 0, 0), cutoff_angle: 60, spectrum: {EMISSION})"),
        format!("Directional(direction: (0, -1, 0), irradiance: (2, 2, 2), spectrum: {EMISSION})"),
    ] {
        save(&path, &scene(&emitter));
        let mut means = Vec::new();
        for mode in ["--rgb", "--spectral"] {
            let out = dir.path().join("lamp.exr");
            let o = raylab(&["render", s(&path), mode, "-q", "-o", s(&out)]);
            assert!(o.status.success(), "{emitter} {mode}: {}", stderr(&o));
            means.push(mean(&out));
        }
        // The same light in both modes: red and green (the spectrum has little blue).
        for k in 0..2 {
            let ratio = means[1][k] / means[0][k];
            assert!((0.7..1.3).contains(&ratio), "{emitter}: {means:?}");
        }
    }
    save(
        &path,
        &scene(&format!(
            "Point(intensity: (1, 2, 1), spectrum: {EMISSION})"
        )),
    );
    let o = raylab(&["render", s(&path), "-q", "-o", s(&dir.path().join("x.exr"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("grey intensity"), "{}", stderr(&o));
}

/// A principled material's base colour given by wavelength is its colour in RGB mode (the
/// same bytes) and the spectrum itself in spectral mode (not the colour's upsampling).
#[test]
fn a_principled_base_colour_takes_a_spectrum() {
    let dir = tempfile::tempdir().unwrap();
    let colour = ColorDesc::spectrum_colour(&pairs(ALBEDO));
    let scene = |base: &str| {
        self::scene("0.5", "Area(radiance: (1, 1, 1))").replace(
            "\"floor\": Lambert(albedo: 0.5)",
            &format!("\"floor\": Principled(base_color: {base}, roughness: 0.6)"),
        )
    };
    let (by_spectrum, by_colour) = (dir.path().join("s.ron"), dir.path().join("c.ron"));
    save(&by_spectrum, &scene(&format!("Spectrum({ALBEDO})")));
    save(
        &by_colour,
        &scene(&format!(
            "({:?}, {:?}, {:?})",
            colour[0], colour[1], colour[2]
        )),
    );
    let render = |scene: &std::path::Path, mode: &str| {
        let stem = scene.file_stem().unwrap().to_string_lossy();
        let out = dir.path().join(format!("{stem}{mode}.exr"));
        let o = raylab(&["render", s(scene), mode, "--spp", "16", "-q", "-o", s(&out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(&out).unwrap()
    };
    assert_eq!(render(&by_spectrum, "--rgb"), render(&by_colour, "--rgb"));
    assert_ne!(
        render(&by_spectrum, "--spectral"),
        render(&by_colour, "--spectral")
    );
}

/// Mitsuba's `<spectrum filename="...">` reads an `.spd` file beside the scene (a pair per
/// line, `#` comments) as a spectrum; a bad line or a missing file is an error at the
/// `<spectrum>`'s place.
#[test]
fn mitsuba_spectra_from_files_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let xml = dir.path().join("scene.xml");
    let scene = |file: &str| {
        format!(
            r#"<scene version="3.0.0">
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
    <shape type="rectangle">
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
        <emitter type="area"><spectrum name="radiance" filename="{file}"/></emitter>
    </shape>
</scene>"#
        )
    };
    save(
        &dir.path().join("lamp.spd"),
        "# a lamp\n400 0\n500 8  # rising\n\n600 15.6\n700 18.4\n",
    );
    save(&xml, &scene("lamp.spd"));
    let ron = dir.path().join("scene.ron");
    let o = raylab(&["import", s(&xml), "-o", s(&ron)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&ron).unwrap();
    assert!(
        text.contains("spectrum: [(400.0, 0.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4)]"),
        "{text}"
    );
    save(&dir.path().join("bad.spd"), "400 0\n500 eight\n");
    for (file, error) in [("bad.spd", "line 2"), ("missing.spd", "missing.spd")] {
        save(&xml, &scene(file));
        let o = raylab(&["import", s(&xml), "-o", s(&ron)]);
        assert_eq!(o.status.code(), Some(2), "{file}");
        assert!(stderr(&o).contains(error), "{file}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("scene.xml:5:"),
            "{file}: {}",
            stderr(&o)
        );
    }
}
