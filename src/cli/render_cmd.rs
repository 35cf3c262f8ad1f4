//! `raylab render`, `raylab validate` and `raylab integrators`.

use super::RenderArgs;
use crate::output::{self, DisplaySettings};
use crate::render::shard_file::{self, ShardInfo};
use crate::render::{
    self, checkpoint, Accumulation, Dropped, Job, Part, RenderStats, Request, ShardSpec,
    StopReason, Target,
};
use crate::scene::RenderScene;
use crate::scene::{self, describe::check_size};
use anyhow::{anyhow, bail, Context, Result};
use raylab_integrators::{registry, ParamKind};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Shortest time between two checkpoint writes.
const CHECKPOINT_INTERVAL: Duration = Duration::from_secs(2);

/// Rendering time between two checkpoint writes, in units of the last write's time.
const CHECKPOINT_SHARE: u32 = 10;

/// Parses `WxH`.
pub(super) fn parse_size(text: &str) -> Result<(u32, u32)> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| anyhow!("--size `{text}`: expected WIDTHxHEIGHT, e.g. 400x400"))?;
    let parse = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|_| anyhow!("--size `{text}`: `{s}` is not a whole number"))
    };
    let (w, h) = (parse(w)?, parse(h)?);
    check_size(w, h).map_err(|e| anyhow!("--size: {e}"))?;
    Ok((w, h))
}

/// Parses `NAME=VALUE`.
pub(super) fn parse_param(text: &str) -> Result<(String, String)> {
    let (k, v) = text
        .split_once('=')
        .ok_or_else(|| anyhow!("-p `{text}`: expected NAME=VALUE, e.g. -p max-depth=8"))?;
    Ok((k.trim().to_string(), v.trim().to_string()))
}

/// `NAME.png` for scene `NAME.ron`, in the current folder.
/// Where the image of a layer named `name` goes: beside `output`, as `STEM_NAME.EXT`.
fn layer_path(output: &Path, name: &str) -> PathBuf {
    let stem = output.file_stem().unwrap_or_default().to_string_lossy();
    let ext = output
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    output.with_file_name(format!("{stem}_{name}{ext}"))
}

pub(super) fn default_output(scene: &Path) -> PathBuf {
    let stem = scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".into());
    PathBuf::from(format!("{stem}.png"))
}

