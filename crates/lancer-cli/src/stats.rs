//! What a render did, in words and as JSON: the effective model, ray counts by kind (in the words
//! of POV-Ray's statistics where they match), time per system, rays per second per thread. The
//! same document is `--stats-json` and the manifest written beside the `--aov` images.

use std::fmt::Write;
use std::time::Duration;

use lancer_core::{ImageSettings, RenderStats};
use lancer_output::Ordered;
use lancer_shading::{ParamValue, Pipeline};
use serde::Serialize;

/// `name {k = v, ...}` or just `name`.
fn with_params(name: &str, params: &[(String, ParamValue)]) -> String {
    if params.is_empty() {
        return name.to_owned();
    }
    let list: Vec<String> = params.iter().map(|(k, v)| format!("{k} = {v}")).collect();
    format!("{name} {{ {} }}", list.join(", "))
}

/// The model as it was rendered: every term with its variant and parameters, the shadow model
/// with its parameters, the depth, and the samples per pixel.
pub fn effective_model(pipeline: &Pipeline, image: &ImageSettings) -> String {
    let terms: Vec<String> =
        pipeline.terms.iter().map(|t| with_params(&format!("{}:{}", t.name, t.variant), &t.params)).collect();
    let samples = match image.adaptive {
        Some(a) => format!("adaptive samples (threshold {}, depth {})", a.threshold, a.depth),
        None => format!("{} sample{} per pixel", image.samples.max(1), if image.samples > 1 { "s" } else { "" }),
    };
    format!(
        "terms {}; shadows {}; max_depth {}; {samples}",
        terms.join(", "),
        with_params(&pipeline.shadows.name, &pipeline.shadows.params),
        pipeline.max_depth,
    )
}

/// The name POV-Ray's statistics give the rays a term spawns.
fn kind_of(term: &str) -> String {
    match term {
        "mirror" => "Reflected Rays".to_owned(),
        "refraction" => "Refracted Rays".to_owned(),
        other => format!("Rays spawned by {other}"),
    }
}

/// A finished render, ready to be reported.
pub struct Run<'a> {
    /// How the scene is named.
    pub scene: &'a str,
    /// The image settings.
    pub image: &'a ImageSettings,
    /// The model.
    pub pipeline: &'a Pipeline,
    /// The render's counts and times.
    pub stats: &'a RenderStats,
    /// Wall time of the render.
    pub elapsed: Duration,
    /// Worker threads.
    pub threads: usize,
}

