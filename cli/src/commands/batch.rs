//! `stiction batch`: many loops in parallel, one result row per loop and combination, failures in
//! their rows, resumable (`monitoring::batch`).

use std::path::{Path, PathBuf};

use monitoring::batch::{self, BatchOptions, Labels, DEFAULT_MIN_FIT};
use monitoring::registration::{expand, file_name, Integrating};
use stiction_models::find_model;

use super::load::DataFlags;
use super::search_flags::SearchFlags;
use crate::{data, usage, CmdResult, Streams};

pub(crate) const AFTER_HELP: &str = "\
Loops run in parallel (each grid search shares the same thread pool). Each file gets one row
per stiction x linear combination: file, valve, time, status ok/error, S, J with their
likelihood-ratio ranges, F_PV, the no-stiction fit, the reader's notes, for a failure its
one-line error, and the stiction detector's score and verdict on the file's record
(detect_score, detect_verdict: as `stiction detect` gives them). Without -o the rows are
printed as a table.

With -o OUT, rows go to OUT.jsonl (one JSON object per line, appended as each loop finishes)
and OUT.csv (rewritten at the end from OUT.jsonl). The run is resumable: a file whose name,
size and modification time, and the run's settings, match a row already in OUT.jsonl is
skipped; change the file or the settings and it is done again.

--labels FILE (CSV with columns file,label; label stiction / no-stiction) adds the label to
each row and reports how well S separates the labels: ROC AUC and the threshold maximising
TPR - FPR (Youden), over the rows with status ok of the first combination; and the same for
the detector's score over the same rows.

Examples:
  stiction batch ../shared/data/plant -o plant --labels ../shared/data/plant/labels.csv
  stiction batch DIR --stiction kano,he --linear arx,ss -o results";

/// Arguments of `stiction batch`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Directories or files of registrations (.csv, .tsv, .txt, .mat).
    #[arg(required = true, value_name = "DIR")]
    paths: Vec<PathBuf>,
    /// Output prefix: writes OUT.jsonl and OUT.csv (resumable). Without it, a table on stdout.
    #[arg(short = 'o', long, value_name = "OUT")]
    out: Option<PathBuf>,
    /// Only the registrations of this valve (file-name prefix before `_`).
    #[arg(long, value_name = "TAG")]
    valve: Option<String>,
    /// Stiction models, comma-separated.
    #[arg(
        long,
        value_name = "A,B",
        value_delimiter = ',',
        default_value = "kano"
    )]
    stiction: Vec<String>,
    /// Linear identifiers, comma-separated.
    #[arg(long, value_name = "X,Y", value_delimiter = ',', default_value = "arx")]
    linear: Vec<String>,
    /// Labels (CSV `file,label`, label `stiction` / `no-stiction`): report ROC AUC of S and of
    /// the detector's score.
    #[arg(long, value_name = "FILE")]
    labels: Option<PathBuf>,
    /// Minimum validation F_PV (%) below which the evidence says "poor fit".
    #[arg(long, value_name = "PCT", default_value_t = DEFAULT_MIN_FIT)]
    min_fit: f64,
    /// Integrating loops are identified from MV to ΔPV; `auto` = level loops (tag letter L).
    #[arg(long, value_enum, default_value = "auto")]
    integrating: IntegratingFlag,
    #[command(flatten)]
    search: SearchFlags,
    #[command(flatten)]
    data: DataFlags,
}

/// `--integrating`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum IntegratingFlag {
    /// Level loops (tag letter `L`) are integrating, others not.
    Auto,
    /// Every loop is integrating: identify MV → ΔPV.
    Yes,
    /// No loop is integrating: identify MV → PV.
    No,
}

impl From<IntegratingFlag> for Integrating {
    fn from(f: IntegratingFlag) -> Integrating {
        match f {
            IntegratingFlag::Auto => Integrating::Auto,
            IntegratingFlag::Yes => Integrating::Yes,
            IntegratingFlag::No => Integrating::No,
        }
    }
}

