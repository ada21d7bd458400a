//! MATLAB v5 `.mat` files, with a minimal reader of our own.
//!
//! The reader understands the 128-byte header (either byte order), data elements (normal and
//! small 4-byte ones, 8-byte padding), `miCOMPRESSED` elements (zlib, inflated with `flate2`)
//! and `miMATRIX` elements of the numeric classes (double, single, int8 … uint64, whatever the
//! storage type of the values; complex arrays give their real part) and of the struct class
//! (nested to any depth; an element `i` of a struct array is addressed as `name(i)`).
//! Character, cell, sparse, logical and object arrays are skipped.
//!
//! A *loop* is a set of numeric variables named like the CSV columns (`OP`, `PV`, `SP`, `MV`,
//! `MODE`, `t`/`time`, case-insensitive, remapped by the same [`ReadOptions`]) and optionally
//! a scalar sampling time `Ts` (s), which gives the time axis (`t = k·Ts`) when there is no
//! time vector. It is either the file's top level (a loop's fields saved as top-level
//! variables) or a struct with at least the OP and PV fields, such as the International
//! Stiction Database's `cdata.<sector>.loop<N>`. [`list_mat_loops`] lists a file's loops by
//! path; [`ReadOptions::mat_loop`] selects one. Without a selection the top-level variables are
//! read when they form a loop, else the only struct loop; several struct loops are an error
//! listing their paths.
//!
//! The vectors are handed to the CSV reader's checks (gaps, mode, time, flat stretches), so a
//! `.mat` file obeys the same rules and notes as a CSV file; row `r` in a message is sample
//! `r - 1`.

use std::io::Read;
use std::path::Path;

use crate::{read_csv, DataError, LoopData, Note, NoteKind, ReadOptions};

/// Deepest nesting of arrays accepted (a guard against hostile files).
const MAX_DEPTH: usize = 64;
/// Largest inflated size of one compressed element.
const MAX_INFLATED: u64 = 1 << 30;

/// One parsed MATLAB array.
#[derive(Debug, Clone, PartialEq)]
enum MatValue {
    /// Real values (column-major) and dimensions.
    Numeric(Vec<f64>, Vec<usize>),
    /// Fields in file order; a struct array has fields `(1)`, `(2)`, … holding its elements.
    Struct(Vec<(String, MatValue)>),
    /// An array of a class that is not read (the class number).
    Other(u8),
}

#[derive(Clone, Copy)]
struct Order {
    big: bool,
}

impl Order {
    fn u32(self, b: &[u8]) -> u32 {
        let a = [b[0], b[1], b[2], b[3]];
        if self.big {
            u32::from_be_bytes(a)
        } else {
            u32::from_le_bytes(a)
        }
    }
    fn u16(self, b: &[u8]) -> u16 {
        let a = [b[0], b[1]];
        if self.big {
            u16::from_be_bytes(a)
        } else {
            u16::from_le_bytes(a)
        }
    }
}

/// One data element: its type and its data bytes.
struct Element<'a> {
    kind: u32,
    data: &'a [u8],
    /// Offset of the element's tag within the buffer being read.
    at: usize,
}

/// Reads consecutive data elements from a buffer.
struct Elements<'a> {
    bytes: &'a [u8],
    pos: usize,
    order: Order,
}

impl<'a> Elements<'a> {
    fn new(bytes: &'a [u8], pos: usize, order: Order) -> Self {
        Elements { bytes, pos, order }
    }

    fn done(&self) -> bool {
        self.pos >= self.bytes.len()
    }

