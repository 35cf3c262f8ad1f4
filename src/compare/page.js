"use strict";
const DATA = JSON.parse(document.getElementById("data").textContent);
const $ = (id) => document.getElementById(id);
const W = DATA.width, H = DATA.height;
// Shared view: zoom relative to fit, and the image point at the canvases' centre.
const view = { zoom: 1, cx: W / 2, cy: H / 2 };
let flipped = false;
const hdr = {}, maps = {};

function decode(b64) {
  const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
  const out = new Float32Array(W * H * 3);
  for (let i = 0; i < W * H; i++) {
    const e = bytes[4 * i + 3];
    if (e === 0) continue;
    const f = Math.pow(2, e - 136);
    for (let c = 0; c < 3; c++) out[3 * i + c] = (bytes[4 * i + c] + 0.5) * f;
  }
  return out;
}

function loadImage(src) {
  return new Promise((ok, fail) => { const i = new Image(); i.onload = () => ok(i); i.onerror = fail; i.src = src; });
}

const srgb = (x) => x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
const byte = (x) => Math.max(0, Math.min(255, Math.round(255 * srgb(Math.max(0, Math.min(1, x))))));
// A perceptual ramp (viridis at five stops) for false colour, t in [0, 1].
const RAMP = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
function ramp(t) {
  t = Math.max(0, Math.min(1, t)) * (RAMP.length - 1);
  const i = Math.min(RAMP.length - 2, Math.floor(t)), f = t - i;
  return RAMP[i].map((v, c) => Math.round(v + f * (RAMP[i + 1][c] - v)));
}

// What the controls ask of an image, as a cache key: tonemapping every image again on every
// mouse move would make panning a large image crawl.
const settings = () => [$("show").value, $("channel").value, $("exposure").value].join("|");
const cache = new Map();
function cached(kind, name, make) {
  const key = kind + "|" + name + "|" + settings();
  if (!cache.has(key)) { if (cache.size > 8 * DATA.order.length) cache.clear(); cache.set(key, make()); }
  return cache.get(key);
}

// The 8-bit RGBA pixels of image `name` as the controls ask for them.
function pixels(name) { return cached("pixels", name, () => tonemap(name)); }
function tonemap(name) {
  const show = $("show").value, ch = $("channel").value;
  const scale = Math.pow(2, Number($("exposure").value));
  const out = new ImageData(W, H), d = out.data, src = hdr[name], ref = hdr[DATA.order[0]];
  for (let i = 0; i < W * H; i++) {
    let rgb;
    if (show === "relerr") {
      let e = 0;
      for (let c = 0; c < 3; c++) { const r = ref[3 * i + c], x = src[3 * i + c] - r; e += x * x / (r * r + 0.01); }
      // 1e-4 to 1 on a log scale.
      rgb = ramp((Math.log10(e / 3 + 1e-12) + 4) / 4);
    } else {
      let [r, g, b] = [src[3 * i] * scale, src[3 * i + 1] * scale, src[3 * i + 2] * scale];
      if (ch === "r") g = b = r; else if (ch === "g") r = b = g; else if (ch === "b") r = g = b;
      else if (ch === "y") r = g = b = 0.2126 * r + 0.7152 * g + 0.0722 * b;
      rgb = [byte(r), byte(g), byte(b)];
    }
    d[4 * i] = rgb[0]; d[4 * i + 1] = rgb[1]; d[4 * i + 2] = rgb[2]; d[4 * i + 3] = 255;
  }
  return out;
}

// An offscreen canvas with image `name` at its own resolution.
function source(name) { return cached("source", name, () => offscreen(name)); }
function offscreen(name) {
  const show = $("show").value;
  const c = document.createElement("canvas"); c.width = W; c.height = H;
  const g = c.getContext("2d");
  const map = maps[name] && maps[name][show];
  if (show === "flip" || show === "ztest") {
    if (map) g.drawImage(map, 0, 0); else g.putImageData(pixels(name), 0, 0);
  } else {
    g.putImageData(pixels(name), 0, 0);
  }
  return c;
}

function panelSize() {
  const grid = $("mode").value === "grid";
  const max = grid ? 360 : 720;
  const fit = Math.min(max / W, max / H);
  return { fit, w: Math.round(W * fit), h: Math.round(H * fit) };
}

