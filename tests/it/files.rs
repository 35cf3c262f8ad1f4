//! What raylab does to the files around a render: no output may destroy an input or another
//! output (whatever path names it), a replaced file keeps what it was (permissions, the link
//! that names it) or is refused, and SIGTERM or SIGHUP save the samples like Ctrl-C.

use crate::common::stderr;
use crate::common::{raylab_in, repo_file, Running};
use std::path::Path;
use std::process::Output;

/// Expects exit 2 with a message containing every one of `words`.
fn refused(o: &Output, words: &[&str]) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    for w in words {
        assert!(e.contains(w), "`{w}` not in: {e}");
    }
}

/// A folder with the Cornell box as `s.ron` and the mesh scene with its assets.
fn workspace() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(repo_file("scenes/cornell_box.ron"), d.join("s.ron")).unwrap();
    std::fs::create_dir(d.join("assets")).unwrap();
    for f in ["assets/pyramid.obj", "assets/panel.gltf", "mesh_files.ron"] {
        std::fs::copy(repo_file(&format!("scenes/{f}")), d.join(f)).unwrap();
    }
    dir
}

const QUICK: [&str; 5] = ["--spp", "1", "--size", "16x16", "-q"];

/// `raylab compare s.ron -i path` at 1 spp, 16x16, against `reference`, into `out`.
fn compare(dir: &Path, reference: &str, out: &str) -> Output {
    raylab_in(
        dir,
        &[
            "compare",
            "s.ron",
            "-i",
            "path",
            "--spp",
            "1",
            "--size",
            "16x16",
            "-q",
            "--reference",
            reference,
            "-o",
            out,
        ],
    )
}

fn render(dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["render"];
    args.extend_from_slice(extra);
    args.extend_from_slice(&QUICK);
    raylab_in(dir, &args)
}

