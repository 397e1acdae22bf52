//! Runnable examples of Lancer used as a library; see `rim_light.rs` (`cargo run --release -p
//! lancer-examples --example rim_light -- render examples/rim-light.toml`).
