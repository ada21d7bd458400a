//! `stiction audit`: the batch's rows appended to a results history in SQLite, each
//! registration once (`audit`), and the fleet page drawn from that history
//! (`report::fleet`): every valve once, ranked by what a repair would buy, each linked to the
//! page of its latest registration.

use std::path::{Path, PathBuf};
use std::time::Instant;

use ::audit::{RegistrationSummary, Store, ValveHistory};
use anyhow::anyhow;
use monitoring::batch::BatchOptions;
use rayon::prelude::*;
use report::fleet::{FleetRegistration, FleetValve};

use super::batch::{Fleet, FleetRun};
use crate::{CmdResult, Streams};

/// Arguments of `stiction audit`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Directories or files of registrations (.csv, .tsv, .txt, .mat); none with --report
    /// draws the page from the database alone.
    #[arg(required_unless_present = "report", value_name = "PATH")]
    paths: Vec<PathBuf>,
    /// The SQLite database (created when missing; registrations already in it are skipped).
    #[arg(long, value_name = "FILE")]
    db: PathBuf,
    #[command(flatten)]
    fleet: Fleet,
    /// Write the fleet page to DIR/index.html (every valve once, ranked by what a repair would
    /// buy) and the page of each valve's latest registration to DIR/valves/TAG/index.html.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// With --report: diagnose each valve's latest registration (`stiction diagnose`): its
    /// page is the diagnosis, and the fleet page's causes are the diagnosis' causes (about a
    /// second per valve on 3000 samples) instead of the quantify run's evidence.
    #[arg(long, requires = "report")]
    diagnose: bool,
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    let FleetRun {
        opts,
        labels,
        files,
    } = (args.fleet).take(&args.paths, std::slice::from_ref(&args.db), s)?;
    if !files.is_empty() || args.report.is_none() {
        let bar = crate::progress::Progress::new(s.progress, "audit");
        let run = ::audit::run(&files, &opts, labels.as_ref(), &args.db, Some(&bar.tick()));
        bar.finish();
        let run = run?;
        s.text(format!("{}\n", run.summary(&args.db)))?;
    } else if !args.db.exists() {
        return Err(anyhow!(
            "{}: no such database (give registrations to audit)",
            args.db.display()
        )
        .into());
    }
    if let Some(dir) = &args.report {
        let diagnose = args.diagnose.then(|| args.fleet.run.search_args());
        write_fleet(dir, &args.db, &opts, diagnose.as_ref(), s)?;
    }
    Ok(())
}

/// Valves of the ranking printed on standard output with `--report` (the page has them all).
const RANKING_LINES: usize = 10;

