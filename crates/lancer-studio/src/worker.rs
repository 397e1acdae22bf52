//! The render worker: one thread that renders the newest state each viewer asked for (coarse,
//! then full), cancelling a viewer's render as soon as that viewer asks for a newer one, and a
//! watcher that reloads the scene when its files change.
//!
//! A viewer is every page at once ([`EVERY_PAGE`]: the one shared state, or in a read-only studio
//! the file's own) or, in a read-only studio (`--read-only`), one page ([`Tab`]), whose edits
//! render for it alone. Each viewer keeps only its newest request, and the viewers with one
//! waiting are served in turn, a coarse or a full image at a time: a page dragging a slider holds
//! another back by one render at most, and its newer edit cancels only its own render.

use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use lancer_core::Frame;
use lancer_shading::{Registry, RenderOptions};
use notify_debouncer_mini::notify::RecursiveMode;
use serde_json::json;
use tokio::sync::{Notify, broadcast, mpsc, watch};

use crate::State;
use crate::server::{Loader, SceneSlot};

/// A rendered frame as the render thread hands it to the pages' connections; each connection
/// sends it as the messages [`Sent::messages`] makes.
pub(crate) struct Rendered {
    generation: u64,
    coarse: bool,
    /// The render's time.
    seconds: f64,
    frame: Frame,
}

/// A rendered frame, shared by the pages' connections (each makes its own messages of it).
pub(crate) type SharedFrame = Arc<Rendered>;

/// Floats per message (2 MB): browsers take much larger messages badly.
const CHUNK: usize = 512 * 1024;

impl Rendered {
    /// Its images by name, in the order their floats go: the layers, then `beauty`.
    fn images(&self) -> impl Iterator<Item = (&str, &[glam::Vec3])> {
        let layers = self.frame.layers.iter().map(|l| (l.name.as_str(), l.pixels.as_slice()));
        layers.chain(std::iter::once(("beauty", self.frame.beauty.as_slice())))
    }

    /// The image called `name`, if the frame has one.
    fn image(&self, name: &str) -> Option<&[glam::Vec3]> {
        self.images().find(|(n, _)| *n == name).map(|(_, p)| p)
    }
}

/// What one connection has sent its page: the last full frame. A newer full frame of the same
/// size sends of each image only the stretch that differs from that frame's image of the same
/// name (from its first differing float to its last), and nothing of an image that is the same
/// to the bit: moving one material's `diff` changes the diffuse image where that material is
/// seen, and the mirror, refraction and beauty images where it is seen in them, and no other.
///
/// The messages of a frame: each a little-endian `u32` header length, the JSON header
/// (`generation`, `width`, `height`, `coarse`, `seconds`, `layers`, `sent`, `offset` and `count`
/// of the floats it carries, `total`), spaces up to a multiple of four bytes, then the floats.
/// `layers` names the frame's layers; `sent` lists `[name, from, to]` for the images whose
/// floats `from..to` (linear RGB per pixel) the messages carry, one after the other, out of the
/// layers and `beauty`. Every other float of those images is the one at the same place in the
/// image of that name in the last full frame sent before.
#[derive(Clone, Default)]
pub(crate) struct Sent {
    last_full: Option<SharedFrame>,
}

/// The stretch `from..to` of floats where `new` differs from `old` to the bit (the whole of
/// `new` when there is no `old`); `None` when they are the same.
fn changed(old: Option<&[glam::Vec3]>, new: &[glam::Vec3]) -> Option<(usize, usize)> {
    let new: &[u32] = bytemuck::cast_slice(new);
    let Some(old) = old.map(bytemuck::cast_slice::<_, u32>).filter(|o| o.len() == new.len()) else {
        return Some((0, new.len()));
    };
    // Blocks compared whole first (a memcmp), then the floats of the first and the last block
    // that differ.
    const BLOCK: usize = 256;
    let differs = |k: usize| {
        let at = k * BLOCK..((k + 1) * BLOCK).min(new.len());
        old[at.clone()] != new[at]
    };
    let blocks = new.len().div_ceil(BLOCK);
    let first = (0..blocks).find(|&k| differs(k))?;
    let last = (first..blocks).rev().find(|&k| differs(k)).unwrap_or(first);
    let from = first * BLOCK + (first * BLOCK..new.len()).position(|i| old[i] != new[i]).unwrap_or(0);
    let end = ((last + 1) * BLOCK).min(new.len());
    let to = end - (0..end).rev().position(|i| old[i] != new[i]).unwrap_or(0);
    Some((from, to))
}

