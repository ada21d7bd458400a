//! Many loops, one row per loop and combination: the batch that `stiction batch` runs and that
//! a Python binding calls file by file on its workers.
//!
//! * [`run_file`] reads and searches one file with every combination of a [`BatchOptions`]
//!   and returns its [`Row`]s. It never fails and never panics: a file the reader refuses, a
//!   failed search or a bug becomes a row with status `error` and its one-line error.
//! * [`run`](fn@run) does it for many files in parallel, resumably: with a JSONL file, the rows already
//!   there for the same file (full path and SHA-256 of its bytes) and the same options are kept, a
//!   torn line (an interrupted run) is dropped and its file computed again, and each new file's
//!   rows are appended as soon as it is done.
//! * [`Labels`] joins a `file,label` table to the rows; [`label_summary`] measures how well S
//!   separates the labels (ROC AUC, Youden's threshold).
//!
//! ```no_run
//! use std::path::Path;
//! use monitoring::batch::{run_file, BatchOptions, Status};
//!
//! let opts = BatchOptions {
//!     stiction: vec!["kano".into(), "he".into()],
//!     ..BatchOptions::default()
//! };
//! // On a worker: one file, one row per combination, never an error.
//! let rows = run_file(Path::new("plant/2411FIC20102_20240301-0800.csv"), &opts);
//! for row in &rows {
//!     match &row.status {
//!         Status::Ok(fit) => println!("{} {}: S = {}", row.file, fit.stiction_model, fit.s),
//!         Status::Error(e) => println!("{}: {}", row.file, e.error),
//!     }
//! }
//! // The options and the rows travel as JSON (serde).
//! let wire = serde_json::to_string(&opts)?;
//! let back: BatchOptions = serde_json::from_str(&wire)?;
//! assert_eq!(back, opts);
//! # Ok::<(), serde_json::Error>(())
//! ```

use std::collections::{HashMap, HashSet};
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use datasets::{format_epoch, ReadOptions};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::answer::{SFrom, RANGE_UNIT, SPAN_UNIT};
use crate::detect::Detected;
use crate::kind::Integrating;
use crate::registration::{evaluate, unread, FitEvidence, Plan, Registration, RegistrationError};
use crate::{roc, MonitoringError, Roc, TimeSource};
use run::{null_as_nan, on_grid, Combination, QuantifyRecord, Settings};

/// Default minimum validation F_PV (%) below which the evidence says "poor fit".
pub const DEFAULT_MIN_FIT: f64 = grid_search::trust::WEAK_FIT;

/// Fewest data rows a registration must have.
pub const MIN_ROWS: usize = 30;

/// What a batch computes for each file. Serialisable, so that it can be sent to workers; two
/// runs with equal options give equal rows, and a resumed run keeps only the rows computed
/// with equal options ([`BatchOptions::fingerprint`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BatchOptions {
    /// Stiction models (registered names).
    pub stiction: Vec<String>,
    /// Linear identifiers (registered names); every stiction × linear combination is run,
    /// stiction-major.
    pub linear: Vec<String>,
    /// Orders, dead time, grid and search options of every combination.
    pub settings: Settings,
    /// The reader's options (columns, gaps, controller mode, OP range, limits).
    pub read: ReadOptions,
    /// Which loops are integrating (identified from MV to ΔPV).
    pub integrating: Integrating,
    /// Validation F_PV (%) below which the evidence says "poor fit".
    pub min_fit: f64,
}

impl Default for BatchOptions {
    fn default() -> Self {
        BatchOptions {
            stiction: vec!["kano".into()],
            linear: vec!["arx".into()],
            settings: Settings::default(),
            read: ReadOptions {
                require_pv: true,
                min_rows: MIN_ROWS,
                ..ReadOptions::default()
            },
            integrating: Integrating::Auto,
            min_fit: DEFAULT_MIN_FIT,
        }
    }
}

