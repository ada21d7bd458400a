//! A control loop's analysis as typed values, in one place: the stiction × linear
//! [`Combination`] and its [`Fitted`] result with its serialisable [`QuantifyRecord`]; the
//! [`Settings`] a run shares between its combinations; registrations read and searched with
//! the evidence behind a doubtful estimate ([`registration`]); the batch over many loops, its
//! rows and labels ([`batch`]); the trend of a valve over repeated registrations with its
//! maintenance verdict ([`trend`](mod@trend)); the detection crate's verdict on each record read
//! ([`detect`]); ROC and robust statistics ([`stats`]).
//!
//! The CLI parses arguments, calls this crate and prints; `discrepancy` extends the
//! combinations it runs; `xtask reproduce` runs the paper's study through them. This crate
//! never prints; its only IO is reading registrations and labels and writing a batch's rows.

pub mod batch;
mod combination;
mod consensus;
pub mod detect;
pub mod identify;
mod record;
pub mod registration;
mod settings;
pub mod stats;
pub mod trend;

use std::path::PathBuf;

pub use combination::{
    build_identifier, paper_example, problem, span_of, Combination, Delay, FitSummary, Fitted,
    MAX_AUTO_DELAY,
};
pub use consensus::{Consensus, Disagreement};
pub use detect::{
    detect_decided, detect_document, detect_file, detect_loop, sample_time, DetectError, Detected,
    DetectionRecord,
};
pub use record::{
    models_record, on_grid, CompareError, CompareRecord, DelayScore, GridRecord, IntervalRecord,
    OtherFit, QuantifyRecord,
};
pub use registration::{
    Evidence, ExplainFit, FitEvidence, Integrating, KindDecision, KindSource, Registration,
    RegistrationError, TimeSource,
};
pub use settings::{identifier_for, parse_orders, DelayArg, Orders, SearchArgs, Settings};
pub use stats::{median, roc, theil_sen, Roc};
pub use trend::{maintenance, trend, with_detection, Flag, Maintenance, Point, Trend};

/// Errors of the workflow.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MonitoringError {
    /// A stiction model name or parameter was rejected.
    #[error(transparent)]
    Stiction(#[from] stiction_models::StictionError),
    /// An identifier name or order was rejected, or the identification failed.
    #[error(transparent)]
    Identification(#[from] linear_id::IdError),
    /// The search failed.
    #[error(transparent)]
    Search(#[from] grid_search::SearchError),
    /// The data were refused.
    #[error(transparent)]
    Data(#[from] datasets::DataError),
    /// More positional orders than the identifier has.
    #[error("{identifier} takes at most {} positional orders ({})", .positional.len(), .positional.join(", "))]
    TooManyOrders {
        /// The identifier.
        identifier: &'static str,
        /// Its orders without the dead time.
        positional: Vec<&'static str>,
    },
    /// A file or directory that is not there.
    #[error("{}: no such file or directory", .0.display())]
    NoSuchPath(PathBuf),
    /// A file or directory could not be read or written.
    #[error("{}: {source}", .path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// What failed.
        source: std::io::Error,
    },
    /// Another run holds the output's lock.
    #[error("{}: another batch run is writing this output (its lock {}.lock is held): wait for it to end or give another -o", .path.display(), .path.display())]
    OutputBusy {
        /// The JSONL output.
        path: PathBuf,
    },
    /// A file could not be created.
    #[error("cannot create {}", .path.display())]
    Create {
        /// The file.
        path: PathBuf,
        /// What failed.
        source: std::io::Error,
    },
    /// A file could not be written to the end.
    #[error("cannot write {}", .path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What failed.
        source: std::io::Error,
    },
    /// A CSV file could not be read or written.
    #[error("{}: {source}", .path.display())]
    Csv {
        /// The path.
        path: PathBuf,
        /// What failed.
        source: csv::Error,
    },
    /// A table lacks a column.
    #[error("{}: no column {column} in the header", .path.display())]
    NoColumn {
        /// The table.
        path: PathBuf,
        /// The column.
        column: &'static str,
    },
    /// A search setting that cannot work (the message is the whole sentence, naming the CLI's
    /// flag).
    #[error("{message}")]
    Setting {
        /// The CLI flag, e.g. `--orders`.
        flag: &'static str,
        /// The sentence.
        message: String,
    },
    /// A trend was asked for a valve with no registration among the files.
    #[error("no registration of valve {valve} (found: {})", .found.join(", "))]
    NoRegistration {
        /// The valve asked for.
        valve: String,
        /// The valves found.
        found: Vec<String>,
    },
    /// A trend over no registration file at all.
    #[error("no registration files found")]
    NoFiles,
    /// A trend follows one valve, and the files hold several: one must be chosen.
    #[error("trend follows one valve; the files hold {}: choose one with --valve", .0.join(", "))]
    SeveralValves(
        /// Each valve with its number of registrations, `TAG (n)`.
        Vec<String>,
    ),
    /// A label that is neither `stiction` nor `no-stiction`.
    #[error("{}: row {row}, column label: {value:?} is not stiction / no-stiction", .path.display())]
    BadLabel {
        /// The labels file.
        path: PathBuf,
        /// The row (1 = header).
        row: usize,
        /// The value.
        value: String,
    },
}

/// An error and its causes on one line, joined with `": "`, leaving out a cause whose text the
/// line already says.
pub fn error_line(e: &(dyn std::error::Error + 'static)) -> String {
    let mut msg = String::new();
    let mut next = Some(e);
    while let Some(cause) = next {
        let text = cause.to_string().replace('\n', " ");
        if !(text.is_empty() || msg.contains(&text)) {
            if !msg.is_empty() {
                msg.push_str(": ");
            }
            msg.push_str(&text);
        }
        next = cause.source();
    }
    msg
}
