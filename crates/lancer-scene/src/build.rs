//! From the parsed document to the hecs World and the pipeline, checking names against the
//! registry and the materials table.

use std::collections::HashMap;
use std::ops::Range;

use glam::{Affine3A, DVec3, Mat3, Vec3};
use lancer_core::{
    Camera, ImageSettings, Light, Material, MaterialOf, Meta, Pattern, Position, Scene, Texture, Transform,
};
use lancer_shading::{NamedShadow, NamedTerm, ParamValue, Params, Pipeline, Registry};
use lancer_shapes::{CsgNode, CsgOp, Mesh, MeshError, Shape};
use toml::Spanned;

use crate::doc::{
    ColorDoc, Exact, MaterialDoc, MaterialRef, ModelDoc, NamedDoc, Num, ObjectDoc, ObjectsDoc, OperandDoc, PatternDoc,
    Scale, SceneDoc,
};
use crate::error::{Errors, Lines};
use crate::{LoadError, LoadErrorKind, Place, Warning};

/// A loaded scene file: the scene and the lighting model its `[model]` describes.
pub struct Loaded {
    /// Objects, materials, lights, camera, image settings.
    pub scene: Scene,
    /// The `[model]` table built against the registry (the full handout model when absent).
    pub pipeline: Pipeline,
    /// What the file allows but probably does not mean (unused materials, colours above 1, no
    /// lights, degenerate mesh triangles skipped).
    pub warnings: Vec<Warning>,
    /// Where each object, light and the camera are written, for later warnings.
    pub places: Places,
}

/// Where the scene's parts are written in its file.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Places {
    /// Each `[[objects]]` entry, in order (the prepared scene's object order).
    pub objects: Vec<Place>,
    /// Each `[[lights]]` entry, in order.
    pub lights: Vec<Place>,
    /// The `[camera]` table.
    pub camera: Option<Place>,
    /// A name for each material in the prepared table's order: `[materials.NAME]`'s name, or
    /// `object N` for an object's inline material (the default material, last, is not listed).
    pub materials: Vec<String>,
    /// Whether the model's terms were chosen (a `terms` list in the scene, or on the command
    /// line) rather than left to the default: only chosen terms are worth a warning when they
    /// have nothing to act on.
    pub chosen_terms: bool,
}

#[derive(Clone, Copy)]
struct Ctx<'a> {
    file: &'a str,
    /// The whole file.
    src: &'a str,
    /// Its line table, built once.
    lines: &'a Lines,
    /// Where in `src` the text the spans count from starts (a batch of objects is read on its
    /// own).
    offset: usize,
}

