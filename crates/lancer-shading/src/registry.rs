//! The registry: terms and shadow models found by name, and the pipeline a model builds from it.

use crate::{ParamError, ParamSpec, ParamValue, Params, ShadowModel, Term};

/// How to build one term variant. A user crate fills one in and calls
/// [`Registry::register_term`].
#[derive(Clone, Copy)]
pub struct TermSpec {
    /// The term's name: its image's name and its key in `terms = [...]`.
    pub name: &'static str,
    /// The variant's name; the first variant registered under a name is its default.
    pub variant: &'static str,
    /// One line for `lancer terms`.
    pub summary: &'static str,
    /// The parameters it reads, for `lancer terms` and "did you mean" hints.
    pub params: &'static [ParamSpec],
    /// Builds the term from its parameters (reading each it knows).
    pub build: fn(&mut Params) -> Result<Box<dyn Term>, ParamError>,
}

/// How to build one shadow model.
#[derive(Clone, Copy)]
pub struct ShadowSpec {
    /// The name used in `shadows = "..."`.
    pub name: &'static str,
    /// One line for `lancer terms`.
    pub summary: &'static str,
    /// The parameters it reads.
    pub params: &'static [ParamSpec],
    /// Builds the model from its parameters.
    pub build: fn(&mut Params) -> Result<Box<dyn ShadowModel>, ParamError>,
}

/// A registration that clashes with one already there.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RegistryError {
    /// The same term name and variant twice.
    #[error("term `{name}` variant `{variant}` is already registered")]
    DuplicateTerm {
        /// Term name.
        name: String,
        /// Variant name.
        variant: String,
    },
    /// The same shadow model name twice.
    #[error("shadow model `{0}` is already registered")]
    DuplicateShadow(String),
    /// A name outside the grammar of [`is_name`], or one kept for Lancer's own files.
    #[error(
        "`{0}` cannot name a term, variant or shadow model: a name is a lowercase letter, then up to {max} lowercase letters, digits, `-` or `_`, and not `beauty`, `background` or `manifest`",
        max = NAME_MAX - 1
    )]
    BadName(String),
}

/// The longest name a term, variant or shadow model may have.
pub const NAME_MAX: usize = 32;

/// Names a term may not take: its image would take the place of one of Lancer's own files
/// (`beauty.exr`, `background.exr`, `manifest.json` in an `--aov` folder).
pub const RESERVED: [&str; 3] = ["beauty", "background", "manifest"];

/// Whether `s` is in the grammar of term, variant and shadow-model names: a lowercase ASCII letter,
/// then lowercase letters, digits, `-` and `_`, at most [`NAME_MAX`] bytes. A term's name is its
/// image's file name, so the grammar leaves out every path separator, dot and control character.
pub fn is_name(s: &str) -> bool {
    let mut bytes = s.bytes();
    s.len() <= NAME_MAX
        && bytes.next().is_some_and(|b| b.is_ascii_lowercase())
        && bytes.all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'_')
}

/// Whether `s` can name a term (and so a per-term image): [`is_name`] and not [`RESERVED`].
pub fn is_term_name(s: &str) -> bool {
    is_name(s) && !RESERVED.contains(&s)
}

/// A model that names something the registry does not have, or gives it bad parameters.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ModelError {
    /// No term of that name.
    #[error("unknown term `{name}`{}; known terms: {}", hint(nearest), known.join(", "))]
    UnknownTerm {
        /// What the model said.
        name: String,
        /// The closest known name, if any is close.
        nearest: Option<String>,
        /// Every known term.
        known: Vec<String>,
    },
    /// The term exists but not that variant.
    #[error("term `{term}` has no variant `{variant}`{}; its variants: {}", hint(nearest), known.join(", "))]
    UnknownVariant {
        /// The term.
        term: String,
        /// What the model said.
        variant: String,
        /// The closest variant name.
        nearest: Option<String>,
        /// The term's variants.
        known: Vec<String>,
    },
    /// No shadow model of that name.
    #[error("unknown shadow model `{name}`{}; known shadow models: {}", hint(nearest), known.join(", "))]
    UnknownShadow {
        /// What the model said.
        name: String,
        /// The closest known name.
        nearest: Option<String>,
        /// Every known shadow model.
        known: Vec<String>,
    },
    /// A parameter the term or shadow model does not read.
    #[error(
        "`{owner}` has no parameter `{param}`{}; its parameters: {}{}",
        hint(nearest),
        if known.is_empty() { "none".to_owned() } else { known.join(", ") },
        elsewhere_hint(owner, param, elsewhere)
    )]
    UnknownParam {
        /// The term or shadow model.
        owner: String,
        /// The parameter given.
        param: String,
        /// The closest parameter name.
        nearest: Option<String>,
        /// The parameters it has.
        known: Vec<String>,
        /// Other variants of the same term that do take the parameter.
        elsewhere: Vec<String>,
    },
    /// A parameter of the wrong type or range.
    #[error("`{owner}`: {error}")]
    BadParam {
        /// The term or shadow model.
        owner: String,
        /// What was wrong.
        error: ParamError,
    },
    /// The same term twice: their images would share a name.
    #[error("term `{0}` appears twice in the model; each term has one image, so list it once")]
    DuplicateTerm(String),
}

