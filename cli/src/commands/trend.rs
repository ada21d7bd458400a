//! `stiction trend`: one valve recorded again and again (paper §5.2): quantify every
//! registration, order them in time, follow S (and J), flag and explain outliers, and give a
//! maintenance verdict.

use std::path::PathBuf;

use anyhow::anyhow;

use monitoring::batch::DEFAULT_MIN_FIT;
use monitoring::trend::{self, TrendOptions, DEFAULT_HORIZON, DEFAULT_THRESHOLD};

use super::batch::{Combos, RunFlags};
use crate::reporting::{self, ReportFlags};
use crate::{usage, CmdResult, Streams};

pub(crate) const AFTER_HELP: &str = "\
Every registration (file) of one valve is quantified with every stiction x linear
combination; registrations are ordered by the time in the file name (<valve>_YYYYMMDD-HHMM)
or else their first time stamp. For each combination:
  weak      validation F_PV below --min-fit: not used for the trend, with the evidence why
  outlier   S outside median +- max(3 x 1.4826 x MAD, 0.1) of the other usable
            registrations (4 or more needed): not used for the trend, with the evidence why
  level     median S of the usable registrations; slope: Theil-Sen, % per 30 days
Verdict (on the mean over combinations of level, latest usable S and projected S):
  schedule maintenance   level >= threshold
  watch                  level < threshold, but the latest usable S or the level projected
                         --horizon days ahead >= threshold, or level >= threshold / 2
  healthy                otherwise; undetermined when no registration is usable

Examples:
  stiction trend ../shared/data/plant --valve 2411FIC20102
  stiction trend data/V1_*.csv --threshold 1.5 --json
  stiction trend DIR --valve LIC1 --stiction kano,he --linear arx,armax";

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
    #[arg(long, value_name = "S%", default_value_t = DEFAULT_THRESHOLD)]
    threshold: f64,
    /// Minimum validation F_PV (%) for a registration to count in the trend.
    #[arg(long, value_name = "PCT", default_value_t = DEFAULT_MIN_FIT)]
    min_fit: f64,
    /// How far ahead (days) the trend is projected for the `watch` verdict.
    #[arg(long, value_name = "DAYS", default_value_t = DEFAULT_HORIZON)]
    horizon: f64,
    #[command(flatten)]
    run: RunFlags,
    /// Do not diagnose the weak and outlying registrations (faster; `why` then lists only the
    /// evidence from the quantification itself).
    #[arg(long)]
    no_diagnose: bool,
    #[command(flatten)]
    report: ReportFlags,
    /// Print one JSON document.
    #[arg(long)]
    json: bool,
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
    let diagnoser = discrepancy::registration::RegistrationDiagnosis;
    let diagnoser = (!args.no_diagnose).then_some(&diagnoser as _);
    let vt = trend::follow(&valve, &files, &options, diagnoser, Some(&bar.tick()));
    bar.finish();
    let vt = vt.map_err(usage)?;
    reporting::write(&args.report, s, || report::pages::trend_page(&vt))?;
    if args.json {
        return s.json(&vt.record());
    }
    s.text(report::text::trend(&vt)?)
}