impl<'a> Ctx<'a> {
    fn new(file: &'a str, src: &'a str, lines: &'a Lines) -> Ctx<'a> {
        Ctx { file, src, lines, offset: 0 }
    }

    fn shifted(&self, span: Range<usize>) -> Range<usize> {
        span.start + self.offset..span.end + self.offset
    }

    fn place(&self, span: Range<usize>) -> Place {
        self.lines.place(self.file, self.src, self.offset + span.start)
    }

    fn warn(&self, span: Range<usize>, message: String) -> Warning {
        Warning { place: Some(self.place(span)), message }
    }

    fn err(&self, span: Range<usize>, kind: LoadErrorKind) -> LoadError {
        LoadError::located(self.file, self.src, self.lines, Some(self.shifted(span)), kind)
    }

    /// A toml error reading `parsed`, the text its spans count in (the file, the file with its
    /// objects blanked out, or a batch of them).
    fn syntax(&self, e: toml::de::Error, parsed: &str) -> LoadError {
        let message = e.message().trim_end();
        let span = e.span().map(|span| self.shifted(back_to_the_line_it_belongs_to(parsed, span, message)));
        let at = e.span().map_or(parsed.len(), |span| span.start.min(parsed.len()));
        let mut message = in_plain_words(message, parsed, at).unwrap_or_else(|| with_did_you_mean(message));
        if message.starts_with("missing comma between array elements") {
            message.push_str(", or the `]` that closes the array");
        }
        LoadError::located(self.file, self.src, self.lines, span, LoadErrorKind::Syntax(message))
    }

    /// The pass before the toml crate: nesting refused past its limit, objects found.
    fn scan(&self, batches: bool) -> Result<crate::scan::Layout, LoadError> {
        crate::scan::scan(self.src, batches).map_err(|e| self.err(e.span, LoadErrorKind::Syntax(e.message)))
    }
}

/// The toml crate's error reading `src`, the whole text of `file`, located and worded as a scene
/// file's syntax errors are (an unclosed bracket placed at the end of its line, an unknown key
/// with the nearest known one): for other TOML files read with serde (`lancer sheet`'s).
pub fn toml_error(file: &str, src: &str, e: toml::de::Error) -> LoadError {
    let lines = Lines::new(src);
    Ctx::new(file, src, &lines).syntax(e, src)
}

/// An unclosed bracket or a missing comma is found at the start of the next line; the place to
/// fix it is the end of the line before (the last one with something on it).
fn back_to_the_line_it_belongs_to(src: &str, span: Range<usize>, message: &str) -> Range<usize> {
    let start = span.start.min(src.len());
    let at_line_start =
        start == 0 || src[..start].ends_with('\n') || src[..start].trim_end_matches([' ', '\t']).ends_with('\n');
    let about_a_missing_closer =
        ["expected `]`", "expected `,`", "expected `]]`", "expected `}`"].iter().any(|m| message.contains(m));
    if !(at_line_start && about_a_missing_closer) {
        return span;
    }
    // The end of the previous line with code (comments and blank lines skipped), line by line
    // back from the error.
    let mut end = start;
    let found = loop {
        let line_start = src[..end].rfind('\n').map_or(0, |i| i + 1);
        let line = src[line_start..end].trim_end_matches(['\n', '\r']);
        let code = line.split('#').next().unwrap_or("").trim_end();
        if !code.trim().is_empty() {
            break Some(line_start + code.len());
        }
        if line_start == 0 {
            break None;
        }
        end = line_start - 1;
    };
    found.map_or(span, |e| e..e)
}

/// The toml crate's words for two slips of a first TOML file, said the way to fix them: a table
/// header `[lights]` where each light is an entry `[[lights]]` ("invalid type: map, expected a
/// sequence"), and a number without a digit before or after its point, `.8` or `8.` ("invalid
/// mantissa", "invalid fraction"). `at` is the error's place in `parsed`.
fn in_plain_words(message: &str, parsed: &str, at: usize) -> Option<String> {
    let (before, at) = parsed.split_at(at);
    if message.starts_with("invalid type: map, expected a sequence") {
        let name = at.strip_prefix('[').filter(|r| !r.starts_with('['))?.split(']').next()?.trim();
        let entry = match name {
            "lights" => "each light is an array entry `[[lights]]`".to_owned(),
            "objects" => "each object is an array entry `[[objects]]`".to_owned(),
            _ => format!("a list of tables is written `[[{name}]]`, once before each entry"),
        };
        return Some(format!("`[{name}]` is one table; {entry}"));
    }
    // The number as written: a sign, digits, a point, digits, an exponent.
    let number: String =
        at.chars().take_while(|c| c.is_ascii_digit() || matches!(c, '.' | '-' | '+' | 'e' | 'E' | '_')).collect();
    if message.starts_with("invalid mantissa") && number.trim_start_matches(['-', '+']).starts_with('.') {
        let sign = &number[..number.len() - number.trim_start_matches(['-', '+']).len()];
        return Some(format!("a number needs a digit before the point: {sign}0{}", &number[sign.len()..]));
    }
    if message.starts_with("invalid fraction") && before.ends_with('.') {
        // The error stands after the point; the number starts before it.
        let digits = before.len() - before.trim_end_matches(|c: char| c.is_ascii_digit() || c == '.').len();
        return Some(format!("a number needs a digit after the point: {}0", &before[before.len() - digits..]));
    }
    None
}

/// serde's "unknown field `shiny`, expected one of `color`, ..." with the nearest known name.
fn with_did_you_mean(message: &str) -> String {
    let Some(rest) = message.strip_prefix("unknown field `") else { return message.to_owned() };
    let Some((field, expected)) = rest.split_once('`') else { return message.to_owned() };
    let known: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
    // British spellings of the one key that has them.
    let nearest = if field == "colour" && known.contains(&"color") {
        Some("color".to_owned())
    } else {
        lancer_shading::nearest(field, known.iter().copied())
    };
    match nearest {
        Some(n) => format!("{message} (did you mean `{n}`?)"),
        None => message.to_owned(),
    }
}

/// Reads a file a scene refers to (a texture image), given the path as the scene wrote it; the
/// caller decides what it is relative to. Errors are messages such as "no such file".
pub type Resolver<'a> = &'a dyn Fn(&str) -> Result<Vec<u8>, String>;

/// Loads the scene file `file` whose text is `src`; a scene that refers to other files (textures)
/// is an error here: use [`load_scene_with`].
pub fn load_scene(src: &str, file: &str, registry: &Registry) -> Result<Loaded, LoadError> {
    load_scene_with(src, file, registry, &|path: &str| Err(format!("cannot read `{path}`: this loader reads no files")))
}

/// How much a scene's files may cost to load: past these, a located error says what to raise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// The most pixels all textures may hold together (`--max-texture-pixels`).
    pub max_texture_pixels: u64,
    /// The most triangles the scene's meshes may have together (`--max-triangles`), counted as
    /// fanned from their faces (a polygon of k corners is k - 2), each mesh file once however
    /// many objects share it. A file past it is refused at the face that crosses it, before
    /// any of its triangles is stored.
    pub max_triangles: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits { max_texture_pixels: crate::texture::MAX_TEXTURE_PIXELS, max_triangles: MAX_TRIANGLES }
    }
}

/// [`Limits::max_triangles`] unless raised: ten times the largest common test meshes (the
/// Stanford dragon and Buddha are about 10⁶ triangles), about 0.7 GB of mesh at the 70 bytes a
/// triangle a loaded mesh takes, well within the 2 GB a large scene may use.
pub const MAX_TRIANGLES: usize = 10_000_000;

/// `src` with the byte ranges `blank` made spaces (newlines kept): the same offsets, lines and
/// columns, without them.
fn blanked(src: &str, blank: &[Range<usize>]) -> String {
    let mut out = String::with_capacity(src.len());
    let mut at = 0;
    for r in blank {
        out.push_str(&src[at..r.start]);
        for c in src[r.clone()].chars() {
            if c == '\n' {
                out.push('\n');
            } else {
                out.extend(std::iter::repeat_n(' ', c.len_utf8()));
            }
        }
        at = r.end;
    }
    out.push_str(&src[at..]);
    out
}

/// Loads the scene file `file` whose text is `src`, reading the files it refers to through
/// `resolve`, within the default [`Limits`].
pub fn load_scene_with(src: &str, file: &str, registry: &Registry, resolve: Resolver<'_>) -> Result<Loaded, LoadError> {
    load_scene_within(src, file, registry, resolve, &Limits::default())
}

