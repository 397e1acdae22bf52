//! The text of `lancer terms`: every registered term with its variants, parameters and defaults,
//! and every shadow model; with `--mistakes`, the catalogue of classic mistakes instead.

use std::fmt::Write;

use lancer_shading::{ParamSpec, Registry, WEIGHT};

fn params(out: &mut String, params: &[ParamSpec]) {
    for p in params {
        let _ = writeln!(out, "        {} = {}: {}", p.name, p.default, p.doc);
    }
}

/// The listing, grouped by term name in registration order; each name's first variant is its
/// default.
pub fn terms(registry: &Registry) -> String {
    let mut out = String::from("Terms, for `terms = [...]` in [model] or a model file. A term is a name, or a table\n");
    out.push_str("{ term = \"NAME\", variant = \"VARIANT\", PARAM = VALUE, ... }; the first variant is the default.\n");
    let _ = writeln!(out, "Every term also takes `{} = {}`: {}.", WEIGHT.name, WEIGHT.default, WEIGHT.doc);
    let _ = writeln!(
        out,
        "`reads:` names the material fields ({}) a variant's formula uses.\n",
        lancer_shading::MATERIAL_FIELDS.join(" ")
    );
    for name in registry.term_names() {
        let _ = writeln!(out, "{name}");
        for (i, spec) in registry.terms().iter().filter(|t| t.name == name).enumerate() {
            let default = if i == 0 { " (default)" } else { "" };
            let _ = writeln!(out, "    {}{default}: {}", spec.variant, spec.summary);
            // Which numbers of a material change this term's image.
            let _ = writeln!(out, "        reads: {}", spec.reads.join(", "));
            params(&mut out, spec.params);
        }
    }
    out.push_str("\nShadow models, for `shadows = \"NAME\"` or `shadows = { model = \"NAME\", PARAM = VALUE }`;\n");
    out.push_str("`hard` when none is named.\n");
    for spec in registry.shadows() {
        let _ = writeln!(out, "    {}: {}", spec.name, spec.summary);
        params(&mut out, spec.params);
    }
    out
}

/// `lancer terms`'s flags.
#[derive(clap::Args)]
pub(crate) struct TermsArgs {
    /// List the catalogue of classic mistakes instead: each renders like a variant, to show it,
    /// and `lancer diagnose` tells which one explains a student's image.
    #[arg(long)]
    pub(crate) mistakes: bool,
}

/// The text of `lancer terms --mistakes`: every classic mistake of the registry (mistaken term
/// variants and shadow models) and of the image writer, a line each, and how to render it.
pub fn mistakes(registry: &Registry) -> String {
    let mut out = String::from(
        "Classic mistakes of the course, each rendered like any variant to show what it looks like:
",
    );
    out.push_str(
        "terms with --terms or [model] (e.g. --terms ambient,diffuse,specular:sign), shadows with
",
    );
    out.push_str(
        "--shadows (e.g. --shadows no-offset), output with `lancer render --output-mistake NAME`.
",
    );
    out.push_str(
        "`lancer diagnose SCENE --image IMAGE` tells which of them explains a student's image.

",
    );
    let entries = crate::diagnose::catalogue::entries(registry);
    let width = entries.iter().map(|e| e.name.len()).max().unwrap_or(0);
    for e in &entries {
        let _ = writeln!(out, "  {:<width$}  {}", e.name, e.summary);
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn listing_of_the_built_ins() {
        insta::assert_snapshot!(super::terms(&lancer_shading::Registry::with_builtins()));
    }

    #[test]
    fn regression_lancer_terms_did_not_say_which_material_fields_a_term_reads() {
        let listing = super::terms(&lancer_shading::Registry::with_builtins());
        let after = |variant: &str| {
            let at = listing.find(&format!("\n    {variant}")).unwrap_or_else(|| panic!("{variant}: {listing}"));
            listing[at..].lines().nth(2).unwrap().trim().to_owned()
        };
        assert_eq!(after("phong (default)"), "reads: spec, shine");
        assert_eq!(after("lambert (default)"), "reads: diff, color");
        assert_eq!(after("fresnel"), "reads: alpha, n, color");
        assert_eq!(after("schlick"), "reads: spec, n");
    }

    #[test]
    fn the_mistakes_are_listed_apart_one_line_each() {
        let registry = lancer_shading::Registry::with_builtins();
        let normal = super::terms(&registry);
        let mistakes = super::mistakes(&registry);
        for name in
            ["exponent-shine", "no-clamp", "sign-trap", "inverted-index", "no-exit-bend", "no-offset", "past-light"]
        {
            assert!(!normal.contains(name), "`lancer terms` lists the mistake {name}");
        }
        let lines: Vec<&str> = mistakes.lines().filter(|l| l.starts_with("  ")).collect();
        assert_eq!(lines.len(), 12, "{mistakes}");
        for (line, name) in lines.iter().zip([
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
        ]) {
            assert!(line.trim_start().starts_with(&format!("{name} ")), "{line}");
            assert!(line.len() > name.len() + 30, "a description for {name}: {line}");
        }
    }
}
