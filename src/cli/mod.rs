//! Command-line interface: parses flags, calls into the library, prints, and maps errors to
//! exit codes (0 ok, 1 "differs", 2 error).

mod compare_cmd;
mod interrupt;
mod live_cmd;
mod merge_cmd;
mod render_cmd;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

use crate::output::Tonemap;

#[derive(Parser, Debug)]
#[command(
    name = "raylab",
    version,
    about = "A physically based renderer for comparing light-transport algorithms"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene to a PNG (tonemapped) or EXR (linear radiance); with --watch, render
    /// again whenever the scene file or a file it names is saved.
    Render(RenderArgs),
    /// Show a scene rendering live on a local web page (127.0.0.1), with a menu of
    /// integrators and their parameters; it re-renders whenever the scene or a mesh it names
    /// is saved.
    Serve(ServeArgs),
    /// List every integrator with its summary, parameters and defaults.
    Integrators,
    /// Render a scene with several integrators and compare them against a reference.
    Compare(CompareArgs),
    /// Run a matrix of comparisons described in a RON file (scenes x integrators x
    /// settings): one compare page per entry and a summary of who wins where.
    Suite(SuiteArgs),
    /// Print the error metrics between two images (EXR or PNG); exit 1 when they are beyond
    /// --tolerance or either image holds NaN or infinite values.
    Diff(DiffArgs),
    /// Measure rays per second, samples per second, BVH build time and memory.
    Bench(BenchArgs),
    /// Combine the shards of a render (`render --shard I/N -o part.exr`) into exactly the
    /// image the single run writes, after checking that they belong together and cover it.
    /// The parts are read side by side a block of lines at a time: memory holds the image
    /// (about 60 bytes a pixel), whatever the number of parts.
    Merge(MergeArgs),
    /// Convert a Mitsuba 3 XML or pbrt-v4 scene into a RON scene that a person can edit.
    Import {
        /// Scene file (Mitsuba 3 XML, .xml, or pbrt-v4, .pbrt).
        scene: PathBuf,
        /// The RON file to write (.ron), in the scene's folder (file names stay relative);
        /// never the scene or a file it reads.
        #[arg(short = 'o', long = "output", value_name = "FILE")]
        output: PathBuf,
        /// Also print what was mapped approximately, or by a changed convention.
        #[arg(long)]
        report: bool,
        /// Let the scene read files under DIR too (repeatable). By default a scene may read
        /// files (meshes, textures, included files) under its own folder only.
        #[arg(long = "allow-path", value_name = "DIR")]
        allow_path: Vec<PathBuf>,
        #[command(flatten)]
        import: ImportFlags,
    },
    /// Parse and build a scene, then print its counts and bounds.
    Validate {
        /// Scene file (RON, Mitsuba 3 XML or pbrt-v4).
        scene: PathBuf,
        /// Let the scene read files under DIR too (repeatable). By default a scene may read
        /// files (meshes, MTL files, glTF buffers) under its own folder only.
        #[arg(long = "allow-path", value_name = "DIR")]
        allow_path: Vec<PathBuf>,
        #[command(flatten)]
        import: ImportFlags,
    },
}

/// How rays are traced and pixels reconstructed: flags of `render`, `serve` and `compare`.
#[derive(clap::Args, Debug, Clone)]
pub struct TraceArgs {
    /// Accelerator: raylab (its own 8-wide BVH, the default) or obvhs (the obvhs crate's
    /// CWBVH). Images agree up to rounding at primitive edges.
    #[arg(long, value_name = "NAME", default_value = "raylab", value_parser = parse_accel)]
    pub accel: crate::accel::AccelKind,
    /// Pixel reconstruction filter: box, tent or gaussian (Mitsuba 3's default: stddev 0.5,
    /// radius 2); default: the scene's `render.filter`, else box.
    #[arg(long, value_name = "NAME", value_parser = parse_filter)]
    pub filter: Option<raylab_integrators::Filter>,
    /// How camera samples draw their numbers: independent (the default), stratified, sobol
    /// (Owen-scrambled Sobol points, padded by pairs), zsobol (pbrt-v4's default) or halton;
    /// default: the scene's `render.sampler`.
    #[arg(long, value_name = "NAME", value_parser = raylab_integrators::sampler::SamplerKind::parse)]
    pub sampler: Option<raylab_integrators::sampler::SamplerKind>,
    /// Render spectrally: each camera sample carries three wavelengths (hero-wavelength
    /// sampling), every colour is a spectrum at them, and the film turns them into XYZ and
    /// sRGB; default: the scene's `render.spectral`, else RGB.
    #[arg(long, conflicts_with = "rgb")]
    pub spectral: bool,
    /// Render in RGB even where the scene asks for spectral rendering.
    #[arg(long)]
    pub rgb: bool,
}

