//! The edited state written into the scene's own TOML text (toml_edit): only the values the page
//! changed (those that differ from the file's own state) are written; every other byte stays,
//! comments, order, layout and the way numbers and terms are spelled included.

use serde_json::Map;
use toml_edit::{Array, DocumentMut, InlineTable, Item, Table, TableLike, Value};

use crate::State;
use crate::state::{ShadowState, TermState};

/// `x` as the shortest decimal that reads back as the same `f32` (0.3, not 0.30000001...); an
/// integer when the value it replaces was one and `x` is whole (`2` becomes `3`, not `3.0`).
fn num(x: f32, old: Option<&Value>) -> Value {
    let whole = x.fract() == 0.0 && x.abs() < 1e15;
    if whole && old.is_some_and(Value::is_integer) {
        return Value::from(x as i64);
    }
    Value::from(format!("{x}").parse::<f64>().unwrap_or(x as f64))
}

/// A value with the decoration (spaces, comments) of the one it replaces.
fn decorated(mut v: Value, old: Option<&Value>) -> Value {
    if let Some(old) = old {
        *v.decor_mut() = old.decor().clone();
    }
    v
}

/// Sets `key` in a table (a `[table]` or an inline `{ }`), keeping its decoration.
fn set(t: &mut dyn TableLike, key: &str, v: Value) {
    match t.get_mut(key) {
        Some(Item::Value(old)) => *old = decorated(v, Some(old)),
        _ => {
            t.insert(key, Item::Value(v));
        }
    }
}

/// Sets the number `key` to `x`.
fn set_num(t: &mut dyn TableLike, key: &str, x: f32) {
    let v = num(x, t.get(key).and_then(Item::as_value));
    set(t, key, v);
}

/// Sets the triple `key` from `was` to `now`: in an array of three numbers, only the components
/// that changed.
fn set_triple(t: &mut dyn TableLike, key: &str, was: [f32; 3], now: [f32; 3]) {
    if let Some(a) = t.get_mut(key).and_then(Item::as_array_mut).filter(|a| a.len() == 3) {
        for (i, (w, x)) in was.into_iter().zip(now).enumerate() {
            if w != x {
                let v = decorated(num(x, a.get(i)), a.get(i));
                a.replace(i, v);
            }
        }
        return;
    }
    let mut a = Array::new();
    for x in now {
        a.push(num(x, None));
    }
    set(t, key, Value::Array(a));
}

/// After keys were added to an inline table that had `before`: the space before its `}` goes
/// after the new last key (`{ diff = 0.5, spec = 0.3 }`, not `{ diff = 0.5 , spec = 0.3 }`).
fn tidy(t: &mut InlineTable, before: usize) {
    let keys: Vec<String> = t.iter().map(|(k, _)| k.to_owned()).collect();
    let (Some(was), Some(last)) = (before.checked_sub(1).and_then(|i| keys.get(i)), keys.last()) else { return };
    if keys.len() == before {
        return;
    }
    let suffix = t.get(was).and_then(|v| v.decor().suffix()).cloned();
    if let Some(suffix) = suffix {
        if let Some(v) = t.get_mut(was) {
            v.decor_mut().set_suffix("");
        }
        if let Some(v) = t.get_mut(last) {
            v.decor_mut().set_suffix(suffix);
        }
    }
}

/// A parameter's TOML value (numbers like `old` when it was one).
fn param(v: &serde_json::Value, old: Option<&Value>) -> Option<Value> {
    Some(match v {
        serde_json::Value::Bool(b) => Value::from(*b),
        serde_json::Value::Number(n) => num(n.as_f64().unwrap_or(0.0) as f32, old),
        serde_json::Value::String(s) => Value::from(s.as_str()),
        _ => return None,
    })
}