impl BatchOptions {
    /// Every stiction × linear combination (stiction-major), checked: an unknown name or a
    /// bad order is an error here, before any file is read.
    pub fn combinations(&self) -> Result<Vec<Combination>, MonitoringError> {
        let mut out = Vec::new();
        for st in &self.stiction {
            for li in &self.linear {
                out.push(self.settings.combination(st, li)?);
            }
        }
        Ok(out)
    }

    /// The options as one string, stored in every row: a resumed run keeps a row only when
    /// its fingerprint equals the run's.
    pub fn fingerprint(&self) -> String {
        serde_json::to_string(self).unwrap_or_else(|e| format!("unserialisable options: {e}"))
    }
}

/// A file's label.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Label {
    /// The valve sticks.
    Stiction,
    /// It does not.
    NoStiction,
}

/// One row of a batch: one file × one combination (or the file alone when it could not be
/// read). Its JSON is a line of `OUT.jsonl`; [`CSV_COLUMNS`] are the columns of `OUT.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Base name of the file.
    pub file: String,
    /// Path as given.
    pub path: String,
    /// Size, bytes (0 when unknown).
    pub size: u64,
    /// Modification time, seconds since the Unix epoch.
    pub mtime: Option<u64>,
    /// SHA-256 of the file's bytes (hex), the resume key with the full path; `None` when the
    /// row predates it (then computed again) or the file could not be read.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sha256: Option<String>,
    /// The valve (file-name prefix before `_`).
    pub valve: String,
    /// Registration time, `YYYY-MM-DD HH:MM` UTC.
    pub time: Option<String>,
    /// Where the time came from.
    pub time_source: TimeSource,
    /// Identified from MV to ΔPV.
    pub integrating: bool,
    /// The file's label, when labels were given.
    pub label: Option<Label>,
    /// What the reader did to the data, in words.
    pub notes: Vec<String>,
    /// The options' fingerprint ([`BatchOptions::fingerprint`]).
    pub settings: String,
    /// The result.
    #[serde(flatten)]
    pub status: Status,
    /// The detector's score in `[0, 1]` on the file's record (the same on every row of the
    /// file); `null` when it could not run or the row predates it.
    #[serde(default)]
    pub detect_score: Option<f64>,
    /// The detector's verdict: `stiction`, `no-stiction` or `inconclusive`; empty when the file
    /// could not be read or the row predates the detector.
    #[serde(default)]
    pub detect_verdict: String,
    /// The detector's reason, one sentence; empty when the file could not be read or the row
    /// predates it.
    #[serde(default)]
    pub detect_reason: String,
}

/// A row's result: `"status": "ok"` with the estimate, or `"status": "error"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "lowercase")]
pub enum Status {
    /// The estimate.
    Ok(Box<OkRow>),
    /// Why there is none.
    Error(ErrorRow),
}