/// [`load_scene_with`] within `limits`.
pub fn load_scene_within(
    src: &str,
    file: &str,
    registry: &Registry,
    resolve: Resolver<'_>,
    limits: &Limits,
) -> Result<Loaded, LoadError> {
    let lines = Lines::new(src);
    let cx = Ctx::new(file, src, &lines);
    let layout = cx.scan(true)?;
    // Batches of `[[objects]]` are read one after the other, after the rest of the file (read
    // with them blanked out, so its spans are the file's): the toml crate's document of the
    // whole file would take some 40 bytes per byte of it.
    let rest = if layout.object_batches.is_empty() {
        std::borrow::Cow::Borrowed(src)
    } else {
        std::borrow::Cow::Owned(blanked(src, &layout.object_batches))
    };
    // A TOML syntax error, or a key the file format does not have or of the wrong type, stops
    // the toml crate at the first; the errors past it (names, values the builder checks, files)
    // are gathered: up to MAX_ERRORS of them are told together, in file order.
    let doc: SceneDoc = toml::from_str(&rest).map_err(|e| cx.syntax(e, &rest))?;
    drop(rest);
    let mut errors = Errors::default();
    let pipeline = match &doc.model {
        Some(m) => errors.keep(build_pipeline(&cx, m, registry, None)).unwrap_or_else(|| registry.default_pipeline()),
        None => registry.default_pipeline(),
    };
    let mut world = hecs::World::new();

    let mut textures = Textures {
        list: Vec::new(),
        by_path: HashMap::new(),
        by_contents: HashMap::new(),
        resolve,
        used: 0,
        budget: limits.max_texture_pixels,
    };
    let mut meshes = Meshes { by_path: HashMap::new(), triangles: 0, limit: limits.max_triangles };
    let mut warnings = Vec::new();
    let mut places = Places {
        camera: Some(cx.place(doc.camera.span())),
        chosen_terms: doc.model.as_ref().is_some_and(|m| m.terms.is_some()),
        ..Places::default()
    };
    let mut named: HashMap<&str, hecs::Entity> = HashMap::new();
    // Materials in file order (the document's table is sorted by name): the prepared table, the
    // studio's panels and `explain` number them as the file lists them, as objects are.
    let mut in_file_order: Vec<_> = doc.materials.iter().collect();
    in_file_order.sort_by_key(|(name, _)| name.span().start);
    for (name, m) in in_file_order {
        // A material in error still takes its name, so that the objects using it are not
        // told they name an unknown one.
        let m = errors.keep(material(&cx, m, &mut textures, &mut warnings)).unwrap_or_default();
        named.insert(name.get_ref(), world.spawn((m,)));
        places.materials.push(name.get_ref().clone());
    }
    for l in &doc.lights {
        places.lights.push(cx.place(l.span()));
        let l = l.get_ref();
        let at = dvec3(l.at);
        let light = Light { at: at.as_vec3(), color: Vec3::from(l.color), intensity: l.intensity, size: l.size };
        world.spawn((light, Position(at)));
    }
    if doc.lights.is_empty() {
        warnings.push(Warning {
            place: None,
            message: "the scene has no [[lights]]: only the ambient term and the background will show".into(),
        });
    }
    let mut used: std::collections::HashSet<&str> = std::collections::HashSet::new();
    // An object's shape, material and placement are each checked, their errors all kept.
    let mut object = |cx: &Ctx<'_>, o: &Spanned<ObjectDoc>, errors: &mut Errors| {
        places.objects.push(cx.place(o.span()));
        let obj = o.get_ref();
        let fields = ShapeFields {
            shape: &obj.shape,
            minor: &obj.minor,
            op: &obj.op,
            a: obj.a.as_ref(),
            b: obj.b.as_ref(),
            path: obj.path.as_ref(),
            at: o.span(),
        };
        let shape = if obj.shape.get_ref() == "mesh" {
            errors.keep(mesh_shape(cx, o, &mut meshes, textures.resolve, &mut warnings))
        } else {
            errors.keep(build_shape(cx, &fields))
        };
        let mat = match obj.material.as_ref().map(|m| (m.span(), m.get_ref())) {
            None => Some(None),
            Some((_, MaterialRef::Inline(m))) => {
                let m = errors.keep(material(cx, m, &mut textures, &mut warnings));
                places.materials.push(format!("object {}", places.objects.len()));
                m.map(|m| Some(world.spawn((m,))))
            }
            Some((span, MaterialRef::Named(name))) => match named.get_key_value(name.as_str()) {
                Some((&key, &entity)) => {
                    used.insert(key);
                    Some(Some(entity))
                }
                None => {
                    let known: Vec<String> = doc.materials.keys().map(|k| k.get_ref().clone()).collect();
                    errors.push(cx.err(
                        span,
                        LoadErrorKind::UnknownMaterial {
                            name: name.clone(),
                            nearest: lancer_shading::nearest(name, known.iter().map(String::as_str)),
                            known,
                        },
                    ));
                    None
                }
            },
        };
        // The translation in f64: prepare rounds it once the camera's position is taken off.
        let linear = placement(obj.scale.as_ref(), obj.rotate, None).matrix3;
        let transform = Transform::new(linear, obj.translate.map_or(DVec3::ZERO, dvec3));
        // The geometry's own test, here, so the error has a place in the file.
        if lancer_shapes::invertible(&transform.world_from_object).is_none() {
            let span = obj.scale.as_ref().map_or(o.span(), |s| s.span());
            let msg = "this placement (scale, rotate, translate) cannot be inverted in single precision";
            errors.push(cx.err(span, LoadErrorKind::Syntax(msg.into())));
            return;
        }
        match (shape, mat) {
            (Some(shape), Some(Some(m))) => {
                world.spawn((shape, transform, MaterialOf(m)));
            }
            (Some(shape), Some(None)) => {
                world.spawn((shape, transform));
            }
            // In error: the load fails, with this object's errors among the others.
            _ => {}
        }
    };
    for o in &doc.objects {
        object(&cx, o, &mut errors);
    }
    for batch in &layout.object_batches {
        let cx = Ctx { offset: batch.start, ..cx };
        let text = &src[batch.clone()];
        match toml::from_str::<ObjectsDoc>(text) {
            Ok(doc) => {
                for o in &doc.objects {
                    object(&cx, o, &mut errors);
                }
            }
            // The toml crate stops at its first error: the batches after it are not read.
            Err(e) => {
                errors.push(cx.syntax(e, text));
                break;
            }
        }
    }

    let cam = doc.camera.get_ref();
    let camera = Camera::look_at(dvec3(cam.from), dvec3(cam.to), vec3(cam.up), cam.fov.0)
        .map_err(|e| cx.err(doc.camera.span(), LoadErrorKind::Camera(e.to_string())));
    let camera = match camera {
        Ok(camera) => camera,
        Err(e) => {
            errors.push(e);
            return Err(errors.into_error().expect("one error at least"));
        }
    };
    errors.or(())?;
    let mut image = ImageSettings {
        width: doc.image.width,
        height: doc.image.height,
        background: Vec3::from(doc.image.background),
        ..Default::default()
    };
    match doc.image.samples {
        crate::doc::SamplesDoc::Uniform(n) => image.set_samples(n),
        crate::doc::SamplesDoc::Adaptive(a) => {
            image.set_adaptive(lancer_core::Adaptive { threshold: a.adaptive, depth: a.depth })
        }
    }
    for key in doc.materials.keys().filter(|n| !used.contains(n.get_ref().as_str())) {
        // At the table's header (`[materials.NAME]`) or the dotted key (`materials.NAME = ...`)
        // when it is written so, else at the name.
        let at = key.span().start;
        let before = &src[..at];
        let at = ["[materials.", "materials."].iter().find(|p| before.ends_with(*p)).map_or(at, |p| at - p.len());
        let name = key.get_ref();
        warnings.push(cx.warn(at..at, format!("material `{name}` is defined but no object uses it")));
    }
    let meta = Meta { title: doc.meta.title, description: doc.meta.description };
    Ok(Loaded { scene: Scene { world, camera, image, meta, textures: textures.list }, pipeline, warnings, places })
}

