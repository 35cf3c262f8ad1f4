//! Atomic file writes: a temporary file in the target's folder, then a rename, so that no
//! reader ever sees a partly written file. The temporary files being written are registered,
//! so that a second Ctrl-C, which exits at once without running destructors, can remove them
//! first ([`remove_unfinished`]) rather than leave them beside the output.
//!
//! The replace respects what it replaces, as `cp` does: a symbolic link is written through
//! (its target is replaced, the link stays), the existing file's permissions are kept (a
//! private render stays private), and a write-protected file or anything that is not a
//! regular file (a folder, a device, a pipe) is refused.

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files being written now.
static UNFINISHED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn unfinished() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic elsewhere while holding the lock leaves the list usable.
    UNFINISHED.lock().unwrap_or_else(|e| e.into_inner())
}

/// A registered temporary file, taken off the list when its write ends, however it ends.
struct Registered(PathBuf);

impl Registered {
    /// Creates the temporary file beside `path` and registers it under one lock, so that
    /// [`remove_unfinished`] never misses a file that exists.
    fn create_beside(path: &Path) -> std::io::Result<(tempfile::NamedTempFile, Registered)> {
        let mut list = unfinished();
        let tmp = temporary_beside(path)?;
        list.push(tmp.path().to_path_buf());
        let registered = Registered(tmp.path().to_path_buf());
        Ok((tmp, registered))
    }
}

impl Drop for Registered {
    fn drop(&mut self) {
        unfinished().retain(|p| p != &self.0);
    }
}

/// The folder `path` is written in ("." for a bare file name).
pub fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Links a path may go through before it is taken for a loop (Linux's own limit).
const MAX_LINKS: usize = 40;

/// `path` with every symbolic link at its end followed: the file a write through it reaches
/// (which need not exist yet, for a dangling link).
pub fn through_links(path: &Path) -> Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let target = std::fs::read_link(&p)
                    .with_context(|| format!("{}: cannot read the link", p.display()))?;
                p = parent_dir(&p).join(target);
            }
            _ => return Ok(p),
        }
    }
    bail!("{}: too many levels of symbolic links", path.display())
}

/// What an atomic write of `path` will replace: `None` for a new file, else the existing
/// file's permissions. Refuses what `cp` would not overwrite (a file this user may not write)
/// and what is not a regular file.
pub fn check_replaceable(path: &Path) -> Result<Option<std::fs::Permissions>> {
    Ok(replaceable(path)?.1)
}

/// [`check_replaceable`], with the file a write of `path` reaches (through links).
fn replaceable(path: &Path) -> Result<(PathBuf, Option<std::fs::Permissions>)> {
    let target = through_links(path)?;
    let meta = match std::fs::metadata(&target) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok((target, None)),
        Err(e) => return Err(e).with_context(|| format!("{}: cannot inspect it", path.display())),
    };
    if meta.is_dir() {
        bail!("{}: is a folder, not a file", path.display());
    }
    if !meta.is_file() {
        bail!(
            "{}: is not a regular file (a device, pipe or socket); refusing to replace it",
            path.display()
        );
    }
    // Write-protected: no write permission at all (which even root, who may write anything,
    // is taken to respect), or none for this user: opening for writing without truncating
    // changes nothing and asks the system the question `cp` asks.
    let denied = |e: std::io::Error| e.kind() == std::io::ErrorKind::PermissionDenied;
    if meta.permissions().readonly()
        || std::fs::OpenOptions::new()
            .write(true)
            .open(&target)
            .is_err_and(denied)
    {
        bail!(
            "{}: is write-protected; refusing to replace it (make it writable or remove it first)",
            path.display()
        );
    }
    Ok((target, Some(meta.permissions())))
}

/// A temporary file in `path`'s folder, with the permissions of any new file (0666 less the
/// umask): tempfile's default, 0600, would make every image and checkpoint private.
fn temporary_beside(path: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let mut builder = tempfile::Builder::new();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    builder.tempfile_in(parent_dir(path))
}

/// Writes `path` atomically: `write` fills a temporary file beside it (beside the target, for
/// a symbolic link), which then replaces it with the old file's permissions. On any error
/// `path` is untouched and the temporary file is removed. Errors from `write` are returned as
/// they are.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut std::fs::File) -> Result<()>,
) -> Result<()> {
    let (target, existing) = replaceable(path)?;
    let (mut tmp, _registered) = Registered::create_beside(&target).with_context(|| {
        format!(
            "{}: cannot create a temporary file beside it",
            path.display()
        )
    })?;
    if let Some(permissions) = existing {
        tmp.as_file()
            .set_permissions(permissions)
            .with_context(|| format!("{}: cannot keep its permissions", path.display()))?;
    }
    // (The caller's errors carry its own context: "cannot encode the image", ...)
    write(tmp.as_file_mut())?;
    tmp.as_file()
        .sync_all()
        .with_context(|| format!("{}: cannot write (is the disk full?)", path.display()))?;
    tmp.persist(&target)
        .map_err(|e| e.error)
        .with_context(|| format!("{}: cannot move it into place", path.display()))?;
    Ok(())
}

/// Removes the temporary files being written now: for an exit that skips destructors.
pub fn remove_unfinished() {
    remove_unfinished_where(|_| true);
}

/// Removes (and forgets) the temporary files being written whose path matches.
fn remove_unfinished_where(matches: impl Fn(&Path) -> bool) {
    unfinished().retain(|p| {
        if matches(p) {
            let _ = std::fs::remove_file(p);
        }
        !matches(p)
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn writes_replace_the_target_and_failures_leave_it_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        write_atomic(&target, |f| Ok(f.write_all(b"one")?)).unwrap();
        write_atomic(&target, |f| Ok(f.write_all(b"two")?)).unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"two");
        let failed = write_atomic(&target, |f| {
            f.write_all(b"partial")?;
            anyhow::bail!("encoder failed")
        });
        assert!(failed.is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"two");
        assert_eq!(names(dir.path()), ["out.txt"]);
    }

    /// Written files get the same permissions as a file made with `fs::write`, not 0600.
    #[cfg(unix)]
    #[test]
    fn written_files_have_ordinary_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let ordinary = dir.path().join("ordinary.txt");
        std::fs::write(&ordinary, b"x").unwrap();
        let atomic = dir.path().join("atomic.txt");
        write_atomic(&atomic, |f| Ok(f.write_all(b"x")?)).unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&atomic), mode(&ordinary));
    }

    /// What a second Ctrl-C does in the middle of a write: the temporary file goes. (Only
    /// this test's folder: other tests may be writing files at the same time.)
    #[test]
    fn remove_unfinished_removes_a_temporary_being_written() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("checkpoint.bin");
        let result = write_atomic(&target, |f| {
            f.write_all(b"half")?;
            assert_eq!(names(dir.path()).len(), 1, "the temporary file exists");
            remove_unfinished_where(|p| p.starts_with(dir.path()));
            assert!(names(dir.path()).is_empty(), "and is removed");
            anyhow::bail!("interrupted")
        });
        assert!(result.is_err());
        assert!(names(dir.path()).is_empty());
    }
}
