//! `lancer diagnose SCENE --image STUDENT.png`: which classic mistake of the course, if any,
//! explains a student's image of a scene. The scene is rendered with the right model and with
//! each mistake of the catalogue that can be made in it ([`catalogue`]: mistaken term variants
//! and shadow models from the registry, and the image writer's [`output`] mistakes); each
//! render is compared with the image where it differs from the right one ([`decide`]), and the
//! first line of the report is `verdict: NAME` (`correct`, a mistake's name such as
//! `specular:sign`, or `unclear`), then the evidence and a hint in the course's words.
//!
//! `--term T` diagnoses one term's image against that term's layer; `--aov DIR` reads a folder
//! of per-term images (`<term>.png`, `.exr`, `.ppm`, `beauty.*`) and compares every layer it
//! holds. Images are read by `lancer diff`'s readers (PNG, OpenEXR, PPM, PGM) and compared in
//! its display domain. Exit codes: 0 correct, 1 a mistake or unclear, 2 bad input.

pub(crate) mod catalogue;
pub(crate) mod decide;
pub(crate) mod output;

pub(crate) use output::OutputMistake;

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::Vec3;
use lancer_shading::{Pipeline, Registry, RenderOptions};
use serde::Serialize;

use crate::diff::read::{self, Image};
use catalogue::{Entry, Kind};
use decide::{Score, Verdict, db};

/// The most mistakes looked for in one image: the verdict's and two more made with it.
const MOST_MISTAKES: usize = 3;

/// The largest image file read, in MB (as `lancer diff`'s default).
const MAX_IMAGE_MB: u64 = 1024;

/// What `lancer diagnose --help` says after the flags.
const AFTER_HELP: &str = "\
The scene is rendered at the image's size (it must have the scene's shape, or be the size
--width and --height give) with the right model and with each mistake of the catalogue that
the model can make (`lancer terms --mistakes` lists them). Where a mistake's render differs
from the right one, the image must be at least 6 dB closer to it than to the right model,
and within 30 dB of it, for the mistake to explain the image; the verdict is the mistake
that explains it best over the whole image (unclear if another is within 1 dB). With no
mistake explaining it, the image is correct when the right model's PSNR is at least 45 dB,
or at least 30 dB and above every mistake's; else unclear. Everything is compared in the
display domain (sRGB-encoded values clamped to [0, 1]), as `lancer diff` does.

Exit codes:
  0  correct
  1  a mistake, or unclear
  2  bad input: an image missing or unreadable, of the wrong size, a scene that does not
     load, a --term the model does not have";

