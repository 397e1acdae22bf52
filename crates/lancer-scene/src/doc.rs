//! The scene file's serde shape (docs/scene-format.md, version 1). Unknown keys are rejected; numbers
//! must be finite and in range, checked while deserialising so errors carry the value's span.

use std::collections::BTreeMap;
use std::fmt;

use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use toml::Spanned;

/// A finite number; integers are accepted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f32);

struct NumVisitor;

impl Visitor<'_> for NumVisitor {
    type Value = Num;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a finite number")
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Num, E> {
        if v.is_finite() && v.abs() <= f32::MAX as f64 {
            Ok(Num(v as f32))
        } else {
            Err(E::custom(format!("expected a finite number, found {v}")))
        }
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Num, E> {
        Ok(Num(v as f32))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Num, E> {
        Ok(Num(v as f32))
    }
}

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Num, D::Error> {
        d.deserialize_any(NumVisitor)
    }
}

/// A position's coordinate, kept in f64 (translations, light positions, the camera's `from` and
/// `to`): rounded to f32 only once the camera's position is taken off it, at prepare. Finite and
/// within f32's range, as [`Num`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exact(pub f64);

struct ExactVisitor;

impl Visitor<'_> for ExactVisitor {
    type Value = Exact;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a finite number")
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Exact, E> {
        NumVisitor.visit_f64(v).map(|_| Exact(v))
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Exact, E> {
        Ok(Exact(v as f64))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Exact, E> {
        Ok(Exact(v as f64))
    }
}

impl<'de> Deserialize<'de> for Exact {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Exact, D::Error> {
        d.deserialize_any(ExactVisitor)
    }
}

/// A finite number in `[lo, hi]`.
fn ranged<'de, D: Deserializer<'de>>(d: D, lo: f32, hi: f32) -> Result<f32, D::Error> {
    let Num(x) = Num::deserialize(d)?;
    if (lo..=hi).contains(&x) {
        Ok(x)
    } else {
        Err(de::Error::custom(format!("expected a number in [{lo}, {hi}], found {x}")))
    }
}

fn unit<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    ranged(d, 0.0, 1.0)
}

fn index<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    ranged(d, 1.0, 2.5)
}

/// Largest light `intensity` and area light `size`: with colours up to [`MAX_CHANNEL`], the
/// light reaching a point stays far from overflowing.
pub const MAX_LIGHT: f32 = 1e6;

fn light_range<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    ranged(d, 0.0, MAX_LIGHT)
}

/// Largest colour channel: well above any meaningful colour (the handout's are in [0, 1]), low
/// enough that products of colours along a ray stay finite.
pub const MAX_CHANNEL: f32 = 1000.0;

fn colour<'de, D: Deserializer<'de>>(d: D) -> Result<[f32; 3], D::Error> {
    let [r, g, b] = <[Num; 3]>::deserialize(d)?;
    if [r, g, b].iter().any(|c| !(0.0..=MAX_CHANNEL).contains(&c.0)) {
        return Err(de::Error::custom(format!(
            "expected a colour [r, g, b] with channels in [0, {MAX_CHANNEL}] (the handout's are in [0, 1])"
        )));
    }
    Ok([r.0, g.0, b.0])
}

/// A whole number in `[lo, hi]`: an integer, or a float with nothing after the point
/// (`width = 480.0` is 480).
fn one<'de, D: Deserializer<'de>>(d: D, lo: u32, hi: u32) -> Result<u32, D::Error> {
    struct Whole;
    impl Visitor<'_> for Whole {
        type Value = f64;
        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("a whole number")
        }
        fn visit_i64<E: de::Error>(self, v: i64) -> Result<f64, E> {
            Ok(v as f64)
        }
        fn visit_u64<E: de::Error>(self, v: u64) -> Result<f64, E> {
            Ok(v as f64)
        }
        fn visit_f64<E: de::Error>(self, v: f64) -> Result<f64, E> {
            Ok(v)
        }
    }
    whole(d.deserialize_any(Whole)?, lo, hi)
}

