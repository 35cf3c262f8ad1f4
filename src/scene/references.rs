//! The files a scene description names: meshes (OBJ, glTF) and, for a `.gltf`, the buffers
//! and images it points to; environment maps. A live session stamps them, so that an entity
//! whose files changed is made again ([`super::edit`]). (What a load actually read is kept by
//! [`crate::formats::access::SceneFiles`].)

use crate::formats::access::SceneFiles;
use crate::formats::schema::{EmitterDesc, ShapeDesc};
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

/// The files a shape reads, resolved against the scene's folder: a mesh file and, for an
/// OBJ, its material libraries, for a `.gltf`, its buffers and images. An OBJ or glTF file
/// is looked into only if the scene may read it (`scene_files`).
pub fn shape_files(shape: &ShapeDesc, scene_files: &SceneFiles) -> Vec<PathBuf> {
    let dir = scene_files.dir();
    let mut files = Vec::new();
    match shape {
        ShapeDesc::Obj { path, .. } => {
            let obj = dir.join(path);
            if scene_files.check(&obj, path).is_ok() {
                for mtl in obj_mtllibs(&obj) {
                    files.push(folder_of(&obj).join(mtl));
                }
            }
            files.push(obj);
        }
        ShapeDesc::Gltf { path } => {
            let gltf = dir.join(path);
            if scene_files.check(&gltf, path).is_ok() {
                for uri in gltf_uris(&gltf) {
                    files.push(folder_of(&gltf).join(uri));
                }
            }
            files.push(gltf);
        }
        ShapeDesc::Ply { path, .. }
        | ShapeDesc::Serialized { path, .. }
        | ShapeDesc::SdfGrid { path, .. } => files.push(dir.join(path)),
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
