//! The workflow over files, as typed values: registrations read, searched with every
//! combination of the `run` crate and given the evidence behind a doubtful estimate
//! ([`registration`]); the batch over many loops, its
//! rows and labels ([`batch`]); the trend of a valve over repeated registrations with its
//! maintenance verdict ([`trend`](mod@trend)); which loops are integrating ([`kind`]); the detection crate's verdict on each record read
//! ([`detect`]); one verdict and the S that explains it, the loop kind decided once ([`answer`]);
//! the commands' JSON documents ([`document`]); ROC and robust statistics ([`stats`]).
//!
//! The trend diagnoses its registrations with `discrepancy` on the data it has read. The CLI
//! parses arguments, calls this crate and prints. This crate never prints; its only IO is
//! reading registrations and labels and writing a batch's rows.

pub mod answer;
pub mod batch;
pub mod detect;
pub mod document;
pub mod kind;
pub mod registration;
pub mod stats;
pub mod trend;

use std::path::PathBuf;

pub use answer::{analyse, Analysis, Answer, SFrom};
pub use detect::{
    detect_decided, detect_file, detect_loop, detect_view, DetectError, Detected, DetectionFigures,
    DetectionRecord, DetectionView,
};
pub use kind::{Integrating, KindDecision, KindSource};
pub use registration::{
    Evidence, ExplainFit, FitEvidence, Registration, RegistrationError, TimeSource,
};
pub use stats::{median, roc, theil_sen, Roc};
pub use trend::{maintenance, trend, with_detection, Flag, Maintenance, Point, Trend};

/// Errors of the workflow.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MonitoringError {
    /// A combination's run failed, or its settings were refused.
    #[error(transparent)]
    Run(#[from] run::RunError),
    /// The data were refused.
    #[error(transparent)]
    Data(#[from] datasets::DataError),
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