/// `v` as a whole number in `[lo, hi]`.
fn whole<E: de::Error>(v: f64, lo: u32, hi: u32) -> Result<u32, E> {
    if v.fract() == 0.0 && (lo as f64..=hi as f64).contains(&v) {
        Ok(v as u32)
    } else {
        Err(E::custom(format!("expected a whole number in [{lo}, {hi}], found {v}")))
    }
}

/// Largest image side: 16384 pixels.
pub const MAX_SIDE: u32 = 16384;

fn side<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    one(d, 1, MAX_SIDE)
}

/// Most samples per pixel: 4096.
pub const MAX_SAMPLES: u32 = 4096;

/// `samples`: every pixel's number of samples, or adaptive anti-aliasing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SamplesDoc {
    /// `samples = N`.
    Uniform(u32),
    /// `samples = { adaptive = THRESHOLD, depth = N }`.
    Adaptive(AdaptiveDoc),
}

/// `samples = { adaptive = THRESHOLD, depth = N }` (POV-Ray's `+A<THRESHOLD> +R<N>`).
#[derive(Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AdaptiveDoc {
    /// The difference between neighbours from which a pixel is supersampled, in [0, 3].
    #[serde(deserialize_with = "threshold")]
    pub adaptive: f32,
    /// The side of a supersampled pixel's grid of samples (3 unless given).
    #[serde(default = "d_three", deserialize_with = "grid")]
    pub depth: u32,
}

fn threshold<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    ranged(d, 0.0, lancer_core::Adaptive::MAX_THRESHOLD)
}

fn grid<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    one(d, lancer_core::Adaptive::MIN_DEPTH, lancer_core::Adaptive::MAX_DEPTH)
}

fn d_three() -> u32 {
    lancer_core::Adaptive::DEFAULT.depth
}

impl<'de> Deserialize<'de> for SamplesDoc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<SamplesDoc, D::Error> {
        struct Samples;
        impl<'de> Visitor<'de> for Samples {
            type Value = SamplesDoc;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a whole number of samples per pixel or a table { adaptive = THRESHOLD, depth = N }")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<SamplesDoc, E> {
                whole(v as f64, 1, MAX_SAMPLES).map(SamplesDoc::Uniform)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<SamplesDoc, E> {
                whole(v as f64, 1, MAX_SAMPLES).map(SamplesDoc::Uniform)
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<SamplesDoc, E> {
                whole(v, 1, MAX_SAMPLES).map(SamplesDoc::Uniform)
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<SamplesDoc, A::Error> {
                AdaptiveDoc::deserialize(de::value::MapAccessDeserializer::new(map)).map(SamplesDoc::Adaptive)
            }
        }
        d.deserialize_any(Samples)
    }
}

/// Largest `max_depth`: 64 (the child ray's depth is a byte; Whitted scenes need 4 or 5).
pub const MAX_DEPTH: u32 = 64;

fn depth<'de, D: Deserializer<'de>>(d: D) -> Result<u8, D::Error> {
    one(d, 0, MAX_DEPTH).map(|v| v as u8)
}

/// The whole scene file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDoc {
    #[serde(default)]
    pub meta: MetaDoc,
    #[serde(default)]
    pub image: ImageDoc,
    pub camera: Spanned<CameraDoc>,
    pub model: Option<ModelDoc>,
    /// By name; the name's span places the warning about an unused material.
    #[serde(default)]
    pub materials: BTreeMap<Spanned<String>, MaterialDoc>,
    #[serde(default)]
    pub lights: Vec<Spanned<LightDoc>>,
    #[serde(default)]
    pub objects: Vec<Spanned<ObjectDoc>>,
}

