//! `raylab compare` and `raylab diff`.

use super::{CompareArgs, DiffArgs, Metric, SuiteArgs};
use crate::compare::{self, metrics, Budget, CompareOptions, ReferenceSpec, Region};
use crate::output;
use crate::output::plan::FilePlan;
use anyhow::{anyhow, bail, Result};
use std::process::ExitCode;

/// `NAME=v1,v2,...`.
fn parse_sweep(text: &str) -> Result<(String, Vec<String>)> {
    let (name, values) = text.split_once('=').ok_or_else(|| {
        anyhow!("--sweep `{text}`: expected NAME=V1,V2,..., e.g. --sweep depth=1,2,3,4")
    })?;
    let values: Vec<String> = values
        .split(',')
        .map(|v| v.trim().to_string())
        .filter(|v| !v.is_empty())
        .collect();
    if values.is_empty() {
        bail!("--sweep `{text}`: no values");
    }
    Ok((name.trim().to_string(), values))
}

pub fn compare(args: &CompareArgs) -> Result<ExitCode> {
    compare::run(&compare_options(args)?)?;
    note!("wrote {}", args.output.join("index.html").display());
    Ok(ExitCode::SUCCESS)
}

/// The comparison `raylab compare` runs for `args`, checked.
pub fn compare_options(args: &CompareArgs) -> Result<CompareOptions> {
    let params = args
        .params
        .iter()
        .map(|p| compare::parse_scoped_param(p))
        .collect::<Result<Vec<_>>>()?;
    // `-p reference.NAME=VALUE` goes to the reference's integrator.
    let (reference_params, params): (Vec<_>, Vec<_>) =
        params.into_iter().partition(|(i, _, _)| i == "reference");
    for (i, _, _) in &params {
        let compared = |spec: &String| {
            spec == i || compare::parse_contestant(spec).is_ok_and(|(name, _)| name == i)
        };
        if !args.integrators.iter().any(compared) {
            bail!("-p names integrator `{i}`, which is not compared (add -i {i}, or -p reference.NAME=VALUE for the reference)");
        }
    }
    let sweep = args.sweep.as_deref().map(parse_sweep).transpose()?;
    let contestants = compare::contestants(
        &args.integrators,
        &params,
        sweep.as_ref().map(|(n, v)| (n.as_str(), v.as_slice())),
    )?;
    let budget = Budget::choose(args.spp, args.time, Budget::Spp(16), ("--spp", "--time"))?;
    let rendered = args.reference_spp.is_some()
        || args.reference_time.is_some()
        || args.reference_integrator != "path"
        || !reference_params.is_empty();
    let reference = match &args.reference {
        Some(_) if rendered => bail!(
            "--reference names a file; --reference-spp, --reference-time, --reference-integrator and -p reference.* describe a reference to render: give one or the other"
        ),
        Some(f) => {
            if !f.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
                bail!(
                    "{}: the reference must be an EXR of linear radiance (a PNG is tonemapped and clipped; render the reference with -o NAME.exr)",
                    f.display()
                );
            }
            ReferenceSpec::File(f.clone())
        }
        None => {
            let budget = Budget::choose(
                args.reference_spp,
                args.reference_time,
                Budget::Spp(1024),
                ("--reference-spp", "--reference-time"),
            )?;
            let params: Vec<(String, String)> =
                reference_params.into_iter().map(|(_, k, v)| (k, v)).collect();
            // Checked now, not after the renders.
            raylab_integrators::registry::find(&args.reference_integrator)
                .and_then(|e| e.resolve(&params).map(|_| ()))
                .map_err(|e| anyhow!("--reference-integrator: {e}"))?;
            ReferenceSpec::Render {
                integrator: args.reference_integrator.clone(),
                params,
                budget,
            }
        }
    };
    if args.runs == 0 || args.runs > 10_000 {
        bail!("--runs must be between 1 and 10000, got {}", args.runs);
    }
    if let Some(t) = args.target_error {
        if !(t.is_finite() && t > 0.0) {
            bail!("--target-error must be a positive MSE, got {t}");
        }
    }
    super::check_threads(args.threads)?;
    super::check_allowed(&args.allow_path)?;
    let size = args
        .size
        .as_deref()
        .map(super::render_cmd::parse_size)
        .transpose()?;
    let region = args.region.as_deref().map(parse_region).transpose()?;
    Ok(CompareOptions {
        scene: args.scene.clone(),
        allowed: args.allow_path.clone(),
        import: args.import.options(),
        contestants,
        budget,
        runs: args.runs,
        target_error: args.target_error,
        reference,
        cache_dir: compare::cache_dir(&args.output),
        out_dir: args.output.clone(),
        threads: args.threads,
        seed: args.seed,
        size,
        progress: !args.quiet,
        note: args.note.clone(),
        region,
        filter: args.trace.filter,
        sampler: args.trace.sampler,
        spectral: args.trace.spectral(),
        accel: args.trace.accel,
    })
}

/// `X,Y,W,H` in pixels.
fn parse_region(text: &str) -> Result<Region> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let numbers: Option<Vec<u32>> = parts.iter().map(|p| p.parse().ok()).collect();
    match numbers.as_deref() {
        Some(&[x, y, w, h]) if w > 0 && h > 0 => Ok(Region { x, y, w, h }),
        _ => bail!("--region: expected X,Y,W,H (whole numbers, W and H at least 1), got `{text}`"),
    }
}