impl Sent {
    /// The messages that send `rendered` to a page that has been sent what `self` says.
    pub(crate) fn messages(&self, rendered: &Rendered) -> Vec<Vec<u8>> {
        let (width, height) = (rendered.frame.width, rendered.frame.height);
        let before = self
            .last_full
            .as_deref()
            .filter(|b| !rendered.coarse && b.frame.width == width && b.frame.height == height);
        let sent: Vec<(&str, usize, &[f32])> = rendered
            .images()
            .filter_map(|(name, pixels)| {
                let (from, to) = changed(before.and_then(|b| b.image(name)), pixels)?;
                Some((name, from, &bytemuck::cast_slice::<_, f32>(pixels)[from..to]))
            })
            .collect();
        let total: usize = sent.iter().map(|(_, _, f)| f.len()).sum();
        let layers: Vec<&str> = rendered.frame.layers.iter().map(|l| l.name.as_str()).collect();
        let spans: Vec<(&str, usize, usize)> = sent.iter().map(|(n, from, f)| (*n, *from, from + f.len())).collect();
        let mut messages = Vec::new();
        for offset in (0..total.max(1)).step_by(CHUNK) {
            let end = (offset + CHUNK).min(total);
            let mut header = json!({
                "generation": rendered.generation,
                "width": width,
                "height": height,
                "coarse": rendered.coarse,
                "seconds": rendered.seconds,
                "layers": layers,
                "sent": spans,
                "offset": offset,
                "count": end.saturating_sub(offset),
                "total": total,
            })
            .to_string();
            // The floats start 4-byte aligned: the page reads them where they are.
            while !(4 + header.len()).is_multiple_of(4) {
                header.push(' ');
            }
            let mut bytes = Vec::with_capacity(4 + header.len() + end.saturating_sub(offset) * 4);
            bytes.extend_from_slice(&(header.len() as u32).to_le_bytes());
            bytes.extend_from_slice(header.as_bytes());
            // The part of each stretch's floats that falls in offset..end.
            let mut start = 0;
            for (_, _, floats) in &sent {
                let (from, to) = (offset.max(start), end.min(start + floats.len()));
                if from < to {
                    bytes.extend_from_slice(bytemuck::cast_slice(&floats[from - start..to - start]));
                }
                start += floats.len();
            }
            messages.push(bytes);
        }
        messages
    }

    /// Notes that every message of `rendered` has been sent.
    pub(crate) fn sent(&mut self, rendered: SharedFrame) {
        if !rendered.coarse {
            self.last_full = Some(rendered);
        }
    }
}

/// The viewer that is every page: the shared state's renders (in a read-only studio, the file's
/// state's) go to all of them. A read-only studio's tabs are numbered from 1.
pub(crate) const EVERY_PAGE: u64 = 0;

/// One page of a read-only studio: where the renders of its own edits go.
pub(crate) struct Tab {
    /// The newest frame rendered for the page and not yet sent: only the newest is kept, so a
    /// slow page skips frames and a page holds no frame once it has been sent.
    frame: Mutex<Option<SharedFrame>>,
    /// Told when `frame` is set.
    pub ready: Notify,
    /// Its renders' errors and progress (dropped when the page does not keep up).
    events: mpsc::Sender<String>,
    /// Whether the page shows its own edits: the frames rendered for every page (the file's state)
    /// are then not for it, until the scene is reloaded.
    pub own: AtomicBool,
}

impl Tab {
    /// The frame waiting to be sent, if any (taken: it is sent once).
    pub(crate) fn take(&self) -> Option<SharedFrame> {
        lock(&self.frame).take()
    }
}

