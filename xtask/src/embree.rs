//! `cargo xtask bench`'s mesh row against Embree 3: the 1M-triangle height field traced by a small
//! C harness (`embree_harness.c`, compiled here with `cc` against Debian's libembree-dev) one ray
//! at a time, and Lancer's 1-thread frame of the same scene priced at Embree's rates.

use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};

/// The harness's source, written out beside the binary it is compiled into.
const HARNESS: &str = include_str!("embree_harness.c");

/// The height-field scene both trace: its camera, its one light and its depth (the bench's
/// field scenes are written from these too).
pub struct Field {
    pub from: [f64; 3],
    pub to: [f64; 3],
    pub fov: f64,
    pub light: [f64; 3],
    pub max_depth: u32,
    pub width: u32,
    pub height: u32,
}

pub const FIELD: Field = Field {
    from: [0.0, 7.0, -13.0],
    to: [0.0, 0.0, 1.0],
    fov: 50.0,
    light: [-6.0, 12.0, -8.0],
    max_depth: 2,
    width: 640,
    height: 360,
};

/// One harness run: its BVH build time, and for each kind of ray (camera, mirror, shadow) how
/// many it traced and in how many seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Priced {
    pub build: f64,
    pub triangles: u64,
    /// `[camera, mirror, shadow]`: (rays, seconds).
    pub kinds: [(u64, f64); 3],
}

impl Priced {
    /// Seconds per ray of each kind (NaN for a kind it traced none of).
    pub fn rates(&self) -> [f64; 3] {
        self.kinds.map(|(n, s)| if n > 0 { s / n as f64 } else { f64::NAN })
    }
}

/// Reads the harness's line: `embree build S triangles N camera N S mirror N S shadow N S ...`.
pub fn parse(line: &str) -> Result<Priced> {
    let words: Vec<&str> = line.split_whitespace().collect();
    let after = |key: &str, k: usize| -> Result<&str> {
        let at = words.iter().position(|w| *w == key).with_context(|| format!("no `{key}` in `{line}`"))?;
        words.get(at + k).copied().with_context(|| format!("`{key}` without its value in `{line}`"))
    };
    let number = |key: &str, k: usize| -> Result<f64> {
        after(key, k)?.parse::<f64>().with_context(|| format!("`{key}` is not followed by a number in `{line}`"))
    };
    let count = |key: &str| -> Result<u64> {
        after(key, 1)?.parse::<u64>().with_context(|| format!("`{key}` is not followed by a count in `{line}`"))
    };
    if words.first() != Some(&"embree") {
        bail!("not the harness's line: `{line}`");
    }
    let kind = |key: &str| -> Result<(u64, f64)> { Ok((count(key)?, number(key, 2)?)) };
    Ok(Priced {
        build: number("build", 1)?,
        triangles: count("triangles")?,
        kinds: [kind("camera")?, kind("mirror")?, kind("shadow")?],
    })
}

/// Compiles the harness into `dir` (`embree-harness`): its path, or why it cannot be (no C
/// compiler, or Embree 3 not installed).
pub fn build(dir: &Path) -> Result<std::path::PathBuf> {
    let cc = crate::which("cc").context("no C compiler (`cc`) to build the Embree harness with")?;
    std::fs::create_dir_all(dir)?;
    let source = dir.join("embree-harness.c");
    std::fs::write(&source, HARNESS)?;
    let binary = dir.join("embree-harness");
    let out = Command::new(cc)
        .args(["-O2", "-o"])
        .arg(&binary)
        .arg(&source)
        .args(["-lembree3", "-lm"])
        .output()
        .context("running cc")?;
    if !out.status.success() {
        let text = String::from_utf8_lossy(&out.stderr);
        if text.contains("embree3/rtcore.h") || text.contains("-lembree3") {
            bail!("Embree 3 is not installed (Debian: apt-get install libembree-dev)");
        }
        bail!("compiling the Embree harness failed: {text}");
    }
    Ok(binary)
}

/// Runs the harness on `obj` with the camera, light and depth of `f`.
pub fn run(harness: &Path, obj: &Path, f: &Field) -> Result<Priced> {
    let mut args: Vec<String> = vec![f.width.to_string(), f.height.to_string()];
    args.extend(f.from.iter().chain(&f.to).map(f64::to_string));
    args.push(f.fov.to_string());
    args.extend(f.light.iter().map(f64::to_string));
    args.push(f.max_depth.to_string());
    let out = Command::new(harness).arg(obj).args(&args).output().context("running the Embree harness")?;
    if !out.status.success() {
        bail!("the Embree harness failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    parse(String::from_utf8_lossy(&out.stdout).trim())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_harness_line_reads_back_each_kind_of_ray() {
        let p = parse(
            "embree build 0.75 triangles 999698 camera 230400 0.0499 mirror 156079 0.0581 shadow 156521 0.0399 blocked 0",
        )
        .unwrap();
        assert_eq!(p.triangles, 999_698);
        assert_eq!(p.kinds, [(230_400, 0.0499), (156_079, 0.0581), (156_521, 0.0399)]);
        assert!((p.rates()[0] - 0.0499 / 230_400.0).abs() < 1e-15);
        assert!(parse("embree build 0.75 triangles 10 camera 5").is_err());
        assert!(parse("lancer build 1 triangles 1 camera 1 1 mirror 1 1 shadow 1 1").is_err());
        // A kind with no rays has no rate.
        let none = parse("embree build 1 triangles 1 camera 1 1 mirror 0 0 shadow 1 1").unwrap();
        assert!(none.rates()[1].is_nan());
    }

    /// The harness itself, where Embree 3 is installed (CI installs it): a floor under the
    /// whole view, a light above, no second bounce. Every pixel's camera ray hits, each hit sends
    /// one mirror ray (which leaves the scene upward) and one shadow ray.
    #[test]
    fn the_embree_harness_traces_a_floor_seen_by_every_pixel() {
        let dir = std::env::temp_dir().join(format!("lancer-embree-test-{}", std::process::id()));
        let harness = match build(&dir) {
            Ok(h) => h,
            Err(e) if e.to_string().contains("not installed") || e.to_string().contains("no C compiler") => {
                eprintln!("skipped: {e}");
                return;
            }
            Err(e) => panic!("{e:#}"),
        };
        let obj = dir.join("floor.obj");
        std::fs::write(&obj, "v -1000 0 -1000\nv 1000 0 -1000\nv 1000 0 1000\nv -1000 0 1000\nf 1 2 3 4\n").unwrap();
        let floor = Field {
            from: [0.0, 5.0, -10.0],
            to: [0.0, 0.0, 0.0],
            fov: 40.0,
            light: [0.0, 10.0, 0.0],
            max_depth: 2,
            width: 8,
            height: 6,
        };
        let p = run(&harness, &obj, &floor).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(p.triangles, 2, "the quad as a fan of two triangles");
        assert_eq!(p.kinds.map(|k| k.0), [48, 48, 48]);
    }
}