fn hint(nearest: &Option<String>) -> String {
    nearest.as_ref().map(|n| format!(" (did you mean `{n}`?)")).unwrap_or_default()
}

/// The known name closest to `name`, if it is close enough to be a likely typo.
pub fn nearest<'a>(name: &str, known: impl IntoIterator<Item = &'a str>) -> Option<String> {
    known
        .into_iter()
        .map(|k| (strsim::damerau_levenshtein(name, k), k))
        .filter(|&(d, k)| d <= 2.max(k.len() / 3) && d < k.len().max(name.len()))
        .min_by_key(|&(d, _)| d)
        .map(|(_, k)| k.to_owned())
}

/// The parameter every term takes: a factor on everything the term adds (and on the rays it
/// spawns), so `weight = 0.5` halves the term's image.
pub const WEIGHT: ParamSpec =
    ParamSpec { name: "weight", default: "1", doc: "scales everything this term contributes (every term has it)" };

/// A built term with the names it was built from.
pub struct NamedTerm {
    /// The term's name (its image's name).
    pub name: String,
    /// The variant used.
    pub variant: String,
    /// The `weight` parameter: a factor on the term's whole contribution.
    pub weight: f32,
    /// The parameters it was built with (as given; the others have their defaults).
    pub params: Vec<(String, ParamValue)>,
    /// The system.
    pub term: Box<dyn Term>,
}

/// A built shadow model with its name.
pub struct NamedShadow {
    /// Its name.
    pub name: String,
    /// The parameters it was built with (as given; the others have their defaults).
    pub params: Vec<(String, ParamValue)>,
    /// The model.
    pub model: Box<dyn ShadowModel>,
}

/// A lighting model ready to render: the ordered term systems, the shadow model, the depth limit.
pub struct Pipeline {
    /// Recursion limit for child rays (the handout's `rec`).
    pub max_depth: u8,
    /// How light visibility is computed.
    pub shadows: NamedShadow,
    /// The terms, in summation order.
    pub terms: Vec<NamedTerm>,
}

impl Pipeline {
    /// Checks that no term appears twice.
    pub fn new(max_depth: u8, shadows: NamedShadow, terms: Vec<NamedTerm>) -> Result<Pipeline, ModelError> {
        for (i, t) in terms.iter().enumerate() {
            if terms[..i].iter().any(|u| u.name == t.name) {
                return Err(ModelError::DuplicateTerm(t.name.clone()));
            }
        }
        Ok(Pipeline { max_depth, shadows, terms })
    }
}

/// Every term and shadow model that models can name.
#[derive(Clone)]
pub struct Registry {
    terms: Vec<TermSpec>,
    shadows: Vec<ShadowSpec>,
}

impl Default for Registry {
    fn default() -> Self {
        Registry::with_builtins()
    }
}

/// "; variant blinn of `specular` takes `exponent` (...)" when other variants take the parameter.
fn elsewhere_hint(owner: &str, param: &str, elsewhere: &[String]) -> String {
    match elsewhere {
        [] => String::new(),
        [one] => format!(
            "; variant {one} of `{owner}` takes `{param}`: {{ term = \"{owner}\", variant = \"{one}\", {param} = ... }}"
        ),
        many => format!(
            "; variants {} of `{owner}` take `{param}`: {{ term = \"{owner}\", variant = \"{}\", {param} = ... }}",
            many.join(", "),
            many[0]
        ),
    }
}

fn unused_param(owner: &str, params: &Params, specs: &[ParamSpec], others: &[TermSpec]) -> Result<(), ModelError> {
    match params.unused().next() {
        None => Ok(()),
        Some(p) => Err(ModelError::UnknownParam {
            owner: owner.to_owned(),
            param: p.to_owned(),
            nearest: nearest(p, specs.iter().map(|s| s.name)),
            known: specs.iter().map(|s| s.name.to_owned()).collect(),
            elsewhere: others
                .iter()
                .filter(|t| t.params.iter().any(|s| s.name == p))
                .map(|t| t.variant.to_owned())
                .collect(),
        }),
    }
}

impl Registry {
    /// The built-in terms and shadow models.
    pub fn with_builtins() -> Registry {
        Registry { terms: crate::terms::BUILTIN.to_vec(), shadows: crate::shadows::BUILTIN.to_vec() }
    }