/// A batch of `[[objects]]` sections, read on its own (see `scan.rs`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectsDoc {
    pub objects: Vec<Spanned<ObjectDoc>>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct MetaDoc {
    pub title: Option<String>,
    pub description: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageDoc {
    #[serde(default = "d_width", deserialize_with = "side")]
    pub width: u32,
    #[serde(default = "d_height", deserialize_with = "side")]
    pub height: u32,
    #[serde(default, deserialize_with = "colour")]
    pub background: [f32; 3],
    #[serde(default = "d_samples")]
    pub samples: SamplesDoc,
}

impl Default for ImageDoc {
    fn default() -> Self {
        ImageDoc { width: d_width(), height: d_height(), background: [0.0; 3], samples: d_samples() }
    }
}

fn d_width() -> u32 {
    640
}
fn d_height() -> u32 {
    480
}
fn d_samples() -> SamplesDoc {
    SamplesDoc::Uniform(1)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDoc {
    pub from: [Exact; 3],
    pub to: [Exact; 3],
    #[serde(default = "d_up")]
    pub up: [Num; 3],
    #[serde(default = "d_fov", deserialize_with = "fov")]
    pub fov: Num,
}

/// The vertical field of view: strictly between 0 and 180 degrees.
fn fov<'de, D: Deserializer<'de>>(d: D) -> Result<Num, D::Error> {
    let v = Num::deserialize(d)?;
    if v.0 > 0.0 && v.0 < 180.0 {
        Ok(v)
    } else {
        Err(de::Error::custom(format!(
            "expected the vertical field of view in degrees, strictly between 0 and 180, found {}",
            v.0
        )))
    }
}

fn d_up() -> [Num; 3] {
    [Num(0.0), Num(1.0), Num(0.0)]
}
fn d_fov() -> Num {
    Num(45.0)
}

/// `[model]`, or a whole model file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelDoc {
    #[serde(default, deserialize_with = "opt_depth")]
    pub max_depth: Option<u8>,
    pub shadows: Option<Spanned<NamedDoc>>,
    #[serde(default, deserialize_with = "term_list")]
    pub terms: Option<Vec<Spanned<NamedDoc>>>,
}

/// `terms = [...]`, with the list's own words when it is something else.
fn term_list<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec<Spanned<NamedDoc>>>, D::Error> {
    struct List;
    impl<'de> Visitor<'de> for List {
        type Value = Vec<Spanned<NamedDoc>>;
        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("a list of terms, e.g. terms = [\"ambient\", \"diffuse\"]")
        }
        fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
            Err(E::custom(format!("expected a list of terms in brackets: terms = [\"{v}\"]")))
        }
        fn visit_seq<A: de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
            let mut out = Vec::new();
            while let Some(t) = seq.next_element()? {
                out.push(t);
            }
            Ok(out)
        }
    }
    d.deserialize_any(List).map(Some)
}

/// `max_depth` when none is given.
pub const DEFAULT_DEPTH: u8 = 5;

fn opt_depth<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u8>, D::Error> {
    depth(d).map(Some)
}

/// A term or shadow model: a bare name, or a table with its name under `key` (`term` or
/// `model`), an optional `variant` and parameters.
pub struct NamedDoc {
    pub name: Spanned<String>,
    pub variant: Option<Spanned<String>>,
    pub params: Vec<(Spanned<String>, Spanned<toml::Value>)>,
    /// Which key held the name in table form (`term` or `model`), for error messages.
    pub key: Option<String>,
}

struct NamedVisitor;

