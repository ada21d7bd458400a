//! A control loop's analysis as typed values, in one place: the stiction × linear
//! [`Combination`] and its [`Fitted`] result; the trend of a valve over repeated registrations
//! with its maintenance verdict ([`trend`]); ROC and robust statistics ([`stats`]).
//!
//! The CLI parses arguments, calls this crate and prints; `discrepancy` extends the
//! combinations it runs; `xtask reproduce` runs the paper's study through them. This crate does
//! no IO and never prints.

mod combination;
pub mod doc;
pub mod settings;
pub mod stats;
pub mod trend;

pub use combination::{span_of, Combination, Delay, FitSummary, Fitted, MAX_AUTO_DELAY};
pub use settings::{DelaySetting, SearchSettings};
pub use stats::{median, roc, theil_sen, Roc};
pub use trend::{maintenance, trend, Flag, Maintenance, Point, Trend};

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
    /// A search setting cannot work (the message names the CLI's flag).
    #[error("{message}")]
    Setting {
        /// The CLI flag of the setting, e.g. `--orders`.
        flag: &'static str,
        /// The whole sentence.
        message: String,
    },
}
