//! What a comparison prints and the tables it writes: a row per contestant on the terminal,
//! a summary, `metrics.json`, `metrics.csv` and `convergence.csv`.

use super::{Report, Row};
use anyhow::{anyhow, Context, Result};
use std::fmt::Write as _;
use std::path::Path;

/// `value ± ci95`, or the value alone from one run.
fn with_interval(value: f64, ci95: Option<f64>, digits: usize) -> String {
    match ci95 {
        Some(ci) => format!("{value:.digits$e} ± {ci:.1e}"),
        None => format!("{value:.digits$e}"),
    }
}

pub(super) fn print_row(r: &Row) {
    let in_region = r.region.map_or(String::new(), |m| {
        format!(
            "  region: MSE {}  relMSE {:.4}  FLIP {:.4}",
            with_interval(m.mse, m.mse_ci95, 3),
            m.relmse,
            m.flip
        )
    });
    let bias = match (r.variance, r.bias2) {
        (Some(v), Some(b)) => format!("  variance {v:.3e}  bias² {b:.2e}"),
        _ => String::new(),
    };
    note!(
        "{:<28} {:>7.1} spp {:>8.2} s  MSE {}  relMSE {:.4} (robust {:.4})  FLIP {:.4}  HDR-FLIP {:.4}{bias}{}{in_region}",
        r.label,
        r.spp,
        r.time,
        with_interval(r.mse, r.mse_ci95, 3),
        r.relmse,
        r.relmse_robust,
        r.flip,
        r.hdrflip,
        r.slope.map_or(String::new(), |s| format!(
            "  slope {s:.2} (relMSE {})",
            r.slope_relmse.map_or("-".into(), |s| format!("{s:.2}"))
        )),
    );
}

/// Efficiency and time to the target error, relative to the most efficient contestant.
pub(super) fn print_summary(rows: &[Row], target: Option<f64>) {
    let best = rows
        .iter()
        .filter_map(|r| r.efficiency)
        .max_by(f64::total_cmp);
    if let Some(t) = target {
        note!("time to reach MSE {t:.3e} (~: extrapolated along the fitted slope):");
    }
    for r in rows {
        let eff = match (r.efficiency, best) {
            (Some(e), Some(b)) => format!("efficiency {e:.3e} ({:.2}x the best)", e / b),
            _ => "efficiency -".to_string(),
        };
        let reach = match r.time_to_target {
            Some(t) => format!(
                "{}{t:.2} s",
                if r.time_to_target_extrapolated {
                    "~"
                } else {
                    ""
                }
            ),
            None => "not within reach (its error does not fall that far)".to_string(),
        };
        note!("  {:<28} {eff}  reaches it in {reach}", r.label);
    }
}

/// `metrics.json` and `metrics.csv`.
pub(super) fn write_tables(dir: &Path, report: &Report) -> Result<()> {
    let json =
        serde_json::to_string_pretty(report).map_err(|e| anyhow!("cannot encode metrics: {e}"))?;
    write_text(&dir.join("metrics.json"), &json)?;
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6e}"));
    let mut csv = String::from(
        "label,integrator,params,sampler,swept_param,swept_value,runs,spp,time,time_ci95,mse,mse_ci95,variance,bias2,relmse,relmse_ci95,flip,flip_ci95,hdrflip,hdrflip_ci95,efficiency,time_to_target,time_to_target_extrapolated,slope,slope_relmse,rmse,psnr,reference_share,ztest_failed_pixels,rays_camera,rays_extension,rays_shadow,rays_light,rays_connection,rays_per_s,samples_per_s,mean_r,mean_g,mean_b,region_mse,region_mse_ci95,region_relmse,region_flip,relmse_robust,relmse_robust_ci95,time_to_unit_variance\n",
    );
    for r in &report.rows {
        let _ = writeln!(
            csv,
            "{},{},\"{}\",{},{},{},{},{:.2},{:.4},{},{:.6e},{},{},{},{:.6e},{},{:.6},{},{:.6},{},{},{},{},{},{},{:.6e},{:.3},{},{},{},{:.0},{:.0},{:.6},{:.6},{:.6},{},{:.6e},{},{}",
            r.label,
            r.integrator,
            r.params,
            r.sampler,
            r.swept_param.as_deref().unwrap_or(""),
            r.swept_value.as_deref().unwrap_or(""),
            r.runs,
            r.spp,
            r.time,
            opt(r.time_ci95),
            r.mse,
            opt(r.mse_ci95),
            opt(r.variance),
            opt(r.bias2),
            r.relmse,
            opt(r.relmse_ci95),
            r.flip,
            opt(r.flip_ci95),
            r.hdrflip,
            opt(r.hdrflip_ci95),
            opt(r.efficiency),
            opt(r.time_to_target),
            r.time_to_target_extrapolated,
            opt(r.slope),
            opt(r.slope_relmse),
            r.rmse,
            r.psnr,
            opt(r.reference_share),
            r.ztest_failed_pixels.map_or(String::new(), |n| n.to_string()),
            r.rays_joined(","),
            r.rays_per_s,
            r.samples_per_s,
            r.mean[0],
            r.mean[1],
            r.mean[2],
            r.region.map_or(",,,".to_string(), |m| format!(
                "{:.6e},{},{:.6e},{:.6}",
                m.mse,
                opt(m.mse_ci95),
                m.relmse,
                m.flip
            )),
            r.relmse_robust,
            opt(r.relmse_robust_ci95),
            opt(r.time_to_unit_variance),
        );
    }
    write_text(&dir.join("metrics.csv"), &csv)
}

/// `convergence.csv`: every contestant's mean curve over its runs.
pub(super) fn write_convergence_csv(dir: &Path, report: &Report) -> Result<()> {
    let mut csv = String::from("label,integrator,spp,time,mse,relmse\n");
    for r in &report.rows {
        for p in &r.convergence {
            let _ = writeln!(
                csv,
                "{},{},{},{:.6},{:.6e},{:.6e}",
                r.label, r.integrator, p.spp, p.time, p.mse, p.relmse
            );
        }
    }
    write_text(&dir.join("convergence.csv"), &csv)
}

/// Writes a text file atomically.
pub(crate) fn write_text(path: &Path, text: &str) -> Result<()> {
    use std::io::Write;
    crate::output::atomic::write_atomic(path, |file| {
        file.write_all(text.as_bytes())
            .with_context(|| format!("{}: cannot write", path.display()))
    })
}
