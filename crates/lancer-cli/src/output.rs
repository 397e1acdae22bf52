//! Image files and atomic file output: the encoders (from `lancer-output`) written to files whole
//! or not at all.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use glam::Vec3;

pub use lancer_output::encode::{encode_exr, encode_png, srgb_encode, to_srgb8};
use lancer_output::encode::{write_exr, write_png};

/// The image formats `lancer` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// sRGB 8-bit PNG.
    Png,
    /// Linear float OpenEXR.
    Exr,
}

impl Format {
    /// The format a path's extension asks for; PNG for a device or a pipe that has none
    /// (`-o /dev/null`, `-o /dev/stdout`).
    pub fn of(path: &Path) -> Result<Format> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("png") => Ok(Format::Png),
            Some("exr") => Ok(Format::Exr),
            _ if is_stream(path) => Ok(Format::Png),
            _ => bail!("output {} must end in .png (sRGB 8-bit) or .exr (linear float)", path.display()),
        }
    }

    /// Encodes a linear image in this format.
    pub fn encode(self, width: u32, height: u32, pixels: &[Vec3]) -> Result<Vec<u8>> {
        match self {
            Format::Png => Ok(encode_png(width, height, pixels)?),
            Format::Exr => Ok(encode_exr(width, height, pixels)?),
        }
    }

    /// Writes a linear image in this format to `path`, whole or not at all, encoding straight
    /// into the file (no copy of the encoded image in memory).
    pub fn write(self, path: &Path, width: u32, height: u32, pixels: &[Vec3]) -> Result<()> {
        self.begin_write(path, width, height, pixels)?.finish()
    }

    /// The first half of [`Format::write`]: the image encoded into a temporary file beside
    /// `path`, which [`Pending::finish`] puts in place.
    pub fn begin_write(self, path: &Path, width: u32, height: u32, pixels: &[Vec3]) -> Result<Pending> {
        Pending::begin(path, |file| {
            let mut out = BufWriter::new(file);
            match self {
                Format::Png => write_png(&mut out, width, height, pixels)?,
                Format::Exr => write_exr(&mut out, width, height, pixels)?,
            }
            out.flush()?;
            Ok(())
        })
    }
}

/// Whether `path` is a character device, a pipe or a socket (`/dev/null`, `/dev/stdout`, a
/// FIFO): written to as it is, not through a temporary file renamed over it (which would
/// replace the device, or fail). A link is followed only under `/dev` and `/proc/self/fd`,
/// where the system makes them (`/dev/stdout` is one): a link planted beside the outputs is
/// replaced, as a file is, never written through. Block devices are never written to.
pub fn is_stream(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let system = path.starts_with("/dev") || path.starts_with("/proc/self/fd");
        let meta = if system { std::fs::metadata(path) } else { std::fs::symlink_metadata(path) };
        meta.is_ok_and(|m| {
            let t = m.file_type();
            t.is_char_device() || t.is_fifo() || t.is_socket()
        })
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        false
    }
}

/// Writes `bytes` to `path` whole or not at all: into a temporary file beside it, then renamed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    atomically(path, |f| Ok(f.write_all(bytes)?))
}

/// The temporary files being written now, removed by [`remove_temporaries`] when the program
/// is interrupted or stopped.
static TEMPORARIES: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Folders this run created for its output, with the files it put in them: removed, files and
/// folder, when the program is interrupted or stopped (the folder's other files, if another
/// program wrote any meanwhile, keep it).
static CREATED_DIRS: std::sync::Mutex<Vec<(PathBuf, Vec<PathBuf>)>> = std::sync::Mutex::new(Vec::new());

