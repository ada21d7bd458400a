//! The CSV reader.
//!
//! Contract (`spec/CLI.md`, "Input data"): a header row; `,` as delimiter, or `;` / tab when the
//! header line shows them; columns found by name case-insensitively (`PV`, `OP`, `SP`, `MV`,
//! `t` / `time`), others ignored; empty or `NaN` cells are gaps, refused by default.

use crate::limits::{excerpt, read_limited, Limits};
use crate::units::OpRange;
use std::io::Read;
use std::path::Path;

use crate::{DataError, LoopData, Note, NoteKind};

mod cells;
mod checks;
mod stamps;

use cells::*;
use checks::*;
pub use checks::{compression, Compression, COMPRESSED_SHARE};

/// What to do with empty or `NaN` cells in the used columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GapPolicy {
    /// Refuse the file, reporting how many gaps there are and where the first one is
    /// ([`DataError::Gaps`]). The default: a gap is never handled silently.
    #[default]
    Refuse,
    /// Carry the last valid value forward (`--fill hold`). A column that *starts* with gaps is
    /// an error ([`DataError::LeadingGap`]): there is nothing to hold, and filling backwards
    /// would invent data before the first measurement. Gaps in the time column are filled by
    /// linear interpolation between the neighbouring times (extrapolated with the nearest
    /// time step at the ends), since a held time would repeat a time stamp.
    FillHold,
    /// Keep only the longest run of consecutive rows with no gap in any used column
    /// (`--drop-gaps`); the earliest such run on ties.
    DropGaps,
}

impl std::str::FromStr for GapPolicy {
    type Err = String;

    /// `refuse`, `hold` or `drop` (the Python package's `gaps`; the CLI spells them
    /// `--fill hold` and `--drop-gaps`).
    fn from_str(s: &str) -> Result<GapPolicy, String> {
        match s {
            "refuse" => Ok(GapPolicy::Refuse),
            "hold" => Ok(GapPolicy::FillHold),
            "drop" => Ok(GapPolicy::DropGaps),
            other => Err(format!(
                "gaps={other:?}: expected \"refuse\", \"hold\" or \"drop\""
            )),
        }
    }
}

