//! A results history in SQLite: every registration × combination a batch computed, kept in one
//! embedded database file (no server), appended once, read back per valve.
//!
//! `stiction audit DIR --db audit.sqlite` runs the batch of `monitoring::batch` over the
//! registrations not yet in the database and appends their rows; the Python package's
//! `fleet.run(..., db=...)` appends the rows its workers send through [`Store::append`]; the
//! fleet page reads [`Store::valves`].
//!
//! # Invariants
//!
//! * A registration is its content: `content_hash` is the SHA-256 (hex) of the file's bytes
//!   ([`content_hash`]), so a renamed or moved copy is the same registration and an edited
//!   file is a new one. A file whose bytes cannot be read is hashed from its path instead.
//! * One row per registration × combination: `SELECT count(*) FROM results` is the number of
//!   registrations times the number of combinations of each run's settings. A file the reader
//!   refuses gets one error row per combination (the batch gives it a single row; [`Store::append`]
//!   spreads it over the combinations named by the row's settings).
//! * Rows are never duplicated: the key `(content_hash, valve, start_time, settings,
//!   stiction_model, linear_model)` is UNIQUE and every write is `INSERT OR IGNORE`, so a
//!   resumed run, or two runs at once on the same database, add each row once.
//! * Each registration's rows are written in one `BEGIN IMMEDIATE` transaction: a reader never
//!   sees half a registration, and an interrupted run leaves whole registrations only, so
//!   [`Store::has`] (all of a file's rows are there) is what resuming needs.
//! * Concurrency: WAL journal (readers do not block the writer) and a busy timeout of
//!   [`BUSY_TIMEOUT`] (a second writer waits for the first's transaction). Within a run the
//!   rayon workers share one connection behind a mutex (one writer per process); other
//!   processes open their own.
//! * This is the only crate that touches SQLite.
//!
//! # Schema
//!
//! `PRAGMA application_id` is [`APPLICATION_ID`] (marks the file as a stiction audit database)
//! and `PRAGMA user_version` the schema version ([`SCHEMA_VERSION`]). [`Store::open`] applies
//! the missing migrations of [`MIGRATIONS`] in one transaction; a database of a newer version
//! is refused ([`AuditError::NewerSchema`]), and so is an SQLite file of another application.
//!
//! Version 1, one table `results` (one row per registration × combination):
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `content_hash` | TEXT | SHA-256 (hex) of the file's bytes |
//! | `valve` | TEXT | the valve (file-name prefix before `_`) |
//! | `start_time` | TEXT | the record's start, `YYYY-MM-DD HH:MM` UTC; `''` when unknown |
//! | `file`, `path` | TEXT | base name, and the path as given |
//! | `settings` | TEXT | the run's options (`BatchOptions::fingerprint`, JSON) |
//! | `stiction_model`, `linear_model` | TEXT | the combination |
//! | `status` | TEXT | `ok` or `error` |
//! | `S`, `S_lo`, `S_hi`, `J`, `J_lo`, `J_hi` | REAL | the estimate and its ranges, % of span |
//! | `fit_pv_val`, `fit_no_stiction` | REAL | validation F_PV (%) and the best with no stiction |
//! | `integrating` | INTEGER | 1 when identified from MV to ΔPV |
//! | `label` | TEXT | `stiction` / `no-stiction` when labels were given |
//! | `detect_score`, `detect_verdict` | REAL, TEXT | the detector's answer on the record |
//! | `why`, `notes` | TEXT | JSON arrays of sentences: evidence against the fit, the reader's notes |
//! | `error` | TEXT | the one-line error of an `error` row |
//! | `reduction`, `error_std_now`, `error_std_repaired`, `reversals_per_hour_now`, `reversals_per_hour_repaired` | REAL | what a repair would buy (`repair` object) |
//! | `repair_reason` | TEXT | why there is no repair estimate |
//! | `repair`, `quantify` | TEXT | JSON of the repair object and of the quantify record |
//! | `audited_at` | TEXT | when the row was written, `YYYY-MM-DDTHH:MM:SSZ` UTC |
//!
//! Numbers that could not be computed are NULL. Indexes on `valve` and `start_time`.
//!
//! Version 2 adds the registration's one answer (`monitoring::batch::OkRow`): `S`, `S_lo`,
//! `S_hi` are the S that explains the detector's verdict and its range (both fits' 95 %
//! regions), `S_from` (TEXT: `one-step` or `output-error`) the fit it comes from, `S_unit`
//! (TEXT: `% of valve span` or `% of the OP range seen`), `S_one_step`, `S_one_step_lo`,
//! `S_one_step_hi` (REAL) the combination's one-step-prediction fit, and `detect_reason`
//! (TEXT) the detector's reason. The migration marks the rows of version 1 as what they are:
//! `S_from` `one-step` and `S_one_step*` copied from `S*` (their `S_unit` and `detect_reason`
//! NULL); they are kept, not computed again.
//!
//! ```no_run
//! use std::path::{Path, PathBuf};
//! use monitoring::batch::BatchOptions;
//!
//! let files = vec![PathBuf::from("plant/2411FIC20102_20240301-0800.csv")];
//! let run = audit::run(&files, &BatchOptions::default(), None, Path::new("audit.sqlite"), None)?;
//! println!("{} computed, {} rows added", run.computed, run.rows_inserted);
//! for valve in audit::Store::open(Path::new("audit.sqlite"))?.valves()? {
//!     for r in &valve.registrations {
//!         println!("{} {}: S = {:?}", valve.valve, r.start_time, r.s);
//!     }
//! }
//! # Ok::<(), audit::AuditError>(())
//! ```

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Duration;

