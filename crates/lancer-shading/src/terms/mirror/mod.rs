//! The `mirror` term's variants: recursive reflection of the rest of the scene.
//!
//! | variant | weight of the reflected ray |
//! |---|---|
//! | `constant` (default, the handout's) | `spec` |
//! | `schlick` | Fresnel–Schlick `F0 + (1 − F0)(1 − cos θ)⁵`, `F0 = ((n − 1)/(n + 1))²` |
//!
//! Classic mistake of the course, kept as a variant to show it (`lancer terms --mistakes`):
//! `sign` (the reflected direction `u_r` with the wrong sign).

pub mod constant;
pub mod schlick;
pub mod sign;