/// Options of [`read_csv`].
///
/// | field | default | meaning |
/// |-------|---------|---------|
/// | `pv`, `op`, `sp`, `mv` | `None` | header name of that column (case-insensitive); `None` = the column named `PV`, `OP`, `SP`, `MV` |
/// | `time` | `None` | header name of the time column; `None` = `t` or `time` |
/// | `require_pv` | `true` | a missing PV column is an error; when `false`, PV is read if present |
/// | `gaps` | [`GapPolicy::Refuse`] | handling of empty / NaN cells |
/// | `min_rows` | 3 | minimum number of data rows after gap handling (at least 1 is always required) |
/// | `mode` | `None` | header name of the controller-mode column; `None` = `MODE` (see below) |
///
/// **Controller mode.** When a mode column is present, each cell says whether the loop was
/// closed: numbers `0` = manual (open loop), any other number = closed loop (`1` auto, `2`
/// cascade, ...); text (case-insensitive) `AUTO`, `AUT`, `A`, `CAS`, `CASCADE`, `RCAS`, `NORMAL`,
/// `CLOSED` = closed loop, `MAN`, `MANUAL`, `M`, `IMAN`, `LO`, `OOS`, `OPEN`, `TRACK`, `TRK` =
/// open loop; an empty cell is an unknown mode, taken as open loop; any other text is an error
/// ([`DataError::BadMode`]). If some rows are not in closed loop, only the longest closed-loop
/// segment is kept, with a note; no closed-loop row at all is [`DataError::NoClosedLoop`].
///
/// **Time.** A time column must increase strictly: a repeated or backward time stamp is refused
/// ([`DataError::TimeNotIncreasing`]). Intervals longer than 1.5 × the median interval are
/// missing samples, handled by the gap policy (refused by [`DataError::TimeGaps`], filled by
/// holding the last row, or dropped by keeping the longest regularly sampled segment); smaller
/// irregularities (jitter) are reported in a note and the record is treated as uniformly
/// sampled at the median interval.
///
/// **Flat stretches** (records of 20 rows or more). Runs of exactly repeated PV or OP values (historian compression, a frozen
/// transmitter) are reported in a note when the longest run is 5 samples or more or repeats are
/// 5 % of the samples or more; a PV or OP flat over more than half of the rows (but not all of
/// them, which is [`DataError::Constant`]) is refused ([`DataError::Flat`]), or kept with a note
/// under [`ReadOptions::accept_constant`].
///
/// A column named explicitly (`Some`) must exist, even an optional one; an optional column
/// found by its default name whose cells are all empty or NaN is ignored with a note.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct ReadOptions {
    /// Header name of the PV column.
    pub pv: Option<String>,
    /// Header name of the OP column.
    pub op: Option<String>,
    /// Header name of the SP column.
    pub sp: Option<String>,
    /// Header name of the MV column.
    pub mv: Option<String>,
    /// Header name of the time column.
    pub time: Option<String>,
    /// Whether a missing PV column is an error.
    pub require_pv: bool,
    /// Handling of empty / NaN cells.
    pub gaps: GapPolicy,
    /// Minimum number of data rows.
    pub min_rows: usize,
    /// Header name of the controller-mode column (`None` = `MODE`).
    pub mode: Option<String>,
    /// MATLAB files only: path of the loop to read in a struct-of-loops file, such as
    /// `cdata.chemicals.loop1` (`""` = the top-level variables); `None` = the top-level
    /// variables when they form a loop, else the file's only loop (see [`crate::list_mat_loops`]).
    pub mat_loop: Option<String>,
    /// OP's units: detected from its range (default), given (`--op-range LO,HI`), or kept.
    /// OP (and a measured MV) are rescaled to % of valve span; see [`crate::units`].
    pub op_range: OpRange,
    /// Input limits (bytes, line and cell length, rows).
    pub limits: Limits,
    /// Keep a PV or OP that is constant over the whole record, or flat over more than half of
    /// it, with a note, instead of refusing it ([`DataError::Constant`], [`DataError::Flat`]).
    /// For a detector, which answers such a record
    /// itself (`inconclusive`: the valve was never asked to move, or the transmitter is
    /// frozen); identification has nothing to fit and keeps the default, `false`.
    pub accept_constant: bool,
    /// The most rows analysed: of a longer record only the latest `window` rows are kept, with
    /// a [`NoteKind::Window`] note (see [`DEFAULT_WINDOW`]). The row limit
    /// ([`Limits::max_rows`]) refuses a file; the window bounds the analysis of one it read.
    pub window: usize,
}

/// The default of [`ReadOptions::window`]: 50 000 rows, about 14 hours of 1-s data.
///
/// Every command's cost grows with the rows analysed (the grid search evaluates each node on
/// the whole record; the diagnosis refits many grids), and a stiction estimate needs tens of
/// the valve's stick-slip cycles, not hundreds of thousands of samples. Decision: a longer
/// record is cut to its **latest** rows, the valve's present state, which is what maintenance is
/// planned from (the trend of S over registrations), rather than decimated (which would
/// change the sampling time the dynamics and the valve's stick-slip events are seen at) or
/// split into segments analysed one by one (whose cost would still grow with the record). The
/// times behind 50 000 are in `docs/decisions/2026-11-27-long-records-and-fuzz.md`.
pub const DEFAULT_WINDOW: usize = 50_000;

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            pv: None,
            op: None,
            sp: None,
            mv: None,
            time: None,
            require_pv: true,
            gaps: GapPolicy::Refuse,
            min_rows: 3,
            mode: None,
            mat_loop: None,
            op_range: OpRange::Detect,
            limits: Limits::default(),
            accept_constant: false,
            window: DEFAULT_WINDOW,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Time,
    Sp,
    Pv,
    Op,
    Mv,
    Mode,
}

struct Wanted {
    role: Role,
    label: &'static str,
    names: Vec<String>,
    required: bool,
    explicit: bool,
}

struct Column {
    role: Role,
    /// Header text as written in the file.
    name: String,
    index: usize,
    required: bool,
    values: Vec<Option<f64>>,
}

/// Kind of a time column, fixed by its first non-empty cell.
#[derive(Clone, Copy, PartialEq)]
enum TimeKind {
    Seconds,
    /// Timestamps, stored relative to the first one (nanoseconds since the epoch, UTC).
    Stamp(i64),
}

/// Read one loop registration from a file.
///
/// The file name as given is used in messages and as [`LoopData::source`].
pub fn read_csv_path(path: impl AsRef<Path>, opts: &ReadOptions) -> Result<LoopData, DataError> {
    let path = path.as_ref();
    let name = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|error| DataError::Io {
        file: name.clone(),
        error,
    })?;
    read_csv(std::io::BufReader::new(file), &name, opts)
}