fn with_ext(out: &Path, ext: &str) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(ext);
    PathBuf::from(s)
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    for name in &args.stiction {
        find_model(name).map_err(usage)?;
    }
    let opts = BatchOptions {
        stiction: args.stiction.clone(),
        linear: args.linear.clone(),
        settings: args.search.settings(&args.linear)?,
        read: args.data.read_options(true, batch::MIN_ROWS),
        integrating: args.integrating.into(),
        min_fit: args.min_fit,
    };
    let labels = match &args.labels {
        Some(p) => Some(Labels::read(p).map_err(data)?),
        None => None,
    };
    let jsonl = args.out.as_deref().map(|o| with_ext(o, ".jsonl"));
    let csv_path = args.out.as_deref().map(|o| with_ext(o, ".csv"));
    let mut exclude: Vec<PathBuf> = args.labels.iter().cloned().collect();
    exclude.extend(jsonl.iter().cloned());
    exclude.extend(csv_path.iter().cloned());
    let (mut files, not_loops) =
        expand(&args.paths, &exclude, args.data.op_column()).map_err(usage)?;
    for n in &not_loops {
        let _ = writeln!(s.stderr, "note: skipped {}: {n}", n.path.display());
    }
    if let Some(v) = &args.valve {
        files.retain(|f| datasets::parse_registration_name(&file_name(f)).valve == *v);
    }
    let bar = crate::progress::Progress::new(s.progress, "batch");
    let tick = |done: usize, total: usize| bar.update(done, total);
    let run = batch::run(
        &files,
        &opts,
        labels.as_ref(),
        jsonl.as_deref(),
        Some(&tick),
    );
    bar.finish();
    let run = run.map_err(data)?;
    if let (Some(path), [first, ..]) = (&jsonl, run.torn.as_slice()) {
        let what = match run.torn.len() {
            1 => format!("line {first} is torn (an interrupted run): its registration is"),
            n => format!("{n} unreadable lines (first: line {first}): their registrations are"),
        };
        let _ = writeln!(s.stderr, "note: {}: {what} computed again", path.display());
    }
    if let Some(path) = &csv_path {
        batch::write_csv(path, &run.rows).map_err(data)?;
    }

    let out = &mut *s.stdout;
    let rows = &run.rows;
    let ok = rows.iter().filter(|r| r.is_ok()).count();
    if args.out.is_none() {
        write!(out, "{}", report::text::batch_table(rows)).map_err(data)?;
    }
    writeln!(
        out,
        "{} file(s): {} row(s) ok, {} error row(s); {} file(s) computed, {} skipped (already in {})",
        files.len(),
        ok,
        rows.len() - ok,
        run.computed,
        run.skipped,
        jsonl
            .as_ref()
            .map_or("-".into(), |p| p.display().to_string())
    )
    .map_err(data)?;
    if labels.is_some() {
        let (st, li) = (&args.stiction[0], &args.linear[0]);
        let sum = batch::label_summary(rows, st, li);
        let (n, npos) = (sum.rows, sum.stiction);
        match sum.roc {
            Some(monitoring::Roc {
                auc,
                threshold: thr,
                tpr,
                fpr,
            }) => writeln!(
                out,
                "labels ({st} + {li}, {n} labelled rows: {npos} stiction, {} no-stiction): ROC AUC of S = {auc:.3}; best threshold S >= {thr:.2} % (Youden: TPR {tpr:.2}, FPR {fpr:.2})",
                n - npos
            ),
            None => writeln!(
                out,
                "labels: ROC needs ok rows of both labels ({n} labelled ok rows, {npos} stiction)"
            ),
        }
        .map_err(data)?;
        let det = batch::detect_label_summary(rows, st, li);
        let (n, npos) = (det.rows, det.stiction);
        match det.roc {
            Some(monitoring::Roc {
                auc,
                threshold: thr,
                tpr,
                fpr,
            }) => writeln!(
                out,
                "labels (detector, same rows, {n} with a score: {npos} stiction, {} no-stiction): ROC AUC of detect_score = {auc:.3}; best threshold score >= {thr:.2} (Youden: TPR {tpr:.2}, FPR {fpr:.2})",
                n - npos
            ),
            None => writeln!(
                out,
                "labels (detector): ROC needs scored ok rows of both labels ({n} labelled scored rows, {npos} stiction)"
            ),
        }
        .map_err(data)?;
    }
    Ok(())
}
