//! `--report DIR`: writing the page of a run (`report::pages`), shared by quantify, compare,
//! diagnose and trend.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::anyhow;
use report::{Report, ReportError, WriteOptions};

use crate::{data, Failure, Streams};

/// The report flags.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Report options")]
pub struct ReportFlags {
    /// Write a report to DIR: index.html (self-contained: numbers, plots inline, summary) and
    /// each plot as DIR/<name>.svg.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Also write each plot of the report as PNG.
    #[arg(long, requires = "report")]
    pub png: bool,
}

/// A report error as bad data.
pub(crate) fn failed(e: ReportError) -> Failure {
    data(anyhow!("report: {e}"))
}

/// Build the page with `page` and write it to the flags' directory (nothing without
/// `--report`), saying so on stderr.
pub(crate) fn write(
    flags: &ReportFlags,
    s: &mut Streams<'_>,
    page: impl FnOnce() -> Result<Report, ReportError>,
) -> Result<(), Failure> {
    let Some(dir) = &flags.report else {
        return Ok(());
    };
    let started = Instant::now();
    let w = page()
        .and_then(|rep| rep.write(dir, WriteOptions { png: flags.png }))
        .map_err(failed)?;
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
    let msg = crate::one_line(failure.error());
    let page = || Ok(report::pages::refused_page(path, &msg, command));
    if let Err(e) = write(flags, s, page) {
        let _ = writeln!(s.stderr, "warning: {:#}", e.error());
    }
    failure
}