pub fn render(args: &RenderArgs) -> Result<ExitCode> {
    // Check everything cheap before loading and rendering.
    let output_path = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.session.scene));
    if output::check_output_path(&output_path)? != output::OutputFormat::Exr && args.xyz {
        bail!(
            "{}: --xyz writes an EXR (-o FILE.exr)",
            output_path.display()
        );
    }
    if args.session.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    super::check_threads(args.session.threads)?;
    super::check_allowed(&args.session.allow_path)?;
    if let Some(t) = args.time {
        if !(t.is_finite() && t > 0.0 && t <= 1e9) {
            bail!("--time must be a positive number of seconds, at most 1e9, got {t}");
        }
    }
    if args.resume && args.checkpoint.is_none() {
        bail!("--resume needs --checkpoint FILE");
    }
    let shard = args
        .shard
        .as_deref()
        .map(str::parse::<ShardSpec>)
        .transpose()?;
    if let Some(spec) = shard {
        if args.time.is_some() {
            return Err(render::job::shard_needs_passes(spec));
        }
        if output::check_output_path(&output_path)? != output::OutputFormat::Exr {
            bail!(
                "{}: a shard is written as EXR (its exact sums for `raylab merge`); use -o part-{}.exr",
                output_path.display(),
                spec.index
            );
        }
    }
    if let Some(c) = &args.checkpoint {
        if !args.resume {
            output::check_writable_folder(c)?;
            output::atomic::check_replaceable(c)?;
        }
    }
    if !args.session.exposure.is_finite() {
        bail!("--exposure must be finite");
    }
    let size = args.session.size.as_deref().map(parse_size).transpose()?;
    let cli_params = args
        .session
        .params
        .iter()
        .map(|p| parse_param(p))
        .collect::<Result<Vec<_>>>()?;

    let loaded = scene::load_scene_defined(
        &args.session.scene,
        &args.session.allow_path,
        &args.session.import.options(),
    )?;
    for w in &loaded.warnings {
        note!("warning: {}: {w}", args.session.scene.display());
    }
    // No output may be an input or another output: the scene and every file it read.
    let mut plan = render::scene_inputs(&loaded.inputs)?;
    plan.output("the image", &output_path)?;
    if let Some(c) = &args.checkpoint {
        plan.output("the checkpoint", c)?;
    }
    plan.check()?;
    let mut job = Job::new(
        &loaded,
        &Request {
            integrator: args.session.integrator.clone(),
            params: cli_params,
            scene_params: true,
            size,
            target: args.session.spp.map_or(Target::Scene, Target::Spp),
            time: args.time.map(Duration::from_secs_f64),
            seed: args.session.seed,
            filter: args.session.trace.filter,
            sampler: args.session.trace.sampler,
            spectral: args.session.trace.spectral(),
            threads: args.session.threads,
            accel: args.session.trace.accel,
            progress: !args.session.quiet,
            shard,
        },
    )?;
    let name = job.entry.name;
    // Images the integrator writes beside the output (`bdpt`'s strategies): checked as
    // outputs too, and not kept by checkpoints.
    let layers: Vec<(u32, PathBuf)> = job
        .layers()
        .into_iter()
        .map(|(id, layer)| (id, layer_path(&output_path, &layer)))
        .collect();
    if !layers.is_empty() {
        if let Some(spec) = shard {
            bail!(
                "--shard {spec}: integrator `{name}` writes an image per layer (write-strategies), which shards do not merge; render without write-strategies"
            );
        }
        if args.checkpoint.is_some() {
            bail!(
                "integrator `{name}` writes an image per layer (write-strategies), which checkpoints do not keep; render without --checkpoint"
            );
        }
        let mut plan = render::scene_inputs(&loaded.inputs)?;
        plan.output("the image", &output_path)?;
        for (_, path) in &layers {
            output::check_output_path(path)?;
            plan.output("a layer's image", path)?;
        }
        plan.check()?;
    }
    let (camera, spp, part) = (
        job.camera.clone(),
        job.settings.spp,
        job.shard.as_ref().map(|(_, p)| p.clone()),
    );
    // Checkpoints and shards are tied to everything that determines the image: the settings
    // and the scene's identity (read and hashed only when needed); a checkpoint also to its
    // shard.
    let (scene_hash, hash) = match (&args.checkpoint, shard) {
        (None, None) => (0, 0),
        _ => job.identity(&loaded)?,
    };
    let mut acc = match (&args.checkpoint, args.resume) {
        (Some(path), true) => {
            let acc = checkpoint::load(path, hash, camera.width, camera.height)?;
            let first_pass = job.first_pass();
            if acc.first_pass != first_pass {
                bail!(
                    "{}: the checkpoint starts at pass {}, this render at pass {first_pass}",
                    path.display(),
                    acc.first_pass
                );
            }
            let end = match &part {
                Some(Part::Passes(r)) => Some(r.end),
                _ => spp,
            };
            if let Some(target) = end.filter(|t| acc.spp_done > *t) {
                bail!(
                    "{}: the checkpoint has {} spp, more than the target {target}",
                    path.display(),
                    acc.spp_done
                );
            }
            if !args.session.quiet {
                note!("resuming from {} at {} spp", path.display(), acc.spp_done);
            }
            acc
        }
        _ => job.accumulation(),
    };

    if args.check {
        let what = match (shard, &part) {
            (Some(spec), Some(part)) => format!(", shard {spec}: {part}"),
            _ => String::new(),
        };
        note!(
            "{}: ok: would render {}x{} with {}{what}, writing {}",
            args.session.scene.display(),
            camera.width,
            camera.height,
            name,
            output_path.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    let built = job.build_scene(&loaded)?;
    // Ctrl-C, SIGTERM, SIGHUP: the first abandons the pass in progress and writes the image
    // of the passes done, the second stops at once.
    super::interrupt::install(
        "stopping, writing the image of the passes done (Ctrl-C again to stop at once)",
        || {},
    );
    let stop = super::interrupt::stopping;
    if !args.session.quiet {
        note!(
            "rendering {}x{} with {name}, {} (Ctrl-C writes the image of the passes done)",
            camera.width,
            camera.height,
            job.target_text()
        );
    }
    // Checkpoints: while rendering, at most every few seconds and never more than a tenth of
    // the time (a 4K render's checkpoint is gigabytes); once at the end.
    let mut last_save: Option<(Instant, Duration)> = None;
    let mut after_pass = |acc: &Accumulation, _: &RenderStats| -> Result<()> {
        if let Some(path) = &args.checkpoint {
            let due = last_save.is_none_or(|(t, took)| {
                t.elapsed() >= CHECKPOINT_INTERVAL.max(took * CHECKPOINT_SHARE)
            });
            if due {
                let start = Instant::now();
                checkpoint::save(path, acc, hash)?;
                last_save = Some((Instant::now(), start.elapsed()));
            }
        }
        Ok(())
    };
    let stats = job.run(&built, &mut acc, &stop, &mut after_pass)?;
    if let Some(path) = &args.checkpoint {
        checkpoint::save(path, &acc, hash)?;
    }
    if acc.passes() == 0 {
        bail!("stopped before the first pass finished: no image written");
    }
    let film = acc.film();
    let display = DisplaySettings {
        exposure: args.session.exposure,
        tonemap: args.session.tonemap,
    };
    match (shard, part, spp) {
        (Some(spec), Some(part), Some(spp)) => shard_file::write(
            &output_path,
            &acc,
            &ShardInfo {
                scene: format!("{scene_hash:016x}"),
                scene_name: args
                    .session
                    .scene
                    .file_name()
                    .map_or(String::new(), |n| n.to_string_lossy().into_owned()),
                settings: job.settings_text(),
                version: env!("CARGO_PKG_VERSION").to_string(),
                spec,
                part,
                spp,
                passes_done: acc.spp_done,
                dropped: acc.dropped_so_far(),
                display,
                width: camera.width,
                height: camera.height,
            },
        )?,
        _ if args.xyz => output::write_exr_xyz(&output_path, &film)?,
        _ => output::write_image(&output_path, &film, display)?,
    }

    for (id, path) in &layers {
        if let Some(film) = acc.layer_film(*id) {
            output::write_image(
                path,
                &film,
                DisplaySettings {
                    exposure: args.session.exposure,
                    tonemap: args.session.tonemap,
                },
            )?;
        }
    }

    match stats.stopped {
        Some(StopReason::Interrupted) => note!(
            "interrupted: wrote the image with {} spp{}",
            acc.spp_done,
            spp.map_or(String::new(), |n| format!(" of {n}"))
        ),
        Some(StopReason::TimeBudget) => {
            note!("time budget spent: {} spp", acc.spp_done)
        }
        _ => {}
    }
    if let Dropped {
        count,
        first: Some(first),
    } = stats.dropped
    {
        note!(
            "warning: dropped {} non-finite or out-of-range sample(s); first at pixel ({}, {}) sample {}",
            count,
            first.x,
            first.y,
            first.sample
        );
    }
    if !args.session.quiet {
        let secs = stats.elapsed.as_secs_f64();
        let mean = film.mean();
        note!(
            "{}: {} {} | {}x{} {} spp | {:.2} s, {} threads | {:.3} M samples/s | {:.2} M rays/s (camera {}, extension {}, shadow {}, light {}, connection {}) | mean radiance ({:.4}, {:.4}, {:.4}) | wrote {}",
            args.session.scene.display(),
            name,
            job.describe_params(),
            camera.width,
            camera.height,
            acc.spp_done,
            secs,
            stats.threads,
            stats.samples_per_second() / 1e6,
            stats.rays_per_second() / 1e6,
            stats.rays.camera,
            stats.rays.extension,
            stats.rays.shadow,
            stats.rays.light,
            stats.rays.connection,
            mean.x,
            mean.y,
            mean.z,
            output_path.display()
        );
    }
    // A shard that stopped before the end of its part is not done: a scheduler must see it
    // fail (and retry it, resuming from its checkpoint), and merge refuses its part.
    if let (Some(spec), Some(_)) = (shard, stats.stopped) {
        note!(
            "shard {spec} stopped before the end of its part: run it again with --checkpoint FILE --resume (exit {UNFINISHED_SHARD})"
        );
        return Ok(ExitCode::from(UNFINISHED_SHARD));
    }
    Ok(ExitCode::SUCCESS)
}

/// The exit code of a shard stopped before the end of its part (BSD's EX_TEMPFAIL: try
/// again).
pub const UNFINISHED_SHARD: u8 = 75;

/// `raylab import`: a Mitsuba 3 XML or pbrt-v4 scene written out as RON, checked by loading
/// it the way `render` would before anything is written. The RON file may be none of the
/// files the scene reads.
pub fn import(
    path: &Path,
    output: &Path,
    report: bool,
    allowed: &[PathBuf],
    options: &scene::ImportOptions,
) -> Result<ExitCode> {
    if !scene::is_imported(path) {
        bail!(
            "{}: import reads Mitsuba 3 XML (.xml) and pbrt-v4 (.pbrt) scenes; this is neither",
            path.display()
        );
    }
    if !output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("ron"))
    {
        bail!(
            "{}: import writes a RON scene; name it FILE.ron",
            output.display()
        );
    }
    let folder = |p: &Path| {
        let parent = crate::output::atomic::parent_dir(p);
        std::fs::canonicalize(parent).unwrap_or_else(|_| parent.to_path_buf())
    };
    if folder(path) != folder(output) {
        bail!(
            "{}: write the RON scene into the imported scene's folder ({}), where the files it names are",
            output.display(),
            crate::output::atomic::parent_dir(path).display()
        );
    }
    output::atomic::check_replaceable(output)?;
    let files = crate::formats::access::SceneFiles::new(path, &options.readable(allowed));
    let Some(imported) = scene::import_scene(&files, options)? else {
        bail!("{}: not a scene of another format", path.display());
    };
    // The same checks as rendering it: a scene that will not load is not written.
    let loaded = scene::load::load_imported(&imported, &files, options)?;
    let mut plan = render::scene_inputs(&loaded.inputs)?;
    plan.output("the RON scene", output)?.check()?;
    let ron = imported
        .ron()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    crate::output::atomic::write_atomic(output, |f| {
        use std::io::Write as _;
        f.write_all(ron.as_bytes())
            .with_context(|| format!("{}: cannot write (is the disk full?)", output.display()))
    })?;
    note!("{}: wrote {}", path.display(), output.display());
    if report {
        say!("| what | how raylab reads it |");
        say!("|---|---|");
        for line in &imported.report {
            let (what, how) = line.split_once(": ").unwrap_or(("", line));
            say!("| {what} | {how} |");
        }
    }
    Ok(ExitCode::SUCCESS)
}

