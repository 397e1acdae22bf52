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
    /// The material fields its formula reads, of [`MATERIAL_FIELDS`] (`lancer terms` shows them:
    /// which numbers of a material change this term's image).
    pub reads: &'static [&'static str],
    /// The parameters it reads, for `lancer terms` and "did you mean" hints.
    pub params: &'static [ParamSpec],
    /// Builds the term from its parameters (reading each it knows).
    pub build: fn(&mut Params) -> Result<Box<dyn Term>, ParamError>,
    /// `Some` for a classic mistake of the course ([`Mistake`]) rather than a model: it renders
    /// like any variant but is left out of [`Registry::terms`] (the `lancer terms` listing, the
    /// studio's menus) and listed by [`Registry::mistakes`] instead.
    pub mistake: Option<Mistake>,
}

/// A classic mistake of the course, registered as a term variant or a shadow model so that a
/// teacher can render it (`--terms specular:sign`, `--shadows no-offset`) and `lancer diagnose`
/// can recognise it in a student's image. Its spec's `summary` says what it is, in one line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mistake {
    /// The variant (or shadow model) it is a mistake of: `phong` for `specular:sign`, `hard` for
    /// `shadows:no-offset`. `lancer diagnose` tries it only where the model uses that one.
    pub of: &'static str,
    /// What to check in the code, in the course's words: `lancer diagnose`'s hint.
    pub hint: &'static str,
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
    /// `Some` for a classic mistake of the course ([`Mistake`]): left out of
    /// [`Registry::shadows`], listed by [`Registry::shadow_mistakes`].
    pub mistake: Option<Mistake>,
}

/// The fields of a material, as a scene file names them: what a term can read
/// ([`TermSpec::reads`]).
pub const MATERIAL_FIELDS: [&str; 7] = ["ambi", "diff", "spec", "shine", "alpha", "n", "color"];

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
    /// A term that says it reads something a material does not have.
    #[error(
        "term `{name}` variant `{variant}` reads `{field}`, which is not a material field; the fields: {}",
        MATERIAL_FIELDS.join(", ")
    )]
    UnknownField {
        /// Term name.
        name: String,
        /// Variant name.
        variant: String,
        /// The field it names.
        field: String,
    },
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
    #[error("{}{}", no_param(owner, param, nearest, known), elsewhere_hint(owner, param, elsewhere))]
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
    /// The material fields it reads ([`TermSpec::reads`]).
    pub reads: &'static [&'static str],
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
    /// The term variants that are classic mistakes (found by name like the others).
    mistakes: Vec<TermSpec>,
    /// The shadow models that are classic mistakes.
    shadow_mistakes: Vec<ShadowSpec>,
}

impl Default for Registry {
    fn default() -> Self {
        Registry::with_builtins()
    }
}

/// "`specular` has no parameter `exponant` (did you mean ...?); its parameters: ...".
fn no_param(owner: &str, param: &str, nearest: &Option<String>, known: &[String]) -> String {
    let known = if known.is_empty() { "none".to_owned() } else { known.join(", ") };
    format!("`{owner}` has no parameter `{param}`{}; its parameters: {known}", hint(nearest))
}

impl ModelError {
    /// This error as a command-line flag (`--terms`) says it, `entry` being the flag's entry in
    /// error (`diffuse:lambert:roughness=3`): a hint about the variant that takes the parameter
    /// is written in the flag's syntax (`diffuse:oren-nayar:roughness=3`), not a scene file's.
    pub fn in_flag_syntax(&self, entry: &str) -> String {
        match self {
            ModelError::UnknownParam { owner, param, nearest, known, elsewhere } if !elsewhere.is_empty() => {
                // The entry with the variant that takes the parameter, put in place of the one
                // given (or after the name when none was).
                let mut parts: Vec<&str> = entry.split(':').collect();
                if parts.get(1).is_some_and(|p| !p.contains('=')) {
                    parts.remove(1);
                }
                parts.insert(1.min(parts.len()), &elsewhere[0]);
                let takes = match elsewhere.as_slice() {
                    [one] => format!("variant {one} of `{owner}` takes"),
                    many => format!("variants {} of `{owner}` take", many.join(", ")),
                };
                format!("{}; {takes} `{param}`: {}", no_param(owner, param, nearest, known), parts.join(":"))
            }
            other => other.to_string(),
        }
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
        let (mistakes, terms) = crate::terms::BUILTIN.iter().partition(|t| t.mistake.is_some());
        let (shadow_mistakes, shadows) = crate::shadows::BUILTIN.iter().partition(|s| s.mistake.is_some());
        Registry { terms, shadows, mistakes, shadow_mistakes }
    }