pub fn diff(args: &DiffArgs) -> Result<ExitCode> {
    // Everything that can be refused before reading the images.
    if args.ztest {
        for path in [&args.a, &args.b] {
            if !path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
            {
                bail!(
                    "{}: the z-test compares linear radiance with its variance: give EXR files (a PNG is tonemapped and has none)",
                    path.display()
                );
            }
        }
    }
    if !(args.significance > 0.0 && args.significance < 1.0) {
        bail!(
            "--significance must lie strictly between 0 and 1, got {}",
            args.significance
        );
    }
    if let Some(t) = args.tolerance {
        if !t.is_finite() || (t < 0.0 && args.metric != Metric::Psnr) {
            bail!("--tolerance must be a finite number, at least 0 (for PSNR, any finite dB)");
        }
    }
    if let Some(path) = &args.output {
        let png = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !png {
            bail!("{}: the error map is a PNG; name it .png", path.display());
        }
        output::check_writable_folder(path)?;
        output::atomic::check_replaceable(path)?;
        let mut plan = FilePlan::new();
        plan.input("image A", &args.a)?
            .input("image B", &args.b)?
            .output("the error map", path)?
            .check()?;
    }
    let a = output::read_image(&args.a)?;
    let b = output::read_image(&args.b)?;
    // NaN and infinity make every metric meaningless (NaN compares as within any
    // tolerance): a non-finite pixel in either image is a difference in itself.
    let mut non_finite = false;
    for (name, path, film) in [("A", &args.a, &a), ("B", &args.b, &b)] {
        if let Some((count, (x, y))) = film.non_finite() {
            say!(
                "non-finite: image {name} ({}) has {count} pixel(s) with NaN or infinite values, the first at ({x}, {y})",
                path.display()
            );
            non_finite = true;
        }
    }
    if non_finite {
        say!("differs: an image holds values that are not finite");
        return Ok(ExitCode::from(1));
    }
    let (m, map) = metrics::compare(&a, &b)
        .map_err(|e| anyhow!("{} vs {}: {e}", args.a.display(), args.b.display()))?;
    let ztest = args
        .ztest
        .then(|| compare::ztest::z_test(&a, &b, args.significance))
        .transpose()
        .map_err(|e| anyhow!("{} vs {}: {e}", args.a.display(), args.b.display()))?;
    if let Some(path) = &args.output {
        match &ztest {
            Some(z) => output::write_png(path, &compare::ztest::failure_map(z, &b))?,
            None => output::write_png(path, &metrics::error_map_image(&map, a.width, a.height))?,
        }
    }
    say!("RMSE    {:.6}", m.rmse);
    say!("relMSE  {:.6}", m.rel_mse);
    say!(
        "PSNR    {} dB",
        if m.psnr.is_infinite() {
            "inf".to_string()
        } else {
            format!("{:.3}", m.psnr)
        }
    );
    say!("FLIP    {:.6}", m.flip);
    say!("HDR-FLIP {:.6}", metrics::hdr_flip(&a, &b).0);
    let (ma, mb) = (a.mean(), b.mean());
    say!("mean A  ({:.5}, {:.5}, {:.5})", ma.x, ma.y, ma.z);
    say!("mean B  ({:.5}, {:.5}, {:.5})", mb.x, mb.y, mb.z);
    if let Some(z) = &ztest {
        let noise = match (a.has_variance, b.has_variance) {
            (true, true) => "both images' variance",
            (true, false) => "A's variance only (B has no variance layer)",
            _ => "B's variance only (A has no variance layer)",
        };
        say!(
            "z-test  {} of {} pixels fail at significance {} ({noise}; per channel p < {:.2e}); smallest p {:.2e}",
            z.failed_pixels,
            a.width as u64 * a.height as u64,
            args.significance,
            z.alpha,
            z.min_p
        );
        if let Some((x, y)) = z.first_failure {
            say!("differs: pixel ({x}, {y}) is the first beyond the noise (z-test)");
            return Ok(ExitCode::from(1));
        }
    }
    if let Some(t) = args.tolerance {
        let (value, exceeded) = match args.metric {
            Metric::Rmse => (m.rmse, m.rmse > t),
            Metric::RelMse => (m.rel_mse, m.rel_mse > t),
            Metric::Flip => (m.flip, m.flip > t),
            // Higher PSNR is better: the tolerance is a floor.
            Metric::Psnr => (m.psnr, m.psnr < t),
        };
        if exceeded {
            say!(
                "differs: {:?} {value} is beyond the tolerance {t}",
                args.metric
            );
            return Ok(ExitCode::from(1));
        }
    }
    Ok(ExitCode::SUCCESS)
}

pub fn suite(args: &SuiteArgs) -> Result<ExitCode> {
    super::check_threads(args.threads)?;
    super::check_allowed(&args.allow_path)?;
    let opts = compare::suite::SuiteOptions {
        file: args.file.clone(),
        out_dir: args.output.clone(),
        threads: args.threads,
        progress: !args.quiet,
        allowed: args.allow_path.clone(),
        spectral: args.spectral.then_some(true),
    };
    let standings = compare::suite::run(&opts)?;
    for s in standings.iter().filter(|s| s.rank == 1) {
        say!(
            "{:<24} {} wins (MSE {:.3e}, relMSE {:.3e} in {:.2} s)",
            s.entry,
            s.label,
            s.mse,
            s.relmse,
            s.time
        );
    }
    note!("wrote {}", args.output.join("index.html").display());
    Ok(ExitCode::SUCCESS)
}
