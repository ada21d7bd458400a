//! Registrations: finding the files of a folder that are loop registrations, reading each one,
//! searching it with every combination and asking the detector whether the valve sticks, and
//! the evidence that explains a doubtful
//! estimate. What `trend` and `batch` share.
//!
//! Conventions (documented in `docs/PLANT_DATA.md`):
//! * a registration is one file (`.csv`, `.tsv`, `.txt` or `.mat`); a directory stands for its
//!   files with those extensions (not recursive), in name order;
//! * the valve is the file name up to the first `_`; the registration time is the file name's
//!   `_YYYYMMDD-HHMM` suffix, else the first time stamp of the data, else unknown;
//! * integrating loops (level: the tag's first letter, ISA-5.1, is `L`) are identified from MV
//!   to the PV increment ΔPV(k) = PV(k) − PV(k−1) with [`Integrating::Auto`] (the default):
//!   an integrator has no stable ARX model from MV to PV, so the grid search would skip the
//!   no-stiction node as unstable and keep only nodes whose MV happens to give a stable fit.

use std::fmt;
use std::path::{Path, PathBuf};

use datasets::{parse_registration_name, DataError, LoopData, Note, NoteKind, ReadOptions};
use grid_search::{Problem, Quantification};
use serde::{Deserialize, Serialize};

use crate::detect::{detect_decided, Detected};
use crate::kind::{file_name, Integrating};
use crate::MonitoringError;
use run::{error_line, Combination, QuantifyRecord};

/// File extensions read from a directory.
pub const EXTENSIONS: [&str; 4] = ["csv", "tsv", "txt", "mat"];

/// A file left out: of a directory and not a loop registration, or given twice.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NotALoop {
    /// The file.
    pub path: PathBuf,
    /// The OP column its header lacks.
    pub column: String,
    /// The path under which the same file is already counted (given twice, or by a folder and
    /// by name).
    pub duplicate_of: Option<PathBuf>,
}

impl fmt::Display for NotALoop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.duplicate_of {
            Some(first) => write!(f, "the same file as {}, counted once", first.display()),
            None => write!(
                f,
                "no {} column in its header, not a loop registration",
                self.column
            ),
        }
    }
}

/// What a file of a folder is, from its header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// A loop registration (or a file the reader will explain in its row).
    Loop,
    /// A labels table (columns `file` and `label`): left out without a note.
    Labels,
    /// Something else: left out with a note.
    Other,
}

/// What a delimited text file is: a loop registration when its header names the OP column
/// `op` (case-insensitive), a labels table when it names `file` and `label`, else something
/// else (a results table). `.mat` files are always taken (their reader lists the loops inside).
fn kind_of(f: &Path, op: &str) -> Kind {
    let is_text = f
        .extension()
        .is_some_and(|e| !e.eq_ignore_ascii_case("mat"));
    if !is_text {
        return Kind::Loop;
    }
    let Ok(file) = std::fs::File::open(f) else {
        return Kind::Loop; // the reader says why, in the file's row
    };
    let mut first = Vec::new();
    let _ = std::io::BufRead::read_until(
        &mut std::io::BufReader::new(std::io::Read::take(file, 64 * 1024)),
        b'\n',
        &mut first,
    );
    // Only a readable header that names other columns makes a file "something else": an empty
    // file, one that is not UTF-8 (UTF-16), a comment line or a first line of numbers (no
    // header) is a registration the reader cannot read, and gets its error row.
    let Ok(first) = std::str::from_utf8(&first) else {
        return Kind::Loop;
    };
    let first = first.trim_start_matches('\u{feff}');
    if first.trim().is_empty() || first.contains('\0') || first.starts_with('#') {
        return Kind::Loop;
    }
    let names: Vec<&str> = first
        .split([',', ';', '\t'])
        .map(|c| c.trim().trim_matches('"'))
        .collect();
    if names
        .iter()
        .all(|c| c.is_empty() || c.parse::<f64>().is_ok())
    {
        return Kind::Loop;
    }
    let has = |name: &str| names.iter().any(|c| c.eq_ignore_ascii_case(name));
    if has(op) {
        Kind::Loop
    } else if has("file") && has("label") {
        Kind::Labels
    } else {
        Kind::Other
    }
}

