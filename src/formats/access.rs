//! Which files a scene may make raylab read. Scenes are shared between people, so by default
//! every file a scene names (meshes, MTL files, glTF buffers), directly or through another
//! file, must lie under the folder of the scene file given on the command line; `--allow-path
//! DIR` adds folders a user trusts (for scenes whose assets sit beside them, as Mitsuba's test
//! scenes reach `../../../common`). Paths are compared after resolving links, so neither
//! `../` nor a symbolic link leaves the allowed folders.
//!
//! Every file a scene reads passes through here, so [`SceneFiles`] also keeps the list of
//! them (its *inputs*: the scene, included files, meshes, material libraries, buffers,
//! textures, environment maps), missing ones included: what no output may replace, what a
//! live session watches, and what the scene's identity ([`crate::scene::inputs`]) hashes.

use std::collections::BTreeSet;
use std::path::{Component, Path, PathBuf};
use std::sync::{Arc, Mutex};

/// A scene's folder, the folders its files may come from, and the files it has read.
#[derive(Clone, Debug)]
pub struct SceneFiles {
    /// The scene file itself.
    scene: PathBuf,
    /// The scene file's folder: relative paths in the scene start here.
    dir: PathBuf,
    /// Canonical folders files may lie under: the scene's, then those allowed.
    roots: Vec<PathBuf>,
    /// Every file asked for through [`SceneFiles::named`] or [`SceneFiles::check`], as it
    /// was reached (lexically: the scene's folder joined with the name), shared by the
    /// clones (the loaders of one scene, which may run in parallel).
    read: Arc<Mutex<BTreeSet<PathBuf>>>,
    /// What the readers of its files noted while reading them (a mesh's repaired normals),
    /// shared by the clones: the load's warnings.
    notes: Arc<Mutex<Vec<String>>>,
}

impl SceneFiles {
    /// The files of the scene at `scene`, which may also come from the folders `allowed`.
    pub fn new(scene: &Path, allowed: &[PathBuf]) -> SceneFiles {
        let dir = match scene.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let roots = std::iter::once(&dir)
            .chain(allowed)
            .filter_map(|d| d.canonicalize().ok())
            .collect();
        SceneFiles {
            scene: scene.to_path_buf(),
            dir,
            roots,
            read: Arc::default(),
            notes: Arc::default(),
        }
    }

    /// Notes `message` as a warning of the load.
    pub fn note(&self, message: String) {
        self.notes
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(message);
    }

    /// The notes so far, taken (the list is left empty).
    pub fn take_notes(&self) -> Vec<String> {
        std::mem::take(&mut *self.notes.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// The same scene's files, with a list of files read of its own, empty.
    pub fn with_new_list(&self) -> SceneFiles {
        SceneFiles {
            read: Arc::default(),
            ..self.clone()
        }
    }

    /// The scene file's folder, which relative paths start from.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The scene file.
    pub fn scene(&self) -> &Path {
        &self.scene
    }

    /// The files the scene has read so far besides the scene file (or tried to: missing
    /// ones too, whose creation must count as a change), in path order.
    pub fn read(&self) -> Vec<PathBuf> {
        self.log().iter().cloned().collect()
    }

    fn log(&self) -> std::sync::MutexGuard<'_, BTreeSet<PathBuf>> {
        // A panic while holding it leaves a set of paths: still usable.
        self.read.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The file the scene names as `path` (relative to the scene's folder), if the scene
    /// may read it.
    pub fn named(&self, path: &str) -> Result<PathBuf, String> {
        let file = self.dir.join(path);
        self.check(&file, path)?;
        Ok(file)
    }

    /// Refuses `file` (named `as_named` where it is named) unless it lies under an allowed
    /// folder. A file that does not exist passes: opening it reports that. Either way the
    /// file joins the scene's inputs.
    pub fn check(&self, file: &Path, as_named: &str) -> Result<(), String> {
        if file != self.scene {
            self.log().insert(file.to_path_buf());
        }
        let Ok(real) = file.canonicalize() else {
            return Ok(());
        };
        if self.roots.iter().any(|r| real.starts_with(r)) {
            return Ok(());
        }
        Err(format!(
            "`{as_named}` is `{}`, outside the scene's folder `{}`; a scene may only read files under its own folder (add --allow-path {} to trust that folder)",
            real.display(),
            self.roots
                .first()
                .map_or_else(|| self.dir.display().to_string(), |r| r.display().to_string()),
            suggested_folder(&real).display()
        ))
    }
}

/// The folder to suggest for `--allow-path`: the file's own.
fn suggested_folder(file: &Path) -> PathBuf {
    file.parent()
        .map_or_else(|| file.to_path_buf(), Path::to_path_buf)
}

/// A URI inside a mesh file (a glTF buffer's) as a relative path, or why it is refused:
/// only relative paths and `data:` URIs are read, never `file://`, `http://` or an absolute
/// path. `None` for a `data:` URI (embedded bytes).
pub fn relative_uri(uri: &str) -> Result<Option<PathBuf>, String> {
    if uri.starts_with("data:") {
        return Ok(None);
    }
    let decoded = percent_decode(uri);
    let has_scheme = decoded
        .split_once(':')
        .is_some_and(|(scheme, _)| !scheme.is_empty() && !scheme.contains(['/', '\\']));
    let path = PathBuf::from(&decoded);
    if has_scheme
        || path.is_absolute()
        || path.components().any(|c| matches!(c, Component::Prefix(_)))
    {
        return Err(format!(
            "the URI `{uri}` is not a relative path (only relative paths and data: URIs are read)"
        ));
    }
    Ok(Some(path))
}

fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: Option<&u8>| b.and_then(|&b| (b as char).to_digit(16));
        match (bytes[i], hex(bytes.get(i + 1)), hex(bytes.get(i + 2))) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                i += 3;
            }
            (b, _, _) => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_outside_the_scenes_folder_are_refused_unless_allowed() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir_all(d.join("scene/meshes")).unwrap();
        std::fs::create_dir_all(d.join("common")).unwrap();
        std::fs::write(d.join("scene/meshes/a.obj"), "").unwrap();
        std::fs::write(d.join("common/b.obj"), "").unwrap();
        std::os::unix::fs::symlink(d.join("common/b.obj"), d.join("scene/link.obj")).unwrap();
        let scene = d.join("scene/s.ron");
        let files = SceneFiles::new(&scene, &[]);
        assert!(files.named("meshes/a.obj").is_ok());
        assert!(files.named("meshes/../meshes/a.obj").is_ok());
        for escape in ["../common/b.obj", "link.obj", "/etc/passwd"] {
            let e = files.named(escape).unwrap_err();
            assert!(e.contains("--allow-path") && e.contains(escape), "{e}");
        }
        let trusting = SceneFiles::new(&scene, &[d.join("common")]);
        assert!(trusting.named("../common/b.obj").is_ok());
        assert!(trusting.named("/etc/passwd").is_err());
    }

    #[test]
    fn uris_must_be_relative_paths_or_data() {
        assert_eq!(
            relative_uri("data:application/octet-stream;base64,AA=="),
            Ok(None)
        );
        assert_eq!(
            relative_uri("bin/a%20b.bin"),
            Ok(Some(PathBuf::from("bin/a b.bin")))
        );
        for bad in [
            "file:///etc/passwd",
            "/etc/passwd",
            "http://x/y.bin",
            "%2Fetc%2Fpasswd",
        ] {
            assert!(relative_uri(bad).is_err(), "{bad}");
        }
    }
}
