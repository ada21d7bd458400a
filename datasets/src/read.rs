//! The CSV reader.
//!
//! Contract (`spec/CLI.md`, "Input data"): a header row; `,` as delimiter, or `;` / tab when the
//! header line shows them; columns found by name case-insensitively (`PV`, `OP`, `SP`, `MV`,
//! `t` / `time`), others ignored; empty or `NaN` cells are gaps, refused by default.

use std::io::Read;
use std::path::Path;

use crate::{DataError, LoopData};

/// What to do with empty or `NaN` cells in the used columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
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

/// Options of [`read_csv`].
///
/// | field | default | meaning |
/// |-------|---------|---------|
/// | `pv`, `op`, `sp`, `mv` | `None` | header name of that column (case-insensitive); `None` = the column named `PV`, `OP`, `SP`, `MV` |
/// | `time` | `None` | header name of the time column; `None` = `t` or `time` |
/// | `require_pv` | `true` | a missing PV column is an error; when `false`, PV is read if present |
/// | `gaps` | [`GapPolicy::Refuse`] | handling of empty / NaN cells |
/// | `min_rows` | 3 | minimum number of data rows after gap handling (at least 1 is always required) |
///
/// A column named explicitly (`Some`) must exist, even an optional one; an optional column
/// found by its default name whose cells are all empty or NaN is ignored with a note.
#[derive(Debug, Clone, PartialEq, Eq)]
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
}

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

/// Read one loop registration from CSV text; `source` names it in messages.
///
/// Never panics: any input yields either data or a [`DataError`].
pub fn read_csv(
    mut reader: impl Read,
    source: &str,
    opts: &ReadOptions,
) -> Result<LoopData, DataError> {
    let file = source.to_string();
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|error| DataError::Io {
            file: file.clone(),
            error,
        })?;
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
    // A quoted header cell may span lines; messages name columns on one line.
    let header: Vec<String> = header
        .iter()
        .map(|h| h.replace(['\r', '\n'], " "))
        .collect();
    if header.iter().all(String::is_empty) {
        return Err(DataError::Empty { file });
    }

    // Locate the columns.
    let wanted = wanted_columns(opts);
    let mut columns: Vec<Column> = Vec::new();
    for w in &wanted {
        let found = header
            .iter()
            .position(|h| w.names.iter().any(|n| h.to_lowercase() == *n));
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
                    file,
                    column: format!("{} ({tried})", w.label),
                    found: header,
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
        notes.push(format!("ignored column(s): {}", ignored.join(", ")));
    }

    // Parse the rows.
    let mut lines: Vec<u64> = Vec::new();
    let mut time_kind: Option<TimeKind> = None;
    let mut decimal_commas = 0usize;
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
        lines.push(row);
        for col in &mut columns {
            let text = &record[col.index];
            let value = if col.role == Role::Time {
                parse_time(text, &mut time_kind)
            } else {
                parse_number(text, delimiter == b';', &mut decimal_commas)
            };
            match value {
                Cell::Gap => col.values.push(None),
                Cell::Value(v) => col.values.push(Some(v)),
                Cell::NotANumber | Cell::NotFinite | Cell::BadTime => {
                    let (file, column, text) = (file, col.name.clone(), text.to_string());
                    return Err(match value {
                        Cell::NotFinite => DataError::NotFinite {
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
                    });
                }
            }
        }
    }
    if decimal_commas > 0 {
        notes.push(format!(
            "read {decimal_commas} cell(s) with a decimal comma"
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
            notes.push(format!(
                "column {} ignored: every cell is empty or NaN",
                col.name
            ));
        } else {
            kept.push(col);
        }
    }
    let mut columns = kept;

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
                        notes.push(format!(
                            "filled {count} gap(s) in column {} by linear interpolation of time",
                            col.name
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
                    notes.push(format!(
                        "filled {count} gap(s) in column {} by holding the last value",
                        col.name
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
                    notes.push(format!(
                        "dropped gaps: kept rows {}-{} ({} of {} data rows), the longest \
                         segment without empty or NaN cells ({gap_count} gap cell(s) in total)",
                        lines[a],
                        lines[b - 1],
                        b - a,
                        n
                    ));
                } else {
                    notes.push(format!(
                        "dropped gaps: no data row is free of empty or NaN cells ({n} rows)"
                    ));
                }
                for col in &mut columns {
                    col.values = col.values[a..b].to_vec();
                }
                lines = lines[a..b].to_vec();
            }
        }
    }

    let n = lines.len();
    if n < needed {
        return Err(DataError::TooFewRows {
            file,
            needed,
            got: n,
        });
    }

    let mut data = LoopData {
        source: file.clone(),
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
        match col.role {
            Role::Time => {
                let t0 = values[0];
                for v in &mut values {
                    *v -= t0;
                }
                data.t = Some(values);
            }
            Role::Sp => data.sp = Some(values),
            Role::Pv => {
                check_constant(&file, &col.name, &values)?;
                data.pv = Some(values);
            }
            Role::Op => {
                check_constant(&file, &col.name, &values)?;
                data.op = values;
            }
            Role::Mv => data.mv = Some(values),
        }
    }
    Ok(data)
}

fn check_constant(file: &str, column: &str, values: &[f64]) -> Result<(), DataError> {
    match values.first() {
        Some(&v0) if values.iter().all(|&v| v == v0) => Err(DataError::Constant {
            file: file.to_string(),
            column: column.to_string(),
            value: v0,
            rows: values.len(),
        }),
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

enum Cell {
    Gap,
    Value(f64),
    NotANumber,
    NotFinite,
    BadTime,
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
        Some(v) => Cell::Value(v),
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