/// Expand files and directories into registration files: a directory gives its files with a
/// known extension whose header names the OP column `op` or cannot be read (the reader then
/// explains it in the file's error row), sorted by name, minus `exclude`; the files of a
/// directory left out as not being loops, and files given twice, are returned beside them,
/// except labels tables (a header with `file` and `label`), which are left out quietly.
pub fn expand(
    paths: &[PathBuf],
    exclude: &[PathBuf],
    op: &str,
) -> Result<(Vec<PathBuf>, Vec<NotALoop>), MonitoringError> {
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    };
    let mut out = Vec::new();
    let mut skipped = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| MonitoringError::Io {
                    path: p.clone(),
                    source: e,
                })?
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
                match kind_of(&f, op) {
                    Kind::Loop => out.push(f),
                    Kind::Labels => {}
                    Kind::Other => skipped.push(NotALoop {
                        path: f,
                        column: op.to_string(),
                        duplicate_of: None,
                    }),
                }
            }
        } else if p.exists() {
            out.push(p.clone());
        } else {
            return Err(MonitoringError::NoSuchPath(p.clone()));
        }
    }
    // The same file twice (given twice, or by name and by its folder) counts once.
    let mut seen: Vec<(PathBuf, PathBuf)> = Vec::new();
    let mut once = Vec::with_capacity(out.len());
    for f in out {
        let full = f.canonicalize().unwrap_or_else(|_| f.clone());
        match seen.iter().find(|(c, _)| *c == full) {
            Some((_, first)) => skipped.push(NotALoop {
                path: f,
                column: op.to_string(),
                duplicate_of: Some(first.clone()),
            }),
            None => {
                seen.push((full, f.clone()));
                once.push(f);
            }
        }
    }
    Ok((once, skipped))
}

/// Where a registration's time came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum TimeSource {
    /// The file name's `_YYYYMMDD-HHMM` suffix.
    #[serde(rename = "file name")]
    FileName,
    /// The data's first time stamp.
    #[serde(rename = "first time stamp")]
    FirstTimeStamp,
    /// Not known.
    #[serde(rename = "unknown")]
    Unknown,
}

/// Why a registration, or one combination on it, gave no estimate.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RegistrationError {
    /// The reader refused the file.
    #[error(transparent)]
    Read(#[from] DataError),
    /// The search failed (the message names the file).
    #[error("{file}: {}", error_line(.error))]
    Search {
        /// The loop's source (its path).
        file: String,
        /// What failed.
        error: run::RunError,
    },
    /// The record was read as the detector reads it, but it has nothing to fit (a PV or OP
    /// constant, or flat over more than half of the rows): the detector answers it, the
    /// combination gives no estimate. The reason is the reader's one line.
    #[error("{0}")]
    Unfit(String),
    /// The options are invalid (an unknown model, a bad order): nothing was run.
    #[error("{}", error_line(.0))]
    Options(MonitoringError),
    /// A bug: the evaluation panicked. Kept in the registration so that one file cannot end
    /// a batch or a trend.
    #[error("internal error on this registration (a bug, please report it): {0}")]
    Internal(String),
}

/// Evidence, from one quantification, that something besides the valve moves PV (see
/// [`FitEvidence`]), or the diagnosis of the registration.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Evidence {
    /// Validation F_PV below the minimum.
    PoorFit {
        /// The fit, %.
        fit: f64,
        /// The minimum, %.
        min_fit: f64,
    },
    /// The validation residual's moving average holds this share of its variance.
    SlowResidual(f64),
    /// Mean PV moves by this many standard deviations between identification and validation.
    PvDrift(f64),
    /// The set point changed this many times.
    SetPointMoved(usize),
    /// S = 0 is inside the likelihood-ratio region.
    NoStictionNeeded,
    /// The reader made up or left out samples, cut a closed-loop segment or saw flat
    /// stretches.
    Data(Note),
    /// The diagnosis of the registration, in one sentence (`discrepancy::registration`).
    Diagnosis(String),
}