/// Loads a model file (the keys of `[model]` at top level) on its own: what it leaves out has
/// its default.
pub fn load_model(src: &str, file: &str, registry: &Registry) -> Result<Pipeline, LoadError> {
    let lines = Lines::new(src);
    let cx = Ctx::new(file, src, &lines);
    cx.scan(false)?;
    let doc: ModelDoc = toml::from_str(src).map_err(|e| cx.syntax(e, src))?;
    build_pipeline(&cx, &doc, registry, None)
}

/// Loads a model file over `base` (a scene's model): it replaces only what it sets (`terms`,
/// `shadows`, `max_depth`), so a file that swaps the highlight leaves the scene's shadows and
/// depth alone.
pub fn load_model_over(src: &str, file: &str, registry: &Registry, base: Pipeline) -> Result<Pipeline, LoadError> {
    let lines = Lines::new(src);
    let cx = Ctx::new(file, src, &lines);
    cx.scan(false)?;
    let doc: ModelDoc = toml::from_str(src).map_err(|e| cx.syntax(e, src))?;
    build_pipeline(&cx, &doc, registry, Some(base))
}

/// Scale, then rotate (degrees about x, then y, then z), then translate.
fn placement(scale: Option<&Spanned<Scale>>, rotate: Option<[Num; 3]>, translate: Option<[Num; 3]>) -> Affine3A {
    let scale = scale.map_or(Vec3::ONE, |s| Vec3::from(s.get_ref().0));
    let [rx, ry, rz] = rotate.map_or([0.0; 3], |r| r.map(|Num(d)| d.to_radians()));
    // Each turn's sine and cosine from `libm`, as glam's `from_rotation_*` lays them out: the
    // platform's own sine may differ in the last bit, and the browser build must place objects
    // as the native one does.
    let turn = |angle: f32, axis: usize| {
        let (s, c) = libm::sincosf(angle);
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut m = [[0.0f32; 3]; 3];
        m[axis][axis] = 1.0;
        (m[a][a], m[a][b], m[b][a], m[b][b]) = (c, s, -s, c);
        Mat3::from_cols_array_2d(&m)
    };
    let rotation = turn(rz, 2) * turn(ry, 1) * turn(rx, 0);
    Affine3A::from_mat3_translation(rotation * Mat3::from_diagonal(scale), translate.map_or(Vec3::ZERO, vec3))
}

/// The shape-describing keys of an object or a CSG operand.
struct ShapeFields<'d> {
    shape: &'d Spanned<String>,
    minor: &'d Option<Spanned<Num>>,
    op: &'d Option<Spanned<String>>,
    a: Option<&'d Spanned<Box<OperandDoc>>>,
    b: Option<&'d Spanned<Box<OperandDoc>>>,
    /// A mesh's file (objects only).
    path: Option<&'d Spanned<String>>,
    /// The whole table, for errors about missing keys.
    at: Range<usize>,
}

