// Lancer studio: the page. Frames arrive as linear float layers; everything about display
// (exposure, false colour, zoom, snapshots) is done here without asking for a render; edits go
// to the engine, which renders the newest one. Two engines speak the same messages: `lancer
// serve` over a WebSocket, or, in the browser build (`<body data-engine="wasm">`, made by
// `cargo xtask web`), the renderer in WebAssembly in Web Workers (local-engine.js).
"use strict";

const $ = (id) => document.getElementById(id);
// What the page's content security policy refused (none, unless something reached for another
// host): the browser check reads it.
const violations = [];
document.addEventListener("securitypolicyviolation", (e) => violations.push(`${e.violatedDirective}: ${e.blockedURI}`));
window.addEventListener("error", (e) => { $("error").hidden = false; $("error").textContent = `page error: ${e.message}`; });
let registry = null;
let state = null;
let frame = null;         // { width, height, coarse, layers: [{name, data: Float32Array}] }
let selected = "beauty";  // the layer shown big
let snapshot = null;      // { width, height, pixels: Uint8ClampedArray, name }
let width = 0, height = 0; // the full image's size
let marked = null;         // the pixel explained last

const FORMULAS = {
  ambi: "ambient: ambi · Col_Ω",
  diff: "diffuse: diff · Col_Ω · Σ (N·w) Col_L",
  spec: "specular: spec · shine · (−u·w_r)^(1/(1−shine)) · Col_L; mirror: spec · Col(R_r)",
  shine: "highlight exponent 1/(1−shine); also its strength spec · shine",
  alpha: "refraction: alpha · Col(R_t); transmissive shadows let alpha through",
  n: "u_t = VctTransmis(u, −N, 1/n), v_t = VctTransmis(u_t, N_j, n)",
};
const RANGES = { ambi: [0, 1], diff: [0, 1], spec: [0, 1], shine: [0, 1], alpha: [0, 1], n: [1, 2.5] };

// --- the engines -----------------------------------------------------------------------
const LOCAL = document.body.dataset.engine === "wasm";
let engine = null;
const handlers = { message, frame: showFrame };

// `lancer serve`: frames and events over a WebSocket, the rest over HTTP.
function serverEngine() {
  const ws = new WebSocket(`ws://${location.host}/ws`);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => status("connected");
  ws.onclose = () => status("disconnected: restart lancer serve and reload");
  // `--read-only` (the hello says): this tab's edits are its own, so the inspector and Download
  // send them along; otherwise the server's one shared state is what the image shows.
  let readOnly = false;
  ws.onmessage = (e) => {
    if (typeof e.data === "string") {
      const m = JSON.parse(e.data);
      if (m.type === "hello") readOnly = !!m.read_only;
      return message(m);
    }
    receiveFrame(e.data);
  };
  const ask = (url, state) => fetch(url, readOnly ? { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(state) } : {});
  return {
    send(state) { ws.send(JSON.stringify(state)); },
    async explain(state, x, y) { const r = await ask(`/api/explain?x=${x}&y=${y}`, state); return { ok: r.ok, text: await r.text() }; },
    async sceneText(state) { const r = await ask("/api/scene.toml", state); return { ok: r.ok, text: await r.text() }; },
    // The server encodes what the page holds: the bytes `lancer render` writes.
    async encode(format, width, height, floats) {
      const r = await fetch(`/api/encode?format=${format}&width=${width}&height=${height}`, { method: "POST", body: floats });
      if (!r.ok) throw await r.text();
      return new Uint8Array(await r.arrayBuffer());
    },
  };
}

function status(text) { $("status").textContent = text; }

let fileState = null; // the state as the file has it (for "reset to the file")
let adaptive = null; // the scene's adaptive anti-aliasing ({threshold, depth}), kept while the samples are the file's
let objectLabels = []; // each object as the file names it: `object 3 (sphere, glass.toml:45)`

function message(m) {
  if (m.type === "hello") {
    registry = m.registry;
    state = m.state;
    fileState = JSON.parse(JSON.stringify(m.file_state ?? m.state));
    objectLabels = m.objects || [];
    adaptive = m.adaptive || null;
    width = m.width; height = m.height;
    $("scene").textContent = `${m.scene} · ${m.width}×${m.height}`;
    $("error").hidden = true;
    $("warnings").hidden = m.warnings.length === 0;
    $("warnings").textContent = m.warnings.join("\n");
    $("save").disabled = !m.can_save;
    $("save").title = m.can_save ? `write the edits into ${m.file}`
      : m.read_only ? "the studio is read-only: your edits stay in this tab (Download keeps them)"
      : "start lancer serve with --allow-save";
    sceneFile = m.file || "scene.toml";
    buildPanels();
    if (!LOCAL) showSource();
  } else if (m.type === "error") {
    $("error").hidden = false;
    $("error").textContent = m.message + "\n(the last good image stays)";
  } else if (m.type === "progress") {
    // At most ten updates a second: each one repaints the page, and one a band (45 for the
    // benchmark scene) made a 2-worker render in headless Chromium on 2 cores 40 % slower.
    // An update held back is shown when its tenth of a second is over.
    progressValue = m.done / m.total;
    const wait = 100 - (performance.now() - progressShown);
    if (wait <= 0 || m.done === m.total) showProgress();
    else if (!progressTimer) progressTimer = setTimeout(showProgress, wait);
  }
}

let progressShown = 0; // when the progress bar was last moved (performance.now(), ms)
let progressValue = 0; // the latest progress reported
let progressTimer = null; // the update held back, if any
function showProgress() {
  clearTimeout(progressTimer);
  progressTimer = null;
  progressShown = performance.now();
  $("progress").value = progressValue;
}
let incoming = null; // the frame being received: { header, floats, got }
let lastFull = null; // the last full frame received: what a newer frame's images not sent are