/// The estimate of a row with status `ok`. S, J and their ranges are rounded to the grid's
/// resolution.
///
/// `S` is the registration's one answer ([`Registration::reported`], as `quantify` and
/// `trend` report it): the S that explains the detector's verdict, from the combination's
/// one-step-prediction fit when it agrees with the verdict, else from the detector's
/// output-error fit (`S_from`); `S_lo`, `S_hi` the hull of both fits' 95 % regions. The
/// combination's own one-step fit is kept beside it (`S_one_step`, `S_one_step_lo`,
/// `S_one_step_hi`). Rows written before these keys have `S_from` absent: their `S` is the
/// one-step S.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OkRow {
    /// Stiction model.
    pub stiction_model: String,
    /// Linear identifier.
    pub linear_model: String,
    /// S reported, in `S_unit`.
    #[serde(rename = "S", deserialize_with = "null_as_nan")]
    pub s: f64,
    /// Lower end of its range (both fits' 95 % regions).
    #[serde(rename = "S_lo", deserialize_with = "null_as_nan")]
    pub s_lo: f64,
    /// Upper end.
    #[serde(rename = "S_hi", deserialize_with = "null_as_nan")]
    pub s_hi: f64,
    /// Which fit `S` comes from; `None` in a row written before it (`S` is then the one-step
    /// S).
    #[serde(rename = "S_from", default)]
    pub s_from: Option<SFrom>,
    /// The unit of S: `% of valve span`, or `% of the OP range seen` when OP's valve span is
    /// unknown (then no threshold in % of valve span applies); empty in a row written before
    /// it.
    #[serde(rename = "S_unit", default)]
    pub s_unit: String,
    /// The combination's one-step-prediction S (`None` in a row written before it).
    #[serde(rename = "S_one_step", default)]
    pub s_one_step: Option<f64>,
    /// Lower end of its likelihood-ratio region.
    #[serde(rename = "S_one_step_lo", default)]
    pub s_one_step_lo: Option<f64>,
    /// Upper end.
    #[serde(rename = "S_one_step_hi", default)]
    pub s_one_step_hi: Option<f64>,
    /// J.
    #[serde(rename = "J", deserialize_with = "null_as_nan")]
    pub j: f64,
    /// Lower end of the range of J.
    #[serde(rename = "J_lo", deserialize_with = "null_as_nan")]
    pub j_lo: f64,
    /// Upper end.
    #[serde(rename = "J_hi", deserialize_with = "null_as_nan")]
    pub j_hi: f64,
    /// Validation F_PV of the ranking criterion, %.
    #[serde(deserialize_with = "null_as_nan")]
    pub fit_pv_val: f64,
    /// Best validation fit with negligible stiction, %.
    pub fit_no_stiction: Option<f64>,
    /// Evidence that something besides the valve moves PV, in words.
    pub why: Vec<String>,
    /// The contract's quantify object.
    pub quantify: QuantifyRecord,
}

/// A row with status `error`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorRow {
    /// Stiction model (absent when the file could not be read at all).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiction_model: Option<String>,
    /// Linear identifier (likewise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear_model: Option<String>,
    /// The one-line error.
    pub error: String,
}

impl Row {
    /// Whether the row has an estimate.
    pub fn is_ok(&self) -> bool {
        matches!(self.status, Status::Ok(_))
    }

    /// The estimate, when there is one.
    pub fn ok(&self) -> Option<&OkRow> {
        match &self.status {
            Status::Ok(r) => Some(r),
            Status::Error(_) => None,
        }
    }

    /// `(stiction, linear)` of the row (empty for a file that could not be read).
    pub fn combination(&self) -> (&str, &str) {
        match &self.status {
            Status::Ok(r) => (&r.stiction_model, &r.linear_model),
            Status::Error(e) => (
                e.stiction_model.as_deref().unwrap_or(""),
                e.linear_model.as_deref().unwrap_or(""),
            ),
        }
    }

    /// The one-line error, for a row with status `error`.
    pub fn error(&self) -> Option<&str> {
        match &self.status {
            Status::Ok(_) => None,
            Status::Error(e) => Some(&e.error),
        }
    }

    /// The row as one JSON line (keys sorted, as `OUT.jsonl` has them).
    pub fn to_json_line(&self) -> String {
        serde_json::to_value(self)
            .map(|v| v.to_string())
            .unwrap_or_else(|e| format!("{{\"error\":\"unserialisable row: {e}\"}}"))
    }

    /// The row's cells in [`CSV_COLUMNS`] order (lists joined with ` | `, null empty; the
    /// repair columns from the quantify object's `repair`).
    pub fn csv_record(&self) -> Vec<String> {
        let v = serde_json::to_value(self).unwrap_or_default();
        CSV_COLUMNS
            .iter()
            .map(|k| match *k {
                "reduction" => csv_cell(&v["quantify"]["repair"]["reduction"]),
                "repair_reason" => csv_cell(&v["quantify"]["repair_reason"]),
                key => csv_cell(&v[key]),
            })
            .collect()
    }
}

