//! Tidy checks over the source tree: every Rust file says what it is on its first line, no
//! placeholder macro (todo, unimplemented) is left, and every built-in term is used by some scene.

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
fn every_built_in_term_and_shadow_model_is_used_by_a_scene() {
    let scenes: String = lancer_tests::scene_files().iter().map(|p| std::fs::read_to_string(p).unwrap()).collect();
    for t in lancer_shading::terms::BUILTIN {
        assert!(scenes.contains(&format!("\"{}\"", t.name)), "no scene uses term `{}`", t.name);
    }
    for s in lancer_shading::shadows::BUILTIN {
        assert!(scenes.contains(&format!("\"{}\"", s.name)), "no scene uses shadow model `{}`", s.name);
    }
}
