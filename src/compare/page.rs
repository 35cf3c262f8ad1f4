//! `index.html`: one self-contained page (no network, no other file) that is the viewer of a
//! comparison. Every image is embedded as linear radiance (RGBE, 8-bit mantissas sharing an
//! exponent: about 1% precision), so the page tonemaps it itself: an exposure slider, a
//! per-channel view, false-colour error maps computed from the radiance, FLIP's and the
//! z-test's maps, A/B slider and toggle views and a grid of every image, all sharing one zoom
//! and pan (wheel to zoom at the cursor, drag to pan). Below: the metrics table with 95%
//! intervals, the convergence plot and, for sweeps, the sweep plot.
//!
//! Opening the page with `#selftest` makes it drive its own controls through their events
//! (switch images, move the slider, change exposure, zoom in the grid) and check what the
//! canvases show; it puts the verdict in the title and each check in `#selftest`, which the
//! headless-Chromium test reads.
//!
//! The page is three real files beside this module (`page.html`, `page.css`, `page.js`), put
//! together when raylab is built; the HTML marks where each value goes (`@@name@@`), and the
//! data (images, probes) is a JSON block the script parses.

use super::Report;
use crate::render::Film;
use anyhow::{Context, Result};
use base64::Engine as _;
use std::fmt::Write as _;
use std::path::Path;

