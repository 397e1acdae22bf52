//! The edited state written into the scene's own TOML text (toml_edit): only the values the
//! studio edits change; comments, order and layout stay.

use toml_edit::{Array, DocumentMut, InlineTable, Item, Table, Value};

use crate::State;

/// `x` as the shortest decimal that reads back as the same `f32` (0.3, not 0.30000001...).
fn num(x: f32) -> Value {
    Value::from(format!("{x}").parse::<f64>().unwrap_or(x as f64))
}

fn triple(c: [f32; 3]) -> Value {
    let mut a = Array::new();
    for x in c {
        a.push(num(x));
    }
    Value::Array(a)
}

/// Sets `key` in a table-like item (a `[table]` or an inline `{ }`), keeping its decoration.
fn set(item: &mut Item, key: &str, v: Value) {
    if let Some(t) = item.as_table_like_mut() {
        match t.get_mut(key) {
            Some(Item::Value(old)) => {
                let decor = old.decor().clone();
                *old = v;
                *old.decor_mut() = decor;
            }
            _ => {
                t.insert(key, Item::Value(v));
            }
        }
    }
}

fn params(table: &mut InlineTable, params: &serde_json::Map<String, serde_json::Value>) {
    for (k, v) in params {
        let v = match v {
            serde_json::Value::Bool(b) => Value::from(*b),
            serde_json::Value::Number(n) => num(n.as_f64().unwrap_or(0.0) as f32),
            serde_json::Value::String(s) => Value::from(s.as_str()),
            _ => continue,
        };
        table.insert(k, v);
    }
}

/// `source` (the scene file's text) with `state`'s values: each material (named, or an object's
/// inline one; which is which comes from `loaded`, the server's own state of the file, never
/// from the page), each light, the model and the samples.
pub(crate) fn edited(source: &str, state: &State, loaded: &State) -> Result<String, String> {
    let mut doc: DocumentMut = source.parse().map_err(|e| format!("the scene file no longer parses: {e}"))?;
    if state.materials.len() != loaded.materials.len() || state.lights.len() != loaded.lights.len() {
        return Err("the edits are for another version of the scene".into());
    }
    for (m, known) in state.materials.iter().zip(&loaded.materials) {
        let label = &known.label;
        let item = match label.strip_prefix("object ").and_then(|n| n.parse::<usize>().ok()) {
            Some(n) => doc
                .get_mut("objects")
                .and_then(|o| o.as_array_of_tables_mut())
                .and_then(|a| a.get_mut(n.checked_sub(1)?))
                .and_then(|t| t.get_mut("material")),
            None => doc.get_mut("materials").and_then(|t| t.get_mut(label)),
        };
        let Some(item) = item else { return Err(format!("material `{}` is not in the file", m.label)) };
        // A pattern keeps its table: only plain colours are written.
        let plain = item
            .as_table_like()
            .and_then(|t| t.get("color"))
            .is_none_or(|c| c.as_value().is_some_and(|v| v.is_array()));
        if plain {
            set(item, "color", triple(m.color));
        }
        for (k, x) in
            [("ambi", m.ambi), ("diff", m.diff), ("spec", m.spec), ("shine", m.shine), ("alpha", m.alpha), ("n", m.n)]
        {
            set(item, k, num(x));
        }
    }
    if let Some(lights) = doc.get_mut("lights").and_then(|l| l.as_array_of_tables_mut()) {
        for (t, l) in lights.iter_mut().zip(&state.lights) {
            let mut item = Item::Table(std::mem::take(t));
            set(&mut item, "at", triple(l.at));
            set(&mut item, "color", triple(l.color));
            set(&mut item, "intensity", num(l.intensity));
            *t = item.into_table().unwrap_or_default();
        }
    }
    let model = doc.entry("model").or_insert(Item::Table(Table::new()));
    let m = &state.model;
    set(model, "max_depth", Value::from(m.max_depth as i64));
    let shadows = if m.shadows.params.is_empty() {
        Value::from(m.shadows.name.as_str())
    } else {
        let mut t = InlineTable::new();
        t.insert("model", Value::from(m.shadows.name.as_str()));
        params(&mut t, &m.shadows.params);
        Value::InlineTable(t)
    };
    set(model, "shadows", shadows);
    let mut terms = Array::new();
    for t in m.terms.iter().filter(|t| t.enabled) {
        if t.params.is_empty() {
            terms.push(format!("{}:{}", t.name, t.variant));
        } else {
            let mut table = InlineTable::new();
            table.insert("term", Value::from(t.name.as_str()));
            table.insert("variant", Value::from(t.variant.as_str()));
            params(&mut table, &t.params);
            terms.push(Value::InlineTable(table));
        }
    }
    set(model, "terms", Value::Array(terms));
    let image = doc.entry("image").or_insert(Item::Table(Table::new()));
    set(image, "samples", Value::from(m.samples as i64));
    Ok(doc.to_string())
}