    fn next_element(&mut self) -> Result<Element<'a>, String> {
        let at = self.pos;
        let rest = &self.bytes[at.min(self.bytes.len())..];
        if rest.len() < 8 {
            return Err(format!("truncated data element at byte {at}"));
        }
        let first = self.order.u32(&rest[..4]);
        if first >> 16 != 0 {
            // Small data element: type and size packed in 4 bytes, data in the next 4.
            let kind = first & 0xffff;
            let n = (first >> 16) as usize;
            if n > 4 {
                return Err(format!("bad small data element at byte {at}"));
            }
            self.pos = at + 8;
            return Ok(Element {
                kind,
                data: &rest[4..4 + n],
                at,
            });
        }
        let kind = first;
        let n = self.order.u32(&rest[4..8]) as usize;
        if rest.len() - 8 < n {
            return Err(format!(
                "truncated data element at byte {at} ({n} bytes announced, {} left)",
                rest.len() - 8
            ));
        }
        let data = &rest[8..8 + n];
        // Elements are padded to 8 bytes, except compressed ones (and possibly the last one).
        let padded = if kind == MI_COMPRESSED {
            n
        } else {
            n.div_ceil(8) * 8
        };
        self.pos = at + 8 + padded.min(rest.len() - 8);
        Ok(Element { kind, data, at })
    }
}

const MI_INT8: u32 = 1;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;

const MX_STRUCT: u8 = 2;

/// The values of a numeric data element, whatever its storage type.
fn element_values(e: &Element<'_>, order: Order) -> Result<Vec<f64>, String> {
    let b = e.data;
    let size = match e.kind {
        1 | 2 => 1,
        3 | 4 => 2,
        5..=7 => 4,
        9 | 12 | 13 => 8,
        k => return Err(format!("unknown numeric storage type {k} at byte {}", e.at)),
    };
    if !b.len().is_multiple_of(size) {
        return Err(format!(
            "numeric data of {} bytes at byte {} is not a whole number of values",
            b.len(),
            e.at
        ));
    }
    let chunks = b.chunks_exact(size);
    let u64_of = |c: &[u8]| {
        let a = [c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]];
        if order.big {
            u64::from_be_bytes(a)
        } else {
            u64::from_le_bytes(a)
        }
    };
    Ok(match e.kind {
        1 => chunks.map(|c| f64::from(c[0] as i8)).collect(),
        2 => chunks.map(|c| f64::from(c[0])).collect(),
        3 => chunks.map(|c| f64::from(order.u16(c) as i16)).collect(),
        4 => chunks.map(|c| f64::from(order.u16(c))).collect(),
        5 => chunks.map(|c| f64::from(order.u32(c) as i32)).collect(),
        6 => chunks.map(|c| f64::from(order.u32(c))).collect(),
        7 => chunks
            .map(|c| f64::from(f32::from_bits(order.u32(c))))
            .collect(),
        9 => chunks.map(|c| f64::from_bits(u64_of(c))).collect(),
        12 => chunks.map(|c| u64_of(c) as i64 as f64).collect(),
        _ => chunks.map(|c| u64_of(c) as f64).collect(),
    })
}

/// A name from the file, made printable on one line.
fn clean_name(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end])
        .chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .collect()
}

