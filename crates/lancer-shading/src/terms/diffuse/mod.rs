//! The `diffuse` term's variants: matte reflection.
//!
//! | variant | formula per light |
//! |---|---|
//! | `lambert` (default, the handout's) | `diff · (N·w) · Col_Ω · Col_L` |
//! | `oren-nayar` | Lambert times `A + B · max(0, cos(φ_i − φ_r)) · sin α · tan β` (rough surfaces) |
//!
//! Classic mistake of the course, kept as a variant to show it (`lancer terms --mistakes`):
//! `no-clamp` (`N·w` without `max(…, 0)`).

pub mod lambert;
pub mod no_clamp;
pub mod oren_nayar;