/// The fleet page of the database `db` in `dir`, with each valve's latest registration's
/// `quantify` page (searched again with `opts`, the combination the database chose for it), or
/// its diagnosis with `diagnose` (the search flags), under `dir/valves/TAG/`.
fn write_fleet(
    dir: &Path,
    db: &Path,
    opts: &BatchOptions,
    diagnose: Option<&run::SearchArgs>,
    s: &mut Streams<'_>,
) -> CmdResult {
    let started = Instant::now();
    let history = Store::open(db)?.valves()?;
    let bar = crate::progress::Progress::new(s.progress, "fleet page");
    let tick = bar.tick();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let pages: Vec<Result<Option<LatestPage>, String>> = history
        .par_iter()
        .map(|h| {
            let out = match h.registrations.last() {
                Some(latest) => latest_page(dir, &h.valve, latest, opts, diagnose).map(Some),
                None => Ok(None),
            };
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            tick(k, history.len());
            out
        })
        .collect();
    bar.finish();
    let mut valves = Vec::with_capacity(history.len());
    for (h, page) in history.iter().zip(pages) {
        let page = match page {
            Ok(page) => page,
            Err(e) => {
                let _ = writeln!(
                    s.stderr,
                    "note: {}: no page of its latest registration: {e}",
                    h.valve
                );
                None
            }
        };
        let mut valve = fleet_valve(h, page.as_ref().map(|p| p.link.clone()));
        if let Some(causes) = page.and_then(|p| p.causes) {
            valve.causes = causes;
        }
        valves.push(valve);
    }
    let name = db.file_name().map_or_else(
        || db.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let index = report::fleet::write(dir, &format!("Fleet: {name}"), &valves)
        .map_err(|e| anyhow!("report: {e}"))?;
    let _ = writeln!(
        s.stderr,
        "report: {} ({} valves, {} registration pages, {:.0} ms)",
        index.display(),
        valves.len(),
        valves.iter().filter(|v| v.link.is_some()).count(),
        started.elapsed().as_secs_f64() * 1e3
    );
    s.text(report::fleet::ranking_text(&valves, RANKING_LINES))
}

/// A valve of the fleet page from its history: the latest registration's answers, S over the
/// dates of them all.
fn fleet_valve(h: &ValveHistory, link: Option<String>) -> FleetValve {
    let registrations = h
        .registrations
        .iter()
        .map(|r| FleetRegistration {
            date: (!r.start_time.is_empty()).then(|| r.start_time.clone()),
            s: r.s,
            s_lo: r.s_range.map(|x| x[0]),
            s_hi: r.s_range.map(|x| x[1]),
            file: r.file.clone(),
        })
        .collect();
    let Some(latest) = h.registrations.last() else {
        return FleetValve {
            valve: h.valve.clone(),
            ..FleetValve::default()
        };
    };
    FleetValve {
        valve: h.valve.clone(),
        registrations,
        verdict: latest.detect_verdict.clone(),
        verdict_reason: latest.detect_reason.clone(),
        score: latest.detect_score,
        s: latest.s,
        span_unknown: latest.s_unit.as_deref() == Some(monitoring::answer::RANGE_UNIT),
        s_lo: latest.s_range.map(|x| x[0]),
        s_hi: latest.s_range.map(|x| x[1]),
        causes: latest.causes.clone(),
        reduction: latest.reduction,
        repair_reason: latest.repair_reason.clone(),
        error: latest.error.clone(),
        link,
    }
}

/// The page of a valve's latest registration: its link relative to the fleet page, and the
/// diagnosis' causes when it is a diagnosis.
struct LatestPage {
    link: String,
    causes: Option<Vec<String>>,
}

/// The `quantify` page (with `diagnose`, the `diagnose` page) of a valve's latest
/// registration in `dir/valves/TAG/`.
fn latest_page(
    dir: &Path,
    valve: &str,
    latest: &RegistrationSummary,
    opts: &BatchOptions,
    diagnose: Option<&run::SearchArgs>,
) -> Result<LatestPage, String> {
    if !latest.ok {
        return Err(latest.error.clone().unwrap_or_else(|| "no estimate".into()));
    }
    let path = Path::new(&latest.path);
    let d = datasets::read_path(path, &opts.read).map_err(|e| e.to_string())?;
    let kind = opts.integrating.decide(valve, Some(&d));
    let integrating = kind.integrating;
    let a = monitoring::Analysis::of(&d, kind);
    let used = &a.searched;
    let problem = run::problem(used).map_err(|e| e.to_string())?;
    // the tests judge the record as read; the page draws `used` (the increments of an
    // integrating loop), and the detection figures with it
    let det = monitoring::DetectionView {
        detected: monitoring::detect_decided(&d, kind),
        figures: monitoring::detect::detection_figures(used, integrating),
    };
    let (st, li) = (&latest.stiction_model, &latest.linear_model);
    let (page, causes) = match diagnose {
        Some(search) => {
            let baseline = discrepancy::baseline(search, st, li).map_err(|e| e.to_string())?;
            let span = run::span_of(&used.op);
            let options = discrepancy::options_for(search, span, &[]).map_err(|e| e.to_string())?;
            let dg =
                discrepancy::diagnose(problem, &baseline, &options).map_err(|e| e.to_string())?;
            let fit = dg.final_fit().unwrap_or(&dg.baseline_fit);
            let answer = monitoring::Answer::new(&a, &det.detected, Some(&fit.result));
            let repair = answer.repair(fit.repair(&d, integrating));
            let causes = if dg.causes.is_empty() {
                vec!["none (the baseline explains PV)".to_string()]
            } else {
                dg.causes.clone()
            };
            (
                report::pages::diagnose_page(used, &dg, &det, &repair, &answer),
                Some(causes),
            )
        }
        None => {
            let combination = opts
                .settings
                .combination(st, li)
                .map_err(|e| e.to_string())?;
            let fitted = combination.run(problem, None).map_err(|e| e.to_string())?;
            let answer = monitoring::Answer::new(&a, &det.detected, Some(&fitted.result));
            let repair = answer.repair(fitted.repair(&d, integrating));
            (
                report::pages::quantify_page(used, &fitted, &det, &repair, &answer),
                None,
            )
        }
    };
    let safe: String = valve
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    page.and_then(|page| {
        page.write(
            &dir.join("valves").join(&safe),
            report::WriteOptions { png: false },
        )
    })
    .map_err(|e| e.to_string())?;
    Ok(LatestPage {
        link: format!("valves/{safe}/index.html"),
        causes,
    })
}