function receiveFrame(buffer) {
  if (framesLost) return;
  const view = new DataView(buffer);
  const length = view.getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  if (header.offset === 0 || !incoming || incoming.header.generation !== header.generation || incoming.header.coarse !== header.coarse) {
    incoming = { header, floats: null, got: 0 };
  }
  // The floats start 4-byte aligned; a frame in one message is used where it is.
  const at = 4 + length;
  const part = at % 4 === 0 ? new Float32Array(buffer, at, header.count) : new Float32Array(buffer.slice(at, at + 4 * header.count));
  if (header.offset === 0 && header.count === header.total) incoming.floats = part;
  else (incoming.floats ||= new Float32Array(header.total)).set(part, header.offset);
  incoming.got += header.count;
  if (incoming.got < header.total) return;
  const n = header.width * header.height * 3;
  const floats = incoming.floats || new Float32Array(0);
  incoming = null;
  // The stretches of each image sent, one after the other; the rest of each image is the last
  // full frame's (the server sends only what changed since the last full frame it sent here).
  const sent = header.sent || header.layers.map((name, i) => [name, 0, n]);
  const before = header.sent && !header.coarse && lastFull && lastFull.width === header.width && lastFull.height === header.height ? lastFull : null;
  const old = (name) => before && (name === "beauty" ? before.beauty : before.layers.find((l) => l.name === name)?.data);
  // Every stretch checked before any is written: a frame that does not fit what the page holds
  // (which the server never sends) changes nothing, and the page stops taking frames.
  let pos = 0;
  const stretches = sent.map(([name, from, to]) => {
    const at = pos;
    pos += to - from;
    return { name, from, to, floats: floats.subarray(at, pos) };
  });
  const lost = pos !== floats.length ? { name: "every" } : stretches.find((t) => !(t.from >= 0 && t.from <= t.to && t.to <= n && (t.to - t.from === n || old(t.name))));
  if (lost) return lostFrame(lost.name);
  const unknown = header.layers.find((name) => !sent.some(([s]) => s === name) && !old(name));
  if (unknown) return lostFrame(unknown);
  const images = new Map();
  for (const { name, from, to, floats: values } of stretches) {
    if (from === 0 && to === n) { images.set(name, values); continue; }
    // The last full frame's image, changed where it is: nothing shows that frame any more (a
    // snapshot, a thumbnail and a download each hold their own copy).
    const base = old(name);
    base.set(values, from);
    images.set(name, base);
  }
  const image = (name) => images.get(name) || old(name);
  const layers = header.layers.map((name) => ({ name, data: image(name) }));
  const f = { width: header.width, height: header.height, coarse: header.coarse, layers, generation: header.generation, seconds: header.seconds };
  // The beauty image as the server summed it (the same bits as the page's sum), when it has it.
  const beauty = image("beauty");
  if (beauty) f.beauty = beauty;
  // The thumbnails of the images the same as before.
  if (before && before.thumbs) f.thumbs = new Map([...before.thumbs].filter(([name]) => !images.has(name)));
  if (!f.coarse) lastFull = f;
  showFrame(f);
}

// A frame that does not fit what the page holds (which the server never sends): later frames
// would be put together on the wrong images, so the page takes no more and says so.
let framesLost = false;
function lostFrame(name) {
  framesLost = true;
  lastFull = null;
  studio.lost = (studio.lost || 0) + 1;
  $("error").hidden = false;
  $("error").textContent = `the studio sent a frame that does not fit the ${name} image this page holds: reload the page`;
}

function showFrame(f) {
  frame = f;
  // A progress update held back is older than this frame.
  clearTimeout(progressTimer);
  progressTimer = null;
  progressShown = performance.now();
  // When the frame came, and when it was drawn (its image on the canvas): what the user waits for.
  const arrival = { generation: f.generation, coarse: f.coarse, at: performance.now(), drawn: null };
  studio.arrivals.push(arrival);
  $("error").hidden = true;
  $("progress").value = f.coarse ? 0 : 1;
  status(`${f.coarse ? "coarse" : "full"} image in ${(f.seconds * 1000).toFixed(0)} ms${LOCAL ? ` · ${engine.workers} workers${engine.simd ? ", SIMD" : ""}` : ""}`);
  draw(true);
  arrival.drawn = performance.now();
}