/// A parameter's value as the state has it.
fn json(v: &Value) -> Option<serde_json::Value> {
    Some(match v {
        Value::Integer(i) => serde_json::json!(*i.value() as f64),
        Value::Float(f) => serde_json::json!(*f.value()),
        Value::Boolean(b) => serde_json::Value::Bool(*b.value()),
        Value::String(s) => serde_json::Value::String(s.value().clone()),
        _ => return None,
    })
}

/// Whether the parameters of an inline table (all keys but `names`) are `params`.
fn same_params(t: &InlineTable, names: &[&str], params: &Map<String, serde_json::Value>) -> bool {
    let given: Vec<_> = t.iter().filter(|(k, _)| !names.contains(k)).collect();
    given.len() == params.len()
        && given.iter().all(|(k, v)| {
            let (a, b) = (json(v), params.get(*k));
            match (a.as_ref().and_then(serde_json::Value::as_f64), b.and_then(serde_json::Value::as_f64)) {
                (Some(x), Some(y)) => x == y,
                _ => a.as_ref() == b,
            }
        })
}

/// Sets `params` in an inline table (all keys but `names`), writing only those that changed
/// from `was` and removing those no longer given.
fn update_params(
    t: &mut InlineTable,
    names: &[&str],
    was: &Map<String, serde_json::Value>,
    params: &Map<String, serde_json::Value>,
) {
    let gone: Vec<String> = t
        .iter()
        .map(|(k, _)| k.to_owned())
        .filter(|k| !names.contains(&k.as_str()) && !params.contains_key(k))
        .collect();
    for k in gone {
        t.remove(&k);
    }
    for (k, v) in params {
        if was.get(k) != Some(v)
            && let Some(v) = param(v, t.get(k))
        {
            set(t, k, v);
        }
    }
}

/// Whether the written entry `entry` of a `terms` array is the term `t`. An entry that names no
/// variant means the one the file was loaded with (`was`, the server's state of the file): its
/// default variant.
fn is_term(entry: &Value, t: &TermState, was: &[TermState]) -> bool {
    let variant_is = |written: Option<&str>| match written {
        Some(v) => v == t.variant,
        None => was.iter().find(|w| w.name == t.name).is_some_and(|w| w.variant == t.variant),
    };
    match entry {
        Value::String(s) => {
            let (name, variant) = s.value().split_once(':').map_or((s.value().as_str(), None), |(n, v)| (n, Some(v)));
            name == t.name && variant_is(variant) && t.params.is_empty()
        }
        Value::InlineTable(table) => {
            table.get("term").and_then(Value::as_str) == Some(&t.name)
                && variant_is(table.get("variant").and_then(Value::as_str))
                && same_params(table, &["term", "variant"], &t.params)
        }
        _ => false,
    }
}

/// A term as a `terms` entry.
fn term_entry(t: &TermState) -> Value {
    if t.params.is_empty() {
        return Value::from(format!("{}:{}", t.name, t.variant));
    }
    let mut table = InlineTable::new();
    table.insert("term", Value::from(t.name.as_str()));
    table.insert("variant", Value::from(t.variant.as_str()));
    for (k, v) in &t.params {
        if let Some(v) = param(v, None) {
            table.insert(k, v);
        }
    }
    Value::InlineTable(table)
}

/// The `terms` array for `now` (its enabled terms): an entry that is still the same term stays as
/// written, in the array's own layout; only new or changed ones are written afresh.
fn terms(old: Option<&Value>, now: &[TermState], was: &[TermState]) -> Value {
    let old = old.and_then(Value::as_array);
    let mut written: Vec<Option<&Value>> = old.map(|a| a.iter().map(Some).collect()).unwrap_or_default();
    let mut array = old.cloned().unwrap_or_default();
    array.clear();
    for (i, t) in now.iter().filter(|t| t.enabled).enumerate() {
        let kept = written.iter_mut().find(|e| e.is_some_and(|e| is_term(e, t, was))).and_then(Option::take);
        let mut v = kept.cloned().unwrap_or_else(|| term_entry(t));
        // The place's decoration: the first entry's, a new line in an array written one a line.
        if let Some(like) = old.and_then(|a| a.get(i).or_else(|| a.get(a.len().wrapping_sub(1)))) {
            *v.decor_mut() = like.decor().clone();
        }
        array.push_formatted(v);
    }
    if old.is_none() {
        array.fmt();
    }
    Value::Array(array)
}