/// Parse the body of a `miMATRIX` element into its name and value.
fn parse_matrix(data: &[u8], order: Order, depth: usize) -> Result<(String, MatValue), String> {
    if depth > MAX_DEPTH {
        return Err(format!("arrays nested more than {MAX_DEPTH} deep"));
    }
    if data.is_empty() {
        // An empty array (e.g. an unset struct field).
        return Ok((String::new(), MatValue::Other(0)));
    }
    let mut els = Elements::new(data, 0, order);
    let flags = els.next_element()?;
    if flags.kind != MI_UINT32 || flags.data.len() < 8 {
        return Err(format!("bad array flags at byte {}", flags.at));
    }
    let word = order.u32(&flags.data[..4]);
    let class = (word & 0xff) as u8;
    let logical = word & 0x0200 != 0;
    let dims_el = els.next_element()?;
    if dims_el.kind != MI_INT32 || dims_el.data.len() % 4 != 0 {
        return Err(format!("bad array dimensions at byte {}", dims_el.at));
    }
    let mut dims = Vec::new();
    for c in dims_el.data.chunks_exact(4) {
        let d = order.u32(c) as i32;
        dims.push(usize::try_from(d).map_err(|_| format!("negative dimension {d}"))?);
    }
    let count = dims
        .iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .ok_or("array dimensions overflow")?;
    let name_el = els.next_element()?;
    if name_el.kind != MI_INT8 && name_el.kind != 2 {
        return Err(format!("bad array name at byte {}", name_el.at));
    }
    let name = clean_name(name_el.data);
    let value = match class {
        6..=15 if !logical => {
            let real = els.next_element()?;
            let values = element_values(&real, order)?;
            if values.len() != count {
                return Err(format!(
                    "array {name} has {} values for {count} elements",
                    values.len()
                ));
            }
            MatValue::Numeric(values, dims)
        }
        MX_STRUCT => {
            let len_el = els.next_element()?;
            if len_el.kind != MI_INT32 || len_el.data.len() < 4 {
                return Err(format!("bad field-name length in struct {name}"));
            }
            let len = order.u32(&len_el.data[..4]) as usize;
            let names_el = els.next_element()?;
            if len == 0 || names_el.data.len() % len != 0 {
                return Err(format!("bad field names in struct {name}"));
            }
            let fields: Vec<String> = names_el.data.chunks_exact(len).map(clean_name).collect();
            let mut elements = Vec::new();
            // Without fields the elements hold nothing (and `count` may be anything).
            let count = if fields.is_empty() { 1 } else { count };
            for _ in 0..count {
                let mut values = Vec::with_capacity(fields.len());
                for field in &fields {
                    let el = els.next_element()?;
                    if el.kind != MI_MATRIX {
                        return Err(format!(
                            "field {field} of struct {name} is not an array (type {})",
                            el.kind
                        ));
                    }
                    let (_, v) = parse_matrix(el.data, order, depth + 1)?;
                    values.push((field.clone(), v));
                }
                elements.push(values);
            }
            if count == 1 {
                MatValue::Struct(elements.pop().unwrap_or_default())
            } else {
                MatValue::Struct(
                    elements
                        .into_iter()
                        .enumerate()
                        .map(|(i, f)| (format!("({})", i + 1), MatValue::Struct(f)))
                        .collect(),
                )
            }
        }
        c => MatValue::Other(c),
    };
    Ok((name, value))
}

/// Parse a whole file into its top-level variables.
fn parse_file(bytes: &[u8]) -> Result<Vec<(String, MatValue)>, String> {
    const NOT: &str = "not a readable MATLAB v5 file";
    if bytes.len() < 128 {
        return Err(format!("{NOT} (shorter than the 128-byte header)"));
    }
    if !bytes.starts_with(b"MATLAB") {
        return Err(format!("{NOT} (no MATLAB header text)"));
    }
    let order = match &bytes[126..128] {
        b"IM" => Order { big: false },
        b"MI" => Order { big: true },
        _ => return Err(format!("{NOT} (bad endian indicator)")),
    };
    let version = order.u16(&bytes[124..126]);
    if version != 0x0100 {
        return Err(format!("{NOT} (version {version:#06x}, expected 0x0100)"));
    }
    let mut vars = Vec::new();
    let mut els = Elements::new(bytes, 128, order);
    while !els.done() {
        let el = els.next_element().map_err(|e| format!("{NOT}: {e}"))?;
        match el.kind {
            MI_MATRIX => {
                vars.push(parse_matrix(el.data, order, 0).map_err(|e| format!("{NOT}: {e}"))?)
            }
            MI_COMPRESSED => {
                let mut inflated = Vec::new();
                flate2::read::ZlibDecoder::new(el.data)
                    .take(MAX_INFLATED)
                    .read_to_end(&mut inflated)
                    .map_err(|e| format!("{NOT}: compressed element at byte {}: {e}", el.at))?;
                let mut inner = Elements::new(&inflated, 0, order);
                while !inner.done() {
                    let e = inner.next_element().map_err(|e| {
                        format!("{NOT}: in the compressed element at byte {}: {e}", el.at)
                    })?;
                    if e.kind == MI_MATRIX {
                        vars.push(parse_matrix(e.data, order, 0).map_err(|m| {
                            format!("{NOT}: in the compressed element at byte {}: {m}", el.at)
                        })?);
                    }
                }
            }
            _ => {}
        }
    }
    Ok(vars)
}