// What the browser test (cargo xtask studio-check) reads: frames as they arrive, and a
// fingerprint of each layer.
const studio = window.studio = {
  arrivals: [],
  frame: () => frame && { width: frame.width, height: frame.height, coarse: frame.coarse, generation: frame.generation, key: frame.key, seconds: frame.seconds, layers: frame.layers.map((l) => l.name) },
  hash(name) {
    const data = frame && layerData(name);
    if (!data) return null;
    const bits = new Uint32Array(data.buffer, data.byteOffset, data.length);
    let h = 2166136261;
    for (let i = 0; i < bits.length; i++) { h ^= bits[i]; h = Math.imul(h, 16777619) >>> 0; }
    return h;
  },
  // A layer's floats as base64 of their little-endian bytes (to compare them with a native render).
  layerBase64(name) {
    const data = frame && layerData(name);
    return data ? base64(new Uint8Array(data.buffer, data.byteOffset, data.byteLength)) : null;
  },
  // `cargo xtask bench`: `n` full renders of the current state one after the other, with no
  // coarse image first; their times (ms, from the request to the last band placed, the engine's
  // own count, before the page draws) land in `benchTimes`.
  benchTimes: null,
  bench(n) {
    studio.benchTimes = null;
    const times = [];
    const one = () => {
      const start = performance.now();
      const before = frame ? frame.generation : 0;
      engine.send(state, { coarse: false });
      const poll = () => {
        if (frame && frame.generation > before && !frame.coarse) {
          times.push(frame.seconds !== undefined ? frame.seconds * 1000 : performance.now() - start);
          return times.length < n ? setTimeout(one, 50) : (studio.benchTimes = times);
        }
        setTimeout(poll, 2);
      };
      poll();
    };
    one();
    return true;
  },
  // The display's table-driven levels against the formula's (the studio check wants none
  // wrong): at each level's least value and the doubles beside it, across [0, 1] in steps of a
  // millionth, at every 97th float from 2^-12 to 1, and at the odd ones (negative, NaN, infinite).
  checkLevels() {
    const bits = new Float64Array(1), word = new BigUint64Array(bits.buffer);
    const beside = (v, step) => { bits[0] = v; word[0] += BigInt(step); return bits[0]; };
    let checked = 0;
    const wrong = [];
    const one = (v) => { checked++; if (level(v) !== levelByFormula(v) && wrong.length < 10) wrong.push(v); };
    for (let k = 1; k <= 255; k++) if (LEAST[k] > 0 && LEAST[k] < 1) for (let s = -3; s <= 3; s++) one(beside(LEAST[k], s));
    for (let i = 0; i <= 1000000; i++) one(i / 1000000);
    const f = new Float32Array(1), fw = new Uint32Array(f.buffer);
    for (let w = 0x39800000; w < 0x3f800000; w += 97) { fw[0] = w; one(f[0]); }
    for (const v of [-0, -1, -1e-30, NaN, Infinity, -Infinity, 1, 1.0000001, 2, 1e30, Number.MIN_VALUE]) one(v);
    return { checked, wrong };
  },
  // The last file offered for download: its name and bytes as base64.
  lastDownload: null,
  violations: () => violations,
  engineInfo: () => engine && { local: LOCAL, simd: !!engine.simd, workers: engine.workers || 0, key: engine.key || 0 },
  pixel(name, x, y) {
    const data = frame && layerData(name);
    const i = 3 * (y * frame.width + x);
    return data ? [data[i], data[i + 1], data[i + 2]] : null;
  },
};

// --- display ----------------------------------------------------------------------------
// The beauty image is the sum of the layers in their order, each step rounded to f32 (the sums
// of adding each layer in turn into a Float32Array, made in one pass), once a frame.
function layerData(name, f = frame) {
  if (name !== "beauty") return f.layers.find((l) => l.name === name)?.data;
  if (!f.beauty) {
    const sum = new Float32Array(f.width * f.height * 3), layers = f.layers.map((l) => l.data);
    for (let i = 0; i < sum.length; i++) {
      let s = 0;
      for (let k = 0; k < layers.length; k++) s = Math.fround(s + layers[k][i]);
      sum[i] = s;
    }
    f.beauty = sum;
  }
  return f.beauty;
}

function srgb(x) {
  x = Math.max(0, Math.min(1, x));
  return x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
}

// The display's 8-bit level of a linear value: by definition what a Uint8ClampedArray makes of
// `srgb(v) * 255 + 0.5`, but without a pow per channel. That level only rises with v, so it is
// found from the least v of each level (found once, by bisection over the formula) starting at
// the level of a table of 4096 steps over [0, 1], each of which spans less than one level.
const clamp8 = new Uint8ClampedArray(1);
function levelByFormula(v) { clamp8[0] = srgb(v) * 255 + 0.5; return clamp8[0]; }
const STEPS = 4096;
const LEAST = new Float64Array(257).fill(Infinity); // LEAST[k]: the least v whose level is k or more
const LEVEL_AT = new Uint8Array(STEPS + 1);         // the level of k / STEPS
LEAST[0] = -Infinity;
for (let k = 1; k <= 255; k++) {
  if (levelByFormula(1) < k) break;
  let lo = 0, hi = 1; // level(lo) < k <= level(hi)
  if (levelByFormula(0) >= k) { LEAST[k] = -Infinity; continue; }
  for (let i = 0; i < 200 && lo < hi; i++) {
    const mid = lo + (hi - lo) / 2;
    if (mid === lo || mid === hi) break;
    if (levelByFormula(mid) >= k) hi = mid; else lo = mid;
  }
  LEAST[k] = hi;
}
for (let i = 0; i <= STEPS; i++) LEVEL_AT[i] = levelByFormula(i / STEPS);
function level(v) {
  if (!(v > 0)) return LEVEL_AT[0];
  if (v >= 1) return LEVEL_AT[STEPS];
  let k = LEVEL_AT[(v * STEPS) | 0];
  while (v >= LEAST[k + 1]) k++;
  return k;
}

// Small values made visible: log-scaled luminance through a blue–green–yellow–red ramp.
function falseColour(v) {
  const t = v <= 0 ? 0 : Math.max(0, Math.min(1, (Math.log10(v) + 4) / 4));
  const stops = [[0, 0, 0.3], [0, 0.6, 0.8], [0.2, 0.8, 0.2], [1, 0.9, 0], [1, 0.1, 0]];
  const f = t * (stops.length - 1), i = Math.min(stops.length - 2, Math.floor(f)), k = f - i;
  return stops[i].map((c, j) => c + (stops[i + 1][j] - c) * k);
}

// Each image keeps its own exposure (a term's image is often far darker than the beauty
// image); the slider shows and sets the one of the image shown.
const exposures = {};
const exposureOf = (name) => exposures[name] ?? 0;

