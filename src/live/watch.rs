//! Watching a scene file and the files it names (the `notify` crate).
//!
//! Editors often save by writing a new file and renaming it over the old one, which a watch
//! on the file itself would lose; so the folders are watched and events filtered by path.
//! Events are debounced: the reload is requested once the files have been quiet for
//! [`DEBOUNCE`], so one save (often several events) gives one reload.

use super::Control;
use anyhow::{Context, Result};
use notify::{EventKind, RecommendedWatcher, RecursiveMode, Watcher};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Quiet time after the last change before reloading: long enough to take an editor's
/// write-and-rename as one save, short beside the reload (an edit reaches its first pass in
/// tens of milliseconds; a reload of an unchanged file costs about nothing).
pub const DEBOUNCE: Duration = Duration::from_millis(25);

/// Watches a scene and the files it names; a change asks the [`Control`] for a reload.
pub struct SceneWatcher {
    scene: PathBuf,
    watcher: Mutex<RecommendedWatcher>,
    /// Folders being watched, with the identity (device, inode) of the folder watched: a
    /// folder deleted and made again is a new one, whose watch must be set again.
    dirs: Mutex<HashMap<PathBuf, (u64, u64)>>,
    /// The scene and the files it names, normalised: what [`SceneWatcher::files`] lists.
    tracked: Mutex<Vec<PathBuf>>,
    /// Files whose changes count (absolute, with canonical folders), shared with the thread.
    files: Arc<Mutex<HashSet<PathBuf>>>,
}

/// `path` with its folder made canonical (the file itself may not exist, or be mid-rename),
/// as notify reports paths under a canonical watched folder, and the folder to watch for it:
/// its own, or, while that is missing (deleted, about to be made again), the nearest folder
/// above it that exists, which sees it come back.
fn normalize(path: &Path) -> Option<(PathBuf, PathBuf)> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = path.file_name()?;
    if let Ok(dir) = dir.canonicalize() {
        return Some((dir.join(name), dir));
    }
    let absolute = std::path::absolute(dir).ok()?;
    let existing = absolute.ancestors().find_map(|a| a.canonicalize().ok())?;
    Some((absolute.join(name), existing))
}

