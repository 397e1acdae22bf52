//! The `lancer` command: flags, reading scene and model files, the thread pool, progress, and
//! writing images. [`main_with`] runs it with any registry, so a crate that registers its own
//! terms gets the whole command line for free.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use crate::output::Format;
use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use lancer_core::Frame;
use lancer_core::frame::BACKGROUND;
use lancer_shading::{Choice, Pipeline, Registry, RenderOptions};

/// The largest image, in pixels, Lancer agrees to render (8192 × 8192).
const MAX_PIXELS: u64 = 1 << 26;

/// The scene rendered when no scene file is given (`scenes/showcase.toml`, embedded).
pub const DEFAULT_SCENE: &str = include_str!("../../../scenes/showcase.toml");
const DEFAULT_SCENE_NAME: &str = "scenes/showcase.toml (embedded default)";

#[derive(Parser)]
#[command(
    name = "lancer",
    version,
    about = "Lancer: a Whitted ray tracer whose illumination model is a list of pluggable terms",
    // `lancer scene.toml -o out.png` is `lancer render scene.toml -o out.png`.
    args_conflicts_with_subcommands = true
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    render: RenderArgs,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (the embedded showcase when no SCENE is given).
    Render(RenderArgs),
    /// Render a scene, then again each time the scene, the model file or a mesh or texture it
    /// uses is saved (the same flags as `render`); Ctrl-C stops.
    Watch(RenderArgs),
    /// Load and prepare a scene without rendering it: a summary, and warnings about what it
    /// probably does not mean.
    Check(CheckArgs),
    /// Explain one pixel: its ray tree, the light at each hit, every term's inputs and
    /// contribution, and the per-term totals (the values `--aov` writes there).
    Explain(ExplainArgs),
    /// Put the parts of a render (`render --tile I/N`) back together into its images.
    Merge(MergeArgs),
    /// A local web studio: sliders for the materials, the lights and the model, live per-term
    /// images, a pixel inspector (the embedded showcase without a SCENE).
    Serve(ServeArgs),
    /// Write the scene for another renderer: `lancer export pov SCENE -o OUT.pov` (POV-Ray 3.7).
    Export(ExportArgs),
    /// List every registered term, its variants and parameters, and every shadow model
    /// (`--mistakes`: the catalogue of classic mistakes instead).
    Terms(crate::listing::TermsArgs),
    /// Compare two images, or two `--aov` folders term by term: PSNR, absolute errors, ꟻLIP, the
    /// worst region, and the usual mismatches named (upside down, sRGB curve, a factor, channel
    /// order, a shifted pixel grid); exit 0 pass, 1 differ, 2 bad input.
    Diff(crate::diff::DiffArgs),
    /// Tell which classic mistake of the course, if any, explains a student's image of a scene:
    /// the first line is `verdict: correct`, `verdict: NAME` (e.g. specular:sign) or
    /// `verdict: unclear`; exit 0 correct, 1 a mistake or unclear, 2 bad input.
    Diagnose(crate::diagnose::DiagnoseArgs),
    /// A lecture sheet: a scene rendered in a grid whose columns and rows change the model, the
    /// materials or the image shown, with its title and labels drawn in (`-o sheet.png`), or as
    /// a page (`-o sheet.html`); the format is in docs/sheets.md.
    Sheet(crate::sheet::SheetArgs),
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum AovFormat {
    /// Linear float OpenEXR only.
    Exr,
    /// sRGB 8-bit PNG only.
    Png,
    /// Both.
    #[default]
    Both,
}

/// The default of `--max-file-size`, in MB.
pub(crate) const MAX_FILE_MB: u64 = 1024;

/// What every command that renders reads: the scene and how to change its model and image.
#[derive(Args, Clone, Default)]
pub(crate) struct SceneArgs {
    /// Scene file (TOML); the embedded showcase when absent.
    pub(crate) scene: Option<PathBuf>,
    /// Apply this model file over the scene's [model]: what it sets (terms, shadows, max_depth)
    /// replaces the scene's, the rest stays.
    #[arg(long, value_name = "FILE")]
    pub(crate) model: Option<PathBuf>,
    /// Replace the model's terms (keeping its shadows and depth): names in order, each with an
    /// optional variant (the default one otherwise) and parameters, e.g.
    /// `ambient,diffuse,specular:blinn:exponent=64`. A term the scene has in the same variant
    /// keeps its parameters (`weight` too) unless given again.
    #[arg(long, value_name = "TERM[:VARIANT][:KEY=VALUE]...,...", value_delimiter = ',')]
    pub(crate) terms: Option<Vec<String>>,
    /// Replace the model's shadow model, with parameters as KEY=VALUE, e.g. `none`, `hard`,
    /// `soft:samples=64`, `transmissive:tint=true`. The scene's model keeps its parameters unless
    /// given again.
    #[arg(long, value_name = "MODEL[:KEY=VALUE]...")]
    pub(crate) shadows: Option<String>,
    /// Replace the model's recursion limit for mirror and refraction rays.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(0..=64))]
    pub(crate) max_depth: Option<u8>,
    /// Image width (the height follows the scene's aspect ratio unless --height is given).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: Option<u32>,
    /// Image height (the width follows the scene's aspect ratio unless --width is given).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: Option<u32>,
    /// Anti-aliasing, overriding the scene's: N samples per pixel (1 to 4096), or
    /// `adaptive[:threshold=T][:depth=D]` (POV-Ray's `+AT +RD`): each pixel once at its centre,
    /// then D x D more samples (and the centre again) where it differs from a neighbour by T or
    /// more (T from 0 to 3, summed over R, G, B as a PNG stores them; D from 2 to 9; 0.3 and 3
    /// unless given).
    #[arg(long, value_name = "N|adaptive:threshold=T:depth=D", value_parser = parse_samples)]
    pub(crate) samples: Option<Samples>,
    /// Largest file (scene, model, mesh or texture) Lancer will read, in MB.
    #[arg(long, value_name = "MB", default_value_t = MAX_FILE_MB, value_parser = clap::value_parser!(u64).range(1..))]
    pub(crate) max_file_size: u64,
    /// The most pixels a scene's textures may hold together (each is refused from its header).
    #[arg(long, value_name = "N", default_value_t = lancer_scene::MAX_TEXTURE_PIXELS, value_parser = clap::value_parser!(u64).range(1..))]
    pub(crate) max_texture_pixels: u64,
    /// The most triangles a scene's meshes may hold together (polygons counted as fanned).
    #[arg(long, value_name = "N", default_value_t = lancer_scene::MAX_TRIANGLES, value_parser = clap::value_parser!(usize))]
    pub(crate) max_triangles: usize,
    /// Meshes and textures only from under the scene's folder (the studio sets it).
    #[arg(skip)]
    confined: bool,
    /// Fingerprint every byte read (a part of a render, `--tile`, records it for the merge).
    #[arg(skip)]
    fingerprint: bool,
}