impl Run<'_> {
    fn rays_per_thread_second(&self) -> f64 {
        self.stats.total() as f64 / (self.elapsed.as_secs_f64() * self.threads as f64).max(1e-9)
    }

    /// The statistics block `--stats` prints.
    pub fn text(&self) -> String {
        let (s, img) = (self.stats, self.image);
        let pixels = img.width as u64 * img.height as u64;
        let line = "-".repeat(76);
        let mut out = String::new();
        let _ = writeln!(out, "Render Statistics");
        let _ = writeln!(out, "Image Resolution {} x {}", img.width, img.height);
        let _ = writeln!(out, "Model: {}", effective_model(self.pipeline, img));
        let _ = writeln!(out, "{line}");
        let _ = writeln!(
            out,
            "Pixels:  {pixels:>12}   Samples: {:>12}   Smpls/Pxl: {:.2}",
            s.camera_rays,
            s.camera_rays as f64 / pixels.max(1) as f64
        );
        let _ = writeln!(out, "Rays:    {:>12}   Max Level: {}/{}", s.total(), s.max_level, self.pipeline.max_depth);
        if let Some(a) = self.image.adaptive {
            let _ = writeln!(
                out,
                "Supersampled: {:>7} pixels ({:.1} %) at {} samples ({} rays) each (threshold {}, depth {}); \
                 {} camera rays traced again around the tiles",
                s.supersampled,
                100.0 * s.supersampled as f64 / pixels.max(1) as f64,
                a.samples(),
                a.rays(),
                a.threshold,
                a.depth,
                s.border_rays
            );
        }
        let _ = writeln!(out, "{line}");
        let _ = writeln!(out, "{:<28}{:>12}", "Camera Rays:", s.camera_rays);
        for (term, count) in self.pipeline.terms.iter().zip(&s.spawned) {
            if *count > 0 {
                let _ = writeln!(out, "{:<28}{count:>12}   ({} term)", format!("{}:", kind_of(&term.name)), term.name);
            }
        }
        let _ = writeln!(
            out,
            "{:<28}{:>12}   ({} shadows)",
            "Shadow Ray Tests:", s.shadow_rays, self.pipeline.shadows.name
        );
        let _ = writeln!(out, "{line}");
        let times = &s.times;
        let total = times.total().as_secs_f64().max(1e-12);
        let _ = writeln!(out, "Time per system (thread-seconds over {} thread(s)):", self.threads);
        let mut row = |name: &str, d: Duration| {
            let _ = writeln!(out, "  {name:<26}{:>9.3} s {:>6.1} %", d.as_secs_f64(), 100.0 * d.as_secs_f64() / total);
        };
        row("camera rays", times.camera);
        row("trace (closest hits)", times.trace);
        row("visibility (shadow rays)", times.visibility);
        row("background", times.background);
        for (term, d) in self.pipeline.terms.iter().zip(&times.terms) {
            row(&format!("term {}", term.name), *d);
        }
        row("ray chunks and tiles", times.chunks);
        let _ = writeln!(out, "{line}");
        let _ = writeln!(
            out,
            "Trace Time: {:.3} seconds using {} thread(s) ({:.3} thread-seconds in systems)",
            self.elapsed.as_secs_f64(),
            self.threads,
            times.total().as_secs_f64()
        );
        let _ = writeln!(out, "Rays per second per thread: {:.2} M", self.rays_per_thread_second() / 1e6);
        out
    }

    /// The same as JSON; `files` lists the images written beside it (for the `--aov` manifest).
    pub fn json(&self, files: &[String]) -> String {
        let (s, img, p) = (self.stats, self.image, self.pipeline);
        let secs = |d: &Duration| d.as_secs_f64();
        let doc = Doc {
            generator: GENERATOR,
            scene: self.scene,
            width: img.width,
            height: img.height,
            samples_per_pixel: img.samples.max(1),
            adaptive: img.adaptive.map(|a| Adaptive {
                threshold: a.threshold,
                depth: a.depth,
                supersampled_pixels: s.supersampled,
                border_rays: s.border_rays,
            }),
            model: Model {
                summary: effective_model(p, img),
                terms: p
                    .terms
                    .iter()
                    .map(|t| Named { name: &t.name, variant: Some(&t.variant), params: Params(&t.params) })
                    .collect(),
                shadows: Named { name: &p.shadows.name, variant: None, params: Params(&p.shadows.params) },
                max_depth: p.max_depth,
            },
            rays: Rays {
                camera: s.camera_rays,
                secondary: s.secondary_rays,
                shadow: s.shadow_rays,
                total: s.total(),
                spawned_by_term: p.terms.iter().zip(&s.spawned).map(|(t, n)| (t.name.as_str(), *n)).collect(),
            },
            max_level: s.max_level,
            render_seconds: self.elapsed.as_secs_f64(),
            threads: self.threads,
            rays_per_second_per_thread: self.rays_per_thread_second(),
            system_thread_seconds: Systems {
                camera: secs(&s.times.camera),
                trace: secs(&s.times.trace),
                visibility: secs(&s.times.visibility),
                background: secs(&s.times.background),
                terms: p.terms.iter().zip(&s.times.terms).map(|(t, d)| (t.name.as_str(), secs(d))).collect(),
                chunks: secs(&s.times.chunks),
            },
            files,
        };
        serde_json::to_string_pretty(&doc).expect("plain data serialises")
    }
}

/// Adaptive anti-aliasing's settings and how many pixels it supersampled.
#[derive(Serialize)]
struct Adaptive {
    threshold: f32,
    depth: u32,
    supersampled_pixels: u64,
    border_rays: u64,
}

/// What `Doc::generator` says: a manifest of Lancer's, whose `files` Lancer may remove.
pub const GENERATOR: &str = "lancer";

#[derive(Serialize)]
struct Doc<'a> {
    generator: &'static str,
    scene: &'a str,
    width: u32,
    height: u32,
    samples_per_pixel: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    adaptive: Option<Adaptive>,
    model: Model<'a>,
    rays: Rays<'a>,
    max_level: u8,
    render_seconds: f64,
    threads: usize,
    rays_per_second_per_thread: f64,
    system_thread_seconds: Systems<'a>,
    #[serde(skip_serializing_if = "<[String]>::is_empty")]
    files: &'a [String],
}

#[derive(Serialize)]
struct Model<'a> {
    summary: String,
    terms: Vec<Named<'a>>,
    shadows: Named<'a>,
    max_depth: u8,
}

#[derive(Serialize)]
struct Named<'a> {
    name: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    variant: Option<&'a str>,
    params: Params<'a>,
}

/// Parameters as a JSON object.
struct Params<'a>(&'a [(String, ParamValue)]);

impl Serialize for Params<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in self.0 {
            match v {
                ParamValue::Number(x) => map.serialize_entry(k, x)?,
                ParamValue::Bool(b) => map.serialize_entry(k, b)?,
                ParamValue::Text(t) => map.serialize_entry(k, t)?,
            }
        }
        map.end()
    }
}

#[derive(Serialize)]
struct Rays<'a> {
    camera: u64,
    secondary: u64,
    shadow: u64,
    total: u64,
    spawned_by_term: Ordered<'a, u64>,
}

#[derive(Serialize)]
struct Systems<'a> {
    camera: f64,
    trace: f64,
    visibility: f64,
    background: f64,
    terms: Ordered<'a, f64>,
    chunks: f64,
}