/// Whether `bytes` look like UTF-16: a byte-order mark (`FF FE` or `FE FF`), or a NUL byte next
/// to every other byte of the first line's ASCII (`\0t\0,\0S\0P`). Printed as is, such a
/// header put NUL bytes on the terminal.
fn is_utf16(bytes: &[u8]) -> bool {
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        return true;
    }
    let head = &bytes[..bytes.len().min(64)];
    head.len() >= 4 && {
        let even = head.iter().step_by(2).filter(|&&b| b == 0).count();
        let odd = head.iter().skip(1).step_by(2).filter(|&&b| b == 0).count();
        let half = head.len() / 2;
        even * 10 >= half * 9 || odd * 10 >= half * 9
    }
}

/// Read one loop registration from CSV text; `source` names it in messages.
///
/// Never panics: any input yields either data or a [`DataError`].
pub fn read_csv(
    mut reader: impl Read,
    source: &str,
    opts: &ReadOptions,
) -> Result<LoopData, DataError> {
    let file = source.to_string();
    let bytes = read_limited(&mut reader, &file, &opts.limits, true)?;
    if is_utf16(&bytes) {
        return Err(DataError::Utf16 { file });
    }
    if let Some(byte) = bytes.iter().position(|&b| b == 0) {
        let row = 1 + bytes[..byte].iter().filter(|&&b| b == b'\n').count() as u64;
        return Err(DataError::NulByte { file, row, byte });
    }
    let text = match std::str::from_utf8(&bytes) {
        Ok(t) => t,
        Err(e) => {
            let byte = e.valid_up_to();
            let row = 1 + bytes[..byte].iter().filter(|&&b| b == b'\n').count() as u64;
            return Err(DataError::InvalidUtf8 { file, row, byte });
        }
    };
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if text.trim().is_empty() {
        return Err(DataError::Empty { file });
    }
    let delimiter = detect_delimiter(text);
    let mut notes = Vec::new();

    let mut rdr = csv::ReaderBuilder::new()
        .delimiter(delimiter)
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let mut records = rdr.records();
    // Where a record starts (after CRLF the csv crate's position points at the `\n`, and its
    // line count is one short): the line (header = 1) is counted from the bytes.
    let start = |byte: u64| {
        let b = (byte as usize).min(text.len());
        b + usize::from(text.as_bytes().get(b) == Some(&b'\n'))
    };
    let line_at = |byte: u64| {
        1 + text.as_bytes()[..start(byte)]
            .iter()
            .filter(|&&b| b == b'\n')
            .count() as u64
    };
    let csv_err = |file: &str, e: csv::Error| DataError::Csv {
        file: file.to_string(),
        row: e.position().map_or(0, |p| line_at(p.byte())),
        message: e.to_string(),
    };
    let header = match records.next() {
        None => return Err(DataError::Empty { file }),
        Some(Err(e)) => return Err(csv_err(&file, e)),
        Some(Ok(h)) => h,
    };
    // A quoted header cell may span lines: keep messages on one line.
    let header: Vec<String> = header
        .iter()
        .map(|h| excerpt(&h.replace(['\n', '\r'], " ")))
        .collect();
    if header.iter().all(String::is_empty) {
        return Err(DataError::Empty { file });
    }

    let mut columns = locate_columns(&file, &header, opts, &mut notes)?;

    // Parse the rows.
    let mut lines: Vec<u64> = Vec::new();
    let mut time_kind: Option<TimeKind> = None;
    let mut decimal_commas = 0usize;
    let mut unread_pv: Option<DataError> = None;
    let (mut seen, mut newlines) = (0usize, 0u64);
    for record in records {
        let record = record.map_err(|e| csv_err(&file, e))?;
        let row = record.position().map_or(0, |p| {
            let byte = start(p.byte()).max(seen);
            newlines += text.as_bytes()[seen..byte]
                .iter()
                .filter(|&&b| b == b'\n')
                .count() as u64;
            seen = byte;
            1 + newlines
        });
        if header.len() > 1 && record.len() == 1 && record[0].is_empty() {
            continue; // a blank line
        }
        if record.len() != header.len() {
            return Err(DataError::RaggedRow {
                file,
                row,
                expected: header.len(),
                got: record.len(),
            });
        }
        if let Some((i, cell)) = record
            .iter()
            .enumerate()
            .find(|(_, c)| c.len() > opts.limits.max_cell)
        {
            return Err(DataError::Limit {
                file,
                what: format!(
                    "row {row}, column {}: a cell of {} bytes, over the limit of {} KiB: {:?}",
                    header.get(i).map_or("?", |h| h.as_str()),
                    cell.len(),
                    opts.limits.max_cell >> 10,
                    excerpt(cell)
                ),
            });
        }
        lines.push(row);
        for col in &mut columns {
            let text = &record[col.index];
            let value = match col.role {
                Role::Time => {
                    parse_time(text, &mut time_kind, delimiter == b';', &mut decimal_commas)
                }
                Role::Mode => parse_mode(text),
                _ => parse_number(text, delimiter == b';', &mut decimal_commas),
            };
            col.push_cell(value, text, (&file, row), &mut unread_pv)?;
        }
    }
    leave_out_unread_pv(&file, unread_pv, &mut columns, &mut notes);
    finish(file, columns, lines, time_kind, decimal_commas, notes, opts)
}