impl SceneArgs {
    /// The scene file `scene` as it is, read within the command line's default limits.
    pub(crate) fn of(scene: Option<PathBuf>) -> SceneArgs {
        SceneArgs {
            scene,
            max_file_size: MAX_FILE_MB,
            max_texture_pixels: lancer_scene::MAX_TEXTURE_PIXELS,
            max_triangles: lancer_scene::MAX_TRIANGLES,
            ..SceneArgs::default()
        }
    }
}

#[derive(Args, Clone, Default)]
pub(crate) struct RenderArgs {
    #[command(flatten)]
    pub(crate) input: SceneArgs,
    /// Beauty image: .png (sRGB 8-bit) or .exr (linear float); a device or pipe such as
    /// /dev/null or /dev/stdout gets a PNG [default: render.png; with --tile I/N, the part file
    /// render-I.lpart].
    #[arg(short, long, value_name = "FILE")]
    pub(crate) output: Option<PathBuf>,
    /// Also write DIR/<term>.exr and DIR/<term>.png for every term, and DIR/beauty.{exr,png}.
    #[arg(long, value_name = "DIR")]
    aov: Option<PathBuf>,
    /// Which files --aov writes for each image: linear EXR, sRGB PNG, or both.
    #[arg(long, value_enum, default_value_t = AovFormat::Both)]
    aov_format: AovFormat,
    /// Worker threads (default: one per core). The image is identical for any count.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// No progress bar or summary line.
    #[arg(short, long)]
    quiet: bool,
    /// Print render statistics: rays by kind, time per system, rays per second per thread.
    #[arg(long)]
    stats: bool,
    /// Write the render statistics as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    stats_json: Option<PathBuf>,
    /// Render only part I of N (I from 0): every N-th band of 16 rows from band I, written to
    /// -o as a part file that `lancer merge` puts back together with the others, bit for bit.
    #[arg(long, value_name = "I/N", value_parser = crate::part::parse_tile)]
    tile: Option<(u32, u32)>,
    /// Render by the reference path: every ray alone in plain code (no block tracer, no
    /// eight-lane groups), each built-in term by its formula one hit at a time. Slower; the
    /// same image but where two surfaces tie exactly.
    #[arg(long)]
    reference: bool,
    /// Write the images through a classic mistake of an image writer, to show it (see
    /// `lancer terms --mistakes`): linear values as if sRGB, rows upside down, or BGR.
    #[arg(long, value_enum, value_name = "MISTAKE")]
    output_mistake: Option<crate::diagnose::OutputMistake>,
}

#[derive(Args)]
struct ServeArgs {
    #[command(flatten)]
    input: SceneArgs,
    /// The port to listen on (0: any free one; the printed address says which).
    #[arg(long, default_value_t = 8470)]
    port: u16,
    /// Do not open the page in a browser.
    #[arg(long)]
    no_open: bool,
    /// The address to listen on; anything but 127.0.0.1 exposes the studio to the network.
    /// 0.0.0.0 (or ::) listens on every interface and prints each address, loopback first.
    #[arg(long, default_value = "127.0.0.1")]
    host: std::net::IpAddr,
    /// Another name the page may be opened by, such as this machine's name on the network
    /// (lab-pc.local): a DNS name or an IP address, without port or path. Repeatable.
    #[arg(long = "allow-host", value_name = "NAME", value_parser = lancer_studio::allowed_host)]
    allow_host: Vec<String>,
    /// Let the page's Save write the edits back into the scene file (keeping its comments).
    #[arg(long)]
    allow_save: bool,
    /// For a class: each page's edits render for that page alone (never on the others'
    /// screens) and Save is off; the scene file's own state and its reloads reach every page.
    #[arg(long, conflicts_with = "allow_save")]
    read_only: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum ExportFormat {
    /// POV-Ray 3.7 scene language.
    Pov,
}

#[derive(Args)]
struct ExportArgs {
    /// The format to write.
    #[arg(value_enum)]
    format: ExportFormat,
    #[command(flatten)]
    input: SceneArgs,
    /// The file to write (image textures are written beside it).
    #[arg(short, long, default_value = "scene.pov")]
    output: PathBuf,
}

#[derive(Args)]
struct MergeArgs {
    /// The part files (from `render --tile I/N`), every part of one render exactly once.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Beauty image: .png (sRGB 8-bit) or .exr (linear float).
    #[arg(short, long, default_value = "render.png")]
    output: PathBuf,
    /// Also write DIR/<term>.exr and DIR/<term>.png for every term, and DIR/beauty.{exr,png}.
    #[arg(long, value_name = "DIR")]
    aov: Option<PathBuf>,
    /// Which files --aov writes for each image: linear EXR, sRGB PNG, or both.
    #[arg(long, value_enum, default_value_t = AovFormat::Both)]
    aov_format: AovFormat,
    /// Largest part file Lancer will read, in MB.
    #[arg(long, value_name = "MB", default_value_t = 16 * MAX_FILE_MB, value_parser = clap::value_parser!(u64).range(1..))]
    max_file_size: u64,
    /// No summary line.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Args)]
struct CheckArgs {
    #[command(flatten)]
    input: SceneArgs,
}

#[derive(Args)]
struct ExplainArgs {
    #[command(flatten)]
    input: SceneArgs,
    /// The pixel: column X from the left, row Y from the top, as in the images.
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel)]
    pixel: (u32, u32),
    /// Print the explanation as JSON.
    #[arg(long)]
    json: bool,
}

impl RenderArgs {
    /// Where the render goes: `-o`, else `render.png`, or for a part of a render (`--tile I/N`)
    /// `render-I.lpart` (a part file named like an image would be taken for one, and parts of
    /// one render written side by side must not overwrite each other).
    pub(crate) fn output(&self) -> PathBuf {
        match (&self.output, self.tile) {
            (Some(path), _) => path.clone(),
            (None, Some((index, _))) => PathBuf::from(format!("render-{index}.lpart")),
            (None, None) => PathBuf::from("render.png"),
        }
    }
}

