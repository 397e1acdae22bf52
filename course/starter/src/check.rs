//! The tests' harness (given: you need not change this file): renders a course scene with
//! Lancer's model and again with your terms in place of Lancer's, compares each of your terms'
//! images with Lancer's term of the same name pixel by pixel, and, where they differ, says
//! where and by how much, and asks `lancer diagnose` which classic mistake of the course
//! explains your image.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::Vec3;
use lancer_core::Frame;
use lancer_shading::{Params, Pipeline, Registry, RenderOptions};

/// How far apart two pixels of a term's image may be and still match: 1e-5 of the value (or
/// 1e-5 for values below 1), in every channel. Your formula may round differently from
/// Lancer's (another order of the same products), never by more.
pub const TOLERANCE: f32 = 1e-5;

/// The course's folder: the scenes `ex*.toml`, one level above this crate.
pub fn course_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the starter sits in course/").to_path_buf()
}

/// Renders the course scene `scene` (a file name in [`course_dir`], e.g. `ex3-specular.toml`)
/// with Lancer's model and with `terms` (names of its model, e.g. `["diffuse", "specular"]`)
/// replaced by yours (`student-diffuse`, ...), and compares each of those terms' images.
/// `Err` holds the report of every term that differs, with its diagnosis.
pub fn compare(scene: &str, terms: &[&str]) -> Result<(), String> {
    let path = course_dir().join(scene);
    let registry = crate::registry();
    let src = std::fs::read_to_string(&path).map_err(|e| format!("reading {}: {e}", path.display()))?;
    let resolve = |rel: &str| std::fs::read(course_dir().join(rel)).map_err(|e| e.to_string());
    let loaded = lancer_scene::load_scene_with(&src, &path.display().to_string(), &registry, &resolve)
        .map_err(|e| e.to_string())?;
    let right = &loaded.pipeline;
    for t in terms {
        if !right.terms.iter().any(|r| r.name == *t) {
            return Err(format!("{scene}'s model has no term `{t}`"));
        }
    }
    let yours = with_yours(&registry, right, terms)?;
    let prepared = lancer_shading::prepare(&loaded.scene).map_err(|e| e.to_string())?;
    let render = |p: &Pipeline| {
        let options = RenderOptions { layers: true, ..RenderOptions::default() };
        lancer_shading::render_prepared(&prepared, &loaded.scene.camera, &loaded.scene.image, p, options)
    };
    let (lancers, mine) = (render(right), render(&yours));
    let list: Vec<&str> = yours.terms.iter().map(|t| t.name.as_str()).collect();
    let case = Case { registry: &registry, path: &path, scene, frame: &lancers, yours: &list.join(",") };
    let mut report = String::new();
    for t in terms {
        let theirs = &lancers.layer(t).expect("a term of the model has its image").pixels;
        let student = format!("student-{t}");
        let ours = &mine.layer(&student).expect("your term has its image").pixels;
        match case.differences(t, theirs, ours) {
            Some(text) => report += &text,
            None => println!("{student} matches Lancer's {t} on {scene}: every pixel within {TOLERANCE:e}"),
        }
    }
    if report.is_empty() { Ok(()) } else { Err(report) }
}

/// Lancer's pipeline `right` with the terms `terms` replaced by yours, in the same places (so
/// that every pixel's sums are made in the same order).
fn with_yours(registry: &Registry, right: &Pipeline, terms: &[&str]) -> Result<Pipeline, String> {
    let mut list = Vec::new();
    for t in &right.terms {
        let params = Params::new(t.params.clone());
        let built = if terms.contains(&t.name.as_str()) {
            registry.build_term(&format!("student-{}", t.name), None, params)
        } else {
            registry.build_term(&t.name, Some(&t.variant), params)
        };
        list.push(built.map_err(|e| e.to_string())?);
    }
    let shadows = registry
        .build_shadow(&right.shadows.name, Params::new(right.shadows.params.clone()))
        .map_err(|e| e.to_string())?;
    Pipeline::new(right.max_depth, shadows, list).map_err(|e| e.to_string())
}

/// Whether the pixel `ours` matches `theirs` within [`TOLERANCE`].
fn matches(ours: Vec3, theirs: Vec3) -> bool {
    let allowed = TOLERANCE * theirs.abs().max(Vec3::ONE);
    (ours - theirs).abs().cmple(allowed).all()
}

/// One comparison: the scene, Lancer's render of it, and your terms' model.
struct Case<'a> {
    registry: &'a Registry,
    /// The scene file, and its name in the course folder.
    path: &'a Path,
    scene: &'a str,
    /// Lancer's render (for its size).
    frame: &'a Frame,
    /// The model's terms with yours in place, as `--terms` takes them.
    yours: &'a str,
}

impl Case<'_> {
    /// The report on term `term` where your image `ours` differs from Lancer's `theirs`: how
    /// many pixels, the worst one and how to see it explained, and the diagnosis. `None` where
    /// every pixel matches.
    fn differences(&self, term: &str, theirs: &[Vec3], ours: &[Vec3]) -> Option<String> {
        let differing = ours.iter().zip(theirs).filter(|(o, t)| !matches(**o, **t)).count();
        if differing == 0 {
            return None;
        }
        let (scene, (width, height)) = (self.scene, (self.frame.width, self.frame.height));
        // The pixel off by the most (a NaN counts as the most of all).
        let off = |k: usize| {
            let d = (ours[k] - theirs[k]).abs().max_element();
            if d.is_nan() { f32::INFINITY } else { d }
        };
        let worst = (0..ours.len()).max_by(|&a, &b| off(a).total_cmp(&off(b))).unwrap_or(0);
        let (x, y) = (worst as u32 % width, worst as u32 / width);
        let mut out = String::new();
        let _ = writeln!(
            out,
            "\nstudent-{term} differs from Lancer's {term} on {scene}: {differing} of {} pixels ({:.2} %) are off by more than {TOLERANCE:e}",
            theirs.len(),
            100.0 * differing as f64 / theirs.len() as f64
        );
        let _ = writeln!(out, "  worst pixel {x},{y}: yours {}, Lancer's {}", rgb(ours[worst]), rgb(theirs[worst]));
        let _ = writeln!(
            out,
            "  every input of Lancer's formula there: cargo run --release -- explain ../{scene} --pixel {x},{y}"
        );
        let _ = writeln!(
            out,
            "  your images: cargo run --release -- render ../{scene} --terms {} -o mine.png --aov mine/",
            self.yours
        );
        let file = term_file(term);
        if ours.iter().all(|p| *p == Vec3::ZERO) {
            let _ = writeln!(
                out,
                "  your term adds nothing anywhere: it is still the stub that returns zero; write its formula in {file}\n  (the diagnosis comes once it adds something: an image of nothing is no classic mistake)"
            );
            return Some(out);
        }
        let label = format!("your student-{term} image from {file}");
        match lancer_cli::diagnose_layer(self.registry, self.path, term, &label, (width, height), ours.to_vec()) {
            Ok(d) => {
                let _ = writeln!(out, "  the diagnosis (as lancer diagnose ../{scene} --term {term} says it):");
                for line in d.report.lines() {
                    let _ = writeln!(out, "    {line}");
                }
            }
            Err(e) => {
                let _ = writeln!(out, "  no diagnosis: {e:#}");
            }
        }
        Some(out)
    }
}

/// The file of yours that computes term `term`.
fn term_file(term: &str) -> String {
    format!("src/{term}.rs")
}

/// A colour as `(r, g, b)` with six decimals.
fn rgb(c: Vec3) -> String {
    format!("({:.6}, {:.6}, {:.6})", c.x, c.y, c.z)
}