impl TraceArgs {
    /// The mode the flags ask for; `None`: the scene's.
    pub fn spectral(&self) -> Option<bool> {
        match (self.spectral, self.rgb) {
            (true, _) => Some(true),
            (_, true) => Some(false),
            _ => None,
        }
    }
}

/// What `render` (and its `--watch`) and `serve` share: the scene, what renders it, and how
/// the image is shown.
#[derive(clap::Args, Debug, Clone)]
pub struct SessionArgs {
    /// Scene file (RON).
    pub scene: PathBuf,
    /// Integrator (see `raylab integrators`); default: the scene's, else `path`.
    #[arg(short, long)]
    pub integrator: Option<String>,
    /// Integrator parameter as NAME=VALUE; repeat for several.
    #[arg(short = 'p', long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Samples per pixel, stratified on an NxN grid when a square. `render` stops there
    /// (default: the scene's, or open-ended with --time); `serve` and `--watch` stop each
    /// render there (default: refine until the next change).
    #[arg(long, allow_negative_numbers = true)]
    pub spp: Option<u32>,
    /// Random seed (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    pub seed: Option<u64>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Image size WIDTHxHEIGHT, overriding the scene's resolution.
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    #[command(flatten)]
    pub trace: TraceArgs,
    /// Let the scene read files under DIR too (repeatable). By default a scene may read
    /// files (meshes, MTL files, glTF buffers) under its own folder only.
    #[arg(long = "allow-path", value_name = "DIR")]
    pub allow_path: Vec<PathBuf>,
    #[command(flatten)]
    pub import: ImportFlags,
    /// Exposure in stops for the PNG or the page's image (each +1 doubles the brightness).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Tone curve for the PNG or the page's image.
    #[arg(long, value_enum, default_value_t = Tonemap::Clamp)]
    pub tonemap: Tonemap,
    /// No progress bar and no summary line (`serve`: no line per render).
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(clap::Args, Debug, Clone)]
pub struct RenderArgs {
    #[command(flatten)]
    pub session: SessionArgs,
    /// Output file: .png or .exr (default: the scene's name with .png, in the current folder).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Stop after this many seconds and write the image of the passes done (the pass in
    /// progress is abandoned; the first pass is always finished, unless still running at ten
    /// times the budget and ten seconds more). Without --spp the render is open-ended.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub time: Option<f64>,
    /// Save the render's state to FILE after every pass.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,
    /// Continue from --checkpoint FILE (refused if the scene or settings changed).
    #[arg(long)]
    pub resume: bool,
    /// Render only shard I of N (counting from 0) of this render, into an EXR that `raylab
    /// merge` combines with the others into exactly the image of the single run: a range of
    /// passes, or for integrators with state per pixel (sppm-pixel) a band of rows.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// Keep going: watch the scene file and the files it names (meshes) and render again on
    /// every save, rewriting the output (atomically, at most twice a second) as passes
    /// complete.
    /// Renders until Ctrl-C unless --spp is given. A file that does not load prints its
    /// error (file:line:column) and leaves the last good image as it was.
    #[arg(long)]
    pub watch: bool,
    /// Check everything this render would check (the scene and every file it reads, the
    /// integrator and its parameters, the output files, the shard, the memory, a checkpoint to
    /// resume) and exit 0, before building the BVH, without rendering or writing anything:
    /// what a job script asks before it queues work.
    #[arg(long, conflicts_with = "watch")]
    pub check: bool,
    /// Write the image as CIE 1931 XYZ (an EXR with channels X, Y, Z) instead of linear sRGB:
    /// the film's colour by the inverse of the sRGB matrix it came through, so exactly what
    /// a spectral render accumulates, up to rounding. Needs -o FILE.exr.
    #[arg(long, conflicts_with_all = ["watch", "shard"])]
    pub xyz: bool,
}

