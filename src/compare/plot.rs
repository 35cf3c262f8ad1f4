//! Sweep plots: error (FLIP, which follows what a person sees; RMSE is often dominated by a
//! few aliased emitter edges) against time, and time against the swept value, as SVG and PNG.

use super::{stats, Report, Row};
use anyhow::{anyhow, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Draws a plot of `size` with `draw` (generic over the backend) twice, into `NAME.svg` and
/// `NAME.png` in `dir`; the SVG text.
macro_rules! write_plots {
    ($dir:expr, $name:literal, $size:expr, $draw:ident, $report:expr) => {{
        let mut svg = String::new();
        $draw(
            SVGBackend::with_string(&mut svg, $size).into_drawing_area(),
            $report,
        )?;
        super::write_text(&$dir.join(concat!($name, ".svg")), &svg)?;
        let (w, h) = $size;
        let mut buffer = vec![0u8; (w * h * 3) as usize];
        $draw(
            BitMapBackend::with_buffer(&mut buffer, $size).into_drawing_area(),
            $report,
        )?;
        let img = image::RgbImage::from_raw(w, h, buffer).expect("buffer matches the plot size");
        crate::output::write_png(&$dir.join(concat!($name, ".png")), &img)?;
        Ok(svg)
    }};
}

const SIZE: (u32, u32) = (1000, 420);

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, report: &Report) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("plot: {e}");
    root.fill(&WHITE).map_err(err)?;
    let (left, right) = root.split_horizontally(SIZE.0 / 2);
    let rows: Vec<&Row> = report
        .rows
        .iter()
        .filter(|r| r.swept_value.is_some())
        .collect();
    let param = rows
        .first()
        .and_then(|r| r.swept_param.clone())
        .unwrap_or_default();
    let series: Vec<String> = {
        let mut v: Vec<String> = rows.iter().map(|r| r.integrator.clone()).collect();
        v.dedup();
        v
    };

    // Left: FLIP against time (log), each point labelled with its swept value.
    let t_max = rows.iter().map(|r| r.time).fold(1e-3, f64::max) * 2.0;
    let t_min = rows
        .iter()
        .map(|r| r.time)
        .fold(f64::INFINITY, f64::min)
        .max(1e-4)
        / 2.0;
    let e_max = rows.iter().map(|r| r.flip).fold(1e-6, f64::max) * 1.2;
    let mut chart = ChartBuilder::on(&left)
        .caption("error against time", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((t_min..t_max).log_scale(), 0.0..e_max)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc("FLIP (lower is better)")
        .light_line_style(WHITE)
        .draw()
        .map_err(err)?;
    for (i, name) in series.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let pts: Vec<(f64, f64, String)> = rows
            .iter()
            .filter(|r| &r.integrator == name)
            .map(|r| (r.time, r.flip, r.swept_value.clone().unwrap_or_default()))
            .collect();
        chart
            .draw_series(LineSeries::new(
                pts.iter().map(|p| (p.0, p.1)),
                c.stroke_width(2),
            ))
            .map_err(err)?
            .label(format!("{name}, labelled by {param}"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart
            .draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 4, c.filled())))
            .map_err(err)?;
        chart
            .draw_series(pts.iter().map(|p| {
                EmptyElement::at((p.0, p.1)) + Text::new(p.2.clone(), (6, -18), ("sans-serif", 14))
            }))
            .map_err(err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .border_style(BLACK)
        .background_style(WHITE)
        .draw()
        .map_err(err)?;

    // Right: time against the swept value (numeric values on a linear axis; unlimited ones
    // one step past the largest, labelled).
    let (x_of, unlimited_at) = axis_positions(&rows);
    let xs: Vec<f64> = x_of.iter().flatten().copied().collect();
    let (x_min, x_max) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    let (x_min, x_max) = if x_min.is_finite() {
        (x_min - 0.5, x_max + 0.5)
    } else {
        (0.0, 1.0)
    };
    let mut chart = ChartBuilder::on(&right)
        .caption(format!("time against {param}"), ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x_min..x_max, (t_min..t_max).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(param.clone())
        .x_label_formatter(&|x| match unlimited_at {
            Some(u) if (x - u).abs() < 1e-9 => "unlimited".to_string(),
            _ if (x - x.round()).abs() < 1e-9 => format!("{}", x.round()),
            _ => format!("{x:.2}"),
        })
        .y_desc("time (s)")
        .light_line_style(WHITE)
        .draw()
        .map_err(err)?;
    for (i, name) in series.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .zip(&x_of)
            .filter(|(r, _)| &r.integrator == name)
            .filter_map(|(r, x)| Some(((*x)?, r.time)))
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
            .map_err(err)?;
        chart
            .draw_series(pts.iter().map(|p| Circle::new(*p, 4, c.filled())))
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Each row's place on the swept-value axis: its number when it is a finite one; an
/// unlimited value (`inf`, `unlimited`) one step past the largest finite number (the plotting
/// library cannot draw infinity); `None` for a value that is no number. Also that place, if
/// some value is unlimited, for its label.
fn axis_positions(rows: &[&Row]) -> (Vec<Option<f64>>, Option<f64>) {
    let values: Vec<Option<f64>> = rows
        .iter()
        .map(|r| {
            let v = r.swept_value.as_deref()?.trim();
            match v.to_ascii_lowercase().as_str() {
                "unlimited" | "infinite" => Some(f64::INFINITY),
                _ => v.parse::<f64>().ok().filter(|x| !x.is_nan()),
            }
        })
        .collect();
    let finite: Vec<f64> = values
        .iter()
        .flatten()
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    if !values.iter().flatten().any(|x| x.is_infinite()) {
        return (values, None);
    }
    let (lo, hi) = finite
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    let at = if hi.is_finite() {
        hi + ((hi - lo) * 0.25).max(1.0)
    } else {
        0.0
    };
    let placed = values
        .into_iter()
        .map(|x| x.map(|x| if x.is_infinite() { at } else { x }))
        .collect();
    (placed, Some(at))
}

/// Writes `sweep.svg` and `sweep.png`; returns the SVG text for the page.
pub fn write_sweep_plots(dir: &Path, report: &Report) -> Result<Option<String>> {
    let svg: Result<String> = (|| write_plots!(dir, "sweep", SIZE, draw, report))();
    svg.map(Some)
}

/// The convergence plot: error against time on log-log axes, MSE on the left and relMSE on
/// the right (a few bright fireflies sway the first far more than the second), one curve per
/// contestant (the mean over its runs), its fitted slope in the legend. Points whose error is
/// not positive (the reference's noise subtracted, below it) cannot be drawn on a log axis and
/// are left out.
fn draw_convergence<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, report: &Report) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("plot: {e}");
    root.fill(&WHITE).map_err(err)?;
    let (left, right) = root.split_horizontally(CONVERGENCE_SIZE.0 / 2);
    for (area, metric, name, slope_of) in [
        (
            left,
            stats::MSE,
            "MSE",
            (|r: &Row| r.slope) as fn(&Row) -> Option<f64>,
        ),
        (right, stats::RELMSE, "relMSE", |r: &Row| r.slope_relmse),
    ] {
        let points = |r: &Row| -> Vec<(f64, f64)> {
            r.convergence
                .iter()
                .filter(|p| metric(p) > 0.0 && p.time > 0.0)
                .map(|p| (p.time, metric(p)))
                .collect()
        };
        let all: Vec<(f64, f64)> = report.rows.iter().flat_map(points).collect();
        let range = |f: fn(&(f64, f64)) -> f64| {
            all.iter()
                .map(f)
                .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        };
        let (t0, t1) = range(|p| p.0);
        let (e0, e1) = range(|p| p.1);
        let (t0, t1) = if t0.is_finite() {
            (t0 / 1.5, t1 * 1.5)
        } else {
            (1e-3, 1.0)
        };
        let (e0, e1) = if e0.is_finite() {
            (e0 / 1.5, e1 * 1.5)
        } else {
            (1e-6, 1.0)
        };
        let mut chart = ChartBuilder::on(&area)
            .caption(
                format!("convergence: {name} against time"),
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d((t0..t1).log_scale(), (e0..e1).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .y_desc(format!("{name} (lower is better)"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .light_line_style(WHITE)
            .draw()
            .map_err(err)?;
        for (i, r) in report.rows.iter().enumerate() {
            let c = COLOURS[i % COLOURS.len()];
            let pts = points(r);
            let label = match slope_of(r) {
                Some(s) => format!("{} (slope {s:.2})", r.label),
                None => r.label.clone(),
            };
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))
                .map_err(err)?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, 3, c.filled())))
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// One colour per contestant.
const COLOURS: [RGBColor; 8] = [
    RED,
    BLUE,
    GREEN,
    MAGENTA,
    CYAN,
    BLACK,
    RGBColor(230, 140, 0),
    RGBColor(120, 60, 160),
];

const CONVERGENCE_SIZE: (u32, u32) = (1200, 480);

/// Writes `convergence.svg` and `convergence.png`; returns the SVG text for the page.
pub fn write_convergence_plots(dir: &Path, report: &Report) -> Result<String> {
    write_plots!(
        dir,
        "convergence",
        CONVERGENCE_SIZE,
        draw_convergence,
        report
    )
}

const SPECTRUM_SIZE: (u32, u32) = (700, 420);

/// The error spectrum plot: each contestant's radially averaged power spectrum of its error
/// (mean over runs) against frequency, power on a log axis. Rings with no positive power are
/// left out.
fn draw_spectrum<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, report: &Report) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("plot: {e}");
    root.fill(&WHITE).map_err(err)?;
    let points = |r: &Row| -> Vec<(f64, f64)> {
        report
            .spectrum_frequencies
            .iter()
            .zip(&r.error_spectrum)
            .filter(|(_, p)| **p > 0.0 && p.is_finite())
            .map(|(f, p)| (*f, *p))
            .collect()
    };
    let (lo, hi) = report
        .rows
        .iter()
        .flat_map(points)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), (_, p)| {
            (lo.min(p), hi.max(p))
        });
    let (lo, hi) = if lo.is_finite() {
        (lo / 1.5, hi * 1.5)
    } else {
        (1e-6, 1.0)
    };
    let mut chart = ChartBuilder::on(&root)
        .caption("error spectrum (mean over runs)", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..0.5f64, (lo..hi).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("frequency (cycles per pixel)")
        .y_desc("power of the error")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .light_line_style(WHITE)
        .draw()
        .map_err(err)?;
    for (i, r) in report.rows.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        chart
            .draw_series(LineSeries::new(points(r), c.stroke_width(2)))
            .map_err(err)?
            .label(r.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .border_style(BLACK)
        .background_style(WHITE)
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Writes `spectrum.svg` and `spectrum.png`; returns the SVG text for the page.
pub fn write_spectrum_plots(dir: &Path, report: &Report) -> Result<String> {
    write_plots!(dir, "spectrum", SPECTRUM_SIZE, draw_spectrum, report)
}
