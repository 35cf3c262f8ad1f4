//! `raylab render --watch` as a user runs it: saving the scene (or a mesh it names)
//! re-renders and rewrites the output, rebuilding only what the save changed (the `reload:`
//! line says what), into the image a fresh render of the saved scene gives; a broken save
//! reports file:line:column and keeps the last good image; fixing it resumes; Ctrl-C stops it
//! cleanly.

use crate::common;
use crate::common::s;

use common::{break_scene, eventually, raylab_in, save, scene_copy, Running, CORNELL_LIGHT};
use std::path::Path;
use std::time::{Duration, Instant};

/// `raylab render SCENE --watch` at 32x32, 8 spp, one thread.
fn watch(scene: &Path, out: &Path) -> Running {
    Running::start(
        &[
            "render",
            s(scene),
            "--watch",
            "--size",
            "32x32",
            "--spp",
            "8",
            "--threads",
            "1",
            "-o",
            s(out),
        ],
        // Beside the output: a test may delete the scene's folder.
        &out.with_extension("stderr"),
        false,
    )
}

fn done_count(stderr: &str) -> usize {
    stderr.lines().filter(|l| l.starts_with("done:")).count()
}

/// Mean of the PNG's 8-bit values.
fn brightness(png: &Path) -> f64 {
    let img = image::open(png).unwrap().to_rgb8();
    img.as_raw().iter().map(|&v| v as f64).sum::<f64>() / img.as_raw().len() as f64
}

#[test]
fn saving_the_scene_rerenders_and_ctrl_c_stops_cleanly() {
    let (dir, scene) = scene_copy("cornell_box.ron");
    let out = dir.path().join("out.png");
    let run = watch(&scene, &out);
    run.wait_stderr("the first image", |e| done_count(e) == 1);
    let before = brightness(&out);
    assert!(before > 20.0, "the box is lit: {before}");

    // A dimmer light: the image must darken.
    let text = std::fs::read_to_string(&scene).unwrap();
    assert!(text.contains(CORNELL_LIGHT));
    save(
        &scene,
        &text.replace(CORNELL_LIGHT, "radiance: (1.5, 1.5, 1.5)"),
    );
    run.wait_stderr("the second render", |e| done_count(e) >= 2);
    let after = brightness(&out);
    assert!(after < before * 0.5, "{after} vs {before}");
    let e = run.stderr();
    assert!(
        e.contains("reload: 1 entity changed (emitter), rebuilt the light table")
            && e.contains("first pass began"),
        "{e}"
    );

    let status = run.interrupt();
    assert_eq!(status.code(), Some(0), "Ctrl-C is a clean stop");
}

#[test]
fn a_broken_save_reports_line_and_column_and_keeps_the_last_image() {
    let (dir, scene) = scene_copy("cornell_box.ron");
    let out = dir.path().join("out.png");
    let run = watch(&scene, &out);
    run.wait_stderr("the first image", |e| done_count(e) == 1);
    let good = std::fs::read(&out).unwrap();

    // A syntax error on the `entities: [` line.
    let (text, at) = break_scene(&scene);
    run.wait_stderr("the load error", |e| e.contains(&at));
    assert!(run.stderr().contains("keeping"), "{}", run.stderr());

    // The last good image stays, byte for byte, while the file is broken.
    let end = Instant::now() + Duration::from_millis(800);
    while Instant::now() < end {
        assert_eq!(std::fs::read(&out).unwrap(), good, "the image changed");
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(done_count(&run.stderr()), 1);

    // Fixed (with a dimmer light): rendering resumes.
    save(
        &scene,
        &text.replace(CORNELL_LIGHT, "radiance: (1.5, 1.5, 1.5)"),
    );
    run.wait_stderr("the render after the fix", |e| done_count(e) >= 2);
    assert!(eventually(|| std::fs::read(&out).unwrap() != good));
    // The broken save touched nothing: the fix is an edit of the world before it.
    let e = run.stderr();
    assert!(e.contains("reload: 1 entity changed (emitter)"), "{e}");
    assert_eq!(run.interrupt().code(), Some(0));
}

#[test]
fn saving_a_mesh_the_scene_names_rerenders() {
    let (dir, scene) = scene_copy("mesh_files.ron");
    let out = dir.path().join("out.png");
    let run = watch(&scene, &out);
    run.wait_stderr("the first image", |e| done_count(e) == 1);
    let first = std::fs::read(&out).unwrap();

    // Grow the pyramid from the OBJ file.
    let obj = dir.path().join("assets/pyramid.obj");
    let text = std::fs::read_to_string(&obj).unwrap();
    let grown: String = text
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(v) => {
                let c: Vec<f32> = v.split_whitespace().map(|x| x.parse().unwrap()).collect();
                format!("v {} {} {}\n", c[0] * 2.0, c[1] * 2.0, c[2] * 2.0)
            }
            None => format!("{l}\n"),
        })
        .collect();
    assert_ne!(grown, text);
    std::fs::write(&obj, grown).unwrap();
    run.wait_stderr("the render after the mesh changed", |e| done_count(e) >= 2);
    assert_ne!(std::fs::read(&out).unwrap(), first);
    let e = run.stderr();
    assert!(e.contains("reload: 1 entity changed (shape)"), "{e}");
    assert_eq!(run.interrupt().code(), Some(0));
}

