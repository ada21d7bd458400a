//! Which valve a registration belongs to and when it was recorded, from its file name.
//!
//! Convention (the plant data's): `<valve>_<YYYYMMDD>-<HHMM>.<ext>`, e.g.
//! `2411FIC20102_20240609-0750.csv`. The valve is the file stem up to the first `_` (the whole
//! stem when there is none); the time is the last `_`-separated part when it reads as
//! `YYYYMMDD-HHMM`, `YYYYMMDD-HHMMSS`, `YYYYMMDDTHHMM[SS]` or `YYYYMMDD` (taken as UTC).

use chrono::{DateTime, NaiveDate, NaiveDateTime};

/// Valve and start time read from a file name.
#[derive(Debug, Clone, PartialEq)]
pub struct RegistrationName {
    /// The valve (loop tag): the file stem up to the first `_`.
    pub valve: String,
    /// Start time, seconds since the Unix epoch (UTC), when the name carries one.
    pub start: Option<f64>,
}

/// Read the valve and the start time from a file name (a path's last component is used).
pub fn parse_registration_name(file_name: &str) -> RegistrationName {
    let base = file_name.rsplit(['/', '\\']).next().unwrap_or(file_name);
    let stem = match base.rsplit_once('.') {
        Some((s, _)) if !s.is_empty() => s,
        _ => base,
    };
    let valve = stem.split('_').next().unwrap_or(stem).to_string();
    let start = stem
        .rsplit_once('_')
        .and_then(|(_, last)| parse_compact_time(last));
    RegistrationName { valve, start }
}

fn parse_compact_time(text: &str) -> Option<f64> {
    for fmt in [
        "%Y%m%d-%H%M%S",
        "%Y%m%d-%H%M",
        "%Y%m%dT%H%M%S",
        "%Y%m%dT%H%M",
    ] {
        if let Ok(dt) = NaiveDateTime::parse_from_str(text, fmt) {
            return Some(dt.and_utc().timestamp() as f64);
        }
    }
    if text.len() == 8 {
        if let Ok(d) = NaiveDate::parse_from_str(text, "%Y%m%d") {
            return d
                .and_hms_opt(0, 0, 0)
                .map(|dt| dt.and_utc().timestamp() as f64);
        }
    }
    None
}

/// `YYYY-MM-DD HH:MM` (UTC) of a time in seconds since the Unix epoch; `?` when out of range.
pub fn format_epoch(secs: f64) -> String {
    if !secs.is_finite() {
        return "?".into();
    }
    match DateTime::from_timestamp(secs.floor() as i64, 0) {
        Some(dt) => dt.format("%Y-%m-%d %H:%M").to_string(),
        None => "?".into(),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn plant_names() {
        let r = parse_registration_name("../x/2411FIC20102_20240609-0750.csv");
        assert_eq!(r.valve, "2411FIC20102");
        assert_eq!(format_epoch(r.start.unwrap()), "2024-06-09 07:50");
        let r = parse_registration_name("loop.csv");
        assert_eq!((r.valve.as_str(), r.start), ("loop", None));
        let r = parse_registration_name("A_B_20240101.mat");
        assert_eq!(r.valve, "A");
        assert_eq!(format_epoch(r.start.unwrap()), "2024-01-01 00:00");
        assert_eq!(parse_registration_name("V_notatime.csv").start, None);
    }
}
