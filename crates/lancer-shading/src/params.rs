//! Typed parameters of terms and shadow models, with a check that every given one was used.

/// A parameter value as the model file gave it.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    /// A finite number (integers are accepted where floats are expected).
    Number(f64),
    /// A boolean.
    Bool(bool),
    /// A string.
    Text(String),
}

impl std::fmt::Display for ParamValue {
    /// As TOML writes it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamValue::Number(x) => write!(f, "{x}"),
            ParamValue::Bool(b) => write!(f, "{b}"),
            ParamValue::Text(t) => write!(f, "{t:?}"),
        }
    }
}

impl ParamValue {
    fn kind(&self) -> &'static str {
        match self {
            ParamValue::Number(_) => "a number",
            ParamValue::Bool(_) => "a boolean",
            ParamValue::Text(_) => "a string",
        }
    }
}

/// Documentation of one parameter, for `lancer terms` and error messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamSpec {
    /// The key in the model file.
    pub name: &'static str,
    /// The default, as it would be written in TOML.
    pub default: &'static str,
    /// One line saying what it does.
    pub doc: &'static str,
}

/// A parameter that could not be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("parameter `{param}`: {message}")]
pub struct ParamError {
    /// The parameter's key.
    pub param: String,
    /// What was wrong, e.g. "expected a number in [0, 1], found 3".
    pub message: String,
}

/// The parameters given to one term or shadow model. Builders read them by name; whatever is
/// left unread afterwards is an unknown parameter.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Params {
    values: Vec<(String, ParamValue, bool)>,
}

impl Params {
    /// Parameters from `(key, value)` pairs.
    pub fn new(values: impl IntoIterator<Item = (String, ParamValue)>) -> Params {
        Params { values: values.into_iter().map(|(k, v)| (k, v, false)).collect() }
    }

    /// The parameters given, in order.
    pub fn given(&self) -> impl Iterator<Item = (&str, &ParamValue)> {
        self.values.iter().map(|(k, v, _)| (k.as_str(), v))
    }

    fn take(&mut self, name: &str) -> Option<ParamValue> {
        self.values.iter_mut().find(|(k, _, _)| k == name).map(|(_, v, used)| {
            *used = true;
            v.clone()
        })
    }

    fn wrong(name: &str, expected: &str, found: &ParamValue) -> ParamError {
        ParamError { param: name.to_owned(), message: format!("expected {expected}, found {}", found.kind()) }
    }

    /// A number in `[lo, hi]`, or `default` when absent.
    pub fn number(&mut self, name: &str, default: f64, lo: f64, hi: f64) -> Result<f64, ParamError> {
        match self.take(name) {
            None => Ok(default),
            Some(ParamValue::Number(x)) if (lo..=hi).contains(&x) => Ok(x),
            Some(ParamValue::Number(x)) => Err(ParamError {
                param: name.to_owned(),
                // An open end (the largest float) is not worth printing in full.
                message: if hi >= f32::MAX as f64 {
                    format!("expected a number of at least {lo}, found {x}")
                } else {
                    format!("expected a number in [{lo}, {hi}], found {x}")
                },
            }),
            Some(v) => Err(Self::wrong(name, "a number", &v)),
        }
    }

    /// A boolean, or `default` when absent.
    pub fn boolean(&mut self, name: &str, default: bool) -> Result<bool, ParamError> {
        match self.take(name) {
            None => Ok(default),
            Some(ParamValue::Bool(b)) => Ok(b),
            Some(v) => Err(Self::wrong(name, "a boolean", &v)),
        }
    }

    /// Keys given but never read.
    pub fn unused(&self) -> impl Iterator<Item = &str> {
        self.values.iter().filter(|(_, _, used)| !used).map(|(k, _, _)| k.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_defaults_ranges_and_reports_unused() {
        let mut p = Params::new([
            ("weight".to_owned(), ParamValue::Number(0.5)),
            ("tint".to_owned(), ParamValue::Bool(true)),
            ("stray".to_owned(), ParamValue::Number(1.0)),
        ]);
        assert_eq!(p.number("weight", 1.0, 0.0, 1.0), Ok(0.5));
        assert_eq!(p.number("absent", 2.0, 0.0, 5.0), Ok(2.0));
        assert_eq!(p.boolean("tint", false), Ok(true));
        assert_eq!(p.unused().collect::<Vec<_>>(), ["stray"]);
        let mut p = Params::new([("weight".to_owned(), ParamValue::Number(3.0))]);
        assert!(p.number("weight", 1.0, 0.0, 1.0).unwrap_err().message.contains("[0, 1]"));
        let mut p = Params::new([("tint".to_owned(), ParamValue::Text("yes".into()))]);
        assert_eq!(p.boolean("tint", false).unwrap_err().message, "expected a boolean, found a string");
    }
}
