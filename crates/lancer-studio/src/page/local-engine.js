// Lancer in the browser: the page's local engine (the build of `cargo xtask web`). The renderer is
// the wasm module (with SIMD where the browser runs it); N module Web Workers (N = the machine's
// cores) each hold an instance with the scene loaded and render bands of 16 rows, worker I the
// bands I, I+N, I+2N... as `lancer render --tile I/N` (one that runs out takes the last bands of
// the fullest other share); the page puts the bands in place, so the frame is the bits of one
// render. A worker is asked for at most two bands at once (one rendering, the next waiting, so
// it never idles between bands): a newer edit starts within two bands' time. One more instance, on the page's thread, loads each scene first (its errors),
// explains pixels, writes the edited text and encodes downloads.
"use strict";

const TILE = 16;
/// The bands a worker is asked for at once: one rendering, the next waiting in its queue.
const AHEAD = 2;

// A module of one function that uses a 128-bit vector instruction: valid only where the browser
// runs WebAssembly SIMD.
const SIMD_PROBE = new Uint8Array([0, 97, 115, 109, 1, 0, 0, 0, 1, 5, 1, 96, 0, 1, 123, 3, 2, 1, 0, 10, 10, 1, 8, 0, 65, 0, 253, 15, 253, 98, 11]);

async function compile(url) {
  try {
    return await WebAssembly.compileStreaming(fetch(url));
  } catch {
    // A server that does not send .wasm as application/wasm.
    const r = await fetch(url);
    if (!r.ok) throw new Error(`fetching ${url}: ${r.status}`);
    return WebAssembly.compile(await r.arrayBuffer());
  }
}

/// Files (name -> Uint8Array) as the engine takes them: a JSON index of [name, offset, length]
/// and one buffer.
function pack(files) {
  let size = 0;
  for (const bytes of files.values()) size += bytes.length;
  const blob = new Uint8Array(size);
  const index = [];
  let at = 0;
  for (const [name, bytes] of files) { blob.set(bytes, at); index.push([name, at, bytes.length]); at += bytes.length; }
  return { index: JSON.stringify(index), blob };
}