/// `X,Y` as two whole numbers.
fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let expected = || format!("expected X,Y (column from the left, row from the top), e.g. 120,45; got `{s}`");
    let (x, y) = s.split_once(',').ok_or_else(expected)?;
    Ok((x.trim().parse().map_err(|_| expected())?, y.trim().parse().map_err(|_| expected())?))
}

/// Runs the `lancer` command line (`std::env::args`) with `registry`'s terms and shadow models;
/// errors are printed on stderr. Call it from `main` after registering your own terms.
pub fn main_with(registry: Registry) -> ExitCode {
    stop_cleanly_on_signals();
    let args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if let Some(message) = neither_a_scene_nor_a_subcommand(&args) {
        eprintln!("error: {message}");
        // A usage error, as clap's own.
        return ExitCode::from(2);
    }
    match run(Cli::parse_from(args), &registry) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// What to say when the first word of `lancer WORD ...` (no subcommand: a render of the scene
/// WORD) is neither a file nor a subcommand: a subcommand it is close to (`chek`: "did you mean
/// 'check'?"), else that there is no such scene, with the subcommands. Otherwise clap would
/// take the word for the scene and say "the subcommand 'x.toml' cannot be used with '[SCENE]'"
/// of `lancer chek x.toml`, and the render "reading scene serv" of `lancer serv`. (clap's own
/// suggestions are for a word in a subcommand's place, which this one is not.)
fn neither_a_scene_nor_a_subcommand(args: &[std::ffi::OsString]) -> Option<String> {
    use clap::CommandFactory;
    let cmd = Cli::command();
    let word = first_positional(&cmd, args)?;
    let mut names: Vec<&str> = cmd.get_subcommands().map(|c| c.get_name()).collect();
    names.push("help");
    if names.contains(&word) || Path::new(word).exists() {
        return None;
    }
    Some(match lancer_shading::nearest(word, names.iter().copied()) {
        Some(near) => format!("unknown subcommand '{word}' — did you mean '{near}'?"),
        None => {
            format!("scene file `{word}` not found (nor is it a subcommand); the subcommands: {}", names.join(", "))
        }
    })
}

/// The first word of `args` (after the program's name) that is not a flag nor a flag's value,
/// as `cmd` reads them; `None` when there is none, or it is not UTF-8.
fn first_positional<'a>(cmd: &clap::Command, args: &'a [std::ffi::OsString]) -> Option<&'a str> {
    let takes_value = |arg: Option<&clap::Arg>| arg.is_some_and(|a| a.get_action().takes_values());
    let mut words = args.iter().skip(1);
    while let Some(word) = words.next() {
        let word = word.to_str()?;
        if word == "--" {
            return words.next()?.to_str();
        }
        if let Some(long) = word.strip_prefix("--") {
            if !long.contains('=') && takes_value(cmd.get_arguments().find(|a| a.get_long() == Some(long))) {
                words.next();
            }
        } else if let Some(shorts) = word.strip_prefix('-').filter(|s| !s.is_empty()) {
            // `-q`, `-qo out.png`, `-oout.png`, `-o out.png`: a short flag taking a value takes
            // the rest of the word, or the next word when it is the last.
            for (i, c) in shorts.char_indices() {
                if takes_value(cmd.get_arguments().find(|a| a.get_short() == Some(c))) {
                    if i + c.len_utf8() == shorts.len() {
                        words.next();
                    }
                    break;
                }
            }
        } else {
            return Some(word);
        }
    }
    None
}

/// Ctrl-C (SIGINT), SIGTERM and SIGHUP (what `timeout`, Slurm's `scancel` and Kubernetes send):
/// stop at once, leaving no temporary file and no output folder this run created behind
/// (finished files are whole: they are renamed into place only once written), and exit with
/// 128 + the signal's number, as a shell reports it (130, 143, 129).
#[cfg(unix)]
fn stop_cleanly_on_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    // When the handlers cannot be set, the default behaviour stays.
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else { return };
    let _ = std::thread::Builder::new().name("signals".into()).spawn(move || {
        if let Some(signal) = signals.forever().next() {
            crate::output::remove_temporaries();
            let name = match signal {
                SIGINT => "interrupted",
                SIGTERM => "stopped (SIGTERM)",
                _ => "stopped (SIGHUP)",
            };
            eprintln!("{name}; no partial output left");
            std::process::exit(128 + signal);
        }
    });
}

/// Ctrl-C: stop at once, leaving no temporary file behind. A second handler cannot be set (a
/// host program may have its own): then the default behaviour stays.
#[cfg(not(unix))]
fn stop_cleanly_on_signals() {
    let _ = ctrlc::set_handler(|| {
        crate::output::remove_temporaries();
        eprintln!("interrupted; no partial output left");
        std::process::exit(130);
    });
}

fn run(cli: Cli, registry: &Registry) -> Result<()> {
    match cli.command {
        None => render(registry, cli.render),
        Some(Command::Render(args)) => render(registry, args),
        Some(Command::Check(args)) => check(registry, args),
        Some(Command::Watch(args)) => crate::watch::watch(registry, args),
        Some(Command::Explain(args)) => explain(registry, args),
        Some(Command::Merge(args)) => merge(args),
        Some(Command::Export(args)) => export(registry, args),
        Some(Command::Serve(args)) => serve(registry, args),
        Some(Command::Diff(args)) => crate::diff::run(args),
        Some(Command::Diagnose(args)) => crate::diagnose::run(registry, args),
        Some(Command::Sheet(args)) => crate::sheet::run(registry, args),
        Some(Command::Terms(args)) => {
            print!(
                "{}",
                if args.mistakes { crate::listing::mistakes(registry) } else { crate::listing::terms(registry) }
            );
            Ok(())
        }
    }
}

/// The bytes of the file `path` (a `what`: scene, model, file), if it is a regular file (not a
/// device, a pipe or a folder, which could be read without end) of at most `limit` MB.
pub(crate) fn read_bytes(path: &Path, what: &str, limit: u64) -> Result<Vec<u8>, String> {
    read_checked(path, what, limit, None)
}