impl<'d> ShapeFields<'d> {
    fn of(o: &'d Spanned<Box<OperandDoc>>) -> ShapeFields<'d> {
        let d = o.get_ref();
        ShapeFields {
            shape: &d.shape,
            minor: &d.minor,
            op: &d.op,
            a: d.a.as_ref(),
            b: d.b.as_ref(),
            path: None,
            at: o.span(),
        }
    }
}

fn build_shape(cx: &Ctx<'_>, f: &ShapeFields<'_>) -> Result<Shape, LoadError> {
    let syntax = |span: Range<usize>, msg: String| cx.err(span, LoadErrorKind::Syntax(msg));
    let name = f.shape.get_ref();
    if name == "mesh" {
        return Err(syntax(
            f.shape.span(),
            "a mesh cannot be a csg operand (CSG needs shapes with exact insides)".into(),
        ));
    }
    if let Some(p) = f.path {
        return Err(syntax(p.span(), format!("`path` belongs to a mesh; a {name} has none")));
    }
    if name == "csg" {
        if let Some(m) = f.minor {
            return Err(syntax(m.span(), "`minor` is a torus parameter; a csg has none".into()));
        }
        let mut nodes = Vec::new();
        let root = csg_node(cx, f, Affine3A::IDENTITY, &mut nodes)?;
        let csg = lancer_shapes::Csg::new(nodes, root)
            .ok_or_else(|| syntax(f.at.clone(), "a csg operand has a singular transform".into()))?;
        return Ok(Shape::Csg(std::sync::Arc::new(csg)));
    }
    let shape = Shape::from_name(name).ok_or_else(|| {
        cx.err(
            f.shape.span(),
            LoadErrorKind::UnknownShape {
                name: name.clone(),
                nearest: lancer_shading::nearest(name, Shape::NAMES.iter().copied()),
                known: Shape::NAMES.iter().map(|s| s.to_string()).collect(),
            },
        )
    })?;
    {
        for (key, span) in
            [("op", f.op.as_ref().map(|x| x.span())), ("a", f.a.map(|x| x.span())), ("b", f.b.map(|x| x.span()))]
        {
            if let Some(span) = span {
                return Err(syntax(span, format!("`{key}` belongs to a csg shape; a {name} has none")));
            }
        }
    }
    match (shape, f.minor) {
        (Shape::Torus { .. }, Some(m)) => {
            let minor = m.get_ref().0;
            if !(minor > 0.0 && minor < 1.0) {
                let msg =
                    format!("`minor` must be in (0, 1) (the tube's radius, the major radius being 1), found {minor}");
                return Err(syntax(m.span(), msg));
            }
            Ok(Shape::Torus { minor })
        }
        (shape, Some(m)) => Err(syntax(m.span(), format!("`minor` is a torus parameter; a {} has none", shape.name()))),
        (shape, None) => Ok(shape),
    }
}

/// Adds the CSG node `f` (placed by `node_from` in the tree's space) and its operands to `nodes`.
fn csg_node(
    cx: &Ctx<'_>,
    f: &ShapeFields<'_>,
    node_from: Affine3A,
    nodes: &mut Vec<CsgNode>,
) -> Result<u32, LoadError> {
    let syntax = |span: Range<usize>, msg: String| cx.err(span, LoadErrorKind::Syntax(msg));
    if f.shape.get_ref() != "csg" {
        let shape = build_shape(cx, f)?;
        // Checked again here: an operand's own shape must enclose a volume.
        if !shape.is_closed() {
            return Err(syntax(
                f.shape.span(),
                format!("a {} has no inside, so it cannot be a csg operand", shape.name()),
            ));
        }
        nodes.push(CsgNode::Leaf { shape, node_from_leaf: node_from });
        return Ok((nodes.len() - 1) as u32);
    }
    let op = f.op.as_ref().ok_or_else(|| {
        syntax(f.at.clone(), "a csg shape needs `op = \"union\" | \"intersection\" | \"difference\"`".into())
    })?;
    let op_kind = CsgOp::from_name(op.get_ref()).ok_or_else(|| {
        let hint = lancer_shading::nearest(op.get_ref(), CsgOp::NAMES.iter().copied())
            .map(|n| format!(" (did you mean `{n}`?)"))
            .unwrap_or_default();
        syntax(
            op.span(),
            format!("unknown csg operation `{}`{hint}; known operations: {}", op.get_ref(), CsgOp::NAMES.join(", ")),
        )
    })?;
    let mut operand = |which: &str, o: Option<&Spanned<Box<OperandDoc>>>| -> Result<u32, LoadError> {
        let o =
            o.ok_or_else(|| syntax(f.at.clone(), format!("a csg shape needs operand `{which} = {{ shape = ... }}`")))?;
        let d = o.get_ref();
        csg_node(cx, &ShapeFields::of(o), node_from * placement(d.scale.as_ref(), d.rotate, d.translate), nodes)
    };
    let a = operand("a", f.a)?;
    let b = operand("b", f.b)?;
    nodes.push(CsgNode::Op { op: op_kind, a, b });
    Ok((nodes.len() - 1) as u32)
}

fn vec3(v: [Num; 3]) -> Vec3 {
    Vec3::new(v[0].0, v[1].0, v[2].0)
}

fn dvec3(v: [Exact; 3]) -> DVec3 {
    DVec3::new(v[0].0, v[1].0, v[2].0)
}

/// The mesh object `o` describes.
fn mesh_shape(
    cx: &Ctx<'_>,
    o: &Spanned<ObjectDoc>,
    meshes: &mut Meshes,
    resolve: Resolver<'_>,
    warnings: &mut Vec<Warning>,
) -> Result<Shape, LoadError> {
    let obj = o.get_ref();
    let path = obj.path.as_ref().ok_or_else(|| {
        cx.err(
            o.span(),
            LoadErrorKind::Syntax("a mesh needs `path = \"file.obj\"` (relative to the scene file)".into()),
        )
    })?;
    for (key, span) in [("minor", obj.minor.as_ref().map(|x| x.span())), ("op", obj.op.as_ref().map(|x| x.span()))] {
        if let Some(span) = span {
            return Err(cx.err(span, LoadErrorKind::Syntax(format!("`{key}` does not apply to a mesh"))));
        }
    }
    Ok(Shape::Mesh(meshes.load(cx, path, resolve, warnings)?))
}

/// Meshes loaded so far, each file once (objects that share a file share the mesh).
struct Meshes {
    by_path: HashMap<String, std::sync::Arc<Mesh>>,
    /// Their triangles, as fanned from their faces.
    triangles: usize,
    /// The most they may have together ([`Limits::max_triangles`]).
    limit: usize,
}

impl Meshes {
    fn load(
        &mut self,
        cx: &Ctx<'_>,
        path: &Spanned<String>,
        resolve: Resolver<'_>,
        warnings: &mut Vec<Warning>,
    ) -> Result<std::sync::Arc<Mesh>, LoadError> {
        if let Some(m) = self.by_path.get(path.get_ref()) {
            return Ok(m.clone());
        }
        let bad = |msg: String| cx.err(path.span(), LoadErrorKind::Syntax(format!("mesh `{}`: {msg}", path.get_ref())));
        let bytes = resolve(path.get_ref()).map_err(bad)?;
        if bytes.starts_with(&[0xFE, 0xFF]) || bytes.starts_with(&[0xFF, 0xFE]) {
            return Err(bad("the file is UTF-16 text; save it as UTF-8 or ASCII".into()));
        }
        let budget = crate::obj::Budget { limit: self.limit, earlier: self.triangles };
        let obj = crate::obj::parse(&bytes, budget).map_err(|e| match e.column {
            // Past the budget: where in the OBJ file, and what to raise.
            Some(column) => bad(format!("{}:{}:{column}: {}", path.get_ref(), e.line, e.message)),
            None => bad(format!("not a readable OBJ file (line {}: {})", e.line, e.message)),
        })?;
        drop(bytes);
        self.triangles += obj.triangles.len();
        if let Some(line) = obj.mixed {
            warnings.push(cx.warn(
                path.span(),
                format!(
                    "mesh `{}`: line {line} gives its corners normals or texture coordinates differently from the \
                     faces before it; they are ignored for the whole mesh (flat shading, no texture coordinates)",
                    path.get_ref()
                ),
            ));
        }
        if obj.replaced > 0 {
            warnings.push(cx.warn(
                path.span(),
                format!(
                    "mesh `{}`: {} normal or texture coordinate line{} with numbers that are not finite (such as \
                     `nan`) read as zero",
                    path.get_ref(),
                    obj.replaced,
                    if obj.replaced > 1 { "s" } else { "" }
                ),
            ));
        }
        let (positions, normals, uvs, triangles) = one_index(obj);
        let before = triangles.len();
        if before == 0 {
            return Err(bad("the file has no faces (`f` lines): nothing to render".into()));
        }
        // Renderers skip triangles with no area (real files have a few): say how many.
        let (mesh, skipped) = match Mesh::skipping_degenerate(positions, normals, uvs, triangles) {
            Ok(built) => built,
            Err(MeshError::Empty) => {
                return Err(bad(format!("every triangle ({before}) is degenerate (its corners are on one line)")));
            }
            Err(e) => return Err(bad(e.to_string())),
        };
        if skipped > 0 {
            warnings.push(cx.warn(
                path.span(),
                format!(
                    "mesh `{}`: {skipped} degenerate triangle{} (corners on one line) skipped of {before}",
                    path.get_ref(),
                    if skipped > 1 { "s" } else { "" }
                ),
            ));
        }
        let mesh = std::sync::Arc::new(mesh);
        self.by_path.insert(path.get_ref().clone(), mesh.clone());
        Ok(mesh)
    }
}

/// A mesh's arrays with one index per corner for positions, normals and texture coordinates:
/// the file's own when it indexes them alike, else a vertex for each distinct combination
/// (found by sorting the corners, not hashing them).
fn one_index(obj: crate::obj::Obj) -> (Vec<Vec3>, Vec<Vec3>, Vec<glam::Vec2>, Vec<[u32; 3]>) {
    let crate::obj::Obj { positions, normals, uvs, triangles, normal_triangles, uv_triangles, .. } = obj;
    // Normals and texture coordinates count only where every face refers to them: a file may
    // list `vn` lines its faces never use.
    let (smooth, textured) = (!normal_triangles.is_empty(), !uv_triangles.is_empty());
    let alike =
        |other: &[[u32; 3]], len: usize| other.is_empty() || (other == triangles.as_slice() && len == positions.len());
    if alike(&normal_triangles, normals.len()) && alike(&uv_triangles, uvs.len()) {
        let normals = if smooth { normals } else { Vec::new() };
        let uvs = if textured { uvs } else { Vec::new() };
        return (positions, normals, uvs, triangles);
    }
    let corners = 3 * triangles.len();
    let at = |list: &[[u32; 3]], k: usize| if list.is_empty() { 0 } else { list[k / 3][k % 3] };
    let key = |k: usize| (at(&triangles, k), at(&normal_triangles, k), at(&uv_triangles, k));
    let mut order: Vec<u32> = (0..corners as u32).collect();
    order.sort_unstable_by_key(|&k| (key(k as usize), k));
    let (mut p, mut n, mut t) = (Vec::new(), Vec::new(), Vec::new());
    let mut out = vec![[0u32; 3]; triangles.len()];
    let mut last = None;
    for &k in &order {
        let (pi, ni, ti) = key(k as usize);
        if last != Some((pi, ni, ti)) {
            last = Some((pi, ni, ti));
            p.push(positions[pi as usize]);
            if smooth {
                n.push(normals[ni as usize]);
            }
            if textured {
                t.push(uvs[ti as usize]);
            }
        }
        out[k as usize / 3][k as usize % 3] = (p.len() - 1) as u32;
    }
    (p, n, t, out)
}

/// A texture file's contents and the index of its decoded texture.
type Decoded = (Vec<u8>, u32);

/// Texture images loaded so far, each file once.
struct Textures<'r> {
    list: Vec<Texture>,
    /// By the path as the scene wrote it.
    by_path: HashMap<String, u32>,
    /// By the file's contents (their hash and length): the same file named two ways
    /// (`a.png`, `./a.png`) or copied is decoded once.
    by_contents: HashMap<(u64, usize), Vec<Decoded>>,
    resolve: Resolver<'r>,
    /// Pixels the textures loaded so far hold.
    used: u64,
    /// The most pixels they may hold together.
    budget: u64,
}