impl fmt::Display for Evidence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Evidence::PoorFit { fit, min_fit } => write!(
                f,
                "poor fit: F_PV val {fit:.1} % < {min_fit:.0} %, the valve + linear model explains \
                 little of PV"
            ),
            Evidence::SlowResidual(ratio) => write!(
                f,
                "slow residual: {:.0} % of the validation residual's variance is slow \
                 (moving average over N/10 samples): an unmodelled disturbance or drift",
                100.0 * ratio
            ),
            Evidence::PvDrift(sds) => write!(
                f,
                "PV drift: mean PV moves by {sds:.1} standard deviations between \
                 identification and validation data (non-stationary)"
            ),
            Evidence::SetPointMoved(moves) => {
                write!(f, "set point moved {moves} time(s) during the record")
            }
            Evidence::NoStictionNeeded => {
                f.write_str("no stiction needed: S = 0 is inside the likelihood-ratio region")
            }
            Evidence::Data(note) => write!(f, "data: {note}"),
            Evidence::Diagnosis(text) => f.write_str(text),
        }
    }
}

impl Serialize for Evidence {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// A successful search of one combination on one registration.
#[derive(Debug, Clone)]
pub struct ComboFit {
    /// The contract's quantify object.
    pub record: QuantifyRecord,
    /// S, % of valve span.
    pub s: f64,
    /// Its likelihood-ratio range.
    pub s_range: [f64; 2],
    /// J.
    pub j: f64,
    /// Its range.
    pub j_range: [f64; 2],
    /// The grid's finest step (numbers in rows are rounded to its resolution, [`on_grid`]).
    ///
    /// [`on_grid`]: run::on_grid
    pub step: f64,
    /// Validation F_PV of the ranking criterion, %.
    pub fit_val: f64,
    /// Why the estimate may be doubtful (see [`ExplainFit`]).
    pub evidence: Vec<Evidence>,
}

/// One combination on one registration.
#[derive(Debug)]
pub struct ComboOutcome {
    /// Stiction model.
    pub stiction: &'static str,
    /// Linear identifier.
    pub linear: &'static str,
    /// The fit, or why there is none.
    pub result: Result<ComboFit, RegistrationError>,
}

/// One registration: where it is, which valve, when, and its results.
#[derive(Debug)]
pub struct Registration {
    /// The file.
    pub path: PathBuf,
    /// Its base name.
    pub file: String,
    /// The valve (file-name prefix before `_`).
    pub valve: String,
    /// Start, seconds since the Unix epoch (UTC).
    pub start: Option<f64>,
    /// Where the time came from.
    pub time_source: TimeSource,
    /// Identified from MV to ΔPV.
    pub integrating: bool,
    /// What the reader did to the data.
    pub notes: Vec<Note>,
    /// Results per combination (in the plan's order), or why the file could not be used.
    pub outcome: Result<Vec<ComboOutcome>, RegistrationError>,
    /// The detection crate's verdict on the record as read (time series only: PV, OP, SP,
    /// the sampling time and [`Registration::integrating`]); `None` when the file could not be
    /// read.
    pub detection: Option<Detected>,
    /// The record as searched (the increments of an integrating loop), kept when the plan
    /// asks for it ([`Plan::keep_data`]) and the file could be read.
    pub data: Option<LoopData>,
}

impl Registration {
    /// The fit of combination `c`, when there is one.
    pub fn fit(&self, c: usize) -> Option<&ComboFit> {
        self.outcome.as_ref().ok()?.get(c)?.result.as_ref().ok()
    }

    /// The detector's verdict, `None` when it did not run (the file could not be read).
    pub fn detect_verdict(&self) -> Option<detection::Verdict> {
        self.detection.as_ref().map(Detected::verdict)
    }

    /// Whether the record was read and answered by the detector but has nothing to fit (a
    /// PV or OP constant or flat over most of it: [`RegistrationError::Unfit`]): the
    /// registration is judged, with the detector's verdict and reason, not an error.
    pub fn unfit(&self) -> bool {
        self.outcome.as_ref().is_ok_and(|combos| {
            combos
                .iter()
                .any(|o| matches!(o.result, Err(RegistrationError::Unfit(_))))
        })
    }

    /// The error of combination `c` (or of the whole registration), when there is one.
    pub fn error(&self, c: usize) -> Option<&RegistrationError> {
        match &self.outcome {
            Err(e) => Some(e),
            Ok(combos) => combos.get(c)?.result.as_ref().err(),
        }
    }
}

/// Everything needed to evaluate a registration.
#[derive(Clone, Copy)]
pub struct Plan<'a> {
    /// The combinations, in the order of the results.
    pub combinations: &'a [Combination],
    /// The reader's options.
    pub read: &'a ReadOptions,
    /// Which loops are integrating.
    pub integrating: Integrating,
    /// The evidence for each fit.
    pub explainer: &'a (dyn ExplainFit + Sync),
    /// Keep the record as searched in [`Registration::data`] (for a diagnosis after the
    /// search).
    pub keep_data: bool,
}

