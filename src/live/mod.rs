//! Live editing: a session that loads a scene, renders it pass by pass, and starts over when
//! a watched file changes or another integrator is chosen. `raylab render --watch` and
//! `raylab serve` share it; they differ only in their [`Observer`] (write a file, or keep a
//! PNG in memory for the page).
//!
//! Threads talk through a [`Control`]: the file watcher asks for a reload, the web page for a
//! new [`Selection`], Ctrl-C for the end. Any of these stops the render in progress at the end
//! of its current pass.
//!
//! The session keeps the scene's world across saves ([`SceneState`]): a save is applied to it as
//! an edit, and only what the edit changed is rebuilt (nothing for a material's colour, the
//! small flat BVH and the top level for a moved or added entity). The render scene is made
//! beside the one in use, which no pass ever sees change, and takes its place between two
//! renders. A new integrator or new parameters rebuild nothing. Each reload prints what it did
//! and how long after the save its first pass ended.

pub mod serve;
pub mod watch;

use crate::formats::access::SceneFiles;
use crate::render::{Film, Job, RenderStats, Request, Target};
use crate::scene::edit::SceneState;
use crate::scene::RenderScene;
use crate::scene::{self, LoadedScene};
use anyhow::Result;
use raylab_integrators::registry::{self, IntegratorEntry, ParamError, Params};
use raylab_integrators::ParamKind;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// Which integrator to render with, and the parameters the user set.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Selection {
    /// `None`: the scene's own integrator.
    pub integrator: Option<String>,
    /// (name, value text), checked against the registry.
    pub params: Vec<(String, String)>,
    /// How camera samples draw their numbers; `None`: the session's `--sampler`, else the
    /// scene's.
    pub sampler: Option<raylab_integrators::sampler::SamplerKind>,
}

impl Selection {
    /// Checks the integrator name and the parameters against the registry (and that they can
    /// finish a pass). Parameters for
    /// the scene's own integrator can only be checked once the scene is loaded.
    pub fn check(&self) -> Result<(), ParamError> {
        if let Some(name) = &self.integrator {
            let entry = registry::find(name)?;
            entry.build_checked(&entry.resolve(&self.params)?)?;
        }
        Ok(())
    }
}

/// What a live session renders, besides the integrator.
#[derive(Clone, Debug)]
pub struct LiveSettings {
    pub scene: PathBuf,
    /// Folders beside the scene's that it may read files from (`--allow-path`).
    pub allowed: Vec<PathBuf>,
    /// How a Mitsuba XML or pbrt-v4 scene is read (`-D`, `--approximate`).
    pub import: scene::ImportOptions,
    /// Image size overriding the scene's.
    pub size: Option<(u32, u32)>,
    /// Samples per pixel to stop at; `None` renders until the next change or Ctrl-C.
    pub spp: Option<u32>,
    /// Seed overriding the scene's.
    pub seed: Option<u64>,
    pub threads: Option<usize>,
    /// The accelerator renders are traced with.
    pub accel: crate::accel::AccelKind,
    /// Pixel reconstruction filter overriding the scene's.
    pub filter: Option<raylab_integrators::Filter>,
    /// Sampler overriding the scene's.
    pub sampler: Option<raylab_integrators::sampler::SamplerKind>,
    /// Spectral rendering overriding the scene's choice.
    pub spectral: Option<bool>,
    /// Shortest time between two images handed to the observer (the first pass and the last
    /// are always handed over).
    pub image_interval: Duration,
}

