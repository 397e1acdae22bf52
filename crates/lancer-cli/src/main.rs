//! `lancer`: render a scene file (or the embedded showcase) with its lighting model, writing the
//! beauty image and, on request, one image per term; or list the registered terms.

fn main() -> std::process::ExitCode {
    lancer_cli::main_with(lancer_shading::Registry::with_builtins())
}
