//! What `trend` and `batch` share: finding registration files, reading them, quantifying each
//! with every chosen model combination, and the evidence that explains a doubtful estimate.
//!
//! Conventions (documented in `docs/PLANT_DATA.md`):
//! * a registration is one file (`.csv`, `.tsv`, `.txt` or `.mat`); a directory argument stands
//!   for its files with those extensions (not recursive), in name order;
//! * the valve is the file name up to the first `_`; the registration time is the file name's
//!   `_YYYYMMDD-HHMM` suffix, else the first time stamp of the data, else unknown;
//! * integrating loops (level: the tag's first letter, ISA-5.1, is `L`) are identified from MV to
//!   the PV increment ΔPV(k) = PV(k) − PV(k−1) with `--integrating auto` (the default): an
//!   integrator has no stable ARX model from MV to PV, so the grid search would skip the
//!   no-stiction node as unstable and keep only nodes whose MV happens to give a stable fit.

use std::path::{Path, PathBuf};

use datasets::{parse_registration_name, LoopData, NoteKind};
use grid_search::Quantification;
use serde_json::Value;

use super::load::DataFlags;
use super::quantify::{quantify_json, run_one, Run};
use super::search_flags::SearchFlags;
use crate::Streams;

/// File extensions read from a directory.
pub(crate) const EXTENSIONS: [&str; 4] = ["csv", "tsv", "txt", "mat"];

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

impl IntegratingFlag {
    /// Whether the loop of `valve` is treated as integrating.
    pub(crate) fn applies(self, valve: &str) -> bool {
        match self {
            IntegratingFlag::Yes => true,
            IntegratingFlag::No => false,
            IntegratingFlag::Auto => valve
                .chars()
                .find(|c| c.is_ascii_alphabetic())
                .is_some_and(|c| c.eq_ignore_ascii_case(&'l')),
        }
    }
}

/// Whether a delimited text file in a folder looks like a loop registration: its header names
/// the OP column `op` (case-insensitive). A folder's `labels.csv` or a results table does not,
/// and is skipped with a note instead of becoming a valve or an error row. `.mat` files are
/// always taken (their reader lists the loops inside).
fn looks_like_loop(f: &Path, op: &str) -> Result<(), String> {
    let is_text = f
        .extension()
        .is_some_and(|e| !e.eq_ignore_ascii_case("mat"));
    if !is_text {
        return Ok(());
    }
    let Ok(file) = std::fs::File::open(f) else {
        return Ok(()); // the reader says why, in the file's row
    };
    let mut first = String::new();
    let _ = std::io::BufRead::read_line(
        &mut std::io::BufReader::new(std::io::Read::take(file, 64 * 1024)),
        &mut first,
    );
    let found = first
        .trim_start_matches('\u{feff}')
        .split([',', ';', '\t'])
        .any(|c| c.trim().trim_matches('"').eq_ignore_ascii_case(op));
    if found {
        Ok(())
    } else {
        Err(format!(
            "no {op} column in its header, not a loop registration"
        ))
    }
}

/// The registration files of [`expand`], and the files of a directory left out with why.
pub(crate) type Expanded = (Vec<PathBuf>, Vec<(PathBuf, String)>);

/// Expand files and directories into registration files (directories: their files with a
/// known extension whose header names the OP column `op`, sorted by name, minus `exclude`);
/// the files of a directory left out as not being loops are returned with the reason.
pub(crate) fn expand(paths: &[PathBuf], exclude: &[PathBuf], op: &str) -> anyhow::Result<Expanded> {
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    };
    let mut out = Vec::new();
    let mut skipped = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?
                .flatten()
                .map(|e| e.path())
                .filter(|f| {
                    f.is_file()
                        && f.extension()
                            .is_some_and(|e| EXTENSIONS.iter().any(|x| e.eq_ignore_ascii_case(x)))
                })
                .filter(|f| !exclude.iter().any(|x| same(f, x)))
                .collect();
            files.sort();
            for f in files {
                match looks_like_loop(&f, op) {
                    Ok(()) => out.push(f),
                    Err(why) => skipped.push((f, why)),
                }
            }
        } else if p.exists() {
            out.push(p.clone());
        } else {
            anyhow::bail!("{}: no such file or directory", p.display());
        }
    }
    Ok((out, skipped))
}

/// The base name of a path, for rows and messages.
pub(crate) fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

/// One stiction × linear combination on one registration.
pub(crate) struct ComboOutcome {
    pub stiction: String,
    pub linear: String,
    /// The contract's quantify object, or the error message.
    pub result: Result<ComboFit, String>,
}