#[test]
fn an_edited_session_writes_the_image_a_fresh_render_of_the_saved_scene_writes() {
    let (dir, scene) = scene_copy("cornell_box.ron");
    let out = dir.path().join("out.exr");
    let run = watch(&scene, &out);
    run.wait_stderr("the first image", |e| done_count(e) == 1);

    // Move the small box, change the light and the red wall's colour, add a sphere.
    let text = std::fs::read_to_string(&scene).unwrap();
    let edited = text
        .replace("(0.335, -0.7, 0.38)", "(0.3, -0.7, 0.3)")
        .replace(CORNELL_LIGHT, "radiance: (12, 12, 12)")
        .replace("(0.570068, 0.0430135, 0.0443706)", "(0.2, 0.2, 0.6)")
        .replace(
            "    entities: [\n",
            "    entities: [\n        (name: \"new\", shape: Sphere(center: (0, 0.5, 0), radius: 0.1), material: \"white\"),\n",
        );
    for part in [
        "(0.3, -0.7, 0.3)",
        "(12, 12, 12)",
        "(0.2, 0.2, 0.6)",
        "\"new\"",
    ] {
        assert!(edited.contains(part), "the edit must apply: {part}");
    }
    save(&scene, &edited);
    run.wait_stderr("the render after the edit", |e| done_count(e) >= 2);
    let e = run.stderr();
    assert!(
        e.contains("1 entity added") && e.contains("1 material changed"),
        "{e}"
    );
    assert_eq!(run.interrupt().code(), Some(0));

    let fresh = dir.path().join("fresh.exr");
    let o = raylab_in(
        dir.path(),
        &[
            "render",
            s(&scene),
            "--size",
            "32x32",
            "--spp",
            "8",
            "--threads",
            "1",
            "-q",
            "-o",
            s(&fresh),
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        std::fs::read(&out).unwrap() == std::fs::read(&fresh).unwrap(),
        "the edited session's image differs from a fresh render's"
    );
}

#[test]
fn watch_refuses_options_it_cannot_honour() {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", "scenes/cornell_box.ron", "--watch", "--time", "1"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--watch renders until Ctrl-C"));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", "scenes/cornell_box.ron", "--watch", "-i", "nope"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown integrator `nope`"));
}

/// A scene watched through a symbolic link in another folder: saving the file the link
/// points to renders again.
#[cfg(unix)]
#[test]
fn edits_through_a_symlinked_scene_rerender() {
    let (dir, scene) = scene_copy("cornell_box.ron");
    let links = tempfile::tempdir().unwrap();
    let link = links.path().join("linked.ron");
    std::os::unix::fs::symlink(&scene, &link).unwrap();
    let out = dir.path().join("out.png");
    let run = watch(&link, &out);
    run.wait_stderr("the first image", |e| done_count(e) == 1);
    let text = std::fs::read_to_string(&scene).unwrap();
    save(
        &scene,
        &text.replace(CORNELL_LIGHT, "radiance: (1.5, 1.5, 1.5)"),
    );
    run.wait_stderr("the render after the edit", |e| done_count(e) >= 2);
    assert_eq!(run.interrupt().code(), Some(0));
}