/// The render in progress, as observers see it.
#[derive(Clone, Debug)]
pub struct RenderInfo {
    pub integrator: &'static str,
    /// Every parameter with its value, as a user would type it.
    pub params: Vec<(&'static str, String)>,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel to stop at, if any.
    pub target_spp: Option<u32>,
    /// The sampler its camera samples draw from.
    pub sampler: raylab_integrators::sampler::SamplerKind,
}

impl RenderInfo {
    /// `name=value` pairs separated by spaces.
    pub fn describe_params(&self) -> String {
        self.params
            .iter()
            .map(|(n, v)| format!("{n}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// Why a render ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ended {
    /// It reached its samples per pixel.
    Finished,
    /// A file changed or another integrator was chosen: a new render follows.
    Changed,
    /// The session is stopping (Ctrl-C).
    Quit,
}

/// What a live session reports to. Calls come from the session's thread.
pub trait Observer {
    /// A scene loaded and a render starts.
    fn render_started(&mut self, info: &RenderInfo);
    /// An image of the render so far (at most every `image_interval`, and after the last
    /// pass of a render that finished or was stopped; not of one a change replaces).
    fn image(&mut self, film: &Film, info: &RenderInfo, stats: &RenderStats);
    /// A render ended; its last image was already handed over (unless a change ended it).
    fn render_ended(&mut self, info: &RenderInfo, stats: &RenderStats, why: Ended);
    /// The scene (or a file it names, or the integrator chosen) failed: `message` names the
    /// file and, for syntax errors, `line:column`. The last good image stays.
    fn load_failed(&mut self, message: &str);
    /// What a load or reload did and how long it took, once the first pass after it ended:
    /// `reload: 1 material changed (`white`), rebuilt nothing, first pass after 41 ms`.
    fn reloaded(&mut self, line: &str);
    /// The files the scene has read, after a load or reload (also one that failed): what
    /// an observer that writes files must not replace.
    fn inputs(&mut self, _scene: &std::path::Path, _files: &[PathBuf]) {}
}

/// Requests not yet acted on.
#[derive(Debug, Default)]
struct Pending {
    /// A reload, and when the first change that asked for it happened.
    reload: Option<Instant>,
    selection: Option<Selection>,
    quit: bool,
}

impl Pending {
    fn any(&self) -> bool {
        self.reload.is_some() || self.selection.is_some() || self.quit
    }
}

/// Requests to a live session from other threads: reload, switch integrator, stop.
#[derive(Debug, Default)]
pub struct Control {
    pending: Mutex<Pending>,
    wake: Condvar,
    /// Set with any request: the render in progress abandons its pass (long work inside the
    /// pass checks it as it goes).
    interrupt: AtomicBool,
    quitting: AtomicBool,
}

impl Control {
    pub fn new() -> Control {
        Control::default()
    }

    fn lock(&self) -> MutexGuard<'_, Pending> {
        // A panic elsewhere while holding the lock leaves plain flags behind: still usable.
        self.pending.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn request(&self, f: impl FnOnce(&mut Pending)) {
        let mut pending = self.lock();
        f(&mut pending);
        // Under the lock, as `take` clears it: never set with nothing pending.
        self.interrupt.store(true, Ordering::SeqCst);
        drop(pending);
        self.wake.notify_all();
    }

    /// A watched file changed at `when` (the first of a burst of changes): load the scene
    /// again, and time the reload from then.
    pub fn request_reload_since(&self, when: Instant) {
        self.request(|p| p.reload = Some(p.reload.map_or(when, |t| t.min(when))));
    }

    /// Render with another integrator or other parameters from now on.
    pub fn select(&self, selection: Selection) {
        self.request(|p| p.selection = Some(selection));
    }

    /// Stop the session (after the current pass).
    pub fn quit(&self) {
        self.quitting.store(true, Ordering::SeqCst);
        self.request(|p| p.quit = true);
    }

    /// Whether [`Control::quit`] was called.
    pub fn is_quitting(&self) -> bool {
        self.quitting.load(Ordering::SeqCst)
    }

    /// Whether a request arrived since the session last took them.
    fn interrupted(&self) -> bool {
        self.interrupt.load(Ordering::SeqCst)
    }

    /// Takes the requests so far (and clears the interrupt, under the same lock).
    fn take(&self) -> Pending {
        let mut p = self.lock();
        self.interrupt.store(false, Ordering::SeqCst);
        std::mem::take(&mut *p)
    }

    /// Blocks until a request arrives (returns at once if one is waiting).
    fn wait(&self) {
        let mut p = self.lock();
        while !p.any() {
            p = self.wake.wait(p).unwrap_or_else(|e| e.into_inner());
        }
    }
}

fn param_values(entry: &IntegratorEntry, params: &Params) -> Vec<(&'static str, String)> {
    entry
        .params
        .iter()
        .map(|p| {
            let v = params.get(p.name);
            let text = match p.kind {
                ParamKind::Depth if v.is_infinite() => "unlimited".to_string(),
                ParamKind::Choice(_) => params.text(p),
                _ => format!("{v}"),
            };
            (p.name, text)
        })
        .collect()
}

/// Reads the scene file and applies it to the session's world (or loads it, the first time
/// and after a load that failed), then builds what changed. Returns what it did, for the
/// reload line. On an error the world and its render scene stay as they were.
fn reload(
    live: &mut Option<SceneState>,
    settings: &LiveSettings,
    files: &SceneFiles,
    imported: &SceneFiles,
) -> Result<String> {
    let start = Instant::now();
    let (file, approximated, origins) =
        scene::load::read_scene_file_with_origins(imported, &settings.import)?;
    let (state, what) = match live {
        None => {
            let state = SceneState::new(file, &settings.scene, files.clone())
                .map_err(|e| origins.place(e))?;
            (live.insert(state), "load".to_string())
        }
        Some(state) => {
            let edit = state.apply(file).map_err(|e| origins.place(e))?;
            let what = format!("reload: {}", edit.describe());
            (state, what)
        }
    };
    state.loaded.warnings.extend(approximated);
    state.loaded.inputs = scene::SceneInputs::of(files, &settings.import);
    for w in &state.loaded.warnings {
        note!("warning: {}: {w}", settings.scene.display());
    }
    match state.render_scene(settings.accel, settings.threads) {
        Ok((_, rebuilt)) => {
            let ms = start.elapsed().as_secs_f64() * 1e3;
            Ok(format!("{what}, {rebuilt} ({ms:.1} ms)"))
        }
        Err(e) => {
            // The world moved on without a render scene of it: load afresh next time.
            *live = None;
            Err(e)
        }
    }
}

/// The job of rendering the scene with the selected integrator, and what observers see of it.
fn prepare(
    settings: &LiveSettings,
    selection: &Selection,
    loaded: &LoadedScene,
) -> Result<(Job, RenderInfo)> {
    let job = Job::new(
        loaded,
        &Request {
            integrator: selection.integrator.clone(),
            params: selection.params.clone(),
            scene_params: true,
            size: settings.size,
            target: settings.spp.map_or(Target::OpenEnded, Target::Spp),
            time: None,
            seed: settings.seed,
            filter: settings.filter,
            sampler: selection.sampler.or(settings.sampler),
            spectral: settings.spectral,
            threads: settings.threads,
            accel: settings.accel,
            progress: false,
            shard: None,
        },
    )?;
    let info = RenderInfo {
        integrator: job.entry.name,
        params: param_values(job.entry, &job.params),
        width: job.camera.width,
        height: job.camera.height,
        target_spp: settings.spp,
        sampler: job.settings.sampler,
    };
    Ok((job, info))
}

/// Renders `job` until it finishes or a request arrives, handing images to `observer`; after
/// its first pass, tells the observer `what` the reload before it did and how long after
/// `since` (the save) that pass began (now) and ended.
fn render_job(
    (mut job, info): (Job, RenderInfo),
    built: &RenderScene,
    interval: Duration,
    control: &Control,
    observer: &mut dyn Observer,
    (since, what): (Instant, String),
) {
    observer.render_started(&info);
    let mut acc = job.accumulation();
    let mut last_image: Option<Instant> = None;
    let mut shown_spp = 0;
    let mut reported = false;
    let began = since.elapsed().as_secs_f64() * 1e3;
    let stop = || control.interrupted();
    let result = job.run(built, &mut acc, &stop, &mut |acc, stats| {
        if !reported {
            let ended = since.elapsed().as_secs_f64() * 1e3;
            observer.reloaded(&format!(
                "{what}; first pass began {began:.0} ms after the save, ended after \
                     {ended:.0} ms"
            ));
            reported = true;
        }
        if last_image.is_none_or(|t| t.elapsed() >= interval) {
            observer.image(&acc.film(), &info, stats);
            last_image = Some(Instant::now());
            shown_spp = acc.spp_done;
        }
        Ok(())
    });
    match result {
        Ok(stats) => {
            let why = if stats.stopped.is_none() {
                Ended::Finished
            } else if control.is_quitting() {
                Ended::Quit
            } else {
                Ended::Changed
            };
            // A change replaces the image within a pass: not encoded now, between the save
            // and the new render (the last one handed over stays until then).
            if acc.spp_done > shown_spp && why != Ended::Changed {
                observer.image(&acc.film(), &info, &stats);
            }
            observer.render_ended(&info, &stats, why);
        }
        Err(e) => observer.load_failed(&format!("{e:#}")),
    }
}

/// A live session's scene: the world kept across saves, and the files every load of the
/// session read through. [`Session::load`] loads it the first time (so that a command can
/// check its outputs against what the scene reads before the session starts), [`run`] on
/// every save after.
pub struct Session {
    live: Option<SceneState>,
    // Every load of the session reads through these, so they list every file any version
    // of the scene read (a file no longer named only costs a reload that changes nothing).
    files: SceneFiles,
    /// The first load's result and the files its import read, until [`run`] takes them.
    first: Option<(Result<String>, SceneFiles)>,
}

impl Session {
    /// Loads the scene of `settings` (an error is kept: the session starts anyway, and the
    /// next save tries again).
    pub fn load(settings: &LiveSettings) -> Session {
        let files = SceneFiles::new(
            &settings.scene,
            &settings.import.readable(&settings.allowed),
        );
        let mut live = None;
        // The import reads the whole text again on every reload (its own list: the
        // included files of this version); the world's edits read only what changed.
        let imported = files.with_new_list();
        let first = reload(&mut live, settings, &files, &imported);
        Session {
            live,
            files,
            first: Some((first, imported)),
        }
    }

    /// The loaded scene, if it loaded.
    pub fn loaded(&self) -> Option<&LoadedScene> {
        self.live.as_ref().map(|s| &s.loaded)
    }
}

/// Runs a live session until [`Control::quit`]: render, wait for a request, load again,
/// repeat. `watcher` and `observer` are told the files the scene has read after every load,
/// or tried to (an included file with an error in it, a missing texture): saving any of
/// them loads it again.
pub fn run(
    settings: &LiveSettings,
    mut selection: Selection,
    control: &Control,
    watcher: &watch::SceneWatcher,
    observer: &mut dyn Observer,
    mut session: Session,
) {
    let mut watched = std::collections::BTreeSet::new();
    loop {
        let pending = control.take();
        if pending.quit {
            return;
        }
        let since = pending.reload.unwrap_or_else(Instant::now);
        let mut what = String::from("new integrator or parameters, rebuilt nothing (0.0 ms)");
        if let Some(s) = pending.selection {
            selection = s;
        }
        let first = session.first.take();
        if first.is_some() || pending.reload.is_some() || session.live.is_none() {
            let (reloaded, imported) = first.unwrap_or_else(|| {
                let imported = session.files.with_new_list();
                let reloaded = reload(&mut session.live, settings, &session.files, &imported);
                (reloaded, imported)
            });
            watched.extend(imported.read());
            watched.extend(session.files.read());
            let all: Vec<PathBuf> = watched.iter().cloned().collect();
            // Folders made again since are watched anew too.
            if let Err(e) = watcher.track(&all) {
                note!("warning: {e:#}");
            }
            // What this version of the scene reads: its import's files and its world's.
            if let (Ok(_), Some(state)) = (&reloaded, &session.live) {
                let mut now = imported.read();
                now.extend(state.files_in_use());
                observer.inputs(&settings.scene, &now);
            }
            match reloaded {
                Ok(line) => what = line,
                Err(e) => {
                    observer.load_failed(&format!("{e:#}"));
                    control.wait();
                    continue;
                }
            }
        }
        let Some((state, built)) = session.live.as_ref().and_then(|s| Some((s, s.built()?))) else {
            observer.load_failed("no scene loaded");
            control.wait();
            continue;
        };
        match prepare(settings, &selection, &state.loaded) {
            Ok(job) => render_job(
                job,
                built,
                settings.image_interval,
                control,
                observer,
                (since, what),
            ),
            Err(e) => observer.load_failed(&format!("{e:#}")),
        }
        control.wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_interrupt_and_are_taken_once() {
        let c = Control::new();
        assert!(!c.interrupted());
        c.request_reload_since(Instant::now());
        c.select(Selection {
            integrator: Some("whitted".into()),
            params: vec![],
            sampler: None,
        });
        assert!(c.interrupted());
        c.wait(); // returns at once: something is pending
        let p = c.take();
        assert!(p.reload.is_some() && !p.quit);
        assert_eq!(p.selection.unwrap().integrator.as_deref(), Some("whitted"));
        assert!(!c.interrupted());
        assert!(!c.take().any());
        c.quit();
        assert!(c.is_quitting() && c.take().quit);
    }

    #[test]
    fn selections_are_checked_against_the_registry() {
        let sel = |i: Option<&str>, p: &[(&str, &str)]| Selection {
            integrator: i.map(String::from),
            params: p
                .iter()
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .collect(),
            sampler: None,
        };
        assert!(sel(Some("path"), &[("max-depth", "3")]).check().is_ok());
        assert!(sel(None, &[("anything", "3")]).check().is_ok());
        let e = sel(Some("nope"), &[]).check().unwrap_err().to_string();
        assert!(e.contains("unknown integrator `nope`"), "{e}");
        let e = sel(Some("path"), &[("max-depth", "-1")])
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("out of range"), "{e}");
    }
}