/// A successful quantification with the numbers trend and batch use.
pub(crate) struct ComboFit {
    pub json: Value,
    pub s: f64,
    pub s_range: [f64; 2],
    /// The grid's finest step (JSON numbers are rounded to its resolution, `crate::on_grid`).
    pub step: f64,
    pub j: f64,
    pub j_range: [f64; 2],
    pub fit_val: f64,
    /// Evidence that something besides the valve moves PV (see [`FitEvidence`]).
    pub evidence: Vec<String>,
}

/// One registration: where it is, which valve, when, and its results.
pub(crate) struct Registration {
    pub path: PathBuf,
    pub file: String,
    pub valve: String,
    /// Start, seconds since the Unix epoch (UTC).
    pub start: Option<f64>,
    /// Where the time came from: `file name`, `first time stamp` or `unknown`.
    pub time_source: &'static str,
    pub integrating: bool,
    /// Notes of the reader (what was done to the data).
    pub notes: Vec<datasets::Note>,
    /// Results per combination, or the reason the file could not be used at all.
    pub outcome: Result<Vec<ComboOutcome>, String>,
}

/// Everything needed to evaluate a registration.
pub(crate) struct Plan<'a> {
    pub stiction: &'a [String],
    pub linear: &'a [String],
    pub search: &'a SearchFlags,
    pub data: &'a DataFlags,
    pub integrating: IntegratingFlag,
    pub explainer: &'a (dyn ExplainFit + Sync),
}

/// Read and quantify one registration with every combination. Never fails: a problem is
/// recorded in the registration — a panic too (the registration runs isolated, so one bad
/// file cannot end a batch or a trend).
pub(crate) fn evaluate(path: &Path, plan: &Plan<'_>) -> Registration {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        evaluate_unguarded(path, plan)
    })) {
        Ok(reg) => reg,
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            let file = file_name(path);
            let name = parse_registration_name(&file);
            Registration {
                path: path.to_path_buf(),
                integrating: plan.integrating.applies(&name.valve),
                file,
                valve: name.valve,
                start: name.start,
                time_source: if name.start.is_some() {
                    "file name"
                } else {
                    "unknown"
                },
                notes: Vec::new(),
                outcome: Err(format!(
                    "internal error on this registration (a bug, please report it): {}",
                    what.replace('\n', " ")
                )),
            }
        }
    }
}

fn evaluate_unguarded(path: &Path, plan: &Plan<'_>) -> Registration {
    let file = file_name(path);
    let name = parse_registration_name(&file);
    let integrating = plan.integrating.applies(&name.valve);
    let mut reg = Registration {
        path: path.to_path_buf(),
        file,
        valve: name.valve,
        start: name.start,
        time_source: if name.start.is_some() {
            "file name"
        } else {
            "unknown"
        },
        integrating,
        notes: Vec::new(),
        outcome: Err(String::new()),
    };
    // Tests prove the isolation with a registration that panics (debug builds only).
    if cfg!(debug_assertions)
        && std::env::var_os("STICTION_TEST_PANIC_ON").is_some_and(|v| *v == *reg.file)
    {
        panic!("test panic on {}", reg.file);
    }
    let opts = plan.data.read_options(true, 30);
    let d = match datasets::read_path(path, &opts) {
        Ok(d) => d,
        Err(e) => {
            reg.outcome = Err(e.to_string());
            return reg;
        }
    };
    if reg.start.is_none() {
        if let Some(s) = d.start {
            reg.start = Some(s);
            reg.time_source = "first time stamp";
        }
    }
    reg.notes = d.notes.clone();
    let used = if integrating { increments(&d) } else { d };
    let mut combos = Vec::new();
    for st in plan.stiction {
        for li in plan.linear {
            let mut input = std::io::empty();
            let mut out = std::io::sink();
            let mut err = std::io::sink();
            let mut quiet = Streams {
                stdin: &mut input,
                stdout: &mut out,
                stderr: &mut err,
                progress: false,
            };
            let result = run_one(
                st,
                li,
                plan.search,
                &used,
                &mut quiet,
                (std::time::Instant::now(), ""),
            )
            .map(|r| fit_of(&r, &used, &reg.notes, plan))
            .map_err(|f| crate::one_line(f.error()));
            combos.push(ComboOutcome {
                stiction: st.clone(),
                linear: li.clone(),
                result,
            });
        }
    }
    reg.outcome = Ok(combos);
    reg
}

fn fit_of(r: &Run, d: &LoopData, notes: &[datasets::Note], plan: &Plan<'_>) -> ComboFit {
    let q = &r.result;
    let json = quantify_json(r, plan.search.init.label());
    let fit_val = q.fits_score(q.criterion);
    ComboFit {
        s: q.s,
        s_range: q.interval.s,
        j: q.j,
        j_range: q.interval.j,
        step: q.grid.step(),
        fit_val,
        evidence: plan.explainer.explain(d, q, notes),
        json,
    }
}