    /// Adds a term variant. Errors if that name and variant are already there.
    pub fn register_term(&mut self, spec: TermSpec) -> Result<(), RegistryError> {
        for name in [spec.name, spec.variant] {
            if !is_name(name) {
                return Err(RegistryError::BadName(name.into()));
            }
        }
        if RESERVED.contains(&spec.name) {
            return Err(RegistryError::BadName(spec.name.into()));
        }
        if self.terms.iter().any(|t| t.name == spec.name && t.variant == spec.variant) {
            return Err(RegistryError::DuplicateTerm { name: spec.name.into(), variant: spec.variant.into() });
        }
        self.terms.push(spec);
        Ok(())
    }

    /// Adds a shadow model. Errors if the name is already there.
    pub fn register_shadow(&mut self, spec: ShadowSpec) -> Result<(), RegistryError> {
        if !is_name(spec.name) {
            return Err(RegistryError::BadName(spec.name.into()));
        }
        if self.shadows.iter().any(|s| s.name == spec.name) {
            return Err(RegistryError::DuplicateShadow(spec.name.into()));
        }
        self.shadows.push(spec);
        Ok(())
    }

    /// Every registered term variant, built-ins first, in registration order.
    pub fn terms(&self) -> &[TermSpec] {
        &self.terms
    }

    /// Every registered shadow model.
    pub fn shadows(&self) -> &[ShadowSpec] {
        &self.shadows
    }

