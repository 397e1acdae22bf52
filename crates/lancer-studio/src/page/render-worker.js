// Lancer in the browser: one render worker (a module Web Worker). It holds one wasm engine with
// the scene loaded, and renders what the page asks for, one band of rows at a time, so that a
// newer edit never waits for more than a band (the page sends the next band only when this one
// is back). Its bands are the page's interleaved share, exactly `lancer render --tile I/N`'s.
"use strict";

let engine = null;
let loaded = null; // the key of the scene loaded

self.onmessage = async (e) => {
  const m = e.data;
  try {
    if (m.type === "init") {
      const glue = await import(m.glue);
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
      const header = JSON.parse(r.header());
      const floats = r.floats();
      r.free();
      self.postMessage({ type: "rendered", job: m.job, header, floats, ms: performance.now() - start }, [floats.buffer]);
    }
  } catch (err) {
    // A trap (a bug in the engine) leaves the instance unusable: the page replaces the worker.
    const message = typeof err === "string" ? err : String(err && err.message || err);
    self.postMessage({ type: "failed", job: m.job, key: m.key, message, fatal: err instanceof WebAssembly.RuntimeError });
  }
};