/// A page's tab for as long as its connection lasts: dropping it forgets the tab's request and
/// cancels its render in progress.
pub(crate) struct Joined {
    shared: Arc<Shared>,
    /// The tab's viewer number.
    pub id: u64,
    /// The tab.
    pub tab: Arc<Tab>,
}

impl Drop for Joined {
    fn drop(&mut self) {
        let mut queue = lock(&self.shared.queue);
        queue.tabs.remove(&self.id);
        queue.forget(self.id);
    }
}

/// A render asked for: the state, its generation (what the frame's header says), which image.
#[derive(Clone, Debug)]
struct Job {
    generation: u64,
    state: State,
    coarse: bool,
}

/// The renders waiting, one per viewer, in the order the viewers are served, and the one in
/// progress.
#[derive(Default)]
struct Queue {
    /// Counts the requests of every viewer: the generation of the newest.
    generation: u64,
    /// Each viewer's newest request not yet started.
    pending: HashMap<u64, Job>,
    /// The viewers with a request pending, in turn (each once).
    order: VecDeque<u64>,
    /// The viewer being rendered for, and the flag that stops that render.
    running: Option<(u64, Arc<AtomicBool>)>,
    /// A read-only studio's connected pages, by viewer number.
    tabs: HashMap<u64, Arc<Tab>>,
    /// The last tab's number.
    last_tab: u64,
}

impl Queue {
    /// Makes `job` the viewer's newest request: it replaces the one still waiting (which keeps
    /// its place in turn), or else waits at the end; the viewer's own render in progress is
    /// cancelled, and no other viewer's.
    fn push(&mut self, viewer: u64, job: Job) {
        if self.pending.insert(viewer, job).is_none() {
            self.order.push_back(viewer);
        }
        if let Some((v, cancel)) = &self.running
            && *v == viewer
        {
            cancel.store(true, Ordering::SeqCst);
        }
    }

    /// The next viewer's request, in turn.
    fn pop(&mut self) -> Option<(u64, Job)> {
        while let Some(viewer) = self.order.pop_front() {
            if let Some(job) = self.pending.remove(&viewer) {
                return Some((viewer, job));
            }
        }
        None
    }

    /// After the coarse image of `job`, its full image waits its turn behind the other viewers'
    /// requests, unless the viewer asked for something newer meanwhile or is gone.
    fn then_full(&mut self, viewer: u64, job: Job) {
        if self.pending.contains_key(&viewer) || (viewer != EVERY_PAGE && !self.tabs.contains_key(&viewer)) {
            return;
        }
        self.push(viewer, Job { coarse: false, ..job });
    }

    /// Drops the viewer's request and stops its render in progress.
    fn forget(&mut self, viewer: u64) {
        if self.pending.remove(&viewer).is_some() {
            self.order.retain(|v| *v != viewer);
        }
        if let Some((v, cancel)) = &self.running
            && *v == viewer
        {
            cancel.store(true, Ordering::SeqCst);
        }
    }
}

/// What the server's handlers share with the worker. Locks are taken in the order `slot`,
/// `queue`, `current` (or a tab's frame), never the other way.
pub(crate) struct Shared {
    pub registry: Registry,
    pub slot: Mutex<SceneSlot>,
    /// The renders asked for.
    queue: Mutex<Queue>,
    /// Wakes the render thread when a request is queued.
    wake: Condvar,
    /// The state every page shares (the last one asked for, or the file's); in a read-only
    /// studio, the file's.
    pub current: Mutex<State>,
    /// The newest frame for every page.
    pub frames: watch::Sender<Option<SharedFrame>>,
    /// What every page is told (errors, progress, the hello after a reload).
    pub events: broadcast::Sender<String>,
    /// Whether the page may write the scene file.
    pub allow_save: bool,
    /// Whether each page's edits are its own (`--read-only`); Save is off then.
    pub read_only: bool,
    /// The render's scratch buffers, kept from one render to the next (renders are one at a
    /// time, on the render thread): a slider's renders do not grow them and fault their pages
    /// in afresh each time.
    scratch: lancer_shading::Scratches,
}

