//! What a loaded scene read, and the one identity that covers all of it.
//!
//! The loaders read every file through [`SceneFiles`], which keeps the list (the scene,
//! `<include>`d and `Include`d files, meshes, material libraries, glTF buffers, textures,
//! environment maps; missing files too). [`SceneInputs`] is that list with the options the
//! scene was read with (`-D`, `--approximate`): the inputs no output of a command may
//! replace, the files a live session watches, and, through [`SceneInputs::identity`], what
//! checkpoints, shards and `compare`'s reference cache are tied to.

use crate::formats::access::SceneFiles;
use crate::formats::import::ImportOptions;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The files a scene read and how it was read.
#[derive(Clone, Debug, Default)]
pub struct SceneInputs {
    /// The scene file.
    pub scene: PathBuf,
    /// Every other file it read or looked for, in path order.
    pub files: Vec<PathBuf>,
    /// `-D` values and `--approximate`.
    pub options: ImportOptions,
    /// The identity of a scene kept in memory (from Python): fixed when it was read, and
    /// moved by each edit since, whatever its files say now.
    pub known: Option<u64>,
}

impl SceneInputs {
    /// What the scene of `files` has read so far, read with `options`.
    pub fn of(files: &SceneFiles, options: &ImportOptions) -> SceneInputs {
        SceneInputs {
            scene: files.scene().to_path_buf(),
            files: files.read(),
            options: options.clone(),
            known: None,
        }
    }

    /// The scene file, then every other file it read.
    pub fn all(&self) -> impl Iterator<Item = &Path> {
        std::iter::once(self.scene.as_path()).chain(self.files.iter().map(PathBuf::as_path))
    }

    /// A hash of everything that determines the scene: the scene file's bytes, the `-D`
    /// values and `--approximate`, and every other file it read (by its name relative to
    /// the scene's folder, and its bytes, or that it is missing); [`SceneInputs::known`] when
    /// set. Not the scene's own path:
    /// `scenes/x.ron` and `./scenes/x.ron`, or the same scene on two machines, hash alike.
    pub fn identity(&self) -> std::io::Result<u64> {
        if let Some(known) = self.known {
            return Ok(known);
        }
        let mut h = Fnv::new();
        h.part(b"raylab scene identity 2");
        hash_file(&self.scene, &mut h)?;
        for (name, value) in &self.options.defines {
            h.part(b"define");
            h.part(name.as_bytes());
            h.part(value.as_bytes());
        }
        h.part(if self.options.approximate {
            b"approximate"
        } else {
            b"exact"
        });
        let dir = super::references::folder_of(&self.scene);
        for file in &self.files {
            let name = file.strip_prefix(dir).unwrap_or(file);
            h.part(name.to_string_lossy().as_bytes());
            match hash_file(file, &mut h) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => h.part(b"\0missing"),
                Err(_) => h.part(b"\0unreadable"),
            }
        }
        Ok(h.0)
    }
}

/// FNV-1a, 64 bits, fed in length-prefixed parts (stable across builds and platforms, like
/// [`super::references::stable_hash`]).
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn bytes(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 ^= *b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    fn part(&mut self, part: &[u8]) {
        self.bytes(&(part.len() as u64).to_le_bytes());
        self.bytes(part);
    }
}

/// Feeds a regular file's length and bytes to `h`, in chunks (a mesh of gigabytes is not
/// held in memory for it).
fn hash_file(path: &Path, h: &mut Fnv) -> std::io::Result<()> {
    let (mut file, len) = crate::files::open_capped(path, crate::files::MAX_BINARY)?;
    h.bytes(&len.to_le_bytes());
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = file.read(&mut buf)?;
        if n == 0 {
            return Ok(());
        }
        h.bytes(&buf[..n]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inputs(scene: &Path, read: &[&str], options: ImportOptions) -> SceneInputs {
        let files = SceneFiles::new(scene, &[]);
        for r in read {
            let _ = files.named(r);
        }
        SceneInputs::of(&files, &options)
    }

    #[test]
    fn the_identity_covers_every_file_read_and_the_options() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let scene = d.join("s.xml");
        std::fs::write(&scene, "<scene/>").unwrap();
        std::fs::write(d.join("inc.xml"), "one").unwrap();
        std::fs::write(d.join("tex.png"), "two").unwrap();
        let id = |o: ImportOptions| {
            inputs(&scene, &["inc.xml", "tex.png", "gone.ply"], o)
                .identity()
                .unwrap()
        };
        let base = id(ImportOptions::default());
        assert_eq!(base, id(ImportOptions::default()));
        // The same scene reached by another path.
        let other = inputs(
            &d.join(".").join("s.xml"),
            &["inc.xml", "tex.png", "gone.ply"],
            ImportOptions::default(),
        );
        assert_eq!(base, other.identity().unwrap());
        let defined = ImportOptions {
            defines: vec![("r".into(), "0.3".into())],
            approximate: false,
            ..ImportOptions::default()
        };
        assert_ne!(base, id(defined));
        let approximate = ImportOptions {
            defines: vec![],
            approximate: true,
            ..ImportOptions::default()
        };
        assert_ne!(base, id(approximate));
        std::fs::write(d.join("inc.xml"), "One").unwrap();
        assert_ne!(base, id(ImportOptions::default()));
        std::fs::write(d.join("inc.xml"), "one").unwrap();
        std::fs::write(d.join("tex.png"), "twO").unwrap();
        assert_ne!(base, id(ImportOptions::default()));
        std::fs::write(d.join("tex.png"), "two").unwrap();
        std::fs::write(d.join("gone.ply"), "").unwrap();
        assert_ne!(base, id(ImportOptions::default()));
        std::fs::remove_file(d.join("gone.ply")).unwrap();
        assert_eq!(base, id(ImportOptions::default()));
        // Two files' contents swapped: their names are hashed with them.
        std::fs::write(d.join("inc.xml"), "two").unwrap();
        std::fs::write(d.join("tex.png"), "one").unwrap();
        assert_ne!(base, id(ImportOptions::default()));
    }

    #[test]
    fn inputs_are_the_scene_and_every_file_asked_for() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("s.ron");
        let i = inputs(
            &scene,
            &["b.obj", "a.png", "b.obj", "../x.ply"],
            Default::default(),
        );
        let all: Vec<&Path> = i.all().collect();
        let d = dir.path();
        assert_eq!(
            all,
            [
                scene.as_path(),
                &d.join("../x.ply"),
                &d.join("a.png"),
                &d.join("b.obj")
            ]
        );
    }
}