/// Reads the regular file `path` of at most `limit` MB (a `what`: scene, mesh...), and when
/// `under` is given only if its real path is under that folder. The checks are made on the file
/// opened, not on the path before it is opened: a file swapped for a link or another file between
/// the check and the read is refused.
pub(crate) fn read_checked(path: &Path, what: &str, limit: u64, under: Option<&Path>) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let fail = |e: std::io::Error| format!("reading {what} {}: {e}", path.display());
    // Looked at first so that a FIFO or a device is never opened (opening a FIFO would wait).
    if !std::fs::metadata(path).map_err(fail)?.is_file() {
        return Err(format!("{what} {} is not a regular file", path.display()));
    }
    let file = std::fs::File::open(path).map_err(fail)?;
    let opened = file.metadata().map_err(fail)?;
    if !opened.is_file() {
        return Err(format!("{what} {} is not a regular file", path.display()));
    }
    let real = std::fs::canonicalize(path).map_err(fail)?;
    // The real path must name the very file opened (it was not swapped meanwhile).
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let now = std::fs::metadata(&real).map_err(fail)?;
        if (now.dev(), now.ino()) != (opened.dev(), opened.ino()) {
            return Err(format!("{what} {} changed while it was being opened; try again", path.display()));
        }
    }
    if let Some(folder) = under
        && !real.starts_with(folder)
    {
        return Err(format!(
            "`{}` is outside the scene's folder: the studio reads only files under it",
            path.display()
        ));
    }
    let max = limit * 1_000_000;
    let too_big = |len: u64| {
        format!(
            "{what} {} is {:.0} MB, over the {limit} MB limit (raise it with --max-file-size)",
            path.display(),
            len as f64 / 1e6
        )
    };
    if opened.len() > max {
        return Err(too_big(opened.len()));
    }
    // Never more than the limit, even if the file grows while it is read.
    let mut bytes = Vec::with_capacity(opened.len() as usize);
    file.take(max + 1).read_to_end(&mut bytes).map_err(fail)?;
    if bytes.len() as u64 > max {
        return Err(too_big(bytes.len() as u64));
    }
    Ok(bytes)
}

pub(crate) fn read(path: &Path, what: &str, limit: u64) -> Result<String> {
    let bytes = read_bytes(path, what, limit).map_err(anyhow::Error::msg)?;
    String::from_utf8(bytes).with_context(|| format!("reading {what} {}: not UTF-8 text", path.display()))
}

/// A scene loaded with its model, the command line's changes applied.
pub(crate) struct Loaded {
    pub(crate) scene: lancer_core::Scene,
    pub(crate) pipeline: Pipeline,
    /// What loading found to warn about.
    warnings: Vec<lancer_scene::Warning>,
    /// Where the scene's parts are in its file.
    pub(crate) places: lancer_scene::Places,
    /// Fingerprints of everything the render depends on (the scene, model and files read,
    /// the effective model and image settings, Lancer's version): parts of one render share them.
    identity: crate::part::Sources,
    /// How the scene is named in messages.
    pub(crate) name: String,
    /// The scene file's text as it was read (what the studio's Save edits).
    source: String,
    load_time: std::time::Duration,
}

/// Reads and builds the scene and its model, applies the command line's changes, and checks the
/// image's size.
pub(crate) fn load(registry: &Registry, args: &SceneArgs) -> Result<Loaded> {
    load_recording(registry, args, &std::cell::RefCell::new(Vec::new()))
}

/// The files a load read, each with its size and modification time taken just before it was
/// read (so a save made while the render runs is seen as a change afterwards).
pub(crate) type Inputs = std::cell::RefCell<Vec<(PathBuf, Option<crate::watch::Stamp>)>>;

/// [`load`], adding to `inputs` every file it reads (scene, model, meshes, textures), even when
/// it fails: what `watch` watches.
fn load_recording(registry: &Registry, args: &SceneArgs, inputs: &Inputs) -> Result<Loaded> {
    inputs.borrow_mut().extend(args.scene.iter().chain(&args.model).map(|p| (p.clone(), crate::watch::stamp(p))));
    let (src, name) = match &args.scene {
        Some(p) => (read(p, "scene", args.max_file_size)?, p.display().to_string()),
        None => (DEFAULT_SCENE.to_owned(), DEFAULT_SCENE_NAME.to_owned()),
    };
    // Files a scene refers to (textures) are relative to the scene file's folder.
    let base = args.scene.as_ref().and_then(|p| p.parent()).map(Path::to_path_buf).unwrap_or_default();
    let sources = std::cell::RefCell::new(crate::part::Sources {
        scene: crate::part::digest(src.as_bytes()),
        version: env!("CARGO_PKG_VERSION").to_owned(),
        ..Default::default()
    });
    let folder = match args.confined {
        true => Some(
            std::fs::canonicalize(if base.as_os_str().is_empty() { Path::new(".") } else { &base })
                .with_context(|| format!("finding the folder of {name}"))?,
        ),
        false => None,
    };
    let resolve = |rel: &str| {
        let path = base.join(rel);
        inputs.borrow_mut().push((path.clone(), crate::watch::stamp(&path)));
        // (Read as often as the scene names it: the scene decodes a texture's contents once, and
        // keeping the bytes here would hold every mesh file twice.)
        let bytes = read_checked(&path, "file", args.max_file_size, folder.as_deref())
            .map_err(|e| e.replace(&format!("`{}`", path.display()), &format!("`{rel}`")))?;
        // Only a part of a render needs it: hashing a large mesh byte by byte is not free.
        if args.fingerprint {
            sources.borrow_mut().files.push((rel.to_owned(), crate::part::digest(&bytes)));
        }
        Ok(bytes)
    };

    let load_start = Instant::now();
    let limits =
        lancer_scene::Limits { max_texture_pixels: args.max_texture_pixels, max_triangles: args.max_triangles };
    let loaded =
        lancer_scene::load_scene_within(&src, &name, registry, &resolve, &limits).map_err(anyhow::Error::msg)?;
    let load_time = load_start.elapsed();
    let (mut scene, warnings, mut places) = (loaded.scene, loaded.warnings, loaded.places);
    places.chosen_terms |= args.terms.is_some() || args.model.is_some();
    let (pipeline, model_file) = change_model(registry, args, loaded.pipeline)?;
    sources.borrow_mut().model_file = model_file;
    let img = &mut scene.image;
    resize(img, args.width, args.height);
    if let Some(s) = args.samples {
        s.apply(img);
    }
    check_pixels(img)?;
    let mut identity = sources.into_inner();
    let img = &scene.image;
    identity.model = crate::part::digest(crate::stats::effective_model(&pipeline, img).as_bytes());
    let mut settings = Vec::new();
    for x in [img.width, img.height, img.samples] {
        settings.extend(x.to_le_bytes());
    }
    if let Some(a) = img.adaptive {
        settings.extend(b"adaptive");
        settings.extend(a.threshold.to_bits().to_le_bytes());
        settings.extend(a.depth.to_le_bytes());
    }
    for c in img.background.to_array() {
        settings.extend(c.to_bits().to_le_bytes());
    }
    identity.image = crate::part::digest(&settings);
    Ok(Loaded { scene, pipeline, warnings, places, identity, name, source: src, load_time })
}