/// The scene's folder deleted and made again (a checkout, a sync tool): saves into the new
/// folder still render.
#[test]
fn saves_after_the_scenes_folder_is_made_again_rerender() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("scene");
    std::fs::create_dir(&folder).unwrap();
    let scene = folder.join("box.ron");
    let text = std::fs::read_to_string(common::repo_file("scenes/cornell_box.ron")).unwrap();
    std::fs::write(&scene, &text).unwrap();
    let out = dir.path().join("out.png");
    let run = watch(&scene, &out);
    run.wait_stderr("the first image", |e| done_count(e) == 1);
    std::fs::remove_dir_all(&folder).unwrap();
    run.wait_stderr("the load error", |e| e.contains("cannot read"));
    std::fs::create_dir(&folder).unwrap();
    std::thread::sleep(Duration::from_millis(300));
    save(
        &scene,
        &text.replace(CORNELL_LIGHT, "radiance: (1.5, 1.5, 1.5)"),
    );
    run.wait_stderr("the render in the new folder", |e| done_count(e) >= 2);
    save(&scene, &text);
    run.wait_stderr("a second save there", |e| done_count(e) >= 3);
    assert_eq!(run.interrupt().code(), Some(0));
}

/// Saving a file the scene `<include>`s re-renders, as saving the scene does: the watch
/// covers every file a load read, not only those the RON names.
#[test]
fn saving_an_included_file_rerenders() {
    let dir = tempfile::tempdir().unwrap();
    let text =
        std::fs::read_to_string(common::repo_file("scenes/mitsuba/cornell_box.xml")).unwrap();
    let (start, end) = (
        text.find("<shape type=\"rectangle\" id=\"light\">")
            .unwrap(),
        text.find("<shape type=\"rectangle\" id=\"floor\">")
            .unwrap(),
    );
    let light = |radiance: &str| {
        format!(
            "<scene version=\"3.0.0\">\n{}\n</scene>\n",
            text[start..end].replace("18.387, 13.9873, 6.75357", radiance)
        )
    };
    let part = dir.path().join("light.xml");
    std::fs::write(&part, light("18.387, 13.9873, 6.75357")).unwrap();
    let scene = dir.path().join("box.xml");
    std::fs::write(
        &scene,
        format!(
            "{}<include filename=\"light.xml\"/>\n{}",
            &text[..start],
            &text[end..]
        ),
    )
    .unwrap();
    let out = dir.path().join("out.png");
    let run = watch(&scene, &out);
    run.wait_stderr("the first image", |e| done_count(e) == 1);
    let before = brightness(&out);
    let tmp = dir.path().join("light.xml.tmp~");
    std::fs::write(&tmp, light("1.5, 1.5, 1.5")).unwrap();
    std::fs::rename(&tmp, &part).unwrap();
    run.wait_stderr("the render after the include's save", |e| {
        done_count(e) >= 2
    });
    let after = brightness(&out);
    assert!(after < before * 0.5, "{after} vs {before}");
    assert_eq!(run.interrupt().code(), Some(0));
}

/// A save that makes the scene read the output image (as a texture) stops the writes, and
/// a save that stops reading it starts them again: the rule holds for the scene as it is now.
#[test]
fn the_output_is_not_written_while_the_scene_reads_it() {
    let (dir, scene) = scene_copy("cornell_box.ron");
    let out = dir.path().join("out.png");
    let run = watch(&scene, &out);
    run.wait_stderr("the first image", |e| done_count(e) == 1);
    let text = std::fs::read_to_string(&scene).unwrap();
    let white = "\"white\": Lambert(albedo: (0.885809, 0.698859, 0.666422))";
    assert!(text.contains(white));
    save(
        &scene,
        &text.replace(
            white,
            "\"white\": Lambert(albedo: Image(path: \"out.png\"))",
        ),
    );
    run.wait_stderr("the refusal", |e| {
        e.contains("not writing it until the scene stops reading it")
    });
    run.wait_stderr("the render that did not write", |e| {
        e.contains("did not write")
    });
    let written = std::fs::metadata(&out).unwrap().modified().unwrap();
    save(&scene, &text);
    run.wait_stderr("a render that writes again", |e| {
        e.lines()
            .filter(|l| l.starts_with("done:") && l.contains("| wrote "))
            .count()
            >= 2
    });
    assert!(std::fs::metadata(&out).unwrap().modified().unwrap() > written);
    assert_eq!(run.interrupt().code(), Some(0));
}
