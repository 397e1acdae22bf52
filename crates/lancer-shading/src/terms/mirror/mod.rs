//! The `mirror` term's variants: recursive reflection of the rest of the scene.
//!
//! | variant | weight of the reflected ray |
//! |---|---|
//! | `constant` (default, the handout's) | `spec` |
//! | `schlick` | Fresnel–Schlick `F0 + (1 − F0)(1 − cos θ)⁵`, `F0 = ((n − 1)/(n + 1))²` |

pub mod constant;
pub mod schlick;