use monitoring::batch::{BatchOptions, Labels, Row, Status};
use monitoring::MonitoringError;
use rayon::prelude::*;
use rusqlite::{params, Connection, OptionalExtension, TransactionBehavior};
use sha2::{Digest, Sha256};

/// `PRAGMA application_id` of an audit database ("STIC").
pub const APPLICATION_ID: i64 = 0x5354_4943;

/// How long a writer waits for another's transaction before giving up.
pub const BUSY_TIMEOUT: Duration = Duration::from_secs(60);

/// The schema's migrations: `MIGRATIONS[k]` takes a database from version `k` to `k + 1`.
pub const MIGRATIONS: &[&str] = &[
    // 1: the results table.
    "CREATE TABLE results (
        content_hash TEXT NOT NULL,
        valve TEXT NOT NULL,
        start_time TEXT NOT NULL,
        file TEXT NOT NULL,
        path TEXT NOT NULL,
        settings TEXT NOT NULL,
        stiction_model TEXT NOT NULL,
        linear_model TEXT NOT NULL,
        status TEXT NOT NULL CHECK (status IN ('ok', 'error')),
        S REAL, S_lo REAL, S_hi REAL,
        J REAL, J_lo REAL, J_hi REAL,
        fit_pv_val REAL,
        fit_no_stiction REAL,
        integrating INTEGER NOT NULL,
        label TEXT,
        detect_score REAL,
        detect_verdict TEXT NOT NULL,
        why TEXT NOT NULL,
        notes TEXT NOT NULL,
        error TEXT,
        reduction REAL,
        error_std_now REAL,
        error_std_repaired REAL,
        reversals_per_hour_now REAL,
        reversals_per_hour_repaired REAL,
        repair_reason TEXT,
        repair TEXT,
        quantify TEXT,
        audited_at TEXT NOT NULL,
        UNIQUE (content_hash, valve, start_time, settings, stiction_model, linear_model)
    );
    CREATE INDEX results_valve ON results (valve);
    CREATE INDEX results_start_time ON results (start_time);",
    // 2: the registration's one answer. `S`, `S_lo`, `S_hi` become the S that explains the
    // detector's verdict; the combination's one-step S moves beside it. Rows of version 1 hold
    // the one-step S: they say so.
    "ALTER TABLE results ADD COLUMN S_from TEXT;
    ALTER TABLE results ADD COLUMN S_unit TEXT;
    ALTER TABLE results ADD COLUMN S_one_step REAL;
    ALTER TABLE results ADD COLUMN S_one_step_lo REAL;
    ALTER TABLE results ADD COLUMN S_one_step_hi REAL;
    ALTER TABLE results ADD COLUMN detect_reason TEXT;
    UPDATE results SET S_from = 'one-step', S_one_step = S, S_one_step_lo = S_lo,
        S_one_step_hi = S_hi WHERE status = 'ok';",
];