/// Replace the single-sample spikes of a column ([`crate::spikes`]) and say so.
fn spike_note(column: &str, values: &mut [f64], lines: &[u64]) -> Option<Note> {
    let sig = crate::units::sig;
    match crate::spikes::remove(values) {
        Ok(found) if found.is_empty() => None,
        Ok(found) => {
            let shown: Vec<String> = found
                .iter()
                .take(3)
                .map(|&(i, v)| format!("row {} ({})", lines.get(i).copied().unwrap_or(0), sig(v)))
                .collect();
            let more = if found.len() > 3 {
                format!(" and {} more", found.len() - 3)
            } else {
                String::new()
            };
            Some(Note::new(
                NoteKind::Spikes,
                format!(
                    "column {column}: {} single-sample spike(s) replaced by the previous sample: {}{more}",
                    found.len(),
                    shown.join(", ")
                ),
            ))
        }
        Err(count) => Some(Note::new(
            NoteKind::Spikes,
            format!(
                "column {column}: {count} samples stand out from both neighbours (over 1 % of the samples): kept as the signal"
            ),
        )),
    }
}

/// PV that the caller does not need (`stiction valve`) and cannot be read is left out with a
/// note, not a reason to refuse the file.
fn leave_out_unread_pv(
    file: &str,
    unread: Option<DataError>,
    columns: &mut Vec<Column>,
    notes: &mut Vec<Note>,
) {
    if let Some(e) = unread {
        columns.retain(|c| c.role != Role::Pv);
        let why = e.to_string();
        let why = why.strip_prefix(&format!("{file}: ")).unwrap_or(&why);
        notes.push(Note::new(
            NoteKind::Columns,
            format!("PV is not needed here and was not read: {why}"),
        ));
    }
}

/// The error for a cell the parsers refused (`cell` is not a gap or a value).
impl Column {
    /// Push the cell read from `text` (at `row` of `file`): a gap or a value; an unreadable
    /// PV that is not required becomes a gap (its first refusal kept in `unread_pv`); any
    /// other unreadable cell is the error.
    fn push_cell(
        &mut self,
        value: Cell,
        text: &str,
        (file, row): (&str, u64),
        unread_pv: &mut Option<DataError>,
    ) -> Result<(), DataError> {
        match value {
            Cell::Gap => self.values.push(None),
            Cell::Value(v) => self.values.push(Some(v)),
            bad if self.role == Role::Pv && !self.required => {
                unread_pv.get_or_insert_with(|| {
                    refuse(bad, file.to_string(), row, self.name.clone(), excerpt(text))
                });
                self.values.push(None);
            }
            bad => {
                return Err(refuse(
                    bad,
                    file.to_string(),
                    row,
                    self.name.clone(),
                    excerpt(text),
                ))
            }
        }
        Ok(())
    }
}

fn refuse(cell: Cell, file: String, row: u64, column: String, text: String) -> DataError {
    macro_rules! error {
        ($variant:ident) => {
            DataError::$variant {
                file,
                row,
                column,
                text,
            }
        };
    }
    match cell {
        Cell::BadMode => error!(BadMode),
        Cell::NotFinite => error!(NotFinite),
        Cell::TooLarge => error!(TooLarge),
        Cell::BadTime => error!(BadTime),
        _ => error!(NotANumber),
    }
}