#[derive(clap::Args, Debug, Clone)]
pub struct ServeArgs {
    #[command(flatten)]
    pub session: SessionArgs,
    /// Port to listen on; 0 picks a free one. The address is printed on stdout.
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Address to listen on. The default, loopback, keeps the page to this machine.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
}

#[derive(clap::Args, Debug, Clone)]
pub struct CompareArgs {
    /// Scene file (RON).
    pub scene: PathBuf,
    /// An integrator to compare, NAME or NAME@SAMPLER (under a sampler of its own, e.g.
    /// path@sobol); repeat for several.
    #[arg(
        short = 'i',
        long = "integrator",
        required = true,
        value_name = "NAME[@SAMPLER]"
    )]
    pub integrators: Vec<String>,
    /// Integrator parameter as INTEGRATOR.NAME=VALUE; repeat for several.
    #[arg(short = 'p', long = "param", value_name = "INTEGRATOR.NAME=VALUE")]
    pub params: Vec<String>,
    /// Equal samples per pixel for every integrator (default 16).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Equal time for every integrator, in seconds (progressive passes; at least one each).
    #[arg(long, value_name = "SECONDS")]
    pub time: Option<f64>,
    /// Reference image (EXR, linear radiance) of the same size.
    #[arg(long, value_name = "FILE")]
    pub reference: Option<PathBuf>,
    /// Render the reference at this many spp (default 1024; cached by scene and settings).
    #[arg(long, value_name = "N")]
    pub reference_spp: Option<u32>,
    /// Render the reference for this many seconds instead (cached like --reference-spp).
    #[arg(long, value_name = "SECONDS")]
    pub reference_time: Option<f64>,
    /// The integrator that renders the reference (default `path`): a consistent one where
    /// `path` cannot converge (caustics: `sppm`, `vcm`). Its parameters: -p reference.NAME=VALUE.
    #[arg(long, value_name = "NAME", default_value = "path")]
    pub reference_integrator: String,
    /// Independent runs per integrator (seeds derived from --seed): metrics become means
    /// with 95% intervals, and variance and squared bias are measured.
    #[arg(long, value_name = "K", default_value_t = 1)]
    pub runs: u32,
    /// Report the time each integrator needs to reach this MSE (default: the best final MSE).
    #[arg(long, value_name = "MSE")]
    pub target_error: Option<f64>,
    /// Render one image per value of a parameter: NAME=V1,V2,... (sampler=independent,sobol
    /// sweeps the sampler)
    #[arg(long, value_name = "NAME=V1,V2,...")]
    pub sweep: Option<String>,
    /// Image size WIDTHxHEIGHT, overriding the scene's resolution.
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// Random seed (the same for every integrator).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    #[command(flatten)]
    pub trace: TraceArgs,
    /// Let the scene read files under DIR too (repeatable). By default a scene may read
    /// files (meshes, MTL files, glTF buffers) under its own folder only.
    #[arg(long = "allow-path", value_name = "DIR")]
    pub allow_path: Vec<PathBuf>,
    #[command(flatten)]
    pub import: ImportFlags,
    /// Output folder (created if missing).
    #[arg(short, long)]
    pub output: PathBuf,
    /// A note shown at the top of the page (e.g. why the resolution was reduced).
    #[arg(long)]
    pub note: Option<String>,
    /// Also measure the error inside this pixel rectangle (a caustic, a shadow): X,Y,W,H
    /// from the top-left corner.
    #[arg(long, value_name = "X,Y,W,H")]
    pub region: Option<String>,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(clap::Args, Debug, Clone)]
pub struct SuiteArgs {
    /// Suite file (RON): see docs/compare.md#suites.
    pub file: PathBuf,
    /// Output folder: the summary page and one folder per entry (created if missing).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Let the scenes read files under DIR too (repeatable).
    #[arg(long = "allow-path", value_name = "DIR")]
    pub allow_path: Vec<PathBuf>,
    /// Render every entry spectrally (see `render --spectral`); default: each scene's
    /// `render.spectral`.
    #[arg(long)]
    pub spectral: bool,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(clap::Args, Debug, Clone)]
