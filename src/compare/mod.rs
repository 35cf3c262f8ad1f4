//! `raylab compare`: the same scene under several integrators, at equal samples per pixel or
//! equal time, measured against a reference; writes every image, error maps, the metrics (JSON
//! and CSV), a mosaic, sweep plots and a self-contained page.

mod cache;
pub mod metrics;
mod mosaic;
mod page;
mod plot;
pub mod spectrum;
pub mod stats;
pub mod suite;
mod tables;
pub mod ztest;

pub(crate) use tables::write_text;
use tables::{print_row, print_summary, write_convergence_csv, write_tables};

use crate::output::{self, DisplaySettings};
use crate::render::{self, checkpoint::stable_hash, Film, Job, Request, Target};
use crate::scene::{LoadedScene, RenderScene};
use anyhow::{anyhow, bail, Context, Result};
pub use cache::cache_dir;
use cache::Cache;
use raylab_integrators::registry;
use raylab_integrators::sampler::SamplerKind;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// One render to compare: an integrator with its parameters and its sampler, under a label.
#[derive(Clone, Debug)]
pub struct Contestant {
    /// File name stem and display name.
    pub label: String,
    pub integrator: String,
    pub params: Vec<(String, String)>,
    /// How its camera samples draw their numbers (`-i NAME@SAMPLER`, `--sweep sampler=...`);
    /// `None`: the comparison's `--sampler`, else the scene's.
    pub sampler: Option<SamplerKind>,
    /// The swept parameter and its value, for sweeps.
    pub swept: Option<(String, String)>,
}

/// How much work each contestant gets.
#[derive(Clone, Copy, Debug)]
pub enum Budget {
    /// Equal samples per pixel.
    Spp(u32),
    /// Equal wall time (open-ended progressive passes; at least one pass each).
    Time(Duration),
}

impl Budget {
    /// A budget from a choice of samples per pixel or seconds (`spp_flag` and `time_flag`
    /// name them in messages), `default` when neither is given; both, zero samples, or a time
    /// that is not a positive number of seconds (at most 1e9) are refused.
    pub fn choose(
        spp: Option<u32>,
        time: Option<f64>,
        default: Budget,
        (spp_flag, time_flag): (&str, &str),
    ) -> Result<Budget> {
        match (spp, time) {
            (Some(_), Some(_)) => bail!("give either {spp_flag} or {time_flag}, not both"),
            (Some(0), _) => bail!("{spp_flag} must be at least 1"),
            (Some(n), None) => Ok(Budget::Spp(n)),
            (None, Some(t)) if t.is_finite() && t > 0.0 && t <= 1e9 => {
                Ok(Budget::Time(Duration::from_secs_f64(t)))
            }
            (None, Some(t)) => {
                bail!("{time_flag} must be a positive number of seconds, at most 1e9, got {t}")
            }
            (None, None) => Ok(default),
        }
    }
}

/// Where the reference comes from.
#[derive(Clone, Debug)]
pub enum ReferenceSpec {
    File(PathBuf),
    /// A render by a consistent integrator (`path` by default) under its own budget, cached
    /// by scene and settings.
    Render {
        integrator: String,
        params: Vec<(String, String)>,
        budget: Budget,
    },
}

/// Everything `raylab compare` needs.
#[derive(Clone, Debug)]
pub struct CompareOptions {
    pub scene: PathBuf,
    /// Folders beside the scene's that it may read files from (`--allow-path`).
    pub allowed: Vec<PathBuf>,
    /// `-D` parameters of a Mitsuba XML scene.
    pub import: crate::scene::ImportOptions,
    pub contestants: Vec<Contestant>,
    pub budget: Budget,
    /// Independent runs per contestant (seeds derived from `seed`), at least 1.
    pub runs: u32,
    /// The MSE whose time to reach is reported; `None`: the best contestant's final MSE.
    pub target_error: Option<f64>,
    pub reference: ReferenceSpec,
    pub out_dir: PathBuf,
    pub threads: Option<usize>,
    pub seed: u64,
    pub size: Option<(u32, u32)>,
    /// Where cached references live.
    pub cache_dir: PathBuf,
    pub progress: bool,
    /// Shown at the top of the page and kept in `metrics.json`.
    pub note: Option<String>,
    /// A pixel rectangle measured on its own as well (a caustic, a shadow).
    pub region: Option<Region>,
    /// The accelerator every render is traced with.
    pub accel: crate::accel::AccelKind,
    /// Pixel reconstruction filter for every render and the reference; `None`: the scene's.
    pub filter: Option<raylab_integrators::Filter>,
    /// How every contestant's camera samples draw their numbers; `None`: the scene's. The
    /// reference always renders with independent samples.
    pub sampler: Option<raylab_integrators::sampler::SamplerKind>,
    /// Spectral rendering for every render and the reference; `None`: the scene's.
    pub spectral: Option<bool>,
}

