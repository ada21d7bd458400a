//! A lenient look at a delimited text file the reader refused: its numeric columns, for
//! showing what was logged.

use std::path::Path;

/// The numeric columns of a delimited text file, read leniently (non-numbers become NaN), for
/// showing data the reader refused. At most six columns, the loop's own first.
pub fn raw_columns(path: &Path) -> Option<Vec<(String, Vec<f64>)>> {
    let text = std::fs::read_to_string(path).ok()?;
    let first = text.lines().next()?;
    let delim = [b',', b';', b'\t']
        .into_iter()
        .max_by_key(|d| first.bytes().filter(|b| b == d).count())?;
    let mut rdr = csv::ReaderBuilder::new()
        .delimiter(delim)
        .flexible(true)
        .from_reader(text.as_bytes());
    let header: Vec<String> = rdr.headers().ok()?.iter().map(str::to_string).collect();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
    for rec in rdr.records().flatten() {
        for (i, c) in cols.iter_mut().enumerate() {
            c.push(
                rec.get(i)
                    .and_then(|v| v.trim().parse::<f64>().ok())
                    .unwrap_or(f64::NAN),
            );
        }
    }
    let order = ["SP", "PV", "OP", "MV"];
    let mut named: Vec<(String, Vec<f64>)> = header
        .into_iter()
        .zip(cols)
        .filter(|(_, v)| v.iter().any(|x| x.is_finite()))
        .filter(|(h, _)| !matches!(h.to_ascii_lowercase().as_str(), "t" | "time"))
        .collect();
    named.sort_by_key(|(h, _)| {
        order
            .iter()
            .position(|o| o.eq_ignore_ascii_case(h))
            .unwrap_or(order.len())
    });
    named.truncate(6);
    (!named.is_empty()).then_some(named)
}
