//! One stiction × linear combination run on a loop, in one place: the [`Combination`] (model,
//! identifier, orders, dead time, grid, options) and its [`Fitted`] result with its
//! serialisable [`QuantifyRecord`]; the [`Settings`] a run shares between its combinations and
//! the flags that give them ([`SearchArgs`]); the linear identification alone ([`identify`]);
//! the [`Consensus`] a valve's diagnoses agree on.
//!
//! `discrepancy` extends the combinations it runs, `monitoring` runs them over files, the CLI
//! and `xtask reproduce` call it. This crate never prints; its only IO is writing a surface CSV
//! ([`Fitted::write_surface`]).

mod combination;
mod consensus;
pub mod identify;
mod record;
mod settings;

pub use combination::{
    build_identifier, paper_example, problem, span_of, Combination, Delay, FitSummary, Fitted,
    MAX_AUTO_DELAY,
};
pub use consensus::{Consensus, Disagreement};
pub use record::{
    models_record, null_as_nan, on_grid, CompareError, CompareRecord, DelayScore, GridRecord,
    IntervalRecord, OtherFit, QuantifyRecord,
};
pub use settings::{identifier_for, parse_orders, DelayArg, Orders, SearchArgs, Settings};

use std::path::PathBuf;

/// Errors of a run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunError {
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
    /// A search setting that cannot work (the message is the whole sentence, naming the CLI's
    /// flag).
    #[error("{message}")]
    Setting {
        /// The CLI flag, e.g. `--orders`.
        flag: &'static str,
        /// The sentence.
        message: String,
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
    /// A CSV file could not be written.
    #[error("{}: {source}", .path.display())]
    Csv {
        /// The path.
        path: PathBuf,
        /// What failed.
        source: csv::Error,
    },
}

/// Median of a slice (`NaN` when empty).
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Seconds per sample of a record: the median step of its time column, else 1 s.
pub fn sample_time(d: &datasets::LoopData) -> f64 {
    d.t.as_ref()
        .map(|t| {
            let dts: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
            median(&dts)
        })
        .filter(|v| v.is_finite() && *v > 0.0)
        .unwrap_or(1.0)
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
