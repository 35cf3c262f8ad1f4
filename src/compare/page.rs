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
         <th>MSE</th><th>variance</th><th>bias²</th><th>relMSE</th><th>FLIP</th><th>HDR-FLIP</th>\
         <th>efficiency (× best)</th><th>time to target (s)</th><th>slope</th><th>z-test: failing pixels</th>\
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
             <td>{}</td><td>{}</td><td>{}</td><td>{efficiency}</td><td>{reach}</td><td>{}</td><td>{}</td><td>{:.2}</td>\
             <td>{:.4}, {:.4}, {:.4}</td>",
            escape(&r.label),
            escape(&r.label),
            escape(&r.params),
            r.runs,
            r.spp,
            pm_fixed(r.time, r.time_ci95),
            pm(r.mse, r.mse_ci95),
            opt(r.variance),
            opt(r.bias2),
            pm(r.relmse, r.relmse_ci95),
            pm_fixed(r.flip, r.flip_ci95),
            pm_fixed(r.hdrflip, r.hdrflip_ci95),
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

pub fn write(
    dir: &Path,
    report: &Report,
    convergence_svg: &str,
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

    let html = format!(
        r##"<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<title>raylab compare: {scene}</title>
<style>
body {{ font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; color: #222; background: #fafafa; }}
h1 {{ font-size: 1.4em; }}
.controls {{ display: flex; flex-wrap: wrap; gap: 0.6em 1.2em; align-items: center; margin: 0.6em 0; }}
.views {{ display: flex; flex-wrap: wrap; gap: 8px; }}
.panel {{ display: inline-block; }}
.panel canvas {{ display: block; background: #333; cursor: grab; border: 1px solid #999; }}
.panel .name {{ font-size: 0.9em; }}
table {{ border-collapse: collapse; margin: 1em 0; }}
th, td {{ border: 1px solid #ccc; padding: 0.3em 0.6em; text-align: right; white-space: nowrap; }}
th:first-child, td:first-child, td:nth-child(2) {{ text-align: left; }}
.note {{ color: #555; }}
.warning {{ background: #fff3cd; border: 1px solid #e0c36b; padding: 0.5em; }}
#readout {{ font-family: ui-monospace, monospace; font-size: 0.9em; min-height: 1.4em; }}
</style></head>
<body>
<h1>raylab compare: {scene}</h1>
{note}<p class="note">{w}x{h}, {budget}, {runs} run(s) each, {threads} threads, seed {seed}. Reference: {reference}. {reference_noise} MSE and relMSE are on linear radiance, the mean over pixels and channels; FLIP on the displayed images, HDR-FLIP on the radiance over an exposure bracket. With several runs: means with 95% intervals, the per-pixel variance of one run, and the squared bias of the runs' mean.{target}</p>
{warning}
<div class="controls">
  <label>view <select id="mode">
    <option value="slider">A | B slider</option>
    <option value="toggle">A / B toggle (click or space)</option>
    <option value="grid">all images side by side</option>
  </select></label>
  <label>A <select id="a"></select></label>
  <label>B <select id="b"></select></label>
  <label>show <select id="show">
    <option value="image">image</option>
    <option value="relerr">relative error against the reference (false colour)</option>
    <option value="flip">FLIP error map</option>
    <option value="ztest">z-test: failing pixels in red</option>
  </select></label>
  <label>channel <select id="channel">
    <option value="rgb">RGB</option><option value="r">R</option><option value="g">G</option><option value="b">B</option><option value="y">luminance</option>
  </select></label>
  <label>exposure <input type="range" id="exposure" min="-10" max="10" step="0.1" value="0"> <span id="ev">0.0</span> EV</label>
  <label>split <input type="range" id="split" min="0" max="100" value="50"></label>
  <label>zoom <select id="zoom"><option value="1">fit</option><option>2</option><option>4</option><option>8</option><option>16</option><option>32</option></select></label>
  <button id="reset">reset view</button>
</div>
<div id="readout"></div>
<div class="views" id="views"></div>
<h2>Metrics</h2>
{table}
<p class="note">Also as <a href="metrics.json">metrics.json</a> and <a href="metrics.csv">metrics.csv</a>; a picture of the renders in <a href="mosaic.png">mosaic.png</a>.</p>
<h2>Convergence</h2>
<div class="plot">{convergence_svg}</div>
<p class="note">The mean over the runs of each render's MSE after log-spaced passes, against its render time; the data in <a href="convergence.csv">convergence.csv</a>, the plot also as <a href="convergence.svg">convergence.svg</a> and <a href="convergence.png">convergence.png</a>. An unbiased estimator falls with slope -1; a consistent one more slowly at first.</p>
{sweep}
<pre id="selftest" hidden></pre>
<script>
"use strict";
const DATA = {data};
const $ = (id) => document.getElementById(id);
const W = DATA.width, H = DATA.height;
// Shared view: zoom relative to fit, and the image point at the canvases' centre.
const view = {{ zoom: 1, cx: W / 2, cy: H / 2 }};
let flipped = false;
const hdr = {{}}, maps = {{}};

function decode(b64) {{
  const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
  const out = new Float32Array(W * H * 3);
  for (let i = 0; i < W * H; i++) {{
    const e = bytes[4 * i + 3];
    if (e === 0) continue;
    const f = Math.pow(2, e - 136);
    for (let c = 0; c < 3; c++) out[3 * i + c] = (bytes[4 * i + c] + 0.5) * f;
  }}
  return out;
}}

function loadImage(src) {{
  return new Promise((ok, fail) => {{ const i = new Image(); i.onload = () => ok(i); i.onerror = fail; i.src = src; }});
}}

const srgb = (x) => x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
const byte = (x) => Math.max(0, Math.min(255, Math.round(255 * srgb(Math.max(0, Math.min(1, x))))));
// A perceptual ramp (viridis at five stops) for false colour, t in [0, 1].
const RAMP = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
function ramp(t) {{
  t = Math.max(0, Math.min(1, t)) * (RAMP.length - 1);
  const i = Math.min(RAMP.length - 2, Math.floor(t)), f = t - i;
  return RAMP[i].map((v, c) => Math.round(v + f * (RAMP[i + 1][c] - v)));
}}

// What the controls ask of an image, as a cache key: tonemapping every image again on every
// mouse move would make panning a large image crawl.
const settings = () => [$("show").value, $("channel").value, $("exposure").value].join("|");
const cache = new Map();
function cached(kind, name, make) {{
  const key = kind + "|" + name + "|" + settings();
  if (!cache.has(key)) {{ if (cache.size > 8 * DATA.order.length) cache.clear(); cache.set(key, make()); }}
  return cache.get(key);
}}

// The 8-bit RGBA pixels of image `name` as the controls ask for them.
function pixels(name) {{ return cached("pixels", name, () => tonemap(name)); }}
function tonemap(name) {{
  const show = $("show").value, ch = $("channel").value;
  const scale = Math.pow(2, Number($("exposure").value));
  const out = new ImageData(W, H), d = out.data, src = hdr[name], ref = hdr[DATA.order[0]];
  for (let i = 0; i < W * H; i++) {{
    let rgb;
    if (show === "relerr") {{
      let e = 0;
      for (let c = 0; c < 3; c++) {{ const r = ref[3 * i + c], x = src[3 * i + c] - r; e += x * x / (r * r + 0.01); }}
      // 1e-4 to 1 on a log scale.
      rgb = ramp((Math.log10(e / 3 + 1e-12) + 4) / 4);
    }} else {{
      let [r, g, b] = [src[3 * i] * scale, src[3 * i + 1] * scale, src[3 * i + 2] * scale];
      if (ch === "r") g = b = r; else if (ch === "g") r = b = g; else if (ch === "b") r = g = b;
      else if (ch === "y") r = g = b = 0.2126 * r + 0.7152 * g + 0.0722 * b;
      rgb = [byte(r), byte(g), byte(b)];
    }}
    d[4 * i] = rgb[0]; d[4 * i + 1] = rgb[1]; d[4 * i + 2] = rgb[2]; d[4 * i + 3] = 255;
  }}
  return out;
}}

// An offscreen canvas with image `name` at its own resolution.
function source(name) {{ return cached("source", name, () => offscreen(name)); }}
function offscreen(name) {{
  const show = $("show").value;
  const c = document.createElement("canvas"); c.width = W; c.height = H;
  const g = c.getContext("2d");
  const map = maps[name] && maps[name][show];
  if (show === "flip" || show === "ztest") {{
    if (map) g.drawImage(map, 0, 0); else g.putImageData(pixels(name), 0, 0);
  }} else {{
    g.putImageData(pixels(name), 0, 0);
  }}
  return c;
}}

function panelSize() {{
  const grid = $("mode").value === "grid";
  const max = grid ? 360 : 720;
  const fit = Math.min(max / W, max / H);
  return {{ fit, w: Math.round(W * fit), h: Math.round(H * fit) }};
}}

// Draws `src` into `canvas` under the shared view.
function paint(canvas, src, clipTo) {{
  const {{ fit, w, h }} = panelSize();
  canvas.width = w; canvas.height = h;
  const g = canvas.getContext("2d", {{ willReadFrequently: true }});
  g.imageSmoothingEnabled = false;
  const s = fit * view.zoom;
  g.setTransform(1, 0, 0, 1, 0, 0);
  g.fillStyle = "#333"; g.fillRect(0, 0, w, h);
  if (clipTo !== undefined) {{ g.save(); g.beginPath(); g.rect(0, 0, clipTo, h); g.clip(); }}
  g.setTransform(s, 0, 0, s, w / 2 - view.cx * s, h / 2 - view.cy * s);
  g.drawImage(src, 0, 0);
  if (clipTo !== undefined) g.restore();
  canvas.dataset.view = [view.zoom, view.cx, view.cy].join(",");
}}

// The image pixel under canvas position (x, y).
function imagePoint(x, y) {{
  const {{ fit, w, h }} = panelSize();
  const s = fit * view.zoom;
  return [Math.floor(view.cx + (x - w / 2) / s), Math.floor(view.cy + (y - h / 2) / s)];
}}

function panel(name, label) {{
  const p = document.createElement("div"); p.className = "panel";
  const c = document.createElement("canvas"); c.dataset.name = name;
  const t = document.createElement("div"); t.className = "name"; t.textContent = label;
  p.appendChild(c); p.appendChild(t); $("views").appendChild(p);
  attach(c);
  return c;
}}

function draw() {{
  $("ev").textContent = Number($("exposure").value).toFixed(1);
  const mode = $("mode").value, a = $("a").value, b = $("b").value;
  $("views").innerHTML = "";
  if (mode === "grid") {{
    for (const n of DATA.order) paint(panel(n, n), source(n));
  }} else if (mode === "slider") {{
    const c = panel(a + "|" + b, "left: " + a + ", right: " + b);
    const {{ w }} = panelSize();
    const x = Math.round(w * Number($("split").value) / 100);
    paint(c, source(b));
    const g = c.getContext("2d");
    const tmp = document.createElement("canvas"); paint(tmp, source(a));
    g.setTransform(1, 0, 0, 1, 0, 0);
    if (x > 0) g.drawImage(tmp, 0, 0, x, c.height, 0, 0, x, c.height);
    g.fillStyle = "rgba(255,255,255,0.8)"; g.fillRect(Math.min(x, c.width - 1), 0, 1, c.height);
  }} else {{
    const n = flipped ? b : a;
    paint(panel(n, "showing " + n + " (click or space: flip)"), source(n));
  }}
}}

function readout(x, y) {{
  const [i, j] = imagePoint(x, y);
  if (i < 0 || j < 0 || i >= W || j >= H) {{ $("readout").textContent = ""; return; }}
  const k = 3 * (j * W + i), f = (n) => Array.from(hdr[n].slice(k, k + 3)).map((v) => v.toPrecision(4)).join(", ");
  $("readout").textContent = "(" + i + ", " + j + ")  A " + $("a").value + ": " + f($("a").value) + "   B " + $("b").value + ": " + f($("b").value);
}}

// Dragging pans; the state lives outside the canvases, which every draw replaces.
let drag = null, moved = false;
window.addEventListener("mouseup", () => {{ drag = null; }});
let frame = false;
window.addEventListener("mousemove", (e) => {{
  if (!drag) return;
  const s = panelSize().fit * view.zoom;
  view.cx -= (e.clientX - drag.x) / s; view.cy -= (e.clientY - drag.y) / s;
  drag.x = e.clientX; drag.y = e.clientY; moved = true;
  // One redraw per frame however many moves arrive.
  if (!frame) {{ frame = true; requestAnimationFrame(() => {{ frame = false; draw(); }}); }}
}});

function attach(c) {{
  c.addEventListener("wheel", (e) => {{
    e.preventDefault();
    const r = c.getBoundingClientRect(), [px, py] = [e.clientX - r.left, e.clientY - r.top];
    const {{ fit, w, h }} = panelSize(), s0 = fit * view.zoom;
    const ix = view.cx + (px - w / 2) / s0, iy = view.cy + (py - h / 2) / s0;
    view.zoom = Math.max(1, Math.min(64, view.zoom * (e.deltaY < 0 ? 1.25 : 0.8)));
    const s1 = fit * view.zoom;
    view.cx = ix - (px - w / 2) / s1; view.cy = iy - (py - h / 2) / s1;
    $("zoom").value = [1, 2, 4, 8, 16, 32].includes(view.zoom) ? String(view.zoom) : $("zoom").value;
    draw();
  }}, {{ passive: false }});
  c.addEventListener("mousedown", (e) => {{ drag = {{ x: e.clientX, y: e.clientY }}; moved = false; e.preventDefault(); }});
  c.addEventListener("mousemove", (e) => {{ const r = c.getBoundingClientRect(); readout(e.clientX - r.left, e.clientY - r.top); }});
  c.addEventListener("click", () => {{ if ($("mode").value === "toggle" && !moved) {{ flipped = !flipped; draw(); }} }});
}}

// ---- self-test: drives the controls through their events and checks the canvases ----
function fire(id, value, kind) {{ $(id).value = value; $(id).dispatchEvent(new Event(kind)); }}
function shown(canvas, x, y) {{ return Array.from(canvas.getContext("2d").getImageData(x, y, 1, 1).data).slice(0, 3); }}
function expected(name, i, j) {{
  const d = pixels(name).data, k = 4 * (j * W + i);
  return [d[k], d[k + 1], d[k + 2]];
}}
const same = (p, q) => p.every((v, i) => v === q[i]);
const centre = (c) => [Math.floor(c.width / 2), Math.floor(c.height / 2)];
const panels = () => Array.from(document.querySelectorAll("#views canvas"));
// Every panel shows, at its centre, its own image's pixel (i, j).
const panelsShow = (i, j) => panels().every((p) => same(shown(p, ...centre(p)), expected(p.dataset.name.split("|")[0], i, j)));

function selftest() {{
  const checks = {{}};
  const names = DATA.order, a = names[names.length - 1], ref = names[0];
  // The radiance decodes to what raylab wrote, within RGBE's precision.
  checks.radiance_decodes = DATA.probes.every((p) => p.rgb.every((v, c) => Math.abs(hdr[p.name][3 * p.index + c] - v) <= 0.01 * Math.max(...p.rgb) + 1e-30));
  fire("mode", "slider", "change"); fire("a", a, "change"); fire("b", ref, "change");
  // A pixel where A and the reference differ on screen, darkening the exposure until one
  // does (bright images clip to the same white).
  let spot = null, ev = 0;
  for (; ev >= -12 && !spot; ev -= 2) {{
    fire("exposure", ev, "input");
    for (let j = 0; j < H && !spot; j++)
      for (let i = 0; i < W && !spot; i++)
        if (!same(expected(a, i, j), expected(ref, i, j))) spot = [i, j];
  }}
  ev += 2;
  if (!spot) {{ document.title = "selftest: inconclusive (the images are identical)"; return; }}
  // The spot at the canvases' centre, at least two canvas pixels to an image pixel.
  view.zoom = Math.max(1, Math.ceil(2 / panelSize().fit)); view.cx = spot[0] + 0.5; view.cy = spot[1] + 0.5;
  const canvas = () => panels()[0];
  const at = () => centre(canvas());
  fire("split", 100, "input");
  checks.slider_shows_a = same(shown(canvas(), ...at()), expected(a, ...spot));
  fire("split", 0, "input");
  checks.slider_shows_b = same(shown(canvas(), ...at()), expected(ref, ...spot));
  // Switching image A through its menu shows the new image (one that differs there).
  const other = names.find((n) => n !== a && !same(expected(n, ...spot), expected(a, ...spot)));
  fire("split", 100, "input"); fire("a", other, "change");
  checks.switching_images = same(shown(canvas(), ...at()), expected(other, ...spot));
  fire("a", a, "change");
  // Two stops less exposure darken the canvas, or two more brighten it.
  const total = () => {{ const c = canvas(); return c.getContext("2d").getImageData(0, 0, c.width, c.height).data.reduce((s, v) => s + v, 0); }};
  const before = total();
  fire("exposure", ev - 2, "input");
  const darker = total();
  fire("exposure", ev + 2, "input");
  const brighter = total();
  checks.exposure = darker < before || brighter > before;
  fire("exposure", ev, "input");
  // The red channel alone: grey levels of the red.
  fire("channel", "r", "change");
  const red = shown(canvas(), ...at());
  checks.channel_view = red[0] === red[1] && red[1] === red[2] && red[0] === expected(a, ...spot)[0];
  fire("channel", "rgb", "change");
  // Grid: every image, each showing its own pixel at the shared point.
  fire("mode", "grid", "change");
  // The grid's panels are half the slider's: zoom in again to two canvas pixels an image pixel.
  view.zoom = Math.max(view.zoom, Math.ceil(2 / panelSize().fit)); draw();
  checks.grid_shows_every_image = panels().length === names.length && panelsShow(...spot);
  // The wheel over one panel zooms every panel about the cursor: the point under it stays.
  const zoom = view.zoom, p0 = canvas(), r0 = p0.getBoundingClientRect(), [cx, cy] = centre(p0);
  p0.dispatchEvent(new WheelEvent("wheel", {{ deltaY: -100, clientX: r0.left + cx + 0.5, clientY: r0.top + cy + 0.5, bubbles: true, cancelable: true }}));
  checks.wheel_zooms_every_panel = view.zoom > zoom && panelsShow(...spot);
  // Dragging one panel pans them all: three image pixels towards the image's middle. A mouse
  // event's clientX is a whole CSS pixel (Chromium truncates a fractional one), so the drag is
  // a whole number of them, the nearest to three image pixels, and the check reads the image
  // pixel that the panels' centre pixel samples, as the page maps it.
  const step = spot[0] < W / 2 ? 3 : -3, s = panelSize().fit * view.zoom, dx = Math.round(step * s);
  const from = view.cx, p1 = canvas(), r1 = p1.getBoundingClientRect();
  const x0 = Math.round(r1.left + cx), y0 = Math.round(r1.top + cy);
  p1.dispatchEvent(new MouseEvent("mousedown", {{ clientX: x0, clientY: y0, bubbles: true }}));
  window.dispatchEvent(new MouseEvent("mousemove", {{ clientX: x0 - dx, clientY: y0 }}));
  window.dispatchEvent(new MouseEvent("mouseup", {{ clientX: x0 - dx, clientY: y0 }}));
  draw();
  const [di, dj] = imagePoint(cx + 0.5, cy + 0.5);
  checks.drag_pans_every_panel = Math.abs(view.cx - from - dx / s) < 1e-9 && di === spot[0] + step && dj === spot[1] && panelsShow(di, dj);
  fire("zoom", "1", "change"); fire("mode", "slider", "change");
  // The metrics table has a row for every render.
  const rows = Array.from(document.querySelectorAll("#metrics tbody tr")).map((r) => r.dataset.label);
  checks.table_rows = rows.length === names.length - 1 && rows.every((r, i) => r === names[i + 1]);
  $("selftest").textContent = JSON.stringify(checks);
  const failed = Object.keys(checks).filter((k) => !checks[k]);
  document.title = failed.length === 0 ? "selftest: ok" : "selftest: FAIL " + failed.join(", ");
}}

async function main() {{
  for (const n of DATA.order) {{
    const d = DATA.images[n];
    hdr[n] = decode(d.rgbe);
    maps[n] = {{}};
    for (const k of ["flip", "ztest"]) if (d[k]) maps[n][k] = await loadImage(d[k]);
  }}
  for (const id of ["a", "b"]) {{
    for (const n of DATA.order) {{ const o = document.createElement("option"); o.value = o.textContent = n; $(id).appendChild(o); }}
  }}
  $("a").value = DATA.order[DATA.order.length > 1 ? 1 : 0];
  $("b").value = DATA.order[0];
  for (const id of ["a", "b", "mode", "show", "channel"]) $(id).addEventListener("change", draw);
  $("zoom").addEventListener("change", () => {{ view.zoom = Number($("zoom").value); draw(); }});
  for (const id of ["split", "exposure"]) $(id).addEventListener("input", draw);
  $("reset").addEventListener("click", () => {{ view.zoom = 1; view.cx = W / 2; view.cy = H / 2; $("zoom").value = "1"; draw(); }});
  document.addEventListener("keydown", (e) => {{
    if (e.code === "Space" && $("mode").value === "toggle") {{ e.preventDefault(); flipped = !flipped; draw(); }}
  }});
  draw();
  if (location.hash === "#selftest") selftest();
}}
main();
</script>
</body></html>
"##,
        scene = escape(&report.scene),
        w = report.width,
        h = report.height,
        budget = escape(&report.budget),
        runs = report.runs,
        threads = report.threads,
        seed = report.seed,
        reference = escape(&report.reference),
        table = table(report),
        note = report
            .note
            .as_deref()
            .map(|n| format!("<p><strong>{}</strong></p>", escape(n)))
            .unwrap_or_default(),
    );
    super::write_text(&dir.join("index.html"), &html)
}
