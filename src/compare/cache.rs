//! The cache of rendered references: `reference-<hash>.exr` files in a folder of the user's
//! (`$XDG_CACHE_HOME/raylab`, else `~/.cache/raylab`).
//!
//! The names are predictable, so the folder is treated as a place others might reach: it must
//! be the user's own and not writable by everyone (it is made `0700`); an entry is read only
//! when it is a regular file of the user's, opened without following a symbolic link, and is
//! checked as a `--reference` file is (size, NaN or infinite pixels); an entry is written to
//! a temporary file in the folder and renamed over its name, which replaces a link planted
//! there instead of writing through it. The folder is made and tried before anything
//! renders, so a cache that cannot be written costs nothing; an entry that cannot be written
//! after all is a warning (the reference is in hand).

use crate::output::{self, Film};
use anyhow::{bail, Context, Result};
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Where rendered references are cached: `$XDG_CACHE_HOME/raylab`, else
/// `~/.cache/raylab`, else a `.cache` folder in the output folder `out`.
pub fn cache_dir(out: &Path) -> PathBuf {
    let base = std::env::var_os("XDG_CACHE_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")));
    match base {
        Some(b) => b.join("raylab"),
        None => out.join(".cache"),
    }
}

/// A cache folder that was checked and can be written.
pub struct Cache {
    dir: PathBuf,
    /// The user who owns what this process creates (the probe file's owner).
    #[cfg(unix)]
    uid: u32,
}

impl Cache {
    /// Makes the folder if it is missing (`0700`), and checks that it is a folder of this
    /// user's, not writable by everyone, in which a file can be created.
    pub fn open(dir: &Path) -> Result<Cache> {
        let mut builder = std::fs::DirBuilder::new();
        builder.recursive(true);
        #[cfg(unix)]
        std::os::unix::fs::DirBuilderExt::mode(&mut builder, 0o700);
        builder
            .create(dir)
            .with_context(|| format!("{}: cannot create the cache folder", dir.display()))?;
        let probe = tempfile::NamedTempFile::new_in(dir).with_context(|| {
            format!(
                "{}: cannot write in the reference cache folder (set XDG_CACHE_HOME to a folder of yours, or give --reference FILE)",
                dir.display()
            )
        })?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            let uid = probe.as_file().metadata()?.uid();
            let meta = std::fs::metadata(dir)?;
            if meta.uid() != uid || meta.mode() & 0o002 != 0 {
                bail!(
                    "{}: the reference cache folder is {}; it must be yours and not writable by others (set XDG_CACHE_HOME to a folder of yours)",
                    dir.display(),
                    if meta.uid() != uid {
                        "another user's"
                    } else {
                        "writable by everyone"
                    }
                );
            }
            Ok(Cache {
                dir: dir.to_path_buf(),
                uid,
            })
        }
        #[cfg(not(unix))]
        {
            drop(probe);
            Ok(Cache {
                dir: dir.to_path_buf(),
            })
        }
    }

    /// The entry for `hash`.
    pub fn entry(&self, hash: u64) -> PathBuf {
        self.dir.join(format!("reference-{hash:016x}.exr"))
    }

    /// The cached image of `hash` if there is a good one of `width x height`: a regular file
    /// of this user's (a symbolic link is not followed), decoded, of that size, every pixel
    /// finite. Anything else is `Err` with the reason (the caller renders anew).
    pub fn read(&self, hash: u64, width: u32, height: u32) -> Result<Film> {
        let path = self.entry(hash);
        let mut file = open_no_follow(&path)?;
        let meta = file.metadata()?;
        if !meta.is_file() {
            bail!("{}: not a regular file", path.display());
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            if meta.uid() != self.uid {
                bail!("{}: another user's file", path.display());
            }
        }
        if meta.len() > crate::files::MAX_BINARY {
            bail!("{}: too large", path.display());
        }
        let film = output::decode_image(&mut file, image::ImageFormat::OpenExr, &path)?;
        super::check_reference(&film, width, height, &path)?;
        Ok(film)
    }

    /// Stores `film` as the entry of `hash`: written beside it and renamed over it.
    pub fn write(&self, hash: u64, film: &Film) -> Result<()> {
        let path = self.entry(hash);
        let mut bytes = std::io::Cursor::new(Vec::new());
        output::exr_file::encode(film, &mut bytes)?;
        let mut tmp = tempfile::Builder::new()
            .prefix(".reference-")
            .tempfile_in(&self.dir)
            .with_context(|| format!("{}: cannot write in the cache folder", path.display()))?;
        tmp.write_all(bytes.get_ref())
            .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), output::write_error(&e)))?;
        tmp.persist(&path)
            .with_context(|| format!("{}: cannot store the reference", path.display()))?;
        Ok(())
    }
}

/// Opens `path` for reading without following a symbolic link at its last component.
fn open_no_follow(path: &Path) -> Result<std::fs::File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(target_os = "linux")]
    std::os::unix::fs::OpenOptionsExt::custom_flags(&mut options, libc::O_NOFOLLOW);
    #[cfg(not(target_os = "linux"))]
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        bail!("{}: a symbolic link", path.display());
    }
    options
        .open(path)
        .with_context(|| format!("{}: cannot open", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film(v: f32) -> Film {
        let mut f = Film::new(4, 2);
        f.pixels.iter_mut().for_each(|p| *p = glam::Vec3::splat(v));
        f
    }

    #[test]
    fn entries_round_trip_and_bad_ones_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(&dir.path().join("raylab")).unwrap();
        assert!(cache.read(1, 4, 2).is_err());
        cache.write(1, &film(0.5)).unwrap();
        assert_eq!(cache.read(1, 4, 2).unwrap().pixels[3].x, 0.5);
        // Another size: not this reference.
        assert!(cache.read(1, 2, 4).is_err());
        // NaN inside: refused as a --reference file would be.
        cache.write(2, &film(f32::NAN)).unwrap();
        let e = cache.read(2, 4, 2).unwrap_err().to_string();
        assert!(e.contains("NaN"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn links_in_the_cache_are_neither_read_nor_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(&dir.path().join("raylab")).unwrap();
        // Another scene's image, and a file of the user's, linked under entries' names.
        let other = dir.path().join("other.exr");
        let mut bytes = std::io::Cursor::new(Vec::new());
        output::exr_file::encode(&film(0.25), &mut bytes).unwrap();
        std::fs::write(&other, bytes.get_ref()).unwrap();
        std::os::unix::fs::symlink(&other, cache.entry(7)).unwrap();
        assert!(cache.read(7, 4, 2).is_err());
        let victim = dir.path().join("victim.txt");
        std::fs::write(&victim, "keep me").unwrap();
        std::os::unix::fs::symlink(&victim, cache.entry(8)).unwrap();
        cache.write(8, &film(1.0)).unwrap();
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep me");
        assert_eq!(cache.read(8, 4, 2).unwrap().pixels[0].x, 1.0);
    }

    #[cfg(unix)]
    #[test]
    fn a_folder_everyone_may_write_is_refused_before_anything_renders() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let open = dir.path().join("open");
        std::fs::create_dir(&open).unwrap();
        std::fs::set_permissions(&open, std::fs::Permissions::from_mode(0o777)).unwrap();
        let e = Cache::open(&open).err().unwrap().to_string();
        assert!(e.contains("writable by everyone"), "{e}");
        // A file where the folder should be.
        let file = dir.path().join("file");
        std::fs::write(&file, "").unwrap();
        assert!(Cache::open(&file).is_err());
    }
}
