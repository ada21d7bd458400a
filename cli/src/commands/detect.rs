//! `stiction detect`: is it the valve? The detection crate's tests and one verdict.

use std::path::PathBuf;

use anyhow::anyhow;

use super::batch::IntegratingFlag;
use super::load::{load, DataFlags};
use crate::{usage, CmdResult, Streams};

/// Arguments of `stiction detect`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// CSV or MAT file with PV and OP columns (optional SP, time); `-` for standard input.
    file: PathBuf,
    /// Whether the loop is integrating (a level): `auto` takes level loops by the tag's first
    /// letter `L` (ISA-5.1) in the file name, as `trend` and `batch` do.
    #[arg(long, value_enum, default_value = "auto")]
    integrating: IntegratingFlag,
    #[command(flatten)]
    data: DataFlags,
    /// Not available for `detect` yet (refused).
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Print one JSON document.
    #[arg(long)]
    json: bool,
}

/// `stiction detect`.
pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    if args.report.is_some() {
        return Err(usage(anyhow!(
            "detect: --report is not available yet; use --json, or `stiction quantify --report DIR` for the pictures"
        )));
    }
    let d = load(&args.file, &args.data, true, 30, s)?;
    d.require_pv()?;
    let det = match monitoring::detect_file(&d, Some(&args.file), args.integrating.into()) {
        monitoring::Detected::Ran(det) => det,
        monitoring::Detected::Failed(e) => return Err(anyhow!("{}: {e}", d.source).into()),
    };
    if args.json {
        return s.json(&monitoring::detect_document(&d, &det));
    }
    s.text(report::text::detect(&d, &det)?)
}
