// Lancer studio: the page. Frames arrive as linear float layers; everything about display
// (exposure, false colour, zoom, snapshots) is done here without asking for a render; edits go
// to the server, which renders the newest one.
"use strict";

const $ = (id) => document.getElementById(id);
window.addEventListener("error", (e) => { $("error").hidden = false; $("error").textContent = `page error: ${e.message}`; });
let registry = null;
let state = null;
let frame = null;         // { width, height, coarse, layers: [{name, data: Float32Array}] }
let selected = "beauty";  // the layer shown big
let snapshot = null;      // { width, height, pixels: Uint8ClampedArray, name }
let width = 0, height = 0; // the full image's size

const FORMULAS = {
  ambi: "ambient: ambi · Col_Ω",
  diff: "diffuse: diff · Col_Ω · Σ (N·w) Col_L",
  spec: "specular: spec · shine · (−u·w_r)^(1/(1−shine)) · Col_L; mirror: spec · Col(R_r)",
  shine: "highlight exponent 1/(1−shine); also its strength spec · shine",
  alpha: "refraction: alpha · Col(R_t); transmissive shadows let alpha through",
  n: "u_t = VctTransmis(u, −N, 1/n), v_t = VctTransmis(u_t, N_j, n)",
};
const RANGES = { ambi: [0, 1], diff: [0, 1], spec: [0, 1], shine: [0, 1], alpha: [0, 1], n: [1, 2.5] };

// --- connection -------------------------------------------------------------------------
const ws = new WebSocket(`ws://${location.host}/ws`);
ws.binaryType = "arraybuffer";
ws.onopen = () => status("connected");
ws.onclose = () => status("disconnected: restart lancer serve and reload");
ws.onmessage = (e) => {
  if (typeof e.data === "string") return message(JSON.parse(e.data));
  receiveFrame(e.data);
};

function status(text) { $("status").textContent = text; }

function message(m) {
  if (m.type === "hello") {
    registry = m.registry;
    state = m.state;
    width = m.width; height = m.height;
    $("scene").textContent = `${m.scene} · ${m.width}×${m.height}`;
    $("error").hidden = true;
    $("warnings").hidden = m.warnings.length === 0;
    $("warnings").textContent = m.warnings.join("\n");
    $("save").disabled = !m.can_save;
    $("save").title = m.can_save ? `write the edits into ${m.file}` : "start lancer serve with --allow-save";
    buildPanels();
  } else if (m.type === "error") {
    $("error").hidden = false;
    $("error").textContent = m.message + "\n(the last good image stays)";
  } else if (m.type === "progress") {
    $("progress").value = m.done / m.total;
  }
}

let incoming = null; // the frame being received: { header, floats, got }

function receiveFrame(buffer) {
  const view = new DataView(buffer);
  const length = view.getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  if (header.offset === 0 || !incoming || incoming.header.generation !== header.generation || incoming.header.coarse !== header.coarse) {
    incoming = { header, floats: new Float32Array(header.total), got: 0 };
  }
  // The floats may not be 4-byte aligned in the message: copy them out.
  incoming.floats.set(new Float32Array(buffer.slice(4 + length)), header.offset);
  incoming.got += header.count;
  if (incoming.got < header.total) return;
  const n = header.width * header.height * 3;
  const floats = incoming.floats;
  const layers = header.layers.map((name, i) => ({ name, data: floats.subarray(i * n, (i + 1) * n) }));
  frame = { width: header.width, height: header.height, coarse: header.coarse, layers, generation: header.generation };
  incoming = null;
  studio.arrivals.push({ generation: header.generation, coarse: header.coarse, at: performance.now() });
  $("error").hidden = true;
  $("progress").value = header.coarse ? 0 : 1;
  status(`${header.coarse ? "coarse" : "full"} image in ${(header.seconds * 1000).toFixed(0)} ms`);
  draw();
}

