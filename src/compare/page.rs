//! `index.html`: one self-contained page (images embedded, no network) with the renders side
//! by side, a viewer that flips or slides between any two images with pixel-exact zoom, a
//! false-colour error view, the metrics table and the sweep plot.
//!
//! Opening the page with `#selftest` makes it check its own viewer (the slider must change the
//! shown image) and put the verdict in the title; the headless-Chromium test reads it.

use super::Report;
use anyhow::{Context, Result};
use base64::Engine as _;
use std::fmt::Write as _;
use std::path::Path;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn data_uri(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    Ok(format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    ))
}

fn fmt_metric(v: f64, digits: usize) -> String {
    if v.is_infinite() {
        "inf".into()
    } else {
        format!("{v:.digits$}")
    }
}

pub fn write(dir: &Path, report: &Report, sweep_svg: Option<&str>) -> Result<()> {
    // Images, embedded: the reference and every render with its error map.
    let mut images = serde_json::Map::new();
    let mut entry = serde_json::Map::new();
    entry.insert("src".into(), data_uri(&dir.join("reference.png"))?.into());
    images.insert("reference".into(), entry.into());
    for r in &report.rows {
        let mut entry = serde_json::Map::new();
        entry.insert(
            "src".into(),
            data_uri(&dir.join(format!("{}.png", r.label)))?.into(),
        );
        entry.insert(
            "error".into(),
            data_uri(&dir.join(format!("{}-error.png", r.label)))?.into(),
        );
        images.insert(r.label.clone(), entry.into());
    }
    let order: Vec<String> = std::iter::once("reference".to_string())
        .chain(report.rows.iter().map(|r| r.label.clone()))
        .collect();
    let data = serde_json::json!({ "order": order, "images": images, "width": report.width, "height": report.height });
    // `</` cannot appear in the JSON of base64 strings and labels, but be safe inside <script>.
    let data = data.to_string().replace("</", "<\\/");

    let mut table = String::from(
        "<table id=\"metrics\"><thead><tr><th>render</th><th>parameters</th><th>spp</th><th>time (s)</th>\
         <th>rays (camera / extension / shadow / light / connection)</th><th>M rays/s</th><th>mean radiance</th>\
         <th>RMSE</th><th>relMSE</th><th>PSNR (dB)</th><th>FLIP</th>",
    );
    if let Some(region) = report.region {
        let _ = write!(
            table,
            "<th>RMSE in {region}</th><th>relMSE in region</th><th>FLIP in region</th>"
        );
    }
    table.push_str("</tr></thead><tbody>");
    for r in &report.rows {
        let _ = write!(
            table,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{}</td><td>{:.2}</td>\
             <td>{:.4}, {:.4}, {:.4}</td><td>{:.5}</td><td>{:.5}</td><td>{}</td><td>{:.4}</td>",
            escape(&r.label),
            escape(&r.params),
            r.spp,
            r.time_s,
            r.rays_joined(" / "),
            r.rays_per_s / 1e6,
            r.mean[0],
            r.mean[1],
            r.mean[2],
            r.metrics.rmse,
            r.metrics.rel_mse,
            fmt_metric(r.metrics.psnr, 2),
            r.metrics.flip
        );
        if let Some(m) = r.region {
            let _ = write!(
                table,
                "<td>{:.5}</td><td>{:.5}</td><td>{:.4}</td>",
                m.rmse, m.rel_mse, m.flip
            );
        }
        table.push_str("</tr>");
    }
    table.push_str("</tbody></table>");

    let mut gallery = String::new();
    for name in &order {
        let caption = match report.rows.iter().find(|r| &r.label == name) {
            Some(r) => format!(
                "{} — {} spp, {:.2} s, FLIP {:.4}",
                escape(name),
                r.spp,
                r.time_s,
                r.metrics.flip
            ),
            None => "reference".to_string(),
        };
        let _ = write!(
            gallery,
            "<figure><img class=\"full\" data-name=\"{}\" width=\"{}\" height=\"{}\" alt=\"{}\"><figcaption>{caption}</figcaption></figure>",
            escape(name),
            report.width,
            report.height,
            escape(name)
        );
    }

    let sweep = sweep_svg
        .map(|svg| format!("<h2>Sweep</h2><div class=\"plot\">{svg}</div><p>Also as <a href=\"sweep.svg\">sweep.svg</a> and <a href=\"sweep.png\">sweep.png</a>.</p>"))
        .unwrap_or_default();

    let html = format!(
        r##"<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<title>raylab compare: {scene}</title>
<style>
body {{ font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; color: #222; background: #fafafa; }}
h1 {{ font-size: 1.4em; }}
.controls {{ display: flex; flex-wrap: wrap; gap: 1em; align-items: center; margin: 0.8em 0; }}
#viewport {{ overflow: auto; max-width: 100%; max-height: 80vh; border: 1px solid #ccc; background: #333; display: inline-block; }}
canvas, img.full {{ image-rendering: pixelated; image-rendering: crisp-edges; display: block; }}
table {{ border-collapse: collapse; margin: 1em 0; }}
th, td {{ border: 1px solid #ccc; padding: 0.3em 0.6em; text-align: right; }}
th:first-child, td:first-child, td:nth-child(2) {{ text-align: left; }}
figure {{ display: inline-block; margin: 0 1em 1em 0; vertical-align: top; }}
figcaption {{ font-size: 0.9em; }}
.note {{ color: #555; }}
</style></head>
<body>
<h1>raylab compare: {scene}</h1>
{note}<p class="note">{w}x{h}, {budget}, {threads} threads, seed {seed}. Reference: {reference}. Errors are measured against the reference: RMSE and relMSE on linear radiance, PSNR and FLIP on the displayed (clamped sRGB) images.</p>
<div class="controls">
  <label>A <select id="a"></select></label>
  <label>B <select id="b"></select></label>
  <label>view <select id="mode">
    <option value="slider">slider: A left, B right</option>
    <option value="toggle">toggle: click or space flips A/B</option>
    <option value="error">error of A (FLIP, magma)</option>
  </select></label>
  <label>split <input type="range" id="split" min="0" max="100" value="50"></label>
  <label>zoom <select id="zoom"><option>1</option><option>2</option><option>4</option><option>8</option><option>16</option></select></label>
  <span id="shown"></span>
</div>
<div id="viewport"><canvas id="view"></canvas></div>
<h2>Metrics</h2>
{table}
<p class="note">Also as <a href="metrics.json">metrics.json</a> and <a href="metrics.csv">metrics.csv</a>; a picture of it all in <a href="mosaic.png">mosaic.png</a>.</p>
{sweep}
<h2>All images at full size</h2>
<div id="gallery">{gallery}</div>
<script>
"use strict";
const DATA = {data};
const $ = (id) => document.getElementById(id);
const canvas = $("view"), ctx = canvas.getContext("2d", {{ willReadFrequently: true }});
const loaded = {{}};
let flipped = false;

function load(src) {{
  return new Promise((ok, fail) => {{ const i = new Image(); i.onload = () => ok(i); i.onerror = fail; i.src = src; }});
}}

function draw() {{
  const a = $("a").value, b = $("b").value, mode = $("mode").value;
  const w = DATA.width, h = DATA.height, zoom = Number($("zoom").value);
  canvas.width = w; canvas.height = h;
  canvas.style.width = (w * zoom) + "px"; canvas.style.height = (h * zoom) + "px";
  ctx.imageSmoothingEnabled = false;
  let label;
  if (mode === "slider") {{
    const x = Math.round(w * Number($("split").value) / 100);
    ctx.drawImage(loaded[b].src, 0, 0);
    ctx.drawImage(loaded[a].src, 0, 0, x, h, 0, 0, x, h);
    ctx.fillStyle = "rgba(255,255,255,0.8)"; ctx.fillRect(Math.min(x, w - 1), 0, 1, h);
    label = "left: " + a + ", right: " + b;
  }} else if (mode === "toggle") {{
    const n = flipped ? b : a;
    ctx.drawImage(loaded[n].src, 0, 0);
    label = "showing " + n;
  }} else {{
    const e = loaded[a].error;
    if (e) {{ ctx.drawImage(e, 0, 0); label = "FLIP error of " + a; }}
    else {{ ctx.drawImage(loaded[a].src, 0, 0); label = a + " is the reference: no error map"; }}
  }}
  $("shown").textContent = label;
}}

function pixelOf(img, x, y) {{
  const c = document.createElement("canvas"); c.width = DATA.width; c.height = DATA.height;
  const g = c.getContext("2d", {{ willReadFrequently: true }}); g.drawImage(img, 0, 0);
  return Array.from(g.getImageData(x, y, 1, 1).data);
}}

function shownPixel(x, y) {{ return Array.from(ctx.getImageData(x, y, 1, 1).data); }}

function selftest() {{
  // Pick A and B that differ somewhere, find such a pixel, move the slider both ways through
  // its input event, and check that the viewer shows A's pixel, then B's.
  const names = DATA.order;
  const a = names[names.length - 1], b = names[0];
  $("a").value = a; $("b").value = b; $("mode").value = "slider";
  const same = (p, q) => p.every((v, i) => v === q[i]);
  let spot = null;
  for (let y = 0; y < DATA.height && !spot; y += 3)
    for (let x = 0; x < DATA.width && !spot; x += 3)
      if (!same(pixelOf(loaded[a].src, x, y), pixelOf(loaded[b].src, x, y))) spot = [x, y];
  if (!spot) {{ document.title = "selftest: inconclusive (A and B are identical)"; return; }}
  const slide = (v) => {{ $("split").value = v; $("split").dispatchEvent(new Event("input")); }};
  slide(100);
  const left = shownPixel(spot[0], spot[1]);
  slide(0);
  const right = shownPixel(spot[0], spot[1]);
  const ok = same(left, pixelOf(loaded[a].src, spot[0], spot[1])) && same(right, pixelOf(loaded[b].src, spot[0], spot[1])) && !same(left, right);
  document.title = ok ? "selftest: ok" : "selftest: FAIL at " + spot + ": " + left + " / " + right;
}}

async function main() {{
  for (const n of DATA.order) {{
    const d = DATA.images[n];
    loaded[n] = {{ src: await load(d.src), error: d.error ? await load(d.error) : null }};
  }}
  for (const img of document.querySelectorAll("img.full")) img.src = DATA.images[img.dataset.name].src;
  for (const id of ["a", "b"]) {{
    for (const n of DATA.order) {{ const o = document.createElement("option"); o.value = o.textContent = n; $(id).appendChild(o); }}
  }}
  $("a").value = DATA.order[DATA.order.length > 1 ? 1 : 0];
  $("b").value = DATA.order[0];
  for (const id of ["a", "b", "mode", "zoom"]) $(id).addEventListener("change", draw);
  $("split").addEventListener("input", draw);
  canvas.addEventListener("click", () => {{ flipped = !flipped; draw(); }});
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
        threads = report.threads,
        seed = report.seed,
        reference = escape(&report.reference),
        note = report
            .note
            .as_deref()
            .map(|n| format!("<p><strong>{}</strong></p>", escape(n)))
            .unwrap_or_default(),
    );
    super::write_text(&dir.join("index.html"), &html)
}