/// The schema version this code writes and reads.
pub const SCHEMA_VERSION: i64 = MIGRATIONS.len() as i64;

/// What went wrong with the database or the run's options.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AuditError {
    /// SQLite refused an operation on the database at `path`.
    #[error("{}: {source}", .path.display())]
    Sqlite {
        /// The database.
        path: PathBuf,
        /// SQLite's error.
        source: rusqlite::Error,
    },
    /// The database was written by a newer version of this program.
    #[error(
        "{}: audit database schema version {found} is newer than this program's ({known}): use a newer stiction",
        .path.display()
    )]
    NewerSchema {
        /// The database.
        path: PathBuf,
        /// Its `user_version`.
        found: i64,
        /// [`SCHEMA_VERSION`].
        known: i64,
    },
    /// The file is not a stiction audit database.
    #[error("{}: not a stiction audit database ({why})", .path.display())]
    NotAudit {
        /// The file.
        path: PathBuf,
        /// What it is instead.
        why: String,
    },
    /// The run's options or files.
    #[error(transparent)]
    Monitoring(#[from] MonitoringError),
    /// A worker panicked while holding the database.
    #[error("{}: the database connection was poisoned by a failed worker", .path.display())]
    Poisoned {
        /// The database.
        path: PathBuf,
    },
}

