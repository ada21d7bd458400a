//! The crate's error type.

use stiction_models::StictionError;

/// Everything that can go wrong while reading loop data or simulating a loop.
///
/// Every variant carries the offending values; [`Display`](std::fmt::Display) is one line that
/// names the file, the row (the line number as a user sees it in the file: the header is line
/// 1, the first data row line 2) and the column where they apply, e.g.
/// `loop.csv: row 17, column PV: "abc" is not a number`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DataError {
    /// A cell so large (|x| >= 1e60) that the solvers' sums of squares and their products could overflow.
    #[error(
        "{file}: row {row}, column {column}: {text:?} is too large to compute with (|value| >= 1e60); rescale the column"
    )]
    TooLarge {
        /// File name.
        file: String,
        /// 1-based line number.
        row: u64,
        /// Column name.
        column: String,
        /// The cell text (an excerpt).
        text: String,
    },
    /// An input limit ([`crate::Limits`]) was exceeded.
    #[error("{file}: {what}")]
    Limit {
        /// File name.
        file: String,
        /// Which limit, in words.
        what: String,
    },
    /// `--op-range` is not `LO,HI` with `LO < HI`.
    #[error("{file}: {message}")]
    OpRange {
        /// File name.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// The file could not be read.
    #[error("{file}: {error}")]
    Io {
        /// File name (or `-` for stdin).
        file: String,
        /// The underlying error (in the message, not a `source`: `{:#}` would print it twice).
        error: std::io::Error,
    },
    /// The input has no header row (it is empty or only blank).
    #[error("{file}: empty file (no header row)")]
    Empty {
        /// File name.
        file: String,
    },
    /// The input is UTF-16 (a byte-order mark, or NUL bytes between ASCII characters).
    #[error("{file}: the file is UTF-16, which is not supported: save it as UTF-8")]
    Utf16 {
        /// File name.
        file: String,
    },
    /// The input holds NUL bytes (a binary file?).
    #[error("{file}: row {row}: a NUL byte at byte {byte}: not a text file")]
    NulByte {
        /// File name.
        file: String,
        /// Line number of the first NUL byte (header = 1).
        row: u64,
        /// Byte offset of the first NUL byte.
        byte: usize,
    },
    /// The input is not valid UTF-8.
    #[error("{file}: row {row}: invalid UTF-8 at byte {byte}")]
    InvalidUtf8 {
        /// File name.
        file: String,
        /// Line number of the first invalid byte (header = 1).
        row: u64,
        /// Byte offset of the first invalid byte from the start of the input.
        byte: usize,
    },
    /// The CSV parser failed (for example an unterminated quote).
    #[error("{file}: row {row}: {message}")]
    Csv {
        /// File name.
        file: String,
        /// Line number where the parser stopped (header = 1).
        row: u64,
        /// The parser's message.
        message: String,
    },
    /// A required (or explicitly requested) column is not in the header.
    #[error("{file}: no column {column} in the header (found: {})", found.join(", "))]
    MissingColumn {
        /// File name.
        file: String,
        /// The column that was looked for (its role and the name(s) tried).
        column: String,
        /// The header as found in the file.
        found: Vec<String>,
    },
    /// A data row has a different number of cells than the header.
    #[error("{file}: row {row}: {got} cells, the header has {expected}")]
    RaggedRow {
        /// File name.
        file: String,
        /// Line number (header = 1).
        row: u64,
        /// Number of header cells.
        expected: usize,
        /// Number of cells in the row.
        got: usize,
    },
    /// Columns handed over in memory ([`crate::read_columns`]) have different lengths.
    #[error("{file}: column {column} has {got} rows, column {first} has {expected}")]
    ColumnLengths {
        /// Source name.
        file: String,
        /// The first column's name.
        first: String,
        /// Its number of rows.
        expected: usize,
        /// The first column of another length.
        column: String,
        /// Its number of rows.
        got: usize,
    },
    /// A cell of a used column is not a number.
    #[error("{file}: row {row}, column {column}: {text:?} is not a number")]
    NotANumber {
        /// File name.
        file: String,
        /// Line number (header = 1).
        row: u64,
        /// Column name as written in the header.
        column: String,
        /// The cell text.
        text: String,
    },
    /// A cell of a used column is an infinite number (`inf`, `1e999`).
    #[error("{file}: row {row}, column {column}: {text:?} is not a finite number")]
    NotFinite {
        /// File name.
        file: String,
        /// Line number (header = 1).
        row: u64,
        /// Column name as written in the header.
        column: String,
        /// The cell text.
        text: String,
    },
    /// A time cell is neither a number of seconds nor a supported timestamp.
    #[error(
        "{file}: row {row}, column {column}: {text:?} is not a time (seconds, or a timestamp \
         YYYY-MM-DDTHH:MM:SS[.fff][Z|+hh:mm], YYYY-MM-DD HH:MM[:SS[.fff]] or DD.MM.YYYY \
         HH:MM[:SS[.fff]], one kind per column)"
    )]
    BadTime {
        /// File name.
        file: String,
        /// Line number (header = 1).
        row: u64,
        /// Column name as written in the header.
        column: String,
        /// The cell text.
        text: String,
    },
    /// Empty or NaN cells were found and the gap policy is [`GapPolicy::Refuse`](crate::GapPolicy::Refuse).
    #[error(
        "{file}: {count} empty or NaN cell(s) in the used columns, the first at row {row}, \
         column {column}; fill them (hold the last value) or drop them (keep the longest clean \
         segment) explicitly"
    )]
    Gaps {
        /// File name.
        file: String,
        /// Number of empty/NaN cells in the used columns.
        count: usize,
        /// Line number of the first one (header = 1).
        row: u64,
        /// Its column.
        column: String,
    },
    /// Gap policy [`GapPolicy::FillHold`](crate::GapPolicy::FillHold) and a column starts with
    /// gaps, so there is no earlier value to hold.
    #[error(
        "{file}: row {row}, column {column}: the column starts with {count} empty or NaN \
         cell(s), there is no earlier value to hold; drop the gaps instead"
    )]
    LeadingGap {
        /// File name.
        file: String,
        /// Line number of the first row (header = 1).
        row: u64,
        /// Column name.
        column: String,
        /// Number of leading gaps.
        count: usize,
    },
    /// A controller-mode cell is neither a number nor a known mode name.
    #[error(
        "{file}: row {row}, column {column}: {text:?} is not a controller mode (a number, 0 = \
         manual; or AUTO, CAS, MAN, ...)"
    )]
    BadMode {
        /// File name.
        file: String,
        /// Line number (header = 1).
        row: u64,
        /// Column name as written in the header.
        column: String,
        /// The cell text.
        text: String,
    },
    /// The mode column says the loop is never in closed loop.
    #[error(
        "{file}: column {column}: no row in closed loop (all {rows} rows manual or unknown mode)"
    )]
    NoClosedLoop {
        /// File name.
        file: String,
        /// Mode column name.
        column: String,
        /// Number of rows.
        rows: usize,
    },
    /// The time column repeats or goes back.
    #[error(
        "{file}: row {row}, column {column}: time does not increase ({value} s after {previous} s \
         from the first sample); {count} repeated or backward time stamp(s): duplicated rows or \
         a clock jump in the export, refused"
    )]
    TimeNotIncreasing {
        /// File name.
        file: String,
        /// Line number of the first offending row (header = 1).
        row: u64,
        /// Time column name.
        column: String,
        /// Its time, s from the first sample.
        value: f64,
        /// The previous row's time, s from the first sample.
        previous: f64,
        /// Number of non-increasing steps in the file.
        count: usize,
    },
    /// Samples are missing (intervals longer than 1.5 × the median sampling time) and the gap
    /// policy is [`GapPolicy::Refuse`](crate::GapPolicy::Refuse).
    #[error(
        "{file}: row {row}, column {column}: {count} interval(s) longer than 1.5 x the median \
         sampling time {ts} s, the first ending here ({gap} s): samples are missing; fill them \
         (hold the last value) or drop them (keep the longest regular segment) explicitly"
    )]
    TimeGaps {
        /// File name.
        file: String,
        /// Line number of the row after the first long interval (header = 1).
        row: u64,
        /// Time column name.
        column: String,
        /// Number of long intervals.
        count: usize,
        /// Length of the first long interval, s.
        gap: f64,
        /// Median sampling interval, s.
        ts: f64,
    },
    /// PV or OP is flat (one repeated value) over more than half of the rows.
    #[error(
        "{file}: row {row}, column {column}: the same value for {run} of {rows} rows (historian \
         compression, a frozen transmitter or a saturated valve): too little movement to identify"
    )]
    Flat {
        /// File name.
        file: String,
        /// Line number where the flat run starts (header = 1).
        row: u64,
        /// Column name.
        column: String,
        /// Length of the flat run.
        run: usize,
        /// Number of rows.
        rows: usize,
    },
    /// A MATLAB file could not be parsed or lacks what is needed.
    #[error("{file}: {message}")]
    Mat {
        /// File name.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A required column has no value at all.
    #[error("{file}: column {column}: every cell is empty or NaN")]
    AllGaps {
        /// File name.
        file: String,
        /// Column name.
        column: String,
    },
    /// Fewer data rows than needed.
    #[error("{file}: too few data rows: {needed} needed, {got} available")]
    TooFewRows {
        /// File name.
        file: String,
        /// Minimum number of rows.
        needed: usize,
        /// Number of rows available (after gap handling).
        got: usize,
    },
    /// The controller-mode column leaves too short a closed-loop segment.
    #[error(
        "{file}: column {column}: the longest closed-loop segment has {got} of {total} rows, {needed} needed (the controller mode changes too often)"
    )]
    TooFewClosedLoopRows {
        /// File name.
        file: String,
        /// The mode column's name.
        column: String,
        /// Minimum number of rows.
        needed: usize,
        /// Rows in the longest closed-loop segment (after the later checks).
        got: usize,
        /// Rows before the mode selection.
        total: usize,
    },
    /// OP or PV does not vary: nothing can be identified.
    #[error("{file}: column {column}: constant ({value:?}) over all {rows} rows")]
    Constant {
        /// File name.
        file: String,
        /// Column name.
        column: String,
        /// The constant value.
        value: f64,
        /// Number of rows.
        rows: usize,
    },
    /// A plant definition is invalid (leading coefficients, non-finite values, ...).
    #[error("invalid plant: {reason}")]
    InvalidPlant {
        /// What is wrong.
        reason: String,
    },
    /// A scenario setting is out of range.
    #[error("scenario: {name} = {value} is out of range: expected {expected}")]
    InvalidParameter {
        /// Setting name (JSON path, e.g. `controller.kc`).
        name: String,
        /// The rejected value.
        value: f64,
        /// The valid range, in words.
        expected: String,
    },
    /// The closed loop without stiction is not stable for this plant and tuning.
    #[error(
        "closed loop unstable with Kc = {}, KI = {}, delay {delay}: largest closed-loop \
         root modulus {} >= 1",
        short_number(*.kc), short_number(*.ki), if .max_modulus.abs() < 1e9 { format!("{:.6}", .max_modulus) } else { format!("{:.4e}", .max_modulus) }
    )]
    Unstable {
        /// Proportional gain.
        kc: f64,
        /// Integral gain.
        ki: f64,
        /// Extra dead time (samples).
        delay: usize,
        /// Largest modulus of the closed-loop characteristic roots.
        max_modulus: f64,
    },
    /// The simulation produced a non-finite value (the loop diverged).
    #[error("simulation diverged: {signal} is not finite at sample {sample}")]
    Diverged {
        /// Signal name (`PV`, `OP`, `MV`).
        signal: &'static str,
        /// Sample index (including the warm-up).
        sample: usize,
    },
    /// A scenario (JSON) could not be parsed or is invalid.
    #[error("scenario: {message}")]
    Config {
        /// The parser's message (includes the stiction model's own message for bad valve
        /// parameters).
        message: String,
    },
    /// The valve model rejected its input or initial state.
    #[error(transparent)]
    Stiction(#[from] StictionError),
}

/// A number for a one-line message: plain when moderate, in exponent form when tiny or huge.
pub(crate) fn short_number(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e9).contains(&x.abs()) {
        format!("{}", (x * 1e6).round() / 1e6)
    } else {
        format!("{x:.4e}")
    }
}