    /// Adds a term variant (a classic mistake when its `mistake` is set). Errors if that name
    /// and variant are already there.
    pub fn register_term(&mut self, spec: TermSpec) -> Result<(), RegistryError> {
        for name in [spec.name, spec.variant] {
            if !is_name(name) {
                return Err(RegistryError::BadName(name.into()));
            }
        }
        if RESERVED.contains(&spec.name) {
            return Err(RegistryError::BadName(spec.name.into()));
        }
        if let Some(field) = spec.reads.iter().find(|f| !MATERIAL_FIELDS.contains(f)) {
            return Err(RegistryError::UnknownField {
                name: spec.name.into(),
                variant: spec.variant.into(),
                field: (*field).into(),
            });
        }
        if self.terms.iter().chain(&self.mistakes).any(|t| t.name == spec.name && t.variant == spec.variant) {
            return Err(RegistryError::DuplicateTerm { name: spec.name.into(), variant: spec.variant.into() });
        }
        match spec.mistake {
            Some(_) => self.mistakes.push(spec),
            None => self.terms.push(spec),
        }
        Ok(())
    }

    /// Adds a shadow model (a classic mistake when its `mistake` is set). Errors if the name is
    /// already there.
    pub fn register_shadow(&mut self, spec: ShadowSpec) -> Result<(), RegistryError> {
        if !is_name(spec.name) {
            return Err(RegistryError::BadName(spec.name.into()));
        }
        if self.shadows.iter().chain(&self.shadow_mistakes).any(|s| s.name == spec.name) {
            return Err(RegistryError::DuplicateShadow(spec.name.into()));
        }
        match spec.mistake {
            Some(_) => self.shadow_mistakes.push(spec),
            None => self.shadows.push(spec),
        }
        Ok(())
    }

    /// Every registered term variant, built-ins first, in registration order; classic mistakes
    /// are left out ([`Registry::mistakes`]).
    pub fn terms(&self) -> &[TermSpec] {
        &self.terms
    }

    /// Every registered shadow model but the classic mistakes ([`Registry::shadow_mistakes`]).
    pub fn shadows(&self) -> &[ShadowSpec] {
        &self.shadows
    }

    /// The term variants that are classic mistakes of the course, in registration order.
    pub fn mistakes(&self) -> &[TermSpec] {
        &self.mistakes
    }

    /// The shadow models that are classic mistakes of the course, in registration order.
    pub fn shadow_mistakes(&self) -> &[ShadowSpec] {
        &self.shadow_mistakes
    }