#[test]
fn no_output_may_overwrite_the_scene_a_mesh_or_another_output() {
    let dir = workspace();
    let d = dir.path();
    let scene = std::fs::read(d.join("s.ron")).unwrap();
    let obj = std::fs::read(d.join("assets/pyramid.obj")).unwrap();

    // The checkpoint as the scene, by any spelling.
    for spelling in ["s.ron", "./s.ron", "assets/../s.ron"] {
        let o = render(d, &["s.ron", "--checkpoint", spelling, "-o", "a.png"]);
        refused(&o, &["the checkpoint would overwrite the scene"]);
    }
    // The image as a mesh the scene names, through a symbolic link and a hard link.
    std::os::unix::fs::symlink("assets/pyramid.obj", d.join("link.png")).unwrap();
    std::fs::hard_link(d.join("assets/pyramid.obj"), d.join("hard.exr")).unwrap();
    for out in ["link.png", "hard.exr"] {
        let o = render(d, &["mesh_files.ron", "-o", out]);
        refused(&o, &["the image would overwrite a file the scene reads"]);
    }
    // Checkpoint and image in one file: neither could be resumed.
    let o = render(d, &["s.ron", "--checkpoint", "x.exr", "-o", "./x.exr"]);
    refused(&o, &["the image and the checkpoint are the same file"]);
    assert!(!d.join("x.exr").exists());
    // --watch holds to the same rule.
    let o = raylab_in(
        d,
        &["render", "mesh_files.ron", "--watch", "-o", "link.png"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));

    assert_eq!(std::fs::read(d.join("s.ron")).unwrap(), scene);
    assert_eq!(std::fs::read(d.join("assets/pyramid.obj")).unwrap(), obj);
    // And a legitimate pair still works.
    let o = render(d, &["s.ron", "--checkpoint", "c.bin", "-o", "a.png"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn diff_never_replaces_its_operands_and_writes_only_png() {
    let dir = workspace();
    let d = dir.path();
    assert!(render(d, &["s.ron", "-o", "a.png"]).status.success());
    std::fs::copy(d.join("a.png"), d.join("b.png")).unwrap();
    let a = std::fs::read(d.join("a.png")).unwrap();
    std::os::unix::fs::symlink("a.png", d.join("l.png")).unwrap();
    for out in ["a.png", "./b.png", "l.png"] {
        let o = raylab_in(d, &["diff", "a.png", "b.png", "-o", out]);
        refused(&o, &["the error map would overwrite image"]);
    }
    assert_eq!(std::fs::read(d.join("a.png")).unwrap(), a);
    let o = raylab_in(d, &["diff", "a.png", "b.png", "-o", "e.jpg"]);
    refused(&o, &["the error map is a PNG"]);
    assert!(!d.join("e.jpg").exists());
    let o = raylab_in(d, &["diff", "a.png", "b.png", "--tolerance", "-1"]);
    refused(&o, &["--tolerance must be", "at least 0"]);
    // PSNR's tolerance is a floor in dB: any finite value.
    let o = raylab_in(
        d,
        &[
            "diff",
            "a.png",
            "b.png",
            "--metric",
            "psnr",
            "--tolerance",
            "-1",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn compare_keeps_its_reference_and_leaves_no_empty_folder() {
    let dir = workspace();
    let d = dir.path();
    std::fs::create_dir(d.join("out")).unwrap();
    assert!(render(d, &["s.ron", "-o", "out/reference.exr"])
        .status
        .success());
    let reference = std::fs::read(d.join("out/reference.exr")).unwrap();
    let o = compare(d, "out/reference.exr", "out");
    refused(&o, &["would overwrite the reference image"]);
    assert_eq!(
        std::fs::read(d.join("out/reference.exr")).unwrap(),
        reference
    );
    // The same reference, moved out of the way, is fine.
    std::fs::rename(d.join("out/reference.exr"), d.join("ref.exr")).unwrap();
    assert!(compare(d, "ref.exr", "out").status.success());
    // A comparison that fails removes the folder it created, and only an empty one.
    let o = compare(d, "missing.exr", "new");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!d.join("new").exists());
    // An output folder that is a file is refused before anything is rendered.
    let o = compare(d, "ref.exr", "s.ron");
    refused(&o, &["is a file, not a folder"]);
}

#[cfg(unix)]
#[test]
fn a_replaced_file_keeps_its_permissions_and_link_and_odd_files_are_refused() {
    use std::os::unix::fs::PermissionsExt;
    let dir = workspace();
    let d = dir.path();
    let mode = |p: &str| std::fs::metadata(d.join(p)).unwrap().permissions().mode() & 0o777;
    assert!(render(d, &["s.ron", "-o", "private.png"]).status.success());
    std::fs::set_permissions(d.join("private.png"), PermissionsExt::from_mode(0o600)).unwrap();
    assert!(render(d, &["s.ron", "-o", "private.png", "--seed", "3"])
        .status
        .success());
    assert_eq!(mode("private.png"), 0o600, "a private render stays private");

    // Written through a link: the link stays, its target holds the new image.
    std::fs::create_dir(d.join("store")).unwrap();
    std::fs::write(d.join("store/img.png"), b"old").unwrap();
    std::os::unix::fs::symlink("store/img.png", d.join("img.png")).unwrap();
    assert!(render(d, &["s.ron", "-o", "img.png"]).status.success());
    assert!(d
        .join("img.png")
        .symlink_metadata()
        .unwrap()
        .file_type()
        .is_symlink());
    assert_ne!(std::fs::read(d.join("store/img.png")).unwrap(), b"old");
    assert!(
        std::fs::read_dir(d.join("store")).unwrap().count() == 1,
        "no temporary left beside the target"
    );

    // Refused before rendering: write-protected, a folder, a pipe.
    std::fs::write(d.join("ro.png"), b"keep").unwrap();
    std::fs::set_permissions(d.join("ro.png"), PermissionsExt::from_mode(0o444)).unwrap();
    refused(&render(d, &["s.ron", "-o", "ro.png"]), &["write-protected"]);
    assert_eq!(std::fs::read(d.join("ro.png")).unwrap(), b"keep");
    std::fs::create_dir(d.join("dir.png")).unwrap();
    refused(&render(d, &["s.ron", "-o", "dir.png"]), &["is a folder"]);
    let fifo = std::process::Command::new("mkfifo")
        .arg(d.join("fifo.png"))
        .status()
        .unwrap();
    assert!(fifo.success());
    refused(
        &render(d, &["s.ron", "-o", "fifo.png"]),
        &["not a regular file"],
    );
    refused(
        &render(d, &["s.ron", "-o", "a.png", "--checkpoint", "fifo.png"]),
        &["not a regular file"],
    );
}

/// A Mitsuba scene's textures and included files are inputs like its meshes: no render,
/// checkpoint or import may replace them, under any name (a link too); import
/// writes `.ron` only.
#[test]
fn textures_and_included_files_are_inputs_of_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("assets")).unwrap();
    std::fs::copy(
        repo_file("scenes/mitsuba/assets/tiles.png"),
        d.join("assets/tiles.png"),
    )
    .unwrap();
    let scene = std::fs::read_to_string(repo_file("scenes/mitsuba/textured_glossy.xml")).unwrap();
    // The sensor moved into a file of its own, included.
    let start = scene.find("<sensor").unwrap();
    let end = scene.find("</sensor>").unwrap() + "</sensor>".len();
    std::fs::write(
        d.join("camera.xml"),
        format!(
            "<scene version=\"3.0.0\">\n{}\n</scene>\n",
            &scene[start..end]
        ),
    )
    .unwrap();
    let main = format!(
        "{}<include filename=\"camera.xml\"/>{}",
        &scene[..start],
        &scene[end..]
    );
    std::fs::write(d.join("t.xml"), main).unwrap();
    std::os::unix::fs::symlink("camera.xml", d.join("camera-link.ron")).unwrap();
    let tiles = std::fs::read(d.join("assets/tiles.png")).unwrap();
    let camera = std::fs::read(d.join("camera.xml")).unwrap();
    for (args, words) in [
        (
            vec!["render", "t.xml", "-o", "assets/tiles.png"],
            vec!["the image would overwrite a file the scene reads"],
        ),
        (
            vec![
                "render",
                "t.xml",
                "-o",
                "a.png",
                "--checkpoint",
                "camera.xml",
            ],
            vec!["the checkpoint would overwrite a file the scene reads"],
        ),
        (
            vec!["import", "t.xml", "-o", "camera-link.ron"],
            vec!["the RON scene would overwrite a file the scene reads"],
        ),
        (
            vec!["import", "t.xml", "-o", "t.png"],
            vec!["import writes a RON scene"],
        ),
    ] {
        let mut all = args.clone();
        all.extend(["--spp", "1", "-q"].iter().filter(|_| args[0] != "import"));
        let o = raylab_in(d, &all);
        refused(&o, &words);
    }
    assert_eq!(std::fs::read(d.join("assets/tiles.png")).unwrap(), tiles);
    assert_eq!(std::fs::read(d.join("camera.xml")).unwrap(), camera);
    // The same commands into files of their own do their work.
    let o = raylab_in(d, &["import", "t.xml", "-o", "t.ron"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// `compare -o DIR` and `suite -o DIR` into a folder raylab did not make: taken only when
/// none of their files is there already (a folder of the user's keeps its files).
#[test]
fn comparisons_do_not_replace_files_in_a_folder_of_the_users() {
    let dir = workspace();
    let d = dir.path();
    let mine = d.join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("reference.png"), "my own picture").unwrap();
    let o = render(d, &["s.ron", "-o", "ref.exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let compare = |out: &str| compare(d, "ref.exr", out);
    let o = compare("mine");
    refused(&o, &["was not made by raylab", "reference.png"]);
    assert_eq!(
        std::fs::read(mine.join("reference.png")).unwrap(),
        b"my own picture"
    );
    // An empty folder of the user's is taken, and marked; the next run replaces its files.
    std::fs::create_dir(d.join("empty")).unwrap();
    for _ in 0..2 {
        let o = compare("empty");
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert!(d.join("empty/.raylab-output").is_file());
}

/// SIGTERM (a timeout, a scheduler's preemption, `docker stop`) and SIGHUP (a closed
/// terminal) save the samples so far, image and checkpoint, as the first Ctrl-C does; so does
/// a signal delivered twice at once.
#[test]
fn sigterm_and_sighup_write_the_image_and_the_checkpoint() {
    let dir = workspace();
    let d = dir.path();
    // And a signal delivered twice at once (GNU `timeout` signals raylab, then its process
    // group, microseconds apart): one stop, which writes the image, not "Ctrl-C again".
    for (name, signal, twice) in [
        ("TERM", "TERM", false),
        ("HUP", "HUP", false),
        ("twice", "TERM", true),
    ] {
        let (out, ck) = (d.join(format!("{name}.png")), d.join(format!("{name}.ck")));
        let r = Running::start(
            &[
                "render",
                repo_file("scenes/cornell_box.ron").to_str().unwrap(),
                "--size",
                "64x64",
                "--spp",
                "100000",
                "-o",
                out.to_str().unwrap(),
                "--checkpoint",
                ck.to_str().unwrap(),
            ],
            &d.join(format!("{name}.log")),
            false,
        );
        // The first pass done (its checkpoint saved), so that there is an image to write.
        assert!(crate::common::eventually(|| ck.exists()), "{}", r.stderr());
        let log = r.stderr.clone();
        let status = if twice {
            r.stop_with_twice(signal)
        } else {
            r.stop_with(signal)
        };
        let e = std::fs::read_to_string(log).unwrap();
        assert!(status.success(), "SIG{signal}: {e}");
        assert!(e.contains("interrupted: wrote the image with"), "{e}");
        assert!(out.exists() && ck.exists(), "SIG{signal}: {e}");
    }
    crate::common::assert_no_temporaries(d);
}

/// One NaN pixel, or an image of infinity, is a difference whatever the tolerance, reported
/// with its count and first pixel; a reference with either is refused.
#[test]
fn non_finite_pixels_are_differences_and_bad_references() {
    use raylab::output::{write_image, DisplaySettings, Film};
    let dir = workspace();
    let d = dir.path();
    let write = |name: &str, f: &dyn Fn(usize) -> f32| {
        let mut film = Film::new(16, 16);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            *p = glam::Vec3::splat(f(i));
        }
        write_image(&d.join(name), &film, DisplaySettings::default()).unwrap();
    };
    write("black.exr", &|_| 0.0);
    write("one-nan.exr", &|i| if i == 37 { f32::NAN } else { 0.0 });
    write("inf.exr", &|_| f32::INFINITY);
    for (a, count, first) in [("one-nan.exr", 1, "(5, 2)"), ("inf.exr", 256, "(0, 0)")] {
        let o = raylab_in(d, &["diff", a, "black.exr", "--tolerance", "1e9"]);
        let out = String::from_utf8_lossy(&o.stdout);
        assert_eq!(o.status.code(), Some(1), "{out}");
        assert!(
            out.contains(&format!(
                "{count} pixel(s) with NaN or infinite values, the first at {first}"
            )),
            "{out}"
        );
    }
    let o = compare(d, "one-nan.exr", "cmp");
    refused(&o, &["the reference has 1 pixel(s) with NaN"]);
    // A PNG is no radiance reference.
    assert!(render(d, &["s.ron", "-o", "r.png"]).status.success());
    let o = raylab_in(
        d,
        &[
            "compare",
            "s.ron",
            "-i",
            "path",
            "--reference",
            "r.png",
            "-o",
            "cmp",
        ],
    );
    refused(&o, &["must be an EXR"]);
}

/// A checkpoint is checked before it is used: damage, a pipe, more passes than the target.
#[test]
fn damaged_or_odd_checkpoints_are_refused() {
    let dir = workspace();
    let d = dir.path();
    let with_ck = |spp: &str, resume: bool| {
        let mut args = vec![
            "render",
            "s.ron",
            "--spp",
            spp,
            "--size",
            "16x16",
            "-q",
            "-o",
            "a.png",
            "--checkpoint",
            "c.bin",
        ];
        if resume {
            args.push("--resume");
        }
        raylab_in(d, &args)
    };
    assert!(with_ck("2", false).status.success());
    let good = std::fs::read(d.join("c.bin")).unwrap();
    let mut bad = good.clone();
    bad[100] ^= 1;
    std::fs::write(d.join("c.bin"), &bad).unwrap();
    refused(&with_ck("2", true), &["cannot resume", "damaged"]);
    std::fs::write(d.join("c.bin"), [&good[..], &[7u8; 64][..]].concat()).unwrap();
    refused(&with_ck("2", true), &["cannot resume", "damaged"]);
    std::fs::remove_file(d.join("c.bin")).unwrap();
    let fifo = std::process::Command::new("mkfifo")
        .arg(d.join("c.bin"))
        .status()
        .unwrap();
    assert!(fifo.success());
    refused(&with_ck("2", true), &["not a regular file"]);
}

/// A scene reads files under its own folder only, unless `--allow-path` trusts another; a
/// pipe or a device is never read (it would block or never end), whatever the folder.
#[cfg(unix)]
#[test]
fn scenes_read_only_regular_files_under_allowed_folders() {
    let dir = workspace();
    let d = dir.path();
    std::fs::create_dir(d.join("scene")).unwrap();
    let panel = |path: &str| {
        format!(
            r#"(camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (8, 8)),
materials: {{"white": Lambert(albedo: (0.5, 0.5, 0.5))}},
entities: [(name: "panel", shape: Obj(path: "{path}"), material: "white")])"#
        )
    };
    std::fs::write(d.join("scene/outside.ron"), panel("../assets/pyramid.obj")).unwrap();
    let o = raylab_in(d, &["validate", "scene/outside.ron"]);
    refused(&o, &["outside the scene's folder", "--allow-path"]);
    let o = raylab_in(
        d,
        &["validate", "scene/outside.ron", "--allow-path", "assets"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = render(
        d,
        &["scene/outside.ron", "--allow-path", "assets", "-o", "a.png"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = raylab_in(
        d,
        &["validate", "scene/outside.ron", "--allow-path", "nowhere"],
    );
    refused(&o, &["--allow-path nowhere: no such folder"]);

    // A device as a mesh, even in a trusted folder; a pipe as the scene.
    std::fs::write(d.join("scene/zero.ron"), panel("/dev/zero")).unwrap();
    let o = raylab_in(d, &["validate", "scene/zero.ron", "--allow-path", "/dev"]);
    refused(&o, &["/dev/zero", "not a regular file"]);
    let fifo = std::process::Command::new("mkfifo")
        .arg(d.join("pipe.ron"))
        .status()
        .unwrap();
    assert!(fifo.success());
    refused(
        &render(d, &["pipe.ron", "-o", "p.png"]),
        &["not a regular file"],
    );
}

/// A glTF whose node graph places one mesh 200,000 times (400 million triangles) is refused
/// for the memory it would need, before anything is flattened.
#[test]
fn a_gltf_that_places_a_mesh_too_often_is_refused_for_memory() {
    use std::fmt::Write as _;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // One mesh of 2,000 triangles (unindexed), placed by 200,000 nodes.
    let mut data = Vec::new();
    for t in 0..2000u32 {
        for (x, y) in [(0.0f32, 0.0f32), (1.0, 0.0), (0.0, 1.0)] {
            for v in [x + t as f32, y, 0.0] {
                data.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    let b64 = {
        use base64::Engine;
        base64::engine::general_purpose::STANDARD.encode(&data)
    };
    let mut nodes = String::new();
    for i in 0..200_000 {
        let _ = write!(nodes, "{}{{\"mesh\":0}}", if i > 0 { "," } else { "" });
    }
    let roots: Vec<String> = (0..200_000).map(|i| i.to_string()).collect();
    let gltf = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{nodes}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{b64}"}}],
"bufferViews":[{{"buffer":0,"byteLength":{}}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":6000,"type":"VEC3","min":[0,0,0],"max":[2000,1,0]}}]}}"#,
        roots.join(","),
        data.len(),
        data.len()
    );
    std::fs::write(d.join("many.gltf"), gltf).unwrap();
    std::fs::write(
        d.join("s.ron"),
        r#"(camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (8, 8)),
materials: {"white": Lambert(albedo: (0.5, 0.5, 0.5))},
entities: [(name: "crowd", shape: Gltf(path: "many.gltf"), material: "white")])"#,
    )
    .unwrap();
    let o = raylab_in(d, &["validate", "s.ron"]);
    refused(
        &o,
        &[
            "entity `crowd`",
            "400000000 triangles need about",
            "GiB of memory",
        ],
    );
}

/// A scene saved with a UTF-8 byte-order mark (as some editors do) loads; an OBJ with one too.
#[test]
fn a_byte_order_mark_is_no_error() {
    let dir = workspace();
    let d = dir.path();
    let scene = std::fs::read_to_string(d.join("mesh_files.ron")).unwrap();
    std::fs::write(d.join("bom.ron"), format!("\u{feff}{scene}")).unwrap();
    // The mark right before the first vertex line, where tobj would miss the `v`.
    let obj = std::fs::read_to_string(d.join("assets/pyramid.obj")).unwrap();
    let body: String = obj
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with('o'))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(body.starts_with("v "));
    std::fs::write(d.join("assets/pyramid.obj"), format!("\u{feff}{body}")).unwrap();
    let o = raylab_in(d, &["validate", "bom.ron"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Under `ulimit -v` (as a batch job sets it), a render too large for the limit is refused
/// with a message naming it, not aborted in the allocation.
#[cfg(unix)]
#[test]
fn an_address_space_limit_is_respected() {
    let dir = workspace();
    let o = crate::common::raylab_limited(
        dir.path(),
        2_000_000,
        &[
            "render",
            "s.ron",
            "--size",
            "8000x8000",
            "--spp",
            "1",
            "-q",
            "-o",
            "big.png",
        ],
    );
    refused(&o, &["8000x8000 image needs", "ulimit -v"]);
    assert!(!dir.path().join("big.png").exists());
}

/// An image whose header claims 65536 x 65536 pixels (a few hundred bytes of file) is
/// refused from its header, as a texture and as an environment map, by what raylab would
/// hold of it: the decoded image and the float texels made of it, not the decoded bytes
/// alone.
#[test]
fn images_are_refused_by_what_raylab_would_hold_of_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let chunk = |kind: &[u8], data: &[u8]| {
        let mut c = (data.len() as u32).to_be_bytes().to_vec();
        c.extend_from_slice(kind);
        c.extend_from_slice(data);
        let mut crc = flate2::Crc::new();
        crc.update(kind);
        crc.update(data);
        c.extend_from_slice(&crc.sum().to_be_bytes());
        c
    };
    // An 8-bit grey PNG of `side` x `side` black pixels, whole (`rows`) or only its header.
    let png = |side: u32, rows: bool| {
        use std::io::Write as _;
        let mut ihdr = side.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&side.to_be_bytes());
        ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
        if rows {
            let row = vec![0u8; side as usize + 1];
            for _ in 0..side {
                z.write_all(&row).unwrap();
            }
        }
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        png.extend(chunk(b"IHDR", &ihdr));
        png.extend(chunk(b"IDAT", &z.finish().unwrap()));
        png.extend(chunk(b"IEND", &[]));
        png
    };
    std::fs::write(d.join("huge.png"), png(65536, false)).unwrap();
    // 389 kB: 400 MB decoded, which the decoder's own limit lets through, and 18 GB as an
    // environment map's float texels and tables.
    std::fs::write(d.join("big.png"), png(20000, true)).unwrap();
    let camera = "camera: LookAt(eye: (0, 0, 3), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (8, 8))";
    for (name, text) in [
        (
            "texture.ron",
            format!(
                r#"({camera}, materials: {{"w": Lambert(albedo: Image(path: "huge.png"))}}, environment: (1, 1, 1), entities: [(shape: Sphere(radius: 1), material: "w")])"#
            ),
        ),
        (
            "sky.ron",
            format!(
                r#"({camera}, materials: {{"w": Lambert(albedo: (0.5, 0.5, 0.5))}}, entities: [(shape: Sphere(radius: 1), material: "w"), (emitter: Environment(path: "huge.png"))])"#
            ),
        ),
    ] {
        std::fs::write(d.join(name), &text).unwrap();
        let o = raylab_in(d, &["validate", name]);
        refused(&o, &["huge.png", "65536 x 65536 pixels, which take"]);
        // Under 4 GB of address space the 20000 x 20000 one is refused too, from its
        // header, where it used to be decoded and abort in the float copy.
        let big = format!("big-{name}");
        std::fs::write(d.join(&big), text.replace("huge.png", "big.png")).unwrap();
        let o = crate::common::raylab_limited(d, 4_000_000, &["validate", &big]);
        refused(&o, &["big.png", "20000 x 20000 pixels, which take"]);
    }
}

/// What a scene file says reaches the terminal escaped: an entity named with an escape
/// sequence (clear the screen, set the window title) and a NUL is printed as `\u{..}`, never
/// as the bytes a terminal would act on.
#[test]
fn control_characters_from_files_never_reach_the_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("s.ron"),
        r#"(camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (8, 8)),
            materials: {"w": Lambert(albedo: (0.5, 0.5, 0.5))},
            entities: [(name: "x\u{1b}]0;owned\u{7}\u{1b}[2J\u{0}y", shape: Sphere(radius: -1), material: "w")])"#,
    )
    .unwrap();
    let o = raylab_in(d, &["validate", "s.ron"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        !o.stderr.iter().any(|b| matches!(b, 0x1b | 0x07 | 0x00)),
        "raw control bytes: {:?}",
        o.stderr
    );
    assert!(
        stderr(&o).contains(r"x\u{1b}]0;owned\u{7}\u{1b}[2J\u{0}y"),
        "{}",
        stderr(&o)
    );
}