/// One column handed to [`read_columns`]: numbers (NaN is a gap), or text cells (`None` is a
/// gap), e.g. time stamps or a controller mode.
#[derive(Debug, Clone, Copy)]
pub enum ColumnInput<'a> {
    /// Numbers, as a numeric column of a data frame holds them.
    Numbers(&'a [f64]),
    /// Text cells, read as the CSV reader reads a cell (trimmed).
    Text(&'a [Option<String>]),
}

impl ColumnInput<'_> {
    fn len(&self) -> usize {
        match self {
            ColumnInput::Numbers(x) => x.len(),
            ColumnInput::Text(t) => t.len(),
        }
    }
}

/// Read one loop registration from named columns held in memory (a data frame's), with the
/// same conventions, notes and errors as [`read_csv`] on the CSV text of those columns (header
/// on line 1, data row `i` on line `i + 2`), without making or parsing that text: numeric
/// cells of the SP/PV/OP/MV columns are taken as they are (NaN a gap, infinite or beyond
/// 1e60 refused as the CSV reader refuses them); time, mode and text cells go through the
/// CSV reader's own cell parsers. Equal column lengths are the caller's to ensure (an error
/// otherwise). `tests/columns.rs` checks the two entries agree.
pub fn read_columns(
    source: &str,
    names: &[String],
    columns: &[ColumnInput<'_>],
    opts: &ReadOptions,
) -> Result<LoopData, DataError> {
    let file = source.to_string();
    if names.len() != columns.len() {
        return Err(DataError::Limit {
            file,
            what: format!("{} column names for {} columns", names.len(), columns.len()),
        });
    }
    let rows = columns.first().map_or(0, ColumnInput::len);
    if let Some((j, c)) = columns.iter().enumerate().find(|(_, c)| c.len() != rows) {
        return Err(DataError::ColumnLengths {
            file,
            first: names[0].clone(),
            expected: rows,
            column: names[j].clone(),
            got: c.len(),
        });
    }
    if rows > opts.limits.max_rows {
        return Err(DataError::Limit {
            file,
            what: format!(
                "more than {} data rows (the limit; raise it with --max-rows)",
                opts.limits.max_rows
            ),
        });
    }
    let header: Vec<String> = names
        .iter()
        .map(|h| excerpt(h.replace(['\n', '\r'], " ").trim()))
        .collect();
    if header.iter().all(String::is_empty) {
        return Err(DataError::Empty { file });
    }
    let mut notes = Vec::new();
    let mut located = locate_columns(&file, &header, opts, &mut notes)?;
    let lines: Vec<u64> = (0..rows as u64).map(|i| i + 2).collect();
    let mut time_kind: Option<TimeKind> = None;
    let mut decimal_commas = 0usize;
    let mut unread_pv: Option<DataError> = None;
    let mut number = ryu::Buffer::new();
    for col in &mut located {
        col.values.reserve_exact(rows);
    }
    // Row by row, as the CSV reader goes: the first refused cell is the same one.
    for (i, &row) in lines.iter().enumerate() {
        for col in &mut located {
            let input = columns[col.index];
            let text: &str = match input {
                ColumnInput::Numbers(x) => {
                    let v = x[i];
                    match col.role {
                        Role::Time | Role::Mode => {
                            if v.is_finite() {
                                number.format_finite(v)
                            } else if v.is_nan() {
                                ""
                            } else if v > 0.0 {
                                "inf"
                            } else {
                                "-inf"
                            }
                        }
                        _ => {
                            if v.is_nan() {
                                col.values.push(None);
                            } else if v.is_infinite() || v.abs() >= TOO_LARGE {
                                let cell = if v.is_infinite() {
                                    Cell::NotFinite
                                } else {
                                    Cell::TooLarge
                                };
                                let text = if v.is_infinite() {
                                    (if v > 0.0 { "inf" } else { "-inf" }).to_string()
                                } else {
                                    number.format_finite(v).to_string()
                                };
                                if col.role == Role::Pv && !col.required {
                                    unread_pv.get_or_insert_with(|| {
                                        refuse(cell, file.clone(), row, col.name.clone(), text)
                                    });
                                    col.values.push(None);
                                    continue;
                                }
                                return Err(refuse(cell, file, row, col.name.clone(), text));
                            } else {
                                col.values.push(Some(v));
                            }
                            continue;
                        }
                    }
                }
                ColumnInput::Text(t) => t[i].as_deref().unwrap_or("").trim(),
            };
            if text.len() > opts.limits.max_cell {
                return Err(DataError::Limit {
                    file,
                    what: format!(
                        "row {row}, column {}: a cell of {} bytes, over the limit of {} KiB: {:?}",
                        col.name,
                        text.len(),
                        opts.limits.max_cell >> 10,
                        excerpt(text)
                    ),
                });
            }
            let value = match col.role {
                Role::Time => parse_time(text, &mut time_kind, false, &mut decimal_commas),
                Role::Mode => parse_mode(text),
                _ => parse_number(text, false, &mut decimal_commas),
            };
            col.push_cell(value, text, (&file, row), &mut unread_pv)?;
        }
    }
    leave_out_unread_pv(&file, unread_pv, &mut located, &mut notes);
    finish(file, located, lines, time_kind, decimal_commas, notes, opts)
}

/// The wanted columns found in `header` (by name, case-insensitively), with notes on
/// ambiguous and ignored columns; a missing required (or explicitly named) column is an error.
fn locate_columns(
    file: &str,
    header: &[String],
    opts: &ReadOptions,
    notes: &mut Vec<Note>,
) -> Result<Vec<Column>, DataError> {
    let wanted = wanted_columns(opts);
    let mut columns: Vec<Column> = Vec::new();
    for w in &wanted {
        let found = header
            .iter()
            .position(|h| w.names.iter().any(|n| is_named(h, n)))
            .or_else(|| tag_suffixed(header, w, notes));
        if let Some(index) = found {
            let others: Vec<usize> = header
                .iter()
                .enumerate()
                .filter(|(i, h)| *i != index && w.names.iter().any(|n| is_named(h, n)))
                .map(|(i, _)| i + 1)
                .collect();
            if !others.is_empty() {
                notes.push(Note::new(NoteKind::Columns, format!(
                    "{}: {} columns match; using column {} ({:?}), ignoring column(s) {}; name the one you mean with --{}",
                    w.label,
                    others.len() + 1,
                    index + 1,
                    header[index],
                    others
                        .iter()
                        .map(|i| format!("{i} ({:?})", header[i - 1]))
                        .collect::<Vec<_>>()
                        .join(", "),
                    w.label.to_lowercase()
                )));
            }
        }
        match found {
            Some(index) => columns.push(Column {
                role: w.role,
                name: header[index].clone(),
                index,
                required: w.required,
                values: Vec::new(),
            }),
            None if w.required || w.explicit => {
                let tried = w
                    .names
                    .iter()
                    .map(|n| format!("{n:?}"))
                    .collect::<Vec<_>>()
                    .join(" or ");
                // A name the user gave is wrong as given; a default name is only the reader's
                // guess, and the option tells it another (the CLI's flag, Python's keyword).
                let hint = if w.explicit {
                    String::new()
                } else {
                    format!("; name yours with --{}", w.label.to_lowercase())
                };
                return Err(DataError::MissingColumn {
                    file: file.to_string(),
                    column: format!("{} ({tried}{hint})", w.label),
                    found: header.to_vec(),
                });
            }
            None => {}
        }
    }
    let ignored: Vec<&str> = header
        .iter()
        .enumerate()
        .filter(|(i, _)| !columns.iter().any(|c| c.index == *i))
        .map(|(_, h)| h.as_str())
        .collect();
    if !ignored.is_empty() {
        notes.push(Note::new(
            NoteKind::Columns,
            format!("ignored column(s): {}", ignored.join(", ")),
        ));
    }
    Ok(columns)
}

/// Whether the header cell `h` is the column named `n` (lower case): as written, or without
/// its unit ([`bare_name`]).
fn is_named(h: &str, n: &str) -> bool {
    h.trim().to_lowercase() == n || bare_name(h) == n
}

/// A column's name as matched against a role's: lower case, without surrounding blanks and
/// without a trailing unit in brackets or parentheses (`PV [m3/h]`, `OP (%)`).
fn bare_name(h: &str) -> String {
    let h = h.trim().to_lowercase();
    let open = match h.chars().last() {
        Some(')') => '(',
        Some(']') => '[',
        _ => return h,
    };
    match h.rfind(open) {
        Some(i) if !h[..i].trim().is_empty() => h[..i].trim().to_string(),
        _ => h,
    }
}

/// A historian's export names its columns by tag and parameter (`FIC101.PV`, `FIC101_OP`,
/// `FIC101 SP`): where no column has the role's own name, the one column whose name ends in
/// it after a separator (`.`, `_`, `:`, `-`, `/` or a space) takes the role, with a note; none
/// or several such columns leave the role unfound (several: name the one with the flag). Not
/// for a name the user gave, nor for MV (some vendors' `MV` is the controller's output, not
/// the valve's position) or time (`_t` may be a temperature).
fn tag_suffixed(header: &[String], w: &Wanted, notes: &mut Vec<Note>) -> Option<usize> {
    if w.explicit || matches!(w.role, Role::Mv | Role::Time) {
        return None;
    }
    let ends_in = |h: &str| {
        let h = bare_name(h);
        w.names.iter().any(|n| {
            h.len() > n.len()
                && h.ends_with(n.as_str())
                && h[..h.len() - n.len()].ends_with(['.', '_', ':', '-', '/', ' '])
        })
    };
    let mut matching = header.iter().enumerate().filter(|(_, h)| ends_in(h));
    let (index, name) = matching.next()?;
    if matching.next().is_some() {
        return None;
    }
    notes.push(Note::new(
        NoteKind::Columns,
        format!(
            "{}: read from column {} ({name:?}), whose name ends in it; name another with --{}",
            w.label,
            index + 1,
            w.label.to_lowercase()
        ),
    ));
    Some(index)
}

fn wanted_columns(opts: &ReadOptions) -> Vec<Wanted> {
    let mk = |role, label, given: &Option<String>, default: &[&str], required| Wanted {
        role,
        label,
        names: match given {
            Some(n) => vec![n.trim().to_lowercase()],
            None => default.iter().map(|s| s.to_string()).collect(),
        },
        required,
        explicit: given.is_some(),
    };
    vec![
        mk(
            Role::Time,
            "time",
            &opts.time,
            &["t", "time", "timestamp"],
            false,
        ),
        mk(Role::Sp, "SP", &opts.sp, &["sp"], false),
        mk(Role::Pv, "PV", &opts.pv, &["pv"], opts.require_pv),
        mk(Role::Op, "OP", &opts.op, &["op"], true),
        mk(Role::Mv, "MV", &opts.mv, &["mv"], false),
        mk(Role::Mode, "MODE", &opts.mode, &["mode"], false),
    ]
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn delimiter_detection() {
        assert_eq!(detect_delimiter("PV,OP\n1;2"), b',');
        assert_eq!(detect_delimiter("PV;OP;SP\n1,5;2;3"), b';');
        assert_eq!(detect_delimiter("PV\tOP\n1\t2"), b'\t');
        assert_eq!(detect_delimiter("OP"), b',');
    }

    #[test]
    fn timestamps_parse() {
        let a = parse_timestamp("2024-03-01T12:00:00Z").unwrap();
        let b = parse_timestamp("2024-03-01T13:00:01.5+01:00").unwrap();
        assert_eq!(b - a, 1_500_000_000);
        let c = parse_timestamp("2024-03-01 12:00:02.25").unwrap();
        assert_eq!(c - a, 2_250_000_000);
        let d = parse_timestamp("2024-03-01T12:00:03").unwrap();
        assert_eq!(d - a, 3_000_000_000);
        assert!(parse_timestamp("2024-13-01T12:00:00").is_none());
        assert!(parse_timestamp("yesterday").is_none());
    }

    #[test]
    fn interpolation_fills_inside_and_ends() {
        let mut v = vec![None, Some(1.0), None, None, Some(4.0), None];
        interpolate(&mut v);
        let v: Vec<f64> = v.into_iter().map(|x| x.unwrap()).collect();
        assert_eq!(v, vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
    }

    #[test]
    fn numbers_and_gaps() {
        let mut n = 0;
        assert!(matches!(parse_number("NaN", false, &mut n), Cell::Gap));
        assert!(matches!(parse_number("nan", false, &mut n), Cell::Gap));
        assert!(matches!(parse_number("", false, &mut n), Cell::Gap));
        assert!(matches!(
            parse_number("-inf", false, &mut n),
            Cell::NotFinite
        ));
        assert!(matches!(
            parse_number("1,5", false, &mut n),
            Cell::NotANumber
        ));
        assert!(matches!(parse_number("1,5", true, &mut n), Cell::Value(v) if v == 1.5));
        assert_eq!(n, 1);
    }
}