/// MV → ΔPV for an integrating loop: PV replaced by its increments, every series shortened by
/// its first sample.
pub(crate) fn increments(d: &LoopData) -> LoopData {
    let tail = |v: &Vec<f64>| v.get(1..).map(<[f64]>::to_vec).unwrap_or_default();
    let mut out = LoopData {
        source: d.source.clone(),
        start: d.start,
        t: d.t.as_ref().map(tail),
        sp: d.sp.as_ref().map(tail),
        pv: d
            .pv
            .as_ref()
            .map(|p| p.windows(2).map(|w| w[1] - w[0]).collect()),
        op: tail(&d.op),
        mv: d.mv.as_ref().map(tail),
        notes: d.notes.clone(),
    };
    out.notes.push(datasets::Note::new(
        datasets::NoteKind::Integrating,
        "integrating loop: identified from MV to the PV increment ΔPV",
    ));
    out
}

/// Evidence, from one quantification, that something besides the valve moves PV (a
/// disturbance, a drifting operating point, poor data). Used to say *why* a registration is
/// doubtful or an outlier.
///
/// `trend` adds the diagnosis of each doubtful registration ([`diagnose_registration`]) in
/// front of this evidence; the diagnosis runs only for the registrations that need it.
pub(crate) trait ExplainFit {
    /// Sentences a plant engineer can read; empty when nothing stands out.
    fn explain(&self, d: &LoopData, q: &Quantification, notes: &[datasets::Note]) -> Vec<String>;
}

/// The evidence available from the quantification itself.
///
/// | evidence | rule |
/// |---|---|
/// | poor fit | validation F_PV below `min_fit` % |
/// | slow residual | the validation residual's moving average (window N/10) holds more than 30 % of its variance: a slow, unmodelled component (a disturbance or a drifting operating point) |
/// | PV drift | mean PV moves by more than half its standard deviation between identification and validation data |
/// | set-point moves | the set point changes during the record (operating point not constant) |
/// | no stiction needed | the no-stiction valve (S = J = 0) lies inside the likelihood-ratio region |
/// | data notes | the reader reported flat stretches (historian compression) or dropped/filled samples |
pub(crate) struct FitEvidence {
    pub min_fit: f64,
}

impl ExplainFit for FitEvidence {
    fn explain(&self, d: &LoopData, q: &Quantification, notes: &[datasets::Note]) -> Vec<String> {
        let mut why = Vec::new();
        let fit = q.fits_score(q.criterion);
        if fit < self.min_fit {
            why.push(format!(
                "poor fit: F_PV val {fit:.1} % < {:.0} %, the valve + linear model explains \
                 little of PV",
                self.min_fit
            ));
        }
        if let Some(pv) = d.pv.as_deref() {
            let split = q.split_index.min(pv.len());
            let resid: Vec<f64> = (split..pv.len())
                .filter_map(|k| {
                    let e = q.pv_est.get(k).copied()?;
                    e.is_finite().then(|| pv[k] - e)
                })
                .collect();
            if let Some(ratio) = slow_fraction(&resid) {
                if ratio > 0.3 {
                    why.push(format!(
                        "slow residual: {:.0} % of the validation residual's variance is slow \
                         (moving average over N/10 samples): an unmodelled disturbance or drift",
                        100.0 * ratio
                    ));
                }
            }
            if split > 1 && split + 1 < pv.len() {
                let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
                let m = mean(pv);
                let sd = (pv.iter().map(|x| (x - m).powi(2)).sum::<f64>() / pv.len() as f64).sqrt();
                let shift = (mean(&pv[split..]) - mean(&pv[..split])).abs();
                if sd > 0.0 && shift > 0.5 * sd {
                    why.push(format!(
                        "PV drift: mean PV moves by {:.1} standard deviations between \
                         identification and validation data (non-stationary)",
                        shift / sd
                    ));
                }
            }
        }
        if let Some(sp) = d.sp.as_deref() {
            let moves = sp.windows(2).filter(|w| w[1] != w[0]).count();
            if moves > 0 {
                why.push(format!("set point moved {moves} time(s) during the record"));
            }
        }
        if q.interval.s[0] <= 0.0 {
            why.push("no stiction needed: S = 0 is inside the likelihood-ratio region".into());
        }
        for n in notes {
            // Samples made up or left out, a closed-loop segment cut out, flat stretches.
            if n.kind.changes_samples() || matches!(n.kind, NoteKind::Mode | NoteKind::Flat) {
                why.push(format!("data: {n}"));
            }
        }
        why
    }
}

