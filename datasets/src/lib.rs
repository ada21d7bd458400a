//! Loop data readers and the closed-loop benchmark simulator.
//!
//! * [`read_csv`] / [`read_csv_path`] read one registration of a control loop (PV, OP and
//!   optionally SP, MV and time) from CSV into [`LoopData`], with explicit policies for empty
//!   and NaN cells ([`GapPolicy`]) and one-line errors naming file, row and column
//!   ([`DataError`]).
//! * [`read_mat`] / [`read_mat_path`] read the same variables from MATLAB v5 files (top-level
//!   vectors, or a struct-of-loops such as the International Stiction Database's
//!   `cdata.<sector>.loop<N>`, selected by [`ReadOptions::mat_loop`]; [`list_mat_loops`] lists
//!   them), [`read_path`] picks the reader
//!   by extension, [`parse_registration_name`] reads valve and start time from a file name.
//! * [`simulate`] is the closed-loop benchmark of the reference paper (§3.1, eqs. 10-12): an
//!   ARMAX plant under a velocity-form PI controller with a sticky valve taken from any
//!   registered [`stiction_models::StictionModel`], configured by a serialisable
//!   [`simulate::Scenario`].
//!
//! ```
//! use datasets::{read_csv, ReadOptions};
//! let csv = "t,PV,OP\n0,1.0,50\n1,1.5,51\n2,1.2,50.5\n";
//! let data = read_csv(csv.as_bytes(), "loop.csv", &ReadOptions::default())?;
//! assert_eq!(data.op, vec![50.0, 51.0, 50.5]);
//! assert_eq!(data.pv.as_deref(), Some(&[1.0, 1.5, 1.2][..]));
//! # Ok::<(), datasets::DataError>(())
//! ```
#![deny(missing_docs)]

mod error;
pub mod held;
pub mod limits;
mod mat;
mod note;
pub mod quantisation;
mod raw;
mod read;
mod registration;
pub mod simulate;
mod spikes;
pub mod units;

pub use error::DataError;
pub use limits::Limits;
pub use mat::{list_mat_loops, read_mat, read_mat_path};
pub use note::{Note, NoteKind};
pub use raw::raw_columns;
pub use read::{
    compression, read_columns, read_csv, read_csv_path, ColumnInput, Compression, GapPolicy,
    ReadOptions, COMPRESSED_SHARE, DEFAULT_WINDOW,
};
pub use registration::{format_epoch, parse_registration_name, RegistrationName};
pub use units::OpRange;

/// Read a registration from a file, by its extension: `.mat` with [`read_mat_path`], anything
/// else with [`read_csv_path`].
pub fn read_path(
    path: impl AsRef<std::path::Path>,
    opts: &ReadOptions,
) -> Result<LoopData, DataError> {
    let path = path.as_ref();
    let is_mat = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mat"));
    if is_mat {
        read_mat_path(path, opts)
    } else {
        read_csv_path(path, opts)
    }
}

/// One registration of a control loop, as read from a file or produced by the simulator.
///
/// All present series have the same length ([`LoopData::len`]). OP is always present; PV is
/// present whenever the reader was asked to require it ([`ReadOptions::require_pv`], the
/// default), otherwise it is present when the file has it.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopData {
    /// Where the data came from (file name, `-` for stdin, or `simulation`); used in messages.
    pub source: String,
    /// Start of the record (its first kept sample), seconds since the Unix epoch (UTC), when the
    /// time column holds timestamps; `None` otherwise.
    pub start: Option<f64>,
    /// Time in seconds from the first sample, when the file has a time column.
    pub t: Option<Vec<f64>>,
    /// Set point, when available.
    pub sp: Option<Vec<f64>>,
    /// Process variable (controlled variable).
    pub pv: Option<Vec<f64>>,
    /// Controller output (valve command), % of valve span (rescaled by the reader when OP
    /// was logged as a fraction or in counts; see [`units`]).
    pub op: Vec<f64>,
    /// Measured valve position, when available.
    pub mv: Option<Vec<f64>>,
    /// What was done to the data on the way in (gap filling, dropped rows, ignored columns).
    pub notes: Vec<Note>,
}

impl LoopData {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.op.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.op.is_empty()
    }

    /// PV, or [`DataError::MissingColumn`] when the data has none.
    pub fn require_pv(&self) -> Result<&[f64], DataError> {
        self.pv.as_deref().ok_or_else(|| DataError::MissingColumn {
            file: self.source.clone(),
            column: "PV".into(),
            found: self.columns(),
        })
    }

    /// Names of the series present, in the order t, SP, PV, OP, MV.
    pub fn columns(&self) -> Vec<String> {
        let mut v = Vec::new();
        if self.t.is_some() {
            v.push("t".to_string());
        }
        if self.sp.is_some() {
            v.push("SP".to_string());
        }
        if self.pv.is_some() {
            v.push("PV".to_string());
        }
        v.push("OP".to_string());
        if self.mv.is_some() {
            v.push("MV".to_string());
        }
        v
    }
}
