//! `raylab render --watch` and `raylab serve`: a live session (see [`crate::live`]) that
//! writes the output file after each pass, or shows the render on a local web page.
//!
//! Ctrl-C, as for `raylab render`: the first stops after the current pass (the watch mode
//! writes that last image) and exits 0, a second exits 130 at once.

use super::render_cmd::{parse_param, parse_size};
use super::{RenderArgs, ServeArgs, SessionArgs};
use crate::live::serve;
use crate::live::{self, watch::SceneWatcher, Control, Ended, LiveSettings, Observer, RenderInfo};
use crate::output::{self, DisplaySettings};
use crate::render::{Film, RenderStats};
use anyhow::{bail, Context, Result};
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

/// Shortest time between two writes of the output file (tiny passes would rewrite it
/// thousands of times a second).
const FILE_INTERVAL: Duration = Duration::from_millis(500);
/// Shortest time between two images for the page.
const PAGE_INTERVAL: Duration = Duration::from_millis(200);

/// The live session the shared flags ask for, checked.
fn settings(c: &SessionArgs, interval: Duration) -> Result<(LiveSettings, live::Selection)> {
    if c.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    super::check_threads(c.threads)?;
    super::check_allowed(&c.allow_path)?;
    if !c.exposure.is_finite() {
        bail!("--exposure must be finite");
    }
    if !c.scene.is_file() {
        bail!("{}: no such scene file", c.scene.display());
    }
    let selection = live::Selection {
        integrator: c.integrator.clone(),
        params: c
            .params
            .iter()
            .map(|p| parse_param(p))
            .collect::<Result<Vec<_>>>()?,
        sampler: None,
    };
    selection.check()?;
    Ok((
        LiveSettings {
            scene: c.scene.clone(),
            allowed: c.allow_path.clone(),
            import: c.import.options(),
            size: c.size.as_deref().map(parse_size).transpose()?,
            spp: c.spp,
            seed: c.seed,
            threads: c.threads,
            filter: c.trace.filter,
            sampler: c.trace.sampler,
            spectral: c.trace.spectral(),
            accel: c.trace.accel,
            image_interval: interval,
        },
        selection,
    ))
}

/// Ctrl-C, SIGTERM or SIGHUP: the first asks the session to stop, a later one exits 130 at
/// once (see [`super::interrupt`]).
fn install_interrupt_handler(control: Arc<Control>) {
    super::interrupt::install("stopping (Ctrl-C again to stop at once)", move || {
        control.quit()
    });
}

/// Writes every image to the output file (atomically) and reports on stderr.
struct FileObserver {
    scene: PathBuf,
    output: PathBuf,
    display: DisplaySettings,
    quiet: bool,
    /// Whether this session has written the output yet.
    wrote: bool,
    /// Why the output may not be written: it is one of the files the scene read.
    refused: Option<String>,
}

impl Observer for FileObserver {
    fn render_started(&mut self, info: &RenderInfo) {
        if !self.quiet {
            let until = match info.target_spp {
                Some(n) => format!("to {n} spp"),
                None => "until the next change or Ctrl-C".to_string(),
            };
            note!(
                "rendering {}: {} {} | {}x{} | {until}",
                self.scene.display(),
                info.integrator,
                info.describe_params(),
                info.width,
                info.height
            );
        }
    }

    fn inputs(&mut self, scene: &std::path::Path, files: &[PathBuf]) {
        let inputs = crate::scene::SceneInputs {
            scene: scene.to_path_buf(),
            files: files.to_vec(),
            ..Default::default()
        };
        let plan = crate::render::scene_inputs(&inputs).and_then(|mut plan| {
            plan.output("the image", &self.output)?;
            plan.check()
        });
        self.refused = plan.err().map(|e| format!("{e:#}"));
        if let Some(why) = &self.refused {
            note!("error: {why}; not writing it until the scene stops reading it");
        }
    }

    fn image(&mut self, film: &Film, _info: &RenderInfo, _stats: &RenderStats) {
        if self.refused.is_some() {
            return;
        }
        match output::write_image(&self.output, film, self.display) {
            Ok(()) => self.wrote = true,
            Err(e) => note!("error: {e:#}"),
        }
    }