/// The `shadows` value for `now`, from the one written (`old`) for `was`: the same model given
/// as a table keeps its table and changes only its parameters that changed.
fn shadows(old: Option<&Value>, was: &ShadowState, now: &ShadowState) -> Value {
    if let Some(Value::InlineTable(t)) = old
        && t.get("model").and_then(Value::as_str) == Some(&now.name)
        && now.name == was.name
    {
        let mut t = t.clone();
        update_params(&mut t, &["model"], &was.params, &now.params);
        return Value::InlineTable(t);
    }
    if now.params.is_empty() {
        return Value::from(now.name.as_str());
    }
    let mut t = InlineTable::new();
    t.insert("model", Value::from(now.name.as_str()));
    update_params(&mut t, &["model"], &Map::new(), &now.params);
    Value::InlineTable(t)
}

/// A table of the document, made when the file has none.
fn table<'a>(doc: &'a mut DocumentMut, key: &str) -> Option<&'a mut dyn TableLike> {
    doc.entry(key).or_insert(Item::Table(Table::new())).as_table_like_mut()
}

/// `source` (the scene file's text) with the values where `state` differs from `loaded` (the
/// server's own state of the file; which material is which comes from it, never from the page):
/// a material's numbers, a light's, the model's and the samples. Everything the page did not
/// change stays byte for byte: an unchanged state gives `source` back.
pub(crate) fn edited(source: &str, state: &State, loaded: &State) -> Result<String, String> {
    if state.materials.len() != loaded.materials.len() || state.lights.len() != loaded.lights.len() {
        return Err("the edits are for another version of the scene".into());
    }
    let mut doc: DocumentMut = source.parse().map_err(|e| format!("the scene file no longer parses: {e}"))?;
    let mut changed = false;
    for (m, known) in state.materials.iter().zip(&loaded.materials) {
        let numbers = [
            ("ambi", m.ambi, known.ambi),
            ("diff", m.diff, known.diff),
            ("spec", m.spec, known.spec),
            ("shine", m.shine, known.shine),
            ("alpha", m.alpha, known.alpha),
            ("n", m.n, known.n),
        ];
        if m.color == known.color && numbers.iter().all(|(_, x, was)| x == was) {
            continue;
        }
        let label = &known.label;
        let item = match label.strip_prefix("object ").and_then(|n| n.parse::<usize>().ok()) {
            Some(n) => doc
                .get_mut("objects")
                .and_then(|o| o.as_array_of_tables_mut())
                .and_then(|a| a.get_mut(n.checked_sub(1)?))
                .and_then(|t| t.get_mut("material")),
            None => doc.get_mut("materials").and_then(|t| t.get_mut(label)),
        };
        let missing = || format!("material `{label}` is not in the file");
        let Some(item) = item else { return Err(missing()) };
        let keys = item.as_table_like().map_or(0, |t| t.len());
        let Some(t) = item.as_table_like_mut() else { return Err(missing()) };
        // A pattern keeps its table: only plain colours are written.
        let plain = t.get("color").is_none_or(|c| c.as_value().is_some_and(Value::is_array));
        if plain && m.color != known.color {
            set_triple(t, "color", known.color, m.color);
        }
        for (k, x, was) in numbers {
            if x != was {
                set_num(t, k, x);
            }
        }
        if let Item::Value(Value::InlineTable(t)) = item {
            tidy(t, keys);
        }
        changed = true;
    }
    for (i, (l, known)) in state.lights.iter().zip(&loaded.lights).enumerate() {
        if l == known {
            continue;
        }
        let light = doc.get_mut("lights").and_then(|l| l.as_array_of_tables_mut()).and_then(|a| a.get_mut(i));
        let Some(t) = light else { return Err(format!("light {} is not in the file", i + 1)) };
        if l.at != known.at {
            set_triple(t, "at", known.at, l.at);
        }
        if l.color != known.color {
            set_triple(t, "color", known.color, l.color);
        }
        if l.intensity != known.intensity {
            set_num(t, "intensity", l.intensity);
        }
        changed = true;
    }
    let (m, known) = (&state.model, &loaded.model);
    if (m.max_depth, &m.shadows, &m.terms) != (known.max_depth, &known.shadows, &known.terms) {
        let Some(model) = table(&mut doc, "model") else { return Err("`model` is not a table".into()) };
        if m.max_depth != known.max_depth {
            set(model, "max_depth", Value::from(i64::from(m.max_depth)));
        }
        if m.shadows != known.shadows {
            let v = shadows(model.get("shadows").and_then(Item::as_value), &known.shadows, &m.shadows);
            set(model, "shadows", v);
        }
        if m.terms != known.terms {
            let v = terms(model.get("terms").and_then(Item::as_value), &m.terms, &known.terms);
            set(model, "terms", v);
        }
        changed = true;
    }
    if m.samples != known.samples {
        let Some(image) = table(&mut doc, "image") else { return Err("`image` is not a table".into()) };
        set(image, "samples", Value::from(i64::from(m.samples)));
        changed = true;
    }
    Ok(if changed { doc.to_string() } else { source.to_owned() })
}