/// SHA-256 (lower-case hex) of the file's bytes; of `unreadable:` and the path when the bytes
/// cannot be read (its rows are then the reader's error).
pub fn content_hash(path: &Path) -> String {
    let digest = match std::fs::read(path) {
        Ok(bytes) => Sha256::digest(&bytes),
        Err(_) => Sha256::digest(format!("unreadable:{}", path.display()).as_bytes()),
    };
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// An open audit database.
#[derive(Debug)]
pub struct Store {
    conn: Connection,
    path: PathBuf,
}

impl Store {
    /// Open (or create) the database at `path`: WAL journal, busy timeout, schema migrated to
    /// [`SCHEMA_VERSION`] in one transaction. Refuses a newer schema and a file that is not a
    /// stiction audit database (another application's SQLite file, or not SQLite at all).
    pub fn open(path: &Path) -> Result<Store, AuditError> {
        let err = sql_err(path);
        let mut conn = Connection::open(path).map_err(err)?;
        conn.busy_timeout(BUSY_TIMEOUT).map_err(err)?;
        // Check before writing anything: an unrelated file is left as it is. One read
        // transaction, so that the checks see one state of a file another process may be
        // creating.
        let read = conn.transaction().map_err(err)?;
        check(&read, path)?;
        read.commit().map_err(err)?;
        let mode: String = conn
            .query_row("PRAGMA journal_mode = WAL", [], |r| r.get(0))
            .map_err(err)?;
        if !mode.eq_ignore_ascii_case("wal") {
            return Err(AuditError::NotAudit {
                path: path.to_path_buf(),
                why: format!("journal mode {mode}, WAL refused"),
            });
        }
        let tx = conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(err)?;
        // Again under the write lock: another process may have migrated it meanwhile.
        let version = check(&tx, path)?;
        for (k, sql) in MIGRATIONS.iter().enumerate().skip(version as usize) {
            tx.execute_batch(sql).map_err(err)?;
            tx.pragma_update(None, "user_version", k as i64 + 1)
                .map_err(err)?;
        }
        tx.pragma_update(None, "application_id", APPLICATION_ID)
            .map_err(err)?;
        tx.commit().map_err(err)?;
        Ok(Store {
            conn,
            path: path.to_path_buf(),
        })
    }

    /// The database's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Append one registration's rows (from `monitoring::batch::run_file`) in one
    /// `BEGIN IMMEDIATE` transaction; returns how many were new (`INSERT OR IGNORE`: a row
    /// already there under the unique key is left as it is). An error row without a
    /// combination (the file could not be read) becomes one row per combination of its
    /// settings.
    pub fn append(&mut self, rows: &[Row], content_hash: &str) -> Result<usize, AuditError> {
        let err = sql_err(&self.path);
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(err)?;
        let mut inserted = 0;
        {
            let mut stmt = tx.prepare_cached(INSERT).map_err(err)?;
            for row in rows {
                for (stiction, linear) in combinations_of(row) {
                    let c = Cells::of(row, content_hash, stiction, linear);
                    inserted += stmt
                        .execute(params![
                            c.content_hash,
                            c.valve,
                            c.start_time,
                            c.file,
                            c.path,
                            c.settings,
                            c.stiction_model,
                            c.linear_model,
                            c.status,
                            c.s,
                            c.s_lo,
                            c.s_hi,
                            c.j,
                            c.j_lo,
                            c.j_hi,
                            c.fit_pv_val,
                            c.fit_no_stiction,
                            c.integrating,
                            c.label,
                            c.detect_score,
                            c.detect_verdict,
                            c.why,
                            c.notes,
                            c.error,
                            c.reduction,
                            c.error_std_now,
                            c.error_std_repaired,
                            c.reversals_per_hour_now,
                            c.reversals_per_hour_repaired,
                            c.repair_reason,
                            c.repair,
                            c.quantify,
                            c.s_from,
                            c.s_unit,
                            c.s_one_step,
                            c.s_one_step_lo,
                            c.s_one_step_hi,
                            c.detect_reason,
                        ])
                        .map_err(err)?;
                }
            }
        }
        tx.commit().map_err(err)?;
        Ok(inserted)
    }

    /// Whether the registration `content_hash` already has its `n_combinations` rows for
    /// `settings` (a resumed run does not compute it again).
    pub fn has(
        &self,
        content_hash: &str,
        settings: &str,
        n_combinations: usize,
    ) -> Result<bool, AuditError> {
        let n: i64 = self
            .conn
            .query_row(
                "SELECT count(*) FROM results WHERE content_hash = ?1 AND settings = ?2",
                params![content_hash, settings],
                |r| r.get(0),
            )
            .map_err(sql_err(&self.path))?;
        Ok(n >= n_combinations as i64)
    }

    /// Rows in the database.
    pub fn count(&self) -> Result<usize, AuditError> {
        let n: i64 = self
            .conn
            .query_row("SELECT count(*) FROM results", [], |r| r.get(0))
            .map_err(sql_err(&self.path))?;
        Ok(n as usize)
    }

    /// The history of every valve (sorted by name), each registration once, in time: see
    /// [`ValveHistory`] and [`RegistrationSummary`] for what is chosen.
    pub fn valves(&self) -> Result<Vec<ValveHistory>, AuditError> {
        let err = sql_err(&self.path);
        let mut stmt = self
            .conn
            .prepare(
                "SELECT valve, start_time, content_hash, file, path, stiction_model,
                        linear_model, status, S, S_lo, S_hi, fit_pv_val, detect_verdict,
                        detect_score, reduction, why, error, repair_reason, S_from, S_unit,
                        detect_reason
                 FROM results
                 ORDER BY valve, start_time = '', start_time, file, content_hash,
                          stiction_model, linear_model, settings",
            )
            .map_err(err)?;
        let rows = stmt
            .query_map([], |r| {
                Ok((
                    r.get::<_, String>(0)?,
                    RegistrationSummary {
                        start_time: r.get(1)?,
                        content_hash: r.get(2)?,
                        file: r.get(3)?,
                        path: r.get(4)?,
                        stiction_model: r.get(5)?,
                        linear_model: r.get(6)?,
                        ok: r.get::<_, String>(7)? == "ok",
                        s: r.get(8)?,
                        s_range: match (r.get::<_, Option<f64>>(9)?, r.get(10)?) {
                            (Some(lo), Some(hi)) => Some([lo, hi]),
                            _ => None,
                        },
                        fit_pv_val: r.get(11)?,
                        detect_verdict: r.get(12)?,
                        detect_score: r.get(13)?,
                        reduction: r.get(14)?,
                        causes: serde_json::from_str(&r.get::<_, String>(15)?).unwrap_or_default(),
                        error: r.get(16)?,
                        repair_reason: r.get(17)?,
                        s_from: r.get(18)?,
                        s_unit: r.get(19)?,
                        detect_reason: r.get(20)?,
                        combinations: 1,
                    },
                ))
            })
            .map_err(err)?;
        let mut out: Vec<ValveHistory> = Vec::new();
        for row in rows {
            let (valve, reg) = row.map_err(err)?;
            let same_valve = out.last().is_some_and(|v| v.valve == valve);
            if !same_valve {
                out.push(ValveHistory {
                    valve,
                    registrations: Vec::new(),
                });
            }
            let Some(history) = out.last_mut() else {
                continue;
            };
            match history.registrations.last_mut() {
                Some(last)
                    if last.content_hash == reg.content_hash
                        && last.start_time == reg.start_time =>
                {
                    let combinations = last.combinations + 1;
                    if better(&reg, last) {
                        *last = reg;
                    }
                    last.combinations = combinations;
                }
                _ => history.registrations.push(reg),
            }
        }
        Ok(out)
    }
}

/// Whether `a` is a better choice than `b` for a registration's summary: an ok row with a
/// finite fit beats any other, a higher fit beats a lower one, ties keep the first.
fn better(a: &RegistrationSummary, b: &RegistrationSummary) -> bool {
    let fit = |r: &RegistrationSummary| {
        r.fit_pv_val
            .filter(|f| r.ok && f.is_finite())
            .unwrap_or(f64::NEG_INFINITY)
    };
    (a.ok && !b.ok) || (a.ok == b.ok && fit(a) > fit(b))
}

/// One valve's registrations in the database, ordered by start time (unknown times last, then
/// by file name).
#[derive(Debug, Clone, PartialEq)]
pub struct ValveHistory {
    /// The valve.
    pub valve: String,
    /// Its registrations, one entry each (whatever the combinations and settings).
    pub registrations: Vec<RegistrationSummary>,
}

/// One registration of a valve, as the fleet page shows it: the row of the combination with the
/// best validation fit among its `ok` rows (over every combination and settings stored for it),
/// or its first row when none is `ok`.
#[derive(Debug, Clone, PartialEq)]
pub struct RegistrationSummary {
    /// Start, `YYYY-MM-DD HH:MM` UTC (`''` when unknown).
    pub start_time: String,
    /// Base name of the file.
    pub file: String,
    /// Path as given when it was audited.
    pub path: String,
    /// SHA-256 of its bytes.
    pub content_hash: String,
    /// The chosen combination's stiction model (`''` for an error row of an unread file
    /// written without settings).
    pub stiction_model: String,
    /// Its linear identifier.
    pub linear_model: String,
    /// Whether the chosen row has an estimate.
    pub ok: bool,
    /// S reported: the S that explains the detector's verdict (from schema version 2; a
    /// version-1 row's one-step S), in `s_unit`.
    pub s: Option<f64>,
    /// Its range (both fits' 95 % regions; a version-1 row's likelihood-ratio region).
    pub s_range: Option<[f64; 2]>,
    /// Which fit S comes from: `one-step` or `output-error` (`None` for an `error` row).
    pub s_from: Option<String>,
    /// The unit of S: `% of valve span`, or `% of the OP range seen` when OP's valve span is
    /// unknown (`None` in a version-1 row).
    pub s_unit: Option<String>,
    /// Validation F_PV, %.
    pub fit_pv_val: Option<f64>,
    /// The detector's verdict (`''` when the file could not be read).
    pub detect_verdict: String,
    /// The detector's score.
    pub detect_score: Option<f64>,
    /// The detector's reason, one sentence (`None` when the file could not be read, or in a
    /// version-1 row).
    pub detect_reason: Option<String>,
    /// What a repair would buy: the fraction of the control error's spread removed.
    pub reduction: Option<f64>,
    /// Evidence that something besides the valve moves PV (the `why` sentences).
    pub causes: Vec<String>,
    /// The one-line error of an `error` row.
    pub error: Option<String>,
    /// Why `reduction` is `None` (the repair estimate's reason).
    pub repair_reason: Option<String>,
    /// How many rows (combinations × settings) the registration has.
    pub combinations: usize,
}

/// What [`run`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AuditRun {
    /// Distinct registration files given.
    pub files: usize,
    /// Paths given more than once (same canonical path), counted once.
    pub duplicates: usize,
    /// Files computed now.
    pub computed: usize,
    /// Files whose rows were all in the database already.
    pub skipped: usize,
    /// Rows this run added.
    pub rows_inserted: usize,
    /// Rows in the database at the end.
    pub total_rows: usize,
}

