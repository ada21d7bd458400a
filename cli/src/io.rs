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

impl Streams<'_> {
    /// Print one JSON document (through a `Value`: keys sorted), pretty, and a newline.
    pub(crate) fn json(&mut self, doc: &impl serde::Serialize) -> crate::CmdResult {
        let doc = serde_json::to_value(doc)?;
        serde_json::to_writer_pretty(&mut *self.stdout, &doc)?;
        Ok(writeln!(self.stdout)?)
    }

    /// Print `text` as it is.
    pub(crate) fn text(&mut self, text: impl std::fmt::Display) -> crate::CmdResult {
        Ok(write!(self.stdout, "{text}")?)
    }
}