/// The exposure that puts the brightest 0.5 % of an image's luminance at 0.9 (whole stops).
function autoExposure(data) {
  const lum = [];
  for (let p = 0; p < data.length / 3; p += 7) lum.push(0.2126 * data[3 * p] + 0.7152 * data[3 * p + 1] + 0.0722 * data[3 * p + 2]);
  lum.sort((a, b) => a - b);
  const high = lum[Math.floor(lum.length * 0.995)] || 0;
  return high > 0 ? Math.max(-6, Math.min(12, Math.floor(Math.log2(0.9 / high)))) : 0;
}

function toPixels(data, w, h, name = selected) {
  const out = new Uint8ClampedArray(w * h * 4);
  const gain = Math.pow(2, exposureOf(name));
  if ($("falsecolour").checked) {
    for (let p = 0; p < w * h; p++) {
      const [r, g, b] = falseColour(gain * (0.2126 * data[3 * p] + 0.7152 * data[3 * p + 1] + 0.0722 * data[3 * p + 2]));
      out[4 * p] = r * 255 + 0.5; out[4 * p + 1] = g * 255 + 0.5; out[4 * p + 2] = b * 255 + 0.5; out[4 * p + 3] = 255;
    }
    return out;
  }
  for (let p = 0; p < w * h; p++) {
    out[4 * p] = level(data[3 * p] * gain); out[4 * p + 1] = level(data[3 * p + 1] * gain);
    out[4 * p + 2] = level(data[3 * p + 2] * gain); out[4 * p + 3] = 255;
  }
  return out;
}

// A layer's thumbnail, `{ data, width, height }`: each of its pixels the mean of the image's
// pixels under it (linear, so beauty's thumbnail is the sum of the layers' thumbnails), at most
// THUMB pixels wide (the thumbnails show 120 CSS pixels wide), made once a frame.
const THUMB = 240;
function thumbData(name, f = frame) {
  f.thumbs ||= new Map();
  if (f.thumbs.has(name)) return f.thumbs.get(name);
  const w = f.width, h = f.height;
  const tw = Math.min(w, THUMB), th = Math.max(1, Math.round((h * tw) / w));
  const out = new Float32Array(tw * th * 3);
  if (name === "beauty") {
    for (const l of f.layers) {
      const t = thumbData(l.name, f).data;
      for (let i = 0; i < out.length; i++) out[i] += t[i];
    }
  } else {
    boxFilter(layerData(name, f), w, h, out, tw, th);
  }
  const thumb = { data: out, width: tw, height: th };
  f.thumbs.set(name, thumb);
  return thumb;
}

function boxFilter(data, w, h, out, tw, th) {
  for (let y = 0; y < th; y++) {
    const y0 = Math.floor((y * h) / th), y1 = Math.max(y0 + 1, Math.floor(((y + 1) * h) / th));
    for (let x = 0; x < tw; x++) {
      const x0 = Math.floor((x * w) / tw), x1 = Math.max(x0 + 1, Math.floor(((x + 1) * w) / tw));
      let r = 0, g = 0, b = 0;
      for (let sy = y0; sy < y1; sy++) {
        for (let i = 3 * (sy * w + x0), end = 3 * (sy * w + x1); i < end; i += 3) { r += data[i]; g += data[i + 1]; b += data[i + 2]; }
      }
      const n = (x1 - x0) * (y1 - y0), o = 3 * (y * tw + x);
      out[o] = r / n; out[o + 1] = g / n; out[o + 2] = b / n;
    }
  }
}

let thumbsTimer = null;
// Draws the frame; `fresh` when it has just come.
function draw(fresh = false) {
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
  const ctx = canvas.getContext("2d");
  ctx.putImageData(new ImageData(pixels, frame.width, frame.height), 0, 0);
  const scale = frame.width / width;
  if (useSnap) {
    // The wipe's divider, a dark and a light line.
    const at = Math.round(parseFloat($("wipe").value) * frame.width);
    ctx.fillStyle = "#000"; ctx.fillRect(at - 1, 0, 1, frame.height);
    ctx.fillStyle = "#fff"; ctx.fillRect(at, 0, 1, frame.height);
  }
  if (marked) {
    // The explained pixel, ringed.
    const px = (marked.x + 0.5) * scale, py = (marked.y + 0.5) * scale, r = Math.max(3, 4 * scale);
    ctx.strokeStyle = "#ff0"; ctx.lineWidth = Math.max(1, scale);
    ctx.strokeRect(px - r, py - r, 2 * r, 2 * r);
  }
  // "fit": the whole image in the stage (the screen, full-screen); else whole screen pixels per
  // image pixel, square.
  const fit = $("zoom").value === "fit";
  const stage = $("stage");
  const room = document.fullscreenElement === stage
    ? Math.min(stage.clientWidth / width, stage.clientHeight / height)
    : Math.min(stage.clientWidth / width, (window.innerHeight * 0.7) / height);
  // Fit fills the room, smoothly scaled; the whole zooms show square pixels.
  const fitted = Math.max(0.1, room);
  const zoom = (fit ? fitted : parseFloat($("zoom").value)) * (frame.coarse ? width / frame.width : 1);
  canvas.style.imageRendering = fit && !Number.isInteger(fitted) && !frame.coarse ? "auto" : "pixelated";
  canvas.style.width = `${frame.width * zoom}px`;
  canvas.style.height = `${frame.height * zoom}px`;
  $("showing").textContent = `showing ${selected}${useSnap ? " (snapshot left of the wipe)" : ""}${frame.coarse ? " — coarse, the full image follows" : ""}`;
  if (snapshot && snapshot.width === frame.width && snapshot.height === frame.height) {
    const current = toPixels(data, frame.width, frame.height);
    $("psnr").textContent = `PSNR vs snapshot: ${psnr(current, snapshot.pixels).toFixed(1)} dB`;
  }
  // The thumbnails after the big image is on the screen, of this frame. A new coarse frame
  // leaves them as they are while they show its layers (the full frame's come a moment later,
  // and a redraw already waiting keeps its own frame).
  if (!(fresh && frame.coarse && thumbsMatch(frame))) {
    clearTimeout(thumbsTimer);
    const f = frame;
    thumbsTimer = setTimeout(() => { thumbsTimer = null; drawThumbs(f); }, 0);
  }
  legend();
}