fn lock<T>(m: &std::sync::Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Creates the folder `dir` for output (and its parents), remembering it if it is new, so an
/// interrupt leaves no folder of this run's behind.
pub fn create_output_dir(dir: &Path) -> Result<()> {
    let new = std::fs::symlink_metadata(dir).is_err();
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    if new {
        lock(&CREATED_DIRS).push((dir.to_path_buf(), Vec::new()));
    }
    Ok(())
}

/// Every output of a run is in place: the folders it created are no longer its to remove if it
/// is stopped now (`watch` goes on after its renders; Ctrl-C must not take their images).
pub fn outputs_done() {
    lock(&CREATED_DIRS).clear();
}

/// Removes every temporary file being written, and every output folder this run created with the
/// files it wrote there (for an interrupt or a stop: no partial output is left).
pub fn remove_temporaries() {
    remove_under(Path::new(""));
}

/// [`remove_temporaries`] for the files and folders under `root` only (everything for `""`).
fn remove_under(root: &Path) {
    for tmp in lock(&TEMPORARIES).iter().filter(|t| t.starts_with(root)) {
        let _ = std::fs::remove_file(tmp);
    }
    for (dir, files) in lock(&CREATED_DIRS).iter().filter(|(d, _)| d.starts_with(root)) {
        for f in files {
            let _ = std::fs::remove_file(f);
        }
        let _ = std::fs::remove_dir(dir);
    }
}

/// Runs `fill` on a temporary file beside `path`, flushes it to disk and renames it to `path`;
/// on any error the temporary file is removed and `path` is untouched.
fn atomically(path: &Path, fill: impl FnOnce(&mut std::fs::File) -> Result<()>) -> Result<()> {
    Pending::begin(path, fill)?.finish()
}

/// A file written in full to a temporary file beside its path, not yet flushed to disk nor
/// renamed into place: [`Pending::finish`] does both (and can run on another thread, so that
/// waiting for the disk does not hold up encoding the next file). Dropped unfinished, it
/// removes its temporary file and leaves the path untouched.
///
/// The temporary file is created exclusively (`O_EXCL`) under an unpredictable name in the
/// path's folder, so a symlink or file planted there is never followed nor overwritten; it takes
/// the permissions of the file it replaces (or a new file's usual ones); the rename replaces the
/// path itself, so a symlink planted at the path is replaced, never its target.
pub struct Pending {
    file: Option<Target>,
    /// The temporary file's path, as registered for [`remove_temporaries`].
    tmp: PathBuf,
    path: PathBuf,
}

/// What a [`Pending`] writes into.
enum Target {
    /// A temporary file beside the path, renamed to it when finished.
    Temporary(tempfile::NamedTempFile),
    /// The path itself, a device or a pipe ([`is_stream`]): written as it is.
    Stream(std::fs::File),
}

/// A new temporary file in `path`'s folder, to be renamed to `path`: created exclusively under an
/// unpredictable name, with the permissions of the file at `path` when that is a regular file.
pub fn temporary_for(path: &Path) -> Result<tempfile::NamedTempFile> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().with_context(|| format!("{} is not a file path", path.display()))?;
    let existing = std::fs::symlink_metadata(path).ok().filter(|m| m.is_file()).map(|m| m.permissions());
    let prefix = format!(".{}.", name.to_string_lossy());
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // A new file's usual permissions (0666 less the umask), not the temporary's private 0600.
    #[cfg(unix)]
    let new_file = <std::fs::Permissions as std::os::unix::fs::PermissionsExt>::from_mode(0o666);
    #[cfg(unix)]
    builder.permissions(new_file);
    let tmp = builder.tempfile_in(dir).with_context(|| format!("creating a temporary file in {}", dir.display()))?;
    if let Some(p) = existing {
        // Exactly the replaced file's mode (the umask would narrow it at creation).
        tmp.as_file().set_permissions(p).with_context(|| format!("keeping the permissions of {}", path.display()))?;
    }
    Ok(tmp)
}

