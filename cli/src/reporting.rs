//! `--report DIR`: writing the page of a run (`report::pages`), shared by quantify, compare,
//! diagnose and trend.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::anyhow;
use report::{Report, ReportError, WriteOptions};

use crate::{CmdResult, Failure, Streams};

/// The report flags.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Report options")]
pub struct ReportFlags {
    /// Write a report to DIR: index.html (self-contained: numbers, plots inline, summary) and
    /// each plot as DIR/<name>.svg.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Also write each plot of the report as PNG (in a CLI built with the `png` feature:
    /// `cargo install --path cli --features png`).
    #[arg(long, requires = "report")]
    pub png: bool,
}

/// What a command prints: one JSON document or the text, and the report page.
#[derive(Debug, Clone, clap::Args)]
pub struct Output {
    /// Print one JSON document.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub report: ReportFlags,
}

/// Build the page with `page` and write it to the flags' directory (nothing without
/// `--report`), saying so on stderr.
pub(crate) fn write(
    flags: &ReportFlags,
    s: &mut Streams<'_>,
    page: impl FnOnce() -> Result<Report, ReportError>,
) -> CmdResult {
    let Some(dir) = &flags.report else {
        return Ok(());
    };
    let started = Instant::now();
    let w = page()
        .and_then(|rep| rep.write(dir, WriteOptions { png: flags.png }))
        .map_err(|e| anyhow!("report: {e}"))?;
    let _ = writeln!(
        s.stderr,
        "report: {} ({} figure files, {:.0} kB, {:.0} ms)",
        w.index.display(),
        w.files.len(),
        w.bytes as f64 / 1e3,
        started.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}

/// When a loop could not be read: write a page that says why (with the raw columns when the
/// file is delimited text), then hand the failure back.
pub(crate) fn refused(
    file: Option<&Path>,
    failure: Failure,
    flags: &ReportFlags,
    command: &str,
    s: &mut Streams<'_>,
) -> Failure {
    let (Some(_), Some(path)) = (&flags.report, file) else {
        return failure;
    };
    // A file that is not there (or not a file) has nothing to show: no page, only the error.
    if path.as_os_str() != "-" && !path.is_file() {
        return failure;
    }
    let msg = failure.line();
    if let Err(e) = write(flags, s, || {
        Ok(report::pages::refused_page(path, &msg, command))
    }) {
        let _ = writeln!(s.stderr, "warning: {:#}", e.error);
    }
    failure
}