// False colour's key: the ramp, with the luminance (in the image's own units, its exposure
// taken out) at each decade.
function legend() {
  const box = $("legend");
  box.hidden = !$("falsecolour").checked;
  if (box.hidden) return;
  const c = $("legend-ramp"), ctx = c.getContext("2d");
  for (let x = 0; x < c.width; x++) {
    const v = Math.pow(10, -4 + 4 * x / (c.width - 1));
    ctx.fillStyle = `rgb(${falseColour(v).map((k) => Math.round(k * 255)).join(",")})`;
    ctx.fillRect(x, 0, 1, c.height);
  }
  const gain = Math.pow(2, exposureOf(selected));
  $("legend-ticks").replaceChildren(...[-4, -3, -2, -1, 0].map((k) => el("span", { textContent: (Math.pow(10, k) / gain).toPrecision(2) })));
}

function psnr(a, b) {
  let sum = 0, n = 0;
  for (let i = 0; i < a.length; i++) { if (i % 4 === 3) continue; const d = a[i] - b[i]; sum += d * d; n++; }
  return sum === 0 ? Infinity : 10 * Math.log10(255 * 255 / (sum / n));
}

// Whether the thumbnails shown are of the layers of frame `f`.
function thumbsMatch(f) {
  const names = ["beauty", ...f.layers.map((l) => l.name)], figures = [...$("thumbs").children];
  return figures.length === names.length && figures.every((fig, i) => fig.dataset.layer === names[i]);
}

// The thumbnails' figures stay from one frame to the next while the layers are the same: a
// frame redraws their pixels only (a new canvas each frame cost more than the drawing).
function drawThumbs(f) {
  const box = $("thumbs");
  const names = ["beauty", ...f.layers.map((l) => l.name)];
  if (!thumbsMatch(f)) {
    box.replaceChildren(...names.map((name) => {
      const fig = document.createElement("figure");
      fig.dataset.layer = name;
      fig.append(document.createElement("canvas"), document.createElement("figcaption"));
      fig.onclick = () => { selected = name; showExposure(); draw(); };
      return fig;
    }));
  }
  for (const fig of box.children) {
    const name = fig.dataset.layer, [c, cap] = fig.children, t = thumbData(name, f);
    fig.className = name === selected ? "selected" : "";
    if (c.width !== t.width || c.height !== t.height) { c.width = t.width; c.height = t.height; }
    c.getContext("2d").putImageData(new ImageData(toPixels(t.data, t.width, t.height, name), t.width, t.height), 0, 0);
    cap.textContent = exposureOf(name) ? `${name} (${exposureOf(name) > 0 ? "+" : ""}${exposureOf(name)} stops)` : name;
  }
}