impl Pending {
    /// Runs `fill` on a new temporary file beside `path`.
    fn begin(path: &Path, fill: impl FnOnce(&mut std::fs::File) -> Result<()>) -> Result<Pending> {
        if is_stream(path) {
            // Opened as it is (a pipe waits for its reader), neither created nor truncated.
            let mut file = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .with_context(|| format!("writing {}", path.display()))?;
            fill(&mut file).with_context(|| format!("writing {}", path.display()))?;
            return Ok(Pending { file: Some(Target::Stream(file)), tmp: PathBuf::new(), path: path.to_path_buf() });
        }
        // Created and registered under the registry's lock, so a stop in between (whose cleanup
        // takes the lock) cannot miss it.
        let (file, tmp) = {
            let mut registry = lock(&TEMPORARIES);
            let file = temporary_for(path).with_context(|| format!("writing {}", path.display()))?;
            let tmp = file.path().to_path_buf();
            registry.push(tmp.clone());
            (file, tmp)
        };
        // From here on, dropping `pending` (on an error) removes the temporary file.
        let mut pending = Pending { file: Some(Target::Temporary(file)), tmp, path: path.to_path_buf() };
        let Some(Target::Temporary(f)) = pending.file.as_mut() else { unreachable!("just set") };
        fill(f.as_file_mut()).with_context(|| format!("writing {}", path.display()))?;
        Ok(pending)
    }

    /// Flushes the file to disk and renames it to its path (a device or pipe is already
    /// written).
    pub fn finish(mut self) -> Result<()> {
        let file = match self.file.take().expect("a pending file is filled") {
            Target::Temporary(file) => file,
            // Nothing to rename nor to sync (a device or pipe may refuse `fsync`).
            Target::Stream(mut file) => {
                return file.flush().with_context(|| format!("writing {}", self.path.display()));
            }
        };
        let result = file
            .as_file()
            .sync_all()
            .map_err(anyhow::Error::from)
            .and_then(|()| file.persist(&self.path).map(drop).map_err(|e| anyhow::Error::from(e.error)));
        // Whatever happened, the temporary is no longer ours to remove: persisted, or removed by
        // the failed persist's drop.
        self.untrack();
        self.tmp = PathBuf::new();
        result.with_context(|| format!("writing {}", self.path.display()))?;
        // A file in a folder this run created goes with the folder if the run is stopped.
        let dir = self.path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        if let Some((_, files)) = lock(&CREATED_DIRS).iter_mut().find(|(d, _)| d == dir) {
            files.push(self.path.clone());
        }
        Ok(())
    }

    fn untrack(&self) {
        lock(&TEMPORARIES).retain(|p| *p != self.tmp);
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            // The temporary file removes itself when dropped.
            self.file = None;
            self.untrack();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn a_pending_file_appears_only_when_finished_and_leaves_nothing_when_dropped() {
        let folder = tempfile::tempdir().unwrap();
        let dir = folder.path();
        let listing = || {
            let mut names: Vec<String> = std::fs::read_dir(dir)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            names.sort();
            names
        };
        let path = dir.join("a.bin");
        let pending = Pending::begin(&path, |f| Ok(f.write_all(b"abc")?)).unwrap();
        assert!(!path.exists(), "not in place before finish");
        assert_eq!(listing().len(), 1, "one temporary file: {:?}", listing());
        pending.finish().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"abc");
        assert_eq!(listing(), ["a.bin"]);
        // Dropped unfinished: the old file stays, the temporary goes.
        drop(Pending::begin(&path, |f| Ok(f.write_all(b"new")?)).unwrap());
        assert_eq!(std::fs::read(&path).unwrap(), b"abc");
        assert_eq!(listing(), ["a.bin"]);
        // Two writers of one path at once: a temporary file each, the last finished wins.
        let (one, two) = (
            Pending::begin(&path, |f| Ok(f.write_all(b"one")?)).unwrap(),
            Pending::begin(&path, |f| Ok(f.write_all(b"two")?)).unwrap(),
        );
        assert_eq!(listing().len(), 3, "{:?}", listing());
        one.finish().unwrap();
        two.finish().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        assert_eq!(listing(), ["a.bin"]);
        // A failing fill: an error naming the file, nothing left behind.
        let err = Pending::begin(&dir.join("b.bin"), |_| bail!("no room")).err().unwrap();
        assert!(format!("{err:#}").contains("b.bin") && format!("{err:#}").contains("no room"), "{err:#}");
        assert_eq!(listing(), ["a.bin"]);
        assert!(TEMPORARIES.lock().unwrap().iter().all(|t| !t.starts_with(dir)), "none still tracked");
    }