/// A mutex's guard even if another thread panicked holding it: the data behind these locks is
/// replaced whole, never left half-written, so one failed request does not end the studio.
pub(crate) fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Where a render's frames, errors and progress go.
enum Viewer {
    /// Every page ([`EVERY_PAGE`]).
    Every,
    /// One page of a read-only studio.
    Tab(Arc<Tab>),
}

impl Shared {
    /// Asks for `state` to be rendered for `viewer` ([`EVERY_PAGE`] or a tab's number), once it
    /// has been checked: the viewer's render in progress is cancelled. An invalid edit is the
    /// error returned, and changes nothing. An edit made on a scene since reloaded (an older
    /// `epoch`) is dropped: `Ok(false)`.
    pub(crate) fn ask(&self, viewer: u64, state: State) -> Result<bool, String> {
        let (epoch, mut check) = {
            let slot = lock(&self.slot);
            (slot.epoch, slot.prepared.clone())
        };
        if state.epoch != epoch {
            return Ok(false);
        }
        state.apply(&mut check, &self.registry)?;
        self.post(viewer, state);
        Ok(true)
    }

    /// Queues `state` (already checked) for `viewer`; a tab that has left is not served.
    fn post(&self, viewer: u64, state: State) {
        // The generation, the request and the current state change together.
        let mut queue = lock(&self.queue);
        if viewer != EVERY_PAGE && !queue.tabs.contains_key(&viewer) {
            return;
        }
        queue.generation += 1;
        let generation = queue.generation;
        if viewer == EVERY_PAGE {
            *lock(&self.current) = state.clone();
        }
        queue.push(viewer, Job { generation, state, coarse: true });
        self.wake.notify_one();
    }

    /// A new page's tab (read-only studio), and the receiver of its events.
    pub(crate) fn join(self: &Arc<Self>) -> (Joined, mpsc::Receiver<String>) {
        let (events, receiver) = mpsc::channel(64);
        let tab = Arc::new(Tab { frame: Mutex::new(None), ready: Notify::new(), events, own: AtomicBool::new(false) });
        let mut queue = lock(&self.queue);
        queue.last_tab += 1;
        let id = queue.last_tab;
        queue.tabs.insert(id, tab.clone());
        (Joined { shared: self.clone(), id, tab }, receiver)
    }

    /// After a reload: what the tabs asked for or had rendered on the old scene is dropped, and
    /// every tab shows the file's state again.
    fn reloaded(&self) {
        let mut queue = lock(&self.queue);
        let ids: Vec<u64> = queue.tabs.keys().copied().collect();
        for id in ids {
            queue.forget(id);
        }
        for tab in queue.tabs.values() {
            tab.own.store(false, Ordering::SeqCst);
            lock(&tab.frame).take();
        }
    }

    /// Tells the viewer `text` (an error, progress).
    fn tell(&self, viewer: &Viewer, text: String) {
        match viewer {
            Viewer::Every => {
                let _ = self.events.send(text);
            }
            Viewer::Tab(tab) => {
                let _ = tab.events.try_send(text);
            }
        }
    }

    /// The message a page gets on connecting and after a reload.
    pub(crate) fn hello(&self) -> String {
        let (scene, width, height, adaptive, warnings, can_save, file, objects, file_state) = {
            let slot = lock(&self.slot);
            (
                slot.name.clone(),
                slot.image.width,
                slot.image.height,
                crate::state::adaptive_json(&slot.image),
                slot.warnings.clone(),
                self.allow_save && !self.read_only && slot.path.is_some(),
                slot.path.as_ref().and_then(|p| p.file_name()).map(|n| n.to_string_lossy().into_owned()),
                slot.objects.clone(),
                slot.loaded.clone(),
            )
        };
        json!({
            "type": "hello",
            "scene": scene,
            "width": width,
            "height": height,
            "adaptive": adaptive,
            "warnings": warnings,
            "can_save": can_save,
            "read_only": self.read_only,
            "file": file,
            "state": *lock(&self.current),
            "file_state": file_state,
            "objects": objects,
            "registry": crate::state::registry_json(&self.registry),
        })
        .to_string()
    }
}