// Draws `src` into `canvas` under the shared view.
function paint(canvas, src, clipTo) {
  const { fit, w, h } = panelSize();
  canvas.width = w; canvas.height = h;
  const g = canvas.getContext("2d", { willReadFrequently: true });
  g.imageSmoothingEnabled = false;
  const s = fit * view.zoom;
  g.setTransform(1, 0, 0, 1, 0, 0);
  g.fillStyle = "#333"; g.fillRect(0, 0, w, h);
  if (clipTo !== undefined) { g.save(); g.beginPath(); g.rect(0, 0, clipTo, h); g.clip(); }
  g.setTransform(s, 0, 0, s, w / 2 - view.cx * s, h / 2 - view.cy * s);
  g.drawImage(src, 0, 0);
  if (clipTo !== undefined) g.restore();
  canvas.dataset.view = [view.zoom, view.cx, view.cy].join(",");
}

// The image pixel under canvas position (x, y).
function imagePoint(x, y) {
  const { fit, w, h } = panelSize();
  const s = fit * view.zoom;
  return [Math.floor(view.cx + (x - w / 2) / s), Math.floor(view.cy + (y - h / 2) / s)];
}

function panel(name, label) {
  const p = document.createElement("div"); p.className = "panel";
  const c = document.createElement("canvas"); c.dataset.name = name;
  const t = document.createElement("div"); t.className = "name"; t.textContent = label;
  p.appendChild(c); p.appendChild(t); $("views").appendChild(p);
  attach(c);
  return c;
}

function draw() {
  $("ev").textContent = Number($("exposure").value).toFixed(1);
  const mode = $("mode").value, a = $("a").value, b = $("b").value;
  $("views").innerHTML = "";
  if (mode === "grid") {
    for (const n of DATA.order) paint(panel(n, n), source(n));
  } else if (mode === "slider") {
    const c = panel(a + "|" + b, "left: " + a + ", right: " + b);
    const { w } = panelSize();
    const x = Math.round(w * Number($("split").value) / 100);
    paint(c, source(b));
    const g = c.getContext("2d");
    const tmp = document.createElement("canvas"); paint(tmp, source(a));
    g.setTransform(1, 0, 0, 1, 0, 0);
    if (x > 0) g.drawImage(tmp, 0, 0, x, c.height, 0, 0, x, c.height);
    g.fillStyle = "rgba(255,255,255,0.8)"; g.fillRect(Math.min(x, c.width - 1), 0, 1, c.height);
  } else {
    const n = flipped ? b : a;
    paint(panel(n, "showing " + n + " (click or space: flip)"), source(n));
  }
}

function readout(x, y) {
  const [i, j] = imagePoint(x, y);
  if (i < 0 || j < 0 || i >= W || j >= H) { $("readout").textContent = ""; return; }
  const k = 3 * (j * W + i), f = (n) => Array.from(hdr[n].slice(k, k + 3)).map((v) => v.toPrecision(4)).join(", ");
  $("readout").textContent = "(" + i + ", " + j + ")  A " + $("a").value + ": " + f($("a").value) + "   B " + $("b").value + ": " + f($("b").value);
}

// Dragging pans; the state lives outside the canvases, which every draw replaces.
let drag = null, moved = false;
window.addEventListener("mouseup", () => { drag = null; });
let frame = false;
window.addEventListener("mousemove", (e) => {
  if (!drag) return;
  const s = panelSize().fit * view.zoom;
  view.cx -= (e.clientX - drag.x) / s; view.cy -= (e.clientY - drag.y) / s;
  drag.x = e.clientX; drag.y = e.clientY; moved = true;
  // One redraw per frame however many moves arrive.
  if (!frame) { frame = true; requestAnimationFrame(() => { frame = false; draw(); }); }
});

function attach(c) {
  c.addEventListener("wheel", (e) => {
    e.preventDefault();
    const r = c.getBoundingClientRect(), [px, py] = [e.clientX - r.left, e.clientY - r.top];
    const { fit, w, h } = panelSize(), s0 = fit * view.zoom;
    const ix = view.cx + (px - w / 2) / s0, iy = view.cy + (py - h / 2) / s0;
    view.zoom = Math.max(1, Math.min(64, view.zoom * (e.deltaY < 0 ? 1.25 : 0.8)));
    const s1 = fit * view.zoom;
    view.cx = ix - (px - w / 2) / s1; view.cy = iy - (py - h / 2) / s1;
    $("zoom").value = [1, 2, 4, 8, 16, 32].includes(view.zoom) ? String(view.zoom) : $("zoom").value;
    draw();
  }, { passive: false });
  c.addEventListener("mousedown", (e) => { drag = { x: e.clientX, y: e.clientY }; moved = false; e.preventDefault(); });
  c.addEventListener("mousemove", (e) => { const r = c.getBoundingClientRect(); readout(e.clientX - r.left, e.clientY - r.top); });
  c.addEventListener("click", () => { if ($("mode").value === "toggle" && !moved) { flipped = !flipped; draw(); } });
}

