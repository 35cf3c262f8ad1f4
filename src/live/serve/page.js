"use strict";
const $ = (id) => document.getElementById(id);
const selftest = (location.hash.match(/^#selftest=([A-Za-z0-9_-]+)$/) || [])[1];
let integrators = [];
let shownImage = 0;
let formRender = 0;
let stopped = false;

function buildParams(name, values) {
  const entry = integrators.find((e) => e.name === name);
  const box = $("params");
  box.textContent = "";
  $("summary").textContent = entry ? entry.summary : "";
  if (!entry) return;
  for (const p of entry.params) {
    const label = document.createElement("label");
    label.append(p.name + " ");
    const value = values && values[p.name] !== undefined ? values[p.name] : p.default;
    let input;
    if (p.choices) {
      input = document.createElement("select");
      for (const c of p.choices) input.append(new Option(c, c, false, c === String(value)));
    } else {
      input = document.createElement("input");
      input.size = 9;
      input.value = value;
    }
    input.name = p.name;
    label.append(input);
    const hint = document.createElement("small");
    const range = p.choices
      ? p.choices.join(", ")
      : p.max === null
        ? `${p.min} or more`
        : `${p.min} to ${p.max}`;
    hint.textContent = ` ${p.kind}, ${range}: ${p.doc}`;
    label.append(hint);
    box.append(label);
  }
}

async function post(body) {
  try {
    const r = await fetch("/settings", {
      method: "POST",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify(body),
    });
    const text = await r.text();
    $("settings-error").textContent = r.ok ? "" : text;
  } catch (e) {
    $("settings-error").textContent = "the server did not answer";
  }
}

const chosenSampler = () => $("sampler").value || null;

function formParams() {
  const params = {};
  for (const input of $("params").querySelectorAll("input, select")) params[input.name] = input.value;
  return params;
}

$("integrator").addEventListener("change", () => {
  const name = $("integrator").value;
  buildParams(name, null);
  post({ integrator: name, params: {}, sampler: chosenSampler() });
});

$("sampler").addEventListener("change", () => {
  post({ integrator: $("integrator").value, params: formParams(), sampler: chosenSampler() });
});

$("settings").addEventListener("submit", (ev) => {
  ev.preventDefault();
  post({ integrator: $("integrator").value, params: formParams(), sampler: chosenSampler() });
});

function fmt(v, digits) {
  return typeof v === "number" ? v.toFixed(digits) : "";
}

function showStats(r) {
  const rows = [
    ["state", r.state],
    ["integrator", r.integrator + " " + r.describe],
    ["size", `${r.width}x${r.height}`],
    ["samples per pixel", r.target_spp === null ? `${r.spp}` : `${r.spp} of ${r.target_spp}`],
    ["time (s)", fmt(r.elapsed_s, 2)],
    ["M samples/s", fmt(r.samples_per_s / 1e6, 3)],
    ["M rays/s", fmt(r.rays_per_s / 1e6, 2)],
    ["rays (camera / extension / shadow / light / connection)", `${r.rays.camera} / ${r.rays.extension} / ${r.rays.shadow} / ${r.rays.light} / ${r.rays.connection}`],
  ];
  if (r.dropped > 0) rows.push(["dropped samples", `${r.dropped}`]);
  const body = $("stats").tBodies[0];
  body.textContent = "";
  for (const [k, v] of rows) {
    const tr = body.insertRow();
    const th = document.createElement("th");
    th.textContent = k;
    tr.append(th);
    tr.insertCell().textContent = v;
  }
}

function show(s) {
  $("scene").textContent = s.scene;
  const err = $("error");
  err.hidden = !s.error;
  err.textContent = s.error ? "load error (showing the last good image): " + s.error : "";
  if (s.image && s.image.version !== shownImage) {
    shownImage = s.image.version;
    $("image").src = "/image.png?v=" + s.image.version;
    $("caption").textContent = `${s.image.integrator} ${s.image.params} | ${s.image.spp} spp`;
  }
  const r = s.render;
  const chosen = s.selection.integrator || (r && r.integrator);
  if (chosen && document.activeElement !== $("integrator")) $("integrator").value = chosen;
  const samplers = $("sampler");
  if (samplers.options.length === 0 && s.samplers) {
    for (const name of s.samplers) samplers.append(new Option(name, name));
  }
  const sampler = s.selection.sampler || (r && r.sampler);
  if (sampler && document.activeElement !== samplers) samplers.value = sampler;
  if (r) {
    showStats(r);
    if (r.id !== formRender && r.integrator === $("integrator").value) {
      formRender = r.id;
      buildParams(r.integrator, r.params);
    }
  }
}

const sleep = (ms) => new Promise((res) => setTimeout(res, ms));

// Self-test: switch through the menu, then wait for an image by the new integrator.
const test = { phase: "first", v0: 0, polls: 0, done: false };

function finish(ok, why) {
  test.done = true;
  stopped = true;
  document.title = ok ? "selftest: ok" : "selftest: FAIL: " + why;
  $("verdict").textContent = (ok ? "PASS: " : "FAIL: ") + why;
}

async function selftestStep(s) {
  test.polls += 1;
  if (test.phase === "first") {
    if (s.image && integrators.length > 0) {
      if (!integrators.some((e) => e.name === selftest)) return finish(false, `no integrator ${selftest}`);
      if (s.image.integrator === selftest) return finish(false, `the first image is already by ${selftest}`);
      test.v0 = s.image.version;
      test.phase = "switched";
      test.polls = 0;
      const menu = $("integrator");
      menu.value = selftest;
      menu.dispatchEvent(new Event("change"));
    } else if (test.polls > 100) {
      finish(false, "no first image arrived");
    }
    return;
  }
  if (s.image && s.image.integrator === selftest && s.image.version > test.v0) {
    try {
      await $("image").decode();
    } catch (e) {
      return finish(false, "the new image does not load");
    }
    const want = integrators.find((e) => e.name === selftest).params.length;
    const have = $("params").querySelectorAll("input, select").length;
    if (have !== want) return finish(false, `the form shows ${have} parameters, ${selftest} has ${want}`);
    if (!$("caption").textContent.startsWith(selftest)) return finish(false, "the caption does not name " + selftest);
    return finish(true, `switched to ${selftest}; its image arrived (${s.image.spp} spp)`);
  }
  if (test.polls > 40) finish(false, `no image by ${selftest} arrived`);
}

async function main() {
  while (integrators.length === 0) {
    try {
      integrators = await (await fetch("/integrators")).json();
    } catch (e) {
      $("status").textContent = "cannot reach the server; retrying";
      await sleep(1000);
    }
  }
  const menu = $("integrator");
  for (const e of integrators) {
    const o = document.createElement("option");
    o.value = e.name;
    o.textContent = e.name;
    menu.append(o);
  }
  let since = 0;
  while (!stopped) {
    let s;
    try {
      // The self-test polls briefly, so that it gives up in seconds when nothing comes.
      const wait = selftest ? "&wait=300" : "";
      const r = await fetch("/state?since=" + since + wait, { cache: "no-store" });
      s = await r.json();
      $("status").textContent = "";
    } catch (e) {
      $("status").textContent = "cannot reach the server; retrying";
      await sleep(1000);
      continue;
    }
    since = s.version;
    show(s);
    if (selftest) await selftestStep(s);
  }
}

main();
