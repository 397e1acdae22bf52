//! Your terms against Lancer's, one test per exercise of docs/course.md: `cargo test` runs them
//! all, `cargo test ex3` one. Each renders the exercise's scene (`../ex*.toml`) with Lancer's
//! model and with your term in place of Lancer's, and fails with what differs, the worst pixel
//! and the diagnosis.

use lancer_starter::check::compare;

/// Runs the comparison; the report is the test's failure message.
fn check(scene: &str, terms: &[&str]) {
    if let Err(report) = compare(scene, terms) {
        panic!("{report}");
    }
}

#[test]
fn ex1_ambient() {
    check("ex1-ambient.toml", &["ambient"]);
}

#[test]
fn ex2_diffuse() {
    check("ex2-diffuse.toml", &["diffuse"]);
}

#[test]
fn ex3_specular() {
    check("ex3-specular.toml", &["specular"]);
}

/// Shadows are Lancer's (its shadow model gives `Col_L`, black in a shadow): your diffuse and
/// specular terms need no change for them.
#[test]
fn ex4_shadows() {
    check("ex4-shadows.toml", &["diffuse", "specular"]);
}

#[test]
fn ex5_mirror() {
    check("ex5-mirror.toml", &["mirror"]);
}

#[test]
fn ex6_refraction() {
    check("ex6-refraction.toml", &["refraction"]);
}
