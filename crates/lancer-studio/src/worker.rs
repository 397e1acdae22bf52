//! The render worker: one thread that renders the newest state (coarse, then full), cancelling a
//! render as soon as a newer edit arrives, and a watcher that reloads the scene when its files
//! change. Frames and events go to every connected page.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use lancer_shading::{Registry, RenderOptions};
use notify_debouncer_mini::notify::RecursiveMode;
use serde_json::json;
use tokio::sync::{broadcast, watch};

use crate::{Explainer, Loader, SceneSlot, State};

/// A rendered frame as sent to the page, in messages of at most [`CHUNK`] floats: each a
/// little-endian `u32` header length, the JSON header (`generation`, `width`, `height`, `coarse`,
/// `seconds`, `layers`, `offset` and `count` of the floats it carries, `total`), then the floats:
/// every layer's linear RGB one after the other.
pub(crate) type FrameBytes = Arc<Vec<Vec<u8>>>;

/// Floats per message (2 MB): browsers take much larger messages badly.
const CHUNK: usize = 512 * 1024;

/// What the server's handlers share with the worker.
pub(crate) struct Shared {
    pub registry: Registry,
    pub slot: Mutex<SceneSlot>,
    /// The newest state asked for, and its generation.
    request: Mutex<Option<(u64, State)>>,
    wake: Condvar,
    generation: AtomicU64,
    /// The render in progress is stopped when this is set.
    cancel: Mutex<Arc<AtomicBool>>,
    /// The current state (the last one asked for, or the file's).
    pub current: Mutex<State>,
    pub frames: watch::Sender<Option<FrameBytes>>,
    pub events: broadcast::Sender<String>,
    pub explainer: Explainer,
    /// Whether the page may write the scene file.
    pub allow_save: bool,
}

impl Shared {
    /// Asks for `state` to be rendered: the render in progress (if any) is cancelled.
    pub(crate) fn ask(&self, state: State) {
        let generation = self.generation.fetch_add(1, Ordering::SeqCst) + 1;
        *self.current.lock().expect("state lock") = state.clone();
        *self.request.lock().expect("request lock") = Some((generation, state));
        self.cancel.lock().expect("cancel lock").store(true, Ordering::SeqCst);
        self.wake.notify_one();
    }

    /// The message a page gets on connecting and after a reload.
    pub(crate) fn hello(&self) -> String {
        let slot = self.slot.lock().expect("slot lock");
        json!({
            "type": "hello",
            "scene": slot.name,
            "width": slot.image.width,
            "height": slot.image.height,
            "warnings": slot.warnings,
            "can_save": self.allow_save && slot.path.is_some(),
            "file": slot.path.as_ref().and_then(|p| p.file_name()).map(|n| n.to_string_lossy().into_owned()),
            "state": *self.current.lock().expect("state lock"),
            "registry": crate::state::registry_json(&self.registry),
        })
        .to_string()
    }
}

pub(crate) fn start(
    registry: Registry,
    slot: SceneSlot,
    loader: Loader,
    explainer: Explainer,
    allow_save: bool,
) -> Result<Arc<Shared>> {
    let (frames, _) = watch::channel(None);
    let (events, _) = broadcast::channel(64);
    let state = slot.loaded.clone();
    let inputs = slot.inputs.clone();
    let shared = Arc::new(Shared {
        registry,
        slot: Mutex::new(slot),
        request: Mutex::new(None),
        wake: Condvar::new(),
        generation: AtomicU64::new(0),
        cancel: Mutex::new(Arc::new(AtomicBool::new(false))),
        current: Mutex::new(state.clone()),
        frames,
        events,
        explainer,
        allow_save,
    });
    let worker = shared.clone();
    std::thread::Builder::new().name("render".into()).spawn(move || render_loop(&worker))?;
    watch_files(shared.clone(), loader, inputs)?;
    shared.ask(state);
    Ok(shared)
}

