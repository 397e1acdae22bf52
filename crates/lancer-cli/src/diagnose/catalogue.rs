//! The catalogue of classic mistakes as `lancer diagnose` tries them: the registry's mistaken
//! term variants and shadow models, then the output mistakes, each with its name
//! (`specular:sign`, `shadows:no-offset`, `output:gamma`), what it is, the hint, and how the
//! right model becomes the mistaken one.

use anyhow::{Context, Result};
use lancer_shading::{Params, Pipeline, Registry};

use super::output::OutputMistake;

/// One mistake of the catalogue.
#[derive(Clone, Debug)]
pub(crate) struct Entry {
    /// Its name: `TERM:VARIANT`, `shadows:MODEL` or `output:NAME`.
    pub(crate) name: String,
    /// What it is, in one line.
    pub(crate) summary: &'static str,
    /// What to check in the code.
    pub(crate) hint: &'static str,
    /// Where it goes in.
    pub(crate) kind: Kind,
}

/// How a mistake changes the right render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    /// The term `name`, where the model uses its variant `of`, becomes its variant `variant`.
    Term {
        /// The term.
        name: &'static str,
        /// The mistaken variant.
        variant: &'static str,
        /// The variant it is a mistake of.
        of: &'static str,
    },
    /// The shadow model, where it is `of`, becomes `name`.
    Shadow {
        /// The mistaken shadow model.
        name: &'static str,
        /// The model it is a mistake of.
        of: &'static str,
    },
    /// The image goes through the writer's mistake.
    Output(OutputMistake),
}

/// Every mistake the registry knows, then the output mistakes: the term mistakes in
/// registration order, the shadow mistakes, `output:gamma`, `output:flipped`, `output:bgr`.
pub(crate) fn entries(registry: &Registry) -> Vec<Entry> {
    let mut all = Vec::new();
    for t in registry.mistakes() {
        let Some(m) = t.mistake else { continue };
        all.push(Entry {
            name: format!("{}:{}", t.name, t.variant),
            summary: t.summary,
            hint: m.hint,
            kind: Kind::Term { name: t.name, variant: t.variant, of: m.of },
        });
    }
    for s in registry.shadow_mistakes() {
        let Some(m) = s.mistake else { continue };
        all.push(Entry {
            name: format!("shadows:{}", s.name),
            summary: s.summary,
            hint: m.hint,
            kind: Kind::Shadow { name: s.name, of: m.of },
        });
    }
    for o in OutputMistake::ALL {
        all.push(Entry {
            name: format!("output:{}", o.name()),
            summary: o.summary(),
            hint: o.hint(),
            kind: Kind::Output(o),
        });
    }
    all
}

impl Entry {
    /// `Ok` when the mistake can be made in `pipeline` (its term in the variant it is a
    /// mistake of, or its shadow model), else why not, in a few words.
    pub(crate) fn applies(&self, pipeline: &Pipeline) -> Result<(), String> {
        match self.kind {
            Kind::Term { name, of, .. } => match pipeline.terms.iter().find(|t| t.name == name) {
                None => Err(format!("the model has no {name} term")),
                Some(t) if t.variant != of => {
                    Err(format!("the model's {name} is {}, these are mistakes of {of}", t.variant))
                }
                Some(_) => Ok(()),
            },
            Kind::Shadow { of, .. } if pipeline.shadows.name != of => {
                Err(format!("the model's shadows are {}, these are mistakes of {of}", pipeline.shadows.name))
            }
            Kind::Shadow { .. } | Kind::Output(_) => Ok(()),
        }
    }

    /// Whether this mistake and `other` can be made together: not two of one term, of the
    /// shadows, or of the output.
    pub(crate) fn goes_with(&self, other: &Entry) -> bool {
        match (self.kind, other.kind) {
            (Kind::Term { name: a, .. }, Kind::Term { name: b, .. }) => a != b,
            (Kind::Shadow { .. }, Kind::Shadow { .. }) | (Kind::Output(_), Kind::Output(_)) => false,
            _ => true,
        }
    }
}

