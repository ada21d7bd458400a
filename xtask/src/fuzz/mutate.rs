//! The fuzzer's mutations: bytes, lines, cells, columns and MATLAB element headers.

use super::{Case, Kind, Rng};

pub(super) fn mutate(rng: &mut Rng, mut case: Case) -> Case {
    let rounds = 1 + rng.below(3);
    for _ in 0..rounds {
        match (case.kind, rng.below(10)) {
            (Kind::Csv, 0..=2) => case.bytes = mutate_cells(rng, &case.bytes),
            (Kind::Csv, 3..=4) => case.bytes = mutate_columns(rng, &case.bytes),
            (Kind::Csv, 5..=6) => case.bytes = mutate_lines(rng, &case.bytes),
            (Kind::Mat, 0..=3) => case.bytes = mutate_mat(rng, &case.bytes),
            _ => mutate_bytes(rng, &mut case.bytes),
        }
    }
    if rng.below(5) == 0 {
        case.step = Some(10f64.powf(-6.0 + 12.0 * rng.unit()));
    }
    case.gaps = rng.below(3) as u8;
    case
}

fn mutate_bytes(rng: &mut Rng, b: &mut Vec<u8>) {
    match rng.below(7) {
        0 => {
            for _ in 0..1 + rng.below(8) {
                if !b.is_empty() {
                    let i = rng.below(b.len());
                    b[i] ^= 1 << rng.below(8);
                }
            }
        }
        1 => {
            let i = rng.below(b.len() + 1);
            let junk: Vec<u8> = (0..1 + rng.below(16)).map(|_| rng.next() as u8).collect();
            b.splice(i..i, junk);
        }
        2 => {
            let cut = rng.below(b.len() + 1);
            b.truncate(cut);
        }
        3 => b.splice(0..0, [0xEF, 0xBB, 0xBF]).for_each(drop),
        4 => {
            let text = String::from_utf8_lossy(b).replace('\n', "\r\n");
            *b = text.into_bytes();
        }
        5 => {
            let d = *rng.pick(b";\t |");
            for x in b.iter_mut() {
                if *x == b',' {
                    *x = d;
                }
            }
        }
        _ => {
            if !b.is_empty() {
                let i = rng.below(b.len());
                let n = rng.below(b.len() - i + 1);
                b.drain(i..i + n);
            }
        }
    }
}