// What the browser test (cargo xtask studio-check) reads: frames as they arrive, and a
// fingerprint of each layer.
const studio = window.studio = {
  arrivals: [],
  frame: () => frame && { width: frame.width, height: frame.height, coarse: frame.coarse, generation: frame.generation, layers: frame.layers.map((l) => l.name) },
  hash(name) {
    const data = frame && layerData(name);
    if (!data) return null;
    const bits = new Uint32Array(data.buffer, data.byteOffset, data.length);
    let h = 2166136261;
    for (let i = 0; i < bits.length; i++) { h ^= bits[i]; h = Math.imul(h, 16777619) >>> 0; }
    return h;
  },
  pixel(name, x, y) {
    const data = frame && layerData(name);
    const i = 3 * (y * frame.width + x);
    return data ? [data[i], data[i + 1], data[i + 2]] : null;
  },
};

// --- display ----------------------------------------------------------------------------
function layerData(name) {
  if (name !== "beauty") return frame.layers.find((l) => l.name === name)?.data;
  const sum = new Float32Array(frame.width * frame.height * 3);
  for (const l of frame.layers) for (let i = 0; i < sum.length; i++) sum[i] += l.data[i];
  return sum;
}

function srgb(x) {
  x = Math.max(0, Math.min(1, x));
  return x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
}

// Small values made visible: log-scaled luminance through a blue–green–yellow–red ramp.
function falseColour(v) {
  const t = v <= 0 ? 0 : Math.max(0, Math.min(1, (Math.log10(v) + 4) / 4));
  const stops = [[0, 0, 0.3], [0, 0.6, 0.8], [0.2, 0.8, 0.2], [1, 0.9, 0], [1, 0.1, 0]];
  const f = t * (stops.length - 1), i = Math.min(stops.length - 2, Math.floor(f)), k = f - i;
  return stops[i].map((c, j) => c + (stops[i + 1][j] - c) * k);
}

function toPixels(data, w, h) {
  const out = new Uint8ClampedArray(w * h * 4);
  const gain = Math.pow(2, parseFloat($("exposure").value));
  const fc = $("falsecolour").checked;
  for (let p = 0; p < w * h; p++) {
    let r = data[3 * p] * gain, g = data[3 * p + 1] * gain, b = data[3 * p + 2] * gain;
    if (fc) [r, g, b] = falseColour(0.2126 * r + 0.7152 * g + 0.0722 * b);
    else [r, g, b] = [srgb(r), srgb(g), srgb(b)];
    out[4 * p] = r * 255 + 0.5; out[4 * p + 1] = g * 255 + 0.5; out[4 * p + 2] = b * 255 + 0.5; out[4 * p + 3] = 255;
  }
  return out;
}

function draw() {
  if (!frame) return;
  const canvas = $("main");
  const data = layerData(selected);
  if (!data) { selected = "beauty"; return draw(); }
  let pixels = toPixels(data, frame.width, frame.height);
  canvas.width = frame.width; canvas.height = frame.height;
  const useSnap = snapshot && $("showsnap").checked && snapshot.width === frame.width && snapshot.height === frame.height;
  if (useSnap) {
    // Wipe: the snapshot left of the line, the current image right of it.
    const wipe = Math.round(parseFloat($("wipe").value) * frame.width);
    const mixed = new Uint8ClampedArray(pixels);
    for (let y = 0; y < frame.height; y++) for (let x = 0; x < wipe; x++) {
      const i = 4 * (y * frame.width + x);
      for (let c = 0; c < 4; c++) mixed[i + c] = snapshot.pixels[i + c];
    }
    pixels = mixed;
  }
  canvas.getContext("2d").putImageData(new ImageData(pixels, frame.width, frame.height), 0, 0);
  const zoom = parseFloat($("zoom").value) * (frame.coarse ? width / frame.width : 1);
  canvas.style.width = `${frame.width * zoom}px`;
  canvas.style.height = `${frame.height * zoom}px`;
  $("showing").textContent = `showing ${selected}${useSnap ? " (snapshot left of the wipe)" : ""}${frame.coarse ? " — coarse, the full image follows" : ""}`;
  if (snapshot && snapshot.width === frame.width && snapshot.height === frame.height) {
    const current = toPixels(data, frame.width, frame.height);
    $("psnr").textContent = `PSNR vs snapshot: ${psnr(current, snapshot.pixels).toFixed(1)} dB`;
  }
  drawThumbs();
}