impl AuditRun {
    /// The run in one line, as `stiction audit` prints it: `audit: 49 registration(s): 49
    /// computed, 0 already in audit.sqlite; 49 row(s) added, 49 in the database`.
    pub fn summary(&self, db: &Path) -> String {
        let name = db.file_name().map_or_else(
            || db.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        let mut line = format!(
            "audit: {} registration(s): {} computed, {} already in {name}; {} row(s) added, {} in the database",
            self.files, self.computed, self.skipped, self.rows_inserted, self.total_rows
        );
        if self.duplicates > 0 {
            line.push_str(&format!(
                " ({} path(s) given twice, counted once)",
                self.duplicates
            ));
        }
        line
    }
}

/// Audit `files` (as `monitoring::registration::expand` lists them) into the database `db`:
/// hash each file, skip those whose rows for `opts` are all there, run the others in parallel
/// (rayon, `monitoring::batch::run_file`) and append each file's rows as soon as it is done,
/// one transaction per registration. The workers share this process's one connection (one
/// writer). `labels` fills each row's label; `progress` gets `(files done, files to do)`.
///
/// Errors for invalid options and for the database; a file that fails is its rows' error.
pub fn run(
    files: &[PathBuf],
    opts: &BatchOptions,
    labels: Option<&Labels>,
    db: &Path,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> Result<AuditRun, AuditError> {
    let n_combinations = distinct_pairs(opts)?;
    let (files, duplicates) = distinct_files(files);
    let store = Store::open(db)?;
    let settings = opts.fingerprint();
    let hashes: Vec<String> = files.par_iter().map(|f| content_hash(f)).collect();
    let mut todo = Vec::new();
    for (f, h) in files.iter().zip(hashes) {
        if !store.has(&h, &settings, n_combinations)? {
            todo.push((f, h));
        }
    }
    let store = Mutex::new(store);
    let done = AtomicUsize::new(0);
    let poisoned = || AuditError::Poisoned {
        path: db.to_path_buf(),
    };
    let inserted: Vec<usize> = todo
        .par_iter()
        .map(|(f, h)| {
            let mut rows = monitoring::batch::run_file(f, opts);
            if let Some(labels) = labels {
                for r in &mut rows {
                    r.label = labels.get(&r.file);
                }
            }
            let n = store.lock().map_err(|_| poisoned())?.append(&rows, h)?;
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(p) = progress {
                p(k, todo.len());
            }
            Ok(n)
        })
        .collect::<Result<_, AuditError>>()?;
    let store = store.into_inner().map_err(|_| poisoned())?;
    Ok(AuditRun {
        files: files.len(),
        duplicates,
        computed: todo.len(),
        skipped: files.len() - todo.len(),
        rows_inserted: inserted.iter().sum(),
        total_rows: store.count()?,
    })
}

/// The number of distinct stiction × linear pairs of `opts` (checked).
fn distinct_pairs(opts: &BatchOptions) -> Result<usize, AuditError> {
    opts.combinations()?;
    let pairs: HashSet<(&str, &str)> = opts
        .stiction
        .iter()
        .flat_map(|s| opts.linear.iter().map(move |l| (s.as_str(), l.as_str())))
        .collect();
    Ok(pairs.len())
}

/// `files` without repeats of the same canonical path (first occurrence kept), and how many
/// were left out.
fn distinct_files(files: &[PathBuf]) -> (Vec<PathBuf>, usize) {
    let mut seen = HashSet::new();
    let kept: Vec<PathBuf> = files
        .iter()
        .filter(|f| seen.insert(f.canonicalize().unwrap_or_else(|_| (*f).clone())))
        .cloned()
        .collect();
    let left = files.len() - kept.len();
    (kept, left)
}

/// The combinations a row stands for: its own, or for an error row without one (the file
/// could not be read) every pair of its settings (`BatchOptions` JSON).
fn combinations_of(row: &Row) -> Vec<(String, String)> {
    let (s, l) = row.combination();
    if !(s.is_empty() && l.is_empty()) {
        return vec![(s.to_string(), l.to_string())];
    }
    match serde_json::from_str::<BatchOptions>(&row.settings) {
        Ok(o) if !o.stiction.is_empty() && !o.linear.is_empty() => o
            .stiction
            .iter()
            .flat_map(|s| o.linear.iter().map(move |l| (s.clone(), l.clone())))
            .collect(),
        _ => vec![(String::new(), String::new())],
    }
}

/// Checks that the open file is ours (or empty) and not newer; its schema version.
fn check(conn: &Connection, path: &Path) -> Result<i64, AuditError> {
    let not_audit = |why: &str| AuditError::NotAudit {
        path: path.to_path_buf(),
        why: why.to_string(),
    };
    let pragma = |name: &str| -> Result<i64, AuditError> {
        conn.query_row(&format!("PRAGMA {name}"), [], |r| r.get(0))
            .map_err(|e| match e.sqlite_error_code() {
                Some(rusqlite::ErrorCode::NotADatabase) => not_audit("not an SQLite file"),
                _ => sql_err(path)(e),
            })
    };
    let app = pragma("application_id")?;
    let version = pragma("user_version")?;
    if app != 0 && app != APPLICATION_ID {
        return Err(not_audit(&format!("application id {app:#x}")));
    }
    if version > SCHEMA_VERSION {
        return Err(AuditError::NewerSchema {
            path: path.to_path_buf(),
            found: version,
            known: SCHEMA_VERSION,
        });
    }
    if app == 0 {
        let table: Option<String> = conn
            .query_row(
                "SELECT name FROM sqlite_master WHERE type = 'table' LIMIT 1",
                [],
                |r| r.get(0),
            )
            .optional()
            .map_err(sql_err(path))?;
        if let Some(t) = table {
            return Err(not_audit(&format!("it has a table {t:?} of its own")));
        }
    }
    Ok(version)
}

fn sql_err(path: &Path) -> impl Fn(rusqlite::Error) -> AuditError + Copy + '_ {
    move |source| AuditError::Sqlite {
        path: path.to_path_buf(),
        source,
    }
}

const INSERT: &str = "INSERT OR IGNORE INTO results (
    content_hash, valve, start_time, file, path, settings, stiction_model, linear_model,
    status, S, S_lo, S_hi, J, J_lo, J_hi, fit_pv_val, fit_no_stiction, integrating, label,
    detect_score, detect_verdict, why, notes, error, reduction, error_std_now,
    error_std_repaired, reversals_per_hour_now, reversals_per_hour_repaired, repair_reason,
    repair, quantify, S_from, S_unit, S_one_step, S_one_step_lo, S_one_step_hi, detect_reason,
    audited_at
) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19,
    ?20, ?21, ?22, ?23, ?24, ?25, ?26, ?27, ?28, ?29, ?30, ?31, ?32, ?33, ?34, ?35, ?36, ?37,
    ?38, strftime('%Y-%m-%dT%H:%M:%SZ', 'now'))";