impl Textures<'_> {
    fn load(&mut self, cx: &Ctx<'_>, path: &Spanned<String>) -> Result<u32, LoadError> {
        if let Some(&i) = self.by_path.get(path.get_ref()) {
            return Ok(i);
        }
        let bad =
            |msg: String| cx.err(path.span(), LoadErrorKind::Syntax(format!("texture `{}`: {msg}", path.get_ref())));
        let bytes = (self.resolve)(path.get_ref()).map_err(bad)?;
        let key = {
            use std::hash::{Hash, Hasher};
            let mut h = std::collections::hash_map::DefaultHasher::new();
            bytes.hash(&mut h);
            (h.finish(), bytes.len())
        };
        // The same contents, compared byte for byte (a hash alone could mistake one for another).
        let known = self.by_contents.get(&key).and_then(|same| same.iter().find(|(b, _)| *b == bytes)).map(|e| e.1);
        let i = match known {
            Some(i) => i,
            None => {
                let texture = crate::texture::decode(&bytes, self.used, self.budget).map_err(bad)?;
                self.used += texture.width as u64 * texture.height as u64;
                self.list.push(texture);
                let i = (self.list.len() - 1) as u32;
                self.by_contents.entry(key).or_default().push((bytes, i));
                i
            }
        };
        self.by_path.insert(path.get_ref().clone(), i);
        Ok(i)
    }
}