function showExposure() {
  $("exposure").value = exposureOf(selected);
  $("exposure-value").textContent = `${exposureOf(selected)} stops`;
}
$("exposure").addEventListener("input", () => { exposures[selected] = parseFloat($("exposure").value); showExposure(); draw(); });
$("auto-exposure").onclick = () => { if (frame) { exposures[selected] = autoExposure(layerData(selected)); showExposure(); draw(); } };
for (const id of ["falsecolour", "zoom", "showsnap", "wipe"]) $(id).addEventListener("input", draw);
$("keep").onclick = () => {
  if (!frame) return;
  snapshot = { width: frame.width, height: frame.height, pixels: toPixels(layerData(selected), frame.width, frame.height) };
  $("showsnap").disabled = false; $("wipe").disabled = false;
  draw();
};
$("fullscreen").onclick = () => (document.fullscreenElement ? document.exitFullscreen() : $("stage").requestFullscreen());
document.addEventListener("fullscreenchange", draw);
window.addEventListener("resize", () => { if ($("zoom").value === "fit") draw(); });
document.addEventListener("keydown", (e) => {
  if ((e.key === "f" || e.key === "F") && snapshot && !["INPUT", "TEXTAREA", "SELECT"].includes(e.target.tagName)) {
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
  const { ok, text } = await engine.explain(state, x, y);
  if (!ok) { $("inspector").textContent = text; return; }
  const doc = JSON.parse(text);
  $("inspector").innerHTML = explainText(doc, x, y);
  $("inspector").dataset.json = text;
  marked = { x, y };
  draw();
});

const vec = (v) => `(${v.map((c) => c.toFixed(4)).join(", ")})`;

const html = (t) => String(t).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;");

// What a ray's subtree brought to the pixel: every term's addition below it and the
// background it saw, each already weighted as it reached the pixel.
function carried(ray) {
  let sum = [0, 0, 0];
  const add = (v) => { sum = sum.map((c, i) => c + v[i]); };
  for (const t of ray.terms) add(t.added);
  if (!ray.hit && ray.background) add(ray.background.map((c, i) => c * ray.weight[i]));
  for (const c of ray.children) add(carried(c));
  return sum;
}

/// The explanation as HTML lines: each ray, its hit (the material named as the file names it,
/// a link to its sliders), its lights, and under each term the rays it spawned with what they
/// carried back.
function explainText(doc, x, y) {
  const lines = [`pixel ${x},${y}`];
  // Objects and materials are numbered from 1 in the explanation (file order, and the prepared
  // table's order, whose last entry is the default material); the sliders' list from 0.
  const material = (number) => {
    const m = state.materials[number - 1];
    return m ? `<a href="#" data-material-link="${number - 1}">material "${html(m.label)}"</a>` : `the default material`;
  };
  const walk = (ray, depth) => {
    const pad = "  ".repeat(depth);
    lines.push(`${pad}${html(ray.kind)} ray, generation ${ray.generation}: u = ${vec(ray.direction)}, weight ${vec(ray.weight)}`);
    if (!ray.hit) { lines.push(`${pad}  hits nothing${ray.background ? `: background ${vec(ray.background)}` : ""}`); return; }
    const h = ray.hit;
    lines.push(`${pad}  hits ${html(h.object_name ?? objectLabels[h.object - 1] ?? `object ${h.object} (${h.shape})`)}, ${material(h.material)}: I = ${vec(h.point)}, N = ${vec(h.normal)}, Col_Ω = ${vec(h.color)}`);
    ray.lights.forEach((l, k) => lines.push(`${pad}  light ${k + 1}: ${l.traced ? `N·w = ${l.n_dot_w.toFixed(4)}, transmittance ${vec(l.transmittance)}` : "not lighting this point"}`));
    const spawned = new Set();
    for (const t of ray.terms) {
      const notes = t.notes.map((n) => `${html(n.name)} = ${Array.isArray(n.value) ? vec(n.value) : typeof n.value === "number" ? n.value.toFixed(4) : html(n.value)}`);
      const children = ray.children.filter((c) => c.kind === t.term);
      if (!(t.added.some((c) => c !== 0) || notes.length || children.length)) continue;
      const own = t.added.some((c) => c !== 0) || !children.length ? `adds ${vec(t.added)}` : "adds nothing itself";
      const through = children.length ? `; its ${children.length > 1 ? `${children.length} rays carry` : "ray carries"} ${vec(children.map(carried).reduce((a, v) => a.map((c, i) => c + v[i])))}` : "";
      lines.push(`${pad}  <b>${html(t.term)}</b>: ${own}${through}${notes.length ? "  [" + notes.join("; ") + "]" : ""}`);
      for (const c of children) { spawned.add(c); walk(c, depth + 2); }
    }
    for (const c of ray.children) if (!spawned.has(c)) walk(c, depth + 2);
  };
  for (const r of doc.rays) walk(r, 0);
  lines.push("", "totals (linear RGB, the --aov values at this pixel):");
  for (const [name, v] of Object.entries(doc.terms)) lines.push(`  ${html(name.padEnd(12))} ${vec(v)}`);
  lines.push(`  ${"beauty".padEnd(12)} ${vec(doc.beauty)}`);
  return lines.join("\n");
}

// A material named in the inspector leads to its sliders.
$("inspector").addEventListener("click", (e) => {
  const link = e.target.closest("[data-material-link]");
  if (!link) return;
  e.preventDefault();
  const set = document.querySelector(`fieldset[data-material="${link.dataset.materialLink}"]`);
  if (!set) return;
  set.closest("details").open = true;
  set.scrollIntoView({ block: "center" });
  set.classList.add("flash");
  setTimeout(() => set.classList.remove("flash"), 1200);
});

// --- panels -----------------------------------------------------------------------------
let pending = false, lastSent = -Infinity;
function changed() {
  // An edit after a pause goes at once; the edits that follow it within 16 ms wait for the next
  // animation frame and go as one message, the newest state: a storm of slider moves sends little.
  if (pending) return;
  const send = () => { pending = false; lastSent = performance.now(); engine.send(state); sourceFollows(); };
  if (performance.now() - lastSent >= 16) return send();
  pending = true;
  requestAnimationFrame(send);
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
    set.dataset.name = m.label;
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
  // The scene's adaptive anti-aliasing holds while the samples are the file's (the server and
  // the browser engine both render it so); another number gives every pixel that many.
  const aa = el("p", { className: "formula" });
  const showAdaptive = () => {
    const on = adaptive && fileState && model.samples === fileState.model.samples;
    aa.hidden = !on;
    aa.textContent = on ? `adaptive anti-aliasing (threshold ${adaptive.threshold}, depth ${adaptive.depth}): the scene's; another number of samples gives every pixel that many` : "";
  };
  showAdaptive();
  samples.addEventListener("input", () => { const v = parseInt(samples.value); if (v >= 1 && v <= 256) { model.samples = v; showAdaptive(); changed(); } });
  box.push(shadows, el("div", { className: "row" }, el("label", { textContent: "max_depth" }), depth, el("span")), el("div", { className: "row" }, el("label", { textContent: "samples" }), samples, el("span")), aa);
  $("model").replaceChildren(...box);
}

// --- saving -----------------------------------------------------------------------------
let sceneFile = "scene.toml";

function base64(bytes) {
  let bin = "";
  for (let i = 0; i < bytes.length; i += 0x8000) bin += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(bin);
}

function offer(bytes, name, type) {
  studio.lastDownload = { name, bytes: typeof bytes === "string" ? btoa(unescape(encodeURIComponent(bytes))) : base64(bytes) };
  const a = el("a", { href: URL.createObjectURL(new Blob([bytes], { type })), download: name });
  document.body.append(a); a.click(); a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  $("saved").classList.remove("failed");
  $("saved").textContent = `downloaded ${name}`;
}

$("download").onclick = async () => {
  const { ok, text } = await engine.sceneText(state);
  $("saved").classList.toggle("failed", !ok);
  if (!ok) { $("saved").textContent = text; return; }
  offer(text, sceneFile, "application/toml");
};
$("save").onclick = async () => {
  const r = await fetch("/api/save", { method: "POST" });
  // A 409 is the file changed on disk (or a version the edits do not fit): nothing was written,
  // and the answer says what to do.
  $("saved").textContent = await r.text();
  $("saved").classList.toggle("failed", !r.ok);
};

// --- the scene text ---------------------------------------------------------------------
// The editor shows the scene as it is now (the file with the sliders' edits written in). In the
// browser build it is also where the scene is edited: a pause in typing loads the text, and a
// located error marks its line and keeps the last image.
let typing = null;
let sourceBusy = false;

let loadedText = null; // the text the engine has loaded (or shows), edits of the sliders in

// Whether the editor holds typing the engine has not loaded (a pause pending, or an error).
const unloadedTyping = () => typing !== null || (loadedText !== null && $("source").value !== loadedText);

function showSource() {
  engine.sceneText(state).then(({ ok, text }) => {
    if (ok && !(LOCAL && (unloadedTyping() || document.activeElement === $("source")))) setSource(text);
  });
}

function setSource(text) {
  loadedText = text;
  if ($("source").value === text) return;
  $("source").value = text;
  gutter();
}

// After a slider's edit, the text follows (not over typing the engine has not loaded).
let following = null;
function sourceFollows() {
  if (LOCAL && unloadedTyping()) return;
  clearTimeout(following);
  following = setTimeout(() => { following = null; showSource(); }, 150);
}

function gutter(bad = 0) {
  const lines = $("source").value.split("\n").length;
  const out = [];
  for (let i = 1; i <= lines; i++) out.push(i === bad ? `<span class="bad">${i}</span>` : String(i));
  $("gutter").innerHTML = out.join("\n");
  $("gutter").scrollTop = $("source").scrollTop;
}

function sourceError(e) {
  $("source-error").hidden = !e;
  $("source-error").textContent = e ? e.message : "";
  gutter(e ? e.line : 0);
  if (e && e.line > 0) {
    // The marked line in view.
    const lineHeight = $("source").scrollHeight / Math.max(1, $("source").value.split("\n").length);
    const top = (e.line - 3) * lineHeight;
    if (top < $("source").scrollTop || top > $("source").scrollTop + $("source").clientHeight - 3 * lineHeight) $("source").scrollTop = Math.max(0, top);
  }
}

$("source").addEventListener("scroll", () => { $("gutter").scrollTop = $("source").scrollTop; });
$("source").addEventListener("input", () => {
  gutter();
  if (!LOCAL) return;
  clearTimeout(typing);
  typing = setTimeout(() => { typing = null; openScene(current.name, $("source").value, current.files, { keepText: true }); }, 350);
});

// --- scenes in the browser build ----------------------------------------------------------
let shipped = [];           // scenes/index.json
const shippedFiles = new Map(); // path from scenes/ -> bytes, every mesh and texture shipped
let current = { name: "showcase.toml", original: "", files: new Map() };

async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`fetching ${url}: ${r.status}`);
  return new Uint8Array(await r.arrayBuffer());
}