/// `on.message(m)` gets hello, error and progress messages (as from `lancer serve`), `on.frame(f)`
/// each finished frame.
export async function createLocalEngine(on, options = {}) {
  const simd = options.simd ?? WebAssembly.validate(SIMD_PROBE);
  const name = simd ? "lancer_simd" : "lancer_base";
  const moduleUrl = new URL(`./pkg/${name}_bg.wasm`, import.meta.url);
  const glueUrl = new URL(`./pkg/${name}.js`, import.meta.url).href;
  const module = await compile(moduleUrl);
  // The page's own instance. A trap leaves an instance unusable, and a module's glue starts
  // once: a new instance comes from the glue imported again under another address.
  let glue = null, main = null, instances = 0;
  async function instantiate() {
    glue = await import(instances++ ? `${glueUrl}?instance=${instances}` : glueUrl);
    await glue.default({ module_or_path: module });
    main = new glue.Engine();
  }
  await instantiate();
  let restarting = null;
  /// Runs `f(main)`: its value, or throws the engine's error (a string); after a trap, says
  /// what the panic was and makes a new instance (with the scene loaded again).
  function call(f) {
    try {
      return f(main);
    } catch (e) {
      if (typeof e === "string") throw e;
      let why = String(e && e.message || e);
      try { why = glue.last_panic() || why; } catch { /* gone */ }
      restarting = instantiate().then(() => { if (scene) main.load(scene.name, scene.source, scene.index, scene.blob); }).catch(() => {}).finally(() => { restarting = null; });
      throw `the renderer failed (a bug, please report it): ${why}; it has been restarted`;
    }
  }
  const count = Math.max(1, Math.min(16, options.workers ?? navigator.hardwareConcurrency ?? 2));

  let scene = null;   // { key, name, source, index, blob, width, height }
  let keys = 0;
  let job = null;     // the render in progress: { generation, state, start, phases }
  let generation = 0;
  let jobs = 0;       // counts the bands asked of the workers

  const workers = [];
  const failures = new Array(count).fill(0); // each slot's fatal failures in a row
  function spawn(i) {
    const w = { worker: new Worker(new URL("./render-worker.js", import.meta.url), { type: "module" }), ready: false, asked: new Map(), key: null, index: i, dead: false };
    w.worker.onmessage = (e) => received(w, e.data);
    w.worker.onerror = (e) => on.message({ type: "error", message: `render worker: ${e.message}` });
    w.worker.postMessage({ type: "init", glue: glueUrl, module });
    workers[i] = w;
  }
  for (let i = 0; i < count; i++) spawn(i);

  function received(w, m) {
    if (m.type === "ready") { w.ready = true; return pump(); }
    if (m.type === "loaded") return;
    if (m.type === "failed") {
      // A failed load: the worker has no scene (its render, queued behind, fails too).
      if (m.kind === "load") w.key = null;
      else if (!m.fatal) w.asked.delete(m.job.id);
      const current = job && m.job && m.job.generation === job.generation;
      if (m.fatal) {
        w.worker.terminate();
        w.dead = true;
        failures[w.index] += 1;
        if (failures[w.index] <= 2) spawn(w.index);
        else on.message({ type: "error", message: `render worker ${w.index + 1} keeps failing (${m.message}); rendering on the others` });
        // Its bands (the one that failed, and any asked after it) go back to its share.
        if (job) for (const j of [...w.asked.values()].reverse()) if (j.generation === job.generation) job.phases[j.phase].shares[w.index].unshift(j.band);
      } else if (current) {
        on.message({ type: "error", message: m.message });
        job = null;
      }
      return pump();
    }
    if (m.type !== "rendered") return;
    w.asked.delete(m.job.id);
    failures[w.index] = 0;
    if (job && m.job.generation === job.generation) place(job.phases[m.job.phase], m);
    pump();
  }

  // The bands of each worker's share, for an image `height` rows high.
  function phase(coarse, width, height) {
    const bands = Math.ceil(height / TILE);
    const shares = workers.map((_, i) => { const s = []; for (let b = i; b < bands; b += workers.length) s.push(b); return s; });
    return { coarse, width, height, bands, shares, got: 0, layers: null, rays: 0 };
  }

  function place(p, m) {
    const h = m.header;
    if (h.width !== p.width || h.height !== p.height || h.bands.length !== 1 || h.bands[0] !== m.job.band || h.rows !== Math.min(TILE, p.height - m.job.band * TILE)) {
      on.message({ type: "error", message: `a render worker sent band ${h.bands} (${h.width}x${h.rows}) where band ${m.job.band} of ${p.width}x${p.height} was asked` });
      job = null;
      return;
    }
    if (!p.layers) p.layers = h.layers.map((name) => ({ name, data: new Float32Array(p.width * p.height * 3) }));
    const span = h.rows * h.width * 3;
    if (m.layers.length !== h.layers.length || m.layers.some((a) => a.length !== span)) {
      on.message({ type: "error", message: `a render worker sent layers of the wrong size for band ${m.job.band}` });
      job = null;
      return;
    }
    h.layers.forEach((_, l) => p.layers[l].data.set(m.layers[l], h.bands[0] * TILE * h.width * 3));
    p.got += 1;
    p.rays += h.rays;
    const done = job.phases.reduce((n, q) => n + q.got, 0), total = job.phases.reduce((n, q) => n + q.bands, 0);
    on.message({ type: "progress", done, total });
    if (p.got === p.bands) {
      on.frame({ width: p.width, height: p.height, coarse: p.coarse, layers: p.layers, generation: job.generation, key: job.key, seconds: (performance.now() - job.start) / 1000, rays: p.rays });
      if (!p.coarse) job = null;
    }
  }

  // The next band for worker `i`: its own share of the first phase that has one, else the last
  // band of the fullest other share.
  function next(i) {
    for (const [k, p] of job.phases.entries()) {
      if (p.shares[i].length) return { phase: k, band: p.shares[i].shift() };
      // (A dead slot's share is taken this way too.)
      const fullest = p.shares.reduce((a, s) => (s.length > a.length ? s : a), []);
      if (fullest.length) return { phase: k, band: fullest.pop() };
    }
    return null;
  }

  function pump() {
    if (!job || !scene) return;
    for (const [i, w] of workers.entries()) {
      if (!w.ready || w.dead) continue;
      if (w.key !== scene.key) {
        w.worker.postMessage({ type: "load", key: scene.key, name: scene.name, source: scene.source, index: scene.index, blob: scene.blob });
        w.key = scene.key;
      }
      // Up to AHEAD bands asked at once: the next is queued in the worker while it renders
      // one, so it never waits for the page between bands (a newer edit waits for at most
      // those bands).
      while (w.asked.size < AHEAD) {
        const n = next(i);
        if (!n) break;
        const p = job.phases[n.phase];
        const j = { id: ++jobs, generation: job.generation, phase: n.phase, band: n.band };
        w.asked.set(j.id, j);
        w.worker.postMessage({ type: "render", key: scene.key, state: job.state, coarse: p.coarse, part: n.band, parts: p.bands, job: j });
      }
    }
  }

  const errorOf = (e) => { try { return JSON.parse(e); } catch { return { message: String(e && e.message || e), line: 0, column: 0 }; } };

  return {
    simd,
    workers: count,
    /// Counts the scenes loaded: a frame's `key` says which it shows.
    get key() { return scene ? scene.key : 0; },
    /// Loads a scene: its hello, or { error: { file, line, column, message } }; the previous
    /// scene stays when this one fails.
    load(name, source, files) {
      const { index, blob } = pack(files);
      let hello;
      try { hello = JSON.parse(call((e) => e.load(name, source, index, blob))); } catch (e) { return { error: errorOf(e) }; }
      scene = { key: ++keys, name, source, index, blob, width: hello.width, height: hello.height };
      job = null;
      return hello;
    },
    /// Renders `state`: the coarse image first (unless `coarse` is false), then the full one;
    /// cancels the render before.
    send(state, { coarse = true } = {}) {
      if (!scene) return;
      const w = scene.width, h = scene.height;
      const phases = [phase(false, w, h)];
      if (coarse) phases.unshift(phase(true, Math.max(1, Math.floor(w / 4)), Math.max(1, Math.floor(h / 4))));
      job = { generation: ++generation, key: scene.key, state: JSON.stringify(state), start: performance.now(), phases };
      pump();
    },
    async explain(state, x, y) {
      if (restarting) await restarting;
      try { return { ok: true, text: call((e) => e.explain(JSON.stringify(state), x, y)) }; } catch (e) { return { ok: false, text: String(e) }; }
    },
    async sceneText(state) {
      if (restarting) await restarting;
      try { return { ok: true, text: call((e) => e.edited(JSON.stringify(state))) }; } catch (e) { return { ok: false, text: String(e) }; }
    },
    /// A linear image as a file's bytes: "png" or "exr", the bytes `lancer render` writes.
    encode(format, width, height, floats) { return call(() => glue.Engine.encode(format, width, height, floats)); },
  };
}
