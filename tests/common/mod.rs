//! Helpers for the tests that run `raylab` as a long-lived child process (`render --watch`,
//! `serve`): start it with its stderr in a file, poll with generous timeouts, stop it with
//! SIGINT, and never leave it running when a test fails.

#![allow(dead_code)] // each test file uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// Long enough for a loaded 2-core machine; the tests finish in far less when things work.
pub const TIMEOUT: Duration = Duration::from_secs(30);

/// A running `raylab`, killed when dropped.
pub struct Running {
    pub child: Child,
    pub stderr: PathBuf,
}

impl Running {
    /// Starts `raylab ARGS` in the repository root, stderr to `stderr_file`; stdout piped
    /// when `pipe_stdout`.
    pub fn start(args: &[&str], stderr_file: &Path, pipe_stdout: bool) -> Running {
        let err = std::fs::File::create(stderr_file).unwrap();
        let child = Command::new(env!("CARGO_BIN_EXE_raylab"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .stdin(Stdio::null())
            .stdout(if pipe_stdout {
                Stdio::piped()
            } else {
                Stdio::null()
            })
            .stderr(err)
            .spawn()
            .expect("raylab starts");
        Running {
            child,
            stderr: stderr_file.to_path_buf(),
        }
    }

    /// Everything it wrote to stderr so far.
    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default()
    }

    /// Waits (up to [`TIMEOUT`]) until its stderr satisfies `f`; panics with the stderr if not.
    pub fn wait_stderr(&self, what: &str, f: impl Fn(&str) -> bool) {
        if !eventually(|| f(&self.stderr())) {
            panic!("timed out waiting for {what}; stderr:\n{}", self.stderr());
        }
    }

    /// Sends SIGINT (Ctrl-C) and waits for the exit.
    pub fn interrupt(mut self) -> ExitStatus {
        let pid = self.child.id().to_string();
        let ok = Command::new("kill").args(["-INT", &pid]).status().unwrap();
        assert!(ok.success());
        let end = Instant::now() + TIMEOUT;
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status;
            }
            assert!(
                Instant::now() < end,
                "still running after Ctrl-C; stderr:\n{}",
                self.stderr()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Polls `f` every 20 ms for up to [`TIMEOUT`].
pub fn eventually(mut f: impl FnMut() -> bool) -> bool {
    let end = Instant::now() + TIMEOUT;
    loop {
        if f() {
            return true;
        }
        if Instant::now() >= end {
            return false;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Saves `text` to `path` the way many editors do: a new file renamed over the old one.
pub fn save(path: &Path, text: &str) {
    let tmp = path.with_extension("ron.tmp~");
    std::fs::write(&tmp, text).unwrap();
    std::fs::rename(&tmp, path).unwrap();
}

/// A copy of `scenes/NAME` (and `scenes/assets`) in a new temporary folder.
pub fn scene_copy(name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    std::fs::copy(src.join(name), dir.path().join(name)).unwrap();
    std::fs::create_dir(dir.path().join("assets")).unwrap();
    for f in std::fs::read_dir(src.join("assets")).unwrap() {
        let f = f.unwrap();
        std::fs::copy(f.path(), dir.path().join("assets").join(f.file_name())).unwrap();
    }
    let scene = dir.path().join(name);
    (dir, scene)
}

/// The light of `scenes/cornell_box.ron`, to edit.
pub const CORNELL_LIGHT: &str = "radiance: (18.387, 13.9873, 6.75357)";