impl<'de> Visitor<'de> for NamedVisitor {
    type Value = NamedDoc;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a name, or a table such as { term = \"specular\", variant = \"phong\" }")
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<NamedDoc, E> {
        // `NAME[:VARIANT][:KEY=VALUE]...`, as on the command line. The string's span is the
        // enclosing Spanned's; the builder places errors there.
        let c = lancer_shading::Choice::parse(v).map_err(E::custom)?;
        let params = c
            .params
            .into_iter()
            .map(|(k, value)| {
                let value = match value {
                    lancer_shading::ParamValue::Number(x) => toml::Value::Float(x),
                    lancer_shading::ParamValue::Bool(b) => toml::Value::Boolean(b),
                    lancer_shading::ParamValue::Text(t) => toml::Value::String(t),
                };
                (Spanned::new(0..0, k), Spanned::new(0..0, value))
            })
            .collect();
        let variant = c.variant.map(|v| Spanned::new(0..0, v));
        Ok(NamedDoc { name: Spanned::new(0..0, c.name), variant, params, key: None })
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<NamedDoc, A::Error> {
        let (mut name, mut variant, mut key, mut params) = (None, None, None, Vec::new());
        while let Some(k) = map.next_key::<Spanned<String>>()? {
            match k.get_ref().as_str() {
                "term" | "model" => {
                    if name.is_some() {
                        return Err(de::Error::custom(
                            "give the name once, as `term` (a term) or `model` (a shadow model)",
                        ));
                    }
                    key = Some(k.get_ref().clone());
                    name = Some(map.next_value::<Spanned<String>>()?);
                }
                "variant" => variant = Some(map.next_value::<Spanned<String>>()?),
                _ => params.push((k, map.next_value::<Spanned<toml::Value>>()?)),
            }
        }
        let name = name.ok_or_else(|| {
            de::Error::custom("missing the name: `term = \"...\"` for a term, `model = \"...\"` for a shadow model")
        })?;
        Ok(NamedDoc { name, variant, params, key })
    }
}

impl<'de> Deserialize<'de> for NamedDoc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<NamedDoc, D::Error> {
        d.deserialize_any(NamedVisitor)
    }
}

/// A material's `color`: `[r, g, b]` or a pattern table.
#[derive(Clone)]
pub enum ColorDoc {
    Solid([f32; 3]),
    Pattern(PatternDoc),
}

/// `{ pattern = "checker", colors = [[..], [..]], scale = 1 }` or
/// `{ pattern = "image", path = "file.png", scale = 1 }`.
#[derive(Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct PatternDoc {
    pub pattern: Spanned<String>,
    pub colors: Option<Spanned<[[Num; 3]; 2]>>,
    pub scale: Option<Spanned<Num>>,
    pub path: Option<Spanned<String>>,
}

struct ColorVisitor;

impl<'de> Visitor<'de> for ColorVisitor {
    type Value = ColorDoc;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(
            "a colour [r, g, b] or a pattern table such as { pattern = \"checker\", colors = [[1, 1, 1], [0, 0, 0]] }",
        )
    }
    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<ColorDoc, A::Error> {
        colour(de::value::SeqAccessDeserializer::new(seq)).map(ColorDoc::Solid)
    }
    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<ColorDoc, A::Error> {
        PatternDoc::deserialize(de::value::MapAccessDeserializer::new(map)).map(ColorDoc::Pattern)
    }
}

impl<'de> Deserialize<'de> for ColorDoc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<ColorDoc, D::Error> {
        d.deserialize_any(ColorVisitor)
    }
}

fn d_white_color() -> Spanned<ColorDoc> {
    Spanned::new(0..0, ColorDoc::Solid([1.0; 3]))
}

#[derive(Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct MaterialDoc {
    #[serde(default = "d_white_color")]
    pub color: Spanned<ColorDoc>,
    #[serde(default = "d_ambi", deserialize_with = "unit")]
    pub ambi: f32,
    #[serde(default = "d_diff", deserialize_with = "unit")]
    pub diff: f32,
    #[serde(default, deserialize_with = "unit")]
    pub spec: f32,
    #[serde(default, deserialize_with = "unit")]
    pub shine: f32,
    #[serde(default, deserialize_with = "unit")]
    pub alpha: f32,
    #[serde(default = "d_n", deserialize_with = "index")]
    pub n: f32,
}

