//! `raylab compare`: the same scene under several integrators, at equal samples per pixel or
//! equal time, measured against a reference; writes every image, error maps, the metrics (JSON
//! and CSV), a mosaic, sweep plots and a self-contained page.

pub mod metrics;
mod mosaic;
mod page;
mod plot;

use crate::output::{self, DisplaySettings};
use crate::render::{self, checkpoint::stable_hash, Accumulation, Film, RenderSettings};
use crate::scene::RenderScene;
use anyhow::{anyhow, bail, Context, Result};
use metrics::Metrics;
use raylab_integrators::registry;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// One render to compare: an integrator with its parameters, under a label.
#[derive(Clone, Debug)]
pub struct Contestant {
    /// File name stem and display name.
    pub label: String,
    pub integrator: String,
    pub params: Vec<(String, String)>,
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

/// Where the reference comes from.
#[derive(Clone, Debug)]
pub enum ReferenceSpec {
    File(PathBuf),
    /// A `path` render at this many spp (unlimited depth), cached by scene and settings.
    Spp(u32),
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

/// One row of the results.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub label: String,
    pub integrator: String,
    pub params: String,
    pub swept_param: Option<String>,
    pub swept_value: Option<String>,
    pub spp: u32,
    pub time_s: f64,
    pub rays_camera: u64,
    pub rays_extension: u64,
    pub rays_shadow: u64,
    pub rays_light: u64,
    pub rays_connection: u64,
    pub rays_per_s: f64,
    pub samples_per_s: f64,
    pub mean: [f32; 3],
    #[serde(flatten)]
    pub metrics: Metrics,
    /// The same metrics inside the region, if one was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub region: Option<Metrics>,
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
    pub threads: usize,
    pub seed: u64,
    pub note: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub region: Option<Region>,
    pub rows: Vec<Row>,
}

/// Builds the contestants of a comparison: each integrator with the shared parameters that
/// apply to it (`NAME.key=value`), and with a sweep one per value.
pub fn contestants(
    integrators: &[String],
    params: &[(String, String, String)],
    sweep: Option<(&str, &[String])>,
) -> Result<Vec<Contestant>> {
    if integrators.is_empty() {
        bail!("name at least one integrator with -i");
    }
    let mut out = Vec::new();
    for name in integrators {
        let entry = registry::find(name)?;
        let own: Vec<(String, String)> = params
            .iter()
            .filter(|(i, _, _)| i == name)
            .map(|(_, k, v)| (k.clone(), v.clone()))
            .collect();
        entry.resolve(&own)?;
        match sweep {
            None => out.push(Contestant {
                label: name.clone(),
                integrator: name.clone(),
                params: own,
                swept: None,
            }),
            Some((key, values)) => {
                if !entry.params.iter().any(|p| p.name == key) {
                    bail!("--sweep: integrator `{name}` has no parameter `{key}`");
                }
                for v in values {
                    let mut p = own.clone();
                    p.push((key.to_string(), v.clone()));
                    entry.resolve(&p)?;
                    out.push(Contestant {
                        label: format!("{name}-{key}-{v}"),
                        integrator: name.clone(),
                        params: p,
                        swept: Some((key.to_string(), v.clone())),
                    });
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
                    "-i {}: each integrator may be named once (use --sweep for several values of a parameter)",
                    c.integrator
                ),
            }
        }
    }
    Ok(out)
}

fn render_one(
    built: &RenderScene,
    camera: &crate::scene::Camera,
    c: &Contestant,
    budget: Budget,
    opts: &CompareOptions,
) -> Result<(Film, render::RenderStats, String)> {
    let entry = registry::find(&c.integrator)?;
    let params = entry.resolve(&c.params)?;
    let mut integrator = entry.build_checked(&params)?;
    let settings = match budget {
        Budget::Spp(n) => RenderSettings {
            progress: opts.progress,
            filter: opts.filter.unwrap_or_default(),
            ..RenderSettings::fixed(n, opts.seed, opts.threads)
        },
        Budget::Time(t) => RenderSettings {
            spp: None,
            seed: opts.seed,
            threads: opts.threads,
            progress: opts.progress,
            time_budget: Some(t),
            filter: opts.filter.unwrap_or_default(),
        },
    };
    let mut acc = Accumulation::new(camera.width, camera.height);
    let stats = render::render_passes(
        built,
        camera,
        integrator.as_mut(),
        &settings,
        &mut acc,
        &|| false,
        &mut |_, _| Ok(()),
    )?;
    Ok((acc.film(), stats, params.describe(entry.params)))
}

/// The reference image: a file, or a cached high-spp `path` render.
fn reference(
    opts: &CompareOptions,
    built: &RenderScene,
    camera: &crate::scene::Camera,
) -> Result<(Film, String)> {
    match &opts.reference {
        ReferenceSpec::File(path) => {
            let film = output::read_image(path)?;
            if (film.width, film.height) != (camera.width, camera.height) {
                bail!(
                    "{}: the reference is {}x{}, the renders {}x{}",
                    path.display(),
                    film.width,
                    film.height,
                    camera.width,
                    camera.height
                );
            }
            if let Some((count, (x, y))) = film.non_finite() {
                bail!(
                    "{}: the reference has {count} pixel(s) with NaN or infinite values, the first at ({x}, {y}); no error can be measured against it",
                    path.display()
                );
            }
            Ok((film, format!("file {}", file_name(path))))
        }
        ReferenceSpec::Spp(spp) => {
            // The scene file and the mesh files it names: editing either renders anew.
            let scene_bytes = crate::scene::references::scene_content(&opts.scene)
                .with_context(|| format!("{}: cannot read scene file", opts.scene.display()))?;
            // A seed of its own, so that its noise is independent of the renders'.
            let seed = opts.seed ^ 0x5eed_5eed_5eed_5eed;
            // The version too: a light-transport fix must not reuse an old reference.
            let key = format!(
                "raylab {} reference path max-depth=unlimited spp={spp} seed={seed} {}x{} filter={}",
                env!("CARGO_PKG_VERSION"),
                camera.width,
                camera.height,
                opts.filter.unwrap_or_default()
            );
            let hash = stable_hash(&[&scene_bytes, key.as_bytes()]);
            let cached = opts.cache_dir.join(format!("reference-{hash:016x}.exr"));
            // The page names the cache entry, not the folder: a page must not print a path
            // of the machine that made it.
            let what = format!(
                "path, {spp} spp, unlimited depth (cached as {})",
                file_name(&cached)
            );
            if cached.exists() {
                if let Ok(film) = output::read_image(&cached) {
                    if (film.width, film.height) == (camera.width, camera.height) {
                        return Ok((film, what));
                    }
                }
            }
            let c = Contestant {
                label: "reference".into(),
                integrator: "path".into(),
                params: Vec::new(),
                swept: None,
            };
            let ref_opts = CompareOptions {
                seed,
                ..opts.clone()
            };
            eprintln!("rendering the reference: {what}");
            let (film, _, _) = render_one(built, camera, &c, Budget::Spp(*spp), &ref_opts)?;
            std::fs::create_dir_all(&opts.cache_dir).with_context(|| {
                format!(
                    "{}: cannot create the cache folder",
                    opts.cache_dir.display()
                )
            })?;
            output::write_image(&cached, &film, DisplaySettings::default())?;
            Ok((film, what))
        }
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
        for suffix in [".exr", ".png", "-error.png"] {
            let name = format!("{}{suffix}", c.label);
            files.push((format!("the comparison's {name}"), dir.join(name)));
        }
    }
    let mut pages = vec!["metrics.json", "metrics.csv", "mosaic.png", "index.html"];
    if opts.contestants.iter().any(|c| c.swept.is_some()) {
        pages.extend(["sweep.svg", "sweep.png"]);
    }
    for name in pages {
        files.push((format!("the comparison's {name}"), dir.join(name)));
    }
    files
}

/// Runs the comparison and writes everything into `opts.out_dir` (created if missing, and
/// removed again if the comparison fails before writing anything there).
pub fn run(opts: &CompareOptions) -> Result<Report> {
    if opts.out_dir.exists() && !opts.out_dir.is_dir() {
        bail!(
            "{}: the output folder is a file, not a folder",
            opts.out_dir.display()
        );
    }
    // No output may be an input (the scene, its meshes, the reference image).
    let mut plan = crate::render::scene_inputs(&opts.scene)?;
    if let ReferenceSpec::File(f) = &opts.reference {
        if f.exists() {
            plan.input("the reference image", f)?;
        }
    }
    for (role, file) in output_files(opts) {
        plan.output(&role, &file)?;
    }
    plan.check()?;
    let created = !opts.out_dir.exists();
    if created {
        std::fs::create_dir_all(&opts.out_dir).with_context(|| {
            format!(
                "{}: cannot create the output folder",
                opts.out_dir.display()
            )
        })?;
    }
    let result = run_into(opts);
    if result.is_err() && created {
        // Only an empty folder goes: what a failed run wrote stays for inspection.
        let _ = std::fs::remove_dir(&opts.out_dir);
    }
    result
}

fn run_into(opts: &CompareOptions) -> Result<Report> {
    output::check_writable_folder(&opts.out_dir.join("index.html"))?;
    let loaded = crate::scene::load_scene_defined(&opts.scene, &opts.allowed, &opts.import)?;
    for w in &loaded.warnings {
        eprintln!("warning: {}: {w}", opts.scene.display());
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
    // finish a pass, or the most memory any of them holds beside the film.
    let mut most = 0;
    for c in &opts.contestants {
        let entry = registry::find(&c.integrator)?;
        let demand = entry.build_checked(&entry.resolve(&c.params)?)?.demand();
        render::check_camera(&camera, &demand, entry.name)?;
        most = most.max(demand.memory_for(camera.width as u64 * camera.height as u64));
    }
    render::check_memory(camera.width, camera.height, most)?;
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
    let built = RenderScene::build_on_threads(&loaded, opts.accel, opts.threads)?;
    let (reference, reference_what) = reference(opts, &built, &camera)?;
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
        let (film, stats, params) = render_one(&built, &camera, c, opts.budget, opts)?;
        threads = stats.threads;
        let (m, error) = metrics::compare(&film, &reference)?;
        let dir = &opts.out_dir;
        output::write_image(
            &dir.join(format!("{}.exr", c.label)),
            &film,
            DisplaySettings::default(),
        )?;
        output::write_image(
            &dir.join(format!("{}.png", c.label)),
            &film,
            DisplaySettings::default(),
        )?;
        output::write_png(
            &dir.join(format!("{}-error.png", c.label)),
            &metrics::error_map_image(&error, film.width, film.height),
        )?;
        let region = match opts.region {
            Some(r) => {
                let crop = |f: &Film| f.crop(r.x, r.y, r.w, r.h).context("region outside image");
                Some(metrics::compare(&crop(&film)?, &crop(&reference)?)?.0)
            }
            None => None,
        };
        let mean = film.mean();
        let row = Row {
            label: c.label.clone(),
            integrator: c.integrator.clone(),
            params,
            swept_param: c.swept.as_ref().map(|s| s.0.clone()),
            swept_value: c.swept.as_ref().map(|s| s.1.clone()),
            spp: stats.spp_done,
            time_s: stats.elapsed.as_secs_f64(),
            rays_camera: stats.rays.camera,
            rays_extension: stats.rays.extension,
            rays_shadow: stats.rays.shadow,
            rays_light: stats.rays.light,
            rays_connection: stats.rays.connection,
            rays_per_s: stats.rays_per_second(),
            samples_per_s: stats.samples_per_second(),
            mean: mean.to_array(),
            metrics: m,
            region,
        };
        let in_region = region.map_or(String::new(), |m| {
            format!(
                "  region: RMSE {:.4}  relMSE {:.4}  FLIP {:.4}",
                m.rmse, m.rel_mse, m.flip
            )
        });
        eprintln!(
            "{:<28} {:>6} spp {:>9.2} s {:>8.2} M rays/s  RMSE {:.4}  relMSE {:.4}  PSNR {:>6.2} dB  FLIP {:.4}{in_region}",
            row.label, row.spp, row.time_s, row.rays_per_s / 1e6, m.rmse, m.rel_mse, m.psnr, m.flip
        );
        rows.push(row);
    }

    let report = Report {
        scene: file_name(&opts.scene),
        width: camera.width,
        height: camera.height,
        budget: match opts.budget {
            Budget::Spp(n) => format!("equal samples: {n} spp"),
            Budget::Time(t) => format!("equal time: {:.2} s", t.as_secs_f64()),
        },
        reference: reference_what,
        threads,
        seed: opts.seed,
        note: opts.note.clone(),
        region: opts.region,
        rows,
    };
    write_tables(&opts.out_dir, &report)?;
    let plots = if report.rows.iter().any(|r| r.swept_param.is_some()) {
        plot::write_sweep_plots(&opts.out_dir, &report)?
    } else {
        None
    };
    mosaic::write(&opts.out_dir, &report)?;
    page::write(&opts.out_dir, &report, plots.as_deref())?;
    Ok(report)
}

/// `metrics.json` and `metrics.csv`.
fn write_tables(dir: &Path, report: &Report) -> Result<()> {
    let json =
        serde_json::to_string_pretty(report).map_err(|e| anyhow!("cannot encode metrics: {e}"))?;
    write_text(&dir.join("metrics.json"), &json)?;
    let mut csv = String::from(
        "label,integrator,params,swept_param,swept_value,spp,time_s,rays_camera,rays_extension,rays_shadow,rays_light,rays_connection,rays_per_s,samples_per_s,mean_r,mean_g,mean_b,rmse,rel_mse,psnr,flip,region_rmse,region_rel_mse,region_psnr,region_flip\n",
    );
    for r in &report.rows {
        let _ = writeln!(
            csv,
            "{},{},\"{}\",{},{},{},{:.4},{},{:.0},{:.0},{:.6},{:.6},{:.6},{:.6},{:.6},{:.3},{:.6},{}",
            r.label,
            r.integrator,
            r.params,
            r.swept_param.as_deref().unwrap_or(""),
            r.swept_value.as_deref().unwrap_or(""),
            r.spp,
            r.time_s,
            r.rays_joined(","),
            r.rays_per_s,
            r.samples_per_s,
            r.mean[0],
            r.mean[1],
            r.mean[2],
            r.metrics.rmse,
            r.metrics.rel_mse,
            r.metrics.psnr,
            r.metrics.flip,
            r.region.map_or(",,,".to_string(), |m| format!(
                "{:.6},{:.6},{:.3},{:.6}",
                m.rmse, m.rel_mse, m.psnr, m.flip
            ))
        );
    }
    write_text(&dir.join("metrics.csv"), &csv)
}

/// Writes a text file atomically.
pub(crate) fn write_text(path: &Path, text: &str) -> Result<()> {
    use std::io::Write;
    crate::output::atomic::write_atomic(path, |file| {
        file.write_all(text.as_bytes())
            .with_context(|| format!("{}: cannot write", path.display()))
    })
}

/// The last component of `path`, for pages and reports that must not print where the files
/// of the machine that made them live.
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}