/// `lancer diagnose`'s command line.
#[derive(Args)]
#[command(after_help = AFTER_HELP)]
pub(crate) struct DiagnoseArgs {
    #[command(flatten)]
    input: crate::app::SceneArgs,
    /// The student's image of the scene (PNG, OpenEXR, PPM or PGM): the beauty image, or with
    /// --term the term's own image.
    #[arg(long, value_name = "IMAGE", required_unless_present = "aov", conflicts_with = "aov")]
    image: Option<PathBuf>,
    /// A folder of the student's per-term images, `<term>.png` (or .exr, .ppm, .pgm) and
    /// `beauty.*`, as `render --aov` writes them: every image of a term of the model is compared.
    #[arg(long, value_name = "DIR")]
    aov: Option<PathBuf>,
    /// Diagnose one term: the image is that term's image, compared with that term's layer.
    #[arg(long, value_name = "TERM")]
    term: Option<String>,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs `lancer diagnose`: prints the report (stdout) or the error (stderr) and exits with 1
/// (a mistake, unclear) or 2 (bad input) after it.
pub(crate) fn run(registry: &Registry, args: DiagnoseArgs) -> Result<()> {
    let code = match diagnose(registry, &args) {
        Ok(report) => {
            if args.json {
                println!("{}", serde_json::to_string_pretty(&report).expect("plain data serialises"));
            } else {
                print!("{}", report.text());
            }
            report.exit_code
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            2
        }
    };
    if code != 0 {
        use std::io::Write;
        let _ = std::io::stdout().flush();
        std::process::exit(code);
    }
    Ok(())
}

/// One image of the student's, with the layer it is compared with (`beauty` or a term's name).
struct Given {
    layer: String,
    path: PathBuf,
    image: Image,
}

/// The report, as printed and as JSON.
#[derive(Serialize)]
pub(crate) struct Report {
    /// `correct`, a mistake's name, or `unclear`.
    pub(crate) verdict: String,
    pub(crate) exit_code: i32,
    /// Why, in one sentence.
    pub(crate) reason: String,
    /// What the mistake is (for a mistake's verdict).
    pub(crate) description: Option<String>,
    /// What to check in the code (for a mistake's verdict).
    pub(crate) hint: Option<String>,
    /// The student's files and the layer each is compared with.
    pub(crate) images: Vec<ImageReport>,
    pub(crate) scene: String,
    /// The right model, as `render`'s summary line says it.
    pub(crate) model: String,
    pub(crate) size: [u32; 2],
    /// The right model's PSNR against the image (null: identical).
    pub(crate) right_psnr_db: Option<f64>,
    /// Further mistakes made with the verdict's, found one after the other: each explains
    /// what the ones before leave (see [`MOST_MISTAKES`]).
    pub(crate) also: Vec<AlsoReport>,
    /// The mistakes tried whose render differs from the right one, best first.
    pub(crate) candidates: Vec<CandidateReport>,
    /// Mistakes tried whose render is the right one here: they cannot be told apart from it.
    pub(crate) no_difference: Vec<String>,
    /// Mistakes the model cannot make, and why.
    pub(crate) not_tried: Vec<NotTried>,
    /// For an unclear verdict, the closest candidates, best first.
    pub(crate) closest: Vec<String>,
    pub(crate) notes: Vec<String>,
}

/// A student's file.
#[derive(Serialize)]
pub(crate) struct ImageReport {
    pub(crate) path: String,
    pub(crate) format: String,
    pub(crate) layer: String,
}

/// How one mistake compares.
#[derive(Serialize)]
pub(crate) struct CandidateReport {
    pub(crate) name: String,
    pub(crate) description: String,
    /// The image against the mistake's render (null: identical).
    pub(crate) psnr_db: Option<f64>,
    /// The share of the pixels where the mistake's render differs from the right one.
    pub(crate) differs_on: f64,
    /// On those pixels: the image against the mistake's render (null: identical).
    pub(crate) there_psnr_db: Option<f64>,
    /// On those pixels: the image against the right model's render.
    pub(crate) right_there_psnr_db: Option<f64>,
    /// Whether it explains the image by the rule.
    pub(crate) explains: bool,
    #[serde(skip)]
    hint: String,
}

/// A further mistake made with the verdict's.
#[derive(Serialize)]
pub(crate) struct AlsoReport {
    pub(crate) name: String,
    pub(crate) description: String,
    pub(crate) hint: String,
    /// The image against the render with this mistake and the ones before (null: identical).
    pub(crate) psnr_db: Option<f64>,
}

/// A mistake not tried, and why.
#[derive(Serialize)]
pub(crate) struct NotTried {
    pub(crate) name: String,
    pub(crate) why: String,
}

/// A finite PSNR, or none (identical).
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// The student's images: `--image` (compared with `--term`'s layer, or the beauty image), or
/// the images of `--aov`'s folder named after a layer of `pipeline` (or only `--term`'s).
fn read_given(args: &DiagnoseArgs, pipeline: &Pipeline) -> Result<Vec<Given>> {
    let terms: Vec<&str> = pipeline.terms.iter().map(|t| t.name.as_str()).collect();
    if let Some(t) = &args.term
        && t != "beauty"
        && !terms.contains(&t.as_str())
    {
        bail!(
            "--term {t}: the model has no such term; its terms: {} (or beauty){}",
            terms.join(", "),
            lancer_shading::nearest(t, terms.iter().copied())
                .map(|n| format!(" (did you mean `{n}`?)"))
                .unwrap_or_default()
        );
    }
    if let Some(path) = &args.image {
        let layer = args.term.clone().unwrap_or_else(|| "beauty".to_owned());
        let image = read::read(path, MAX_IMAGE_MB)?;
        return Ok(vec![Given { layer, path: path.clone(), image }]);
    }
    let Some(dir) = &args.aov else { bail!("give the student's image with --image FILE, or a folder with --aov DIR") };
    if !dir.is_dir() {
        bail!("--aov {}: there is no folder {}", dir.display(), dir.display());
    }
    let layers: Vec<&str> = match &args.term {
        Some(t) => vec![t.as_str()],
        None => terms.iter().copied().chain(["beauty"]).collect(),
    };
    let mut given = Vec::new();
    for layer in &layers {
        // EXR first: linear values, no 8-bit rounding.
        let found =
            ["exr", "png", "ppm", "pgm", "pnm"].iter().map(|e| dir.join(format!("{layer}.{e}"))).find(|p| p.is_file());
        if let Some(path) = found {
            let image = read::read(&path, MAX_IMAGE_MB)?;
            given.push(Given { layer: (*layer).to_owned(), path, image });
        }
    }
    if given.is_empty() {
        bail!(
            "{} holds no image of {} (expected files such as {}.png or {}.exr)",
            dir.display(),
            layers.join(", "),
            layers[0],
            layers[0]
        );
    }
    Ok(given)
}

/// The size to render at: the images' (all of one size), which must be the scene's or of its
/// shape; a note when it is not the scene's own.
fn size_of(given: &[Given], scene: (u32, u32), notes: &mut Vec<String>) -> Result<(u32, u32)> {
    let first = &given[0];
    let (w, h) = (first.image.width, first.image.height);
    for g in &given[1..] {
        if (g.image.width, g.image.height) != (w, h) {
            bail!(
                "{} is {}x{} but {} is {w}x{h}: the images of a folder are of one size",
                g.path.display(),
                g.image.width,
                g.image.height,
                first.path.display()
            );
        }
    }
    if (w, h) == scene {
        return Ok((w, h));
    }
    let aspect = scene.0 as f64 / scene.1 as f64;
    let same_shape =
        h == ((w as f64 / aspect).round() as u32).max(1) || w == ((h as f64 * aspect).round() as u32).max(1);
    if !same_shape {
        bail!(
            "{} is {w}x{h}, but the scene renders {}x{} (aspect {aspect:.3}): expected an image of the scene's size or shape (e.g. {}x{}), or give the size it was rendered at with --width and --height",
            first.path.display(),
            scene.0,
            scene.1,
            w,
            ((w as f64 / aspect).round() as u32).max(1)
        );
    }
    notes.push(format!("rendered at {w}x{h}, the image's size (the scene's is {}x{})", scene.0, scene.1));
    Ok((w, h))
}

/// The display values of the layers `given` names in `frame`, one after the other, each
/// through `output` first if given.
fn layers_of(frame: &lancer_core::Frame, given: &[Given], output: Option<OutputMistake>) -> Vec<Vec3> {
    let mut all = Vec::with_capacity(given.len() * frame.beauty.len());
    for g in given {
        let pixels = match g.layer.as_str() {
            "beauty" => Some(&frame.beauty),
            name => frame.layer(name).map(|l| &l.pixels),
        };
        // A term's layer is always there (layers are kept); black otherwise, for safety.
        let mut linear = pixels.cloned().unwrap_or_else(|| vec![Vec3::ZERO; frame.beauty.len()]);
        if let Some(o) = output {
            o.apply(frame.width, &mut linear);
        }
        all.extend(Image::from_linear(frame.width, frame.height, linear).display);
    }
    all
}

/// What [`diagnose_layer`] found: the verdict's name and the whole report.
#[derive(Clone, Debug)]
pub struct Diagnosis {
    /// `correct`, a mistake's name (`specular:sign`, `output:gamma`...) or `unclear`.
    pub verdict: String,
    /// The report as `lancer diagnose` prints it: `verdict: NAME` first, then the evidence and
    /// the hint.
    pub report: String,
}

/// `lancer diagnose SCENE --term TERM` on an image held in memory rather than a file: `linear`
/// (`width` × `height` linear values, row 0 at the top, as a [`lancer_core::Frame`]'s layers
/// hold them) is compared with the layer `term` (a term of the scene's model, or `beauty`) of
/// the scene rendered with the right model and with each mistake of the catalogue. For a
/// program's own tests: course/starter diagnoses a student's term this way. `label` is what the
/// report calls the image (in place of a file's name).
pub fn diagnose_layer(
    registry: &Registry,
    scene: &std::path::Path,
    term: &str,
    label: &str,
    (width, height): (u32, u32),
    linear: Vec<Vec3>,
) -> Result<Diagnosis> {
    if linear.len() != width as usize * height as usize {
        bail!("{} values for a {width}x{height} image", linear.len());
    }
    let loaded = crate::app::load(registry, &scene_alone(scene)?)?;
    if term != "beauty" && !loaded.pipeline.terms.iter().any(|t| t.name == term) {
        bail!("the model of {} has no term `{term}`", scene.display());
    }
    let mut image = Image::from_linear(width, height, linear);
    image.format = "linear float RGB".to_owned();
    let given = vec![Given { layer: term.to_owned(), path: PathBuf::from(label), image }];
    let report = diagnose_given(registry, loaded, given)?;
    Ok(Diagnosis { verdict: report.verdict.clone(), report: report.text() })
}

/// The scene `scene` with its own settings, as `lancer diagnose SCENE` with no other flag reads it.
fn scene_alone(scene: &std::path::Path) -> Result<crate::app::SceneArgs> {
    use clap::FromArgMatches as _;
    let flags = crate::app::SceneArgs::augment_args(clap::Command::new("diagnose"))
        .try_get_matches_from([std::ffi::OsStr::new("diagnose"), scene.as_os_str()])?;
    Ok(crate::app::SceneArgs::from_arg_matches(&flags)?)
}

/// The whole diagnosis: reads, renders, compares, decides.
fn diagnose(registry: &Registry, args: &DiagnoseArgs) -> Result<Report> {
    let loaded = crate::app::load(registry, &args.input)?;
    let given = read_given(args, &loaded.pipeline)?;
    diagnose_given(registry, loaded, given)
}

/// [`diagnose`] of the images `given` against the loaded scene: renders, compares, decides.
fn diagnose_given(registry: &Registry, loaded: crate::app::Loaded, given: Vec<Given>) -> Result<Report> {
    let crate::app::Loaded { mut scene, pipeline, name, .. } = loaded;
    let mut notes: Vec<String> =
        given.iter().flat_map(|g| g.image.notes.iter().map(move |n| format!("{}: {n}", g.path.display()))).collect();
    let (w, h) = size_of(&given, (scene.image.width, scene.image.height), &mut notes)?;
    (scene.image.width, scene.image.height) = (w, h);
    let prepared = lancer_shading::prepare(&scene).with_context(|| format!("preparing {name}"))?;
    let only_beauty = given.iter().all(|g| g.layer == "beauty");
    let render = |p: &Pipeline| {
        let options = RenderOptions { layers: !only_beauty, ..Default::default() };
        lancer_shading::render_prepared(&prepared, &scene.camera, &scene.image, p, options)
    };
    let image: Vec<Vec3> = given.iter().flat_map(|g| g.image.display.iter().copied()).collect();
    let right_frame = render(&pipeline);
    let right = layers_of(&right_frame, &given, None);
    let right_psnr = decide::psnr_of(&image, &right);
    // The compared layers of a render with every mistake of `set` made.
    let render_set = |set: &[&Entry]| -> Result<Vec<Vec3>> {
        let output = set.iter().find_map(|e| match e.kind {
            Kind::Output(o) => Some(o),
            _ => None,
        });
        if set.iter().all(|e| matches!(e.kind, Kind::Output(_))) {
            return Ok(layers_of(&right_frame, &given, output));
        }
        Ok(layers_of(&render(&catalogue::combined(registry, &pipeline, set)?), &given, output))
    };

    let (mut tried, mut scores, mut no_difference, mut not_tried) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for entry in catalogue::entries(registry) {
        if let Err(why) = entry.applies(&pipeline) {
            not_tried.push(NotTried { name: entry.name.clone(), why });
            continue;
        }
        let s = decide::score(&image, &right, &render_set(&[&entry])?);
        if s.differing == 0 {
            no_difference.push(entry.name.clone());
        } else {
            tried.push(entry);
            scores.push(s);
        }
    }
    let names: Vec<&str> = tried.iter().map(|e| e.name.as_str()).collect();
    let decision = decide::decide(right_psnr, &scores, &names);
    let (mut verdict, mut reason) = (decision.verdict, decision.reason);
    // More mistakes made together, found one after the other (see `search`): after the
    // verdict's, or, when no mistake alone explains the image, from the right model, kept only
    // if all of them together explain the image by the rule.
    let mut also: Vec<(usize, f64)> = Vec::new();
    let alone = scores.iter().any(Score::explains);
    match verdict {
        Verdict::Mistake(first) => {
            let base = render_set(&[&tried[first]])?;
            let more = search(&tried, &image, vec![first], base, scores[first].psnr, &render_set)?;
            also = more.mistakes.into_iter().skip(1).collect();
        }
        Verdict::Unclear(_) if !alone && right_psnr < decide::CORRECT_DB => {
            let Found { mistakes: found, render: base } =
                search(&tried, &image, Vec::new(), right.clone(), right_psnr, &render_set)?;
            let together = decide::score(&image, &right, &base);
            if let Some(&(first, _)) = found.first()
                && together.explains()
            {
                let names: Vec<&str> = found.iter().map(|&(k, _)| tried[k].name.as_str()).collect();
                reason = format!(
                    "no mistake alone explains the image, but {} together do: where their render differs from the right model ({:.2} % of the pixels), the image matches it ({}) and not the right model ({})",
                    and_list(&names),
                    100.0 * together.share(),
                    db(together.there),
                    db(together.right_there)
                );
                verdict = Verdict::Mistake(first);
                also = found.into_iter().skip(1).collect();
            }
        }
        _ => {}
    }
    let order = decide::ranked(&scores);
    let candidate = |k: usize| {
        let (e, s): (&Entry, &Score) = (&tried[k], &scores[k]);
        CandidateReport {
            name: e.name.clone(),
            description: e.summary.to_owned(),
            psnr_db: finite(s.psnr),
            differs_on: s.share(),
            there_psnr_db: finite(s.there),
            right_there_psnr_db: finite(s.right_there),
            explains: s.explains(),
            hint: e.hint.to_owned(),
        }
    };
    let (verdict, exit_code, description, hint, closest) = match &verdict {
        Verdict::Correct => ("correct".to_owned(), 0, None, None, Vec::new()),
        Verdict::Mistake(k) => {
            (tried[*k].name.clone(), 1, Some(tried[*k].summary.to_owned()), Some(tried[*k].hint.to_owned()), Vec::new())
        }
        Verdict::Unclear(top) => {
            ("unclear".to_owned(), 1, None, None, top.iter().map(|&k| tried[k].name.clone()).collect())
        }
    };
    Ok(Report {
        verdict,
        exit_code,
        reason,
        description,
        hint,
        images: given
            .iter()
            .map(|g| ImageReport {
                path: g.path.display().to_string(),
                format: g.image.format.clone(),
                layer: g.layer.clone(),
            })
            .collect(),
        scene: name,
        model: crate::stats::effective_model(&pipeline, &scene.image),
        size: [w, h],
        right_psnr_db: finite(right_psnr),
        also: also
            .iter()
            .map(|&(k, psnr)| AlsoReport {
                name: tried[k].name.clone(),
                description: tried[k].summary.to_owned(),
                hint: tried[k].hint.to_owned(),
                psnr_db: finite(psnr),
            })
            .collect(),
        candidates: order.into_iter().map(candidate).collect(),
        no_difference,
        not_tried,
        closest,
        notes,
    })
}

/// `a`, `a and b`, `a, b and c`.
fn and_list(names: &[&str]) -> String {
    match names {
        [] => String::new(),
        [one] => (*one).to_owned(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
    }
}

/// The compared layers of a render with every mistake of a set made.
type RenderSet<'a> = dyn Fn(&[&Entry]) -> Result<Vec<Vec3>> + 'a;

/// What [`search`] found: each mistake (its index) with the image's PSNR once it is added, and
/// the render with them all.
struct Found {
    mistakes: Vec<(usize, f64)>,
    render: Vec<Vec3>,
}

/// Mistakes made together, found greedily after those of `found` (whose render is `base`, at
/// `closeness` dB from the image): at each step, of the mistakes that go with those found, the
/// one whose addition brings the render closest to the image, provided that, where it changes
/// `base`, the image is at least [`decide::MARGIN_DB`] closer to the new render than to `base`,
/// and the whole image more than [`decide::TIE_DB`] closer; until the image is within
/// [`decide::CORRECT_DB`] or [`MOST_MISTAKES`] are found. Gives every mistake found with the
/// PSNR once it is added, and the last render.
fn search(
    tried: &[Entry],
    image: &[Vec3],
    found: Vec<usize>,
    base: Vec<Vec3>,
    closeness: f64,
    render_set: &RenderSet<'_>,
) -> Result<Found> {
    let mut found: Vec<(usize, f64)> = found.into_iter().map(|k| (k, closeness)).collect();
    let (mut base, mut closeness) = (base, closeness);
    while closeness < decide::CORRECT_DB && found.len() < MOST_MISTAKES {
        let mut best: Option<(usize, Score, Vec<Vec3>)> = None;
        for (k, entry) in tried.iter().enumerate() {
            if found.iter().any(|&(f, _)| f == k || !tried[f].goes_with(entry)) {
                continue;
            }
            let mut set: Vec<&Entry> = found.iter().map(|&(f, _)| &tried[f]).collect();
            set.push(entry);
            let with = render_set(&set)?;
            let s = decide::score(image, &base, &with);
            let helps =
                s.differing > 0 && s.there >= s.right_there + decide::MARGIN_DB && s.psnr > closeness + decide::TIE_DB;
            if helps && best.as_ref().is_none_or(|(_, b, _)| s.psnr > b.psnr) {
                best = Some((k, s, with));
            }
        }
        let Some((k, s, with)) = best else { break };
        found.push((k, s.psnr));
        (base, closeness) = (with, s.psnr);
    }
    Ok(Found { mistakes: found, render: base })
}

impl Report {
    /// The report as text: `verdict: NAME` first, then the evidence and the hint.
    pub(crate) fn text(&self) -> String {
        let mut out = format!("verdict: {}\n", self.verdict);
        let _ = writeln!(out, "why: {}", self.reason);
        if let (Some(d), Some(h)) = (&self.description, &self.hint) {
            let _ = writeln!(out, "what it is: {d}");
            let _ = writeln!(out, "hint: {h}");
        }
        for a in &self.also {
            let with = a.psnr_db.map(|v| format!("{v:.1} dB from")).unwrap_or_else(|| "identical to".to_owned());
            let _ = writeln!(out, "also: {} (with it too, the image is {with} the render)", a.name);
            let _ = writeln!(out, "  what it is: {}", a.description);
            let _ = writeln!(out, "  hint: {}", a.hint);
        }
        if !self.closest.is_empty() {
            let _ = writeln!(out, "closest: {}", self.closest.join(", "));
            for c in self.candidates.iter().filter(|c| self.closest.contains(&c.name)) {
                let _ = writeln!(out, "  if it is {}: {}", c.name, c.hint);
            }
        }
        for i in &self.images {
            let _ = writeln!(out, "image: {} ({}), against the {} image", i.path, i.format, i.layer);
        }
        let _ =
            writeln!(out, "scene: {} at {}x{}; right model: {}", self.scene, self.size[0], self.size[1], self.model);
        let _ = writeln!(out, "compared in the display domain (sRGB-encoded values clamped to [0, 1]):");
        let width = self.candidates.iter().map(|c| c.name.len()).max().unwrap_or(0).max("right model".len());
        let psnr = |x: Option<f64>| x.map(|v| format!("PSNR {v:.2} dB")).unwrap_or_else(|| "identical".to_owned());
        let from = |x: Option<f64>| x.map(|v| format!("{v:.1} dB from")).unwrap_or_else(|| "identical to".to_owned());
        let _ = writeln!(out, "  {:<width$}  {}", "right model", psnr(self.right_psnr_db));
        for c in &self.candidates {
            let _ = writeln!(
                out,
                "  {:<width$}  {}; differs from the right model on {:.2} % of the pixels, where the image is {} it and {} the right model{}",
                c.name,
                psnr(c.psnr_db),
                100.0 * c.differs_on,
                from(c.there_psnr_db),
                from(c.right_there_psnr_db),
                if c.explains { " (explains it)" } else { "" }
            );
        }
        if !self.no_difference.is_empty() {
            let _ = writeln!(out, "no difference in this scene, not told apart: {}", self.no_difference.join(", "));
        }
        // The mistakes not tried, grouped by reason.
        let mut reasons: Vec<(&str, Vec<&str>)> = Vec::new();
        for n in &self.not_tried {
            match reasons.iter_mut().find(|(why, _)| *why == n.why) {
                Some((_, names)) => names.push(&n.name),
                None => reasons.push((&n.why, vec![&n.name])),
            }
        }
        for (why, names) in reasons {
            let _ = writeln!(out, "not tried: {} ({why})", names.join(", "));
        }
        for n in &self.notes {
            let _ = writeln!(out, "note: {n}");
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn given(w: u32, h: u32, name: &str) -> Given {
        let image = Image::from_linear(w, h, vec![Vec3::ZERO; (w * h) as usize]);
        Given { layer: "beauty".to_owned(), path: PathBuf::from(name), image }
    }

    #[test]
    fn the_image_must_have_the_scenes_size_or_shape() {
        let mut notes = Vec::new();
        assert_eq!(size_of(&[given(480, 270, "a.png")], (480, 270), &mut notes).unwrap(), (480, 270));
        assert!(notes.is_empty());
        // 96x54 and 97x55 (rounded either way) have the shape of 480x270.
        assert_eq!(size_of(&[given(96, 54, "a.png")], (480, 270), &mut notes).unwrap(), (96, 54));
        assert_eq!(notes, ["rendered at 96x54, the image's size (the scene's is 480x270)"]);
        assert!(size_of(&[given(97, 55, "a.png")], (480, 270), &mut notes).is_ok());
        let e = size_of(&[given(100, 100, "s.png")], (480, 270), &mut notes).unwrap_err().to_string();
        assert_eq!(
            e,
            "s.png is 100x100, but the scene renders 480x270 (aspect 1.778): expected an image of the scene's size or shape (e.g. 100x56), or give the size it was rendered at with --width and --height"
        );
        let e = size_of(&[given(96, 54, "a.png"), given(48, 27, "b.png")], (480, 270), &mut notes).unwrap_err();
        assert_eq!(e.to_string(), "b.png is 48x27 but a.png is 96x54: the images of a folder are of one size");
    }

    #[test]
    fn a_layer_in_memory_is_diagnosed_as_a_file_would_be() {
        // The course's specular exercise: its specular layer rendered with `specular:sign` is
        // named so, the right layer is correct, and a layer of the wrong size is refused.
        let registry = Registry::with_builtins();
        let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../course/ex3-specular.toml");
        let loaded = crate::app::load(&registry, &scene_alone(&scene).unwrap()).unwrap();
        let crate::app::Loaded { scene: world, pipeline, .. } = loaded;
        let prepared = lancer_shading::prepare(&world).unwrap();
        let layer = |p: &Pipeline| {
            let options = RenderOptions { layers: true, ..Default::default() };
            let frame = lancer_shading::render_prepared(&prepared, &world.camera, &world.image, p, options);
            frame.layer("specular").unwrap().pixels.clone()
        };
        let size = (world.image.width, world.image.height);
        let right = diagnose_layer(&registry, &scene, "specular", "mine", size, layer(&pipeline)).unwrap();
        assert_eq!(right.verdict, "correct", "{}", right.report);
        let sign = catalogue::entries(&registry).into_iter().find(|e| e.name == "specular:sign").unwrap();
        let mistaken = catalogue::combined(&registry, &pipeline, &[&sign]).unwrap();
        let d = diagnose_layer(&registry, &scene, "specular", "mine", size, layer(&mistaken)).unwrap();
        assert_eq!(d.verdict, "specular:sign", "{}", d.report);
        assert!(d.report.starts_with("verdict: specular:sign\n") && d.report.contains("image: mine ("), "{}", d.report);
        assert!(diagnose_layer(&registry, &scene, "specular", "mine", (2, 2), vec![Vec3::ZERO; 3]).is_err());
        assert!(diagnose_layer(&registry, &scene, "mirror", "mine", size, layer(&pipeline)).is_err());
    }

    #[test]
    fn lists_read_as_sentences() {
        assert_eq!(and_list(&["a"]), "a");
        assert_eq!(and_list(&["a", "b"]), "a and b");
        assert_eq!(and_list(&["a", "b", "c"]), "a, b and c");
    }
}
