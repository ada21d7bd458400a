//! The `stiction` binary: a thin wrapper around [`stiction_cli::run`].
fn main() -> std::process::ExitCode {
    stiction_cli::run()
}