/// Read and search one registration with every combination of `plan`, and run the detection
/// crate on the record as read ([`detect_loop`](crate::detect::detect_loop), kept in [`Registration::detection`]). Never fails and never
/// panics: a problem is recorded in the registration — a panic too (the registration runs
/// isolated, so one bad file cannot end a batch or a trend). A PV or OP that identification
/// refuses as constant or flat over most of the record is read as `detect` reads it: the
/// detector answers it and each combination's result is [`RegistrationError::Unfit`] with the
/// reader's reason ([`Registration::unfit`]).
pub fn evaluate(path: &Path, plan: &Plan<'_>) -> Registration {
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
            let mut reg = unread(path, plan.integrating);
            reg.outcome = Err(RegistrationError::Internal(what.replace('\n', " ")));
            reg
        }
    }
}

/// A registration known by its name only.
pub(crate) fn unread(path: &Path, integrating: Integrating) -> Registration {
    let file = file_name(path);
    let name = parse_registration_name(&file);
    Registration {
        path: path.to_path_buf(),
        integrating: integrating.decide(&name.valve, None).integrating,
        file,
        valve: name.valve,
        start: name.start,
        time_source: if name.start.is_some() {
            TimeSource::FileName
        } else {
            TimeSource::Unknown
        },
        notes: Vec::new(),
        outcome: Ok(Vec::new()),
        detection: None,
        data: None,
    }
}

fn evaluate_unguarded(path: &Path, plan: &Plan<'_>) -> Registration {
    let mut reg = unread(path, plan.integrating);
    // Tests prove the isolation with a registration that panics (debug builds only).
    if cfg!(debug_assertions)
        && std::env::var_os("STICTION_TEST_PANIC_ON").is_some_and(|v| *v == *reg.file)
    {
        panic!("test panic on {}", reg.file);
    }
    // A PV or OP constant, or flat over more than half of the rows, has nothing to fit, but
    // it is evidence the detector answers (a stuck valve or a frozen transmitter, the valve
    // never asked to move): read it as `detect` does, and let each combination say why there
    // is no fit.
    let (d, unfit) = match datasets::read_path(path, plan.read) {
        Ok(d) => (d, None),
        Err(e @ (DataError::Constant { .. } | DataError::Flat { .. })) => {
            let lenient = ReadOptions {
                accept_constant: true,
                ..plan.read.clone()
            };
            match datasets::read_path(path, &lenient) {
                Ok(d) => (d, Some(e.to_string())),
                Err(e) => {
                    reg.outcome = Err(e.into());
                    return reg;
                }
            }
        }
        Err(e) => {
            reg.outcome = Err(e.into());
            return reg;
        }
    };
    if reg.start.is_none() {
        if let Some(s) = d.start {
            reg.start = Some(s);
            reg.time_source = TimeSource::FirstTimeStamp;
        }
    }
    reg.notes = d.notes.clone();
    let kind = plan.integrating.decide(&reg.valve, Some(&d));
    reg.integrating = kind.integrating;
    reg.detection = Some(detect_decided(&d, kind));
    if let Some(why) = unfit {
        let no_fit = |c: &Combination| ComboOutcome {
            stiction: c.stiction.name,
            linear: c.linear.name,
            result: Err(RegistrationError::Unfit(why.clone())),
        };
        reg.outcome = Ok(plan.combinations.iter().map(no_fit).collect());
        return reg;
    }
    let used = if reg.integrating {
        increments(&d)
    } else {
        d.clone()
    };
    let combos = plan
        .combinations
        .iter()
        .map(|c| ComboOutcome {
            stiction: c.stiction.name,
            linear: c.linear.name,
            result: fit_one(c, (&d, &used), reg.integrating, &reg.notes, plan),
        })
        .collect();
    reg.outcome = Ok(combos);
    if plan.keep_data {
        reg.data = Some(used);
    }
    reg
}

