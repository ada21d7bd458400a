//! A `stiction` binary that also knows the `backlash` model of this crate.
use custom_model as _;

fn main() -> std::process::ExitCode {
    stiction_cli::run()
}
