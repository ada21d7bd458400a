//! One cell's text to a value: the delimiter, numbers (decimal comma too), modes, times.

use super::*;

/// `,` unless the first line has more `;` or tabs than commas.
pub(crate) fn detect_delimiter(text: &str) -> u8 {
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

pub(crate) enum Cell {
    Gap,
    Value(f64),
    NotANumber,
    NotFinite,
    /// Finite but too large to compute with (|x| >= [`TOO_LARGE`]).
    TooLarge,
    BadTime,
    BadMode,
}

pub(crate) fn is_gap(text: &str) -> bool {
    text.is_empty() || text.eq_ignore_ascii_case("nan")
}

pub(crate) fn parse_number(text: &str, decimal_comma: bool, decimal_commas: &mut usize) -> Cell {
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
pub(crate) fn parse_mode(text: &str) -> Cell {
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

/// A time cell: seconds (with a decimal comma where the file's delimiter is `;`, counted in
/// `decimal_commas` as the values' are), or a timestamp ([`parse_timestamp`]); one kind per
/// column.
pub(crate) fn parse_time(
    text: &str,
    kind: &mut Option<TimeKind>,
    decimal_comma: bool,
    decimal_commas: &mut usize,
) -> Cell {
    if is_gap(text) {
        return Cell::Gap;
    }
    let seconds = text.parse::<f64>().or_else(|e| {
        if decimal_comma && text.matches(',').count() == 1 && !text.contains('.') {
            let v = text.replace(',', ".").parse::<f64>();
            if v.is_ok() {
                *decimal_commas += 1;
            }
            v
        } else {
            Err(e)
        }
    });
    match seconds {
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

/// Nanoseconds since the epoch (UTC; timestamps without an offset are taken as UTC): RFC 3339,
/// `YYYY-MM-DD[T ]HH:MM:SS[.fff]`, `YYYY-MM-DD HH:MM`, `YYYY/MM/DD HH:MM:SS[.fff]`, and the
/// day-first `DD.MM.YYYY HH:MM[:SS[.fff]]` that spreadsheets write in locales with a decimal
/// comma (the dots make the order unambiguous; a slash-separated date is not read, since
/// `03/04/2024` is March or April by locale); the seconds' fraction after a `.` or a `,`.
pub(crate) fn parse_timestamp(text: &str) -> Option<i64> {
    use chrono::{DateTime, NaiveDateTime};
    if let Ok(dt) = DateTime::parse_from_rfc3339(text) {
        return dt.timestamp_nanos_opt();
    }
    const FORMATS: [&str; 7] = [
        "%Y-%m-%dT%H:%M:%S%.f",
        "%Y-%m-%d %H:%M:%S%.f",
        "%Y-%m-%d %H:%M",
        "%Y/%m/%d %H:%M:%S%.f",
        "%d.%m.%Y %H:%M:%S%.f",
        "%d.%m.%Y %H:%M",
        "%Y-%m-%dT%H:%M",
    ];
    for fmt in FORMATS {
        if let Ok(dt) = NaiveDateTime::parse_from_str(text, fmt) {
            return dt.and_utc().timestamp_nanos_opt();
        }
    }
    // ISO 8601 allows a comma before the fraction of a second, and decimal-comma locales write it
    if text.matches(',').count() == 1 {
        return parse_timestamp(&text.replace(',', "."));
    }
    None
}