/// `--samples`: every pixel's number of samples, or adaptive anti-aliasing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Samples {
    /// `N`.
    Uniform(u32),
    /// `adaptive:threshold=T:depth=D`.
    Adaptive(lancer_core::Adaptive),
}

impl Samples {
    /// Sets the image's sampling to this (the scene's is replaced, adaptive or not).
    pub fn apply(self, image: &mut lancer_core::ImageSettings) {
        match self {
            Samples::Uniform(n) => image.set_samples(n),
            Samples::Adaptive(a) => image.set_adaptive(a),
        }
    }
}

/// Parses `--samples`: `N` (1 to 4096) or `adaptive[:threshold=T][:depth=D]`.
pub fn parse_samples(text: &str) -> std::result::Result<Samples, String> {
    let mut parts = text.split(':');
    let head = parts.next().unwrap_or_default().trim();
    if head != "adaptive" {
        return match head.parse::<u32>() {
            Ok(n) if (1..=lancer_scene::MAX_SAMPLES).contains(&n) && text.trim() == head => Ok(Samples::Uniform(n)),
            _ => Err(format!(
                "expected a whole number of samples per pixel from 1 to {}, or adaptive[:threshold=T][:depth=D], found `{text}`",
                lancer_scene::MAX_SAMPLES
            )),
        };
    }
    let mut adaptive = lancer_core::Adaptive::DEFAULT;
    for part in parts {
        let (key, value) = part
            .split_once('=')
            .ok_or_else(|| format!("`{part}`: give adaptive's parameters as KEY=VALUE, e.g. threshold=0.3"))?;
        match key.trim() {
            "threshold" => match value.trim().parse::<f32>() {
                Ok(t) if (0.0..=lancer_core::Adaptive::MAX_THRESHOLD).contains(&t) => adaptive.threshold = t,
                _ => return Err(format!("adaptive threshold: expected a number from 0 to 3, found `{value}`")),
            },
            "depth" => match value.trim().parse::<u32>() {
                Ok(d) if (lancer_core::Adaptive::MIN_DEPTH..=lancer_core::Adaptive::MAX_DEPTH).contains(&d) => {
                    adaptive.depth = d
                }
                _ => {
                    return Err(format!(
                        "adaptive depth: expected a whole number from {} to {}, found `{value}`",
                        lancer_core::Adaptive::MIN_DEPTH,
                        lancer_core::Adaptive::MAX_DEPTH
                    ));
                }
            },
            other => return Err(format!("adaptive has no parameter `{other}`; it takes threshold and depth")),
        }
    }
    Ok(Samples::Adaptive(adaptive))
}

/// Every term keeps a float image of the frame: the total is bounded before any is allocated.
pub(crate) fn check_pixels(img: &lancer_core::ImageSettings) -> Result<()> {
    let pixels = img.width as u64 * img.height as u64;
    if pixels > MAX_PIXELS {
        bail!(
            "an image of {}x{} is {pixels} pixels; Lancer renders at most {MAX_PIXELS} (8192x8192), one float image per term",
            img.width,
            img.height
        );
    }
    Ok(())
}

/// `args`' changes to the model `pipeline`, in this order: its model file (what the file sets),
/// its terms, its shadow model, its depth limit. Gives the new model and the model file's
/// digest.
pub(crate) fn change_model(
    registry: &Registry,
    args: &SceneArgs,
    pipeline: Pipeline,
) -> Result<(Pipeline, Option<String>)> {
    let (mut pipeline, model_file) = match &args.model {
        Some(p) => {
            let text = read(p, "model", args.max_file_size)?;
            let over = lancer_scene::load_model_over(&text, &p.display().to_string(), registry, pipeline)
                .map_err(anyhow::Error::msg)?;
            (over, Some(crate::part::digest(text.as_bytes())))
        }
        None => (pipeline, None),
    };
    if let Some(list) = &args.terms {
        let mut terms = Vec::with_capacity(list.len());
        for entry in list {
            let choice = Choice::parse(entry).map_err(anyhow::Error::msg).context("in --terms")?;
            // A name means its default variant, as in a scene file. When the scene has the
            // same term in the same variant, its parameters (weight included) stay unless given
            // again.
            let context = || format!("in --terms {entry}");
            let plain = registry.build_term(&choice.name, choice.variant.as_deref(), choice.over(&[]));
            let kept = plain
                .as_ref()
                .ok()
                .and_then(|built| pipeline.terms.iter().find(|t| t.name == built.name && t.variant == built.variant));
            // Said in the flag's syntax: a hint at another variant as `NAME:VARIANT:KEY=VALUE`.
            let flag = |e: lancer_shading::ModelError| anyhow::anyhow!(e.in_flag_syntax(entry));
            let term = match kept {
                Some(k) => registry
                    .build_term(&choice.name, Some(&k.variant), choice.over(&k.params))
                    .map_err(flag)
                    .with_context(context)?,
                None => plain.map_err(flag).with_context(context)?,
            };
            terms.push(term);
        }
        pipeline = Pipeline::new(pipeline.max_depth, pipeline.shadows, terms).context("in --terms")?;
    }
    if let Some(entry) = &args.shadows {
        let choice = Choice::parse(entry).map_err(anyhow::Error::msg).context("in --shadows")?;
        if let Some(v) = &choice.variant {
            return Err(anyhow::anyhow!(
                "a shadow model has no variant `{v}`; give parameters as KEY=VALUE, e.g. soft:samples=64"
            ))
            .with_context(|| format!("in --shadows {entry}"));
        }
        // The scene's parameters for the same model stay, unless given again.
        let kept = (pipeline.shadows.name == choice.name).then_some(pipeline.shadows.params.as_slice());
        pipeline.shadows = registry
            .build_shadow(&choice.name, choice.over(kept.unwrap_or_default()))
            .with_context(|| format!("in --shadows {entry}"))?;
    }
    if let Some(depth) = args.max_depth {
        pipeline.max_depth = depth;
    }
    Ok((pipeline, model_file))
}

/// Gives `img` the width and height asked for; only one of them, the other follows the
/// image's aspect ratio.
pub(crate) fn resize(img: &mut lancer_core::ImageSettings, width: Option<u32>, height: Option<u32>) {
    let aspect = img.width as f64 / img.height as f64;
    match (width, height) {
        (Some(w), Some(h)) => (img.width, img.height) = (w, h),
        (Some(w), None) => (img.width, img.height) = (w, ((w as f64 / aspect).round() as u32).max(1)),
        (None, Some(h)) => (img.width, img.height) = (((h as f64 * aspect).round() as u32).max(1), h),
        (None, None) => {}
    }
}