pub struct BenchArgs {
    /// Rays per measurement.
    #[arg(long, default_value_t = 1 << 20)]
    pub rays: usize,
    /// Subdivision level of the large icosphere (8: 1.31 M triangles).
    #[arg(long, default_value_t = 8)]
    pub subdivisions: u32,
    /// Thread counts to measure at (default: 1 and all cores).
    #[arg(long, value_delimiter = ',')]
    pub threads: Vec<usize>,
    /// Write each case's triangles and rays here (see `raylab bench --help` and the README).
    #[arg(long, value_name = "DIR")]
    pub dump: Option<PathBuf>,
    /// Also trace the same rays with Intel Embree 3 and print raylab/Embree ratios, build
    /// times, memory and hit agreement (needs a build with `--features embree`).
    #[arg(long)]
    pub embree: bool,
    /// Also build every case with the obvhs backend (`--accel obvhs`) and print its build
    /// time, memory and rates beside raylab's, with the raylab/obvhs ratios.
    #[arg(long)]
    pub obvhs: bool,
    /// Run only these cases (comma-separated; default: all).
    #[arg(long, value_delimiter = ',', value_parser = clap::builder::PossibleValuesParser::new(crate::bench::CASES))]
    pub case: Vec<String>,
    /// With --embree: measure raylab and Embree in turn this many times and print the median
    /// rates and ratios, with the range of the rounds' ratios (this shared machine's rates drift by
    /// 10-20% between runs).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub rounds: u32,
}

/// The metric `diff --tolerance` applies to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Metric {
    Rmse,
    RelMse,
    Psnr,
    Flip,
}

#[derive(clap::Args, Debug, Clone)]
pub struct DiffArgs {
    /// First image (EXR or PNG).
    pub a: PathBuf,
    /// Second image, the reference (EXR or PNG).
    pub b: PathBuf,
    /// Write FLIP's error map here (PNG); with --ztest, the map of failing pixels.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Per-pixel z-test of A against B with the variance layers the images carry (Mitsuba's
    /// render-test method): exit 1 when a pixel differs beyond the noise.
    #[arg(long)]
    pub ztest: bool,
    /// The z-test's significance over the whole image (Šidák-corrected per pixel channel).
    #[arg(long, default_value_t = 0.01, requires = "ztest")]
    pub significance: f64,
    /// Metric the tolerance applies to.
    #[arg(long, value_enum, default_value_t = Metric::Flip)]
    pub metric: Metric,
    /// Exit with 1 when the metric is beyond this (for PSNR: below it).
    #[arg(long, allow_negative_numbers = true)]
    pub tolerance: Option<f64>,
}