/// One combination on `used` (the record, or its increments for an integrating loop), with
/// the repair estimate on the record as read.
fn fit_one(
    c: &Combination,
    (read, d): (&LoopData, &LoopData),
    integrating: bool,
    notes: &[Note],
    plan: &Plan<'_>,
) -> Result<ComboFit, RegistrationError> {
    let pv = d.require_pv()?;
    let problem = Problem {
        op: &d.op,
        pv,
        mv: d.mv.as_deref(),
    };
    let r = c
        .run(problem, None)
        .map_err(|error| RegistrationError::Search {
            file: d.source.clone(),
            error,
        })?;
    let q = &r.result;
    let mut record = r.record(&c.search.init);
    record.set_repair(r.repair(read, integrating));
    Ok(ComboFit {
        record,
        s: q.s,
        s_range: q.interval.s,
        j: q.j,
        j_range: q.interval.j,
        step: q.grid.step(),
        fit_val: q.fits_score(q.criterion),
        evidence: plan.explainer.explain(d, q, notes),
    })
}

/// MV → ΔPV for an integrating loop: PV replaced by its increments, every series shortened by
/// its first sample.
pub fn increments(d: &LoopData) -> LoopData {
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
    out.notes.push(Note::new(
        NoteKind::Integrating,
        "integrating loop: identified from MV to the PV increment ΔPV",
    ));
    out
}

/// Evidence, from one quantification, that something besides the valve moves PV (a
/// disturbance, a drifting operating point, poor data): used to say *why* a registration is
/// doubtful or an outlier.
pub trait ExplainFit {
    /// The evidence; empty when nothing stands out.
    fn explain(&self, d: &LoopData, q: &Quantification, notes: &[Note]) -> Vec<Evidence>;
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
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitEvidence {
    /// Validation F_PV (%) below which the fit is poor.
    pub min_fit: f64,
}

impl ExplainFit for FitEvidence {
    fn explain(&self, d: &LoopData, q: &Quantification, notes: &[Note]) -> Vec<Evidence> {
        let mut why = Vec::new();
        let fit = q.fits_score(q.criterion);
        if fit < self.min_fit {
            why.push(Evidence::PoorFit {
                fit,
                min_fit: self.min_fit,
            });
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
                    why.push(Evidence::SlowResidual(ratio));
                }
            }
            if split > 1 && split + 1 < pv.len() {
                let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
                let m = mean(pv);
                let sd = (pv.iter().map(|x| (x - m).powi(2)).sum::<f64>() / pv.len() as f64).sqrt();
                let shift = (mean(&pv[split..]) - mean(&pv[..split])).abs();
                if sd > 0.0 && shift > 0.5 * sd {
                    why.push(Evidence::PvDrift(shift / sd));
                }
            }
        }
        if let Some(sp) = d.sp.as_deref() {
            let moves = sp.windows(2).filter(|w| w[1] != w[0]).count();
            if moves > 0 {
                why.push(Evidence::SetPointMoved(moves));
            }
        }
        if q.interval.s[0] <= 0.0 {
            why.push(Evidence::NoStictionNeeded);
        }
        for n in notes {
            // Samples made up or left out, a closed-loop segment cut out, flat stretches,
            // compressed storage.
            if n.kind.changes_samples()
                || matches!(
                    n.kind,
                    NoteKind::Mode | NoteKind::Flat | NoteKind::Compression
                )
            {
                why.push(Evidence::Data(n.clone()));
            }
        }
        why
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slow_fraction_separates_white_from_drift() {
        let white: Vec<f64> = (0..300)
            .map(|k| ((k * 7919 % 101) as f64 - 50.0) / 50.0)
            .collect();
        let drift: Vec<f64> = (0..300).map(|k| k as f64 / 30.0).collect();
        assert!(slow_fraction(&white).unwrap_or(1.0) < 0.3);
        assert!(slow_fraction(&drift).unwrap_or(0.0) > 0.3);
    }

    #[test]
    fn increments_shorten_every_series_and_say_so() {
        let d = LoopData {
            source: "x".into(),
            start: None,
            t: Some(vec![0.0, 1.0, 2.0]),
            sp: None,
            pv: Some(vec![1.0, 3.0, 2.0]),
            op: vec![5.0, 6.0, 7.0],
            mv: None,
            notes: Vec::new(),
        };
        let i = increments(&d);
        assert_eq!(i.pv, Some(vec![2.0, -1.0]));
        assert_eq!(i.op, vec![6.0, 7.0]);
        assert_eq!(i.notes[0].kind, NoteKind::Integrating);
    }
}
