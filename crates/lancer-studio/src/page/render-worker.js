// Lancer in the browser: one render worker (a module Web Worker). It holds one wasm engine with
// the scene loaded, and renders what the page asks for, one band of rows at a time, so that a
// newer edit never waits for more than two bands (the page asks for at most two at once). Its bands are the page's interleaved share, exactly `lancer render --tile I/N`'s.
"use strict";

let glue = null;
let engine = null;
let loaded = null; // the key of the scene loaded

self.onmessage = async (e) => {
  const m = e.data;
  try {
    if (m.type === "init") {
      glue = await import(m.glue);
      await glue.default({ module_or_path: m.module });
      engine = new glue.Engine();
      self.postMessage({ type: "ready" });
    } else if (m.type === "load") {
      engine.load(m.name, m.source, m.index, m.blob);
      loaded = m.key;
      self.postMessage({ type: "loaded", key: m.key });
    } else if (m.type === "render") {
      if (m.key !== loaded) throw new Error("the scene of this render is not loaded");
      const start = performance.now();
      const r = engine.render(m.state, m.coarse, m.part, m.parts);
      let header, layers;
      try {
        header = JSON.parse(r.header());
        // Each layer's floats, copied once out of the instance's memory and handed over whole.
        layers = header.layers.map((_, l) => r.layer(l));
      } finally {
        r.free();
      }
      self.postMessage({ type: "rendered", job: m.job, header, layers, ms: performance.now() - start }, layers.map((a) => a.buffer));
    }
  } catch (err) {
    // The engine's own errors are strings; anything else (a trap: a panic, memory exhausted, a
    // stack overflow; or an instance left unusable by one) is fatal: the page replaces the
    // worker. A panic's message is kept by the engine.
    const fatal = typeof err !== "string";
    let message = fatal ? String(err && err.message || err) : err;
    if (fatal && glue) { try { message = glue.last_panic() || message; } catch { /* the instance is gone */ } }
    self.postMessage({ type: "failed", job: m.job, key: m.key, kind: m.type, message, fatal });
  }
};