/// A rectangle of pixels: top-left corner `(x, y)`, `w x h`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Region {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

impl std::fmt::Display for Region {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{} at ({}, {})", self.w, self.h, self.x, self.y)
    }
}

/// One row of the results: a contestant's figures over its runs. Values measured per run are
/// means over the runs with the half-width of their 95% interval (`*_ci95`, absent from one
/// run); errors are the reference's noise subtracted (see [`stats`]).
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub label: String,
    pub integrator: String,
    pub params: String,
    /// The sampler its camera samples drew from.
    pub sampler: String,
    pub swept_param: Option<String>,
    pub swept_value: Option<String>,
    pub runs: u32,
    /// Samples (passes) per pixel, mean over the runs.
    pub spp: f64,
    /// Render time in seconds (measuring excluded), mean over the runs.
    pub time: f64,
    pub time_ci95: Option<f64>,
    pub mse: f64,
    pub mse_ci95: Option<f64>,
    /// Per-pixel variance of one run's image across the runs, mean over pixels and channels.
    pub variance: Option<f64>,
    /// Squared bias: MSE of the runs' mean image less `variance / runs`.
    pub bias2: Option<f64>,
    pub relmse: f64,
    pub relmse_ci95: Option<f64>,
    /// relMSE with the largest 0.1% of per-pixel errors left out (SeeSharp's robust relMSE):
    /// a few fireflies do not rank a method by it.
    pub relmse_robust: f64,
    pub relmse_robust_ci95: Option<f64>,
    /// The per-pixel variance of one run times its time: the seconds it would take to bring
    /// the variance down to 1 (variance falling as 1/time); smaller is better. From two runs.
    pub time_to_unit_variance: Option<f64>,
    /// The error spectrum (Celarek et al. 2019): the radially averaged power spectrum of the
    /// error image, mean over the runs, at [`Report::spectrum_frequencies`].
    pub error_spectrum: Vec<f64>,
    /// LDR-FLIP on the displayed images.
    pub flip: f64,
    pub flip_ci95: Option<f64>,
    /// HDR-FLIP on the radiance.
    pub hdrflip: f64,
    pub hdrflip_ci95: Option<f64>,
    /// `1 / (mse x time)`: how much error each second buys away; `None` when the MSE is not
    /// positive (below the reference's noise).
    pub efficiency: Option<f64>,
    /// Seconds to reach the report's target MSE, from the convergence curve.
    pub time_to_target: Option<f64>,
    /// Whether that time lies past the curve's end, along its fitted slope.
    pub time_to_target_extrapolated: bool,
    /// Slope of log MSE against log time (about -1 for an unbiased estimator).
    pub slope: Option<f64>,
    /// The same for relMSE, which a few bright fireflies sway less.
    pub slope_relmse: Option<f64>,
    /// As measured, the reference's noise included: RMSE on radiance, PSNR on the displayed
    /// images (means over the runs).
    pub rmse: f64,
    pub psnr: f64,
    /// The reference's mean variance over this row's measured MSE: how much of the error is
    /// the reference's own noise.
    pub reference_share: Option<f64>,
    /// Pixels of the first run that fail the per-pixel z-test against the reference (1%
    /// significance over the image); `None` below 100 passes (the passes' variance estimates
    /// are then too rough) or when neither image has a variance layer.
    pub ztest_failed_pixels: Option<usize>,
    pub rays_camera: u64,
    pub rays_extension: u64,
    pub rays_shadow: u64,
    pub rays_light: u64,
    pub rays_connection: u64,
    pub rays_per_s: f64,
    pub samples_per_s: f64,
    /// Mean radiance of the runs' mean image.
    pub mean: [f32; 3],
    /// The errors inside the region, if one was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub region: Option<RegionRow>,
    /// The mean convergence curve over the runs.
    pub convergence: Vec<stats::CurvePoint>,
}

/// A row's errors inside `--region`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct RegionRow {
    pub mse: f64,
    pub mse_ci95: Option<f64>,
    pub relmse: f64,
    pub flip: f64,
}

impl Row {
    /// The ray counts (camera, extension, shadow, light, connection) joined by `sep`.
    pub fn rays_joined(&self, sep: &str) -> String {
        [
            self.rays_camera,
            self.rays_extension,
            self.rays_shadow,
            self.rays_light,
            self.rays_connection,
        ]
        .map(|n| n.to_string())
        .join(sep)
    }
}

/// The whole comparison, as written to `metrics.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub budget: String,
    pub reference: String,
    /// The reference's per-pixel variance, mean over pixels and channels; `None` when it has
    /// no variance layer (its noise then stays in every error).
    pub reference_variance: Option<f64>,
    /// Said when the reference is too noisy to rank the contestants, or its noise unknown.
    pub reference_warning: Option<String>,
    /// The MSE `time_to_target` refers to.
    pub target_error: Option<f64>,
    pub runs: u32,
    pub threads: usize,
    pub seed: u64,
    pub note: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub region: Option<Region>,
    /// The frequencies (cycles per pixel) of the rows' `error_spectrum`.
    pub spectrum_frequencies: Vec<f64>,
    pub rows: Vec<Row>,
}