pub(super) fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn base64(bytes: &[u8]) -> String {
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

fn png_uri(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    Ok(format!("data:image/png;base64,{}", base64(&bytes)))
}

/// Radiance as RGBE (Ward's shared exponent): four bytes a pixel, negative values as zero.
pub fn rgbe(film: &Film) -> Vec<u8> {
    let mut out = Vec::with_capacity(film.pixels.len() * 4);
    for p in &film.pixels {
        let p = p.max(glam::Vec3::ZERO);
        let m = p.max_element();
        if !(m > 1e-32 && m.is_finite()) {
            out.extend_from_slice(&[0, 0, 0, 0]);
            continue;
        }
        // m = f * 2^e with f in [0.5, 1).
        let mut e = m.log2().floor() as i32 + 1;
        if m / (e as f32).exp2() >= 1.0 {
            e += 1;
        }
        let e = e.clamp(-127, 127);
        let scale = 256.0 / (e as f32).exp2();
        let byte = |v: f32| (v * scale).min(255.0) as u8;
        out.extend_from_slice(&[byte(p.x), byte(p.y), byte(p.z), (e + 128) as u8]);
    }
    out
}

/// `value ± ci`, or the value alone.
fn pm(value: f64, ci: Option<f64>) -> String {
    match ci {
        Some(ci) => format!("{value:.3e} ± {ci:.1e}"),
        None => format!("{value:.3e}"),
    }
}

fn pm_fixed(value: f64, ci: Option<f64>) -> String {
    match ci {
        Some(ci) => format!("{value:.4} ± {ci:.4}"),
        None => format!("{value:.4}"),
    }
}

fn opt(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{v:.2e}"))
}

fn table(report: &Report) -> String {
    let best = report
        .rows
        .iter()
        .filter_map(|r| r.efficiency)
        .max_by(f64::total_cmp);
    let mut t = String::from(
        "<table id=\"metrics\"><thead><tr><th>render</th><th>parameters</th><th>runs</th><th>spp</th><th>time (s)</th>\
         <th>MSE</th><th>variance</th><th>bias²</th><th>relMSE</th><th>relMSE, 0.1% outliers out</th><th>FLIP</th><th>HDR-FLIP</th>\
         <th>efficiency (× best)</th><th>time to unit variance (s)</th><th>time to target (s)</th><th>slope</th><th>z-test: failing pixels</th>\
         <th>M rays/s</th><th>mean radiance</th>",
    );
    if let Some(region) = report.region {
        let _ = write!(
            t,
            "<th>MSE in {region}</th><th>relMSE in region</th><th>FLIP in region</th>"
        );
    }
    t.push_str("</tr></thead><tbody>");
    for r in &report.rows {
        let efficiency = match (r.efficiency, best) {
            (Some(e), Some(b)) => format!("{e:.3e} ({:.2}×)", e / b),
            _ => "–".into(),
        };
        let reach = r.time_to_target.map_or("–".into(), |s| {
            format!(
                "{}{s:.2}",
                if r.time_to_target_extrapolated {
                    "~"
                } else {
                    ""
                }
            )
        });
        let _ = write!(
            t,
            "<tr data-label=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{efficiency}</td><td>{}</td><td>{reach}</td><td>{}</td><td>{}</td><td>{:.2}</td>\
             <td>{:.4}, {:.4}, {:.4}</td>",
            escape(&r.label),
            escape(&r.label),
            escape(&format!("{} sampler={}", r.params, r.sampler)),
            r.runs,
            r.spp,
            pm_fixed(r.time, r.time_ci95),
            pm(r.mse, r.mse_ci95),
            opt(r.variance),
            opt(r.bias2),
            pm(r.relmse, r.relmse_ci95),
            pm(r.relmse_robust, r.relmse_robust_ci95),
            pm_fixed(r.flip, r.flip_ci95),
            pm_fixed(r.hdrflip, r.hdrflip_ci95),
            opt(r.time_to_unit_variance),
            r.slope.map_or("–".into(), |s| format!("{s:.2}")),
            r.ztest_failed_pixels
                .map_or("–".into(), |n| format!("{n} of {}", report.width * report.height)),
            r.rays_per_s / 1e6,
            r.mean[0],
            r.mean[1],
            r.mean[2],
        );
        if let Some(m) = r.region {
            let _ = write!(
                t,
                "<td>{}</td><td>{:.3e}</td><td>{:.4}</td>",
                pm(m.mse, m.mse_ci95),
                m.relmse,
                m.flip
            );
        }
        t.push_str("</tr>");
    }
    t.push_str("</tbody></table>");
    t
}

/// The page's template: `page.html` with its style (`page.css`) and script (`page.js`)
/// inlined where it marks them, and `@@name@@` where a value goes.
fn template() -> String {
    include_str!("page.html")
        .replace("/* page.css */", include_str!("page.css"))
        .replace("/* page.js */", include_str!("page.js"))
}

/// `template` with each `@@name@@` replaced by its value, in one pass (a value is never read
/// again for markers: a scene named `@@table@@` stays its name).
fn fill(template: &str, values: &[(&str, String)]) -> String {
    let mut out = String::with_capacity(template.len());
    let mut rest = template;
    while let Some(start) = rest.find("@@") {
        out.push_str(&rest[..start]);
        let after = &rest[start + 2..];
        match after.find("@@").and_then(|end| {
            let name = &after[..end];
            values
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| (v, end))
        }) {
            Some((value, end)) => {
                out.push_str(value);
                rest = &after[end + 2..];
            }
            None => {
                out.push_str("@@");
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

pub fn write(
    dir: &Path,
    report: &Report,
    (convergence_svg, spectrum_svg): (&str, &str),
    sweep_svg: Option<&str>,
) -> Result<()> {
    // Every image as radiance, with its error maps.
    let mut images = serde_json::Map::new();
    let order: Vec<String> = std::iter::once("reference".to_string())
        .chain(report.rows.iter().map(|r| r.label.clone()))
        .collect();
    // A few pixels' radiance as written, which the self-test checks the decoder against.
    let mut probes = Vec::new();
    for name in &order {
        let film = crate::output::read_image(&dir.join(format!("{name}.exr")))?;
        let brightest = (0..film.pixels.len())
            .max_by(|&i, &j| {
                film.pixels[i]
                    .max_element()
                    .total_cmp(&film.pixels[j].max_element())
            })
            .unwrap_or(0);
        for index in [0, film.pixels.len() / 2, brightest] {
            let p = film.pixels[index].max(glam::Vec3::ZERO);
            probes.push(serde_json::json!({ "name": name, "index": index, "rgb": p.to_array() }));
        }
        let mut entry = serde_json::Map::new();
        entry.insert("rgbe".into(), base64(&rgbe(&film)).into());
        for (key, suffix) in [("flip", "-error.png"), ("ztest", "-ztest.png")] {
            let file = dir.join(format!("{name}{suffix}"));
            if name != "reference" && file.exists() {
                entry.insert(key.into(), png_uri(&file)?.into());
            }
        }
        images.insert(name.clone(), entry.into());
    }
    let data = serde_json::json!({ "order": order, "images": images, "probes": probes, "width": report.width, "height": report.height });
    // `</` cannot appear in the JSON of base64 strings and labels, but be safe inside <script>.
    let data = data.to_string().replace("</", "<\\/");

    // Inline SVG needs no namespace; the page names no address at all.
    let inline = |svg: &str| svg.replace(" xmlns=\"http://www.w3.org/2000/svg\"", "");
    let convergence_svg = inline(convergence_svg);
    let spectrum_svg = inline(spectrum_svg);
    let sweep_svg = sweep_svg.map(inline);
    let sweep = sweep_svg
        .map(|svg| format!("<h2>Sweep</h2><div class=\"plot\">{svg}</div><p>Also as <a href=\"sweep.svg\">sweep.svg</a> and <a href=\"sweep.png\">sweep.png</a>.</p>"))
        .unwrap_or_default();
    let reference_noise = match report.reference_variance {
        Some(v) => format!(
            "Its per-pixel variance (mean {v:.3e}) is subtracted from every MSE and relMSE."
        ),
        None => "It carries no variance layer: its own noise is counted in every error.".into(),
    };
    let warning = report
        .reference_warning
        .as_deref()
        .map(|w| {
            format!(
                "<p class=\"warning\" id=\"warning\">Warning: {}</p>",
                escape(w)
            )
        })
        .unwrap_or_default();
    let target = report.target_error.map_or(String::new(), |t| {
        format!(" Time to target: seconds to reach MSE {t:.3e} on the convergence curve (~: extrapolated along its fitted slope).")
    });

    let note = report
        .note
        .as_deref()
        .map(|n| format!("<p><strong>{}</strong></p>", escape(n)))
        .unwrap_or_default();
    let html = fill(
        &template(),
        &[
            ("scene", escape(&report.scene)),
            ("w", report.width.to_string()),
            ("h", report.height.to_string()),
            ("budget", escape(&report.budget)),
            ("runs", report.runs.to_string()),
            ("threads", report.threads.to_string()),
            ("seed", report.seed.to_string()),
            ("reference", escape(&report.reference)),
            ("reference_noise", reference_noise),
            ("target", target),
            ("note", note),
            ("warning", warning),
            ("table", table(report)),
            ("convergence_svg", convergence_svg),
            ("spectrum_svg", spectrum_svg),
            ("sweep", sweep),
            ("data", data),
        ],
    );
    super::write_text(&dir.join("index.html"), &html)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_fill_their_places_once_and_the_page_inlines_its_files() {
        let filled = fill(
            "<h1>@@scene@@</h1>@@table@@@@unknown@@",
            &[("scene", "@@table@@".into()), ("table", "<table>".into())],
        );
        assert_eq!(filled, "<h1>@@table@@</h1><table>@@unknown@@");
        let page = template();
        assert!(page.contains("<style>") && page.contains("font: 14px/1.4 system-ui"));
        assert!(page.contains("JSON.parse(") && page.contains("function selftest()"));
        assert!(!page.contains("/* page.css */") && !page.contains("/* page.js */"));
        assert!(
            !page.contains("{{") && !page.contains("}}"),
            "braces left doubled"
        );
    }
}