fn render_loop(shared: &Shared) {
    loop {
        let (generation, state) = {
            let mut request = shared.request.lock().expect("request lock");
            loop {
                if let Some(r) = request.take() {
                    break r;
                }
                request = shared.wake.wait(request).expect("request lock");
            }
        };
        let cancel = Arc::new(AtomicBool::new(false));
        *shared.cancel.lock().expect("cancel lock") = cancel.clone();
        // A request that came between taking it and installing the flag: start over.
        if shared.generation.load(Ordering::SeqCst) != generation {
            continue;
        }
        let mut slot = shared.slot.lock().expect("slot lock");
        let pipeline = match state.apply(&mut slot.prepared, &shared.registry) {
            Ok(p) => p,
            Err(e) => {
                let _ = shared.events.send(json!({"type": "error", "message": e}).to_string());
                continue;
            }
        };
        for coarse in [true, false] {
            let mut image = slot.image;
            image.samples = state.model.samples;
            if coarse {
                image.width = (image.width / 4).max(1);
                image.height = (image.height / 4).max(1);
                image.samples = 1;
            }
            let start = Instant::now();
            let last = Mutex::new(Instant::now());
            let progress = |done: usize, total: usize| {
                let mut last = last.lock().expect("progress lock");
                if last.elapsed() > Duration::from_millis(100) {
                    *last = Instant::now();
                    let _ = shared.events.send(json!({"type": "progress", "done": done, "total": total}).to_string());
                }
            };
            let frame = lancer_shading::render_prepared(
                &slot.prepared,
                &slot.camera,
                &image,
                &pipeline,
                RenderOptions { progress: Some(&progress), timing: false, part: None, cancel: Some(&cancel) },
            );
            if cancel.load(Ordering::SeqCst) {
                break;
            }
            let floats: Vec<f32> =
                frame.layers.iter().flat_map(|l| bytemuck::cast_slice::<_, f32>(&l.pixels).iter().copied()).collect();
            let mut messages = Vec::new();
            for offset in (0..floats.len().max(1)).step_by(CHUNK) {
                let part = &floats[offset.min(floats.len())..(offset + CHUNK).min(floats.len())];
                let header = json!({
                    "generation": generation,
                    "width": frame.width,
                    "height": frame.height,
                    "coarse": coarse,
                    "seconds": start.elapsed().as_secs_f64(),
                    "layers": frame.layers.iter().map(|l| l.name.clone()).collect::<Vec<_>>(),
                    "offset": offset,
                    "count": part.len(),
                    "total": floats.len(),
                })
                .to_string();
                let mut bytes = Vec::with_capacity(4 + header.len() + part.len() * 4);
                bytes.extend_from_slice(&(header.len() as u32).to_le_bytes());
                bytes.extend_from_slice(header.as_bytes());
                bytes.extend_from_slice(bytemuck::cast_slice(part));
                messages.push(bytes);
            }
            // Kept for pages that connect later, even when none is listening now.
            shared.frames.send_replace(Some(Arc::new(messages)));
        }
    }
}

/// Reloads the scene whenever one of its files changes (size or time), and tells the pages.
fn watch_files(shared: Arc<Shared>, loader: Loader, inputs: Vec<std::path::PathBuf>) -> Result<()> {
    let (tx, rx) = std::sync::mpsc::channel();
    let mut debouncer = notify_debouncer_mini::new_debouncer(Duration::from_millis(150), tx)
        .context("starting to watch the scene's files")?;
    let stamp = |p: &std::path::Path| std::fs::metadata(p).ok().map(|m| (m.len(), m.modified().ok()));
    let mut watched = Vec::new();
    for file in &inputs {
        let folder = file.parent().map(|f| if f.as_os_str().is_empty() { std::path::Path::new(".") } else { f });
        if let Some(folder) = folder
            && !watched.contains(&folder.to_path_buf())
        {
            debouncer.watcher().watch(folder, RecursiveMode::NonRecursive).ok();
            watched.push(folder.to_path_buf());
        }
    }
    std::thread::Builder::new().name("watch".into()).spawn(move || {
        let _keep = debouncer;
        let mut files = inputs;
        let mut stamps: Vec<_> = files.iter().map(|f| stamp(f)).collect();
        while rx.recv().is_ok() {
            // Several events at once: look once.
            while rx.try_recv().is_ok() {}
            let now: Vec<_> = files.iter().map(|f| stamp(f)).collect();
            if now == stamps {
                continue;
            }
            stamps = now;
            match loader().and_then(SceneSlot::new) {
                Ok(slot) => {
                    let state = slot.loaded.clone();
                    files = slot.inputs.clone();
                    stamps = files.iter().map(|f| stamp(f)).collect();
                    *shared.slot.lock().expect("slot lock") = slot;
                    shared.ask(state);
                    let _ = shared.events.send(shared.hello());
                }
                Err(message) => {
                    let _ = shared.events.send(json!({"type": "error", "message": message}).to_string());
                }
            }
        }
    })?;
    Ok(())
}