    fn render_ended(&mut self, info: &RenderInfo, stats: &RenderStats, why: Ended) {
        // A render stopped before its first pass wrote nothing: nothing to report.
        if self.quiet || why == Ended::Changed || stats.spp_done == 0 {
            return;
        }
        let what = match why {
            Ended::Finished => "done",
            _ => "stopped",
        };
        let wrote = match &self.refused {
            None => format!("wrote {}", self.output.display()),
            Some(_) => format!(
                "did not write {} (the scene reads it)",
                self.output.display()
            ),
        };
        note!(
            "{what}: {} {} | {}x{} {} spp | {:.2} s | {:.3} M samples/s | {:.2} M rays/s | {wrote}",
            info.integrator,
            info.describe_params(),
            info.width,
            info.height,
            stats.spp_done,
            stats.elapsed.as_secs_f64(),
            stats.samples_per_second() / 1e6,
            stats.rays_per_second() / 1e6,
        );
    }

    fn reloaded(&mut self, line: &str) {
        if !self.quiet {
            note!("{line}");
        }
    }

    fn load_failed(&mut self, message: &str) {
        note!("error: {message}");
        if self.wrote {
            note!(
                "keeping {} as it was; save the file again to retry",
                self.output.display()
            );
        } else {
            note!("no image yet; save the file again to retry");
        }
    }
}

/// `raylab render SCENE --watch`.
pub fn watch(args: &RenderArgs) -> Result<ExitCode> {
    if args.time.is_some() || args.checkpoint.is_some() || args.resume || args.shard.is_some() {
        bail!(
            "--watch renders until Ctrl-C: --time, --checkpoint, --resume and --shard do not apply"
        );
    }
    let output_path = args
        .output
        .clone()
        .unwrap_or_else(|| super::render_cmd::default_output(&args.session.scene));
    output::check_output_path(&output_path)?;
    let (settings, selection) = settings(&args.session, FILE_INTERVAL)?;
    // The files the scene reads now (a scene that does not load yet: itself); as it changes,
    // each load's (FileObserver::inputs). The session keeps this load for its first render.
    let session = live::Session::load(&settings);
    let mut plan = match session.loaded() {
        Some(loaded) => crate::render::scene_inputs(&loaded.inputs)?,
        None => {
            let mut plan = crate::output::plan::FilePlan::new();
            plan.input("the scene", &args.session.scene)?;
            plan
        }
    };
    plan.output("the image", &output_path)?.check()?;
    let control = Arc::new(Control::new());
    install_interrupt_handler(Arc::clone(&control));
    let watcher = SceneWatcher::start(&args.session.scene, Arc::clone(&control))?;
    if !args.session.quiet {
        note!(
            "watching {} and the files it names; Ctrl-C to stop",
            args.session.scene.display()
        );
    }
    let mut observer = FileObserver {
        scene: args.session.scene.clone(),
        output: output_path,
        display: DisplaySettings {
            exposure: args.session.exposure,
            tonemap: args.session.tonemap,
        },
        quiet: args.session.quiet,
        wrote: false,
        refused: None,
    };
    live::run(
        &settings,
        selection,
        &control,
        &watcher,
        &mut observer,
        session,
    );
    Ok(ExitCode::SUCCESS)
}

/// `raylab serve SCENE`.
pub fn serve(args: &ServeArgs) -> Result<ExitCode> {
    let (settings, selection) = settings(&args.session, PAGE_INTERVAL)?;
    let control = Arc::new(Control::new());
    let shared = serve::Shared::new(&args.session.scene.display().to_string(), selection.clone());
    let server = serve::Server::bind(
        &args.host,
        args.port,
        Arc::clone(&shared),
        Arc::clone(&control),
    )?;
    if !server.addr().ip().is_loopback() {
        note!(
            "warning: serving on {}, reachable from other machines: anyone who can reach it can see the render and change its settings",
            server.addr()
        );
    }
    install_interrupt_handler(Arc::clone(&control));
    let watcher = SceneWatcher::start(&args.session.scene, Arc::clone(&control))?;
    let display = DisplaySettings {
        exposure: args.session.exposure,
        tonemap: args.session.tonemap,
    };
    let session = {
        let control = Arc::clone(&control);
        let quiet = args.session.quiet;
        std::thread::Builder::new()
            .name("raylab-session".into())
            .spawn(move || {
                let mut observer = serve::PageObserver::new(shared, display, quiet);
                let first = live::Session::load(&settings);
                live::run(
                    &settings,
                    selection,
                    &control,
                    &watcher,
                    &mut observer,
                    first,
                );
            })
            .context("cannot start the render thread")?
    };
    say!("serving {}", server.url());
    let _ = std::io::stdout().flush();
    server.run();
    if session.join().is_err() {
        bail!("the render thread panicked");
    }
    Ok(ExitCode::SUCCESS)
}
