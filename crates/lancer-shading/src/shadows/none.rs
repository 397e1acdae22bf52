//! `none`: every light reaches every point that faces it.
//!
//! Formula: transmittance = 1. Reads no material parameter, has no parameter.
//!
//! ```toml
//! [model]
//! shadows = "none"
//! ```

use glam::Vec3;
use lancer_core::Light;
use lancer_shapes::Hit;

use crate::{Params, ShadowContext, ShadowModel, ShadowSpec};

/// The spec registered under `none`.
pub const SPEC: ShadowSpec = ShadowSpec {
    name: "none",
    summary: "no shadows: every light reaches every surface that faces it",
    params: &[],
    build: |_: &mut Params| Ok(Box::new(NoShadows)),
    mistake: None,
};

struct NoShadows;

impl ShadowModel for NoShadows {
    fn transmittance(&self, _: &ShadowContext<'_>, _: &Hit, _: &Light) -> Vec3 {
        Vec3::ONE
    }
}
