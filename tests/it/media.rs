//! Participating media through the command line: every integrator that renders media is
//! deterministic on the shipped media scenes at any thread count, across a checkpoint and
//! resume and across shards merged; the others refuse them; `import` carries Mitsuba's media
//! over into RON that renders the same image.

use crate::common::{raylab, s, stderr};

const MEDIA_SCENES: [&str; 2] = ["scenes/fog_room.ron", "scenes/volumetric_caustic.ron"];

/// The registry's integrators that render media: none can be forgotten.
fn media_integrators() -> Vec<&'static str> {
    let names: Vec<&str> = raylab_integrators::REGISTRY
        .iter()
        .filter(|e| e.media.any())
        .map(|e| e.name)
        .collect();
    assert!(!names.is_empty());
    names
}

/// Renders `scene` small with `integrator` at 8 samples per pixel and `extra` options.
fn render(scene: &str, integrator: &str, extra: &[&str], out: &std::path::Path) -> Vec<u8> {
    render_spp(scene, integrator, "40x30", "8", extra, out)
}

/// [`render`] at `size` and `spp` samples per pixel.
fn render_spp(
    scene: &str,
    integrator: &str,
    size: &str,
    spp: &str,
    extra: &[&str],
    out: &std::path::Path,
) -> Vec<u8> {
    let size = ["--size", size, "--spp", spp, "-q"];
    let args = [
        &["render", scene, "-i", integrator][..],
        &size,
        extra,
        &["-o", s(out)],
    ]
    .concat();
    let o = raylab(&args);
    assert!(o.status.success(), "{scene} {integrator}: {}", stderr(&o));
    std::fs::read(out).unwrap()
}

#[test]
fn media_renders_are_bit_identical_at_1_2_and_8_threads() {
    let dir = tempfile::tempdir().unwrap();
    for scene in MEDIA_SCENES {
        for integrator in media_integrators() {
            let images: Vec<Vec<u8>> = ["1", "2", "8"]
                .iter()
                .map(|t| {
                    let out = dir.path().join(format!("{integrator}-{t}.exr"));
                    render(scene, integrator, &["--threads", t], &out)
                })
                .collect();
            assert!(
                images[0] == images[1] && images[0] == images[2],
                "{scene} {integrator}: the thread count changed the image"
            );
        }
    }
}

#[test]
fn media_shards_merge_into_the_single_run_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    for integrator in media_integrators() {
        let single = dir.path().join(format!("{integrator}.exr"));
        // Three shards of whole blocks of 8 passes (48 rows: three bands of 16-row tiles for
        // an integrator that keeps state per pixel).
        let single = render_spp(MEDIA_SCENES[0], integrator, "40x48", "24", &[], &single);
        let parts: Vec<std::path::PathBuf> = (0..3)
            .map(|i| {
                let part = dir.path().join(format!("{integrator}-{i}.exr"));
                let shard = format!("{i}/3");
                render_spp(
                    MEDIA_SCENES[0],
                    integrator,
                    "40x48",
                    "24",
                    &["--shard", &shard],
                    &part,
                );
                part
            })
            .collect();
        let merged = dir.path().join(format!("{integrator}-merged.exr"));
        let mut args = vec!["merge", "-q", "-o", s(&merged)];
        args.extend(parts.iter().map(|p| s(p)));
        let o = raylab(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(
            std::fs::read(&merged).unwrap() == single,
            "{integrator}: shards merged differ from the single run"
        );
    }
}

#[test]
fn media_render_resumes_from_a_checkpoint_to_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let common = [
        "render",
        MEDIA_SCENES[0],
        "-i",
        "volpath",
        "--size",
        "64x48",
        "--spp",
        "40",
        "--seed",
        "3",
        "-q",
    ];
    let direct = d.join("direct.exr");
    let o = raylab(&[&common[..], &["-o", s(&direct)]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let (partial, ck) = (d.join("partial.exr"), d.join("render.ck"));
    let o = raylab(
        &[
            &common[..],
            &["--time", "0.02", "--checkpoint", s(&ck), "-o", s(&partial)],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(ck.exists(), "no checkpoint left by a stopped render");
    let resumed = d.join("resumed.exr");
    let o = raylab(
        &[
            &common[..],
            &["--checkpoint", s(&ck), "--resume", "-o", s(&resumed)],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        std::fs::read(&resumed).unwrap() == std::fs::read(&direct).unwrap(),
        "the resumed image differs from the direct one"
    );
}

#[test]
fn surface_integrators_refuse_media_and_debug_views_show_them() {
    let dir = tempfile::tempdir().unwrap();
    for entry in raylab_integrators::REGISTRY
        .iter()
        .filter(|e| !e.media.any())
    {
        let out = dir.path().join(format!("{}.exr", entry.name));
        let o = raylab(&[
            "render",
            MEDIA_SCENES[0],
            "-i",
            entry.name,
            "--size",
            "8x6",
            "--spp",
            "1",
            "-q",
            "-o",
            s(&out),
        ]);
        if entry.summary.starts_with("debug view") {
            assert!(o.status.success(), "{}: {}", entry.name, stderr(&o));
        } else {
            assert_eq!(o.status.code(), Some(2), "{}", entry.name);
            assert!(
                stderr(&o).contains("does not render (it would treat them as vacuum)"),
                "{}: {}",
                entry.name,
                stderr(&o)
            );
            assert!(!out.exists());
        }
    }
}
