//! `raylab suite FILE.ron`: a matrix of comparisons described in one file (scenes x
//! integrators x settings), one compare page per entry and a summary page that says which
//! integrator wins on which scene and by how much (efficiency, `1 / (MSE x time)` or, with
//! `rank_by: RelMse`, `1 / (relMSE x time)`, relative to the best on that scene): SmallVCM's `--report`, made quantitative.
//!
//! ```ron
//! (
//!     budget: Time(2.0),              // or Spp(64): every entry's default
//!     runs: 2,                         // independent runs per integrator
//!     size: (128, 128),                // optional: overrides the scenes' resolution
//!     integrators: ["path", "bdpt"],   // the default list
//!     params: ["path.max-depth=8"],    // INTEGRATOR.NAME=VALUE, for every entry
//!     reference: (integrator: "path", spp: 1024),
//!     scenes: [
//!         (scene: "cornell_box.ron"),
//!         (scene: "caustics.ron", name: "caustics-vcm", integrators: ["path", "vcm"],
//!          reference: (integrator: "sppm", time: 20.0), budget: Time(4.0)),
//!     ],
//! )
//! ```
//!
//! Scene files are relative to the suite file's folder. Every entry is checked (file, names,
//! integrators, parameters, budgets) before anything renders.

use super::page::escape;
use super::{Budget, CompareOptions, ReferenceSpec, Region, Report};
use anyhow::{anyhow, bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How much work each integrator of an entry gets.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum BudgetDesc {
    Spp(u32),
    Time(f64),
}

/// How an entry's reference is rendered.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceDesc {
    #[serde(default = "path_integrator")]
    pub integrator: String,
    /// `NAME=VALUE` parameters of the reference's integrator.
    #[serde(default)]
    pub params: Vec<String>,
    #[serde(default)]
    pub spp: Option<u32>,
    #[serde(default)]
    pub time: Option<f64>,
}

fn path_integrator() -> String {
    "path".into()
}

fn one() -> u32 {
    1
}

/// One entry: a scene and the settings it is compared under.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EntryDesc {
    pub scene: PathBuf,
    /// The entry's folder and name in the summary (default: the scene file's stem).
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default)]
    pub integrators: Option<Vec<String>>,
    /// Added to the suite's `params`.
    #[serde(default)]
    pub params: Vec<String>,
    #[serde(default)]
    pub budget: Option<BudgetDesc>,
    #[serde(default)]
    pub runs: Option<u32>,
    #[serde(default)]
    pub size: Option<(u32, u32)>,
    #[serde(default)]
    pub reference: Option<ReferenceDesc>,
    /// A pixel rectangle measured on its own: (x, y, width, height).
    #[serde(default)]
    pub region: Option<(u32, u32, u32, u32)>,
    #[serde(default)]
    pub note: Option<String>,
}

/// A suite file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteDesc {
    #[serde(default)]
    pub title: Option<String>,
    pub budget: BudgetDesc,
    #[serde(default = "one")]
    pub runs: u32,
    #[serde(default)]
    pub size: Option<(u32, u32)>,
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub integrators: Vec<String>,
    #[serde(default)]
    pub params: Vec<String>,
    #[serde(default)]
    pub reference: Option<ReferenceDesc>,
    /// The error the summary ranks by (`Mse` or `RelMse`; default `Mse`).
    #[serde(default)]
    pub rank_by: RankBy,
    pub scenes: Vec<EntryDesc>,
}

/// What the suite needs besides its file.
pub struct SuiteOptions {
    pub file: PathBuf,
    pub out_dir: PathBuf,
    pub threads: Option<usize>,
    pub progress: bool,
    pub allowed: Vec<PathBuf>,
    /// Spectral rendering for every entry; `None`: each scene's.
    pub spectral: Option<bool>,
}