/// The model with every mistake of `entries` made in `pipeline`: the same terms, parameters,
/// shadows and depth, but the mistaken term variants and shadow model (output mistakes are left
/// to the image).
pub(crate) fn combined(registry: &Registry, pipeline: &Pipeline, entries: &[&Entry]) -> Result<Pipeline> {
    let mut terms = Vec::new();
    let mut shadow = None;
    for e in entries {
        match e.kind {
            Kind::Term { name, variant, .. } => terms.push((name, variant)),
            Kind::Shadow { name, .. } => shadow = Some(name),
            Kind::Output(_) => {}
        }
    }
    let names: Vec<&str> = entries.iter().map(|e| e.name.as_str()).collect();
    rebuild(registry, pipeline, &terms, shadow)
        .with_context(|| format!("building the model with {}", names.join(" and ")))
}

/// `pipeline` built again from its names and parameters, each term `t.0` of `terms` in variant
/// `t.1` and the shadow model `shadow` where given.
pub(crate) fn rebuild(
    registry: &Registry,
    pipeline: &Pipeline,
    swaps: &[(&str, &str)],
    shadow: Option<&str>,
) -> Result<Pipeline> {
    let mut terms = Vec::with_capacity(pipeline.terms.len());
    for t in &pipeline.terms {
        let variant = swaps.iter().find(|(name, _)| *name == t.name).map_or(t.variant.as_str(), |(_, v)| v);
        terms.push(registry.build_term(&t.name, Some(variant), Params::new(t.params.clone()))?);
    }
    let shadows = match shadow {
        Some(name) => registry.build_shadow(name, Params::default())?,
        None => registry.build_shadow(&pipeline.shadows.name, Params::new(pipeline.shadows.params.clone()))?,
    };
    Ok(Pipeline::new(pipeline.max_depth, shadows, terms)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_catalogue_names_every_mistake_once_and_each_applies_where_its_variant_is_used() {
        let registry = Registry::with_builtins();
        let all = entries(&registry);
        let names: Vec<&str> = all.iter().map(|e| e.name.as_str()).collect();
        for want in [
            "specular:exponent-shine",
            "specular:sign",
            "diffuse:no-clamp",
            "mirror:sign",
            "refraction:sign-trap",
            "refraction:inverted-index",
            "refraction:no-exit-bend",
            "shadows:no-offset",
            "shadows:past-light",
            "output:gamma",
            "output:flipped",
            "output:bgr",
        ] {
            assert_eq!(names.iter().filter(|n| **n == want).count(), 1, "{want} in {names:?}");
        }
        assert!(all.iter().all(|e| !e.summary.is_empty() && !e.hint.is_empty() && !e.summary.contains('\n')));
        let handout = registry.default_pipeline();
        assert!(all.iter().all(|e| e.applies(&handout).is_ok()), "the handout's model takes every mistake");
        let blinn = rebuild(&registry, &handout, &[("specular", "blinn")], Some("soft")).unwrap();
        let why = |name: &str| all.iter().find(|e| e.name == name).unwrap().applies(&blinn).unwrap_err();
        assert_eq!(why("specular:sign"), "the model's specular is blinn, these are mistakes of phong");
        assert_eq!(why("shadows:no-offset"), "the model's shadows are soft, these are mistakes of hard");
        let made = combined(&registry, &handout, &[all.iter().find(|e| e.name == "specular:sign").unwrap()]).unwrap();
        let variants: Vec<&str> = made.terms.iter().map(|t| t.variant.as_str()).collect();
        assert_eq!(variants, ["seed", "lambert", "sign", "constant", "seed"]);
        assert_eq!((made.shadows.name.as_str(), made.max_depth), ("hard", handout.max_depth));
        // Two mistakes at once: of two terms, or a term's and the shadows'; never two of one.
        let get = |name: &str| all.iter().find(|e| e.name == name).unwrap();
        let both = [get("specular:sign"), get("diffuse:no-clamp"), get("shadows:no-offset"), get("output:gamma")];
        let made = combined(&registry, &handout, &both).unwrap();
        let variants: Vec<&str> = made.terms.iter().map(|t| t.variant.as_str()).collect();
        assert_eq!(variants, ["seed", "no-clamp", "sign", "constant", "seed"]);
        assert_eq!(made.shadows.name, "no-offset");
        assert!(
            get("specular:sign").goes_with(get("diffuse:no-clamp"))
                && get("specular:sign").goes_with(get("output:bgr"))
        );
        assert!(!get("specular:sign").goes_with(get("specular:exponent-shine")));
        assert!(!get("output:gamma").goes_with(get("output:bgr")));
        assert!(!get("shadows:no-offset").goes_with(get("shadows:past-light")));
    }
}
