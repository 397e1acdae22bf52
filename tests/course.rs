//! The course folder (docs/course.md): every exercise's scene in `course/` loads and prepares
//! with no warning from `lancer check` (a course scene teaches nothing it does not mean), and
//! the starter crate's `Cargo.lock` keeps Lancer's versions of every package it shares.

use std::collections::BTreeSet;
use std::path::PathBuf;

use lancer_tests::root;

/// Every scene file of `course/`, sorted.
fn course_scenes() -> Vec<PathBuf> {
    let mut list: Vec<PathBuf> = std::fs::read_dir(root().join("course"))
        .expect("course/ is readable")
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "toml"))
        .collect();
    list.sort();
    list
}

#[test]
fn every_course_scene_checks_with_no_warning() {
    let scenes = course_scenes();
    assert_eq!(scenes.len(), 6, "one scene per exercise: {scenes:?}");
    for path in scenes {
        let loaded = lancer_tests::load_file(&path);
        let prepared = lancer_shading::prepare(&loaded.scene).expect("a course scene prepares");
        let mut warnings = loaded.warnings.clone();
        warnings.extend(lancer_scene::check(&loaded.scene, &loaded.pipeline, &prepared, &loaded.places));
        let text: Vec<String> = warnings.iter().map(|w| w.to_string()).collect();
        assert!(text.is_empty(), "{} warns:\n{}", path.display(), text.join("\n"));
        let image = loaded.scene.image;
        assert_eq!((image.width, image.height, image.samples), (320, 180, 1), "{}", path.display());
    }
}

/// The name and version of every package of a Cargo.lock (each `[[package]]` starts with its
/// `name = "..."` and `version = "..."` lines).
fn locked(path: &std::path::Path) -> BTreeSet<(String, String)> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    let value =
        |line: &str, key: &str| line.strip_prefix(key)?.strip_prefix(" = \"")?.strip_suffix('"').map(str::to_owned);
    let lines: Vec<&str> = text.lines().collect();
    let packages: BTreeSet<(String, String)> = lines
        .windows(3)
        .filter(|w| w[0] == "[[package]]")
        .map(|w| {
            let name = value(w[1], "name").unwrap_or_else(|| panic!("{}: {:?}", path.display(), w));
            (name, value(w[2], "version").unwrap_or_else(|| panic!("{}: {:?}", path.display(), w)))
        })
        .collect();
    assert!(packages.len() > 10, "{} lists {} packages", path.display(), packages.len());
    packages
}

#[test]
fn the_starter_locks_lancers_own_versions() {
    let lancer = locked(&root().join("Cargo.lock"));
    let starter = locked(&root().join("course/starter/Cargo.lock"));
    let stray: Vec<String> = starter
        .iter()
        .filter(|(name, _)| name != "lancer-starter")
        .filter(|k| !lancer.contains(*k))
        .map(|(n, v)| format!("{n} {v}"))
        .collect();
    assert!(
        stray.is_empty(),
        "course/starter/Cargo.lock has versions Lancer's Cargo.lock does not: {}\n(copy Cargo.lock over course/starter/Cargo.lock and run `cargo tree --manifest-path course/starter/Cargo.toml --offline` to trim it)",
        stray.join(", ")
    );
}