async function loadShippedFiles() {
  const wanted = [...new Set(shipped.flatMap((s) => s.files))].filter((f) => !shippedFiles.has(f));
  await Promise.all(wanted.map(async (f) => shippedFiles.set(f, await fetchBytes(`scenes/${f}`))));
}

/// Loads `text` as the scene `name`, with `files` (name -> bytes): the hello and a render, or
/// the located error in the editor (the last image stays).
function openScene(name, text, files, { keepText = false, original = null } = {}) {
  const hello = engine.load(name, text, files);
  current = { name, files, original: original ?? current.original, from: current.from };
  if (!keepText) setSource(text);
  if (hello.error) {
    sourceError(hello.error);
    message({ type: "error", message: hello.error.message });
    return false;
  }
  sourceError(null);
  loadedText = text;
  message(hello);
  engine.send(state);
  return true;
}

/// The shipped files as a scene at `path` (from scenes/) names them: relative to its folder.
function shippedFor(path) {
  const dir = path.split("/").slice(0, -1);
  const files = new Map();
  for (const [p, bytes] of shippedFiles) {
    const parts = p.split("/");
    let common = 0;
    while (common < dir.length && common < parts.length - 1 && dir[common] === parts[common]) common++;
    files.set([...Array(dir.length - common).fill(".."), ...parts.slice(common)].join("/"), bytes);
  }
  return files;
}

let opening = 0; // the newest scene asked for: an older one that arrives later is dropped

async function openShipped(path) {
  const token = ++opening;
  const text = new TextDecoder().decode(await fetchBytes(`scenes/${path}`));
  if (token !== opening) return;
  clearShareLink();
  current.from = path;
  openScene(path, text, shippedFor(path), { original: text });
  $("scenes").value = path;
}

/// A scene opened from the machine: the first .toml file, and the others as the files it names.
/// A scene opened from the machine: the first .toml file, and the others as the files it names
/// (by their file names: a scene's `meshes/knot.obj` is found as `knot.obj`). Files alone (an
/// OBJ, a PNG) join the scene open now, which is loaded again with them.
async function openFiles(list) {
  const token = ++opening;
  const all = [...list];
  const scene = all.find((f) => f.name.toLowerCase().endsWith(".toml"));
  const files = scene ? new Map() : new Map(current.files);
  for (const f of all) if (f !== scene) files.set(f.webkitRelativePath || f.name, new Uint8Array(await f.arrayBuffer()));
  const text = scene ? await scene.text() : $("source").value;
  if (token !== opening) return;
  clearShareLink();
  if (scene) current.from = null;
  openScene(scene ? scene.name : current.name, text, files, scene ? { original: text } : { keepText: true });
  if (scene) $("scenes").value = "";
}