#[cfg(test)]
mod tests {
    use lancer_shading::Registry;

    use super::*;

    /// A scene as it is written by hand: comments, `-3`, integers, a term table, a shadow string.
    const SCENE: &str = r#"# A hand-written scene.
[image]
width = 8   # tiny
height = 6

[camera]
from = [0, 1, -3]
to = [0, 0, 0]

[model]
max_depth = 4
shadows = "hard"      # the default, written anyway
terms = ["ambient", { term = "diffuse", weight = 0.5 }, "specular:blinn"]

[materials.red]
color = [0.8, 0.1, 0.1]
diff = 0.7   # matte
spec = 0.25

[materials.blue]
color = [0.1, 0.2, 1]

[[lights]]
at = [-3, 5, -3]
intensity = 2

[[objects]]
shape = "sphere"
material = "red"

[[objects]]
shape = "plane"
material = { diff = 0.5 }   # inline
translate = [0, -1, 0]
"#;

    /// The state the server makes of `source`.
    fn loaded(source: &str) -> State {
        let registry = Registry::with_builtins();
        let l = lancer_scene::load_scene(source, "scene.toml", &registry).expect("the scene loads");
        let prepared = lancer_shading::prepare(&l.scene).expect("the scene prepares");
        State::of(&prepared, &l.pipeline, &l.places.materials, l.scene.image.samples.clamp(1, 256))
    }