    /// The distinct term names, in registration order.
    pub fn term_names(&self) -> Vec<&'static str> {
        let mut names: Vec<&'static str> = Vec::new();
        for t in &self.terms {
            if !names.contains(&t.name) {
                names.push(t.name);
            }
        }
        names
    }

    /// Builds term `name` (its default variant unless `variant` is given) from `params`.
    pub fn build_term(&self, name: &str, variant: Option<&str>, mut params: Params) -> Result<NamedTerm, ModelError> {
        let variants: Vec<&TermSpec> = self.terms.iter().filter(|t| t.name == name).collect();
        let Some(&first) = variants.first() else {
            let known = self.term_names();
            return Err(ModelError::UnknownTerm {
                name: name.to_owned(),
                nearest: nearest(name, known.iter().copied()),
                known: known.iter().map(|s| s.to_string()).collect(),
            });
        };
        let spec = match variant {
            None => first,
            Some(v) => *variants.iter().find(|t| t.variant == v).ok_or_else(|| ModelError::UnknownVariant {
                term: name.to_owned(),
                variant: v.to_owned(),
                nearest: nearest(v, variants.iter().map(|t| t.variant)),
                known: variants.iter().map(|t| t.variant.to_owned()).collect(),
            })?,
        };
        let given = params.given().map(|(k, v)| (k.to_owned(), v.clone())).collect();
        let bad = |error| ModelError::BadParam { owner: name.to_owned(), error };
        let weight = params.number(WEIGHT.name, 1.0, 0.0, f32::MAX as f64).map_err(bad)? as f32;
        let term = (spec.build)(&mut params).map_err(bad)?;
        let known: Vec<ParamSpec> = spec.params.iter().copied().chain([WEIGHT]).collect();
        let others: Vec<TermSpec> = variants.iter().filter(|t| t.variant != spec.variant).map(|t| **t).collect();
        unused_param(name, &params, &known, &others)?;
        Ok(NamedTerm { name: name.to_owned(), variant: spec.variant.to_owned(), weight, params: given, term })
    }

    /// Builds shadow model `name` from `params`.
    pub fn build_shadow(&self, name: &str, mut params: Params) -> Result<NamedShadow, ModelError> {
        let Some(spec) = self.shadows.iter().find(|s| s.name == name) else {
            return Err(ModelError::UnknownShadow {
                name: name.to_owned(),
                nearest: nearest(name, self.shadows.iter().map(|s| s.name)),
                known: self.shadows.iter().map(|s| s.name.to_owned()).collect(),
            });
        };
        let given = params.given().map(|(k, v)| (k.to_owned(), v.clone())).collect();
        let model =
            (spec.build)(&mut params).map_err(|error| ModelError::BadParam { owner: name.to_owned(), error })?;
        unused_param(name, &params, spec.params, &[])?;
        Ok(NamedShadow { name: name.to_owned(), params: given, model })
    }

    /// Every built-in term, default variant, in the handout's order.
    pub fn default_terms(&self) -> Vec<NamedTerm> {
        let mut names: Vec<&str> = Vec::new();
        for t in crate::terms::BUILTIN {
            if !names.contains(&t.name) {
                names.push(t.name);
            }
        }
        names
            .into_iter()
            .map(|name| {
                self.build_term(name, None, Params::default()).expect("built-in terms build without parameters")
            })
            .collect()
    }

    /// The handout's full model: every built-in term in order, hard shadows, depth 5.
    pub fn default_pipeline(&self) -> Pipeline {
        let shadows =
            self.build_shadow(crate::shadows::DEFAULT, Params::default()).expect("the default shadow model exists");
        Pipeline::new(5, shadows, self.default_terms()).expect("built-in term names are distinct")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ParamValue;

    #[test]
    fn names_that_are_paths_or_lancers_own_files_are_refused() {
        let r = Registry::with_builtins();
        for t in r.terms() {
            assert!(is_term_name(t.name) && is_name(t.variant), "{} {}", t.name, t.variant);
        }
        for s in r.shadows() {
            assert!(is_name(s.name), "{}", s.name);
        }
        let base = r.terms()[0];
        for bad in
            ["../escaped", "/abs", "a/b", "a.b", "", "Beauty", "beauty", "manifest", "background", "é", "a\nb", "1st"]
        {
            assert!(!is_term_name(bad), "{bad:?}");
            let mut reg = Registry::with_builtins();
            let e = reg.register_term(TermSpec { name: Box::leak(bad.to_owned().into_boxed_str()), ..base });
            assert!(matches!(e, Err(RegistryError::BadName(_))), "{bad:?}: {e:?}");
        }
        let long = "a".repeat(NAME_MAX + 1);
        assert!(!is_name(&long) && is_name(&long[..NAME_MAX]));
        let mut reg = Registry::with_builtins();
        let e = reg.register_term(TermSpec { name: "rim", variant: "Odd/one", ..base });
        assert!(matches!(e, Err(RegistryError::BadName(_))));
        assert!(reg.register_term(TermSpec { name: "rim", variant: "fresnel-like_2", ..base }).is_ok());
    }

    #[test]
    fn unknown_names_suggest_the_nearest() {
        let r = Registry::with_builtins();
        let e = r.build_term("difuse", None, Params::default()).err().unwrap();
        assert_eq!(
            e.to_string(),
            "unknown term `difuse` (did you mean `diffuse`?); known terms: ambient, diffuse, specular, mirror, refraction"
        );
        let e = r.build_term("zzz", None, Params::default()).err().unwrap();
        assert!(!e.to_string().contains("did you mean"));
        let e = r.build_shadow("transmisive", Params::default()).err().unwrap();
        assert!(e.to_string().contains("did you mean `transmissive`"), "{e}");
        let e = r.build_term("specular", Some("phog"), Params::default()).err().unwrap();
        assert!(e.to_string().contains("did you mean `phong`"), "{e}");
    }

    #[test]
    fn unknown_and_bad_parameters_are_errors() {
        let r = Registry::with_builtins();
        let p = Params::new([("tnt".to_owned(), ParamValue::Bool(true))]);
        let e = r.build_shadow("transmissive", p).err().unwrap();
        assert_eq!(e.to_string(), "`transmissive` has no parameter `tnt` (did you mean `tint`?); its parameters: tint");
        let p = Params::new([("tint".to_owned(), ParamValue::Number(1.0))]);
        let e = r.build_shadow("transmissive", p).err().unwrap();
        assert_eq!(e.to_string(), "`transmissive`: parameter `tint`: expected a boolean, found a number");
        let p = Params::new([("x".to_owned(), ParamValue::Number(1.0))]);
        assert!(r.build_term("ambient", None, p).err().unwrap().to_string().contains("its parameters: weight"));
        let p = Params::new([("wieght".to_owned(), ParamValue::Number(0.5))]);
        assert!(r.build_term("diffuse", None, p).err().unwrap().to_string().contains("did you mean `weight`"));
        let p = Params::new([("weight".to_owned(), ParamValue::Number(0.5))]);
        assert_eq!(r.build_term("diffuse", None, p).unwrap().weight, 0.5);
        let p = Params::new([("weight".to_owned(), ParamValue::Number(-1.0))]);
        assert!(r.build_term("diffuse", None, p).is_err());
    }

    #[test]
    fn duplicates_are_refused() {
        let mut r = Registry::with_builtins();
        assert!(r.register_term(crate::terms::ambient::SPEC).is_err());
        assert!(r.register_shadow(crate::shadows::hard::SPEC).is_err());
        let a = r.build_term("ambient", None, Params::default()).unwrap();
        let b = r.build_term("ambient", None, Params::default()).unwrap();
        let s = r.build_shadow("none", Params::default()).unwrap();
        assert_eq!(Pipeline::new(1, s, vec![a, b]).err().unwrap(), ModelError::DuplicateTerm("ambient".into()));
    }
}
