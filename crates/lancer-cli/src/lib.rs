//! The `lancer` command's library half: encoding frames to PNG (sRGB, 8-bit) and EXR (linear
//! float), and writing files whole or not at all. The binary in `main.rs` parses flags and
//! composes the other crates.

pub mod listing;
pub mod output;