impl Loaded {
    /// Prepares the scene and gathers every warning: loading's, then the prepared scene's.
    pub(crate) fn prepare(&self) -> Result<(lancer_shading::Prepared, Vec<lancer_scene::Warning>)> {
        let prepared = lancer_shading::prepare(&self.scene).with_context(|| format!("preparing {}", self.name))?;
        let mut warnings = self.warnings.clone();
        warnings.extend(lancer_scene::check(&self.scene, &self.pipeline, &prepared, &self.places));
        Ok((prepared, warnings))
    }
}

fn check(registry: &Registry, args: CheckArgs) -> Result<()> {
    let loaded = load(registry, &args.input)?;
    let (prepared, warnings) = loaded.prepare()?;
    let mut shapes: Vec<(&str, usize)> = Vec::new();
    for o in &prepared.geometry.objects {
        match shapes.iter_mut().find(|(n, _)| *n == o.shape.name()) {
            Some((_, k)) => *k += 1,
            None => shapes.push((o.shape.name(), 1)),
        }
    }
    let shapes: Vec<String> = shapes.iter().map(|(n, k)| format!("{k} {n}")).collect();
    let img = &loaded.scene.image;
    println!("{}: loads and prepares", loaded.name);
    println!(
        "  {} object(s) ({}), {} light(s), {} material(s)",
        prepared.geometry.objects.len(),
        shapes.join(", "),
        prepared.lights.len(),
        // The prepared table ends with the default material for objects that name none.
        prepared.materials.len() - 1
    );
    // Named as the file names them, in its order (the numbering `explain` and the studio use).
    let objects = lancer_studio::session::object_labels(&prepared, &loaded.places);
    const LISTED: usize = 20;
    for o in objects.iter().take(LISTED) {
        println!("  {o}");
    }
    if objects.len() > LISTED {
        println!("  ... and {} more objects", objects.len() - LISTED);
    }
    if !loaded.places.materials.is_empty() {
        let names: Vec<String> = loaded.places.materials.iter().map(|m| format!("\"{m}\"")).collect();
        println!("  materials: {}", names.join(", "));
    }
    println!("  image {}x{}; model: {}", img.width, img.height, crate::stats::effective_model(&loaded.pipeline, img));
    for w in &warnings {
        println!("{w}");
    }
    println!("{} warning{}", warnings.len(), if warnings.len() == 1 { "" } else { "s" });
    Ok(())
}

fn render(registry: &Registry, args: RenderArgs) -> Result<()> {
    render_recording(registry, &args, &std::cell::RefCell::new(Vec::new()))
}

/// [`render`], adding to `inputs` every file it reads.
pub(crate) fn render_recording(registry: &Registry, args: &RenderArgs, inputs: &Inputs) -> Result<()> {
    // Check every output path before the (long) render, so a typo costs nothing. A part's
    // output is a part file whatever its name, but not one named as an image.
    let output = args.output();
    let format = match args.tile {
        Some(_) if Format::of(&output).is_ok() && !crate::output::is_stream(&output) => bail!(
            "with --tile, -o names a part file, which is no image: call it .lpart (e.g. -o part-0.lpart); \
             `lancer merge PARTS... -o {}` writes the image",
            output.display()
        ),
        Some(_) => Format::Exr,
        None => Format::of(&output)?,
    };
    // (The per-term images' folder, made before the render, may hold the image.)
    if let Some(folder) = output.parent().filter(|p| !p.as_os_str().is_empty())
        && !folder.is_dir()
        && args.aov.as_deref() != Some(folder)
    {
        bail!("cannot write {}: there is no folder {}", output.display(), folder.display());
    }
    if args.tile.is_some() && args.output_mistake.is_some() {
        bail!("--output-mistake shows a mistake in whole images; a part of a render (--tile) is written as it is");
    }
    if args.tile.is_some() && args.aov.is_some() {
        bail!("with --tile, the per-term images come from the merge: lancer merge PARTS... --aov DIR");
    }
    let input = SceneArgs { fingerprint: args.tile.is_some(), ..args.input.clone() };
    let loaded = load_recording(registry, &input, inputs)?;
    let (prepared, mut warnings) = loaded.prepare()?;
    if args.aov.is_none() && args.aov_format != AovFormat::default() {
        warnings.push(lancer_scene::Warning {
            place: None,
            message: "--aov-format has no effect without --aov DIR".to_owned(),
        });
    }
    for w in &warnings {
        eprintln!("{w}");
    }
    let Loaded { scene, pipeline, name, load_time, identity, .. } = loaded;
    if let Some((_, count)) = args.tile {
        let bands = scene.image.height.div_ceil(lancer_shading::TILE);
        if count > bands {
            bail!(
                "--tile I/{count}: the image has {bands} bands of {} rows, so at most {bands} parts",
                lancer_shading::TILE
            );
        }
    }
    if let Some(dir) = &args.aov {
        crate::output::create_output_dir(dir).context("creating the AOV directory")?;
    }

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0) as usize)
        .build()
        .context("starting worker threads")?;
    let bar = if args.quiet { indicatif::ProgressBar::hidden() } else { indicatif::ProgressBar::new(0) };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} rendering [{bar:40}] {pos}/{len} tiles{msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    // The estimate from the average time per tile since the start (tiles are done in an order
    // spread over the image, so the average holds), not from the last few.
    let started = Instant::now();
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        let elapsed = started.elapsed().as_secs_f64();
        if done >= 8 && elapsed > 0.5 {
            let left = elapsed * (total - done) as f64 / done as f64;
            bar.set_message(format!(", about {} left", indicatif::HumanDuration(Duration::from_secs_f64(left))));
        }
    };
    let timing = args.stats || args.stats_json.is_some();
    let start = Instant::now();
    let mut frame = pool.install(|| {
        lancer_shading::render_prepared(
            &prepared,
            &scene.camera,
            &scene.image,
            &pipeline,
            RenderOptions {
                progress: Some(&progress),
                timing,
                part: args.tile,
                cancel: None,
                // Per-term images only where they are written: --aov, or a part of a frame.
                layers: args.aov.is_some() || args.tile.is_some(),
                reference: args.reference,
                compact: false,
                scratch: None,
            },
        )
    });
    let elapsed = start.elapsed();
    bar.finish_and_clear();
    if let Some(mistake) = args.output_mistake {
        mistake.apply_to_frame(&mut frame);
    }

    let run = crate::stats::Run {
        scene: &name,
        image: &scene.image,
        pipeline: &pipeline,
        stats: &frame.stats,
        elapsed,
        threads: pool.current_num_threads(),
    };
    let beauty = &frame.beauty;
    pool.install(|| -> Result<()> {
        // The image first: when it cannot be written, the per-term images folder is left as
        // it was.
        match args.tile {
            Some((index, count)) => {
                let header = crate::part::Header {
                    identity: identity.fingerprint(),
                    sources: identity.clone(),
                    scene: name.clone(),
                    width: frame.width,
                    height: frame.height,
                    samples: scene.image.samples.max(1),
                    model: crate::stats::effective_model(&pipeline, &scene.image),
                    index,
                    count,
                    band_rows: lancer_shading::TILE,
                    layers: frame.layers.iter().map(|l| l.name.clone()).collect(),
                    rays: [frame.stats.camera_rays, frame.stats.secondary_rays, frame.stats.shadow_rays],
                    seconds: elapsed.as_secs_f64(),
                };
                crate::part::write(&output, &header, &frame)?;
            }
            None => format.write(&output, frame.width, frame.height, beauty)?,
        }
        if let Some(dir) = &args.aov {
            write_aovs(dir, &frame, beauty, args.aov_format, &|files| run.json(files))?;
        }
        if let Some(path) = &args.stats_json {
            crate::output::write_atomic(path, run.json(&[]).as_bytes())
                .with_context(|| format!("writing {}", path.display()))?;
        }
        crate::output::outputs_done();
        Ok(())
    })?;
    if args.stats {
        eprint!("{}", run.text());
    }
    if !args.quiet {
        eprintln!(
            "rendered {name} at {}x{} ({}) in {:.3} s: {:.2} M rays ({} camera, {} secondary, {} shadow), {:.1} M rays/s -> {}{} (scene loaded in {:.3} s{})",
            frame.width,
            frame.height,
            crate::stats::effective_model(&pipeline, &scene.image),
            elapsed.as_secs_f64(),
            frame.stats.total() as f64 / 1e6,
            frame.stats.camera_rays,
            frame.stats.secondary_rays,
            frame.stats.shadow_rays,
            frame.stats.total() as f64 / 1e6 / elapsed.as_secs_f64().max(1e-9),
            output.display(),
            args.aov.as_ref().map(|d| format!(" and {}/", d.display())).unwrap_or_default(),
            load_time.as_secs_f64(),
            peak_memory().map(|b| format!(", peak memory {:.1} MB", b as f64 / 1e6)).unwrap_or_default()
        );
    }
    Ok(())
}