    /// The distinct term names, in registration order (of the variants that are not mistakes).
    pub fn term_names(&self) -> Vec<&'static str> {
        let mut names: Vec<&'static str> = Vec::new();
        for t in &self.terms {
            if !names.contains(&t.name) {
                names.push(t.name);
            }
        }
        names
    }

    /// Builds term `name` (its default variant unless `variant` is given) from `params`. A
    /// classic mistake ([`Registry::mistakes`]) is named like any variant; the errors list only
    /// the variants that are not mistakes.
    pub fn build_term(&self, name: &str, variant: Option<&str>, mut params: Params) -> Result<NamedTerm, ModelError> {
        let variants: Vec<&TermSpec> = self.terms.iter().filter(|t| t.name == name).collect();
        let mistakes = self.mistakes.iter().filter(|t| t.name == name);
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
            Some(v) => variants.iter().copied().chain(mistakes.clone()).find(|t| t.variant == v).ok_or_else(|| {
                ModelError::UnknownVariant {
                    term: name.to_owned(),
                    variant: v.to_owned(),
                    nearest: nearest(v, variants.iter().map(|t| t.variant))
                        .or_else(|| nearest(v, mistakes.clone().map(|t| t.variant))),
                    known: variants.iter().map(|t| t.variant.to_owned()).collect(),
                }
            })?,
        };
        let given = params.given().map(|(k, v)| (k.to_owned(), v.clone())).collect();
        let bad = |error| ModelError::BadParam { owner: name.to_owned(), error };
        let weight = params.number(WEIGHT.name, 1.0, 0.0, f32::MAX as f64).map_err(bad)? as f32;
        let term = (spec.build)(&mut params).map_err(bad)?;
        let known: Vec<ParamSpec> = spec.params.iter().copied().chain([WEIGHT]).collect();
        let others: Vec<TermSpec> = variants.iter().filter(|t| t.variant != spec.variant).map(|t| **t).collect();
        unused_param(name, &params, &known, &others)?;
        Ok(NamedTerm {
            name: name.to_owned(),
            variant: spec.variant.to_owned(),
            reads: spec.reads,
            weight,
            params: given,
            term,
        })
    }

    /// Builds shadow model `name` (a classic mistake too) from `params`.
    pub fn build_shadow(&self, name: &str, mut params: Params) -> Result<NamedShadow, ModelError> {
        let Some(spec) = self.shadows.iter().chain(&self.shadow_mistakes).find(|s| s.name == name) else {
            return Err(ModelError::UnknownShadow {
                name: name.to_owned(),
                nearest: nearest(name, self.shadows.iter().map(|s| s.name))
                    .or_else(|| nearest(name, self.shadow_mistakes.iter().map(|s| s.name))),
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
        assert_eq!(
            e.to_string(),
            "`transmissive` has no parameter `tnt` (did you mean `tint`?); its parameters: tint, each_surface"
        );
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
    fn mistakes_are_listed_apart_and_built_like_any_variant() {
        let r = Registry::with_builtins();
        assert!(r.terms().iter().all(|t| t.mistake.is_none()) && r.shadows().iter().all(|s| s.mistake.is_none()));
        let names: Vec<String> = r.mistakes().iter().map(|t| format!("{}:{}", t.name, t.variant)).collect();
        assert_eq!(
            names,
            [
                "specular:exponent-shine",
                "specular:sign",
                "diffuse:no-clamp",
                "mirror:sign",
                "refraction:sign-trap",
                "refraction:inverted-index",
                "refraction:no-exit-bend"
            ]
        );
        let shadows: Vec<&str> = r.shadow_mistakes().iter().map(|s| s.name).collect();
        assert_eq!(shadows, ["no-offset", "past-light"]);
        // Each is a mistake of a real variant of its name (or of a real shadow model).
        for t in r.mistakes() {
            let of = t.mistake.unwrap().of;
            assert!(r.terms().iter().any(|v| v.name == t.name && v.variant == of), "{}:{} of {of}", t.name, t.variant);
        }
        for s in r.shadow_mistakes() {
            assert!(r.shadows().iter().any(|v| v.name == s.mistake.unwrap().of), "{}", s.name);
        }
        let p = Params::new([("weight".to_owned(), ParamValue::Number(0.5))]);
        let t = r.build_term("specular", Some("sign"), p).unwrap();
        assert_eq!((t.variant.as_str(), t.weight), ("sign", 0.5));
        assert_eq!(r.build_shadow("no-offset", Params::default()).unwrap().name, "no-offset");
        // The defaults are the handout's, and errors list the real variants (a near miss of a
        // mistake's name is still suggested).
        assert_eq!(r.build_term("specular", None, Params::default()).unwrap().variant, "phong");
        let e = r.build_term("specular", Some("sing"), Params::default()).err().unwrap().to_string();
        assert_eq!(
            e,
            "term `specular` has no variant `sing` (did you mean `sign`?); its variants: phong, blinn, blinn-normalized"
        );
        let e = r.build_shadow("past-lihgt", Params::default()).err().unwrap().to_string();
        assert!(e.contains("did you mean `past-light`") && e.ends_with("none, hard, transmissive, soft"), "{e}");
        // A plugin's mistake goes with the mistakes, and clashes with a variant of its name.
        let mut reg = Registry::with_builtins();
        let rim = TermSpec {
            name: "ambient",
            variant: "doubled",
            mistake: Some(Mistake { of: "seed", hint: "h" }),
            ..r.terms()[0]
        };
        reg.register_term(rim).unwrap();
        assert_eq!(reg.terms().len(), r.terms().len());
        assert_eq!(reg.mistakes().len(), r.mistakes().len() + 1);
        assert!(reg.register_term(TermSpec { mistake: None, ..rim }).is_err());
        assert!(reg.register_term(crate::terms::mirror::sign::SPEC).is_err());
    }

    #[test]
    fn every_term_says_which_material_fields_it_reads_and_only_real_ones() {
        for t in crate::terms::BUILTIN {
            assert!(!t.reads.is_empty(), "{}:{} reads nothing", t.name, t.variant);
        }
        let mut r = Registry::with_builtins();
        let typo = TermSpec { name: "rim", variant: "plain", reads: &["colour"], ..crate::terms::ambient::SPEC };
        let e = r.register_term(typo).unwrap_err().to_string();
        assert!(e.contains("reads `colour`, which is not a material field"), "{e}");
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
