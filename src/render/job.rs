//! A render job: everything one render needs, settled once from a loaded scene and a
//! [`Request`] (the command line's flags, the live page's selection, a comparison's
//! contestant, a script's call): the integrator chosen, built and checked against the camera
//! and the machine's memory, the camera at its size, the render settings, a shard's part,
//! and the identity that ties checkpoints and shards to all of it.
//!
//! `render`, `render --watch`, `serve`, `compare` (and so `suite`) and `render --shard`
//! build their renders here, and `merge` checks parts against the text [`Job::settings_text`]
//! wrote into them, so a setting means the same in every command.

use super::checkpoint;
use super::shard::{Part, ShardSpec};
use super::{Accumulation, Filter, RenderSettings, RenderStats};
use crate::accel::AccelKind;
use crate::scene::{Camera, LoadedScene, RenderScene};
use anyhow::{anyhow, bail, Context, Result};
use raylab_integrators::registry::{self, IntegratorEntry, Params};
use raylab_integrators::sampler::SamplerKind;
use raylab_integrators::Integrator;
use std::time::Duration;

/// What a render is asked for; what it leaves unset, the scene decides.
#[derive(Clone, Debug, Default)]
pub struct Request {
    /// The integrator's name; `None`: the scene's.
    pub integrator: Option<String>,
    /// Parameters (name, value text), over the scene's for its own integrator.
    pub params: Vec<(String, String)>,
    /// Whether the scene's parameters apply when its own integrator renders (render, serve:
    /// yes; a comparison gives each contestant exactly its own).
    pub scene_params: bool,
    /// The image size; `None`: the camera's.
    pub size: Option<(u32, u32)>,
    /// Samples per pixel to reach (see [`Target`]).
    pub target: Target,
    /// Stop when this much time has passed.
    pub time: Option<Duration>,
    /// `None`: the scene's seed.
    pub seed: Option<u64>,
    /// `None`: the scene's filter.
    pub filter: Option<Filter>,
    /// `None`: the scene's sampler.
    pub sampler: Option<SamplerKind>,
    /// Spectral rendering (`--spectral`); `None`: the scene's `render.spectral`.
    pub spectral: Option<bool>,
    /// Worker threads; `None`: every core.
    pub threads: Option<usize>,
    pub accel: AccelKind,
    /// Draw a progress bar on stderr.
    pub progress: bool,
    /// The shard of the render this run is.
    pub shard: Option<ShardSpec>,
}

/// How many samples per pixel a render takes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Target {
    /// The scene's `render.spp`, unless a time budget is given (then open-ended).
    #[default]
    Scene,
    /// Exactly this many.
    Spp(u32),
    /// Until stopped (a live session, a time budget).
    OpenEnded,
}

/// A render, ready to run.
pub struct Job {
    pub entry: &'static IntegratorEntry,
    pub params: Params,
    pub integrator: Box<dyn Integrator>,
    pub camera: Camera,
    pub settings: RenderSettings,
    pub accel: AccelKind,
    /// The shard this run renders, and its part of the render.
    pub shard: Option<(ShardSpec, Part)>,
}

/// The integrator for `loaded`: `integrator`, else the scene's. With `scene_params`, the
/// scene's parameters apply to the scene's own integrator; `given` (name, value text)
/// overrides them.
pub fn choose_integrator(
    loaded: &LoadedScene,
    integrator: Option<&str>,
    given: &[(String, String)],
    scene_params: bool,
) -> Result<(&'static IntegratorEntry, Params)> {
    let name = integrator.unwrap_or(&loaded.render.integrator);
    let entry = registry::find(name)?;
    let mut all: Vec<(String, String)> = Vec::new();
    if scene_params && name == loaded.render.integrator {
        all.extend(
            loaded
                .render
                .params
                .iter()
                .map(|(k, v)| (k.clone(), format!("{v}"))),
        );
    }
    all.extend(given.iter().cloned());
    let params = entry
        .resolve(&all)
        .map_err(|e| anyhow!("{}: {e}", loaded.path.display()))?;
    Ok((entry, params))
}