/// Parses `INTEGRATOR.NAME=VALUE` into its three parts.
pub fn parse_scoped_param(text: &str) -> Result<(String, String, String)> {
    let err = || anyhow!("-p `{text}`: expected INTEGRATOR.NAME=VALUE, e.g. -p path.max-depth=8");
    let (lhs, value) = text.split_once('=').ok_or_else(err)?;
    let (integrator, name) = lhs.split_once('.').ok_or_else(err)?;
    Ok((
        integrator.trim().into(),
        name.trim().into(),
        value.trim().into(),
    ))
}

/// A contestant as named on the command line or in a suite, `NAME` or `NAME@SAMPLER`: the
/// integrator's name and the sampler, if one is given.
pub fn parse_contestant(spec: &str) -> Result<(&str, Option<SamplerKind>)> {
    match spec.split_once('@') {
        None => Ok((spec, None)),
        Some((name, sampler)) => {
            let kind = SamplerKind::parse(sampler).map_err(|e| anyhow!("-i {spec}: {e}"))?;
            Ok((name, Some(kind)))
        }
    }
}

/// The parameter key `--sweep` takes for the sampler.
pub const SAMPLER_SWEEP: &str = "sampler";

/// Builds the contestants of a comparison: each integrator (`NAME`, or `NAME@SAMPLER` under a
/// sampler of its own) with the shared parameters that apply to it (`NAME.key=value` applies
/// to every contestant of integrator `NAME`, `NAME@SAMPLER.key=value` to that one), and with
/// a sweep one per value (`sampler` sweeps the sampler).
pub fn contestants(
    integrators: &[String],
    params: &[(String, String, String)],
    sweep: Option<(&str, &[String])>,
) -> Result<Vec<Contestant>> {
    if integrators.is_empty() {
        bail!("name at least one integrator with -i");
    }
    let mut out = Vec::new();
    for spec in integrators {
        let (name, sampler) = parse_contestant(spec)?;
        let entry = registry::find(name)?;
        let own: Vec<(String, String)> = params
            .iter()
            .filter(|(i, _, _)| i == name || i == spec)
            .map(|(_, k, v)| (k.clone(), v.clone()))
            .collect();
        entry.resolve(&own)?;
        let one = |label: String, params, sampler, swept| Contestant {
            label,
            integrator: name.to_string(),
            params,
            sampler,
            swept,
        };
        match sweep {
            None => out.push(one(spec.clone(), own, sampler, None)),
            Some((key, values)) if key == SAMPLER_SWEEP => {
                if sampler.is_some() {
                    bail!("--sweep sampler: -i {spec} names its sampler already");
                }
                for v in values {
                    let kind =
                        SamplerKind::parse(v).map_err(|e| anyhow!("--sweep sampler: {e}"))?;
                    let swept = Some((key.to_string(), v.clone()));
                    out.push(one(
                        format!("{spec}-{key}-{v}"),
                        own.clone(),
                        Some(kind),
                        swept,
                    ));
                }
            }
            Some((key, values)) => {
                if !entry.params.iter().any(|p| p.name == key) {
                    bail!("--sweep: integrator `{name}` has no parameter `{key}`");
                }
                for v in values {
                    let mut p = own.clone();
                    p.push((key.to_string(), v.clone()));
                    entry.resolve(&p)?;
                    let swept = Some((key.to_string(), v.clone()));
                    out.push(one(format!("{spec}-{key}-{v}"), p, sampler, swept));
                }
            }
        }
    }
    for (k, c) in out.iter().enumerate() {
        if out[..k].iter().any(|d| d.label == c.label) {
            match &c.swept {
                Some((key, value)) => {
                    bail!("--sweep {key}: the value `{value}` is given twice")
                }
                None => bail!(
                    "-i {}: each contestant may be named once (use --sweep for several values of a parameter, NAME@SAMPLER for another sampler)",
                    c.label
                ),
            }
        }
    }
    Ok(out)
}

