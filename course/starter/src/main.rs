//! The whole `lancer` command line with your terms registered beside Lancer's: render a course
//! scene with yours and compare it, diagnose it, or explain a pixel.
//!
//! ```sh
//! cargo run --release -- render ../ex1-ambient.toml --terms student-ambient -o mine.png --aov mine/
//! cargo run --release -- terms      # lists student-ambient ... student-refraction
//! ```

use std::process::ExitCode;

fn main() -> ExitCode {
    lancer_cli::main_with(lancer_starter::registry())
}
