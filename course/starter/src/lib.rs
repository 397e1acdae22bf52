//! The course's starter crate: the five terms of the handout's illumination model, yours to
//! write, each in its own file (`ambient.rs`, `diffuse.rs`, `specular.rs`, `mirror.rs`,
//! `refraction.rs`), each returning zero until you do. They are registered beside Lancer's own
//! terms as `student-ambient` ... `student-refraction` ([`registry`]), so a scene or
//! `--terms` can name them, and `cargo test` compares each with Lancer's term of the same
//! name on the course's scenes (`../ex*.toml`), pixel by pixel, saying what differs and which
//! classic mistake explains it ([`check`]). docs/course.md walks through the exercises.

mod ambient;
pub mod check;
mod diffuse;
mod given;
mod mirror;
mod refraction;
mod specular;

pub use given::{Child, Exit, Hit, Light, Ray};
pub use refraction::vct_transmis;

use given::{Formula, Yours};
use lancer_shading::{ParamError, Params, Registry, Term, TermSpec};

/// Your five terms as the registry builds them: `student-ambient` ... `student-refraction`,
/// each of variant `seed` (the handout's own form of the term, which you are writing).
pub const TERMS: [TermSpec; 5] = [
    spec("student-ambient", "yours: ambi · Col_Ω (src/ambient.rs)", &["ambi", "color"], |_| {
        Ok(Box::new(Yours(Formula::Adds(ambient::ambient))))
    }),
    spec(
        "student-diffuse",
        "yours: diff · max(N·w, 0) · Col_Ω · Col_L (src/diffuse.rs)",
        &["diff", "color"],
        |_| Ok(Box::new(Yours(Formula::Adds(diffuse::diffuse)))),
    ),
    spec(
        "student-specular",
        "yours: spec · shine · max(−u·w_r, 0)^(1/(1−shine)) · Col_L (src/specular.rs)",
        &["spec", "shine"],
        |_| Ok(Box::new(Yours(Formula::Adds(specular::specular)))),
    ),
    spec("student-mirror", "yours: spec · Col(R_r), R_r = [I, u − 2(N·u)N) (src/mirror.rs)", &["spec"], |_| {
        Ok(Box::new(Yours(Formula::Traces(mirror::mirror))))
    }),
    spec(
        "student-refraction",
        "yours: alpha · Col(R_t) through the object (src/refraction.rs)",
        &["alpha", "n"],
        |_| Ok(Box::new(Yours(Formula::Traces(refraction::refraction)))),
    ),
];

/// The spec of one of your terms: its name, its line for `lancer terms`, the material fields
/// its formula reads, and how to build it (it has no parameters but `weight`).
const fn spec(
    name: &'static str,
    summary: &'static str,
    reads: &'static [&'static str],
    build: fn(&mut Params) -> Result<Box<dyn Term>, ParamError>,
) -> TermSpec {
    TermSpec { name, variant: "seed", summary, reads, params: &[], build, mistake: None }
}

/// Lancer's terms and shadow models, and yours.
pub fn registry() -> Registry {
    let mut registry = Registry::with_builtins();
    for spec in TERMS {
        registry.register_term(spec).expect("the student terms' names are free");
    }
    registry
}
