//! The text of `lancer terms`: every registered term with its variants, parameters and defaults,
//! and every shadow model.

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
    let _ = writeln!(out, "Every term also takes `{} = {}`: {}.\n", WEIGHT.name, WEIGHT.default, WEIGHT.doc);
    for name in registry.term_names() {
        let _ = writeln!(out, "{name}");
        for (i, spec) in registry.terms().iter().filter(|t| t.name == name).enumerate() {
            let default = if i == 0 { " (default)" } else { "" };
            let _ = writeln!(out, "    {}{default}: {}", spec.variant, spec.summary);
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

#[cfg(test)]
mod tests {
    #[test]
    fn listing_of_the_built_ins() {
        insta::assert_snapshot!(super::terms(&lancer_shading::Registry::with_builtins()));
    }
}