/// The seed of run `k`: the comparison's own for the first, so that one run renders what it
/// always did; the others spread across the seed space.
pub fn run_seed(seed: u64, k: u32) -> u64 {
    seed ^ (k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
}

/// One finished render.
struct Rendered {
    film: Film,
    stats: render::RenderStats,
    /// Seconds spent rendering, the convergence measurements excluded.
    time: f64,
    params: String,
    /// The sampler its camera samples drew from.
    sampler: SamplerKind,
    curve: Vec<stats::CurvePoint>,
}

/// Renders one contestant with `seed`; with a reference, its error is recorded after every
/// log-spaced pass (and at the end) for the convergence curve.
fn render_one(
    loaded: &LoadedScene,
    built: &RenderScene,
    c: &Contestant,
    budget: Budget,
    seed: u64,
    reference: Option<&Film>,
    opts: &CompareOptions,
) -> Result<Rendered> {
    let mut job = contestant_job(loaded, c, budget, seed, opts)?;
    let mut acc = job.accumulation();
    let mut curve = Vec::new();
    // Time spent measuring, which the curve's times and the row's time leave out.
    let mut measuring = Duration::ZERO;
    let stats = job.run(built, &mut acc, &|| false, &mut |acc, stats| {
        if let Some(r) = reference.filter(|_| stats::records(acc.spp_done)) {
            let started = std::time::Instant::now();
            let e = stats::linear_error(&acc.film(), r);
            curve.push(stats::CurvePoint {
                spp: acc.spp_done,
                time: stats.elapsed.saturating_sub(measuring).as_secs_f64(),
                mse: e.mse,
                relmse: e.relmse,
            });
            measuring += started.elapsed();
        }
        Ok(())
    })?;
    let film = acc.film();
    let time = stats.elapsed.saturating_sub(measuring).as_secs_f64();
    if let Some(r) = reference {
        if curve.last().is_none_or(|p| p.spp != stats.spp_done) && stats.spp_done > 0 {
            let e = stats::linear_error(&film, r);
            curve.push(stats::CurvePoint {
                spp: stats.spp_done,
                time,
                mse: e.mse,
                relmse: e.relmse,
            });
        }
    }
    Ok(Rendered {
        film,
        stats,
        time,
        params: job.describe_params(),
        sampler: job.settings.sampler,
        curve,
    })
}

/// The render of contestant `c` with `seed` under `budget`, at the comparison's size, with
/// its filter, threads and accelerator, and exactly the contestant's parameters.
fn contestant_job(
    loaded: &LoadedScene,
    c: &Contestant,
    budget: Budget,
    seed: u64,
    opts: &CompareOptions,
) -> Result<Job> {
    let (target, time) = match budget {
        Budget::Spp(n) => (Target::Spp(n), None),
        Budget::Time(t) => (Target::OpenEnded, Some(t)),
    };
    Job::new(
        loaded,
        &Request {
            integrator: Some(c.integrator.clone()),
            params: c.params.clone(),
            scene_params: false,
            size: opts.size,
            target,
            time,
            seed: Some(seed),
            filter: Some(opts.filter.unwrap_or_default()),
            sampler: c.sampler.or(opts.sampler),
            spectral: opts.spectral,
            threads: opts.threads,
            accel: opts.accel,
            progress: opts.progress,
            shard: None,
        },
    )
}

/// Refuses a reference image (`--reference`, or a cached one) that cannot be measured
/// against: not `width x height`, or holding NaN or infinite pixels.
pub(crate) fn check_reference(film: &Film, width: u32, height: u32, path: &Path) -> Result<()> {
    if (film.width, film.height) != (width, height) {
        bail!(
            "{}: the reference is {}x{}, the renders {width}x{height}",
            path.display(),
            film.width,
            film.height,
        );
    }
    if let Some((count, (x, y))) = film.non_finite() {
        bail!(
            "{}: the reference has {count} pixel(s) with NaN or infinite values, the first at ({x}, {y}); no error can be measured against it",
            path.display()
        );
    }
    Ok(())
}

/// Where a rendered reference is kept: the cache, checked before anything renders, and the
/// key of this scene's reference in it.
struct CacheEntry {
    cache: Cache,
    hash: u64,
}

/// The cache entry of the reference `opts` asks to render of the scene whose identity is
/// `scene_id`, through `camera`; `None` for a reference file. The cache folder is made and
/// tried here, before anything renders.
fn reference_entry(
    opts: &CompareOptions,
    scene_id: u64,
    camera: &crate::scene::Camera,
) -> Result<Option<CacheEntry>> {
    let ReferenceSpec::Render {
        integrator,
        params,
        budget,
    } = &opts.reference
    else {
        return Ok(None);
    };
    let entry = registry::find(integrator)?;
    let described = entry.resolve(params)?.describe(entry.params);
    // The version too: a light-transport fix must not reuse an old reference.
    let key = format!(
        "raylab {} reference {integrator} {described} {} seed={} {}x{} filter={} accel={}",
        env!("CARGO_PKG_VERSION"),
        budget_text(*budget),
        reference_seed(opts.seed),
        camera.width,
        camera.height,
        opts.filter.unwrap_or_default(),
        opts.accel,
    );
    Ok(Some(CacheEntry {
        cache: Cache::open(&opts.cache_dir)?,
        hash: stable_hash(&[&scene_id.to_le_bytes(), key.as_bytes()]),
    }))
}

/// `256 spp` or `4.000 s`.
fn budget_text(budget: Budget) -> String {
    match budget {
        Budget::Spp(n) => format!("{n} spp"),
        Budget::Time(t) => format!("{:.3} s", t.as_secs_f64()),
    }
}

/// The reference render's seed: its own, so that its noise is independent of the renders'.
fn reference_seed(seed: u64) -> u64 {
    seed ^ 0x5eed_5eed_5eed_5eed
}

/// The reference image: a file, or a render by a consistent integrator kept in the cache
/// (`cached`, from [`reference_entry`]).
fn reference(
    opts: &CompareOptions,
    (loaded, built): (&LoadedScene, &RenderScene),
    camera: &crate::scene::Camera,
    cached: Option<&CacheEntry>,
) -> Result<(Film, String)> {
    match (&opts.reference, cached) {
        (ReferenceSpec::File(path), _) => {
            let film = output::read_image(path)?;
            check_reference(&film, camera.width, camera.height, path)?;
            Ok((film, format!("file {}", file_name(path))))
        }
        (
            ReferenceSpec::Render {
                integrator,
                params,
                budget,
            },
            Some(CacheEntry { cache, hash }),
        ) => {
            let entry = registry::find(integrator)?;
            let described = entry.resolve(params)?.describe(entry.params);
            let size = budget_text(*budget);
            // The page names the cache entry, not the folder: a page must not print a path
            // of the machine that made it.
            let what = format!(
                "{integrator} ({described}), {size} (cached as {})",
                file_name(&cache.entry(*hash))
            );
            match cache.read(*hash, camera.width, camera.height) {
                Ok(film) => return Ok((film, what)),
                Err(e) if cache.entry(*hash).symlink_metadata().is_ok() => {
                    note!("warning: not using the cached reference: {e:#}; rendering it anew")
                }
                Err(_) => {}
            }
            let c = Contestant {
                label: "reference".into(),
                integrator: integrator.clone(),
                params: params.clone(),
                sampler: Some(SamplerKind::Independent),
                swept: None,
            };
            note!("rendering the reference: {what}");
            let seed = reference_seed(opts.seed);
            let film = render_one(loaded, built, &c, *budget, seed, None, opts)?.film;
            // The reference is in hand (and copied into the output folder): a cache that
            // fails now costs the next run, not this one.
            if let Err(e) = cache.write(*hash, &film) {
                note!("warning: the reference was not cached: {e:#}");
            }
            Ok((film, what))
        }
        (ReferenceSpec::Render { .. }, None) => bail!("no cache for the reference"),
    }
}

/// The files a comparison writes into `opts.out_dir`, with their roles.
fn output_files(opts: &CompareOptions) -> Vec<(String, PathBuf)> {
    let dir = &opts.out_dir;
    let mut files = vec![
        (
            "the reference's copy".to_string(),
            dir.join("reference.exr"),
        ),
        (
            "the reference's picture".to_string(),
            dir.join("reference.png"),
        ),
    ];
    for c in &opts.contestants {
        for suffix in [".exr", ".png", "-error.png", "-ztest.png"] {
            let name = format!("{}{suffix}", c.label);
            files.push((format!("the comparison's {name}"), dir.join(name)));
        }
    }
    let mut pages = vec![
        "metrics.json",
        "metrics.csv",
        "mosaic.png",
        "index.html",
        "convergence.csv",
        "convergence.svg",
        "convergence.png",
        "spectrum.svg",
        "spectrum.png",
    ];
    // A sampler sweep has no axis of values: its rows sit side by side in the table.
    if opts.contestants.iter().any(|c| {
        c.swept
            .as_ref()
            .is_some_and(|(key, _)| key != SAMPLER_SWEEP)
    }) {
        pages.extend(["sweep.svg", "sweep.png"]);
    }
    for name in pages {
        files.push((format!("the comparison's {name}"), dir.join(name)));
    }
    files
}

/// The file that marks a folder as one raylab wrote a comparison or a suite into: its files
/// of the same names may be replaced by the next run.
pub const OUTPUT_MARKER: &str = ".raylab-output";

/// Takes the folder `dir` for a command's output `files`: made if missing, and marked as
/// raylab's. An existing folder raylab did not make is taken only if none of `files` is there
/// already: a folder of the user's (or the scene's, through a link) keeps its files. Returns
/// whether the folder was made.
pub fn claim_output_folder(dir: &Path, files: &[(String, PathBuf)]) -> Result<bool> {
    check_output_folder(dir, files)?;
    let created = !dir.exists();
    if created {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the output folder", dir.display()))?;
    }
    let marker = dir.join(OUTPUT_MARKER);
    if !marker.is_file() {
        output::atomic::write_atomic(&marker, |f| {
            use std::io::Write as _;
            f.write_all(b"raylab wrote the files of a comparison here; the next run into this folder replaces them\n")
                .with_context(|| format!("{}: cannot write", marker.display()))
        })?;
    }
    Ok(created)
}

/// The check of [`claim_output_folder`], without making or marking anything.
pub fn check_output_folder(dir: &Path, files: &[(String, PathBuf)]) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!(
            "{}: the output folder is a file, not a folder",
            dir.display()
        );
    }
    if dir.exists() && !dir.join(OUTPUT_MARKER).is_file() {
        let there: Vec<&PathBuf> = files
            .iter()
            .map(|(_, f)| f)
            .filter(|f| f.symlink_metadata().is_ok())
            .collect();
        if let Some(first) = there.first() {
            bail!(
                "{}: this folder was not made by raylab and already holds {}{}, which this command would replace; give a new or empty folder",
                dir.display(),
                file_name(first),
                match there.len() {
                    1 => String::new(),
                    n => format!(" and {} more of its output files", n - 1),
                }
            );
        }
    }
    Ok(())
}