pub fn validate(
    path: &Path,
    allowed: &[PathBuf],
    options: &scene::ImportOptions,
) -> Result<ExitCode> {
    let loaded = scene::load_scene_defined(path, allowed, options)?;
    for w in &loaded.warnings {
        note!("warning: {}: {w}", path.display());
    }
    let built = RenderScene::build(&loaded);
    let s = &built.stats;
    let (lo, hi) = raylab_integrators::Scene::bounds(&built);
    say!("{}: ok", path.display());
    say!("  entities   {}", s.entities);
    say!("  materials  {}", loaded.material_names.len());
    say!("  triangles  {}", s.triangles);
    say!("  spheres    {}", s.spheres);
    if s.quadrics > 0 {
        say!("  disks and cylinders {}", s.quadrics);
    }
    if s.curve_pieces > 0 {
        say!("  curve pieces {}", s.curve_pieces);
    }
    if s.instances > 0 {
        say!(
            "  instances  {} of {} mesh(es): {} triangles held once, {} placed",
            s.instances,
            loaded.meshes.len(),
            s.instanced_triangles,
            s.placed_triangles
        );
    }
    say!(
        "  memory     {:.1} MB of geometry and BVHs",
        built.memory_bytes() as f64 / 1e6
    );
    say!(
        "  emitters   {} ({} light table entries)",
        s.emitters,
        s.lights
    );
    say!(
        "  camera     {}x{}",
        loaded.camera.width,
        loaded.camera.height
    );
    say!(
        "  bounds     ({:.3}, {:.3}, {:.3}) .. ({:.3}, {:.3}, {:.3})",
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z
    );
    let own = match s.own_bvh_meshes {
        0 => String::new(),
        n => format!(" ({n} large mesh(es) with a BVH of their own)"),
    };
    say!(
        "  bvh        {} nodes{own}, built in {:.2} ms",
        s.bvh_nodes,
        s.build_time.as_secs_f64() * 1e3
    );
    Ok(ExitCode::SUCCESS)
}

/// The text of `raylab integrators`.
pub fn integrators_listing() -> String {
    let mut out = String::new();
    for e in registry::REGISTRY {
        let _ = writeln!(out, "{}\n    {}", e.name, e.summary);
        match e.media {
            registry::MediaSupport::None => {}
            registry::MediaSupport::Scattering => {
                let _ = writeln!(out, "    renders participating media (not emitting ones)");
            }
            registry::MediaSupport::Full => {
                let _ = writeln!(out, "    renders participating media");
            }
        }
        let _ = writeln!(out, "    {}", e.spectral.describe());
        for p in e.params {
            let kind = match p.kind {
                ParamKind::Choice(names) => names.join("|"),
                kind => kind.name().to_string(),
            };
            let _ = writeln!(
                out,
                "    -p {}=<{}>  (default {})  {}",
                p.name,
                kind,
                p.default_text(),
                p.doc
            );
        }
        out.push('\n');
    }
    out.push_str(raylab_integrators::DEPTH_CONVENTION);
    out.push('\n');
    out.push_str("participating media: only the integrators marked \"renders participating media\" take a scene with media; the others refuse it rather than render it as vacuum\n");
    out
}