// ---- self-test: drives the controls through their events and checks the canvases ----
function fire(id, value, kind) { $(id).value = value; $(id).dispatchEvent(new Event(kind)); }
function shown(canvas, x, y) { return Array.from(canvas.getContext("2d").getImageData(x, y, 1, 1).data).slice(0, 3); }
function expected(name, i, j) {
  const d = pixels(name).data, k = 4 * (j * W + i);
  return [d[k], d[k + 1], d[k + 2]];
}
const same = (p, q) => p.every((v, i) => v === q[i]);
const centre = (c) => [Math.floor(c.width / 2), Math.floor(c.height / 2)];
const panels = () => Array.from(document.querySelectorAll("#views canvas"));
// Every panel shows, at its centre, its own image's pixel (i, j).
const panelsShow = (i, j) => panels().every((p) => same(shown(p, ...centre(p)), expected(p.dataset.name.split("|")[0], i, j)));

function selftest() {
  const checks = {};
  const names = DATA.order, a = names[names.length - 1], ref = names[0];
  // The radiance decodes to what raylab wrote, within RGBE's precision.
  checks.radiance_decodes = DATA.probes.every((p) => p.rgb.every((v, c) => Math.abs(hdr[p.name][3 * p.index + c] - v) <= 0.01 * Math.max(...p.rgb) + 1e-30));
  fire("mode", "slider", "change"); fire("a", a, "change"); fire("b", ref, "change");
  // A pixel where A and the reference differ on screen, darkening the exposure until one
  // does (bright images clip to the same white).
  let spot = null, ev = 0;
  for (; ev >= -12 && !spot; ev -= 2) {
    fire("exposure", ev, "input");
    for (let j = 0; j < H && !spot; j++)
      for (let i = 0; i < W && !spot; i++)
        if (!same(expected(a, i, j), expected(ref, i, j))) spot = [i, j];
  }
  ev += 2;
  if (!spot) { document.title = "selftest: inconclusive (the images are identical)"; return; }
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
  const total = () => { const c = canvas(); return c.getContext("2d").getImageData(0, 0, c.width, c.height).data.reduce((s, v) => s + v, 0); };
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
  p0.dispatchEvent(new WheelEvent("wheel", { deltaY: -100, clientX: r0.left + cx + 0.5, clientY: r0.top + cy + 0.5, bubbles: true, cancelable: true }));
  checks.wheel_zooms_every_panel = view.zoom > zoom && panelsShow(...spot);
  // Dragging one panel pans them all: three image pixels towards the image's middle. A mouse
  // event's clientX is a whole CSS pixel (Chromium truncates a fractional one), so the drag is
  // a whole number of them, the nearest to three image pixels, and the check reads the image
  // pixel that the panels' centre pixel samples, as the page maps it.
  const step = spot[0] < W / 2 ? 3 : -3, s = panelSize().fit * view.zoom, dx = Math.round(step * s);
  const from = view.cx, p1 = canvas(), r1 = p1.getBoundingClientRect();
  const x0 = Math.round(r1.left + cx), y0 = Math.round(r1.top + cy);
  p1.dispatchEvent(new MouseEvent("mousedown", { clientX: x0, clientY: y0, bubbles: true }));
  window.dispatchEvent(new MouseEvent("mousemove", { clientX: x0 - dx, clientY: y0 }));
  window.dispatchEvent(new MouseEvent("mouseup", { clientX: x0 - dx, clientY: y0 }));
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
}

async function main() {
  for (const n of DATA.order) {
    const d = DATA.images[n];
    hdr[n] = decode(d.rgbe);
    maps[n] = {};
    for (const k of ["flip", "ztest"]) if (d[k]) maps[n][k] = await loadImage(d[k]);
  }
  for (const id of ["a", "b"]) {
    for (const n of DATA.order) { const o = document.createElement("option"); o.value = o.textContent = n; $(id).appendChild(o); }
  }
  $("a").value = DATA.order[DATA.order.length > 1 ? 1 : 0];
  $("b").value = DATA.order[0];
  for (const id of ["a", "b", "mode", "show", "channel"]) $(id).addEventListener("change", draw);
  $("zoom").addEventListener("change", () => { view.zoom = Number($("zoom").value); draw(); });
  for (const id of ["split", "exposure"]) $(id).addEventListener("input", draw);
  $("reset").addEventListener("click", () => { view.zoom = 1; view.cx = W / 2; view.cy = H / 2; $("zoom").value = "1"; draw(); });
  document.addEventListener("keydown", (e) => {
    if (e.code === "Space" && $("mode").value === "toggle") { e.preventDefault(); flipped = !flipped; draw(); }
  });
  draw();
  if (location.hash === "#selftest") selftest();
}
main();
