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
    /// The shadow rays that met something before the light.
    pub blocked: u64,
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
        blocked: count("blocked")?,
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
        assert_eq!(p.blocked, 0);
        assert!((p.rates()[0] - 0.0499 / 230_400.0).abs() < 1e-15);
        assert!(parse("embree build 0.75 triangles 10 camera 5").is_err());
        assert!(parse("embree build 1 triangles 1 camera 1 1 mirror 1 1 shadow 1 1").is_err(), "no blocked count");
        assert!(parse("lancer build 1 triangles 1 camera 1 1 mirror 1 1 shadow 1 1 blocked 0").is_err());
        // A kind with no rays has no rate.
        let none = parse("embree build 1 triangles 1 camera 1 1 mirror 0 0 shadow 1 1 blocked 0").unwrap();
        assert!(none.rates()[1].is_nan());
    }

    /// The harness built, or `None` where Embree 3 (or a C compiler) is missing: allowed on a
    /// developer's machine, not in CI (`CI` set), which installs libembree-dev.
    fn harness(dir: &Path) -> Option<std::path::PathBuf> {
        match build(dir) {
            Ok(h) => Some(h),
            Err(e) if std::env::var_os("CI").is_none() && e.to_string().contains("not installed") => {
                eprintln!("skipped: {e}");
                None
            }
            Err(e) if std::env::var_os("CI").is_none() && e.to_string().contains("no C compiler") => {
                eprintln!("skipped: {e}");
                None
            }
            Err(e) => panic!("{e:#}"),
        }
    }

    fn view(max_depth: u32) -> Field {
        Field {
            from: [0.0, 5.0, -10.0],
            to: [0.0, 0.0, 0.0],
            fov: 40.0,
            light: [0.0, 10.0, 0.0],
            max_depth,
            width: 8,
            height: 6,
        }
    }

    /// A floor under the whole view and a ceiling over it (y = 0 and 20, each a quad, so two
    /// triangles), the light between them. Every camera ray hits the floor; its mirror ray
    /// rises to the ceiling, whose mirror ray comes down to the floor again: `max_depth`
    /// generations of 48 mirror rays, and a shadow ray at every hit, none blocked.
    #[test]
    fn the_embree_harness_traces_max_depth_generations_of_mirror_rays() {
        let dir = std::env::temp_dir().join(format!("lancer-embree-test-{}", std::process::id()));
        let Some(harness) = harness(&dir) else { return };
        let obj = dir.join("room.obj");
        std::fs::write(
            &obj,
            "v -1000 0 -1000\nv 1000 0 -1000\nv 1000 0 1000\nv -1000 0 1000\nf 1 2 3 4\n\
             v -1000 20 -1000\nv 1000 20 -1000\nv 1000 20 1000\nv -1000 20 1000\nf -4 -3 -2 -1\n",
        )
        .unwrap();
        let counts = |max_depth| {
            let p = run(&harness, &obj, &view(max_depth)).unwrap();
            assert_eq!(p.triangles, 4, "two quads, each a fan of two triangles");
            assert_eq!(p.blocked, 0);
            p.kinds.map(|k| k.0)
        };
        assert_eq!(counts(0), [48, 0, 48]);
        assert_eq!(counts(1), [48, 48, 96]);
        assert_eq!(counts(2), [48, 96, 144]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A square between the light and the floor's middle: the shadow rays of the floor points
    /// behind it from the light (|x| and |z| under 15) are blocked, the farther ones not.
    #[test]
    fn the_embree_harness_counts_shadow_rays_blocked_on_the_way_to_the_light() {
        let dir = std::env::temp_dir().join(format!("lancer-embree-shade-{}", std::process::id()));
        let Some(harness) = harness(&dir) else { return };
        let obj = dir.join("shade.obj");
        std::fs::write(
            &obj,
            "v -1000 0 -1000\nv 1000 0 -1000\nv 1000 0 1000\nv -1000 0 1000\nf 1 2 3 4\n\
             v -3 8 -3\nv 3 8 -3\nv 3 8 3\nv -3 8 3\nf 5 6 7 8\n",
        )
        .unwrap();
        let p = run(&harness, &obj, &view(0)).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(p.kinds.map(|k| k.0), [48, 0, 48]);
        assert!(p.blocked > 0 && p.blocked < 48, "{} of 48 blocked", p.blocked);
    }
}
