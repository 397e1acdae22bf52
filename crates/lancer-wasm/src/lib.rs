//! Lancer's renderer for the browser: the studio's engine compiled to WebAssembly. The page
//! (`lancer-studio`'s, the same one `lancer serve` sends) runs one [`Engine`] per Web Worker,
//! each rendering an interleaved share of the image's bands exactly as `lancer render --tile I/N`
//! does, and one more on its own thread for what is not a render (loading errors, the pixel
//! inspector, the edited text, image downloads). Nothing here reads a file or a clock or starts a
//! thread: the page hands over the scene's text and the bytes of the files it names.

use lancer_scene::Limits;
use lancer_shading::Registry;
use lancer_studio::State;
use lancer_studio::session::{Applied, SceneError, Session};
use wasm_bindgen::prelude::*;

#[wasm_bindgen]
extern "C" {
    #[wasm_bindgen(js_namespace = console)]
    fn error(message: &str);
}

/// The files a scene names, as the page hands them over: `index` is a JSON list of
/// `[name, offset, length]` into `blob`.
struct Files<'a> {
    entries: Vec<(String, usize, usize)>,
    blob: &'a [u8],
}

impl<'a> Files<'a> {
    fn parse(index: &str, blob: &'a [u8]) -> Result<Files<'a>, String> {
        let entries: Vec<(String, usize, usize)> =
            serde_json::from_str(index).map_err(|e| format!("the page's list of files: {e}"))?;
        if let Some((name, ..)) =
            entries.iter().find(|(_, at, len)| at.checked_add(*len).is_none_or(|end| end > blob.len()))
        {
            return Err(format!("the page's list of files: `{name}` lies outside the bytes given"));
        }
        Ok(Files { entries, blob })
    }

    /// The bytes of the file a scene names `path`: the file of that path, or else the only one
    /// of that file name (a file dropped on the page has no folder).
    fn get(&self, path: &str) -> Result<Vec<u8>, String> {
        let base = |p: &str| p.rsplit(['/', '\\']).next().unwrap_or(p).to_owned();
        let exact = self.entries.iter().find(|(name, ..)| name == path);
        let by_name: Vec<_> = self.entries.iter().filter(|(name, ..)| base(name) == base(path)).collect();
        let found = exact.or(match by_name.as_slice() {
            [one] => Some(*one),
            _ => None,
        });
        match found {
            Some((_, at, len)) => Ok(self.blob[*at..at + len].to_vec()),
            None if by_name.len() > 1 => Err(format!("cannot tell which of the files named `{}` is meant", base(path))),
            None => Err(format!("cannot read `{path}`: open it with the scene (or drop it on the page beside it)")),
        }
    }
}

fn state(json: &str) -> Result<State, String> {
    serde_json::from_str(json).map_err(|e| format!("the page's state: {e}"))
}

/// The message of the last panic (a bug): a panic traps the instance, and the page reads this
/// to say what went wrong before it replaces the instance.
static LAST_PANIC: std::sync::Mutex<String> = std::sync::Mutex::new(String::new());

/// The last panic's message (empty when none happened).
#[wasm_bindgen]
pub fn last_panic() -> String {
    LAST_PANIC.lock().map(|m| m.clone()).unwrap_or_default()
}

/// One engine: a registry of the built-in terms, the scene loaded last and the state applied
/// last (a worker renders one state band after band: it is applied once).
#[wasm_bindgen]
pub struct Engine {
    registry: Registry,
    session: Option<Session>,
    applied: Option<(String, Applied)>,
}

/// A render's result: a JSON header and the floats of every layer.
#[wasm_bindgen]
pub struct Rendered {
    header: String,
    /// Each layer's pixels, taken one by one by [`Rendered::layer`].
    layers: Vec<Vec<glam::Vec3>>,
}

#[wasm_bindgen]
impl Rendered {
    /// `width`, `height` (the whole image's), `rows` (the rows held), `bands` (which bands of
    /// [`lancer_shading::TILE`] rows, in order), `layers` (their names, in model order, the
    /// background last) and the ray counts.
    pub fn header(&self) -> String {
        self.header.clone()
    }

    /// Layer `index`'s floats (in the order of the header's `layers`): `rows` x `width` linear
    /// RGB triples. Taken once: the pixels go to JavaScript with one copy, none made here.
    pub fn layer(&mut self, index: usize) -> Result<Vec<f32>, String> {
        let pixels = self.layers.get_mut(index).ok_or_else(|| format!("there is no layer {index}"))?;
        // Vec3 is three f32 (size 12, align 4): its buffer is reinterpreted, never copied.
        bytemuck::allocation::try_cast_vec(std::mem::take(pixels)).map_err(|(e, _)| format!("layer {index}: {e:?}"))
    }
}

impl Default for Engine {
    fn default() -> Engine {
        Engine::new()
    }
}

#[wasm_bindgen]
impl Engine {
    /// An engine with the built-in terms and no scene.
    #[wasm_bindgen(constructor)]
    pub fn new() -> Engine {
        // A panic (a bug) traps the instance; its message goes to the console first.
        std::panic::set_hook(Box::new(|info| {
            let message = format!("lancer: {info}");
            error(&message);
            if let Ok(mut last) = LAST_PANIC.lock() {
                *last = message;
            }
        }));
        Engine { registry: Registry::with_builtins(), session: None, applied: None }
    }