fn d_white() -> [f32; 3] {
    [1.0; 3]
}
fn d_ambi() -> f32 {
    0.1
}
fn d_diff() -> f32 {
    0.9
}
fn d_n() -> f32 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightDoc {
    pub at: [Exact; 3],
    #[serde(default = "d_white", deserialize_with = "colour")]
    pub color: [f32; 3],
    #[serde(default = "d_intensity", deserialize_with = "light_range")]
    pub intensity: f32,
    #[serde(default, deserialize_with = "light_range")]
    pub size: f32,
}

fn d_intensity() -> f32 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectDoc {
    pub shape: Spanned<String>,
    pub material: Option<Spanned<MaterialRef>>,
    pub scale: Option<Spanned<Scale>>,
    pub rotate: Option<[Num; 3]>,
    pub translate: Option<[Exact; 3]>,
    /// A torus's tube radius.
    pub minor: Option<Spanned<Num>>,
    /// A CSG object's operation and operands.
    pub op: Option<Spanned<String>>,
    pub a: Option<Spanned<Box<OperandDoc>>>,
    pub b: Option<Spanned<Box<OperandDoc>>>,
    /// A mesh's OBJ file, relative to the scene file.
    pub path: Option<Spanned<String>>,
}

/// A CSG operand: a shape (or CSG node) with its own transform, and no material.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OperandDoc {
    pub shape: Spanned<String>,
    pub scale: Option<Spanned<Scale>>,
    pub rotate: Option<[Num; 3]>,
    pub translate: Option<[Num; 3]>,
    pub minor: Option<Spanned<Num>>,
    pub op: Option<Spanned<String>>,
    pub a: Option<Spanned<Box<OperandDoc>>>,
    pub b: Option<Spanned<Box<OperandDoc>>>,
}

/// `material = "name"` or an inline table.
pub enum MaterialRef {
    Named(String),
    Inline(Box<MaterialDoc>),
}

struct MaterialRefVisitor;

impl<'de> Visitor<'de> for MaterialRefVisitor {
    type Value = MaterialRef;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a material name or an inline material table")
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<MaterialRef, E> {
        Ok(MaterialRef::Named(v.to_owned()))
    }
    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<MaterialRef, A::Error> {
        MaterialDoc::deserialize(de::value::MapAccessDeserializer::new(map)).map(|m| MaterialRef::Inline(Box::new(m)))
    }
}

impl<'de> Deserialize<'de> for MaterialRef {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<MaterialRef, D::Error> {
        d.deserialize_any(MaterialRefVisitor)
    }
}

/// `scale = 2` or `scale = [sx, sy, sz]`; every factor's magnitude in [1e-6, 1e6].
pub struct Scale(pub [f32; 3]);

struct ScaleVisitor;

impl ScaleVisitor {
    fn check<E: de::Error>(s: [f32; 3]) -> Result<Scale, E> {
        if s.iter().any(|x| x.abs() < 1e-6) {
            Err(E::custom("a scale factor of zero flattens the object; use a factor of at least 1e-6 in size"))
        } else if s.iter().any(|x| x.abs() > 1e6) {
            Err(E::custom("a scale factor over 1e6 is out of range; use a factor of at most 1e6 in size"))
        } else {
            Ok(Scale(s))
        }
    }
}

impl<'de> Visitor<'de> for ScaleVisitor {
    type Value = Scale;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a number or [sx, sy, sz]")
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Scale, E> {
        let Num(x) = NumVisitor.visit_f64(v)?;
        Self::check([x; 3])
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Scale, E> {
        Self::check([v as f32; 3])
    }
    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Scale, A::Error> {
        let [x, y, z] = <[Num; 3]>::deserialize(de::value::SeqAccessDeserializer::new(seq))?;
        Self::check([x.0, y.0, z.0])
    }
}

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Scale, D::Error> {
        d.deserialize_any(ScaleVisitor)
    }
}