/// Starts the render thread and the watcher, and queues the file's state for every page.
pub(crate) fn start(
    registry: Registry,
    slot: SceneSlot,
    loader: Loader,
    allow_save: bool,
    read_only: bool,
) -> Result<Arc<Shared>> {
    let (frames, _) = watch::channel(None);
    let (events, _) = broadcast::channel(64);
    let state = slot.loaded.clone();
    let inputs = slot.inputs.clone();
    let shared = Arc::new(Shared {
        registry,
        slot: Mutex::new(slot),
        queue: Mutex::new(Queue::default()),
        wake: Condvar::new(),
        current: Mutex::new(state.clone()),
        frames,
        events,
        allow_save,
        read_only,
        scratch: Default::default(),
    });
    let worker = shared.clone();
    std::thread::Builder::new().name("render".into()).spawn(move || render_loop(&worker))?;
    watch_files(shared.clone(), loader, inputs)?;
    shared.post(EVERY_PAGE, state);
    Ok(shared)
}

fn render_loop(shared: &Shared) {
    loop {
        let (id, job, viewer, cancel) = {
            let mut queue = lock(&shared.queue);
            let (id, job) = loop {
                if let Some(next) = queue.pop() {
                    break next;
                }
                queue = shared.wake.wait(queue).unwrap_or_else(std::sync::PoisonError::into_inner);
            };
            let viewer = if id == EVERY_PAGE {
                Viewer::Every
            } else if let Some(tab) = queue.tabs.get(&id) {
                Viewer::Tab(tab.clone())
            } else {
                continue;
            };
            let cancel = Arc::new(AtomicBool::new(false));
            queue.running = Some((id, cancel.clone()));
            (id, job, viewer, cancel)
        };
        let shown = render(shared, &job, &viewer, &cancel);
        let mut queue = lock(&shared.queue);
        queue.running = None;
        if shown && job.coarse {
            queue.then_full(id, job);
        }
    }
}