fn serve(registry: &Registry, args: ServeArgs) -> Result<()> {
    if !args.host.is_loopback() {
        eprintln!(
            "warning: listening on {}: anyone who can reach this machine and learns the token can use the studio{}",
            match args.host {
                std::net::IpAddr::V6(a) => format!("[{a}]"),
                a => a.to_string(),
            },
            if args.read_only {
                " (read-only: each page's edits stay its own, and no one can Save)"
            } else {
                "; for a class, add --read-only (each student's edits stay in their own tab, and Save is off)"
            }
        );
    }
    let input = SceneArgs { confined: true, ..args.input.clone() };
    let reg = registry.clone();
    let loader: lancer_studio::Loader = std::sync::Arc::new(move || {
        let inputs = std::cell::RefCell::new(Vec::new());
        let loaded = load_recording(&reg, &input, &inputs).map_err(|e| format!("{e:#}"))?;
        // Prepared once, here: the studio renders from it (a large mesh's BVH is built once).
        let (prepared, warnings) = loaded.prepare().map_err(|e| format!("{e:#}"))?;
        let objects = lancer_studio::session::object_labels(&prepared, &loaded.places);
        Ok(lancer_studio::Loaded {
            prepared,
            source: loaded.source,
            path: input.scene.clone(),
            labels: loaded.places.materials.clone(),
            objects,
            warnings: warnings.iter().map(|w| w.to_string()).collect(),
            inputs: inputs.into_inner().into_iter().map(|(p, _)| p).collect(),
            name: loaded.name,
            scene: loaded.scene,
            pipeline: loaded.pipeline,
        })
    });
    let options = lancer_studio::Options {
        host: args.host,
        port: args.port,
        open: !args.no_open,
        allow_save: args.allow_save,
        allow_hosts: args.allow_host,
        read_only: args.read_only,
    };
    lancer_studio::serve(registry.clone(), loader, options)
}

fn export(registry: &Registry, args: ExportArgs) -> Result<()> {
    let ExportFormat::Pov = args.format;
    let loaded = load(registry, &args.input)?;
    let (prepared, _) = loaded.prepare()?;
    let stem = args.output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
    let e = crate::pov::export(
        &prepared,
        &loaded.scene.camera,
        &loaded.scene.image,
        &loaded.pipeline,
        &loaded.scene.textures,
        &format!("{stem}-texture"),
    );
    let folder = args.output.parent().filter(|p| !p.as_os_str().is_empty()).map(Path::to_path_buf).unwrap_or_default();
    for (name, k) in &e.textures {
        let t = &loaded.scene.textures[*k];
        let png = crate::output::encode_png(t.width, t.height, &t.linear_pixels())?;
        crate::output::write_atomic(&folder.join(name), &png).with_context(|| format!("writing {name}"))?;
    }
    crate::output::write_atomic(&args.output, e.text.as_bytes())
        .with_context(|| format!("writing {}", args.output.display()))?;
    for n in &e.notes {
        eprintln!("warning: POV-Ray: {n}");
    }
    eprintln!(
        "exported {} for POV-Ray 3.7 -> {}{}",
        loaded.name,
        args.output.display(),
        if e.textures.is_empty() { String::new() } else { format!(" (+ {} image maps)", e.textures.len()) }
    );
    Ok(())
}

