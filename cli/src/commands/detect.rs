//! `stiction detect`: is it the valve? The detection crate's tests and one verdict.

use std::path::PathBuf;

use anyhow::anyhow;

use super::search_flags::KindFlags;
use datasets::ReadOptions;

use super::load::{load_with, DataFlags};
use crate::reporting::{self, Output};
use crate::{CmdResult, Failure, Streams};

/// Arguments of `stiction detect`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// CSV or MAT file with PV and OP columns (optional SP, time); `-` for standard input.
    file: PathBuf,
    #[command(flatten)]
    kind: KindFlags,
    #[command(flatten)]
    data: DataFlags,
    #[command(flatten)]
    out: Output,
}

/// `stiction detect`.
pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    let refused = |f: Failure, s: &mut Streams<'_>| {
        reporting::refused(Some(&args.file), f, &args.out.report, "detect", s)
    };
    // A constant PV or OP is read (with a note): the detector answers it, `inconclusive` with
    // the reason, where identification refuses it.
    let opts = ReadOptions {
        accept_constant: true,
        ..args.data.read_options(true, 30)
    };
    let d = load_with(&args.file, &opts, s).map_err(|f| refused(f, s))?;
    d.require_pv().map_err(|e| refused(e.into(), s))?;
    let a = monitoring::analyse(&d, Some(&args.file), args.kind.integrating());
    let view = a.detect(&d);
    let answer = monitoring::Answer::new(&a, &view.detected, None);
    let det = match view.detected {
        monitoring::Detected::Ran(det) => det,
        monitoring::Detected::Failed(e) => {
            return Err(refused(anyhow!("{}: {e}", d.source).into(), s))
        }
    };
    let figures = &view.figures;
    reporting::write(&args.out.report, s, || {
        report::pages::detect_page(&d, &det, figures, &answer)
    })?;
    if args.out.json {
        return s.json(&monitoring::document::detect(&d, &det, &answer));
    }
    s.text(report::text::detect(&d, &det, &answer)?)
}