/// Reads and checks a suite file: every entry as the comparison it runs, with its name.
pub fn load(opts: &SuiteOptions) -> Result<(SuiteDesc, Vec<Entry>)> {
    let path = &opts.file;
    let text = crate::files::read_text_capped(path, crate::files::MAX_TEXT)
        .with_context(|| format!("{}: cannot read the suite file", path.display()))?;
    let ron =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    let desc: SuiteDesc = ron.from_str(&text).map_err(|e| {
        anyhow!(
            "{}:{}:{}: {}",
            path.display(),
            e.span.start.line,
            e.span.start.col,
            e.code
        )
    })?;
    if desc.scenes.is_empty() {
        bail!("{}: the suite names no scenes", path.display());
    }
    let folder = path.parent().unwrap_or(Path::new("."));
    let mut entries: Vec<Entry> = Vec::new();
    for (k, e) in desc.scenes.iter().enumerate() {
        let at = |what: String| {
            anyhow!(
                "{}: scenes[{k}] ({}): {what}",
                path.display(),
                e.scene.display()
            )
        };
        let entry = entry_options(&desc, e, folder, opts).map_err(|err| at(format!("{err:#}")))?;
        if entries.iter().any(|other| other.name == entry.name) {
            return Err(at(format!(
                "the name `{}` is used twice; give one entry a `name`",
                entry.name
            )));
        }
        entries.push(entry);
    }
    Ok((desc, entries))
}

fn budget(b: BudgetDesc) -> Result<Budget> {
    let default = Budget::Spp(1);
    match b {
        BudgetDesc::Spp(n) => Budget::choose(Some(n), None, default, ("Spp", "Time")),
        BudgetDesc::Time(t) => Budget::choose(None, Some(t), default, ("Spp", "Time")),
    }
}

fn reference(desc: Option<&ReferenceDesc>) -> Result<ReferenceSpec> {
    let Some(r) = desc else {
        return Ok(ReferenceSpec::Render {
            integrator: "path".into(),
            params: Vec::new(),
            budget: Budget::Spp(1024),
        });
    };
    let params = r
        .params
        .iter()
        .map(|p| {
            p.split_once('=')
                .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
                .ok_or_else(|| anyhow!("reference parameter `{p}`: expected NAME=VALUE"))
        })
        .collect::<Result<Vec<_>>>()?;
    let entry = raylab_integrators::registry::find(&r.integrator)?;
    entry.resolve(&params)?;
    let budget = Budget::choose(
        r.spp,
        r.time,
        Budget::Spp(1024),
        ("the reference's spp", "time"),
    )?;
    Ok(ReferenceSpec::Render {
        integrator: r.integrator.clone(),
        params,
        budget,
    })
}

/// A name that is safe as a folder name: letters, digits, `-`, `_`, `.`, not starting with `.`.
fn check_name(name: &str) -> Result<()> {
    let ok = !name.is_empty()
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if !ok {
        bail!("`{name}` cannot name a folder: use letters, digits, '-', '_' and '.'");
    }
    if ["index.html", "summary.csv", "summary.json"].contains(&name) {
        bail!("`{name}` is the name of a file the summary writes; name the entry otherwise");
    }
    Ok(())
}

/// One entry of a suite, checked: its name, the comparison it runs, and the files its scene
/// reads.
pub struct Entry {
    pub name: String,
    pub compare: CompareOptions,
    pub inputs: crate::scene::SceneInputs,
}