fn merge(args: MergeArgs) -> Result<()> {
    let format = Format::of(&args.output)?;
    let start = Instant::now();
    let (frame, seconds, described) = crate::part::merge(&args.parts, args.max_file_size)?;
    if let Some(dir) = &args.aov {
        crate::output::create_output_dir(dir).context("creating the AOV directory")?;
    }
    let beauty = &frame.beauty;
    format.write(&args.output, frame.width, frame.height, beauty)?;
    if let Some(dir) = &args.aov {
        let manifest = |files: &[String]| {
            serde_json::to_string_pretty(&serde_json::json!({
                "generator": crate::stats::GENERATOR,
                "merged": described,
                "parts": args.parts.len(),
                "rays": { "camera": frame.stats.camera_rays, "secondary": frame.stats.secondary_rays, "shadow": frame.stats.shadow_rays },
                "render_seconds_all_parts": seconds,
                "files": files,
            }))
            .expect("plain data serialises")
        };
        write_aovs(dir, &frame, beauty, args.aov_format, &manifest)?;
    }
    crate::output::outputs_done();
    if !args.quiet {
        eprintln!(
            "merged {} parts of {described} in {:.3} s ({:.3} s of rendering in all) -> {}{}",
            args.parts.len(),
            start.elapsed().as_secs_f64(),
            seconds,
            args.output.display(),
            args.aov.as_ref().map(|d| format!(" and {}/", d.display())).unwrap_or_default()
        );
    }
    Ok(())
}

fn explain(registry: &Registry, args: ExplainArgs) -> Result<()> {
    let loaded = load(registry, &args.input)?;
    let (prepared, warnings) = loaded.prepare()?;
    for w in &warnings {
        eprintln!("{w}");
    }
    let objects = lancer_studio::session::object_labels(&prepared, &loaded.places);
    let Loaded { scene, pipeline, name, places, .. } = loaded;
    let (x, y) = args.pixel;
    let (w, h) = (scene.image.width, scene.image.height);
    if x >= w || y >= h {
        bail!("pixel {x},{y} is outside the {w}x{h} image (columns 0..{}, rows 0..{})", w - 1, h - 1);
    }
    let explanation = lancer_shading::explain_pixel(&prepared, &scene.camera, &scene.image, &pipeline, x, y);
    let report = lancer_output::Report {
        scene: &name,
        image: &scene.image,
        pipeline: &pipeline,
        explanation: &explanation,
        objects: &objects,
        materials: &places.materials,
    };
    if args.json {
        println!("{}", report.json());
    } else {
        print!("{}", report.text());
    }
    Ok(())
}

/// The most memory this process has held at once (its peak resident set), where the system
/// tells it (Linux's `/proc/self/status`).
fn peak_memory() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// The manifest `--aov` writes beside the images: the effective model, the statistics, and the
/// files written (so the next render into the folder knows which images were its
/// predecessor's).
const MANIFEST: &str = "manifest.json";

/// One EXR and one PNG per term, the background layer when it is not black, the beauty image,
/// and the manifest. Images an earlier render listed in the folder's manifest that this one does
/// not write are removed: they would no longer sum to the beauty image.
pub(crate) fn write_aovs(
    dir: &Path,
    frame: &Frame,
    beauty: &[glam::Vec3],
    which: AovFormat,
    manifest: &(dyn Fn(&[String]) -> String + Sync),
) -> Result<()> {
    let mut images: Vec<(&str, &[glam::Vec3])> = Vec::new();
    for layer in &frame.layers {
        if layer.name == BACKGROUND && layer.pixels.iter().all(|p| *p == glam::Vec3::ZERO) {
            continue;
        }
        // A layer's name becomes a file name: only a term's name by the registry's grammar (no
        // separator, no dot, not `beauty` or `manifest`) or the background may.
        if !(lancer_shading::is_term_name(&layer.name) || layer.name == BACKGROUND) {
            bail!("a layer named `{}` cannot be written as a file of {}", layer.name.escape_debug(), dir.display());
        }
        images.push((&layer.name, &layer.pixels));
    }
    images.push(("beauty", beauty));
    let formats = match which {
        AovFormat::Exr => &[Format::Exr][..],
        AovFormat::Png => &[Format::Png][..],
        AovFormat::Both => &[Format::Exr, Format::Png][..],
    };
    // Every image and format encoded on the worker threads, one per worker at a time (each
    // encoding holds its file's compressed lines in memory); each file then waits for the disk
    // on a short-lived thread of its own while the workers encode the next ones. Each file is
    // written whole or not at all.
    use rayon::prelude::*;
    let jobs: Vec<(&str, &[glam::Vec3], Format)> =
        images.iter().flat_map(|&(name, px)| formats.iter().map(move |&f| (name, px, f))).collect();
    let file_name =
        |name: &str, format: Format| format!("{name}.{}", if format == Format::Exr { "exr" } else { "png" });
    let files: Vec<String> = jobs.iter().map(|&(name, _, format)| file_name(name, format)).collect();
    let earlier = earlier_files(&dir.join(MANIFEST));
    std::thread::scope(|s| -> Result<()> {
        let started: Vec<Result<_>> = jobs
            .into_par_iter()
            .map(|(name, pixels, format)| {
                let pending =
                    format.begin_write(&dir.join(file_name(name, format)), frame.width, frame.height, pixels)?;
                // A thread refused is an error (the unfinished file's temporary is removed).
                std::thread::Builder::new()
                    .spawn_scoped(s, move || pending.finish())
                    .context("starting a thread to write an image")
            })
            .collect();
        // Every file encoded is put in place (or removed) before any error is told.
        let finished: Vec<Result<()>> = started
            .into_iter()
            .map(|h| h?.join().unwrap_or_else(|_| bail!("a thread writing an image panicked")))
            .collect();
        finished.into_iter().collect()
    })?;
    for stale in earlier.iter().filter(|f| !files.contains(f)) {
        // Only names a manifest of ours could list (a layer's image): never a path out of the
        // folder, nor another file in it.
        let ours = stale
            .strip_suffix(".exr")
            .or_else(|| stale.strip_suffix(".png"))
            .is_some_and(|stem| lancer_shading::is_term_name(stem) || stem == BACKGROUND);
        if ours {
            let _ = std::fs::remove_file(dir.join(stale));
        }
    }
    crate::output::write_atomic(&dir.join(MANIFEST), manifest(&files).as_bytes())
}

/// The files an earlier render's manifest lists (none if there is no readable manifest).
fn earlier_files(manifest: &Path) -> Vec<String> {
    let Ok(text) = std::fs::read_to_string(manifest) else { return Vec::new() };
    let Ok(doc) = serde_json::from_str::<serde_json::Value>(&text) else { return Vec::new() };
    // Only a manifest Lancer wrote: another tool's `manifest.json` names files Lancer must not touch.
    if doc["generator"] != crate::stats::GENERATOR {
        return Vec::new();
    }
    doc["files"]
        .as_array()
        .map(|a| a.iter().filter_map(|f| f.as_str().map(str::to_owned)).collect())
        .unwrap_or_default()
}
