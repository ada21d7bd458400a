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
    let csv_err = |file: &str, e: csv::Error| DataError::Csv {
        file: file.to_string(),
        row: e.position().map_or(0, |p| p.line()),
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
    for record in records {
        let record = record.map_err(|e| csv_err(&file, e))?;
        let row = record.position().map_or(0, |p| p.line());
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
            let value = if col.role == Role::Time {
                parse_time(text, &mut time_kind)
            } else if col.role == Role::Mode {
                parse_mode(text)
            } else {
                parse_number(text, delimiter == b';', &mut decimal_commas)
            };
            match value {
                Cell::Gap => col.values.push(None),
                Cell::Value(v) => col.values.push(Some(v)),
                bad if col.role == Role::Pv && !col.required => {
                    unread_pv.get_or_insert_with(|| {
                        refuse(bad, file.clone(), row, col.name.clone(), excerpt(text))
                    });
                    col.values.push(None);
                }
                bad => {
                    return Err(refuse(bad, file, row, col.name.clone(), excerpt(text)));
                }
            }
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
fn refuse(cell: Cell, file: String, row: u64, column: String, text: String) -> DataError {
    match cell {
        Cell::BadMode => DataError::BadMode {
            file,
            row,
            column,
            text,
        },
        Cell::NotFinite => DataError::NotFinite {
            file,
            row,
            column,
            text,
        },
        Cell::TooLarge => DataError::TooLarge {
            file,
            row,
            column,
            text,
        },
        Cell::BadTime => DataError::BadTime {
            file,
            row,
            column,
            text,
        },
        _ => DataError::NotANumber {
            file,
            row,
            column,
            text,
        },
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
                Role::Time => parse_time(text, &mut time_kind),
                Role::Mode => parse_mode(text),
                _ => parse_number(text, false, &mut decimal_commas),
            };
            match value {
                Cell::Gap => col.values.push(None),
                Cell::Value(v) => col.values.push(Some(v)),
                bad if col.role == Role::Pv && !col.required => {
                    unread_pv.get_or_insert_with(|| {
                        refuse(bad, file.clone(), row, col.name.clone(), excerpt(text))
                    });
                    col.values.push(None);
                }
                bad => return Err(refuse(bad, file, row, col.name.clone(), excerpt(text))),
            }
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
            .position(|h| w.names.iter().any(|n| h.to_lowercase() == *n));
        if let Some(index) = found {
            let others: Vec<usize> = header
                .iter()
                .enumerate()
                .filter(|(i, h)| *i != index && w.names.iter().any(|n| h.to_lowercase() == *n))
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
                return Err(DataError::MissingColumn {
                    file: file.to_string(),
                    column: format!("{} ({tried})", w.label),
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

/// Everything after the cells are parsed, shared by every reader entry: empty columns, unknown
/// modes, the gap policy, closed-loop selection, time checks, flat and constant columns, the
/// row count and the OP units.
fn finish(
    file: String,
    columns: Vec<Column>,
    mut lines: Vec<u64>,
    time_kind: Option<TimeKind>,
    decimal_commas: usize,
    mut notes: Vec<Note>,
    opts: &ReadOptions,
) -> Result<LoopData, DataError> {
    if decimal_commas > 0 {
        notes.push(Note::new(
            NoteKind::Format,
            format!("read {decimal_commas} cell(s) with a decimal comma"),
        ));
    }
    let needed = opts.min_rows.max(1);
    if lines.is_empty() {
        return Err(DataError::TooFewRows {
            file,
            needed,
            got: 0,
        });
    }

    // Columns without any value.
    let mut kept = Vec::with_capacity(columns.len());
    for col in columns {
        if col.values.iter().all(Option::is_none) {
            if col.required {
                return Err(DataError::AllGaps {
                    file,
                    column: col.name,
                });
            }
            notes.push(Note::new(
                NoteKind::Columns,
                format!("column {} ignored: every cell is empty or NaN", col.name),
            ));
        } else {
            kept.push(col);
        }
    }
    let mut columns = kept;

    // An empty mode cell is an unknown mode: not trusted as closed loop.
    for col in columns.iter_mut().filter(|c| c.role == Role::Mode) {
        let unknown = col.values.iter().filter(|v| v.is_none()).count();
        if unknown > 0 {
            notes.push(Note::new(
                NoteKind::Mode,
                format!(
                    "column {}: {unknown} empty cell(s), taken as not in closed loop",
                    col.name
                ),
            ));
            for v in &mut col.values {
                v.get_or_insert(0.0);
            }
        }
    }

    // Gaps.
    let gap_count: usize = columns
        .iter()
        .map(|c| c.values.iter().filter(|v| v.is_none()).count())
        .sum();
    if gap_count > 0 {
        let mut order: Vec<&Column> = columns.iter().collect();
        order.sort_by_key(|c| c.index);
        let first = (0..lines.len()).find_map(|i| {
            order
                .iter()
                .find(|c| c.values[i].is_none())
                .map(|c| (i, c.name.clone()))
        });
        match opts.gaps {
            GapPolicy::Refuse => {
                let (i, column) = first.unwrap_or((0, String::new()));
                return Err(DataError::Gaps {
                    file,
                    count: gap_count,
                    row: lines[i],
                    column,
                });
            }
            GapPolicy::FillHold => {
                for col in &mut columns {
                    let count = col.values.iter().filter(|v| v.is_none()).count();
                    if count == 0 {
                        continue;
                    }
                    let lead = col.values.iter().take_while(|v| v.is_none()).count();
                    if col.role == Role::Time {
                        interpolate(&mut col.values);
                        notes.push(Note::new(
                            NoteKind::GapsFilled,
                            format!(
                            "filled {count} gap(s) in column {} by linear interpolation of time",
                            col.name
                        ),
                        ));
                        continue;
                    }
                    if lead > 0 {
                        return Err(DataError::LeadingGap {
                            file,
                            row: lines[0],
                            column: col.name.clone(),
                            count: lead,
                        });
                    }
                    let mut last = None;
                    for v in &mut col.values {
                        match v {
                            Some(x) => last = Some(*x),
                            None => *v = last,
                        }
                    }
                    notes.push(Note::new(
                        NoteKind::GapsFilled,
                        format!(
                            "filled {count} gap(s) in column {} by holding the last value",
                            col.name
                        ),
                    ));
                }
            }
            GapPolicy::DropGaps => {
                let n = lines.len();
                let clean: Vec<bool> = (0..n)
                    .map(|i| columns.iter().all(|c| c.values[i].is_some()))
                    .collect();
                let (mut best, mut run_start) = ((0usize, 0usize), 0usize);
                for (i, ok) in clean.iter().chain(std::iter::once(&false)).enumerate() {
                    if !ok {
                        if i - run_start > best.1 - best.0 {
                            best = (run_start, i);
                        }
                        run_start = i + 1;
                    }
                }
                let (a, b) = best;
                if b > a {
                    notes.push(Note::new(
                        NoteKind::RowsDropped,
                        format!(
                            "dropped gaps: kept rows {}-{} ({} of {} data rows), the longest \
                         segment without empty or NaN cells ({gap_count} gap cell(s) in total)",
                            lines[a],
                            lines[b - 1],
                            b - a,
                            n
                        ),
                    ));
                } else {
                    notes.push(Note::new(
                        NoteKind::RowsDropped,
                        format!(
                            "dropped gaps: no data row is free of empty or NaN cells ({n} rows)"
                        ),
                    ));
                }
                for col in &mut columns {
                    col.values = col.values[a..b].to_vec();
                }
                lines = lines[a..b].to_vec();
            }
        }
    }

    let mode_cut = select_closed_loop(&file, &mut columns, &mut lines, &mut notes)?;
    check_time(&file, opts.gaps, &mut columns, &mut lines, &mut notes)?;
    keep_window(&mut columns, &mut lines, opts.window, &mut notes);
    check_flat(&file, &columns, &lines, opts.accept_constant, &mut notes)?;
    check_compression(&columns, &mut notes);
    check_quantisation(&columns, &mut notes);

    let n = lines.len();
    if let Some((column, total)) = mode_cut.filter(|_| n < needed) {
        return Err(DataError::TooFewClosedLoopRows {
            file,
            column,
            needed,
            got: n,
            total,
        });
    }
    if n < needed {
        return Err(DataError::TooFewRows {
            file,
            needed,
            got: n,
        });
    }

    let mut data = LoopData {
        source: file.clone(),
        start: None,
        t: None,
        sp: None,
        pv: None,
        op: Vec::new(),
        mv: None,
        notes,
    };
    for col in columns {
        let mut values: Vec<f64> = col
            .values
            .into_iter()
            .map(|v| v.unwrap_or(f64::NAN))
            .collect();
        if matches!(col.role, Role::Sp | Role::Pv | Role::Op | Role::Mv) {
            if let Some(note) = spike_note(&col.name, &mut values, &lines) {
                data.notes.push(note);
            }
        }
        match col.role {
            Role::Time => {
                let t0 = values[0];
                if let Some(TimeKind::Stamp(ns)) = time_kind {
                    data.start = Some(ns as f64 / 1e9 + t0);
                }
                for v in &mut values {
                    *v -= t0;
                }
                data.t = Some(values);
            }
            Role::Sp => data.sp = Some(values),
            Role::Pv => {
                check_constant(&file, &col.name, &values, opts, &mut data.notes)?;
                data.pv = Some(values);
            }
            Role::Op => {
                check_constant(&file, &col.name, &values, opts, &mut data.notes)?;
                data.op = values;
            }
            Role::Mv => data.mv = Some(values),
            Role::Mode => {}
        }
    }
    let units =
        crate::units::op_units(&data.op, opts.op_range).map_err(|message| DataError::OpRange {
            file: file.clone(),
            message,
        })?;
    if units.span.is_some() {
        for v in data.op.iter_mut().chain(data.mv.iter_mut().flatten()) {
            *v = units.to_percent(*v);
        }
    }
    if let Some(note) = units.note {
        data.notes.push(Note::new(NoteKind::Units, note));
    }
    Ok(data)
}

/// A constant PV or OP: refused, or kept with a note under [`ReadOptions::accept_constant`].
fn check_constant(
    file: &str,
    column: &str,
    values: &[f64],
    opts: &ReadOptions,
    notes: &mut Vec<Note>,
) -> Result<(), DataError> {
    match values.first() {
        Some(&v0) if values.iter().all(|&v| v == v0) => {
            let e = DataError::Constant {
                file: file.to_string(),
                column: column.to_string(),
                value: v0,
                rows: values.len(),
            };
            if !opts.accept_constant {
                return Err(e);
            }
            notes.push(Note::new(
                NoteKind::Flat,
                format!(
                    "column {column}: constant ({v0:?}) over all {} rows; kept",
                    values.len()
                ),
            ));
            Ok(())
        }
        _ => Ok(()),
    }
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
        mk(Role::Time, "time", &opts.time, &["t", "time"], false),
        mk(Role::Sp, "SP", &opts.sp, &["sp"], false),
        mk(Role::Pv, "PV", &opts.pv, &["pv"], opts.require_pv),
        mk(Role::Op, "OP", &opts.op, &["op"], true),
        mk(Role::Mv, "MV", &opts.mv, &["mv"], false),
        mk(Role::Mode, "MODE", &opts.mode, &["mode"], false),
    ]
}

/// `,` unless the first line has more `;` or tabs than commas.
fn detect_delimiter(text: &str) -> u8 {
    let first = text.lines().next().unwrap_or("");
    let count = |c: char| first.chars().filter(|&x| x == c).count();
    let (comma, semi, tab) = (count(','), count(';'), count('\t'));
    if tab > comma && tab >= semi {
        b'\t'
    } else if semi > comma {
        b';'
    } else {
        b','
    }
}

/// Values of this magnitude or more are refused: the solvers square the data (sums of squares
/// over up to 1e6 rows, about 1e126 at this limit) and multiply such sums together (about
/// 1e252), which must stay finite. 1e150 passed and three such cells made the fit's residual
/// overflow (F_PV = -1.7e296 %). [`grid_search`] refuses the same.
pub const TOO_LARGE: f64 = 1e60;

enum Cell {
    Gap,
    Value(f64),
    NotANumber,
    NotFinite,
    /// Finite but too large to compute with (|x| >= [`TOO_LARGE`]).
    TooLarge,
    BadTime,
    BadMode,
}

fn is_gap(text: &str) -> bool {
    text.is_empty() || text.eq_ignore_ascii_case("nan")
}

fn parse_number(text: &str, decimal_comma: bool, decimal_commas: &mut usize) -> Cell {
    if is_gap(text) {
        return Cell::Gap;
    }
    let parsed = text.parse::<f64>().ok().or_else(|| {
        if decimal_comma && text.matches(',').count() == 1 && !text.contains('.') {
            let v = text.replace(',', ".").parse::<f64>().ok();
            if v.is_some() {
                *decimal_commas += 1;
            }
            v
        } else {
            None
        }
    });
    match parsed {
        None => Cell::NotANumber,
        Some(v) if v.is_nan() => Cell::Gap,
        Some(v) if v.is_infinite() => Cell::NotFinite,
        Some(v) if v.abs() >= TOO_LARGE => Cell::TooLarge,
        Some(v) => Cell::Value(v),
    }
}

/// A controller-mode cell: `Value(1.0)` closed loop, `Value(0.0)` open loop.
fn parse_mode(text: &str) -> Cell {
    if text.is_empty() {
        return Cell::Gap;
    }
    if let Ok(v) = text.parse::<f64>() {
        return if v.is_nan() {
            Cell::Gap
        } else if v == 0.0 {
            Cell::Value(0.0)
        } else {
            Cell::Value(1.0)
        };
    }
    const CLOSED: [&str; 8] = [
        "auto", "aut", "a", "cas", "cascade", "rcas", "normal", "closed",
    ];
    const OPEN: [&str; 9] = [
        "man", "manual", "m", "iman", "lo", "oos", "open", "track", "trk",
    ];
    let t = text.to_ascii_lowercase();
    if CLOSED.contains(&t.as_str()) {
        Cell::Value(1.0)
    } else if OPEN.contains(&t.as_str()) {
        Cell::Value(0.0)
    } else {
        Cell::BadMode
    }
}

/// Keep only the rows in `a..b`.
fn keep_rows(columns: &mut [Column], lines: &mut Vec<u64>, a: usize, b: usize) {
    for col in columns.iter_mut() {
        col.values = col.values[a..b].to_vec();
    }
    *lines = lines[a..b].to_vec();
}

/// Keep the latest `window` rows of a longer record, with a note naming the rows kept.
fn keep_window(columns: &mut [Column], lines: &mut Vec<u64>, window: usize, notes: &mut Vec<Note>) {
    let n = lines.len();
    if window == 0 || n <= window {
        return;
    }
    let a = n - window;
    notes.push(Note::new(
        NoteKind::Window,
        format!(
            "analysed the latest {window} of {n} rows (rows {}-{}): S, J and the verdict describe \
             the valve at the end of the record (the window, --window N, bounds the time a long \
             record takes)",
            lines[a],
            lines[n - 1]
        ),
    ));
    keep_rows(columns, lines, a, n);
}

/// The longest run of `true` (earliest on ties), as `a..b`.
fn longest_run(flags: &[bool]) -> (usize, usize) {
    let (mut best, mut start) = ((0usize, 0usize), 0usize);
    for (i, ok) in flags.iter().chain(std::iter::once(&false)).enumerate() {
        if !ok {
            if i - start > best.1 - best.0 {
                best = (start, i);
            }
            start = i + 1;
        }
    }
    best
}

/// Keep the longest closed-loop segment when a mode column says some rows are not; drop the
/// mode column.
fn select_closed_loop(
    file: &str,
    columns: &mut Vec<Column>,
    lines: &mut Vec<u64>,
    notes: &mut Vec<Note>,
) -> Result<Option<(String, usize)>, DataError> {
    let Some(mi) = columns.iter().position(|c| c.role == Role::Mode) else {
        return Ok(None);
    };
    let mut cut = None;
    let closed: Vec<bool> = columns[mi].values.iter().map(|v| *v == Some(1.0)).collect();
    let n = closed.len();
    let open = closed.iter().filter(|c| !**c).count();
    if open > 0 {
        let (a, b) = longest_run(&closed);
        if b == a {
            return Err(DataError::NoClosedLoop {
                file: file.to_string(),
                column: columns[mi].name.clone(),
                rows: n,
            });
        }
        let stretches = closed
            .iter()
            .enumerate()
            .filter(|(i, c)| !**c && (*i == 0 || closed[i - 1]))
            .count();
        notes.push(Note::new(NoteKind::Mode, format!(
            "column {}: {open} of {n} rows not in closed loop (manual or unknown mode, {stretches} stretch(es)); kept rows {}-{} ({} rows), the longest closed-loop segment",
            columns[mi].name,
            lines[a],
            lines[b - 1],
            b - a
        )));
        keep_rows(columns, lines, a, b);
        cut = Some((columns[mi].name.clone(), n));
    }
    columns.remove(mi);
    Ok(cut)
}

/// Strictly increasing time; missing samples by the gap policy; jitter reported.
fn check_time(
    file: &str,
    gaps: GapPolicy,
    columns: &mut [Column],
    lines: &mut Vec<u64>,
    notes: &mut Vec<Note>,
) -> Result<(), DataError> {
    let Some(ti) = columns.iter().position(|c| c.role == Role::Time) else {
        return Ok(());
    };
    let t: Vec<f64> = columns[ti]
        .values
        .iter()
        .map(|v| v.unwrap_or(f64::NAN))
        .collect();
    if t.len() < 2 {
        return Ok(());
    }
    let name = columns[ti].name.clone();
    let bad: Vec<usize> = (1..t.len())
        .filter(|&i| t[i].partial_cmp(&t[i - 1]) != Some(std::cmp::Ordering::Greater))
        .collect();
    if let Some(&i) = bad.first() {
        return Err(DataError::TimeNotIncreasing {
            file: file.to_string(),
            row: lines[i],
            column: name,
            value: t[i] - t[0],
            previous: t[i - 1] - t[0],
            count: bad.len(),
        });
    }
    let dt: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mut sorted = dt.clone();
    sorted.sort_by(f64::total_cmp);
    let ts = sorted[sorted.len() / 2];
    let long: Vec<usize> = (0..dt.len()).filter(|&i| dt[i] > 1.5 * ts).collect();
    if let Some(&i) = long.first() {
        let largest = long.iter().map(|&k| dt[k]).fold(0.0, f64::max);
        match gaps {
            GapPolicy::Refuse => {
                return Err(DataError::TimeGaps {
                    file: file.to_string(),
                    row: lines[i + 1],
                    column: name,
                    count: long.len(),
                    gap: dt[i],
                    ts,
                })
            }
            GapPolicy::DropGaps => {
                let regular: Vec<bool> = (0..t.len())
                    .map(|k| k == 0 || dt[k - 1] <= 1.5 * ts)
                    .collect();
                // A segment starts at a row whose previous interval is long (or at row 0).
                let mut best = (0usize, 0usize);
                let mut start = 0usize;
                for (k, &ok) in regular
                    .iter()
                    .chain(std::iter::once(&false))
                    .enumerate()
                    .skip(1)
                {
                    if !ok {
                        if k - start > best.1 - best.0 {
                            best = (start, k);
                        }
                        start = k;
                    }
                }
                let (a, b) = best;
                notes.push(Note::new(NoteKind::RowsDropped, format!(
                    "column {name}: {} interval(s) longer than 1.5 x the median sampling time {ts} s (up to {largest} s): kept rows {}-{} ({} rows), the longest regularly sampled segment",
                    long.len(),
                    lines[a],
                    lines[b - 1],
                    b - a
                )));
                keep_rows(columns, lines, a, b);
            }
            GapPolicy::FillHold => {
                let mut inserted = 0usize;
                let n = t.len();
                let mut new_cols: Vec<Vec<Option<f64>>> = vec![Vec::new(); columns.len()];
                let mut new_lines = Vec::new();
                for k in 0..n {
                    for (c, col) in columns.iter().enumerate() {
                        new_cols[c].push(col.values[k]);
                    }
                    new_lines.push(lines[k]);
                    if k + 1 < n && dt[k] > 1.5 * ts {
                        let missing = ((dt[k] / ts).round() as usize)
                            .saturating_sub(1)
                            .min(1_000_000);
                        for j in 1..=missing {
                            for (c, col) in columns.iter().enumerate() {
                                let v = if c == ti {
                                    Some(t[k] + j as f64 * ts)
                                } else {
                                    col.values[k]
                                };
                                new_cols[c].push(v);
                            }
                            new_lines.push(lines[k]);
                        }
                        inserted += missing;
                    }
                }
                for (col, v) in columns.iter_mut().zip(new_cols) {
                    col.values = v;
                }
                *lines = new_lines;
                notes.push(Note::new(NoteKind::RowsInserted, format!(
                    "column {name}: {} interval(s) longer than 1.5 x the median sampling time {ts} s (up to {largest} s): inserted {inserted} row(s) holding the last values, at the median sampling time",
                    long.len()
                )));
            }
        }
    }
    let t: Vec<f64> = columns[ti]
        .values
        .iter()
        .map(|v| v.unwrap_or(f64::NAN))
        .collect();
    let dt: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let (lo, hi) = dt
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &d| {
            (l.min(d), h.max(d))
        });
    if !dt.is_empty() && ts > 0.0 && (hi - lo) > 1e-6 * ts {
        let dev = ((hi - ts).abs().max((ts - lo).abs())) / ts * 100.0;
        let irregular = dt.iter().filter(|&&d| (d - ts).abs() > 1e-6 * ts).count();
        notes.push(Note::new(NoteKind::Jitter, format!(
            "column {name}: sampling jitter: {irregular} of {} intervals differ from the median {ts} s (from {lo} to {hi} s, up to {dev:.1} %); treated as uniformly sampled",
            dt.len()
        )));
    }
    Ok(())
}

/// Records shorter than this are not checked for flat stretches (a handful of rows, often
/// filled by holding, says nothing about historian compression).
const FLAT_MIN_ROWS: usize = 20;

/// Exactly repeated PV / OP values: noted, refused over more than half of the rows (kept with a
/// note under [`ReadOptions::accept_constant`]: a detector answers such a record itself).
fn check_flat(
    file: &str,
    columns: &[Column],
    lines: &[u64],
    accept: bool,
    notes: &mut Vec<Note>,
) -> Result<(), DataError> {
    let n = lines.len();
    if n < FLAT_MIN_ROWS {
        return Ok(());
    }
    for col in columns
        .iter()
        .filter(|c| matches!(c.role, Role::Pv | Role::Op))
    {
        let v = &col.values;
        let repeats = (1..n).filter(|&i| v[i] == v[i - 1]).count();
        let (mut best, mut best_start, mut run_start) = (1usize, 0usize, 0usize);
        for i in 1..=n {
            if i == n || v[i] != v[i - 1] {
                if i - run_start > best {
                    best = i - run_start;
                    best_start = run_start;
                }
                run_start = i;
            }
        }
        if best == n {
            continue; // constant: refused later with its own message
        }
        if 2 * best > n && accept {
            notes.push(Note::new(NoteKind::Flat, format!(
                "column {}: the same value for {best} of {n} rows from row {} (a stuck valve, a frozen transmitter or historian compression); kept",
                col.name, lines[best_start]
            )));
            continue;
        }
        if 2 * best > n {
            return Err(DataError::Flat {
                file: file.to_string(),
                row: lines[best_start],
                column: col.name.clone(),
                run: best,
                rows: n,
            });
        }
        if best >= 5 || 20 * repeats >= n {
            notes.push(Note::new(NoteKind::Flat, format!(
                "column {}: {repeats} of {n} samples repeat the previous value exactly, the longest flat stretch {best} samples from row {} (historian compression or a frozen value?); kept",
                col.name, lines[best_start]
            )));
        }
    }
    Ok(())
}

/// What [`compression`] found in a column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Compression {
    /// Share of the samples on straight sloped segments of at least four points.
    pub share: f64,
    /// Number of such segments.
    pub segments: usize,
    /// Their median length, samples.
    pub median_len: usize,
}

/// Samples on straight lines are recognised to this relative round-off of the column's
/// magnitude (an interpolation in double precision is straight to about 1e-15).
const STRAIGHT_RELATIVE: f64 = 1e-9;

/// Historian compression read back by linear interpolation (swinging door, box-car): long
/// runs of samples exactly on a sloped straight line, with kinks where a kept point was.
///
/// A sample `t` is *straight* when its second difference is zero to the data's resolution,
/// `|x(t+1) − 2 x(t) + x(t−1)| <= tol`, and the line is not flat (`|x(t) − x(t−1)| > tol`;
/// flat stretches are [`NoteKind::Flat`]'s). `tol` is the larger of 1e-9 of the column's
/// magnitude (round-off of an interpolation) and 2.01 times its smallest nonzero increment
/// (values written with a fixed number of decimals move by multiples of one quantum `q`, and an
/// interpolated value rounded to `q` has a second difference of at most `2q`; the smallest
/// increment is a multiple of `q`, so this never tolerates less than rounding does). A
/// *segment* is a maximal run of straight samples: `k` straight samples make `k + 2` collinear
/// points; only segments of at least four points count, so a single straight triple (which
/// noise makes by chance) does not.
///
/// Decision, from the physics rather than from fitted thresholds: a measured, noisy PV has a
/// second difference of the order of its noise at nearly every sample, so at most a few
/// percent of its samples fall on 4-point straight runs; a PV read back from compressed storage
/// is straight almost everywhere between its kept points. The column is called compressed when
/// at least half of its samples lie on such segments and there are at least three segments (a
/// single ramp is not an archive's pattern). `None` for fewer than `FLAT_MIN_ROWS` samples or
/// a non-finite value.
pub fn compression(x: &[f64]) -> Option<Compression> {
    let n = x.len();
    if n < FLAT_MIN_ROWS || x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let quantum = x
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min);
    if !quantum.is_finite() {
        return None; // constant
    }
    let tol = (STRAIGHT_RELATIVE * scale).max(2.01 * quantum);
    let straight =
        |t: usize| (x[t + 1] - 2.0 * x[t] + x[t - 1]).abs() <= tol && (x[t] - x[t - 1]).abs() > tol;
    let (mut covered, mut lens) = (0usize, Vec::new());
    let mut t = 1;
    while t + 1 < n {
        if !straight(t) {
            t += 1;
            continue;
        }
        let start = t;
        while t + 1 < n && straight(t) {
            t += 1;
        }
        let k = t - start;
        if k >= 2 {
            covered += k + 2;
            lens.push(k + 2);
        }
    }
    if lens.len() < 3 {
        return Some(Compression {
            share: covered as f64 / n as f64,
            segments: lens.len(),
            median_len: lens.iter().copied().max().unwrap_or(0),
        });
    }
    lens.sort_unstable();
    Some(Compression {
        // segments share their end points (the kept points): count each sample once
        share: (covered.saturating_sub(lens.len() - 1) as f64 / n as f64).min(1.0),
        segments: lens.len(),
        median_len: lens[lens.len() / 2],
    })
}

/// Share of the samples on straight segments from which a column is called compressed.
///
/// Measured: the shared plant registrations (measured values) reach at most 2.5 % (PV or OP,
/// `tests/compression.rs`); a swinging door of 0.3 PV units on a noisy slow loop leaves 32 %
/// of the samples straight (the hidden-effect suite's seed 1056), 0.5-0.8 units 92-100 %. At
/// 0.5 that light compression went unnoticed and its S (2.1 for a true 9.6) unflagged; 0.2 is
/// eight times the plant's largest share.
pub const COMPRESSED_SHARE: f64 = 0.2;

impl Compression {
    /// At least [`COMPRESSED_SHARE`] of the samples on at least three straight segments.
    pub fn detected(&self) -> bool {
        self.share >= COMPRESSED_SHARE && self.segments >= 3
    }
}

fn check_compression(columns: &[Column], notes: &mut Vec<Note>) {
    for col in columns
        .iter()
        .filter(|c| matches!(c.role, Role::Pv | Role::Op))
    {
        let v: Vec<f64> = col.values.iter().map(|v| v.unwrap_or(f64::NAN)).collect();
        if let Some(c) = compression(&v).filter(Compression::detected) {
            notes.push(Note::new(
                NoteKind::Compression,
                format!(
                    "column {}: {:.0} % of the samples lie on {} straight sloped segments (median {} samples) with kinks between them, as a historian's compressed storage read back by linear interpolation makes; fits on the interpolated values are biased, so treat S and J with caution; kept",
                    col.name,
                    100.0 * c.share,
                    c.segments,
                    c.median_len
                ),
            ));
        }
    }
}

/// A quantised column is noted when its step is at least this share of its median move
/// between samples (coarse relative to its motion; `crate::quantisation`).
pub const QUANTISED_SHARE: f64 = 0.01;

/// PV and OP on a lattice (`crate::quantisation::step`) coarse relative to their motion: a
/// note with the step and its share of the median move (records of `FLAT_MIN_ROWS` rows or
/// more, as for flat stretches).
fn check_quantisation(columns: &[Column], notes: &mut Vec<Note>) {
    if columns
        .first()
        .is_none_or(|c| c.values.len() < FLAT_MIN_ROWS)
    {
        return;
    }
    for col in columns
        .iter()
        .filter(|c| matches!(c.role, Role::Pv | Role::Op))
    {
        let v: Vec<f64> = col.values.iter().map(|v| v.unwrap_or(f64::NAN)).collect();
        let (Some(q), Some(m)) = (
            crate::quantisation::step(&v),
            crate::quantisation::median_move(&v),
        ) else {
            continue;
        };
        if q < QUANTISED_SHARE * m {
            continue;
        }
        let what = if matches!(col.role, Role::Op) {
            "the diagnosis takes valve thresholds within one step for the same (a slip within a step of its threshold is hidden by the rounding)"
        } else {
            "the rounding adds about the step squared over 12 to its noise variance"
        };
        notes.push(Note::new(
            NoteKind::Quantised,
            format!(
                "column {}: values on a lattice of step {} ({} % of its median move between samples), as counts or a fixed number of decimals write them; {what}; kept",
                col.name,
                crate::units::sig(q),
                crate::units::sig(100.0 * q / m)
            ),
        ));
    }
}

fn parse_time(text: &str, kind: &mut Option<TimeKind>) -> Cell {
    if is_gap(text) {
        return Cell::Gap;
    }
    match text.parse::<f64>() {
        Ok(v) if v.is_nan() => return Cell::Gap,
        Ok(v) => {
            return match kind {
                None | Some(TimeKind::Seconds) if v.is_finite() => {
                    *kind = Some(TimeKind::Seconds);
                    Cell::Value(v)
                }
                None | Some(TimeKind::Seconds) => Cell::NotFinite,
                Some(TimeKind::Stamp(_)) => Cell::BadTime,
            }
        }
        Err(_) => {}
    }
    let Some(ns) = parse_timestamp(text) else {
        return Cell::BadTime;
    };
    match kind {
        None => {
            *kind = Some(TimeKind::Stamp(ns));
            Cell::Value(0.0)
        }
        Some(TimeKind::Stamp(t0)) => Cell::Value((ns as i128 - *t0 as i128) as f64 / 1e9),
        Some(TimeKind::Seconds) => Cell::BadTime,
    }
}

/// Nanoseconds since the epoch (UTC; timestamps without an offset are taken as UTC).
fn parse_timestamp(text: &str) -> Option<i64> {
    use chrono::{DateTime, NaiveDateTime};
    if let Ok(dt) = DateTime::parse_from_rfc3339(text) {
        return dt.timestamp_nanos_opt();
    }
    for fmt in ["%Y-%m-%dT%H:%M:%S%.f", "%Y-%m-%d %H:%M:%S%.f"] {
        if let Ok(dt) = NaiveDateTime::parse_from_str(text, fmt) {
            return dt.and_utc().timestamp_nanos_opt();
        }
    }
    None
}

/// Fill `None`s by linear interpolation; ends extrapolated with the nearest step. At least one
/// value must be present.
fn interpolate(values: &mut [Option<f64>]) {
    let known: Vec<(usize, f64)> = values
        .iter()
        .enumerate()
        .filter_map(|(i, v)| v.map(|x| (i, x)))
        .collect();
    let Some(&(first_i, first_v)) = known.first() else {
        return;
    };
    let step_at = |w: &[(usize, f64)]| match w {
        [(i0, v0), (i1, v1), ..] => (v1 - v0) / (*i1 - *i0) as f64,
        _ => 1.0,
    };
    let lead_step = step_at(&known);
    let tail: Vec<(usize, f64)> = known.iter().rev().take(2).rev().copied().collect();
    let tail_step = step_at(&tail);
    let &(last_i, last_v) = known.last().unwrap_or(&(first_i, first_v));
    for (i, v) in values.iter_mut().enumerate() {
        if v.is_some() {
            continue;
        }
        *v = Some(if i < first_i {
            first_v - lead_step * (first_i - i) as f64
        } else if i > last_i {
            last_v + tail_step * (i - last_i) as f64
        } else {
            let k = known.partition_point(|&(j, _)| j < i);
            let (i0, v0) = known[k - 1];
            let (i1, v1) = known[k];
            v0 + (v1 - v0) * (i - i0) as f64 / (i1 - i0) as f64
        });
    }
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