/// What the system calls the folder `dir` now (device, inode).
fn identity(dir: &Path) -> Option<(u64, u64)> {
    let meta = std::fs::metadata(dir).ok()?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        Some((meta.dev(), meta.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = meta;
        Some((0, 0))
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl SceneWatcher {
    /// Starts watching `scene` (and nothing else until [`SceneWatcher::track`]).
    pub fn start(scene: &Path, control: Arc<Control>) -> Result<SceneWatcher> {
        let (tx, rx) = mpsc::channel::<notify::Result<notify::Event>>();
        let watcher = notify::recommended_watcher(move |event| {
            // The receiver is gone only when the session ends.
            let _ = tx.send(event);
        })
        .context("cannot start watching files")?;
        let files: Arc<Mutex<HashSet<PathBuf>>> = Arc::default();
        let thread_files = Arc::clone(&files);
        std::thread::Builder::new()
            .name("raylab-watch".into())
            .spawn(move || debounce(rx, &thread_files, &control))
            .context("cannot start the file watcher thread")?;
        let w = SceneWatcher {
            scene: scene.to_path_buf(),
            watcher: Mutex::new(watcher),
            dirs: Mutex::default(),
            tracked: Mutex::default(),
            files,
        };
        w.track(&[])?;
        Ok(w)
    }

    /// Watches the scene and `files` from now on (and folders made again since, anew).
    /// Called after every load.
    pub fn track(&self, files: &[PathBuf]) -> Result<()> {
        let mut wanted = HashSet::new();
        let mut dirs = HashSet::new();
        for f in std::iter::once(&self.scene).chain(files) {
            // A file named through a symbolic link changes where the link points: both the
            // link and its target are watched.
            let target = crate::output::atomic::through_links(f).unwrap_or_else(|_| f.clone());
            for path in [f, &target] {
                if let Some((file, dir)) = normalize(path) {
                    wanted.insert(file);
                    dirs.insert(dir);
                }
            }
        }
        let mut watcher = lock(&self.watcher);
        let mut watched = lock(&self.dirs);
        for d in &dirs {
            let Some(now) = identity(d) else {
                continue;
            };
            if watched.get(d) != Some(&now) {
                if watched.contains_key(d) {
                    let _ = watcher.unwatch(d);
                }
                watcher
                    .watch(d, RecursiveMode::NonRecursive)
                    .with_context(|| format!("cannot watch the folder {}", d.display()))?;
                watched.insert(d.clone(), now);
            }
        }
        for d in watched.keys().cloned().collect::<Vec<_>>() {
            if !dirs.contains(&d) {
                let _ = watcher.unwatch(&d);
                watched.remove(&d);
            }
        }
        let mut tracked: Vec<PathBuf> = wanted.iter().cloned().collect();
        tracked.sort();
        *lock(&self.tracked) = tracked;
        // Changes to the wanted files count, and so does a folder of theirs coming back.
        let folders: Vec<PathBuf> = wanted
            .iter()
            .filter_map(|f| f.parent().map(Path::to_path_buf))
            .collect();
        wanted.extend(folders);
        *lock(&self.files) = wanted;
        Ok(())
    }

    /// The files whose changes count now.
    pub fn files(&self) -> Vec<PathBuf> {
        lock(&self.tracked).clone()
    }
}

/// Whether `event` is a change to one of `files` (reads do not count: the session reads the
/// files itself). Errors and rescans count: something may have been missed.
fn relevant(event: &notify::Result<notify::Event>, files: &Mutex<HashSet<PathBuf>>) -> bool {
    match event {
        Err(_) => true,
        Ok(e) if e.need_rescan() => true,
        Ok(e) if matches!(e.kind, EventKind::Access(_)) => false,
        Ok(e) => {
            let files = lock(files);
            e.paths.iter().any(|p| files.contains(p))
        }
    }
}

/// Turns bursts of relevant events into one reload request each, until the watcher is dropped.
fn debounce(
    rx: mpsc::Receiver<notify::Result<notify::Event>>,
    files: &Mutex<HashSet<PathBuf>>,
    control: &Control,
) {
    while let Ok(event) = rx.recv() {
        if !relevant(&event, files) {
            continue;
        }
        let first = Instant::now();
        let mut deadline = first + DEBOUNCE;
        loop {
            match rx.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
                Ok(e) => {
                    if relevant(&e, files) {
                        deadline = Instant::now() + DEBOUNCE;
                    }
                }
                Err(RecvTimeoutError::Timeout) => break,
                Err(RecvTimeoutError::Disconnected) => return,
            }
        }
        control.request_reload_since(first);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Polls `f` for up to 10 s.
    fn eventually(mut f: impl FnMut() -> bool) -> bool {
        let end = Instant::now() + Duration::from_secs(10);
        while Instant::now() < end {
            if f() {
                return true;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        false
    }

    #[test]
    fn a_save_by_rename_and_a_named_file_request_a_reload_and_other_files_do_not() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("s.ron");
        let mesh = dir.path().join("m.obj");
        std::fs::write(&scene, "a").unwrap();
        let control = Arc::new(Control::new());
        let w = SceneWatcher::start(&scene, Arc::clone(&control)).unwrap();
        w.track(std::slice::from_ref(&mesh)).unwrap();
        assert_eq!(w.files().len(), 2);

        // An unrelated file in the same folder: nothing.
        std::fs::write(dir.path().join("other.txt"), "x").unwrap();
        std::thread::sleep(DEBOUNCE * 3);
        assert!(!control.interrupted());

        // Save by writing a temporary file and renaming it over the scene.
        let tmp = dir.path().join(".s.ron.swp");
        std::fs::write(&tmp, "b").unwrap();
        std::fs::rename(&tmp, &scene).unwrap();
        assert!(eventually(|| control.interrupted()));
        assert!(control.take().reload.is_some());

        // Creating a named file that did not exist.
        std::fs::write(&mesh, "v 0 0 0").unwrap();
        assert!(eventually(|| control.interrupted()));
    }
}