/// Runs the comparison and writes everything into `opts.out_dir` (created if missing, and
/// removed again if the comparison fails before writing anything there).
pub fn run(opts: &CompareOptions) -> Result<Report> {
    check_out_dir(opts)?;
    let loaded = crate::scene::load_scene_defined(&opts.scene, &opts.allowed, &opts.import)?;
    run_loaded(opts, &loaded)
}

/// Refuses an output folder that is a file.
fn check_out_dir(opts: &CompareOptions) -> Result<()> {
    if opts.out_dir.exists() && !opts.out_dir.is_dir() {
        bail!(
            "{}: the output folder is a file, not a folder",
            opts.out_dir.display()
        );
    }
    Ok(())
}

/// [`run`] on a scene already loaded (and perhaps edited in memory: its inputs' identity
/// then covers the edits), `opts.scene` naming it in messages.
pub fn run_loaded(opts: &CompareOptions, loaded: &LoadedScene) -> Result<Report> {
    check_out_dir(opts)?;
    // No output may be an input (the scene, every file it read, the reference image).
    let mut plan = crate::render::scene_inputs(&loaded.inputs)?;
    if let ReferenceSpec::File(f) = &opts.reference {
        if f.exists() {
            plan.input("the reference image", f)?;
        }
    }
    let files = output_files(opts);
    for (role, file) in &files {
        plan.output(role, file)?;
    }
    plan.check()?;
    let created = claim_output_folder(&opts.out_dir, &files)?;
    let result = run_into(opts, loaded);
    if result.is_err() && created {
        // Only a folder with nothing but the marker goes: what a failed run wrote stays for
        // inspection.
        let _ = std::fs::remove_file(opts.out_dir.join(OUTPUT_MARKER));
        if std::fs::remove_dir(&opts.out_dir).is_err() {
            let _ = claim_output_folder(&opts.out_dir, &[]);
        }
    }
    result
}