/// The columns of `OUT.csv`.
pub const CSV_COLUMNS: [&str; 29] = [
    "file",
    "valve",
    "time",
    "status",
    "stiction_model",
    "linear_model",
    "S",
    "S_lo",
    "S_hi",
    "J",
    "J_lo",
    "J_hi",
    "fit_pv_val",
    "fit_no_stiction",
    "integrating",
    "label",
    "why",
    "notes",
    "error",
    "detect_score",
    "detect_verdict",
    "reduction",
    "repair_reason",
    "S_from",
    "S_unit",
    "S_one_step",
    "S_one_step_lo",
    "S_one_step_hi",
    "detect_reason",
];

fn csv_cell(v: &serde_json::Value) -> String {
    use serde_json::Value;
    match v {
        Value::Null => String::new(),
        Value::String(s) => s.clone(),
        Value::Array(a) => a.iter().map(csv_cell).collect::<Vec<_>>().join(" | "),
        other => other.to_string(),
    }
}

/// SHA-256 of the file's bytes in hex; `None` when it cannot be read.
pub fn content_hash(p: &Path) -> Option<String> {
    use sha2::{Digest, Sha256};
    let mut file = std::fs::File::open(p).ok()?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        match std::io::Read::read(&mut file, &mut buf) {
            Ok(0) => break,
            Ok(k) => h.update(&buf[..k]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(_) => return None,
        }
    }
    Some(h.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// The resume key of a file: its full path and the hash of its content. A file of the same
/// name, size and modification time in another folder (`rsync -a`, `tar`) is another file;
/// the same bytes at the same path are the same registration whatever their time stamps.
fn resume_key(path: &Path, hash: Option<&str>) -> Option<String> {
    let full = path.canonicalize().ok()?;
    Some(format!("{}|{}", full.display(), hash?))
}

/// Size and modification time (s), reported in the rows.
fn identity(p: &Path) -> (u64, Option<u64>) {
    let meta = std::fs::metadata(p).ok();
    let size = meta.as_ref().map_or(0, |m| m.len());
    let mtime = meta
        .and_then(|m| m.modified().ok())
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map(|d| d.as_secs());
    (size, mtime)
}

/// The rows of one evaluated registration.
fn rows_of(reg: &Registration, settings: &str) -> Vec<Row> {
    let (size, mtime) = identity(&reg.path);
    let sha256 = content_hash(&reg.path);
    let row = |status: Status| Row {
        file: reg.file.clone(),
        path: reg.path.display().to_string(),
        size,
        mtime,
        sha256: sha256.clone(),
        valve: reg.valve.clone(),
        time: reg.start.map(format_epoch),
        time_source: reg.time_source,
        integrating: reg.integrating,
        label: None,
        notes: reg.notes.iter().map(|n| n.text.clone()).collect(),
        settings: settings.to_string(),
        status,
        detect_score: reg.detection.as_ref().and_then(|d| d.score()),
        detect_verdict: reg
            .detect_verdict()
            .map_or(String::new(), |v| v.as_str().to_string()),
        detect_reason: reg
            .detection
            .as_ref()
            .map_or(String::new(), Detected::reason),
    };
    let unit = if datasets::units::span_unknown(&reg.notes) {
        RANGE_UNIT
    } else {
        SPAN_UNIT
    };
    match &reg.outcome {
        Err(e) => vec![row(Status::Error(ErrorRow {
            stiction_model: None,
            linear_model: None,
            error: e.to_string(),
        }))],
        Ok(combos) => combos
            .iter()
            .enumerate()
            .map(|(k, c)| {
                row(match (&c.result, reg.reported(k)) {
                    (Ok(fit), Some(rep)) => {
                        let g = |x: f64| on_grid(x, fit.step);
                        let mut quantify = fit.record.clone();
                        if let Some(refusal) = reg.repair_refusal(k) {
                            quantify.set_repair(Err(refusal));
                        }
                        Status::Ok(Box::new(OkRow {
                            stiction_model: c.stiction.to_string(),
                            linear_model: c.linear.to_string(),
                            s: g(rep.s),
                            s_lo: g(rep.range[0]),
                            s_hi: g(rep.range[1]),
                            s_from: Some(rep.from),
                            s_unit: unit.to_string(),
                            s_one_step: Some(g(fit.s)).filter(|x| x.is_finite()),
                            s_one_step_lo: Some(g(fit.s_range[0])).filter(|x| x.is_finite()),
                            s_one_step_hi: Some(g(fit.s_range[1])).filter(|x| x.is_finite()),
                            j: g(fit.j),
                            j_lo: g(fit.j_range[0]),
                            j_hi: g(fit.j_range[1]),
                            fit_pv_val: fit.fit_val,
                            fit_no_stiction: fit.record.fit_no_stiction,
                            why: fit.evidence.iter().map(ToString::to_string).collect(),
                            quantify,
                        }))
                    }
                    (result, _) => Status::Error(ErrorRow {
                        stiction_model: Some(c.stiction.to_string()),
                        linear_model: Some(c.linear.to_string()),
                        error: result
                            .as_ref()
                            .err()
                            .map_or_else(|| "no S reported".to_string(), ToString::to_string),
                    }),
                })
            })
            .collect(),
    }
}

/// Read and search one file with every combination of `opts`: one row per combination, or one
/// error row when the file cannot be read or the options are invalid. Never fails, never
/// panics.
pub fn run_file(path: &Path, opts: &BatchOptions) -> Vec<Row> {
    match opts.combinations() {
        Ok(combinations) => run_planned(path, opts, &combinations),
        Err(e) => {
            let mut reg = unread(path, opts.integrating);
            reg.outcome = Err(RegistrationError::Options(e));
            rows_of(&reg, &opts.fingerprint())
        }
    }
}

fn run_planned(path: &Path, opts: &BatchOptions, combinations: &[Combination]) -> Vec<Row> {
    let explainer = FitEvidence {
        min_fit: opts.min_fit,
    };
    let plan = Plan {
        combinations,
        read: &opts.read,
        integrating: opts.integrating,
        explainer: &explainer,
        keep_data: false,
    };
    rows_of(&evaluate(path, &plan), &opts.fingerprint())
}

/// `file -> label` from a labels table.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Labels(pub HashMap<String, Label>);

impl Labels {
    /// Read a CSV with columns `file` and `label` (`stiction` / `no-stiction`; also `1`/`0`,
    /// `true`/`false`, `yes`/`no`).
    pub fn read(path: &Path) -> Result<Labels, MonitoringError> {
        let csv_err = |source: csv::Error| MonitoringError::Csv {
            path: path.to_path_buf(),
            source,
        };
        let mut r = csv::Reader::from_path(path).map_err(csv_err)?;
        let header = r.headers().map_err(csv_err)?.clone();
        let col = |name: &'static str| {
            header
                .iter()
                .position(|h| h.trim().eq_ignore_ascii_case(name))
                .ok_or_else(|| MonitoringError::NoColumn {
                    path: path.to_path_buf(),
                    column: name,
                })
        };
        let (fi, li) = (col("file")?, col("label")?);
        let mut out = HashMap::new();
        for (k, rec) in r.records().enumerate() {
            let rec = rec.map_err(csv_err)?;
            let label = rec.get(li).unwrap_or("").trim().to_ascii_lowercase();
            let label = match label.as_str() {
                "stiction" | "1" | "true" | "yes" => Label::Stiction,
                "no-stiction" | "nostiction" | "no_stiction" | "0" | "false" | "no" => {
                    Label::NoStiction
                }
                _ => {
                    return Err(MonitoringError::BadLabel {
                        path: path.to_path_buf(),
                        row: k + 2,
                        value: label,
                    })
                }
            };
            out.insert(rec.get(fi).unwrap_or("").trim().to_string(), label);
        }
        Ok(Labels(out))
    }

    /// The label of `file` (a base name).
    pub fn get(&self, file: &str) -> Option<Label> {
        self.0.get(file).copied()
    }
}

/// The rows of an existing `OUT.jsonl`, and the line numbers of lines that are not a JSON
/// object (a torn last line is what an interrupted run leaves). A JSON object that is not a
/// row of this version is left out as stale (its file is computed again).
pub fn read_jsonl(path: &Path) -> Result<(Vec<Row>, Vec<usize>), MonitoringError> {
    let io = |source| MonitoringError::Io {
        path: path.to_path_buf(),
        source,
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let (mut rows, mut torn) = (Vec::new(), Vec::new());
    for (i, line) in std::io::BufReader::new(f).lines().enumerate() {
        let line = line.map_err(io)?;
        if line.trim().is_empty() {
            continue;
        }
        match serde_json::from_str::<serde_json::Value>(&line) {
            Ok(v) if v.is_object() => rows.extend(serde_json::from_value::<Row>(v).ok()),
            _ => torn.push(i + 1),
        }
    }
    Ok((rows, torn))
}

/// What [`run`](fn@run) did.
#[derive(Debug, Clone, PartialEq)]
pub struct BatchRun {
    /// Every row (kept from the JSONL and computed now), sorted by file, stiction model and
    /// linear identifier.
    pub rows: Vec<Row>,
    /// Files computed now.
    pub computed: usize,
    /// Files whose rows were already in the JSONL.
    pub skipped: usize,
    /// Line numbers of the JSONL's torn lines (their files were computed again).
    pub torn: Vec<usize>,
}

impl BatchRun {
    /// What happened to the JSONL's torn lines (`None` when there were none): their
    /// registrations were computed again.
    pub fn torn_note(&self) -> Option<String> {
        let first = self.torn.first()?;
        Some(match self.torn.len() {
            1 => format!("line {first} is torn (an interrupted run): its registration is computed again"),
            n => format!("{n} unreadable lines (first: line {first}): their registrations are computed again"),
        })
    }
}

/// The files of a run with the output prefix `out`: `OUT.jsonl` (each row as its loop
/// finishes; what a resumed run reads) and `OUT.csv` (the sorted table, written at the end).
pub fn out_paths(out: &Path) -> (PathBuf, PathBuf) {
    let with = |ext: &str| {
        let mut s = out.as_os_str().to_owned();
        s.push(ext);
        PathBuf::from(s)
    };
    (with(".jsonl"), with(".csv"))
}

/// Hold the lock of the output `jsonl` (an advisory lock on `jsonl` + `.lock`, created if
/// needed) for as long as the returned file is open: a second run on the same output is
/// refused ([`MonitoringError::OutputBusy`]) instead of appending every row a second time. The
/// operating system releases the lock when the process ends, killed or not.
pub fn lock_output(jsonl: &Path) -> Result<std::fs::File, MonitoringError> {
    let mut name = jsonl.as_os_str().to_owned();
    name.push(".lock");
    let path = PathBuf::from(name);
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(|source| MonitoringError::Io {
            path: path.clone(),
            source,
        })?;
    match file.try_lock() {
        Ok(()) => Ok(file),
        Err(std::fs::TryLockError::WouldBlock) => Err(MonitoringError::OutputBusy {
            path: jsonl.to_path_buf(),
        }),
        Err(std::fs::TryLockError::Error(source)) => Err(MonitoringError::Io { path, source }),
    }
}

/// The resume step of a batch ([`resume`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Resume {
    /// The rows of the JSONL kept: their file (full path, content hash) is among the
    /// run's files and their options are the run's.
    pub kept: Vec<Row>,
    /// The files still to compute, in the given order.
    pub todo: Vec<PathBuf>,
    /// Line numbers of the JSONL's torn lines (their files are in `todo`).
    pub torn: Vec<usize>,
}

/// Which of `files` a run with `opts` still has to compute, given the rows already in `jsonl`;
/// rewrites `jsonl` with the kept rows only (dropping torn lines and stale rows), so the new
/// rows can be appended to it as they are computed. Without `jsonl`, everything is to do.
/// [`run`](fn@run) and the Python package's distributed fleet both resume through it.
pub fn resume(
    files: &[PathBuf],
    opts: &BatchOptions,
    jsonl: Option<&Path>,
) -> Result<Resume, MonitoringError> {
    let settings = opts.fingerprint();
    let (mut kept, torn) = match jsonl {
        Some(p) if p.exists() => read_jsonl(p)?,
        _ => (Vec::new(), Vec::new()),
    };
    let keys: Vec<Option<String>> = files
        .iter()
        .map(|f| resume_key(f, content_hash(f).as_deref()))
        .collect();
    let current: HashSet<&String> = keys.iter().flatten().collect();
    let row_key = |r: &Row| resume_key(Path::new(&r.path), r.sha256.as_deref());
    // A row of a registration that was read always has the detector's verdict; one without
    // it was written before the detector existed and is computed again.
    // Likewise a row without the repair assessment (neither `repair` nor its reason).
    let unassessed = |r: &Row| {
        r.ok()
            .is_some_and(|o| o.quantify.repair.is_none() && o.quantify.repair_reason.is_none())
    };
    // Likewise an ok row whose S is the one-step S alone (written before the registration's
    // one answer, `S_from`).
    let unanswered = |r: &Row| r.ok().is_some_and(|o| o.s_from.is_none());
    kept.retain(|r| {
        r.settings == settings
            && row_key(r).is_some_and(|k| current.contains(&k))
            && !(r.is_ok() && r.detect_verdict.is_empty())
            && !unassessed(r)
            && !unanswered(r)
    });
    let done: HashSet<String> = kept.iter().filter_map(row_key).collect();
    let todo: Vec<PathBuf> = files
        .iter()
        .zip(&keys)
        .filter(|(_, k)| !k.as_ref().is_some_and(|k| done.contains(k)))
        .map(|(f, _)| f.clone())
        .collect();
    if let Some(path) = jsonl {
        let io = |source| MonitoringError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut w = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
        for r in &kept {
            writeln!(w, "{}", r.to_json_line()).map_err(io)?;
        }
        w.flush().map_err(io)?;
    }
    Ok(Resume { kept, todo, torn })
}

/// Run `files` in parallel (each file's searches share rayon's pool). With `jsonl`, resume:
/// keep the rows there whose file (full path, content hash) is among `files` and whose
/// options are `opts`, rewrite the file with them (dropping torn lines and stale rows), and
/// append each new file's rows as soon as it is done. `labels` fills each new row's label.
/// `progress` receives `(files done, files to do)` from the worker threads.
///
/// Errors only for the JSONL (it cannot be read or written) and invalid options; a file that
/// fails is its row's error.
pub fn run(
    files: &[PathBuf],
    opts: &BatchOptions,
    labels: Option<&Labels>,
    jsonl: Option<&Path>,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> Result<BatchRun, MonitoringError> {
    let combinations = opts.combinations()?;
    let _lock = jsonl.map(lock_output).transpose()?;
    let Resume {
        kept: previous,
        todo,
        torn,
    } = resume(files, opts, jsonl)?;
    let todo: Vec<&PathBuf> = todo.iter().collect();
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| MonitoringError::Io { path, source }
    };
    let writer = match jsonl {
        Some(path) => {
            let file = std::fs::OpenOptions::new()
                .append(true)
                .open(path)
                .map_err(io(path))?;
            Some((Mutex::new(std::io::BufWriter::new(file)), path))
        }
        None => None,
    };
    let count = AtomicUsize::new(0);
    let results: Vec<Result<Vec<Row>, MonitoringError>> = todo
        .par_iter()
        .map(|f| {
            let mut rows = run_planned(f, opts, &combinations);
            if let Some(labels) = labels {
                for r in &mut rows {
                    r.label = labels.get(&r.file);
                }
            }
            if let Some((w, path)) = &writer {
                let mut w = w.lock().map_err(|_| MonitoringError::Io {
                    path: path.to_path_buf(),
                    source: std::io::Error::other("output lock poisoned"),
                })?;
                for r in &rows {
                    writeln!(w, "{}", r.to_json_line()).map_err(io(path))?;
                }
                w.flush().map_err(io(path))?;
            }
            let k = count.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(p) = progress {
                p(k, todo.len());
            }
            Ok(rows)
        })
        .collect();
    let skipped = files.len() - todo.len();
    let mut rows = previous;
    for r in results {
        rows.extend(r?);
    }
    rows.sort_by(|a, b| (&a.file, a.combination()).cmp(&(&b.file, b.combination())));
    Ok(BatchRun {
        rows,
        computed: todo.len(),
        skipped,
        torn,
    })
}

/// Write `rows` as `OUT.csv` ([`CSV_COLUMNS`]).
pub fn write_csv(path: &Path, rows: &[Row]) -> Result<(), MonitoringError> {
    let csv_err = |source| MonitoringError::Csv {
        path: path.to_path_buf(),
        source,
    };
    let mut w = csv::Writer::from_path(path).map_err(csv_err)?;
    w.write_record(CSV_COLUMNS).map_err(csv_err)?;
    for r in rows {
        w.write_record(r.csv_record()).map_err(csv_err)?;
    }
    w.flush().map_err(|source| MonitoringError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// How well S separates the labels, over the `ok` rows of one combination.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LabelSummary {
    /// Labelled `ok` rows.
    pub rows: usize,
    /// Of which labelled `stiction`.
    pub stiction: usize,
    /// ROC of S (`None` without rows of both labels).
    pub roc: Option<Roc>,
}

/// The ROC of S against the labels over the `ok` rows of `stiction` × `linear`.
pub fn label_summary(rows: &[Row], stiction: &str, linear: &str) -> LabelSummary {
    summary(rows, stiction, linear, |ok, _| Some(ok.s))
}

/// The ROC of the detector's score against the labels over the same rows as
/// [`label_summary`] (the labelled `ok` rows of `stiction` × `linear` with a finite S), less
/// those without a score (the detector could not run, or the row predates it): `rows` says
/// how many were scored.
pub fn detect_label_summary(rows: &[Row], stiction: &str, linear: &str) -> LabelSummary {
    summary(rows, stiction, linear, |_, r| r.detect_score)
}

fn summary(
    rows: &[Row],
    stiction: &str,
    linear: &str,
    score: impl Fn(&OkRow, &Row) -> Option<f64>,
) -> LabelSummary {
    let scores: Vec<(f64, bool)> = rows
        .iter()
        .filter_map(|r| {
            let ok = r.ok()?;
            if !(ok.stiction_model == stiction && ok.linear_model == linear && ok.s.is_finite()) {
                return None;
            }
            let x = score(ok, r).filter(|x| x.is_finite())?;
            Some((x, r.label? == Label::Stiction))
        })
        .collect();
    LabelSummary {
        rows: scores.len(),
        stiction: scores.iter().filter(|x| x.1).count(),
        roc: roc(&scores),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_paths_and_the_torn_lines_note() {
        let (jsonl, csv) = out_paths(Path::new("runs/plant.v2"));
        assert_eq!(jsonl, Path::new("runs/plant.v2.jsonl"));
        assert_eq!(csv, Path::new("runs/plant.v2.csv"));
        let mut run = BatchRun {
            rows: Vec::new(),
            computed: 0,
            skipped: 0,
            torn: Vec::new(),
        };
        assert_eq!(run.torn_note(), None);
        run.torn = vec![7];
        assert_eq!(
            run.torn_note().as_deref(),
            Some("line 7 is torn (an interrupted run): its registration is computed again")
        );
        run.torn = vec![3, 9];
        assert!(run
            .torn_note()
            .is_some_and(|n| n.starts_with("2 unreadable lines (first: line 3)")));
    }
}