fn entry_options(
    desc: &SuiteDesc,
    e: &EntryDesc,
    folder: &Path,
    opts: &SuiteOptions,
) -> Result<Entry> {
    let scene = folder.join(&e.scene);
    if !scene.is_file() {
        bail!("{}: no such scene file", scene.display());
    }
    // Loaded now, so that a mistake in the last scene stops the suite before the first renders.
    let loaded = crate::scene::load_scene_defined(&scene, &opts.allowed, &Default::default())?;
    let name = match &e.name {
        Some(n) => n.clone(),
        None => e
            .scene
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
    };
    check_name(&name)?;
    let integrators = e
        .integrators
        .clone()
        .unwrap_or_else(|| desc.integrators.clone());
    for p in &desc.params {
        // A typo in a suite-wide parameter's integrator would otherwise apply nowhere.
        raylab_integrators::registry::find(
            super::parse_contestant(&super::parse_scoped_param(p)?.0)?.0,
        )?;
    }
    let parse = |list: &[String]| {
        list.iter()
            .map(|p| super::parse_scoped_param(p))
            .collect::<Result<Vec<_>>>()
    };
    // The suite's parameters apply where their integrator is compared; an entry's own must
    // name one it compares.
    let compared = |i: &str| {
        integrators
            .iter()
            .any(|spec| spec == i || super::parse_contestant(spec).is_ok_and(|(name, _)| name == i))
    };
    let mut params: Vec<_> = parse(&desc.params)?
        .into_iter()
        .filter(|(i, _, _)| compared(i))
        .collect();
    for p in parse(&e.params)? {
        if !compared(&p.0) {
            bail!(
                "parameter `{}.{}` names an integrator this entry does not compare",
                p.0,
                p.1
            );
        }
        params.push(p);
    }
    let contestants = super::contestants(&integrators, &params, None)?;
    let runs = e.runs.unwrap_or(desc.runs);
    if runs == 0 || runs > 10_000 {
        bail!("runs must be between 1 and 10000, got {runs}");
    }
    let size = e.size.or(desc.size);
    if let Some((w, h)) = size {
        crate::scene::describe::check_size(w, h).map_err(|m| anyhow!("size: {m}"))?;
    }
    let region = e.region.map(|(x, y, w, h)| Region { x, y, w, h });
    if let Some(r) = region {
        let (w, h) = size.unwrap_or((loaded.camera.width, loaded.camera.height));
        if r.w == 0
            || r.h == 0
            || r.x as u64 + r.w as u64 > w as u64
            || r.y as u64 + r.h as u64 > h as u64
        {
            bail!("region {r} is not inside the {w}x{h} image");
        }
    }
    let out_dir = opts.out_dir.join(&name);
    Ok(Entry {
        name,
        inputs: loaded.inputs,
        compare: CompareOptions {
            scene,
            allowed: opts.allowed.clone(),
            import: Default::default(),
            contestants,
            budget: budget(e.budget.unwrap_or(desc.budget))?,
            runs,
            target_error: None,
            reference: reference(e.reference.as_ref().or(desc.reference.as_ref()))?,
            cache_dir: super::cache_dir(&out_dir),
            out_dir,
            threads: opts.threads,
            seed: desc.seed,
            size,
            progress: opts.progress,
            note: e.note.clone(),
            region,
            accel: Default::default(),
            filter: None,
            sampler: None,
            spectral: opts.spectral,
        },
    })
}

/// The error a suite ranks by.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub enum RankBy {
    /// Mean squared error: what the issue's efficiency is, and what a few bright pixels
    /// (emitters, caustic fireflies) dominate.
    #[default]
    Mse,
    /// Relative MSE, which weighs an error against the pixel's brightness.
    RelMse,
}

impl RankBy {
    fn name(self) -> &'static str {
        match self {
            RankBy::Mse => "MSE",
            RankBy::RelMse => "relMSE",
        }
    }
}

/// One integrator's standing on one entry.
#[derive(Clone, Debug, Serialize)]
pub struct Standing {
    pub entry: String,
    pub scene: String,
    pub label: String,
    pub integrator: String,
    pub mse: f64,
    pub mse_ci95: Option<f64>,
    pub relmse: f64,
    pub relmse_ci95: Option<f64>,
    pub time: f64,
    /// `1 / (error x time)` in the suite's error (MSE or relMSE); `None` when the error is
    /// not positive (below the reference's noise).
    pub efficiency: Option<f64>,
    /// Efficiency over the entry's best: 1 for the winner.
    pub efficiency_ratio: Option<f64>,
    /// 1 for the most efficient.
    pub rank: usize,
    /// Whether its error's interval overlaps the winner's, so that the runs cannot tell the
    /// two apart (only with several runs, and only meaningful at equal time).
    pub tied_with_winner: bool,
}

impl Standing {
    fn error(&self, by: RankBy) -> (f64, Option<f64>) {
        match by {
            RankBy::Mse => (self.mse, self.mse_ci95),
            RankBy::RelMse => (self.relmse, self.relmse_ci95),
        }
    }
}