fn run_into(opts: &CompareOptions, loaded: &LoadedScene) -> Result<Report> {
    output::check_writable_folder(&opts.out_dir.join("index.html"))?;
    for w in &loaded.warnings {
        note!("warning: {}: {w}", opts.scene.display());
    }
    // Every render and the reference with one filter: the flag's, else the scene's.
    let opts = &CompareOptions {
        filter: Some(opts.filter.unwrap_or(loaded.render.filter)),
        ..opts.clone()
    };
    let camera = match opts.size {
        Some((w, h)) => loaded.camera.with_resolution(w, h),
        None => loaded.camera.clone(),
    };
    // Every contestant's configuration, checked before anything renders: one that cannot
    // use the camera, or that would not fit in memory beside the film.
    for c in &opts.contestants {
        contestant_job(loaded, c, opts.budget, opts.seed, opts)?;
    }
    if let Some(r) = opts.region {
        if Film::new(camera.width, camera.height)
            .crop(r.x, r.y, r.w, r.h)
            .is_none()
        {
            bail!(
                "--region {r} is not inside the {}x{} image",
                camera.width,
                camera.height
            );
        }
    }
    // The reference's cache, tried before anything renders; keyed by the scene's identity
    // (every file it read, -D values, --approximate).
    let scene_id = match &opts.reference {
        ReferenceSpec::Render { .. } => loaded
            .inputs
            .identity()
            .with_context(|| format!("{}: cannot read scene file", opts.scene.display()))?,
        ReferenceSpec::File(_) => 0,
    };
    let cached = reference_entry(opts, scene_id, &camera)?;
    let built = RenderScene::build_on_threads(loaded, opts.accel, opts.threads)?;
    let (reference, reference_what) = reference(opts, (loaded, &built), &camera, cached.as_ref())?;
    output::write_image(
        &opts.out_dir.join("reference.exr"),
        &reference,
        DisplaySettings::default(),
    )?;
    output::write_image(
        &opts.out_dir.join("reference.png"),
        &reference,
        DisplaySettings::default(),
    )?;

    let mut rows = Vec::new();
    let mut threads = 0;
    for c in &opts.contestants {
        let (row, used) = measure(opts, (loaded, &built), &camera, c, &reference)?;
        threads = used;
        print_row(&row);
        rows.push(row);
    }

    // The time each needs to reach the target error: the given one, else the best final MSE.
    let target_error = opts.target_error.or_else(|| {
        rows.iter()
            .map(|r| r.mse)
            .filter(|m| *m > 0.0)
            .min_by(f64::total_cmp)
    });
    if let Some(target) = target_error {
        for r in &mut rows {
            if let Some((t, extrapolated)) = stats::time_to_reach(&r.convergence, target) {
                // No extrapolation below a measured bias: the error's floor.
                if extrapolated && r.bias2.is_some_and(|b| b >= target) {
                    continue;
                }
                r.time_to_target = Some(t);
                r.time_to_target_extrapolated = extrapolated;
            }
        }
    }
    let reference_variance = reference
        .has_variance
        .then(|| stats::mean_variance(&reference));
    let reference_warning = match reference_variance {
        None => Some(
            "the reference has no variance layer, so its own noise is counted in every error; render references with raylab (2 spp or more) to have it subtracted"
                .to_string(),
        ),
        Some(v) => {
            let smallest = rows
                .iter()
                .map(|r| r.mse + v)
                .filter(|m| *m > 0.0)
                .min_by(f64::total_cmp);
            smallest.filter(|m| v > 0.25 * m).map(|m| {
                format!(
                    "the reference is too noisy to rank these renders: its own variance is {:.0}% of the smallest error it judges (subtracted, but what remains is uncertain); render it longer with --reference-spp or --reference-time",
                    100.0 * v / m
                )
            })
        }
    };
    if let Some(w) = &reference_warning {
        note!("warning: {w}");
    }
    print_summary(&rows, target_error);

    let report = Report {
        scene: file_name(&opts.scene),
        width: camera.width,
        height: camera.height,
        budget: match opts.budget {
            Budget::Spp(n) => format!("equal samples: {n} spp"),
            Budget::Time(t) => format!("equal time: {:.2} s", t.as_secs_f64()),
        },
        reference: reference_what,
        reference_variance,
        reference_warning,
        target_error,
        runs: opts.runs,
        threads,
        seed: opts.seed,
        note: opts.note.clone(),
        region: opts.region,
        spectrum_frequencies: spectrum::frequencies(),
        rows,
    };
    write_tables(&opts.out_dir, &report)?;
    write_convergence_csv(&opts.out_dir, &report)?;
    let convergence = plot::write_convergence_plots(&opts.out_dir, &report)?;
    let spectrum = plot::write_spectrum_plots(&opts.out_dir, &report)?;
    let plots = if report
        .rows
        .iter()
        .any(|r| r.swept_param.as_deref().is_some_and(|k| k != SAMPLER_SWEEP))
    {
        plot::write_sweep_plots(&opts.out_dir, &report)?
    } else {
        None
    };
    mosaic::write(&opts.out_dir, &report)?;
    page::write(
        &opts.out_dir,
        &report,
        (&convergence, &spectrum),
        plots.as_deref(),
    )?;
    Ok(report)
}