// --- share links: the scene text in the URL's fragment (never sent to any server) -----------
async function squeeze(text) {
  const stream = new Blob([text]).stream().pipeThrough(new CompressionStream("deflate-raw"));
  const bytes = new Uint8Array(await new Response(stream).arrayBuffer());
  return base64(bytes).replace(/\+/g, "-").replace(/\//g, "_").replace(/=+$/, "");
}

async function unsqueeze(data) {
  const bin = atob(data.replace(/-/g, "+").replace(/_/g, "/"));
  const bytes = Uint8Array.from(bin, (c) => c.charCodeAt(0));
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("deflate-raw"));
  return new Response(stream).text();
}

function clearShareLink() {
  if (location.hash) history.replaceState(null, "", location.href.split("#")[0]);
}

$("share").onclick = async () => {
  // The text as it is now: the sliders' last edit in, unless the editor holds unloaded typing.
  let text = $("source").value;
  if (!unloadedTyping()) { const r = await engine.sceneText(state); if (r.ok) text = r.text; }
  const from = current.from ? `&from=${encodeURIComponent(current.from)}` : "";
  const link = `${location.href.split("#")[0]}#scene=${await squeeze(text)}&name=${encodeURIComponent(current.name)}${from}`;
  history.replaceState(null, "", link);
  // A link carries the text only: files opened from the machine are not in it.
  const own = current.from ? [] : [...current.files.keys()].filter((f) => text.includes(f.split("/").pop()));
  const note = own.length ? ` — it does not carry ${own.join(", ")}: whoever opens it must open ${own.length > 1 ? "them" : "it"} too` : "";
  try { await navigator.clipboard.writeText(link); $("saved").textContent = `link copied (${link.length} characters): the scene travels in the link${note}`; } catch { $("saved").textContent = `the link is in the address bar${note}`; }
};

// --- images to download -------------------------------------------------------------------
async function downloadImage(format) {
  if (!frame || frame.coarse) { $("saved").textContent = "wait for the full image"; return; }
  const data = layerData(selected);
  let bytes;
  try { bytes = await engine.encode(format, frame.width, frame.height, data); } catch (e) { $("saved").classList.add("failed"); $("saved").textContent = String(e); return; }
  const stem = current.name.split("/").pop().replace(/\.toml$/i, "");
  offer(bytes, `${stem}-${selected}.${format}`, format === "png" ? "image/png" : "image/x-exr");
}
$("png").onclick = () => downloadImage("png");
$("exr").onclick = () => downloadImage("exr");

// --- reset ------------------------------------------------------------------------------------
$("reset").onclick = () => {
  if (LOCAL && $("source").value !== current.original) { openScene(current.name, current.original, current.files); return; }
  if (!fileState) return;
  state = JSON.parse(JSON.stringify(fileState));
  buildPanels();
  changed();
};

// --- start --------------------------------------------------------------------------------
async function startLocal() {
  status("loading the renderer…");
  for (const id of ["scenes", "open", "share"]) $(id).hidden = false;
  $("editor").open = true;
  // Typing not yet saved anywhere is lost with the tab: say so before it closes.
  window.addEventListener("beforeunload", (e) => { if ($("source").value !== current.original) e.preventDefault(); });
  $("save").hidden = true;
  $("source").readOnly = false;
  const local = await import("./local-engine.js");
  const params = new URLSearchParams(location.search);
  engine = await local.createLocalEngine(handlers, {
    workers: params.has("workers") ? parseInt(params.get("workers")) : undefined,
    simd: params.has("simd") ? params.get("simd") !== "0" : undefined,
  });
  if ("serviceWorker" in navigator && location.protocol !== "file:") navigator.serviceWorker.register("sw.js").catch(() => {});
  shipped = await (await fetch("scenes/index.json")).json();
  $("scenes").replaceChildren(el("option", { value: "", textContent: "(your scene)" }), ...shipped.map((s) => el("option", { value: s.path, textContent: `${s.path} — ${s.title}` })));
  $("scenes").onchange = () => { if ($("scenes").value) openShipped($("scenes").value); };
  $("open").onclick = () => $("files").click();
  $("files").onchange = () => openFiles($("files").files);
  document.addEventListener("dragover", (e) => { e.preventDefault(); document.body.classList.add("dropping"); });
  document.addEventListener("dragleave", () => document.body.classList.remove("dropping"));
  document.addEventListener("drop", (e) => { e.preventDefault(); document.body.classList.remove("dropping"); openFiles(e.dataTransfer.files); });
  await loadShippedFiles();
  window.addEventListener("hashchange", () => openShared().catch(() => {}));
  if (!(await openShared())) await openShipped(params.get("scene") || "showcase.toml");
}

/// The scene of a share link (`#scene=...`), if the address has one: whether it was opened.
async function openShared() {
  const hash = new URLSearchParams(location.hash.slice(1));
  if (!hash.has("scene")) return false;
  let text;
  try {
    text = await unsqueeze(hash.get("scene"));
  } catch {
    // (Shown where a frame does not hide it: the showcase opens instead.)
    $("saved").classList.add("failed");
    $("saved").textContent = "this share link is damaged (cut short when copied?): ask for it again";
    return false;
  }
  // A scene shared from a shipped one finds the shipped files as that one does.
  const from = hash.get("from");
  current.from = from && shipped.some((s) => s.path === from) ? from : null;
  openScene(hash.get("name") || "shared.toml", text, current.from ? shippedFor(current.from) : new Map(), { original: text });
  $("scenes").value = "";
  return true;
}

if (LOCAL) startLocal().catch((e) => { $("error").hidden = false; $("error").textContent = `starting the renderer: ${e.message || e}`; });
else engine = serverEngine();