/// One row's cells, in the order of [`INSERT`].
struct Cells<'a> {
    content_hash: &'a str,
    valve: &'a str,
    start_time: &'a str,
    file: &'a str,
    path: &'a str,
    settings: &'a str,
    stiction_model: String,
    linear_model: String,
    status: &'static str,
    s: Option<f64>,
    s_lo: Option<f64>,
    s_hi: Option<f64>,
    j: Option<f64>,
    j_lo: Option<f64>,
    j_hi: Option<f64>,
    fit_pv_val: Option<f64>,
    fit_no_stiction: Option<f64>,
    integrating: bool,
    label: Option<String>,
    detect_score: Option<f64>,
    detect_verdict: &'a str,
    why: String,
    notes: String,
    error: Option<&'a str>,
    reduction: Option<f64>,
    error_std_now: Option<f64>,
    error_std_repaired: Option<f64>,
    reversals_per_hour_now: Option<f64>,
    reversals_per_hour_repaired: Option<f64>,
    repair_reason: Option<&'a str>,
    repair: Option<String>,
    quantify: Option<String>,
    s_from: Option<&'static str>,
    s_unit: Option<&'a str>,
    s_one_step: Option<f64>,
    s_one_step_lo: Option<f64>,
    s_one_step_hi: Option<f64>,
    detect_reason: Option<&'a str>,
}

