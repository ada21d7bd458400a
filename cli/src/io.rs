//! Standard streams as trait objects, so tests can run the CLI in memory.

use std::io::{Read, Write};

/// The three standard streams of one run.
pub struct Streams<'a> {
    /// Standard input (used when `FILE` is `-`).
    pub stdin: &'a mut dyn Read,
    /// Standard output: results only.
    pub stdout: &'a mut dyn Write,
    /// Standard error: errors, notes and progress.
    pub stderr: &'a mut dyn Write,
    /// Show progress bars on the real standard error (only when it is a terminal).
    pub progress: bool,
}