/// Refuses a scene with participating media for an integrator that does not render them
/// (debug views show the surfaces, which media do not hide from them), and one with emitting
/// media for one that renders only scattering ones.
fn check_media(loaded: &LoadedScene, entry: &IntegratorEntry) -> Result<()> {
    use raylab_integrators::registry::MediaSupport;
    let media = &loaded.media;
    if media.media.is_empty() || entry.summary.starts_with("debug view") {
        return Ok(());
    }
    let able = |full: bool| -> String {
        let names: Vec<&str> = raylab_integrators::REGISTRY
            .iter()
            .filter(|e| e.media == MediaSupport::Full || (!full && e.media.any()))
            .map(|e| e.name)
            .collect();
        names.join(", ")
    };
    match entry.media {
        MediaSupport::None => bail!(
            "{}: the scene has participating media ({}), which integrator `{}` does not render (it would treat them as vacuum); integrators that do: {}",
            loaded.path.display(),
            media.names.join(", "),
            entry.name,
            able(false)
        ),
        MediaSupport::Scattering => {
            let emitting: Vec<&str> = media
                .media
                .iter()
                .zip(&media.names)
                .filter(|(m, _)| m.is_emissive())
                .map(|(_, n)| n.as_str())
                .collect();
            if !emitting.is_empty() {
                bail!(
                    "{}: medium {} emits light, which integrator `{}` does not render (its light paths do not start in media); integrators that do: {}",
                    loaded.path.display(),
                    emitting.join(", "),
                    entry.name,
                    able(true)
                );
            }
            Ok(())
        }
        MediaSupport::Full => Ok(()),
    }
}

/// The error of a shard asked for an open-ended render.
pub fn shard_needs_passes(spec: ShardSpec) -> anyhow::Error {
    anyhow!(
        "--shard {spec}: a time budget renders as many passes as a machine manages, which \
         shards cannot agree on; give --spp (or the scene's render.spp)"
    )
}

impl Job {
    /// The job `request` asks of `loaded`, checked: an integrator that cannot use the camera,
    /// or an image and integrator buffers that would not fit in memory, are errors here,
    /// before anything is built.
    pub fn new(loaded: &LoadedScene, request: &Request) -> Result<Job> {
        let (entry, params) = choose_integrator(
            loaded,
            request.integrator.as_deref(),
            &request.params,
            request.scene_params,
        )?;
        let integrator = entry.build_checked(&params)?;
        check_media(loaded, entry)?;
        let camera = match request.size {
            Some((w, h)) => loaded.camera.with_resolution(w, h),
            None => loaded.camera.clone(),
        };
        let spp = match (request.target, request.time) {
            (Target::Spp(n), _) => Some(n),
            (Target::OpenEnded, _) | (Target::Scene, Some(_)) => None,
            (Target::Scene, None) => Some(loaded.render.spp),
        };
        if spp == Some(0) {
            bail!("{}: render.spp must be at least 1", loaded.path.display());
        }
        let demand = integrator.demand();
        super::check_memory(
            camera.width,
            camera.height,
            demand.memory_for(camera.width as u64 * camera.height as u64),
        )?;
        super::check_camera(&camera, &demand, entry.name)?;
        // A shard's part: a range of passes, or of rows for an integrator with state per pixel.
        let shard = match (request.shard, spp) {
            (Some(spec), Some(spp)) => Some((
                spec,
                spec.part(integrator.work(&camera).shard_by(), spp, camera.height)?,
            )),
            (Some(spec), None) => return Err(shard_needs_passes(spec)),
            (None, _) => None,
        };
        let settings = RenderSettings {
            spp,
            seed: request.seed.unwrap_or(loaded.render.seed),
            threads: request.threads,
            progress: request.progress,
            time_budget: request.time,
            filter: request.filter.unwrap_or(loaded.render.filter),
            sampler: request.sampler.unwrap_or(loaded.render.sampler),
            spectral: request.spectral.unwrap_or(loaded.render.spectral),
            part: shard.as_ref().map(|(_, part)| part.clone()),
        };
        Ok(Job {
            entry,
            params,
            integrator,
            camera,
            settings,
            accel: request.accel,
            shard,
        })
    }