/// The standings of one entry's report, best first. An error at or below zero (the
/// reference's noise subtracted) is below what the reference can resolve: such an integrator
/// has no efficiency figure but ranks first, as the best the comparison can see.
fn standings(entry: &str, report: &Report, by: RankBy) -> Vec<Standing> {
    let mut out: Vec<Standing> = report
        .rows
        .iter()
        .map(|r| Standing {
            entry: entry.to_string(),
            scene: report.scene.clone(),
            label: r.label.clone(),
            integrator: r.integrator.clone(),
            mse: r.mse,
            mse_ci95: r.mse_ci95,
            relmse: r.relmse,
            relmse_ci95: r.relmse_ci95,
            time: r.time,
            efficiency: None,
            efficiency_ratio: None,
            rank: 0,
            tied_with_winner: false,
        })
        .collect();
    for s in &mut out {
        let (e, _) = s.error(by);
        s.efficiency = (e > 0.0 && s.time > 0.0).then(|| 1.0 / (e * s.time));
    }
    let best = out
        .iter()
        .filter_map(|s| s.efficiency)
        .max_by(f64::total_cmp);
    for s in &mut out {
        s.efficiency_ratio = s.efficiency.zip(best).map(|(e, b)| e / b);
    }
    let key = |s: &Standing| {
        if s.error(by).0 <= 0.0 {
            f64::INFINITY
        } else {
            s.efficiency.unwrap_or(f64::NEG_INFINITY)
        }
    };
    // Most efficient first (a stable sort: ties keep the file's order).
    out.sort_by(|a, b| key(b).total_cmp(&key(a)));
    let winner = out.first().map(|w| w.error(by));
    for (k, s) in out.iter_mut().enumerate() {
        s.rank = k + 1;
        if let (Some((m, Some(c))), (own, Some(ci))) = (winner, s.error(by)) {
            s.tied_with_winner = k > 0 && own - ci <= m + c;
        }
    }
    out
}

/// Runs every entry, then writes the summary (`index.html`, `summary.csv`, `summary.json`).
pub fn run(opts: &SuiteOptions) -> Result<Vec<Standing>> {
    let (desc, entries) = load(opts)?;
    // Every file any entry writes, checked against the suite file, every file any scene
    // reads and each other, and the folders' own files, before the first entry renders.
    let summary: Vec<(String, PathBuf)> = ["index.html", "summary.csv", "summary.json"]
        .iter()
        .map(|n| (format!("the suite's {n}"), opts.out_dir.join(n)))
        .collect();
    let mut plan = crate::output::plan::FilePlan::new();
    plan.input("the suite file", &opts.file)?;
    for e in &entries {
        for file in e.inputs.all().filter(|f| f.exists()) {
            plan.input("a file a scene of the suite reads", file)?;
        }
    }
    for (role, file) in &summary {
        plan.output(role, file)?;
    }
    for e in &entries {
        let files = super::output_files(&e.compare);
        super::check_output_folder(&e.compare.out_dir, &files)?;
        for (role, file) in &files {
            plan.output(&format!("entry `{}`'s {role}", e.name), file)?;
        }
    }
    plan.check()?;
    super::claim_output_folder(&opts.out_dir, &summary)?;
    let mut all = Vec::new();
    let mut pages = Vec::new();
    for (k, Entry { name, compare, .. }) in entries.iter().enumerate() {
        note!(
            "suite: {} of {}: {name} ({} integrators)",
            k + 1,
            entries.len(),
            compare.contestants.len()
        );
        let report = super::run(compare)
            .with_context(|| format!("{}: entry `{name}`", opts.file.display()))?;
        all.extend(standings(name, &report, desc.rank_by));
        pages.push((name.clone(), report));
    }
    write_summary(opts, &desc, &pages, &all)?;
    Ok(all)
}

