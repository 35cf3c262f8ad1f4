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
