//! The files a scene file names: meshes (OBJ, glTF) and, for a `.gltf`, the buffers and images
//! it points to; environment maps. Live editing watches them so that saving any of them re-renders.

use super::load::parse_scene_file;
use super::schema::{EmitterDesc, ShapeDesc};
use std::path::{Path, PathBuf};

/// FNV-1a, 64 bits: a hash that is stable across builds and platforms (unlike std's).
pub fn stable_hash(parts: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        // Length-prefix each part so that ("ab", "c") and ("a", "bc") differ.
        for b in (part.len() as u64).to_le_bytes().iter().chain(part.iter()) {
            h ^= *b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}

/// The bytes that determine what `scene` renders: its own text, then a hash of the contents
/// of every file it refers to, in the order the text names them (a marker for a file that
/// cannot be read). Not the files' resolved paths: the scene's text already names them, and
/// `scenes/x.ron` and `./scenes/x.ron` must hash alike. Hashes that must change when any of
/// these files changes (checkpoints, `compare`'s cached reference) are taken over this.
pub fn scene_content(scene: &Path) -> std::io::Result<Vec<u8>> {
    let mut bytes = crate::files::read_capped(scene, crate::files::MAX_TEXT)?;
    for file in referenced_files(scene).unwrap_or_default() {
        match crate::files::read_capped(&file, crate::files::MAX_BINARY) {
            Ok(content) => bytes.extend_from_slice(&stable_hash(&[&content]).to_le_bytes()),
            Err(_) => bytes.extend_from_slice(b"\0unreadable"),
        }
    }
    Ok(bytes)
}

/// The files `scene` refers to, resolved against its folder, in file order without repeats.
/// `None` when the scene file cannot be read or parsed (the caller keeps what it had). Files
/// that are missing are listed all the same: creating them must trigger a reload.
pub fn referenced_files(scene: &Path) -> Option<Vec<PathBuf>> {
    // An imported scene's files, from its RON (the defaults of its parameters).
    let text = super::load::scene_text(scene, &[], &Default::default()).ok()?;
    let file = parse_scene_file(&text, scene).ok()?;
    let dir = folder_of(scene);
    let mut files: Vec<PathBuf> = Vec::new();
    // Entities' shapes, then the mesh assets they may instance, then environment maps.
    let shapes = file
        .entities
        .iter()
        .filter_map(|e| e.shape.as_ref())
        .chain(file.meshes.0.iter().map(|(_, shape)| shape));
    let maps = file.entities.iter().filter_map(|e| e.emitter.as_ref());
    for f in shapes
        .flat_map(|s| shape_files(s, dir))
        .chain(maps.flat_map(|e| emitter_files(e, dir)))
    {
        if !files.contains(&f) {
            files.push(f);
        }
    }
    Some(files)
}

/// The files a shape reads, resolved against the scene's folder `dir`: a mesh file and, for
/// an OBJ, its material libraries, for a `.gltf`, its buffers and images.
pub fn shape_files(shape: &ShapeDesc, dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    match shape {
        ShapeDesc::Obj { path, .. } => {
            let obj = dir.join(path);
            for mtl in obj_mtllibs(&obj) {
                files.push(folder_of(&obj).join(mtl));
            }
            files.push(obj);
        }
        ShapeDesc::Gltf { path } => {
            let gltf = dir.join(path);
            for uri in gltf_uris(&gltf) {
                files.push(folder_of(&gltf).join(uri));
            }
            files.push(gltf);
        }
        ShapeDesc::Ply { path, .. } | ShapeDesc::Serialized { path, .. } => {
            files.push(dir.join(path))
        }
        _ => {}
    }
    files
}

/// The file an emitter reads (an environment map's image), resolved against `dir`.
pub fn emitter_files(emitter: &EmitterDesc, dir: &Path) -> Vec<PathBuf> {
    match emitter {
        EmitterDesc::Environment { path, .. } => vec![dir.join(path)],
        _ => Vec::new(),
    }
}

/// The folder a file's relative references are resolved against: its own ("." for a bare
/// file name).
pub fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// The material libraries (`mtllib` lines) an OBJ file names; none if it cannot be read.
fn obj_mtllibs(path: &Path) -> Vec<String> {
    let Ok(text) = crate::files::read_text_capped(path, crate::files::MAX_BINARY) else {
        return Vec::new();
    };
    text.lines()
        .filter_map(|l| l.trim().strip_prefix("mtllib"))
        .filter(|rest| rest.starts_with(char::is_whitespace))
        .map(|rest| rest.trim().to_string())
        .filter(|name| !name.is_empty())
        .collect()
}

/// The external (not `data:`) buffer and image URIs of a `.gltf` JSON file; none for a
/// binary `.glb` or a file that cannot be read.
fn gltf_uris(path: &Path) -> Vec<String> {
    let Ok(text) = crate::files::read_text_capped(path, crate::files::MAX_TEXT) else {
        return Vec::new();
    };
    let Ok(json) = serde_json::from_str::<serde_json::Value>(&text) else {
        return Vec::new();
    };
    let mut uris = Vec::new();
    for key in ["buffers", "images"] {
        if let Some(items) = json.get(key).and_then(|v| v.as_array()) {
            for item in items {
                if let Some(uri) = item.get("uri").and_then(|u| u.as_str()) {
                    // Relative file names only: no schemes, no absolute paths.
                    if !uri.contains(':') && !uri.starts_with('/') {
                        uris.push(uri.replace("%20", " "));
                    }
                }
            }
        }
    }
    uris
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_obj_gltf_and_gltf_buffers_relative_to_the_scene() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("s.ron");
        std::fs::create_dir(dir.path().join("m")).unwrap();
        std::fs::write(
            dir.path().join("m/a.gltf"),
            r#"{"buffers": [{"uri": "a.bin"}, {"uri": "data:application/octet-stream;base64,AA=="}]}"#,
        )
        .unwrap();
        std::fs::write(dir.path().join("m/y.obj"), "mtllib y.mtl\nv 0 0 0\n").unwrap();
        std::fs::write(
            &scene,
            r#"(camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), fov: 40, resolution: (8, 8)),
                meshes: {"asset": Obj(path: "m/y.obj")},
                entities: [
                    (shape: Obj(path: "m/x.obj")),
                    (shape: Gltf(path: "m/a.gltf")),
                    (shape: Obj(path: "m/x.obj")),
                    (shape: Sphere(radius: 1)),
                    (shape: Instance(mesh: "asset")),
                ])"#,
        )
        .unwrap();
        let files = referenced_files(&scene).unwrap();
        let d = dir.path();
        assert_eq!(
            files,
            vec![
                d.join("m/x.obj"),
                d.join("m/a.bin"),
                d.join("m/a.gltf"),
                d.join("m/y.mtl"),
                d.join("m/y.obj")
            ]
        );
        std::fs::write(&scene, "(camera: ").unwrap();
        assert_eq!(referenced_files(&scene), None);
    }
}