/// Renders `job` for `viewer` and hands it the frame: whether it did (not if cancelled, invalid,
/// or made on a scene since reloaded).
fn render(shared: &Shared, job: &Job, viewer: &Viewer, cancel: &AtomicBool) -> bool {
    // The scene is copied out (meshes are shared, not copied): the lock is held for that only,
    // never during a render.
    let (mut prepared, camera, base_image, epoch) = {
        let slot = lock(&shared.slot);
        (slot.prepared.clone(), slot.camera, slot.image, slot.epoch)
    };
    if job.state.epoch != epoch {
        return false;
    }
    let pipeline = match job.state.apply(&mut prepared, &shared.registry) {
        Ok(p) => p,
        Err(e) => {
            shared.tell(viewer, json!({"type": "error", "message": e}).to_string());
            return false;
        }
    };
    let image = crate::state::image_for(&base_image, &job.state, job.coarse);
    let start = Instant::now();
    let last = Mutex::new(Instant::now());
    let progress = |done: usize, total: usize| {
        let mut last = lock(&last);
        if last.elapsed() > Duration::from_millis(100) {
            *last = Instant::now();
            shared.tell(viewer, json!({"type": "progress", "done": done, "total": total}).to_string());
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
            cancel: Some(cancel),
            layers: true,
            reference: false,
            compact: false,
            scratch: Some(&shared.scratch),
        },
    );
    if cancel.load(Ordering::SeqCst) {
        return false;
    }
    let messages = Arc::new(Rendered {
        generation: job.generation,
        coarse: job.coarse,
        seconds: start.elapsed().as_secs_f64(),
        frame,
    });
    match viewer {
        // Kept for pages that connect later, even when none is listening now.
        Viewer::Every => {
            shared.frames.send_replace(Some(messages));
        }
        Viewer::Tab(tab) => {
            // Under the slot's lock: once the scene has been reloaded, the page is back on the
            // file's state and an image of the old scene is not for it.
            let slot = lock(&shared.slot);
            if slot.epoch != epoch {
                return false;
            }
            *lock(&tab.frame) = Some(messages);
            tab.ready.notify_one();
        }
    }
    true
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
                    shared.reloaded();
                    shared.post(EVERY_PAGE, state);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::{ModelState, ShadowState};

    fn job(generation: u64) -> Job {
        let model = ModelState {
            terms: Vec::new(),
            shadows: ShadowState { name: "hard".into(), params: Default::default() },
            max_depth: 1,
            samples: 1,
        };
        Job { generation, state: State { epoch: 0, materials: Vec::new(), lights: Vec::new(), model }, coarse: true }
    }

    /// A queue with tabs 1 and 2 connected.
    fn two_tabs() -> Queue {
        let mut q = Queue::default();
        for id in [1, 2] {
            let (events, _) = mpsc::channel(1);
            q.tabs.insert(
                id,
                Arc::new(Tab { frame: Mutex::new(None), ready: Notify::new(), events, own: AtomicBool::new(false) }),
            );
        }
        q
    }

    /// Takes the next request as the render thread does: it is running, with a flag of its own.
    fn start(q: &mut Queue) -> (u64, Job, Arc<AtomicBool>) {
        let (viewer, job) = q.pop().expect("a request");
        let cancel = Arc::new(AtomicBool::new(false));
        q.running = Some((viewer, cancel.clone()));
        (viewer, job, cancel)
    }

    fn rendered(generation: u64, coarse: bool, (width, height): (u32, u32), layers: &[(&str, f32)]) -> SharedFrame {
        let n = (width * height) as usize;
        // Each layer a ramp over the pixels from its value; the beauty image their sum.
        let image = |v: f32| (0..n).map(|i| glam::Vec3::splat(v + i as f32)).collect::<Vec<_>>();
        let layers: Vec<lancer_core::Layer> =
            layers.iter().map(|(name, v)| lancer_core::Layer { name: (*name).into(), pixels: image(*v) }).collect();
        let beauty = (0..n).map(|i| layers.iter().map(|l| l.pixels[i]).sum()).collect();
        let frame = Frame { width, height, layers, beauty, stats: Default::default() };
        Arc::new(Rendered { generation, coarse, seconds: 0.0, frame })
    }

    /// What a page makes of a frame's messages, as the page's script does: every image (the
    /// layers, then beauty) by name, its stretches sent put over the last full frame's images.
    fn receive(
        messages: &[Vec<u8>],
        page: &HashMap<String, Vec<f32>>,
    ) -> (serde_json::Value, HashMap<String, Vec<f32>>) {
        let mut floats = Vec::new();
        let mut header = serde_json::Value::Null;
        for m in messages {
            let length = u32::from_le_bytes(m[..4].try_into().unwrap()) as usize;
            assert!((4 + length).is_multiple_of(4), "the floats are not 4-byte aligned");
            header = serde_json::from_slice(&m[4..4 + length]).unwrap();
            assert_eq!(header["offset"].as_u64(), Some(floats.len() as u64));
            let part: Vec<f32> = m[4 + length..].chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
            assert_eq!(header["count"].as_u64(), Some(part.len() as u64));
            floats.extend(part);
        }
        assert_eq!(header["total"].as_u64(), Some(floats.len() as u64));
        let n = (header["width"].as_u64().unwrap() * header["height"].as_u64().unwrap() * 3) as usize;
        let mut images = page.clone();
        let mut pos = 0;
        for span in header["sent"].as_array().unwrap() {
            let (name, from, to) =
                (span[0].as_str().unwrap(), span[1].as_u64().unwrap() as usize, span[2].as_u64().unwrap() as usize);
            let part = &floats[pos..pos + to - from];
            pos += to - from;
            if (from, to) == (0, n) {
                images.insert(name.to_owned(), part.to_vec());
                continue;
            }
            // A stretch goes over the image of the last full frame, which the page must have.
            let image =
                images.get_mut(name).unwrap_or_else(|| panic!("a stretch of {name}, which the page does not have"));
            assert_eq!(image.len(), n, "a stretch of {name} over an image of another size");
            image[from..to].copy_from_slice(part);
        }
        assert_eq!(pos, floats.len());
        (header, images)
    }

    fn images(r: &Rendered) -> HashMap<String, Vec<f32>> {
        r.images().map(|(n, p)| (n.to_owned(), bytemuck::cast_slice::<_, f32>(p).to_vec())).collect()
    }

    #[test]
    fn a_full_frame_sends_only_what_changed_since_the_last_full_frame() {
        let mut sent = Sent::default();
        let first = rendered(1, false, (40, 30), &[("ambient", 1.0), ("diffuse", 2.0), ("background", 0.0)]);
        let (header, page) = receive(&sent.messages(&first), &HashMap::new());
        assert_eq!(page, images(&first));
        assert_eq!(header["total"], 4 * 40 * 30 * 3, "a first frame sends every image whole");
        sent.sent(first);
        // A coarse frame is sent whole and changes nothing of what the next full frame sends.
        let coarse = rendered(2, true, (10, 7), &[("ambient", 1.0), ("diffuse", 5.0), ("background", 0.0)]);
        let (_, shown) = receive(&sent.messages(&coarse), &HashMap::new());
        assert_eq!(shown, images(&coarse));
        sent.sent(coarse);
        // The diffuse image changed between two pixels: that stretch of it and of beauty.
        let mut second = rendered(2, false, (40, 30), &[("ambient", 1.0), ("diffuse", 2.0), ("background", 0.0)]);
        let frame = &mut Arc::get_mut(&mut second).unwrap().frame;
        for i in [100, 250] {
            frame.layers[1].pixels[i].y += 1.0;
            frame.beauty[i].y += 1.0;
        }
        let (header, page) = receive(&sent.messages(&second), &page);
        assert_eq!(page, images(&second));
        assert_eq!(
            header["sent"],
            json!([["diffuse", 301, 752], ["beauty", 301, 752]]),
            "pixel 100's green to pixel 250's"
        );
        sent.sent(second.clone());
        // The same frame again sends nothing; a frame of another size sends every image whole.
        let (header, again) = receive(&sent.messages(&second), &page);
        assert_eq!((header["total"].as_u64(), again), (Some(0), page));
        let resized = rendered(3, false, (41, 30), &[("ambient", 1.0), ("diffuse", 2.0), ("background", 0.0)]);
        assert_eq!(receive(&sent.messages(&resized), &HashMap::new()).1, images(&resized));
    }

    #[test]
    fn the_changed_stretch_is_from_the_first_to_the_last_float_that_differs() {
        // Against the float-by-float answer, at block edges and across them.
        for pixels in [1, 85, 86, 171, 1000] {
            let old: Vec<glam::Vec3> = (0..pixels).map(|i| glam::Vec3::splat(i as f32)).collect();
            assert_eq!(changed(Some(&old), &old), None);
            assert_eq!(changed(None, &old), Some((0, 3 * pixels)));
            let n = 3 * pixels;
            for (a, b) in [(0, 0), (0, n - 1), (n - 1, n - 1), (255, 256), (256, 511), (n / 2, n - 2), (1, 768)] {
                let (a, b) = (a.min(n - 1), b.min(n - 1));
                let mut new = old.clone();
                let floats: &mut [f32] = bytemuck::cast_slice_mut(&mut new);
                floats[a] = -1.0;
                floats[b] = -2.0;
                assert_eq!(changed(Some(&old), &new), Some((a.min(b), a.max(b) + 1)), "{pixels} pixels, {a} and {b}");
            }
        }
        // -0 and 0 differ to the bit.
        assert_eq!(changed(Some(&[glam::Vec3::ZERO]), &[glam::Vec3::new(0.0, -0.0, 0.0)]), Some((1, 2)));
    }

    #[test]
    fn a_frame_larger_than_a_message_is_cut_across_its_images() {
        // 640x360 of five layers and beauty: 4 147 200 floats, eight messages.
        let layers = [("a", 1.0), ("b", 2.0), ("c", 3.0), ("d", 4.0), ("e", 5.0)];
        let mut sent = Sent::default();
        let first = rendered(1, false, (640, 360), &layers);
        let messages = sent.messages(&first);
        assert_eq!(messages.len(), (6 * 640 * 360 * 3usize).div_ceil(CHUNK));
        let (_, page) = receive(&messages, &HashMap::new());
        assert_eq!(page, images(&first));
        sent.sent(first);
        // Stretches of b and d (and so of beauty) changed: 1.1 M floats, three messages, the
        // stretches cut across them.
        let mut second = rendered(2, false, (640, 360), &layers);
        let frame = &mut Arc::get_mut(&mut second).unwrap().frame;
        for (layer, span) in [(1, 100_000..400_000), (3, 50_000..450_000)] {
            for i in span {
                bytemuck::cast_slice_mut::<_, f32>(&mut frame.layers[layer].pixels)[i] += 0.5;
                bytemuck::cast_slice_mut::<_, f32>(&mut frame.beauty)[i] += 0.5;
            }
        }
        let messages = sent.messages(&second);
        assert_eq!(messages.len(), 3);
        let (header, page) = receive(&messages, &page);
        assert_eq!(page, images(&second));
        assert_eq!(
            header["sent"],
            json!([["b", 100_000, 400_000], ["d", 50_000, 450_000], ["beauty", 50_000, 450_000]])
        );
    }

    #[test]
    fn a_tab_dragging_a_slider_does_not_starve_another() {
        let mut q = two_tabs();
        q.push(1, job(1));
        q.push(2, job(2));
        let (viewer, _, cancel) = start(&mut q);
        assert_eq!(viewer, 1);
        // Tab 1 keeps dragging: its render stops, and its newest edit waits behind tab 2's.
        for g in 3..50 {
            q.push(1, job(g));
        }
        assert!(cancel.load(Ordering::SeqCst));
        q.running = None;
        assert_eq!(q.order, [2, 1], "each viewer waits once, whatever it sent");
        let (viewer, job2, _) = start(&mut q);
        assert_eq!((viewer, job2.generation), (2, 2));
        let (viewer, newest, _) = start(&mut q);
        assert_eq!((viewer, newest.generation), (1, 49), "only the newest edit is kept");
        assert!(q.pop().is_none());
    }

    #[test]
    fn a_newer_edit_cancels_only_its_own_viewers_render() {
        let mut q = two_tabs();
        q.push(2, job(1));
        let (_, _, cancel) = start(&mut q);
        q.push(1, job(2));
        q.push(EVERY_PAGE, job(3));
        assert!(!cancel.load(Ordering::SeqCst), "another viewer's edit stopped tab 2's render");
        q.push(2, job(4));
        assert!(cancel.load(Ordering::SeqCst));
    }

    #[test]
    fn a_full_image_waits_behind_the_other_viewers_coarse_ones() {
        let mut q = two_tabs();
        q.push(1, job(1));
        let (_, coarse, _) = start(&mut q);
        q.push(2, job(2));
        q.running = None;
        q.then_full(1, coarse.clone());
        let (viewer, _, _) = start(&mut q);
        assert_eq!(viewer, 2);
        let (viewer, full, _) = start(&mut q);
        assert_eq!((viewer, full.generation, full.coarse), (1, 1, false));
        // Not when a newer edit is waiting, nor for a tab that has left.
        q.push(1, job(3));
        q.then_full(1, coarse.clone());
        assert_eq!(q.pop().map(|(v, j)| (v, j.generation, j.coarse)), Some((1, 3, true)));
        q.tabs.remove(&1);
        q.then_full(1, coarse);
        assert!(q.pop().is_none());
    }

    #[test]
    fn a_tab_that_leaves_is_forgotten_and_its_render_stopped() {
        let mut q = two_tabs();
        q.push(1, job(1));
        q.push(2, job(2));
        let (_, _, cancel) = start(&mut q);
        q.push(1, job(3));
        q.forget(1);
        assert!(cancel.load(Ordering::SeqCst));
        assert_eq!(q.order, [2]);
        assert_eq!(q.pop().map(|(v, _)| v), Some(2));
    }
}
