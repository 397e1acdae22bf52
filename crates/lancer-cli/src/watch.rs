//! `lancer watch`: render, then render again whenever a file the render read is saved.

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use lancer_shading::Registry;
use notify_debouncer_mini::notify::RecursiveMode;
use notify_debouncer_mini::{DebounceEventResult, new_debouncer};

use crate::app::{RenderArgs, render_recording};

/// How long the files must be quiet before a render starts: an editor's save (write, or write
/// a copy and rename it over the file) is one change, not several.
const SETTLE: Duration = Duration::from_millis(150);

/// A file's size and modification time.
pub(crate) type Stamp = (u64, std::time::SystemTime);

/// `path`'s size and modification time (`None` when it is gone).
pub(crate) fn stamp(path: &Path) -> Option<Stamp> {
    let meta = std::fs::metadata(path).ok()?;
    Some((meta.len(), meta.modified().ok()?))
}

/// An absolute form of `path`, with `.` and `..` resolved where the folder exists, so events
/// (which name absolute paths) can be compared with it.
fn absolute(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    match (abs.parent().and_then(|d| d.canonicalize().ok()), abs.file_name()) {
        (Some(dir), Some(name)) => dir.join(name),
        _ => abs,
    }
}

/// Renders `args`, then again after each save of the scene, the model file or a file the scene
/// uses. A render that fails prints its error and leaves the last image in place (images are
/// replaced whole, only once written); the watch goes on until Ctrl-C.
pub fn watch(registry: &Registry, args: RenderArgs) -> Result<()> {
    let Some(scene) = &args.input.scene else {
        bail!("watch needs a scene file: lancer watch SCENE.toml -o OUT.png");
    };
    if !scene.is_file() {
        bail!("scene {} is not a file that can be watched", scene.display());
    }
    let (tx, rx) = std::sync::mpsc::channel::<DebounceEventResult>();
    let mut debouncer = new_debouncer(SETTLE, tx).context("starting to watch files")?;
    let mut folders: Vec<PathBuf> = Vec::new();
    loop {
        let inputs = RefCell::new(Vec::new());
        match render_recording(registry, &args, &inputs) {
            Ok(()) => {}
            Err(e) => eprintln!("error: {e:#}\n(the last image is kept; fix the file and save it again)"),
        }
        // Each file with what it was just before it was read: a save made during the render
        // shows as a change below, and renders again (the image always ends up matching the
        // files' last state).
        // (A file read twice keeps both stamps: either moving is a change.)
        let read: Vec<(PathBuf, Option<Stamp>)> =
            inputs.into_inner().into_iter().map(|(p, s)| (absolute(&p), s)).collect();
        let mut files: Vec<PathBuf> = read.iter().map(|(p, _)| p.clone()).collect();
        files.sort();
        files.dedup();
        // Folders, not files: an editor that saves by renaming a new file over the old one
        // replaces what a watch on the file itself would follow.
        for file in &files {
            let Some(folder) = file.parent() else { continue };
            if !folders.iter().any(|f| f == folder) {
                debouncer
                    .watcher()
                    .watch(folder, RecursiveMode::NonRecursive)
                    .with_context(|| format!("watching {}", folder.display()))?;
                folders.push(folder.to_path_buf());
            }
        }
        let changed = || read.iter().find(|(f, s)| stamp(f) != *s).map(|(f, _)| f.clone());
        if let Some(f) = changed() {
            eprintln!("{} changed during the render: rendering again", f.display());
            continue;
        }
        eprintln!("watching {} file(s) for changes; Ctrl-C to stop", files.len());
        // An event (the watcher also reports files being opened, as the render itself does)
        // counts only if a file's size or modification time moved since it was read.
        loop {
            let events = match rx.recv().context("the file watcher stopped")? {
                Ok(events) => events,
                Err(e) => {
                    eprintln!("warning: file watcher: {e}");
                    continue;
                }
            };
            if !events.iter().any(|e| files.contains(&absolute(&e.path))) {
                continue;
            }
            if let Some(f) = changed() {
                eprintln!("{} changed: rendering again", f.display());
                break;
            }
        }
    }
}
