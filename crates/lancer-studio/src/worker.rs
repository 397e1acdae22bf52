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

use crate::State;
use crate::server::{Loader, SceneSlot};

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
    /// Whether the page may write the scene file.
    pub allow_save: bool,
}

/// A mutex's guard even if another thread panicked holding it: the data behind these locks is
/// replaced whole, never left half-written, so one failed request does not end the studio.
pub(crate) fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl Shared {
    /// Asks for `state` to be rendered, once it has been checked (an invalid edit is answered
    /// with an error event and changes nothing): the render in progress is cancelled. An edit
    /// made on a scene since reloaded (an older `epoch`) is dropped.
    pub(crate) fn ask(&self, state: State) {
        let (epoch, mut check) = {
            let slot = lock(&self.slot);
            (slot.epoch, slot.prepared.clone())
        };
        if state.epoch != epoch {
            return;
        }
        if let Err(e) = state.apply(&mut check, &self.registry) {
            let _ = self.events.send(json!({"type": "error", "message": e}).to_string());
            return;
        }
        self.post(state);
    }

    /// Queues `state` (already checked) for rendering.
    fn post(&self, state: State) {
        // The generation, the request and the current state change together.
        let mut request = lock(&self.request);
        let generation = self.generation.fetch_add(1, Ordering::SeqCst) + 1;
        *lock(&self.current) = state.clone();
        *request = Some((generation, state));
        lock(&self.cancel).store(true, Ordering::SeqCst);
        self.wake.notify_one();
    }

    /// The message a page gets on connecting and after a reload.
    pub(crate) fn hello(&self) -> String {
        let (scene, width, height, warnings, can_save, file) = {
            let slot = lock(&self.slot);
            (
                slot.name.clone(),
                slot.image.width,
                slot.image.height,
                slot.warnings.clone(),
                self.allow_save && slot.path.is_some(),
                slot.path.as_ref().and_then(|p| p.file_name()).map(|n| n.to_string_lossy().into_owned()),
            )
        };
        json!({
            "type": "hello",
            "scene": scene,
            "width": width,
            "height": height,
            "warnings": warnings,
            "can_save": can_save,
            "file": file,
            "state": *lock(&self.current),
            "registry": crate::state::registry_json(&self.registry),
        })
        .to_string()
    }
}

pub(crate) fn start(registry: Registry, slot: SceneSlot, loader: Loader, allow_save: bool) -> Result<Arc<Shared>> {
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
        allow_save,
    });
    let worker = shared.clone();
    std::thread::Builder::new().name("render".into()).spawn(move || render_loop(&worker))?;
    watch_files(shared.clone(), loader, inputs)?;
    shared.post(state);
    Ok(shared)
}

fn render_loop(shared: &Shared) {
    loop {
        let (generation, state) = {
            let mut request = lock(&shared.request);
            loop {
                if let Some(r) = request.take() {
                    break r;
                }
                request = shared.wake.wait(request).unwrap_or_else(std::sync::PoisonError::into_inner);
            }
        };
        let cancel = Arc::new(AtomicBool::new(false));
        *lock(&shared.cancel) = cancel.clone();
        // A request that came between taking it and installing the flag: start over.
        if shared.generation.load(Ordering::SeqCst) != generation {
            continue;
        }
        // The scene is copied out (meshes are shared, not copied): the lock is held for that
        // only, never during a render.
        let (mut prepared, camera, base_image) = {
            let slot = lock(&shared.slot);
            (slot.prepared.clone(), slot.camera, slot.image)
        };
        let pipeline = match state.apply(&mut prepared, &shared.registry) {
            Ok(p) => p,
            Err(e) => {
                let _ = shared.events.send(json!({"type": "error", "message": e}).to_string());
                continue;
            }
        };
        for coarse in [true, false] {
            let image = crate::state::image_for(&base_image, &state, coarse);
            let start = Instant::now();
            let last = Mutex::new(Instant::now());
            let progress = |done: usize, total: usize| {
                let mut last = lock(&last);
                if last.elapsed() > Duration::from_millis(100) {
                    *last = Instant::now();
                    let _ = shared.events.send(json!({"type": "progress", "done": done, "total": total}).to_string());
                }
            };
            let frame = lancer_shading::render_prepared(
                &prepared,
                &camera,
                &image,
                &pipeline,
                RenderOptions {
                    progress: Some(&progress),
                    timing: false,
                    part: None,
                    cancel: Some(&cancel),
                    layers: true,
                    reference: false,
                    compact: false,
                },
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
            // The files as they are before loading: a save during the load is seen next time.
            stamps = now;
            let before = files.clone();
            match loader().map(SceneSlot::new) {
                Ok(mut slot) => {
                    let state = {
                        let mut old = lock(&shared.slot);
                        slot.epoch = old.epoch + 1;
                        slot.loaded.epoch = slot.epoch;
                        let state = slot.loaded.clone();
                        files = slot.inputs.clone();
                        *old = slot;
                        state
                    };
                    if files != before {
                        stamps = files.iter().map(|f| stamp(f)).collect();
                    }
                    shared.post(state);
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