function psnr(a, b) {
  let sum = 0, n = 0;
  for (let i = 0; i < a.length; i++) { if (i % 4 === 3) continue; const d = a[i] - b[i]; sum += d * d; n++; }
  return sum === 0 ? Infinity : 10 * Math.log10(255 * 255 / (sum / n));
}

function drawThumbs() {
  const box = $("thumbs");
  const names = ["beauty", ...frame.layers.map((l) => l.name)];
  box.replaceChildren(...names.map((name) => {
    const fig = document.createElement("figure");
    fig.className = name === selected ? "selected" : "";
    const c = document.createElement("canvas");
    c.width = frame.width; c.height = frame.height;
    c.getContext("2d").putImageData(new ImageData(toPixels(layerData(name), frame.width, frame.height), frame.width, frame.height), 0, 0);
    const cap = document.createElement("figcaption");
    cap.textContent = name;
    fig.append(c, cap);
    fig.dataset.layer = name;
    fig.onclick = () => { selected = name; draw(); };
    return fig;
  }));
}

for (const id of ["exposure", "falsecolour", "zoom", "showsnap", "wipe"]) $(id).addEventListener("input", () => {
  $("exposure-value").textContent = `${$("exposure").value} stops`;
  draw();
});
$("keep").onclick = () => {
  if (!frame) return;
  snapshot = { width: frame.width, height: frame.height, pixels: toPixels(layerData(selected), frame.width, frame.height) };
  $("showsnap").disabled = false; $("wipe").disabled = false;
  draw();
};
document.addEventListener("keydown", (e) => {
  if ((e.key === "f" || e.key === "F") && snapshot && e.target.tagName !== "INPUT") {
    $("showsnap").checked = !$("showsnap").checked;
    draw();
  }
});

// --- the pixel inspector ----------------------------------------------------------------
$("main").addEventListener("click", async (e) => {
  if (!frame) return;
  const rect = e.target.getBoundingClientRect();
  const x = Math.floor((e.clientX - rect.left) / rect.width * width);
  const y = Math.floor((e.clientY - rect.top) / rect.height * height);
  $("inspector").textContent = `explaining pixel ${x},${y}…`;
  const r = await fetch(`/api/explain?x=${x}&y=${y}`);
  const text = await r.text();
  if (!r.ok) { $("inspector").textContent = text; return; }
  const doc = JSON.parse(text);
  $("inspector").textContent = explainText(doc, x, y);
  $("inspector").dataset.json = text;
});

const vec = (v) => `(${v.map((c) => c.toFixed(4)).join(", ")})`;

function explainText(doc, x, y) {
  const lines = [`pixel ${x},${y}`];
  const walk = (ray, depth) => {
    const pad = "  ".repeat(depth);
    lines.push(`${pad}${ray.kind} ray, generation ${ray.generation}: u = ${vec(ray.direction)}, weight ${vec(ray.weight)}`);
    if (!ray.hit) { lines.push(`${pad}  hits nothing${ray.background ? `: background ${vec(ray.background)}` : ""}`); return; }
    const h = ray.hit;
    lines.push(`${pad}  hits object ${h.object} (${h.shape}), material ${h.material}: I = ${vec(h.point)}, N = ${vec(h.normal)}, Col_Ω = ${vec(h.color)}`);
    ray.lights.forEach((l, k) => lines.push(`${pad}  light ${k + 1}: ${l.traced ? `N·w = ${l.n_dot_w.toFixed(4)}, transmittance ${vec(l.transmittance)}` : "not lighting this point"}`));
    for (const t of ray.terms) {
      const notes = t.notes.map((n) => `${n.name} = ${Array.isArray(n.value) ? vec(n.value) : typeof n.value === "number" ? n.value.toFixed(4) : n.value}`);
      if (t.added.some((c) => c !== 0) || notes.length) lines.push(`${pad}  ${t.term}: adds ${vec(t.added)}${notes.length ? "  [" + notes.join("; ") + "]" : ""}`);
    }
    for (const c of ray.children) walk(c, depth + 2);
  };
  for (const r of doc.rays) walk(r, 0);
  lines.push("", "totals (linear RGB, the --aov values at this pixel):");
  for (const [name, v] of Object.entries(doc.terms)) lines.push(`  ${name.padEnd(12)} ${vec(v)}`);
  lines.push(`  ${"beauty".padEnd(12)} ${vec(doc.beauty)}`);
  return lines.join("\n");
}

