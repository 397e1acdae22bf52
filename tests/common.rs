//! Helpers shared by the workspace tests: load a scene from text or from `scenes/`, render it at
//! a chosen size on a chosen number of threads.

use std::path::{Path, PathBuf};

use lancer_core::Frame;
use lancer_scene::Loaded;
use lancer_shading::{Registry, RenderOptions};

pub mod robustness_scenes;

/// The repository's root folder.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ sits in the root").to_path_buf()
}

/// Loads scene text, panicking with the located error if it does not load.
pub fn load(src: &str) -> Loaded {
    lancer_scene::load_scene(src, "test.toml", &Registry::with_builtins()).unwrap_or_else(|e| panic!("{e}"))
}

/// Loads `path` (relative to the repository root, or absolute).
pub fn load_file(path: &Path) -> Loaded {
    let path = root().join(path);
    let src = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    let dir = path.parent().expect("a scene file has a folder").to_path_buf();
    let resolve = |rel: &str| std::fs::read(dir.join(rel)).map_err(|e| e.to_string());
    lancer_scene::load_scene_with(&src, &path.display().to_string(), &Registry::with_builtins(), &resolve)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Renders at `width` (height keeping the scene's aspect ratio) on `threads` threads, keeping
/// every term's image.
pub fn render(loaded: &Loaded, width: Option<u32>, threads: usize) -> Frame {
    render_with(loaded, width, threads, true)
}

/// As [`render`], keeping the per-term images only with `layers` (as `lancer render` does with
/// `--aov`).
pub fn render_with(loaded: &Loaded, width: Option<u32>, threads: usize, layers: bool) -> Frame {
    let mut image = loaded.scene.image;
    if let Some(w) = width {
        image.height = ((w as f64 * image.height as f64 / image.width as f64).round() as u32).max(1);
        image.width = w;
    }
    let prepared = lancer_shading::prepare(&loaded.scene).expect("scene prepares");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
    pool.install(|| {
        lancer_shading::render_prepared(
            &prepared,
            &loaded.scene.camera,
            &image,
            &loaded.pipeline,
            RenderOptions { layers, ..RenderOptions::default() },
        )
    })
}

/// Every scene file under `scenes/`, sorted.
pub fn scene_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("scenes/ is readable") {
            let p = entry.expect("directory entry").path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "toml") {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(&root().join("scenes"), &mut out);
    out.sort();
    out
}