    /// The lines that differ, as (was, now); both texts must have as many lines.
    fn differing<'a>(a: &'a str, b: &'a str) -> Vec<(&'a str, &'a str)> {
        assert_eq!(a.lines().count(), b.lines().count(), "lines were added or removed:\n{b}");
        a.lines().zip(b.lines()).filter(|(x, y)| x != y).collect()
    }

    #[test]
    fn an_unchanged_state_gives_the_file_back_byte_for_byte() {
        let state = loaded(SCENE);
        assert_eq!(edited(SCENE, &state, &state).unwrap(), SCENE);
    }

    #[test]
    fn one_moved_slider_changes_exactly_that_value_and_adds_no_defaults() {
        let known = loaded(SCENE);
        let mut state = known.clone();
        let red = state.materials.iter_mut().find(|m| m.label == "red").unwrap();
        red.diff = 0.6;
        let text = edited(SCENE, &state, &known).unwrap();
        assert_eq!(differing(SCENE, &text), [("diff = 0.7   # matte", "diff = 0.6   # matte")]);
        assert_eq!(loaded(&text), state);
    }

    #[test]
    fn a_changed_colour_channel_keeps_the_others_as_written() {
        let known = loaded(SCENE);
        let mut state = known.clone();
        state.lights[0].at[1] = 6.5;
        let text = edited(SCENE, &state, &known).unwrap();
        assert_eq!(differing(SCENE, &text), [("at = [-3, 5, -3]", "at = [-3, 6.5, -3]")]);
        let mut state = known.clone();
        state.lights[0].intensity = 3.0;
        let text = edited(SCENE, &state, &known).unwrap();
        assert_eq!(differing(SCENE, &text), [("intensity = 2", "intensity = 3")]);
    }

    #[test]
    fn an_inline_material_changes_in_place() {
        let known = loaded(SCENE);
        let mut state = known.clone();
        let inline = state.materials.iter_mut().find(|m| m.label == "object 2").unwrap();
        inline.spec = 0.3;
        let text = edited(SCENE, &state, &known).unwrap();
        assert_eq!(
            differing(SCENE, &text),
            [("material = { diff = 0.5 }   # inline", "material = { diff = 0.5, spec = 0.3 }   # inline")]
        );
        assert_eq!(loaded(&text), state);
    }

    #[test]
    fn regression_a_term_written_without_its_variant_is_rewritten_when_the_variant_changes() {
        // Found in review of the minimal save: `"ambient"` kept as written after the page chose
        // another variant, so the change was lost.
        let known = loaded(SCENE);
        let mut state = known.clone();
        state.model.terms[0].variant = "other".into();
        let text = edited(SCENE, &state, &known).unwrap();
        let (_, now) = differing(SCENE, &text)[0];
        assert!(now.starts_with(r#"terms = ["ambient:other", { term = "diffuse", "#), "{now}");
    }

    #[test]
    fn a_switched_off_term_keeps_the_other_terms_as_written() {
        let known = loaded(SCENE);
        let mut state = known.clone();
        state.model.terms[0].enabled = false;
        let text = edited(SCENE, &state, &known).unwrap();
        assert_eq!(
            differing(SCENE, &text),
            [(
                r#"terms = ["ambient", { term = "diffuse", weight = 0.5 }, "specular:blinn"]"#,
                r#"terms = [{ term = "diffuse", weight = 0.5 }, "specular:blinn"]"#
            )]
        );
        let mut state = known.clone();
        state.model.terms[1].params.insert("weight".into(), serde_json::json!(0.75));
        let text = edited(SCENE, &state, &known).unwrap();
        let (_, now) = differing(SCENE, &text)[0];
        assert!(
            now.starts_with(r#"terms = ["ambient", { term = "diffuse", "#) && now.ends_with(r#""specular:blinn"]"#)
        );
        assert_eq!(loaded(&text), state);
    }

    #[test]
    fn a_shadow_parameter_changes_only_itself() {
        let source = SCENE.replace(r#"shadows = "hard"      "#, r#"shadows = { model = "soft", samples = 16 }"#);
        let known = loaded(&source);
        let mut state = known.clone();
        state.model.shadows.params.insert("samples".into(), serde_json::json!(32));
        let text = edited(&source, &state, &known).unwrap();
        assert_eq!(
            differing(&source, &text),
            [(
                r#"shadows = { model = "soft", samples = 16 }# the default, written anyway"#,
                r#"shadows = { model = "soft", samples = 32 }# the default, written anyway"#
            )]
        );
        let mut state = known.clone();
        state.model.samples = 4;
        let text = edited(&source, &state, &known).unwrap();
        assert_eq!(text.replace("height = 6\nsamples = 4\n", "height = 6\n"), source);
    }
}
