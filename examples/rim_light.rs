//! A term defined outside Lancer: `rim`, a rim light that brightens silhouettes, registered at
//! start-up and used from a scene file like any built-in term. This program is the whole
//! `lancer` command line plus the new term:
//!
//! ```sh
//! cargo run --release -p lancer-examples --example rim_light -- render examples/rim-light.toml -o rim.png --aov out/
//! cargo run --release -p lancer-examples --example rim_light -- terms     # lists `rim` beside the built-ins
//! ```
//!
//! Formula: with `v = −u` towards the viewer, `Col += strength · (1 − max(N·v, 0))^power · Col_Ω`.
//! Reads: `color`. Parameters: `strength` (default 0.6), `power` (default 3), and `weight`.
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", { term = "rim", strength = 0.8, power = 4 }]
//! ```

use std::process::ExitCode;

use lancer_shading::{Chunk, ParamError, ParamSpec, Params, Registry, ShadeContext, Term, TermOutput, TermSpec};

/// How the registry builds `rim` from its parameters.
const RIM: TermSpec = TermSpec {
    name: "rim",
    variant: "fresnel-like",
    summary: "strength · (1 − N·v)^power · Col_Ω: a rim light that outlines silhouettes",
    reads: &["color"],
    params: &[
        ParamSpec { name: "strength", default: "0.6", doc: "brightness of the rim" },
        ParamSpec { name: "power", default: "3", doc: "how thin the rim is (higher: thinner)" },
    ],
    build: build_rim,
    mistake: None,
};

fn build_rim(p: &mut Params) -> Result<Box<dyn Term>, ParamError> {
    Ok(Box::new(Rim {
        strength: p.number("strength", 0.6, 0.0, 10.0)? as f32,
        power: p.number("power", 3.0, 0.1, 64.0)? as f32,
    }))
}

struct Rim {
    strength: f32,
    power: f32,
}

impl Term for Rim {
    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        for lane in chunk.hit_lanes() {
            let facing_viewer = chunk.hits.facing_normal(lane).dot(-chunk.rays.dir.at(lane)).clamp(0.0, 1.0);
            let rim = self.strength * (1.0 - facing_viewer).powf(self.power);
            out.add(lane, rim * ctx.color(chunk.hits, lane));
        }
    }
}

fn main() -> ExitCode {
    let mut registry = Registry::with_builtins();
    if let Err(e) = registry.register_term(RIM) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    lancer_cli::main_with(registry)
}
