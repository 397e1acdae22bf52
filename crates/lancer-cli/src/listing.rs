//! The text of `lancer terms`: every registered term variant and shadow model.

use std::fmt::Write;

use lancer_shading::{ParamSpec, Registry};

fn params(out: &mut String, params: &[ParamSpec]) {
    for p in params {
        let _ = writeln!(out, "      {} = {}  {}", p.name, p.default, p.doc);
    }
}

/// The listing, grouped by term name; each name's first variant is its default.
pub fn terms(registry: &Registry) -> String {
    let mut out = String::from("Terms (used in `terms = [...]`; the first variant of each is its default):\n");
    for name in registry.term_names() {
        let _ = writeln!(out, "  {name}");
        for (i, spec) in registry.terms().iter().filter(|t| t.name == name).enumerate() {
            let default = if i == 0 { " (default)" } else { "" };
            let _ = writeln!(out, "    variant {}{default}: {}", spec.variant, spec.summary);
            params(&mut out, spec.params);
        }
    }
    out.push_str("\nShadow models (used in `shadows = ...`; `hard` when none is named):\n");
    for spec in registry.shadows() {
        let _ = writeln!(out, "  {}: {}", spec.name, spec.summary);
        params(&mut out, spec.params);
    }
    out
}