#[derive(clap::Args, Debug, Clone)]
pub struct MergeArgs {
    /// The image to write: .exr (linear radiance and its variance) or .png (with the
    /// render's exposure and tone curve).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The shards' EXR files, in any order.
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// The comparison `raylab compare ARGS...` would run (`args` without the program's and the
/// command's names), its flags checked as the command checks them: for scripts (the Python
/// module) that compare exactly as the command line does.
pub fn compare_options_from_args(
    args: &[String],
) -> anyhow::Result<crate::compare::CompareOptions> {
    let argv = ["raylab", "compare"]
        .into_iter()
        .map(String::from)
        .chain(args.iter().cloned());
    match Cli::try_parse_from(argv) {
        Ok(Cli {
            command: Command::Compare(args),
        }) => compare_cmd::compare_options(&args),
        Ok(_) => anyhow::bail!("not a comparison"),
        Err(e) => anyhow::bail!("{}", e.render().to_string().trim_end()),
    }
}

/// Runs the command line and returns the process exit code.
pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            note!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Render(args) if args.watch => live_cmd::watch(&args),
        Command::Render(args) => render_cmd::render(&args),
        Command::Serve(args) => live_cmd::serve(&args),
        Command::Integrators => {
            print_out(format_args!("{}", render_cmd::integrators_listing()));
            Ok(ExitCode::SUCCESS)
        }
        Command::Validate {
            scene,
            allow_path,
            import,
        } => {
            check_allowed(&allow_path)?;
            render_cmd::validate(&scene, &allow_path, &import.options())
        }
        Command::Import {
            scene,
            output,
            report,
            allow_path,
            import,
        } => {
            check_allowed(&allow_path)?;
            render_cmd::import(&scene, &output, report, &allow_path, &import.options())
        }
        Command::Compare(args) => compare_cmd::compare(&args),
        Command::Diff(args) => compare_cmd::diff(&args),
        Command::Suite(args) => compare_cmd::suite(&args),
        Command::Merge(args) => merge_cmd::merge(&args),
        Command::Bench(args) => {
            if args.embree && !cfg!(feature = "embree") {
                anyhow::bail!(
                    "raylab was built without the `embree` feature: cargo build --release --features embree (needs Debian's libembree-dev)"
                );
            }
            if args.rays == 0 || args.subdivisions > 10 {
                anyhow::bail!("bench: --rays must be positive, --subdivisions at most 10");
            }
            for n in &args.threads {
                check_threads(Some(*n))?;
            }
            let threads = if args.threads.is_empty() {
                let all = std::thread::available_parallelism().map_or(1, |n| n.get());
                if all > 1 {
                    vec![1, all]
                } else {
                    vec![1]
                }
            } else {
                args.threads.clone()
            };
            crate::bench::run(&crate::bench::BenchOptions {
                rays: args.rays,
                subdivisions: args.subdivisions,
                threads,
                dump: args.dump.clone(),
                embree: args.embree,
                obvhs: args.obvhs,
                cases: args.case.clone(),
                rounds: args.rounds as usize,
            })?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// `--allow-path DIR`: each an existing folder.
fn check_allowed(dirs: &[PathBuf]) -> anyhow::Result<()> {
    for d in dirs {
        if !d.is_dir() {
            anyhow::bail!("--allow-path {}: no such folder", d.display());
        }
    }
    Ok(())
}

/// Threads per core beyond which more only slow a render down.
const THREADS_PER_CORE: usize = 8;

/// `--threads N`: at least 1, at most [`THREADS_PER_CORE`] per core (10,000 threads make a
/// small render take minutes).
fn check_threads(threads: Option<usize>) -> anyhow::Result<()> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    match threads {
        Some(0) => anyhow::bail!("--threads must be at least 1"),
        Some(n) if n > cores * THREADS_PER_CORE => anyhow::bail!(
            "--threads {n}: at most {} on this machine ({THREADS_PER_CORE} per core; more only slow the render down)",
            cores * THREADS_PER_CORE
        ),
        _ => Ok(()),
    }
}

pub use crate::console::print_out;

/// `--filter NAME`.
fn parse_filter(name: &str) -> Result<raylab_integrators::Filter, String> {
    name.parse()
}

/// `--accel NAME`.
fn parse_accel(name: &str) -> Result<crate::accel::AccelKind, String> {
    name.parse()
}

/// `-D NAME=VALUE`: a Mitsuba `<default>` parameter.
/// How a Mitsuba 3 XML or pbrt-v4 scene is read.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ImportFlags {
    /// A Mitsuba scene's `<default>` parameter as NAME=VALUE (as `mitsuba -D`); repeat for
    /// several.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    pub defines: Vec<(String, String)>,
    /// Render what raylab does not have (a spot light's smoothstep falloff, a dispersive
    /// glass, a medium) as the nearest thing it has, each listed as a warning, instead of
    /// refusing the scene.
    #[arg(long)]
    pub approximate: bool,
    /// A folder searched for the files a Mitsuba scene names, after its own folder and its
    /// <path> folders (as `mitsuba -a`; Mitsuba's test scenes find their meshes and textures
    /// in mitsuba-data's `common/` so); files in it may be read. Repeat for several.
    #[arg(short = 'a', long = "search-path", value_name = "DIR")]
    pub search: Vec<PathBuf>,
}

impl ImportFlags {
    pub fn options(&self) -> crate::scene::ImportOptions {
        crate::scene::ImportOptions {
            defines: self.defines.clone(),
            approximate: self.approximate,
            // Relative to where raylab runs (as `mitsuba -a`), not to the scene.
            search: self
                .search
                .iter()
                .map(|d| std::path::absolute(d).unwrap_or_else(|_| d.clone()))
                .collect(),
        }
    }
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((name, value))
            if !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') =>
        {
            Ok((name.to_string(), value.to_string()))
        }
        _ => Err(format!(
            "expected NAME=VALUE (a Mitsuba <default> parameter), got `{s}`"
        )),
    }
}
