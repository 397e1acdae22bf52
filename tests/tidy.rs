//! Tidy checks over the source tree: every Rust file says what it is on its first line, no
//! placeholder macro (todo, unimplemented) is left, and every built-in term, variant and shadow
//! model is used by some scene or model file.

use std::path::{Path, PathBuf};

use lancer_tests::root;

fn rust_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let p = entry.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            if p.is_dir() && name != "target" && !name.starts_with('.') {
                walk(&p, out);
            } else if name.ends_with(".rs") {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    for dir in ["crates", "tests", "xtask", "examples"] {
        if root().join(dir).is_dir() {
            walk(&root().join(dir), &mut out);
        }
    }
    out
}

#[test]
fn every_rust_file_starts_with_a_module_doc_line() {
    let files = rust_files();
    assert!(files.len() > 20);
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        assert!(text.starts_with("//!"), "{} must start with a `//!` line saying what it is", f.display());
    }
}

#[test]
fn no_todo_or_unimplemented_is_left() {
    let (todo, unimpl) = (concat!("todo", "!("), concat!("unimplemented", "!("));
    for f in rust_files() {
        let text = std::fs::read_to_string(&f).unwrap();
        assert!(!text.contains(todo) && !text.contains(unimpl), "{} has a placeholder left", f.display());
    }
}

#[test]
fn every_built_in_term_variant_and_shadow_model_is_used_by_a_scene_or_model_file() {
    let mut files = lancer_tests::scene_files();
    files.extend(std::fs::read_dir(root().join("models")).unwrap().map(|e| e.unwrap().path()));
    let text: String = files.iter().map(|p| std::fs::read_to_string(p).unwrap()).collect();
    // The classic mistakes are shown by `lancer diagnose`'s tests, not by a shipped scene.
    for t in lancer_shading::terms::BUILTIN.iter().filter(|t| t.mistake.is_none()) {
        assert!(text.contains(&format!("\"{}\"", t.name)), "no scene or model uses term `{}`", t.name);
        assert!(
            text.contains(&format!("variant = \"{}\"", t.variant)) || t.variant == default_variant(t.name),
            "no scene or model uses `{}` variant `{}`",
            t.name,
            t.variant
        );
    }
    for s in lancer_shading::shadows::BUILTIN.iter().filter(|s| s.mistake.is_none()) {
        assert!(text.contains(&format!("\"{}\"", s.name)), "no scene or model uses shadow model `{}`", s.name);
    }
}

fn default_variant(name: &str) -> &'static str {
    lancer_shading::terms::BUILTIN.iter().find(|t| t.name == name).unwrap().variant
}

#[test]
fn every_scene_has_a_title_and_description_and_every_shape_a_scene() {
    let mut text = String::new();
    for path in lancer_tests::scene_files() {
        let src = std::fs::read_to_string(&path).unwrap();
        let loaded = lancer_tests::load_file(&path);
        let meta = &loaded.scene.meta;
        assert!(meta.title.as_deref().is_some_and(|t| !t.is_empty()), "{} has no [meta] title", path.display());
        assert!(
            meta.description.as_deref().is_some_and(|d| d.len() > 40),
            "{} has no real [meta] description",
            path.display()
        );
        text += &src;
    }
    for shape in lancer_shapes::Shape::NAMES {
        assert!(text.contains(&format!("shape = \"{shape}\"")), "no scene shows shape `{shape}`");
    }
}