fn material(
    cx: &Ctx<'_>,
    m: &MaterialDoc,
    textures: &mut Textures<'_>,
    warnings: &mut Vec<Warning>,
) -> Result<Material, LoadError> {
    let (color, pattern) = match m.color.get_ref() {
        ColorDoc::Solid(c) => (Vec3::from(*c), Pattern::Solid),
        ColorDoc::Pattern(p) => pattern(cx, p, m.color.span(), textures)?,
    };
    let brightest = match pattern {
        Pattern::Checker { other, .. } => color.max(other),
        _ => color,
    };
    if brightest.max_element() > 1.0 {
        warnings.push(cx.warn(
            m.color.span(),
            format!(
                "a material colour above 1 ({}): a surface reflects more light than it receives; the handout's colours are in [0, 1]",
                brightest.max_element()
            ),
        ));
    }
    Ok(Material { color, pattern, ambi: m.ambi, diff: m.diff, spec: m.spec, shine: m.shine, alpha: m.alpha, n: m.n })
}

const PATTERNS: [&str; 2] = ["checker", "image"];

fn pattern(
    cx: &Ctx<'_>,
    p: &PatternDoc,
    at: Range<usize>,
    textures: &mut Textures<'_>,
) -> Result<(Vec3, Pattern), LoadError> {
    let syntax = |span: Range<usize>, msg: String| cx.err(span, LoadErrorKind::Syntax(msg));
    let scale = match &p.scale {
        None => 1.0,
        // As an object's scale: a cell of 1e-38 units turns every coordinate into infinity.
        Some(s) if (1e-6..=1e6).contains(&s.get_ref().0) => s.get_ref().0,
        Some(s) => {
            return Err(syntax(s.span(), format!("`scale` must be between 1e-6 and 1e6, found {}", s.get_ref().0)));
        }
    };
    let unused = |key: &str, span: Option<Range<usize>>| match span {
        Some(span) => Err(syntax(span, format!("a {} pattern has no `{key}`", p.pattern.get_ref()))),
        None => Ok(()),
    };
    match p.pattern.get_ref().as_str() {
        "checker" => {
            unused("path", p.path.as_ref().map(|x| x.span()))?;
            let colors = p
                .colors
                .as_ref()
                .ok_or_else(|| syntax(at.clone(), "a checker needs `colors = [[r, g, b], [r, g, b]]`".into()))?;
            let [a, b] = colors.get_ref().map(|c| Vec3::new(c[0].0, c[1].0, c[2].0));
            if a.min(b).min_element() < 0.0 {
                return Err(syntax(colors.span(), "expected colours with no negative channel".into()));
            }
            Ok((a, Pattern::Checker { other: b, scale }))
        }
        "image" => {
            unused("colors", p.colors.as_ref().map(|x| x.span()))?;
            let path = p
                .path
                .as_ref()
                .ok_or_else(|| syntax(at.clone(), "an image pattern needs `path = \"file.png\"`".into()))?;
            let texture = textures.load(cx, path)?;
            Ok((Vec3::ONE, Pattern::Image { texture, scale }))
        }
        other => {
            let hint =
                lancer_shading::nearest(other, PATTERNS).map(|n| format!(" (did you mean `{n}`?)")).unwrap_or_default();
            let msg = format!("unknown pattern `{other}`{hint}; known patterns: {}", PATTERNS.join(", "));
            Err(syntax(p.pattern.span(), msg))
        }
    }
}