fn write_summary(
    opts: &SuiteOptions,
    desc: &SuiteDesc,
    pages: &[(String, Report)],
    all: &[Standing],
) -> Result<()> {
    let dir = &opts.out_dir;
    let json = serde_json::to_string_pretty(all).map_err(|e| anyhow!("cannot encode: {e}"))?;
    super::write_text(&dir.join("summary.json"), &json)?;
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6e}"));
    let mut csv = String::from(
        "entry,scene,label,integrator,rank,tied_with_winner,mse,mse_ci95,relmse,relmse_ci95,time,efficiency,efficiency_ratio\n",
    );
    for s in all {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{:.6e},{},{:.6e},{},{:.4},{},{}",
            s.entry,
            s.scene,
            s.label,
            s.integrator,
            s.rank,
            s.tied_with_winner,
            s.mse,
            opt(s.mse_ci95),
            s.relmse,
            opt(s.relmse_ci95),
            s.time,
            opt(s.efficiency),
            s.efficiency_ratio
                .map_or(String::new(), |r| format!("{r:.4}"))
        );
    }
    super::write_text(&dir.join("summary.csv"), &csv)?;

    // The matrix: entries down, integrators across, efficiency over the entry's best.
    let mut labels: Vec<String> = Vec::new();
    for s in all {
        if !labels.contains(&s.label) {
            labels.push(s.label.clone());
        }
    }
    let mut matrix = String::from(
        "<table id=\"summary\"><thead><tr><th>scene</th><th>budget</th><th>winner</th>",
    );
    for l in &labels {
        let _ = write!(matrix, "<th>{}</th>", escape(l));
    }
    matrix.push_str("</tr></thead><tbody>");
    for (name, report) in pages {
        let here: Vec<&Standing> = all.iter().filter(|s| &s.entry == name).collect();
        let tied: Vec<String> = here
            .iter()
            .filter(|s| s.tied_with_winner)
            .map(|s| escape(&s.label))
            .collect();
        let winner = here
            .iter()
            .find(|s| s.rank == 1)
            .map_or("–".to_string(), |s| {
                if tied.is_empty() {
                    escape(&s.label)
                } else {
                    format!(
                        "{} (within the runs' noise of {})",
                        escape(&s.label),
                        tied.join(", ")
                    )
                }
            });
        let _ = write!(
            matrix,
            "<tr data-entry=\"{n}\"><td><a href=\"{n}/index.html\">{n}</a></td><td>{}</td><td>{winner}</td>",
            escape(&report.budget),
            n = escape(name)
        );
        for l in &labels {
            match here.iter().find(|s| &s.label == l) {
                Some(s) => {
                    let ratio = match s.efficiency_ratio {
                        Some(r) => format!("{r:.2}"),
                        None if s.error(desc.rank_by).0 <= 0.0 => {
                            "below the reference's noise".to_string()
                        }
                        None => "–".to_string(),
                    };
                    let shade = s.efficiency_ratio.map_or(
                        if s.error(desc.rank_by).0 <= 0.0 {
                            1.0
                        } else {
                            0.0
                        },
                        |r| r.clamp(0.0, 1.0),
                    );
                    let _ = write!(
                        matrix,
                        "<td title=\"MSE {:.3e}, relMSE {:.3e}, {:.2} s\" style=\"background: rgba(40, 160, 80, {:.2})\">{ratio}</td>",
                        s.mse,
                        s.relmse,
                        s.time,
                        0.1 + 0.6 * shade
                    );
                }
                None => matrix.push_str("<td></td>"),
            }
        }
        matrix.push_str("</tr>");
    }
    matrix.push_str("</tbody></table>");
    let mut wins = String::new();
    for l in &labels {
        let n = all.iter().filter(|s| &s.label == l && s.rank == 1).count();
        let on = all.iter().filter(|s| &s.label == l).count();
        let _ = write!(wins, "<li>{}: wins {n} of {on}</li>", escape(l));
    }
    let title = desc.title.clone().unwrap_or_else(|| {
        opts.file
            .file_name()
            .map_or("suite".into(), |n| n.to_string_lossy().into_owned())
    });
    let html = format!(
        r#"<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>raylab suite: {title}</title>
<style>
body {{ font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; color: #222; background: #fafafa; }}
table {{ border-collapse: collapse; margin: 1em 0; }}
th, td {{ border: 1px solid #ccc; padding: 0.3em 0.6em; text-align: right; }}
th:first-child, td:first-child, td:nth-child(2), td:nth-child(3) {{ text-align: left; }}
.note {{ color: #555; }}
</style></head>
<body>
<h1>raylab suite: {title}</h1>
<p class="note">Each cell is an integrator's efficiency, 1 / ({metric} x time), over the best on that scene's page (1.00: the winner); hover for its MSE, relMSE and time. A winner the runs cannot tell from others is named with them. Each scene's page (linked) has the images, the viewer, the intervals and the convergence plot. Also as <a href="summary.csv">summary.csv</a> and <a href="summary.json">summary.json</a>.</p>
{matrix}
<h2>Wins</h2>
<ul>{wins}</ul>
</body></html>
"#,
        title = escape(&title),
        metric = desc.rank_by.name()
    );
    super::write_text(&dir.join("index.html"), &html)
}
