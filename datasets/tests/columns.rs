//! `read_columns` (columns in memory, as a data frame holds them) against `read_csv` on the CSV
//! text of the same columns: the same data, notes and errors.

use datasets::{read_columns, read_csv, ColumnInput, GapPolicy, ReadOptions};
use proptest::prelude::*;

/// A column as a test writes it.
#[derive(Debug, Clone)]
enum Col {
    Numbers(Vec<f64>),
    Text(Vec<Option<String>>),
}

/// The CSV text of the columns, as the Python package used to make it: numbers in their
/// shortest round-trip form, NaN as an empty cell, text quoted when it must be.
fn csv_text(names: &[&str], cols: &[Col]) -> String {
    let rows = cols.first().map_or(0, |c| match c {
        Col::Numbers(x) => x.len(),
        Col::Text(t) => t.len(),
    });
    let quote = |s: &str| {
        if s.contains([',', '"', '\n', '\r']) {
            format!("\"{}\"", s.replace('"', "\"\""))
        } else {
            s.to_string()
        }
    };
    let mut out = names.iter().map(|n| quote(n)).collect::<Vec<_>>().join(",");
    out.push('\n');
    for k in 0..rows {
        let cells: Vec<String> = cols
            .iter()
            .map(|c| match c {
                Col::Numbers(x) if x[k].is_nan() => String::new(),
                Col::Numbers(x) if x[k].is_infinite() => {
                    if x[k] > 0.0 { "inf" } else { "-inf" }.to_string()
                }
                Col::Numbers(x) => ryu::Buffer::new().format_finite(x[k]).to_string(),
                Col::Text(t) => quote(t[k].as_deref().unwrap_or("")),
            })
            .collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// Both entries on the same columns: `Ok` debug text or the error message.
fn both(names: &[&str], cols: &[Col], opts: &ReadOptions) -> (String, String) {
    let text = csv_text(names, cols);
    let from_csv = match read_csv(text.as_bytes(), "frame", opts) {
        Ok(d) => format!("{d:?}"),
        Err(e) => e.to_string(),
    };
    let owned: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    let inputs: Vec<ColumnInput<'_>> = cols
        .iter()
        .map(|c| match c {
            Col::Numbers(x) => ColumnInput::Numbers(x),
            Col::Text(t) => ColumnInput::Text(t),
        })
        .collect();
    let direct = match read_columns("frame", &owned, &inputs, opts) {
        Ok(d) => format!("{d:?}"),
        Err(e) => e.to_string(),
    };
    (from_csv, direct)
}

fn wave(n: usize, phase: f64, scale: f64) -> Vec<f64> {
    (0..n)
        .map(|k| scale * (50.0 + 10.0 * (0.07 * k as f64 + phase).sin()))
        .collect()
}

#[test]
fn plain_numbers_agree_and_read() {
    let n = 200;
    let cols = [
        Col::Numbers((0..n).map(|k| k as f64).collect()),
        Col::Numbers(wave(n, 0.0, 1.0)),
        Col::Numbers(wave(n, 1.0, 1.0)),
        Col::Numbers(wave(n, 2.0, 1.0)),
        Col::Numbers(wave(n, 3.0, 1.0)),
    ];
    let (a, b) = both(
        &["t", "SP", "PV", "OP", "extra"],
        &cols,
        &ReadOptions::default(),
    );
    assert!(a.starts_with("LoopData"), "{a}");
    assert_eq!(a, b);
}

#[test]
fn special_cases_agree() {
    let n = 60;
    let opts = ReadOptions::default();
    let hold = ReadOptions {
        gaps: GapPolicy::FillHold,
        ..ReadOptions::default()
    };
    let drop = ReadOptions {
        gaps: GapPolicy::DropGaps,
        ..ReadOptions::default()
    };
    let mut gappy = wave(n, 0.5, 1.0);
    gappy[7] = f64::NAN;
    gappy[30] = f64::NAN;
    let mut inf = wave(n, 0.5, 1.0);
    inf[12] = f64::INFINITY;
    let mut huge = wave(n, 0.5, 1.0);
    huge[3] = -1e200;
    let stamps: Vec<Option<String>> = (0..n)
        .map(|k| Some(format!("2024-03-01T10:{:02}:{:02}", k / 60, k % 60)))
        .collect();
    let mut modes: Vec<Option<String>> = (0..n)
        .map(|k| Some(if k < 10 { "MAN" } else { "AUTO" }.to_string()))
        .collect();
    modes[40] = None;
    let mut bad_text = vec![Some("1.5".to_string()); n];
    bad_text[9] = Some("x1".into());
    let cases: Vec<(Vec<&str>, Vec<Col>, &ReadOptions)> = vec![
        // gaps under each policy
        (
            vec!["PV", "OP"],
            vec![Col::Numbers(gappy.clone()), Col::Numbers(wave(n, 1.0, 1.0))],
            &opts,
        ),
        (
            vec!["PV", "OP"],
            vec![Col::Numbers(gappy.clone()), Col::Numbers(wave(n, 1.0, 1.0))],
            &hold,
        ),
        (
            vec!["PV", "OP"],
            vec![Col::Numbers(gappy), Col::Numbers(wave(n, 1.0, 1.0))],
            &drop,
        ),
        // refused cells
        (
            vec!["PV", "OP"],
            vec![Col::Numbers(wave(n, 0.0, 1.0)), Col::Numbers(inf)],
            &opts,
        ),
        (
            vec!["PV", "OP"],
            vec![Col::Numbers(huge), Col::Numbers(wave(n, 1.0, 1.0))],
            &opts,
        ),
        (
            vec!["PV", "OP"],
            vec![Col::Numbers(wave(n, 0.0, 1.0)), Col::Text(bad_text)],
            &opts,
        ),
        // time stamps and a mode column as text
        (
            vec!["time", "PV", "OP", "mode"],
            vec![
                Col::Text(stamps),
                Col::Numbers(wave(n, 0.0, 1.0)),
                Col::Numbers(wave(n, 1.0, 1.0)),
                Col::Text(modes),
            ],
            &opts,
        ),
        // OP logged as a fraction
        (
            vec!["PV", "OP"],
            vec![
                Col::Numbers(wave(n, 0.0, 1.0)),
                Col::Numbers(wave(n, 1.0, 0.01)),
            ],
            &opts,
        ),
        // a missing and an ambiguous column
        (
            vec!["PV", "out"],
            vec![
                Col::Numbers(wave(n, 0.0, 1.0)),
                Col::Numbers(wave(n, 1.0, 1.0)),
            ],
            &opts,
        ),
        (
            vec!["PV", "OP", "op"],
            vec![
                Col::Numbers(wave(n, 0.0, 1.0)),
                Col::Numbers(wave(n, 1.0, 1.0)),
                Col::Numbers(wave(n, 2.0, 1.0)),
            ],
            &opts,
        ),
        // a constant OP, and too few rows
        (
            vec!["PV", "OP"],
            vec![Col::Numbers(wave(n, 0.0, 1.0)), Col::Numbers(vec![40.0; n])],
            &opts,
        ),
        (
            vec!["PV", "OP"],
            vec![Col::Numbers(vec![1.0, 2.0]), Col::Numbers(vec![3.0, 4.0])],
            &opts,
        ),
    ];
    for (names, cols, o) in &cases {
        let (a, b) = both(names, cols, o);
        assert_eq!(a, b, "columns {names:?}");
    }
}

#[test]
fn columns_of_different_lengths_are_refused() {
    let names = vec!["PV".to_string(), "OP".to_string()];
    let (pv, op) = (vec![1.0, 2.0, 3.0], vec![1.0, 2.0]);
    let e = read_columns(
        "frame",
        &names,
        &[ColumnInput::Numbers(&pv), ColumnInput::Numbers(&op)],
        &ReadOptions::default(),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "frame: column OP has 2 rows, column PV has 3"
    );
}

fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -1e3..1e3f64,
        1 => Just(f64::NAN),
        1 => prop_oneof![Just(0.0), Just(1e-300), Just(-5e-324), Just(1e151), Just(f64::NEG_INFINITY)],
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// Random numeric frames (gaps, tiny and huge numbers) under every gap policy.
    #[test]
    fn random_frames_agree(
        rows in 0usize..40,
        policy in 0usize..3,
        seed in prop::collection::vec(value(), 120),
        names in prop::sample::select(vec![vec!["PV", "OP"], vec!["t", "PV", "OP"], vec!["SP", "PV", "OP", "MV"]]),
    ) {
        let cols: Vec<Col> = (0..names.len())
            .map(|j| Col::Numbers((0..rows).map(|k| if j == 0 && names[0] == "t" { k as f64 } else { seed[(k * 3 + j * 7) % seed.len()] + k as f64 * 0.1 }).collect()))
            .collect();
        let opts = ReadOptions {
            gaps: [GapPolicy::Refuse, GapPolicy::FillHold, GapPolicy::DropGaps][policy],
            ..ReadOptions::default()
        };
        let (a, b) = both(&names, &cols, &opts);
        prop_assert_eq!(a, b);
    }
}