impl<'a> Cells<'a> {
    fn of(row: &'a Row, content_hash: &'a str, stiction: String, linear: String) -> Cells<'a> {
        let ok = row.ok();
        let num = |f: fn(&monitoring::batch::OkRow) -> f64| ok.map(f).filter(|x| x.is_finite());
        let repair = ok.and_then(|o| o.quantify.repair.as_ref());
        let rep = |f: fn(&repair::Repair) -> f64| repair.map(f).filter(|x| x.is_finite());
        let start_time = match row.time.as_deref() {
            Some("?") | None => "",
            Some(t) => t,
        };
        Cells {
            content_hash,
            valve: &row.valve,
            start_time,
            file: &row.file,
            path: &row.path,
            settings: &row.settings,
            stiction_model: stiction,
            linear_model: linear,
            status: if ok.is_some() { "ok" } else { "error" },
            s: num(|o| o.s),
            s_lo: num(|o| o.s_lo),
            s_hi: num(|o| o.s_hi),
            j: num(|o| o.j),
            j_lo: num(|o| o.j_lo),
            j_hi: num(|o| o.j_hi),
            fit_pv_val: num(|o| o.fit_pv_val),
            fit_no_stiction: ok.and_then(|o| o.fit_no_stiction).filter(|x| x.is_finite()),
            integrating: row.integrating,
            label: row
                .label
                .and_then(|l| serde_json::to_value(l).ok())
                .and_then(|v| v.as_str().map(str::to_string)),
            detect_score: row.detect_score.filter(|x| x.is_finite()),
            detect_verdict: &row.detect_verdict,
            why: to_json(ok.map_or(&[][..], |o| &o.why[..])),
            notes: to_json(&row.notes),
            error: match &row.status {
                Status::Error(e) => Some(&e.error),
                Status::Ok(_) => None,
            },
            reduction: rep(|r| r.reduction),
            error_std_now: rep(|r| r.error_std_now),
            error_std_repaired: rep(|r| r.error_std_repaired),
            reversals_per_hour_now: rep(|r| r.reversals_per_hour_now),
            reversals_per_hour_repaired: rep(|r| r.reversals_per_hour_repaired),
            repair_reason: ok.and_then(|o| o.quantify.repair_reason.as_deref()),
            repair: repair.map(to_json),
            quantify: ok.map(|o| to_json(&o.quantify)),
            s_from: ok.and_then(|o| o.s_from).map(|f| match f {
                monitoring::SFrom::OneStep => "one-step",
                monitoring::SFrom::OutputError => "output-error",
            }),
            s_unit: ok.map(|o| o.s_unit.as_str()).filter(|u| !u.is_empty()),
            s_one_step: ok.and_then(|o| o.s_one_step).filter(|x| x.is_finite()),
            s_one_step_lo: ok.and_then(|o| o.s_one_step_lo).filter(|x| x.is_finite()),
            s_one_step_hi: ok.and_then(|o| o.s_one_step_hi).filter(|x| x.is_finite()),
            detect_reason: Some(row.detect_reason.as_str()).filter(|r| !r.is_empty()),
        }
    }
}

/// A value as JSON text for a cell (`null` on the impossible failure).
fn to_json<T: serde::Serialize + ?Sized>(v: &T) -> String {
    serde_json::to_string(v).unwrap_or_else(|_| "null".into())
}