/// The fewest passes a render needs for its z-test against the reference to be reported.
const ZTEST_MIN_PASSES: u32 = 100;

/// What one run of a contestant measured.
struct RunFigures {
    error: stats::LinearError,
    relmse_robust: f64,
    flip: f64,
    hdrflip: f64,
    psnr: f64,
    time: f64,
    spp: u32,
    region: Option<(stats::LinearError, f64)>,
}

/// Renders `c` `opts.runs` times, writes its first run's images (render, error map, z-test
/// map) and returns its row and the threads used.
fn measure(
    opts: &CompareOptions,
    (loaded, built): (&LoadedScene, &RenderScene),
    camera: &crate::scene::Camera,
    c: &Contestant,
    reference: &Film,
) -> Result<(Row, usize)> {
    let dir = &opts.out_dir;
    let mut images = stats::RunImages::new(camera.width, camera.height);
    let mut spectra = spectrum::Spectra::new(camera.width, camera.height);
    let mut figures = Vec::new();
    let mut curves = Vec::new();
    let mut first: Option<(Rendered, Option<usize>)> = None;
    for k in 0..opts.runs {
        if opts.progress && opts.runs > 1 {
            note!("{}: run {} of {}", c.label, k + 1, opts.runs);
        }
        let seed = run_seed(opts.seed, k);
        let r = render_one(loaded, built, c, opts.budget, seed, Some(reference), opts)?;
        let (m, flip_map) = metrics::compare(&r.film, reference)?;
        let region = match opts.region {
            Some(g) => {
                let crop = |f: &Film| f.crop(g.x, g.y, g.w, g.h).context("region outside image");
                let (t, rf) = (crop(&r.film)?, crop(reference)?);
                Some((
                    stats::linear_error(&t, &rf),
                    metrics::compare(&t, &rf)?.0.flip,
                ))
            }
            None => None,
        };
        spectra.add(&r.film, reference);
        figures.push(RunFigures {
            error: stats::linear_error(&r.film, reference),
            relmse_robust: stats::robust_relmse(&r.film, reference),
            flip: m.flip,
            hdrflip: metrics::hdr_flip(&r.film, reference).0,
            psnr: m.psnr,
            time: r.time,
            spp: r.stats.spp_done,
            region,
        });
        images.add(&r.film);
        curves.push(r.curve.clone());
        if k == 0 {
            let name = |suffix: &str| dir.join(format!("{}{suffix}", c.label));
            output::write_image(&name(".exr"), &r.film, DisplaySettings::default())?;
            output::write_image(&name(".png"), &r.film, DisplaySettings::default())?;
            output::write_png(
                &name("-error.png"),
                &metrics::error_map_image(&flip_map, r.film.width, r.film.height),
            )?;
            // The test's variances come from the passes: with few, their estimates are too
            // rough (heavy-tailed) for a per-pixel test at a Šidák-corrected level.
            let z = (r.stats.spp_done >= ZTEST_MIN_PASSES)
                .then(|| ztest::z_test(&r.film, reference, 0.01).ok())
                .flatten();
            match &z {
                Some(z) => {
                    output::write_png(&name("-ztest.png"), &ztest::failure_map(z, reference))?
                }
                // No map from an earlier comparison may pass for this one's.
                None => {
                    let _ = std::fs::remove_file(name("-ztest.png"));
                }
            }
            let failed = z.map(|z| z.failed_pixels);
            first = Some((r, failed));
        }
    }
    let (first, ztest_failed_pixels) = first.context("at least one run")?;
    let of = |f: &dyn Fn(&RunFigures) -> f64| {
        stats::Estimate::of(&figures.iter().map(f).collect::<Vec<f64>>())
    };
    let (mse, relmse) = (of(&|f| f.error.mse), of(&|f| f.error.relmse));
    let relmse_robust = of(&|f| f.relmse_robust);
    let variance = images.variance();
    let (flip, hdrflip, time) = (of(&|f| f.flip), of(&|f| f.hdrflip), of(&|f| f.time));
    let mse_raw = of(&|f| f.error.mse_raw).mean;
    let region = opts.region.map(|_| {
        let in_region = |f: &RunFigures| f.region.expect("measured in every run");
        let mse = of(&|f| in_region(f).0.mse);
        RegionRow {
            mse: mse.mean,
            mse_ci95: mse.ci95,
            relmse: of(&|f| in_region(f).0.relmse).mean,
            flip: of(&|f| in_region(f).1).mean,
        }
    });
    let convergence = stats::mean_curve(&curves);
    let runs_done = figures.len() as f64;
    let stats = &first.stats;
    let row = Row {
        label: c.label.clone(),
        integrator: c.integrator.clone(),
        params: first.params.clone(),
        sampler: first.sampler.to_string(),
        swept_param: c.swept.as_ref().map(|s| s.0.clone()),
        swept_value: c.swept.as_ref().map(|s| s.1.clone()),
        runs: opts.runs,
        spp: figures.iter().map(|f| f.spp as f64).sum::<f64>() / runs_done,
        time: time.mean,
        time_ci95: time.ci95,
        mse: mse.mean,
        mse_ci95: mse.ci95,
        variance,
        bias2: images.bias2(reference),
        relmse: relmse.mean,
        relmse_ci95: relmse.ci95,
        relmse_robust: relmse_robust.mean,
        relmse_robust_ci95: relmse_robust.ci95,
        time_to_unit_variance: variance.map(|v| v * time.mean),
        error_spectrum: spectra.mean(),
        flip: flip.mean,
        flip_ci95: flip.ci95,
        hdrflip: hdrflip.mean,
        hdrflip_ci95: hdrflip.ci95,
        efficiency: (mse.mean > 0.0 && time.mean > 0.0).then(|| 1.0 / (mse.mean * time.mean)),
        time_to_target: None,
        time_to_target_extrapolated: false,
        slope: stats::fitted_slope(&convergence, stats::MSE),
        slope_relmse: stats::fitted_slope(&convergence, stats::RELMSE),
        rmse: of(&|f| f.error.mse_raw.sqrt()).mean,
        psnr: of(&|f| f.psnr).mean,
        reference_share: (reference.has_variance && mse_raw > 0.0)
            .then(|| stats::mean_variance(reference) / mse_raw),
        ztest_failed_pixels,
        rays_camera: stats.rays.camera,
        rays_extension: stats.rays.extension,
        rays_shadow: stats.rays.shadow,
        rays_light: stats.rays.light,
        rays_connection: stats.rays.connection,
        rays_per_s: stats.rays_per_second(),
        samples_per_s: stats.samples_per_second(),
        mean: images.mean_film().mean().to_array(),
        region,
        convergence,
    };
    Ok((row, stats.threads))
}

/// The last component of `path`, for pages and reports that must not print where the files
/// of the machine that made them live.
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}