// --- panels -----------------------------------------------------------------------------
let pending = false;
function changed() {
  // One message per animation frame, the newest state: a storm of slider moves sends little.
  if (pending) return;
  pending = true;
  requestAnimationFrame(() => { pending = false; ws.send(JSON.stringify(state)); });
}

function el(tag, props = {}, ...children) {
  const e = Object.assign(document.createElement(tag), props);
  e.append(...children);
  return e;
}

const toHex = (c) => "#" + c.map((x) => Math.round(srgb(Math.min(1, x)) * 255).toString(16).padStart(2, "0")).join("");
const fromHex = (h) => [1, 3, 5].map((i) => { const s = parseInt(h.slice(i, i + 2), 16) / 255; return s <= 0.04045 ? s / 12.92 : Math.pow((s + 0.055) / 1.055, 2.4); });

function slider(label, get, set, [lo, hi], step, formula) {
  const out = el("output", { textContent: get().toFixed(3) });
  const input = el("input", { type: "range", min: lo, max: hi, step, value: get() });
  input.dataset.param = label;
  input.addEventListener("input", () => { set(parseFloat(input.value)); out.textContent = parseFloat(input.value).toFixed(3); changed(); });
  const row = el("div", { className: "row" }, el("label", { textContent: label }), input, out);
  return formula ? [row, el("p", { className: "formula", textContent: formula })] : [row];
}

function buildPanels() {
  $("materials").replaceChildren(...state.materials.map((m, i) => {
    const colour = el("input", { type: "color", value: toHex(m.color) });
    colour.addEventListener("input", () => { m.color = fromHex(colour.value); changed(); });
    const set = el("fieldset", {}, el("legend", { textContent: m.label }), el("div", { className: "row" }, el("label", { textContent: "Col_Ω" }), colour, el("span")));
    set.dataset.material = i;
    for (const k of ["ambi", "diff", "spec", "shine", "alpha", "n"]) set.append(...slider(k, () => m[k], (v) => { m[k] = v; }, RANGES[k], 0.005, FORMULAS[k]));
    return set;
  }));
  $("lights").replaceChildren(...state.lights.map((l, i) => {
    const set = el("fieldset", {}, el("legend", { textContent: `light ${i + 1}` }));
    ["x", "y", "z"].forEach((axis, a) => {
      const input = el("input", { type: "number", step: 0.1, value: l.at[a] });
      input.addEventListener("input", () => { const v = parseFloat(input.value); if (isFinite(v)) { l.at[a] = v; changed(); } });
      set.append(el("div", { className: "row" }, el("label", { textContent: axis }), input, el("span")));
    });
    const colour = el("input", { type: "color", value: toHex(l.color) });
    colour.addEventListener("input", () => { l.color = fromHex(colour.value); changed(); });
    set.append(el("div", { className: "row" }, el("label", { textContent: "Col_L" }), colour, el("span")));
    set.append(...slider("intensity", () => l.intensity, (v) => { l.intensity = v; }, [0, 4], 0.05, "Col_L times intensity"));
    return set;
  }));
  buildModel();
}

function paramInputs(specs, params) {
  return specs.map((p) => {
    const value = params[p.name];
    const input = el("input", { type: p.default === "false" || p.default === "true" ? "checkbox" : "number", step: "any", title: p.doc });
    if (input.type === "checkbox") input.checked = value ?? (p.default === "true");
    else input.value = value ?? (isFinite(parseFloat(p.default)) ? parseFloat(p.default) : "");
    input.addEventListener("input", () => {
      if (input.type === "checkbox") params[p.name] = input.checked;
      else if (input.value === "") delete params[p.name];
      else params[p.name] = parseFloat(input.value);
      changed();
    });
    return el("div", { className: "row" }, el("label", { textContent: p.name, title: p.doc }), input, el("span"));
  });
}

