//! `NAME[:VARIANT][:KEY=VALUE]...`: one way to name a term or shadow model with its variant and
//! parameters, in scene files (`terms = ["specular:blinn:exponent=64"]`) and on the command line
//! (`--terms specular:blinn:exponent=64`, `--shadows soft:samples=64`).

use crate::{ParamValue, Params};

/// A term or shadow model named with its variant and parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Choice {
    /// The term's or shadow model's name.
    pub name: String,
    /// The variant, when one is given (right after the name, without `=`).
    pub variant: Option<String>,
    /// The parameters given, in order.
    pub params: Vec<(String, ParamValue)>,
}

impl Choice {
    /// Reads `NAME[:VARIANT][:KEY=VALUE]...`; a value is a number, `true`, `false` or text.
    pub fn parse(text: &str) -> Result<Choice, String> {
        let mut parts = text.split(':').map(str::trim);
        let name = parts.next().unwrap_or_default().to_owned();
        if name.is_empty() {
            return Err(format!("`{text}`: expected NAME[:VARIANT][:KEY=VALUE]..."));
        }
        let (mut variant, mut params) = (None, Vec::new());
        for (i, part) in parts.enumerate() {
            match part.split_once('=') {
                Some((k, v)) if !k.trim().is_empty() => {
                    let v = v.trim();
                    let value = match v {
                        "true" => ParamValue::Bool(true),
                        "false" => ParamValue::Bool(false),
                        _ => match v.parse::<f64>() {
                            Ok(x) if x.is_finite() => ParamValue::Number(x),
                            _ => ParamValue::Text(v.trim_matches('"').to_owned()),
                        },
                    };
                    params.push((k.trim().to_owned(), value));
                }
                None if i == 0 && !part.is_empty() && part.parse::<f64>().is_err() => variant = Some(part.to_owned()),
                _ => {
                    return Err(format!(
                        "`{text}`: after the name come an optional variant, then parameters as KEY=VALUE \
                         (e.g. soft:samples=64, specular:blinn:exponent=64); `lancer terms` lists them"
                    ));
                }
            }
        }
        Ok(Choice { name, variant, params })
    }

    /// These parameters over `base`'s (kept from an earlier choice of the same thing).
    pub fn over(&self, base: &[(String, ParamValue)]) -> Params {
        let mut all: Vec<(String, ParamValue)> =
            base.iter().filter(|(k, _)| !self.params.iter().any(|(p, _)| p == k)).cloned().collect();
        all.extend(self.params.iter().cloned());
        Params::new(all)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_variants_and_parameters() {
        let c = Choice::parse("specular:blinn:exponent=64").unwrap();
        assert_eq!((c.name.as_str(), c.variant.as_deref()), ("specular", Some("blinn")));
        assert_eq!(c.params, [("exponent".to_owned(), ParamValue::Number(64.0))]);
        let c = Choice::parse("soft:samples=16:tint=true").unwrap();
        assert_eq!(c.variant, None);
        assert_eq!(c.params[1], ("tint".to_owned(), ParamValue::Bool(true)));
        assert_eq!(Choice::parse(" ambient ").unwrap().name, "ambient");
        for bad in ["", "soft:64", "specular:", "specular:blinn:phong", "soft:=3"] {
            assert!(Choice::parse(bad).is_err(), "{bad}");
        }
    }
}