fn find_numeric<'a>(
    fields: &'a [(String, MatValue)],
    name: &str,
) -> Option<(&'a str, &'a [f64], &'a [usize])> {
    fields.iter().find_map(|(n, v)| match v {
        MatValue::Numeric(x, d) if n.eq_ignore_ascii_case(name) => {
            Some((n.as_str(), &x[..], &d[..]))
        }
        _ => None,
    })
}

/// Whether these variables form a loop: numeric OP and PV (as remapped by `opts`).
fn is_loop(fields: &[(String, MatValue)], opts: &ReadOptions) -> bool {
    let op = opts.op.as_deref().map_or("op", str::trim);
    let pv = opts.pv.as_deref().map_or("pv", str::trim);
    find_numeric(fields, op).is_some() && find_numeric(fields, pv).is_some()
}

fn join(prefix: &str, name: &str) -> String {
    if prefix.is_empty() || name.starts_with('(') {
        format!("{prefix}{name}")
    } else {
        format!("{prefix}.{name}")
    }
}

/// Paths of the struct loops under `fields`.
fn struct_loops(
    fields: &[(String, MatValue)],
    prefix: &str,
    opts: &ReadOptions,
    out: &mut Vec<String>,
) {
    for (name, v) in fields {
        if let MatValue::Struct(f) = v {
            let path = join(prefix, name);
            if is_loop(f, opts) {
                out.push(path);
            } else {
                struct_loops(f, &path, opts, out);
            }
        }
    }
}

/// The struct at `path` (`a.b(2).c`), if any.
fn at_path<'a>(fields: &'a [(String, MatValue)], path: &str) -> Option<&'a [(String, MatValue)]> {
    let mut cur = fields;
    for part in path.split('.') {
        let (head, indices) = match part.find('(') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        let mut keys = vec![head.to_string()];
        for idx in indices.split_inclusive(')') {
            keys.push(idx.to_string());
        }
        for key in keys.iter().filter(|k| !k.is_empty()) {
            cur = cur.iter().find_map(|(n, v)| match v {
                MatValue::Struct(f) if n == key => Some(&f[..]),
                _ => None,
            })?;
        }
    }
    Some(cur)
}

fn open(path: &Path) -> Result<(String, Vec<u8>), DataError> {
    let name = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|error| DataError::Io {
        file: name.clone(),
        error,
    })?;
    let bytes = crate::limits::read_limited(file, &name, &crate::Limits::default(), false)?;
    Ok((name, bytes))
}

fn parse_source(bytes: &[u8], source: &str) -> Result<Vec<(String, MatValue)>, DataError> {
    parse_file(bytes).map_err(|message| DataError::Mat {
        file: source.to_string(),
        message,
    })
}

/// Paths of the loops in a MATLAB v5 file: the struct loops (`cdata.chemicals.loop1`, …) in
/// file order, preceded by `""` when the top-level variables themselves form a loop (OP and
/// PV, case-insensitive).
pub fn list_mat_loops(path: impl AsRef<Path>) -> Result<Vec<String>, DataError> {
    let (name, bytes) = open(path.as_ref())?;
    let vars = parse_source(&bytes, &name)?;
    let opts = ReadOptions::default();
    let mut out = Vec::new();
    if is_loop(&vars, &opts) {
        out.push(String::new());
    }
    struct_loops(&vars, "", &opts, &mut out);
    Ok(out)
}