function buildModel() {
  const model = state.model;
  const box = [];
  model.terms.forEach((t, i) => {
    const spec = registry.terms.find((r) => r.name === t.name);
    const on = el("input", { type: "checkbox", checked: t.enabled });
    on.dataset.term = t.name;
    on.addEventListener("input", () => { t.enabled = on.checked; changed(); });
    const variant = el("select", {}, ...(spec ? spec.variants : [{ variant: t.variant }]).map((v) => el("option", { value: v.variant, textContent: v.variant, selected: v.variant === t.variant })));
    variant.dataset.term = t.name;
    variant.addEventListener("input", () => { t.variant = variant.value; t.params = {}; changed(); buildModel(); });
    const up = el("button", { textContent: "↑", title: "earlier in the sum", disabled: i === 0 });
    up.onclick = () => { [model.terms[i - 1], model.terms[i]] = [model.terms[i], model.terms[i - 1]]; changed(); buildModel(); };
    const set = el("fieldset", {}, el("legend", {}, on, ` ${t.name}`), el("div", { className: "term" }, el("span", { textContent: "variant" }), variant, up));
    const v = spec?.variants.find((x) => x.variant === t.variant);
    if (v) {
      set.append(el("p", { className: "formula", textContent: v.summary }));
      set.append(...paramInputs([...v.params, { name: "weight", default: "1", doc: "a factor on the term's whole contribution" }], t.params));
    }
    box.push(set);
  });
  const shadow = el("select", {}, ...registry.shadows.map((s) => el("option", { value: s.name, textContent: s.name, selected: s.name === model.shadows.name })));
  shadow.addEventListener("input", () => { model.shadows = { name: shadow.value, params: {} }; changed(); buildModel(); });
  const sspec = registry.shadows.find((s) => s.name === model.shadows.name);
  const shadows = el("fieldset", {}, el("legend", { textContent: "shadows" }), shadow, ...(sspec ? [el("p", { className: "formula", textContent: sspec.summary }), ...paramInputs(sspec.params, model.shadows.params)] : []));
  const depth = el("input", { type: "number", min: 0, max: 64, value: model.max_depth });
  depth.addEventListener("input", () => { const v = parseInt(depth.value); if (v >= 0 && v <= 64) { model.max_depth = v; changed(); } });
  const samples = el("input", { type: "number", min: 1, max: 256, value: model.samples });
  samples.addEventListener("input", () => { const v = parseInt(samples.value); if (v >= 1 && v <= 256) { model.samples = v; changed(); } });
  box.push(shadows, el("div", { className: "row" }, el("label", { textContent: "max_depth" }), depth, el("span")), el("div", { className: "row" }, el("label", { textContent: "samples" }), samples, el("span")));
  $("model").replaceChildren(...box);
}

// --- saving -----------------------------------------------------------------------------
$("download").onclick = async () => {
  const r = await fetch("/api/scene.toml");
  const text = await r.text();
  $("saved").classList.toggle("failed", !r.ok);
  if (!r.ok) { $("saved").textContent = text; return; }
  const name = (r.headers.get("content-disposition") || "").match(/filename="([^"]+)"/)?.[1] || "scene.toml";
  const a = el("a", { href: URL.createObjectURL(new Blob([text], { type: "application/toml" })), download: name });
  document.body.append(a); a.click(); a.remove();
  $("saved").textContent = `downloaded ${name}`;
};
$("save").onclick = async () => {
  const r = await fetch("/api/save", { method: "POST" });
  // A 409 is the file changed on disk (or a version the edits do not fit): nothing was written,
  // and the answer says what to do.
  $("saved").textContent = await r.text();
  $("saved").classList.toggle("failed", !r.ok);
};