    /// Whether this module was built with WebAssembly SIMD (128-bit vectors).
    pub fn simd() -> bool {
        cfg!(target_feature = "simd128")
    }

    /// Loads the scene `name` whose text is `source`, with the files it names (`index` and
    /// `blob`, see [`Files`]): the page's hello as JSON, or the located error as JSON (`file`,
    /// `line`, `column`, `message`). The previous scene stays loaded when this one fails.
    pub fn load(&mut self, name: &str, source: &str, index: &str, blob: &[u8]) -> Result<String, String> {
        let fail = |message: String| SceneError { file: name.to_owned(), line: 0, column: 0, message };
        let json = |e: SceneError| serde_json::to_string(&e).unwrap_or_default();
        let files = Files::parse(index, blob).map_err(|m| json(fail(m)))?;
        let session =
            Session::load(&self.registry, name, source, &|p: &str| files.get(p), &Limits::default()).map_err(json)?;
        let hello = session.hello().to_string();
        self.session = Some(session);
        self.applied = None;
        Ok(hello)
    }

    fn session(&self) -> Result<&Session, String> {
        self.session.as_ref().ok_or_else(|| "no scene is loaded".to_owned())
    }

    /// Renders the state `state_json` (the page's JSON): the coarse or full image, its bands of
    /// part `part` of `parts` (`lancer render --tile PART/PARTS`), or the whole image when
    /// `parts` is 0.
    pub fn render(&mut self, state_json: &str, coarse: bool, part: u32, parts: u32) -> Result<Rendered, String> {
        let session = self.session.as_ref().ok_or_else(|| "no scene is loaded".to_owned())?;
        let state = state(state_json)?;
        if parts > 0 && part >= parts {
            return Err(format!("part {part} of {parts}: parts are numbered from 0"));
        }
        let split = (parts > 0).then_some((part, parts));
        if self.applied.as_ref().is_none_or(|(json, _)| json != state_json) {
            self.applied = Some((state_json.to_owned(), session.apply(&state)?));
        }
        let (_, applied) = self.applied.as_ref().expect("applied just above");
        let frame = session.render_applied(applied, &state, coarse, split);
        let image = session.image(&state, coarse);
        let bands: Vec<u32> = match split {
            Some((i, n)) => lancer_shading::part_bands(image.height, i, n).collect(),
            None => (0..image.height.div_ceil(lancer_shading::TILE)).collect(),
        };
        let names: Vec<&str> = frame.layers.iter().map(|l| l.name.as_str()).collect();
        let header = serde_json::json!({
            "width": frame.width,
            "height": image.height,
            "rows": frame.height,
            "bands": bands,
            "tile": lancer_shading::TILE,
            "layers": names,
            "rays": frame.stats.total(),
        })
        .to_string();
        Ok(Rendered { header, layers: frame.layers.into_iter().map(|l| l.pixels).collect() })
    }

    /// Pixel `(x, y)` of the full image of the state explained, as `lancer explain --json`.
    pub fn explain(&self, state_json: &str, x: u32, y: u32) -> Result<String, String> {
        self.session()?.explain(&state(state_json)?, x, y)
    }

    /// The scene's text with the state's edits written in.
    pub fn edited(&self, state_json: &str) -> Result<String, String> {
        self.session()?.edited(&state(state_json)?)
    }

    /// A linear image (`width` x `height` RGB floats) as the bytes of a file: `png` (sRGB
    /// 8-bit) or `exr` (linear float), the bytes `lancer render` writes for the same pixels.
    pub fn encode(format: &str, width: u32, height: u32, floats: &[f32]) -> Result<Vec<u8>, String> {
        if !floats.len().is_multiple_of(3) {
            return Err("an image is RGB triples".into());
        }
        let pixels: Vec<glam::Vec3> = floats.chunks_exact(3).map(glam::Vec3::from_slice).collect();
        match format {
            "png" => lancer_output::encode_png(width, height, &pixels),
            "exr" => lancer_output::encode_exr(width, height, &pixels),
            other => return Err(format!("no image format `{other}`: png or exr")),
        }
        .map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::Files;

    #[test]
    fn a_file_is_found_by_its_path_or_else_by_its_only_name() {
        let blob = b"onetwothree";
        let files =
            Files::parse(r#"[["meshes/a.obj", 0, 3], ["b.png", 3, 3], ["x/c.obj", 6, 5], ["y/c.obj", 6, 5]]"#, blob)
                .unwrap();
        assert_eq!(files.get("meshes/a.obj").unwrap(), b"one");
        assert_eq!(files.get("../textures/b.png").unwrap(), b"two", "dropped without its folder");
        assert_eq!(files.get("x/c.obj").unwrap(), b"three");
        assert!(files.get("c.obj").unwrap_err().contains("which of the files named `c.obj`"));
        assert!(files.get("d.obj").unwrap_err().contains("cannot read `d.obj`"));
        assert!(Files::parse(r#"[["a", 5, 7]]"#, blob).is_err(), "past the end");
        assert!(Files::parse(r#"[["a", 18446744073709551615, 2]]"#, blob).is_err(), "an overflow");
    }
}