/// The span of a name: its own in table form, the whole entry's for a bare string.
fn name_span(entry: &Spanned<NamedDoc>) -> Range<usize> {
    let own = entry.get_ref().name.span();
    if own.is_empty() { entry.span() } else { own }
}

fn params(cx: &Ctx<'_>, entry: &NamedDoc) -> Result<Params, LoadError> {
    let mut out = Vec::new();
    for (k, v) in &entry.params {
        let value = match v.get_ref() {
            toml::Value::Integer(i) => ParamValue::Number(*i as f64),
            toml::Value::Float(f) if f.is_finite() => ParamValue::Number(*f),
            toml::Value::Boolean(b) => ParamValue::Bool(*b),
            toml::Value::String(s) => ParamValue::Text(s.clone()),
            other => {
                let what = match other {
                    toml::Value::Float(_) => "a non-finite number",
                    toml::Value::Array(_) => "an array",
                    toml::Value::Table(_) => "a table",
                    _ => "a date",
                };
                return Err(cx.err(
                    v.span(),
                    LoadErrorKind::Syntax(format!(
                        "parameter `{}`: expected a finite number, boolean or string, found {what}",
                        k.get_ref()
                    )),
                ));
            }
        };
        out.push((k.get_ref().clone(), value));
    }
    Ok(Params::new(out))
}

/// Where a model error points: the parameter it names if any, else the name.
fn model_err(cx: &Ctx<'_>, entry: &Spanned<NamedDoc>, e: lancer_shading::ModelError) -> LoadError {
    use lancer_shading::ModelError as M;
    let doc = entry.get_ref();
    let param_span = |p: &str| doc.params.iter().find(|(k, _)| k.get_ref() == p).map(|(k, _)| k.span());
    let span = match &e {
        M::UnknownParam { param, .. } => param_span(param),
        M::BadParam { error, .. } => {
            doc.params.iter().find(|(k, _)| *k.get_ref() == error.param).map(|(_, v)| v.span())
        }
        M::UnknownVariant { .. } => doc.variant.as_ref().map(|v| v.span()).filter(|s| !s.is_empty()),
        _ => None,
    };
    // Parameters written inside a string (`"soft:samples=0"`) have no span of their own.
    cx.err(span.filter(|s| !s.is_empty()).unwrap_or_else(|| name_span(entry)), LoadErrorKind::Model(e))
}

/// The shadow model `entry` names.
fn shadow_model(cx: &Ctx<'_>, entry: &Spanned<NamedDoc>, registry: &Registry) -> Result<NamedShadow, LoadError> {
    let doc = entry.get_ref();
    if doc.key.as_deref() == Some("term") || doc.variant.is_some() {
        let at = doc.variant.as_ref().map(|v| v.span()).filter(|s| !s.is_empty()).unwrap_or_else(|| name_span(entry));
        return Err(cx.err(
            at,
            LoadErrorKind::Syntax("a shadow model is named with `model = \"...\"` and has no variant".into()),
        ));
    }
    registry.build_shadow(doc.name.get_ref(), params(cx, doc)?).map_err(|e| model_err(cx, entry, e))
}

/// The term `entry` names.
fn term(cx: &Ctx<'_>, entry: &Spanned<NamedDoc>, registry: &Registry) -> Result<NamedTerm, LoadError> {
    let doc = entry.get_ref();
    if doc.key.as_deref() == Some("model") {
        return Err(cx.err(name_span(entry), LoadErrorKind::Syntax("a term is named with `term = \"...\"`".into())));
    }
    let variant = doc.variant.as_ref().map(|v| v.get_ref().as_str());
    registry.build_term(doc.name.get_ref(), variant, params(cx, doc)?).map_err(|e| model_err(cx, entry, e))
}

/// The pipeline `m` describes; what it leaves out comes from `base`, else has its default.
fn build_pipeline(
    cx: &Ctx<'_>,
    m: &ModelDoc,
    registry: &Registry,
    base: Option<Pipeline>,
) -> Result<Pipeline, LoadError> {
    let (base_depth, base_shadows, base_terms) = match base {
        Some(p) => (Some(p.max_depth), Some(p.shadows), Some(p.terms)),
        None => (None, None, None),
    };
    let max_depth = m.max_depth.or(base_depth).unwrap_or(crate::doc::DEFAULT_DEPTH);
    // The shadow model's and each term's errors, all kept.
    let mut errors = Errors::default();
    let default_shadows = || {
        registry
            .build_shadow(lancer_shading::shadows::DEFAULT, Params::default())
            .expect("the default shadow model exists")
    };
    let shadows = match &m.shadows {
        None => base_shadows.unwrap_or_else(default_shadows),
        Some(entry) => errors.keep(shadow_model(cx, entry, registry)).unwrap_or_else(default_shadows),
    };
    let terms = match &m.terms {
        None => {
            errors.or(())?;
            return Pipeline::new(max_depth, shadows, base_terms.unwrap_or_else(|| registry.default_terms()))
                .map_err(|e| cx.err(0..0, LoadErrorKind::Model(e)));
        }
        Some(list) => list,
    };
    let mut built = Vec::with_capacity(terms.len());
    for entry in terms {
        if let Some(t) = errors.keep(term(cx, entry, registry)) {
            built.push(t);
        }
    }
    errors.or(())?;
    Pipeline::new(max_depth, shadows, built).map_err(|e| {
        let dup = terms
            .iter()
            .enumerate()
            .find(|(i, t)| terms[..*i].iter().any(|u| u.get_ref().name.get_ref() == t.get_ref().name.get_ref()));
        cx.err(dup.map_or(0..0, |(_, t)| name_span(t)), LoadErrorKind::Model(e))
    })
}