    #[cfg(unix)]
    #[test]
    fn regression_symlinks_planted_at_temporary_names_or_the_output_are_never_followed() {
        // Found in review: temporaries were `.NAME.PID.K.tmp`, opened with create-or-truncate:
        // a symlink planted at that name had its target outside the folder overwritten, and the
        // output path became a symlink to it.
        use std::os::unix::fs::{PermissionsExt, symlink};
        let folder = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        let target = outside.path().join("precious");
        std::fs::write(&target, b"keep me").unwrap();
        let dir = folder.path();
        let path = dir.join("out.png");
        // Every name the old scheme could have picked in this process, and a few more.
        for k in 0..256 {
            symlink(&target, dir.join(format!(".out.png.{}.{k}.tmp", std::process::id()))).unwrap();
        }
        write_atomic(&path, b"image").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"keep me");
        assert!(std::fs::symlink_metadata(&path).unwrap().is_file());
        // The output path itself a symlink out of the folder: replaced, its target untouched.
        let linked = dir.join("linked.png");
        symlink(&target, &linked).unwrap();
        write_atomic(&linked, b"image").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"keep me");
        let meta = std::fs::symlink_metadata(&linked).unwrap();
        assert!(meta.is_file() && !meta.file_type().is_symlink());
        assert_eq!(std::fs::read(&linked).unwrap(), b"image");
        // An existing file keeps its permissions; a new one gets a new file's usual ones.
        let private = dir.join("private.exr");
        std::fs::write(&private, b"old").unwrap();
        std::fs::set_permissions(&private, std::fs::Permissions::from_mode(0o600)).unwrap();
        write_atomic(&private, b"new").unwrap();
        assert_eq!(std::fs::metadata(&private).unwrap().permissions().mode() & 0o777, 0o600);
        let shared = dir.join("shared.exr");
        std::fs::write(&shared, b"old").unwrap();
        std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o664)).unwrap();
        write_atomic(&shared, b"new").unwrap();
        assert_eq!(std::fs::metadata(&shared).unwrap().permissions().mode() & 0o777, 0o664);
        let usual = std::fs::File::create(dir.join("usual")).unwrap().metadata().unwrap().permissions().mode();
        write_atomic(&dir.join("fresh.exr"), b"new").unwrap();
        assert_eq!(std::fs::metadata(dir.join("fresh.exr")).unwrap().permissions().mode(), usual);
    }

    #[test]
    fn regression_a_stop_removes_the_output_folder_it_created_with_the_files_written_there() {
        // Found in review: a stop while the per-term images were being written left the new
        // `--aov` folder with some of them (only an empty folder was removed).
        let folder = tempfile::tempdir().unwrap();
        let existing = folder.path().join("existing");
        std::fs::create_dir(&existing).unwrap();
        std::fs::write(existing.join("mine.txt"), b"not Lancer's").unwrap();
        create_output_dir(&existing).unwrap();
        write_atomic(&existing.join("beauty.png"), b"x").unwrap();
        let created = folder.path().join("aov");
        create_output_dir(&created).unwrap();
        write_atomic(&created.join("ambient.exr"), b"x").unwrap();
        write_atomic(&created.join("beauty.exr"), b"x").unwrap();
        let unfinished = Pending::begin(&created.join("diffuse.exr"), |f| Ok(f.write_all(b"half")?)).unwrap();
        remove_under(folder.path());
        assert!(!created.exists(), "the folder this run created is gone with its files");
        assert!(existing.join("mine.txt").exists() && existing.join("beauty.png").exists(), "an existing folder stays");
        drop(unfinished);
        // Once a run's outputs are all in place, a stop takes nothing (a watch's earlier image).
        let kept = folder.path().join("kept");
        create_output_dir(&kept).unwrap();
        write_atomic(&kept.join("beauty.exr"), b"x").unwrap();
        outputs_done();
        remove_under(folder.path());
        assert!(kept.join("beauty.exr").exists(), "a finished run's folder stays");
    }

    #[test]
    fn unknown_extension_is_refused() {
        assert!(Format::of(Path::new("x.jpg")).unwrap_err().to_string().contains(".png"));
        assert_eq!(Format::of(Path::new("x.EXR")).unwrap(), Format::Exr);
    }
}