/// Read one registration from a MATLAB v5 file.
pub fn read_mat_path(path: impl AsRef<Path>, opts: &ReadOptions) -> Result<LoopData, DataError> {
    let (name, bytes) = open(path.as_ref())?;
    read_mat(bytes.as_slice(), &name, opts)
}

/// The columns as CSV text, a header of their labels, then `len` rows (NaN as an empty cell,
/// numbers with every digit).
fn csv_text(columns: &[(&str, Vec<f64>)], len: usize) -> String {
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
    text
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
    let bytes = crate::limits::read_limited(&mut reader, &file, &opts.limits, false)?;
    let mat_err = |message: String| DataError::Mat {
        file: file.clone(),
        message,
    };
    let vars = parse_source(&bytes, source)?;
    let mut notes = Vec::new();
    let mut loops = Vec::new();
    struct_loops(&vars, "", opts, &mut loops);
    let fields: &[(String, MatValue)] = match opts.mat_loop.as_deref().map(str::trim) {
        Some(p) if !p.is_empty() => {
            let f = at_path(&vars, p).ok_or_else(|| {
                mat_err(format!(
                    "no struct {p} (loops: {})",
                    if loops.is_empty() {
                        "none".to_string()
                    } else {
                        loops.join(", ")
                    }
                ))
            })?;
            notes.push(Note::new(NoteKind::Source, format!("loop {p}")));
            f
        }
        Some(_) => &vars,
        None if is_loop(&vars, opts) || loops.is_empty() => &vars,
        None if loops.len() == 1 => {
            notes.push(Note::new(NoteKind::Source, format!("loop {}", loops[0])));
            at_path(&vars, &loops[0]).unwrap_or(&vars)
        }
        None => {
            return Err(mat_err(format!(
                "{} loops ({}): select one with --loop PATH",
                loops.len(),
                loops.join(", ")
            )))
        }
    };
    let found: Vec<&str> = fields.iter().map(|(n, _)| n.as_str()).collect();
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
        let names: Vec<String> = match given {
            Some(g) => vec![g.trim().to_string()],
            None => defaults.iter().map(|s| s.to_string()).collect(),
        };
        let Some((vname, v, size)) = names.iter().find_map(|n| find_numeric(fields, n)) else {
            let required = label == "OP" || (label == "PV" && opts.require_pv);
            if required || given.is_some() {
                return Err(mat_err(format!(
                    "no numeric variable {label}{} (found: {})",
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
        if size.iter().filter(|&&d| d > 1).count() > 1 {
            return Err(mat_err(format!(
                "variable {vname} is a {} array, expected a vector",
                size.iter()
                    .map(|d| d.to_string())
                    .collect::<Vec<_>>()
                    .join("x")
            )));
        }
        match n {
            None => n = Some((vname.to_string(), v.len())),
            Some((ref first, len)) if len != v.len() => {
                return Err(mat_err(format!(
                    "variables have different lengths: {first} {len}, {vname} {}",
                    v.len()
                )))
            }
            Some(_) => {}
        }
        columns.push((label, v.to_vec()));
    }
    let len = n.map_or(0, |(_, l)| l);
    if !columns.iter().any(|(l, _)| *l == "t") {
        if let Some((name, v)) = fields.iter().find(|(n, _)| n.eq_ignore_ascii_case("ts")) {
            match v {
                MatValue::Numeric(v, _) if v.len() == 1 && v[0].is_finite() && v[0] > 0.0 => {
                    let ts = v[0];
                    columns.insert(0, ("t", (0..len).map(|i| i as f64 * ts).collect()));
                    notes.push(Note::new(
                        NoteKind::Source,
                        format!("time from the sampling time Ts = {ts} s"),
                    ));
                }
                _ => {
                    return Err(mat_err(format!(
                        "variable {name} is not a positive scalar sampling time"
                    )))
                }
            }
        }
    }
    // Hand the vectors to the CSV reader's checks.
    let text = csv_text(&columns, len);
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
