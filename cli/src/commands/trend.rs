//! `stiction trend`: one valve recorded again and again (paper §5.2): quantify every
//! registration, order them in time, follow S (and J), flag and explain outliers, and give a
//! maintenance verdict.

use std::path::PathBuf;

use anyhow::anyhow;

use monitoring::batch::DEFAULT_MIN_FIT;
use monitoring::trend::{self, TrendOptions, DEFAULT_HORIZON, DEFAULT_THRESHOLD};

use super::batch::{Combos, RunFlags};
use crate::reporting::{self, Output};
use crate::{usage, CmdResult, Streams};

/// Arguments of `stiction trend`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Registration files, or directories of them (.csv, .tsv, .txt, .mat).
    #[arg(required = true, value_name = "FILES|DIR")]
    paths: Vec<PathBuf>,
    /// The valve to follow (file-name prefix before `_`); required when the files hold several.
    #[arg(long, value_name = "TAG")]
    valve: Option<String>,
    #[command(flatten)]
    combos: Combos,
    /// Maintenance threshold on S, % of valve span.
    #[arg(long, value_name = "S%", default_value_t = DEFAULT_THRESHOLD, value_parser = super::numbers::non_negative)]
    threshold: f64,
    /// Minimum validation F_PV (%) for a registration to count in the trend.
    #[arg(long, value_name = "PCT", default_value_t = DEFAULT_MIN_FIT, value_parser = super::numbers::fit_percent, allow_negative_numbers = true)]
    min_fit: f64,
    /// How far ahead (days) the trend is projected for the `watch` verdict.
    #[arg(long, value_name = "DAYS", default_value_t = DEFAULT_HORIZON, value_parser = super::numbers::positive)]
    horizon: f64,
    #[command(flatten)]
    run: RunFlags,
    /// Do not diagnose the registrations (faster; `why` then lists only the evidence from the
    /// quantification itself, and no causes the registrations agree on are reported).
    #[arg(long)]
    no_diagnose: bool,
    #[command(flatten)]
    out: Output,
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    let run = args.run.options(&args.combos, args.min_fit)?;
    if !(args.threshold.is_finite() && args.threshold >= 0.0) {
        return Err(usage(anyhow!(
            "--threshold {}: expected a non-negative S in % of valve span",
            args.threshold
        )));
    }
    let files = args.run.files(&args.paths, &[], s)?;
    let (valve, files) = trend::select(files, args.valve.as_deref()).map_err(|e| match e {
        monitoring::MonitoringError::SeveralValves(_) => usage(e),
        other => other.into(),
    })?;
    let (threshold, horizon) = (args.threshold, args.horizon);
    let options = TrendOptions {
        run,
        threshold,
        horizon,
    };
    let bar = crate::progress::Progress::new(s.progress, &format!("trend {valve}"));
    let vt = trend::follow(
        &valve,
        &files,
        &options,
        !args.no_diagnose,
        Some(&bar.tick()),
    );
    bar.finish();
    let vt = vt.map_err(usage)?;
    reporting::write(&args.out.report, s, || report::pages::trend_page(&vt))?;
    if args.out.json {
        return s.json(&vt.record());
    }
    s.text(report::text::trend(&vt)?)
}