/// The diagnosis (`discrepancy::diagnose`, as `stiction diagnose`) of one registration with
/// one stiction x linear combination as baseline, in one sentence: what the model misses in
/// that record and what the extension changes. Used by `trend` for its doubtful registrations.
pub(crate) fn diagnose_registration(
    reg: &Registration,
    stiction: &str,
    linear: &str,
    plan: &Plan<'_>,
) -> Result<String, String> {
    let opts = plan.data.read_options(true, 30);
    let d = datasets::read_path(&reg.path, &opts).map_err(|e| e.to_string())?;
    let d = if reg.integrating { increments(&d) } else { d };
    let pv = d.require_pv().map_err(|e| e.to_string())?;
    let (lo, hi) =
        d.op.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
    let span = hi - lo;
    let fail = |f: crate::Failure| crate::one_line(f.error());
    let (identifier, id_entry) =
        super::search_flags::build_identifier(linear, plan.search.orders.as_deref(), 0)
            .map_err(fail)?;
    let baseline = discrepancy::Baseline {
        stiction: stiction_models::find_model(stiction).map_err(|e| e.to_string())?,
        linear: id_entry,
        orders: identifier
            .orders()
            .into_iter()
            .filter(|(k, _)| *k != "delay")
            .map(|(k, v)| (k.to_string(), v))
            .collect(),
        delay: monitoring::Delay::Fixed(0),
        grid: None,
        search: grid_search::SearchOptions::default(),
    };
    let mut options = discrepancy::DiagnoseOptions::for_span(span);
    options.search = plan.search.options(span).map_err(fail)?;
    let problem = grid_search::Problem {
        op: &d.op,
        pv,
        mv: d.mv.as_deref(),
    };
    let dg = discrepancy::diagnose(problem, &baseline, &options).map_err(|e| e.to_string())?;
    Ok(match dg.chosen.and_then(|i| dg.findings.get(i)) {
        Some(f) if f.cause == "no-stiction" => format!(
            "diagnosis: no-stiction (a valve with negligible stiction, S {} % at most {} %, explains PV as well as S {:.2} %: validation F_PV {:+.1} points)",
            f.extended.as_ref().map_or("-".into(), |x| format!("{:.2}", x.s)),
            grid_search::NEGLIGIBLE_S,
            dg.baseline.s,
            f.gain_fit_pv_val
        ),
        Some(f) => {
            let s = f.extended.as_ref().map_or(String::new(), |x| {
                format!(", S {:.2} -> {:.2} %", dg.baseline.s, x.s)
            });
            format!(
                "diagnosis: {} (validation F_PV {:+.1} points{s})",
                f.cause, f.gain_fit_pv_val
            )
        }
        None => "diagnosis: none (no extension explains this record significantly better)".into(),
    })
}

/// Share of the variance of `r` carried by its moving average over `len/10` samples.
fn slow_fraction(r: &[f64]) -> Option<f64> {
    let n = r.len();
    if n < 20 {
        return None;
    }
    let w = (n / 10).max(3);
    let mean = r.iter().sum::<f64>() / n as f64;
    let var = r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
    if var <= 0.0 {
        return None;
    }
    let mut acc: f64 = r[..w].iter().sum();
    let mut ma = vec![acc / w as f64];
    for k in w..n {
        acc += r[k] - r[k - w];
        ma.push(acc / w as f64);
    }
    let mm = ma.iter().sum::<f64>() / ma.len() as f64;
    let vma = ma.iter().map(|x| (x - mm).powi(2)).sum::<f64>() / ma.len() as f64;
    Some(vma / var)
}

pub(crate) use monitoring::{median, roc};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_tags_are_integrating() {
        assert!(IntegratingFlag::Auto.applies("2111LIC31102B"));
        assert!(!IntegratingFlag::Auto.applies("2411FIC20102"));
        assert!(IntegratingFlag::Yes.applies("2411FIC20102"));
        assert!(!IntegratingFlag::No.applies("LIC1"));
    }

    #[test]
    fn slow_fraction_separates_white_from_drift() {
        let white: Vec<f64> = (0..300)
            .map(|k| ((k * 7919 % 101) as f64 - 50.0) / 50.0)
            .collect();
        let drift: Vec<f64> = (0..300).map(|k| k as f64 / 30.0).collect();
        assert!(slow_fraction(&white).unwrap_or(1.0) < 0.3);
        assert!(slow_fraction(&drift).unwrap_or(0.0) > 0.3);
    }
}
