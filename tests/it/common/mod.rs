//! Helpers for the tests that run `raylab` as a long-lived child process (`render --watch`,
//! `serve`): start it with its stderr in a file, poll with generous timeouts, stop it with
//! SIGINT, and never leave it running when a test fails.

#![allow(dead_code)] // each test module uses its own subset

pub mod pass_means;

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

    /// Sends SIGINT (Ctrl-C) without waiting.
    pub fn signal_interrupt(&self) {
        self.signal("INT");
    }

    /// Sends the signal `name` ("INT", "TERM", "HUP") without waiting.
    pub fn signal(&self, name: &str) {
        let pid = self.child.id().to_string();
        let ok = Command::new("kill")
            .args([&format!("-{name}"), &pid])
            .status()
            .unwrap();
        assert!(ok.success());
    }

    /// Sends SIGINT (Ctrl-C) and waits for the exit.
    pub fn interrupt(self) -> ExitStatus {
        self.stop_with("INT")
    }

    /// Sends the signal `name` and waits for the exit.
    pub fn stop_with(self, name: &str) -> ExitStatus {
        self.signal(name);
        self.wait()
    }

    /// Sends the signal `name` twice at once, from one shell (as GNU `timeout` signals a
    /// command and then its process group), and waits for the exit.
    pub fn stop_with_twice(self, name: &str) -> ExitStatus {
        let pid = self.child.id();
        let ok = Command::new("sh")
            .arg("-c")
            .arg(format!("kill -{name} {pid}; kill -{name} {pid}"))
            .status()
            .unwrap();
        assert!(ok.success());
        self.wait()
    }

    /// Waits for the exit (at most [`TIMEOUT`]).
    pub fn wait(mut self) -> ExitStatus {
        let name = "the end";
        let end = Instant::now() + TIMEOUT;
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status;
            }
            assert!(
                Instant::now() < end,
                "still running, waiting for {name}; stderr:\n{}",
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

/// Runs `raylab ARGS` to its end in the repository's root (where `scenes/` is).
pub fn raylab(args: &[&str]) -> std::process::Output {
    raylab_in(Path::new(env!("CARGO_MANIFEST_DIR")), args)
}

/// A command's standard error as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A path as the `&str` a command line takes.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("test paths are UTF-8")
}

/// Runs `raylab ARGS` to its end in the folder `dir` with at most `kb` kilobytes of address
/// space (`ulimit -v`): a memory limit the run must respect, refusing what does not fit.
pub fn raylab_limited(dir: &Path, kb: u64, args: &[&str]) -> std::process::Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {kb} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_raylab"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("sh runs")
}

/// Runs `raylab ARGS` to its end in the folder `dir`.
pub fn raylab_in(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("raylab runs")
}

/// Fails if `dir` holds a temporary file of an atomic write (`.tmp*`).
pub fn assert_no_temporaries(dir: &Path) {
    let names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().all(|n| !n.starts_with(".tmp")),
        "no temporary file left: {names:?}"
    );
}

/// The repository's file `path`, absolute (for tests that run elsewhere).
pub fn repo_file(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
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

/// Chromium, if this machine has it. Missing is a failure under CI (which installs it) and a
/// loud skip elsewhere: `None`, after saying so.
pub fn chromium() -> Option<&'static str> {
    let found = ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|c| {
            Command::new(c)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        });
    if found.is_none() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must provide Chromium (apt-get install chromium)"
        );
        eprintln!("SKIPPED the page test: no Chromium on this machine (apt-get install chromium)");
    }
    found
}

/// Loads `url` in headless Chromium for `budget_ms` of virtual time (which stands still
/// while a request is pending) and returns the DOM it dumps and the console lines it logged.
/// A browser still running after 90 s of real time is killed.
pub fn chromium_dump_dom(chromium: &str, url: &str, budget_ms: u32) -> (String, Vec<String>) {
    let profile = tempfile::tempdir().unwrap();
    let mut browser = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
            &format!("--virtual-time-budget={budget_ms}"),
            &format!("--user-data-dir={}", profile.path().display()),
            "--dump-dom",
            url,
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The watchdog kills only a browser that has not exited (no stray pid is signalled).
    let pid = browser.id();
    let (exited, watch) = std::sync::mpsc::channel::<()>();
    std::thread::spawn(move || {
        if let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
            watch.recv_timeout(Duration::from_secs(90))
        {
            let _ = Command::new("kill").args(["-9", &pid.to_string()]).status();
        }
    });
    let mut stderr = browser.stderr.take().unwrap();
    let log = std::thread::spawn(move || {
        let mut log = String::new();
        let _ = std::io::Read::read_to_string(&mut stderr, &mut log);
        log
    });
    let mut dom = String::new();
    std::io::Read::read_to_string(&mut browser.stdout.take().unwrap(), &mut dom).unwrap();
    browser.wait().unwrap();
    let _ = exited.send(());
    let log = log.join().unwrap();
    let console = log
        .lines()
        .filter(|l| l.contains(":CONSOLE"))
        .map(String::from)
        .collect();
    (dom, console)
}

/// Saves `scene` with a syntax error (`,,`) on its `entities: [` line; returns the good text
/// and the error's expected `FILE:LINE:` prefix.
pub fn break_scene(scene: &Path) -> (String, String) {
    let text = std::fs::read_to_string(scene).unwrap();
    let line = 1 + text
        .lines()
        .position(|l| l.contains("entities: ["))
        .unwrap();
    save(scene, &text.replacen("entities: [", "entities: [,,", 1));
    let name = scene.file_name().unwrap().to_str().unwrap();
    (text, format!("{name}:{line}:"))
}

/// Renders the scene `text` (written to a temporary folder beside `files`) in process with
/// `integrator` at `spp` samples per pixel and `seed`, over the accelerator `kind`.
pub fn render_text(
    text: &str,
    files: &[(&str, Vec<u8>)],
    integrator: &str,
    spp: u32,
    seed: u64,
    kind: raylab::accel::AccelKind,
) -> raylab::output::Film {
    render_text_with(text, files, integrator, &[], spp, seed, kind)
}

/// [`render_text`] with integrator parameters.
pub fn render_text_with(
    text: &str,
    files: &[(&str, Vec<u8>)],
    integrator: &str,
    params: &[(&str, &str)],
    spp: u32,
    seed: u64,
    kind: raylab::accel::AccelKind,
) -> raylab::output::Film {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    let path = dir.path().join("scene.ron");
    std::fs::write(&path, text).unwrap();
    let loaded = raylab::scene::load_scene(&path).unwrap();
    let built = raylab::scene::RenderScene::build_with(&loaded, kind);
    let mut integrator = raylab_integrators::registry::REGISTRY
        .iter()
        .find(|e| e.name == integrator)
        .unwrap()
        .instantiate(
            &params
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect::<Vec<_>>(),
        )
        .unwrap();
    let settings = raylab::render::RenderSettings::fixed(spp, seed, None);
    raylab::render::render(&built, &loaded.camera, integrator.as_mut(), &settings)
        .unwrap()
        .0
}