    /// The parameters as `name=value` pairs, every one with its value.
    pub fn describe_params(&self) -> String {
        self.params.describe(self.entry.params)
    }

    /// "64 spp" or "open-ended", and the shard's part.
    pub fn target_text(&self) -> String {
        let mut target = self
            .settings
            .spp
            .map_or_else(|| "open-ended".to_string(), |n| format!("{n} spp"));
        if let Some((spec, part)) = &self.shard {
            target = format!("{target}, shard {spec}: {part}");
        }
        target
    }

    /// Everything about the render but the scene, as text: written into shards (which
    /// `merge` compares) and hashed into checkpoints.
    pub fn settings_text(&self) -> String {
        let mode = if self.settings.spectral {
            " spectral"
        } else {
            ""
        };
        format!(
            "integrator={} {} spp={} seed={} size={}x{} filter={} accel={} sampler={}{mode}",
            self.entry.name,
            self.describe_params(),
            self.settings
                .spp
                .map_or("open-ended".to_string(), |n| n.to_string()),
            self.settings.seed,
            self.camera.width,
            self.camera.height,
            self.settings.filter,
            self.accel,
            self.settings.sampler,
        )
    }

    /// The scene's identity (every file it read, its -D values and --approximate; reads
    /// and hashes them) and the job's: the scene's with the settings, the exact parameters,
    /// raylab's version and the shard. A checkpoint resumes only the same job.
    pub fn identity(&self, loaded: &LoadedScene) -> Result<(u64, u64)> {
        let scene = loaded
            .inputs
            .identity()
            .with_context(|| format!("{}: cannot read scene file", loaded.path.display()))?;
        let job = checkpoint::stable_hash(&[
            &scene.to_le_bytes(),
            self.settings_text().as_bytes(),
            // The parameters exactly (the text rounds floats to nine digits).
            format!("{:?}", self.params).as_bytes(),
            env!("CARGO_PKG_VERSION").as_bytes(),
            self.shard
                .as_ref()
                .map(|(s, _)| s.to_string())
                .unwrap_or_default()
                .as_bytes(),
        ]);
        Ok((scene, job))
    }

    /// The images the integrator writes beside the main one (`bdpt`'s strategies), each with
    /// the name of its file.
    pub fn layers(&self) -> Vec<(u32, String)> {
        self.integrator.layers()
    }

    /// A fresh accumulation for this job: the image's size, the shard's first pass, one
    /// image per layer.
    pub fn accumulation(&self) -> Accumulation {
        let layers: Vec<u32> = self.layers().iter().map(|(id, _)| *id).collect();
        Accumulation::new(self.camera.width, self.camera.height)
            .starting_at(self.first_pass())
            .with_layers(&layers)
    }

    /// The pass this run starts at: a shard's first, else 0.
    pub fn first_pass(&self) -> u32 {
        match &self.shard {
            Some((_, Part::Passes(r))) => r.start,
            _ => 0,
        }
    }

    /// Builds the render scene of `loaded` with this job's accelerator and threads.
    pub fn build_scene(&self, loaded: &LoadedScene) -> Result<RenderScene> {
        RenderScene::build_on_threads(loaded, self.accel, self.settings.threads)
    }

    /// Renders pass after pass into `acc` until the target, a spent time budget or `stop`;
    /// `after_pass` sees the accumulation after each.
    pub fn run(
        &mut self,
        scene: &RenderScene,
        acc: &mut Accumulation,
        stop: &(dyn Fn() -> bool + Sync),
        after_pass: &mut dyn FnMut(&Accumulation, &RenderStats) -> Result<()>,
    ) -> Result<RenderStats> {
        super::render_passes(
            scene,
            &self.camera,
            self.integrator.as_mut(),
            &self.settings,
            acc,
            stop,
            after_pass,
        )
    }
}