fn split_csv(b: &[u8]) -> Vec<Vec<String>> {
    String::from_utf8_lossy(b)
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

fn join_csv(rows: &[Vec<String>]) -> Vec<u8> {
    let mut s = String::new();
    for r in rows {
        s.push_str(&r.join(","));
        s.push('\n');
    }
    s.into_bytes()
}

const CELLS: [&str; 20] = [
    "",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-320",
    "abc",
    "\"1,5\"",
    "0x10",
    "1,5",
    "--1",
    "1e",
    "\u{663}",
    "\"",
    "AUTO",
    "MAN",
    "2024-13-45T25:61:00",
    "9999999999999999999999999",
];

fn mutate_cells(rng: &mut Rng, b: &[u8]) -> Vec<u8> {
    let mut rows = split_csv(b);
    if rows.len() < 2 {
        return b.to_vec();
    }
    for _ in 0..1 + rng.below(5) {
        let r = 1 + rng.below(rows.len() - 1);
        let width = rows[r].len();
        if width == 0 {
            continue;
        }
        let c = rng.below(width);
        rows[r][c] = if rng.below(10) == 0 {
            "7".repeat(1 + rng.below(200_000))
        } else {
            rng.pick(&CELLS).to_string()
        };
    }
    join_csv(&rows)
}

fn mutate_columns(rng: &mut Rng, b: &[u8]) -> Vec<u8> {
    let mut rows = split_csv(b);
    if rows.len() < 2 {
        return b.to_vec();
    }
    let header = rows[0].clone();
    let find = |name: &str| header.iter().position(|h| h.eq_ignore_ascii_case(name));
    let (op, pv) = (find("OP"), find("PV"));
    let scale = |rows: &mut Vec<Vec<String>>, col: usize, f: &dyn Fn(f64) -> f64| {
        for r in rows.iter_mut().skip(1) {
            if let Some(cell) = r.get_mut(col) {
                if let Ok(v) = cell.parse::<f64>() {
                    *cell = format!("{}", f(v));
                }
            }
        }
    };
    match rng.below(9) {
        0 | 1 => {
            if let Some(c) = if rng.below(2) == 0 { op } else { pv } {
                let k = *rng.pick(&[1e-9, 1e-3, 0.01, -1.0, 163.83, 1e6, 1e9, 1e300]);
                scale(&mut rows, c, &|v| v * k);
            }
        }
        2 => {
            if let Some(c) = op {
                scale(&mut rows, c, &|v| (v * 163.83).round());
            }
        }
        3 => {
            if let (Some(o), Some(p)) = (op, pv) {
                for r in rows.iter_mut().skip(1) {
                    if r.len() > o.max(p) {
                        r[p] = r[o].clone();
                    }
                }
            }
        }
        4 => {
            if let Some(c) = op {
                scale(&mut rows, c, &|_| 42.0);
            }
        }
        5 => {
            let alternating = rng.below(2) == 0;
            rows[0].push("MODE".into());
            for (i, r) in rows.iter_mut().enumerate().skip(1) {
                r.push(
                    if alternating && i % 2 == 0 {
                        "MAN"
                    } else {
                        "AUTO"
                    }
                    .into(),
                );
            }
        }
        6 => {
            if let Some(p) = pv {
                for (i, r) in rows.iter_mut().enumerate() {
                    let extra = if i == 0 {
                        "pv".to_string()
                    } else {
                        r.get(p).cloned().unwrap_or_default()
                    };
                    r.push(extra);
                }
            }
        }
        7 => {
            // Reorder the columns.
            let n = rows[0].len();
            if n > 1 {
                let (a, b2) = (rng.below(n), rng.below(n));
                for r in rows.iter_mut() {
                    if r.len() == n {
                        r.swap(a, b2);
                    }
                }
            }
        }
        _ => {
            if let Some(c) = pv {
                let k = 10f64.powi(rng.below(40) as i32 * 10 - 200);
                scale(&mut rows, c, &|v| v * k);
            }
        }
    }
    join_csv(&rows)
}

fn mutate_lines(rng: &mut Rng, b: &[u8]) -> Vec<u8> {
    let text = String::from_utf8_lossy(b);
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        return b.to_vec();
    }
    let n = lines.len();
    match rng.below(6) {
        0 => {
            let i = rng.below(n);
            let k = rng.below(n - i + 1);
            lines.drain(i..i + k);
        }
        1 => {
            let i = rng.below(n);
            let l = lines[i].clone();
            for _ in 0..1 + rng.below(50) {
                lines.insert(i, l.clone());
            }
        }
        2 => {
            let (a, c) = (rng.below(n), rng.below(n));
            lines.swap(a, c);
        }
        3 => {
            let i = rng.below(n);
            lines.insert(i, String::new());
        }
        4 => {
            let i = rng.below(n);
            let h = lines[0].clone();
            lines.insert(i, h);
        }
        _ => {
            let i = rng.below(n);
            let l = &mut lines[i];
            let cut = rng.below(l.len() + 1);
            let mut cut_at = cut;
            while !l.is_char_boundary(cut_at) {
                cut_at -= 1;
            }
            l.truncate(cut_at);
        }
    }
    let mut s = lines.join("\n");
    s.push('\n');
    s.into_bytes()
}

/// MAT-specific damage: element sizes and types overwritten with extreme values.
fn mutate_mat(rng: &mut Rng, b: &[u8]) -> Vec<u8> {
    let mut b = b.to_vec();
    if b.len() < 136 {
        mutate_bytes(rng, &mut b);
        return b;
    }
    let words = (b.len() - 128) / 4;
    for _ in 0..1 + rng.below(3) {
        let i = 128 + 4 * rng.below(words);
        let v: u32 = *rng.pick(&[0, 1, 7, 8, 0xFFFF, 0x7FFF_FFFF, 0xFFFF_FFFF, 14, 15, 9, 6]);
        b[i..i + 4].copy_from_slice(&v.to_le_bytes());
    }
    b
}
