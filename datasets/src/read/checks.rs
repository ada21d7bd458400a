//! Everything after the cells are parsed, shared by every reader entry ([`finish`]): empty
//! columns, unknown modes, the gap policy, closed-loop selection, time checks, the window,
//! flat, compressed, quantised and constant columns, and the record assembled.

use super::*;

/// Everything after the cells are parsed, shared by every reader entry: empty columns, unknown
/// modes, the gap policy, closed-loop selection, time checks, flat and constant columns, the
/// row count and the OP units.
pub(crate) fn finish(
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

    let mut columns = drop_empty_columns(&file, columns, &mut notes)?;
    unknown_modes(&mut columns, &mut notes);
    apply_gaps(&file, opts.gaps, &mut columns, &mut lines, &mut notes)?;

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

    assemble(file, columns, &lines, time_kind, opts, notes)
}

/// Drop the columns without any value (an error for a required one), with a note each.
pub(crate) fn drop_empty_columns(
    file: &str,
    columns: Vec<Column>,
    notes: &mut Vec<Note>,
) -> Result<Vec<Column>, DataError> {
    let mut kept = Vec::with_capacity(columns.len());
    for col in columns {
        if col.values.iter().all(Option::is_none) {
            if col.required {
                return Err(DataError::AllGaps {
                    file: file.to_string(),
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
    Ok(kept)
}

/// An empty mode cell is an unknown mode: not trusted as closed loop (set to 0, with a note).
pub(crate) fn unknown_modes(columns: &mut [Column], notes: &mut Vec<Note>) {
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
}

/// Empty or `NaN` cells under the gap policy: refused (naming the first), filled (time by
/// interpolation, the others by holding the last value), or the longest clean run kept.
pub(crate) fn apply_gaps(
    file: &str,
    policy: GapPolicy,
    columns: &mut [Column],
    lines: &mut Vec<u64>,
    notes: &mut Vec<Note>,
) -> Result<(), DataError> {
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
        match policy {
            GapPolicy::Refuse => {
                let (i, column) = first.unwrap_or((0, String::new()));
                return Err(DataError::Gaps {
                    file: file.to_string(),
                    count: gap_count,
                    row: lines[i],
                    column,
                });
            }
            GapPolicy::FillHold => {
                for col in columns.iter_mut() {
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
                            file: file.to_string(),
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
                for col in columns.iter_mut() {
                    col.values = col.values[a..b].to_vec();
                }
                *lines = lines[a..b].to_vec();
            }
        }
    }
    Ok(())
}

/// The loop record from the checked columns: time from 0 (its start kept when stamped),
/// spikes noted, constant PV or OP checked, OP and MV in % of span.
pub(crate) fn assemble(
    file: String,
    columns: Vec<Column>,
    lines: &[u64],
    time_kind: Option<TimeKind>,
    opts: &ReadOptions,
    notes: Vec<Note>,
) -> Result<LoopData, DataError> {
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
            if let Some(note) = spike_note(&col.name, &mut values, lines) {
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
pub(crate) fn check_constant(
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

/// Keep only the rows in `a..b`.
pub(crate) fn keep_rows(columns: &mut [Column], lines: &mut Vec<u64>, a: usize, b: usize) {
    for col in columns.iter_mut() {
        col.values = col.values[a..b].to_vec();
    }
    *lines = lines[a..b].to_vec();
}

/// Keep the latest `window` rows of a longer record, with a note naming the rows kept.
pub(crate) fn keep_window(
    columns: &mut [Column],
    lines: &mut Vec<u64>,
    window: usize,
    notes: &mut Vec<Note>,
) {
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
pub(crate) fn longest_run(flags: &[bool]) -> (usize, usize) {
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
pub(crate) fn select_closed_loop(
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
pub(crate) fn check_time(
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
        if let Some((fixed, rows)) = stamps::on_grid(&t) {
            notes.push(stamps::note(&name, rows.len(), lines[rows[0]], bad.len()));
            columns[ti].values = fixed.iter().map(|&v| Some(v)).collect();
            return check_time(file, gaps, columns, lines, notes);
        }
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
pub(crate) const FLAT_MIN_ROWS: usize = 20;

/// Exactly repeated PV / OP values: noted, refused over more than half of the rows (kept with a
/// note under [`ReadOptions::accept_constant`]: a detector answers such a record itself).
pub(crate) fn check_flat(
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
pub(crate) const STRAIGHT_RELATIVE: f64 = 1e-9;

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

pub(crate) fn check_compression(columns: &[Column], notes: &mut Vec<Note>) {
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
pub(crate) fn check_quantisation(columns: &[Column], notes: &mut Vec<Note>) {
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

/// Fill `None`s by linear interpolation; ends extrapolated with the nearest step. At least one
/// value must be present.
pub(crate) fn interpolate(values: &mut [Option<f64>]) {
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
