//! The `stiction` command line.
use std::process::ExitCode;
/// Run with the process arguments.
pub fn run() -> ExitCode {
    ExitCode::SUCCESS
}
