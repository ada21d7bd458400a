//! MATLAB v5 `.mat` files (the `matfile` crate).
//!
//! A loop is stored as top-level numeric vectors named like the CSV columns (`OP`, `PV`, `SP`,
//! `MV`, `MODE`, `t`/`time`, case-insensitive, remapped by the same [`ReadOptions`]) and
//! optionally a scalar sampling time `Ts` (s), which gives the time axis when there is no time
//! vector. The vectors are handed to the CSV reader's checks (gaps, mode, time, flat
//! stretches), so a `.mat` file obeys the same rules and notes as a CSV file; row `r` in a
//! message is sample `r - 1`.
//!
//! Limitation: `matfile` 0.5 reads numeric arrays only and silently skips structs, cells and
//! character arrays, so the International Stiction Database's struct-of-loops layout
//! (`cdata.<sector>.loop<N>` with fields OP, PV, SP, Ts) cannot be read; such a file gets an
//! error saying so. Save the loop's fields as top-level variables instead
//! (`s = cdata.chemicals.loop1; save('loop1.mat', '-struct', 's')` in MATLAB).

use std::io::Read;
use std::path::Path;

use matfile::{MatFile, NumericData};

use crate::{read_csv, DataError, LoopData, ReadOptions};

/// Read one registration from a MATLAB v5 file.
pub fn read_mat_path(path: impl AsRef<Path>, opts: &ReadOptions) -> Result<LoopData, DataError> {
    let path = path.as_ref();
    let name = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|error| DataError::Io {
        file: name.clone(),
        error,
    })?;
    read_mat(std::io::BufReader::new(file), &name, opts)
}

fn to_f64(data: &NumericData) -> Vec<f64> {
    fn conv<T: Copy + Into<f64>>(v: &[T]) -> Vec<f64> {
        v.iter().map(|&x| x.into()).collect()
    }
    match data {
        NumericData::Int8 { real, .. } => conv(real),
        NumericData::UInt8 { real, .. } => conv(real),
        NumericData::Int16 { real, .. } => conv(real),
        NumericData::UInt16 { real, .. } => conv(real),
        NumericData::Int32 { real, .. } => conv(real),
        NumericData::UInt32 { real, .. } => conv(real),
        NumericData::Int64 { real, .. } => real.iter().map(|&x| x as f64).collect(),
        NumericData::UInt64 { real, .. } => real.iter().map(|&x| x as f64).collect(),
        NumericData::Single { real, .. } => conv(real),
        NumericData::Double { real, .. } => real.clone(),
    }
}

/// Read one registration from MATLAB v5 bytes; `source` names it in messages.
///
/// Never panics: any input yields either data or a [`DataError`].
pub fn read_mat(
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
    let mat_err = |message: String| DataError::Mat {
        file: file.clone(),
        message,
    };
    // The parser is third-party code: a panic on a malformed file must not escape.
    let parsed = std::panic::catch_unwind(|| MatFile::parse(bytes.as_slice()))
        .map_err(|_| mat_err("not a readable MATLAB v5 file (the parser failed)".into()))?
        .map_err(|e| mat_err(format!("not a readable MATLAB v5 file: {e}")))?;
    let arrays = parsed.arrays();
    let found: Vec<String> = arrays.iter().map(|a| a.name().to_string()).collect();
    let find = |given: &Option<String>, defaults: &[&str]| {
        let names: Vec<String> = match given {
            Some(n) => vec![n.trim().to_lowercase()],
            None => defaults.iter().map(|s| s.to_string()).collect(),
        };
        arrays
            .iter()
            .find(|a| names.iter().any(|n| a.name().to_lowercase() == *n))
    };
    let mut columns: Vec<(&str, Vec<f64>)> = Vec::new();
    let mut n = None;
    for (label, given, defaults) in [
        ("t", &opts.time, &["t", "time"][..]),
        ("SP", &opts.sp, &["sp"][..]),
        ("PV", &opts.pv, &["pv"][..]),
        ("OP", &opts.op, &["op"][..]),
        ("MV", &opts.mv, &["mv"][..]),
        ("MODE", &opts.mode, &["mode"][..]),
    ] {
        let Some(a) = find(given, defaults) else {
            let required = label == "OP" || (label == "PV" && opts.require_pv);
            if required || given.is_some() {
                return Err(mat_err(format!(
                    "no numeric variable {label}{} (found: {}); matfile 0.5 reads numeric arrays \
                     only, so structs such as the International Stiction Database's \
                     cdata.<sector>.loop<N> are skipped: save the loop's fields OP, PV, SP, Ts as \
                     top-level variables",
                    given
                        .as_ref()
                        .map(|g| format!(" ({g:?})"))
                        .unwrap_or_default(),
                    if found.is_empty() {
                        "none".to_string()
                    } else {
                        found.join(", ")
                    }
                )));
            }
            continue;
        };
        let size = a.size();
        if size.iter().filter(|&&d| d > 1).count() > 1 {
            return Err(mat_err(format!(
                "variable {} is a {} array, expected a vector",
                a.name(),
                size.iter()
                    .map(|d| d.to_string())
                    .collect::<Vec<_>>()
                    .join("x")
            )));
        }
        let v = to_f64(a.data());
        match n {
            None => n = Some((a.name().to_string(), v.len())),
            Some((ref first, len)) if len != v.len() => {
                return Err(mat_err(format!(
                    "variables have different lengths: {first} {len}, {} {}",
                    a.name(),
                    v.len()
                )))
            }
            Some(_) => {}
        }
        columns.push((label, v));
    }
    let len = n.map_or(0, |(_, l)| l);
    let mut notes = Vec::new();
    if !columns.iter().any(|(l, _)| *l == "t") {
        if let Some(ts) = arrays.iter().find(|a| a.name().eq_ignore_ascii_case("ts")) {
            let v = to_f64(ts.data());
            match v.as_slice() {
                [ts] if ts.is_finite() && *ts > 0.0 => {
                    columns.insert(0, ("t", (0..len).map(|i| i as f64 * ts).collect()));
                    notes.push(format!("time from the sampling time Ts = {ts} s"));
                }
                _ => {
                    return Err(mat_err(format!(
                        "variable {} is not a positive scalar sampling time",
                        ts.name()
                    )))
                }
            }
        }
    }
    // Hand the vectors to the CSV reader's checks.
    let mut text = columns
        .iter()
        .map(|(l, _)| *l)
        .collect::<Vec<_>>()
        .join(",");
    text.push('\n');
    for i in 0..len {
        let row: Vec<String> = columns
            .iter()
            .map(|(_, v)| {
                let x = v[i];
                if x.is_nan() {
                    String::new()
                } else {
                    format!("{x:?}")
                }
            })
            .collect();
        text.push_str(&row.join(","));
        text.push('\n');
    }
    let canonical = ReadOptions {
        pv: None,
        op: None,
        sp: None,
        mv: None,
        time: None,
        mode: None,
        ..opts.clone()
    };
    let mut data = read_csv(text.as_bytes(), source, &canonical)?;
    notes.append(&mut data.notes);
    data.notes = notes;
    Ok(data)
}
