//! The CSV reader: every error with its exact message, delimiters, time stamps, remapping,
//! gap policies, the plant data in `../shared` (skipped when absent) and a no-panic property.

#![allow(clippy::unwrap_used)]

use datasets::{read_csv, read_csv_path, DataError, GapPolicy, ReadOptions};
use proptest::prelude::*;

fn read(text: &str) -> Result<datasets::LoopData, DataError> {
    read_csv(text.as_bytes(), "loop.csv", &ReadOptions::default())
}

fn read_with(text: &str, opts: &ReadOptions) -> Result<datasets::LoopData, DataError> {
    read_csv(text.as_bytes(), "loop.csv", opts)
}

fn message(r: Result<datasets::LoopData, DataError>) -> String {
    r.expect_err("expected an error").to_string()
}

#[test]
fn reads_a_plain_file() {
    let d = read("t,SP,PV,OP,MV,MODE\n0,1,2,3,4,1\n10,1,2.5,3.5,4,1\n20,1,2,3,4.5,1\n").unwrap();
    assert_eq!(d.source, "loop.csv");
    assert_eq!(d.t.as_deref(), Some(&[0.0, 10.0, 20.0][..]));
    assert_eq!(d.sp.as_deref(), Some(&[1.0, 1.0, 1.0][..]));
    assert_eq!(d.pv.as_deref(), Some(&[2.0, 2.5, 2.0][..]));
    assert_eq!(d.op, vec![3.0, 3.5, 3.0]);
    assert_eq!(d.mv.as_deref(), Some(&[4.0, 4.0, 4.5][..]));
    // MODE 1 = closed loop throughout: used, nothing to report.
    assert!(d.notes.is_empty(), "{:?}", d.notes);
    assert_eq!(d.len(), 3);
}

#[test]
fn column_names_are_case_insensitive_and_time_is_relative() {
    let d = read("Time,pv,Op\n100,1,2\n101,2,3\n102.5,1,2\n").unwrap();
    assert_eq!(d.t.as_deref(), Some(&[0.0, 1.0, 2.5][..]));
    assert_eq!(d.op, vec![2.0, 3.0, 2.0]);
    assert_eq!(
        d.notes,
        vec![
            "column Time: sampling jitter: 1 of 2 intervals differ from the median 1.5 s (from \
             1 to 1.5 s, up to 33.3 %); treated as uniformly sampled"
        ]
    );
}

#[test]
fn delimiters_comma_semicolon_tab() {
    for text in [
        "PV,OP\n1,2\n2,3\n1.5,2\n",
        "PV;OP\n1;2\n2;3\n1.5;2\n",
        "PV\tOP\n1\t2\n2\t3\n1.5\t2\n",
        "\u{feff}PV , OP\r\n1, 2\r\n2 ,3\r\n1.5,2\r\n",
    ] {
        let d = read(text).unwrap();
        assert_eq!(d.pv.as_deref(), Some(&[1.0, 2.0, 1.5][..]), "{text:?}");
        assert_eq!(d.op, vec![2.0, 3.0, 2.0]);
    }
    // `;` files may use a decimal comma.
    let d = read("PV;OP\n1,5;2\n2;3,25\n1;2\n").unwrap();
    assert_eq!(d.pv.as_deref(), Some(&[1.5, 2.0, 1.0][..]));
    assert_eq!(d.op, vec![2.0, 3.25, 2.0]);
    assert_eq!(d.notes, vec!["read 2 cell(s) with a decimal comma"]);
    // ... in the time column too (seconds, or a stamp's fraction of a second), and day-first
    // stamps with dots, as a spreadsheet in such a locale writes them
    let d = read("t;PV;OP\n0,0;1;2\n0,5;2;3\n1,0;1;2\n").unwrap();
    assert_eq!(d.t.as_deref(), Some(&[0.0, 0.5, 1.0][..]));
    assert_eq!(d.notes, vec!["read 3 cell(s) with a decimal comma"]);
    let d = read(
        "t;PV;OP\n29.11.2026 04:20:00;1;2\n29.11.2026 04:20:10;2;3\n29.11.2026 04:20:20,5;1;2\n",
    )
    .unwrap();
    assert_eq!(d.t.as_deref(), Some(&[0.0, 10.0, 20.5][..]));
    let d = read("t,PV,OP\n2026-11-29 04:20,1,2\n2026-11-29 04:21,2,3\n2026-11-29 04:22,1,2\n")
        .unwrap();
    assert_eq!(d.t.as_deref(), Some(&[0.0, 60.0, 120.0][..]));
}

#[test]
fn timestamps_become_seconds_from_the_first_sample() {
    let d = read(
        "time,PV,OP\n2024-10-17T21:55:00Z,1,2\n2024-10-17T21:55:10.5Z,2,3\n\
         2024-10-17T23:55:20+02:00,1,2\n",
    )
    .unwrap();
    assert_eq!(d.t.as_deref(), Some(&[0.0, 10.5, 20.0][..]));
    let d = read(
        "t,PV,OP\n2024-10-17 21:55:00,1,2\n2024-10-17 21:55:10,2,3\n2024-10-18 21:55:00.25,1,2\n",
    )
    .unwrap();
    assert_eq!(d.t.as_deref(), Some(&[0.0, 10.0, 86400.25][..]));
    let d = read(
        "t,PV,OP\n2024-10-17T21:55:00,1,2\n2024-10-17T21:56:00,2,3\n2024-10-17T21:57:00,1,2\n",
    )
    .unwrap();
    assert_eq!(d.t.as_deref(), Some(&[0.0, 60.0, 120.0][..]));
}

#[test]
fn columns_can_be_remapped() {
    let opts = ReadOptions {
        pv: Some("FLOW".into()),
        op: Some("out".into()),
        sp: Some("target".into()),
        mv: Some("Pos".into()),
        time: Some("stamp".into()),
        ..ReadOptions::default()
    };
    let d = read_with(
        "stamp,Flow,OUT,Target,pos,PV\n5,1,2,0,3,9\n6,2,3,0,3,9\n7,1,2,0,4,9\n",
        &opts,
    )
    .unwrap();
    assert_eq!(d.pv.as_deref(), Some(&[1.0, 2.0, 1.0][..]));
    assert_eq!(d.op, vec![2.0, 3.0, 2.0]);
    assert_eq!(d.mv.as_deref(), Some(&[3.0, 3.0, 4.0][..]));
    assert_eq!(d.t.as_deref(), Some(&[0.0, 1.0, 2.0][..]));
    assert_eq!(d.notes, vec!["ignored column(s): PV"]);
    // An explicitly named optional column must exist.
    let opts = ReadOptions {
        sp: Some("target".into()),
        ..ReadOptions::default()
    };
    assert_eq!(
        message(read_with("PV,OP\n1,2\n2,3\n1,2\n", &opts)),
        r#"loop.csv: no column SP ("target") in the header (found: PV, OP)"#
    );
}

#[test]
fn pv_is_optional_when_the_caller_says_so() {
    let opts = ReadOptions {
        require_pv: false,
        ..ReadOptions::default()
    };
    let d = read_with("OP\n1\n2\n3\n", &opts).unwrap();
    assert_eq!(d.pv, None);
    assert_eq!(d.op, vec![1.0, 2.0, 3.0]);
    assert_eq!(
        message(d.require_pv().map(|_| d.clone())),
        r#"loop.csv: no column PV in the header (found: OP)"#
    );
}

#[test]
fn error_messages() {
    let cases: Vec<(&[u8], &str)> =
        vec![
        (b"", "loop.csv: empty file (no header row)"),
        (b"\n \n", "loop.csv: empty file (no header row)"),
        (b"PV,OP\n1,\xff\n", "loop.csv: row 2: invalid UTF-8 at byte 8"),
        (
            b"a,OP\n1,2\n",
            r#"loop.csv: no column PV ("pv"; name yours with --pv) in the header (found: a, OP)"#,
        ),
        (
            b"PV,b\n1,2\n",
            r#"loop.csv: no column OP ("op"; name yours with --op) in the header (found: PV, b)"#,
        ),
        (b"PV,OP\n1,2\n3\n", "loop.csv: row 3: 1 cells, the header has 2"),
        (b"PV,OP\n1,2\n3,4,5\n", "loop.csv: row 3: 3 cells, the header has 2"),
        (
            b"PV,OP\n1,2\n2,3\nabc,4\n",
            r#"loop.csv: row 4, column PV: "abc" is not a number"#,
        ),
        (
            b"PV,OP\n1,2\n2,inf\n",
            r#"loop.csv: row 3, column OP: "inf" is not a finite number"#,
        ),
        (
            b"t,PV,OP\n0,1,2\nnoon,2,3\n",
            "loop.csv: row 3, column t: \"noon\" is not a time (seconds, or a timestamp \
             YYYY-MM-DDTHH:MM:SS[.fff][Z|+hh:mm], YYYY-MM-DD HH:MM[:SS[.fff]] or DD.MM.YYYY \
             HH:MM[:SS[.fff]], one kind per column)",
        ),
        (
            b"t,PV,OP\n0,1,2\n2024-01-01T00:00:00,2,3\n",
            "loop.csv: row 3, column t: \"2024-01-01T00:00:00\" is not a time (seconds, or a \
             timestamp YYYY-MM-DDTHH:MM:SS[.fff][Z|+hh:mm], YYYY-MM-DD HH:MM[:SS[.fff]] or \
             DD.MM.YYYY HH:MM[:SS[.fff]], one kind per column)",
        ),
        (
            b"PV,OP\n1,2\n2,\nNaN,3\n1,nan\n2,3\n",
            "loop.csv: 3 empty or NaN cell(s) in the used columns, the first at row 3, column OP; \
             fill them (hold the last value) or drop them (keep the longest clean segment) \
             explicitly",
        ),
        (b"PV,OP\n,2\nnan,3\n", "loop.csv: column PV: every cell is empty or NaN"),
        (b"PV,OP\n1,2\n2,3\n", "loop.csv: too few data rows: 3 needed, 2 available"),
        (b"PV,OP\n", "loop.csv: too few data rows: 3 needed, 0 available"),
        (b"PV,OP\n1,2\n2,2\n3,2\n", "loop.csv: column OP: constant (2.0) over all 3 rows"),
        (b"PV,OP\n1,2\n1,3\n1,2\n", "loop.csv: column PV: constant (1.0) over all 3 rows"),
    ];
    for (input, want) in cases {
        let got = read_csv(input, "loop.csv", &ReadOptions::default())
            .map(|d| format!("unexpected success: {d:?}"))
            .unwrap_or_else(|e| e.to_string());
        assert_eq!(got, want, "input {:?}", String::from_utf8_lossy(input));
        assert!(!got.contains('\n'));
    }
    let fill = ReadOptions {
        gaps: GapPolicy::FillHold,
        ..ReadOptions::default()
    };
    assert_eq!(
        message(read_with(
            "PV,OP\n1,2\n2,3\n3,2\n",
            &ReadOptions {
                min_rows: 10,
                ..fill.clone()
            }
        )),
        "loop.csv: too few data rows: 10 needed, 3 available"
    );
    assert_eq!(
        message(read_with("PV,OP\n1,\n2,\n3,2\n4,3\n", &fill)),
        "loop.csv: row 2, column OP: the column starts with 2 empty or NaN cell(s), there is no \
         earlier value to hold; drop the gaps instead"
    );
    let e = read_csv_path("/nonexistent/dir/loop.csv", &ReadOptions::default()).unwrap_err();
    assert!(matches!(e, DataError::Io { .. }));
    assert!(
        e.to_string().starts_with("/nonexistent/dir/loop.csv: "),
        "{e}"
    );
}

#[test]
fn gaps_fill_hold() {
    let opts = ReadOptions {
        gaps: GapPolicy::FillHold,
        ..ReadOptions::default()
    };
    let d = read_with("t,PV,OP,SP\n0,1,2,\n1,,3,\n,NaN,4,\n3,2,,\n4,3,5,\n", &opts).unwrap();
    assert_eq!(d.pv.as_deref(), Some(&[1.0, 1.0, 1.0, 2.0, 3.0][..]));
    assert_eq!(d.op, vec![2.0, 3.0, 4.0, 4.0, 5.0]);
    assert_eq!(d.t.as_deref(), Some(&[0.0, 1.0, 2.0, 3.0, 4.0][..]));
    assert_eq!(d.sp, None);
    assert_eq!(
        d.notes,
        vec![
            "column SP ignored: every cell is empty or NaN",
            "filled 1 gap(s) in column t by linear interpolation of time",
            "filled 2 gap(s) in column PV by holding the last value",
            "filled 1 gap(s) in column OP by holding the last value",
        ]
    );
}

#[test]
fn gaps_dropped_keeps_the_longest_clean_segment() {
    let opts = ReadOptions {
        gaps: GapPolicy::DropGaps,
        ..ReadOptions::default()
    };
    let text = "t,PV,OP\n0,1,2\n1,2,3\n2,,4\n3,2,5\n4,3,6\n5,4,5\n6,3,nan\n7,1,1\n";
    let d = read_with(text, &opts).unwrap();
    assert_eq!(d.pv.as_deref(), Some(&[2.0, 3.0, 4.0][..]));
    assert_eq!(d.op, vec![5.0, 6.0, 5.0]);
    assert_eq!(d.t.as_deref(), Some(&[0.0, 1.0, 2.0][..]));
    assert_eq!(
        d.notes,
        vec![
            "dropped gaps: kept rows 5-7 (3 of 8 data rows), the longest segment without empty \
             or NaN cells (2 gap cell(s) in total)"
        ]
    );
    // Gaps in an ignored column do not count.
    let d = read("PV,OP,X\n1,2,\n2,3,\n1,2,\n").unwrap();
    assert_eq!(d.len(), 3);
    // Too short a clean segment.
    assert_eq!(
        message(read_with("PV,OP\n1,2\n,3\n2,3\n", &opts)),
        "loop.csv: too few data rows: 3 needed, 1 available"
    );
}

/// The real plant registrations in `../shared/data/plant` (skipped when absent): every file
/// reads (FIC10112 is known bad data, its PV constant: a clear error is fine, a panic is not).
#[test]
fn plant_data_reads() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/plant");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!("skipped: {} not found", dir.display());
        return;
    };
    let mut ok = 0;
    for entry in entries.flatten() {
        let path = entry.path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if !name.ends_with(".csv") || name == "labels.csv" {
            continue;
        }
        match read_csv_path(&path, &ReadOptions::default()) {
            Ok(d) => {
                assert_eq!(d.len(), 751, "{name}");
                assert_eq!(d.t.as_ref().map(|t| t[1]), Some(10.0), "{name}");
                assert!(d.sp.is_some());
                ok += 1;
            }
            Err(e) => {
                assert!(name.contains("FIC10112"), "{name}: {e}");
                println!("{name}: {e}");
            }
        }
    }
    assert!(ok >= 40, "{ok} files read");
}

fn cell() -> impl Strategy<Value = String> {
    prop_oneof![
        Just(String::new()),
        Just("nan".to_string()),
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just("\"".to_string()),
        Just("2024-01-01T00:00:00Z".to_string()),
        Just("AUTO".to_string()),
        Just("man".to_string()),
        any::<f64>().prop_map(|v| v.to_string()),
        (-100i32..100).prop_map(|v| v.to_string()),
        "[a-zA-Z0-9 .,;:\\-+eE\"]{0,8}",
    ]
}

fn header_name() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("PV".to_string()),
        Just("op".to_string()),
        Just("SP".to_string()),
        Just("MV".to_string()),
        Just("t".to_string()),
        Just("time".to_string()),
        Just("MODE".to_string()),
        "[a-z]{0,3}",
    ]
}

proptest! {
    // 300 cases by default; `PROPTEST_CASES` (`cargo xtask proptest --cases N`) scales it.
    #![proptest_config(ProptestConfig::with_cases(
        std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(300)
    ))]

    #[test]
    fn never_panics_on_random_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = read_csv(&bytes[..], "fuzz.csv", &ReadOptions::default());
    }

    #[test]
    fn never_panics_on_random_tables(
        header in proptest::collection::vec(header_name(), 1..6),
        rows in proptest::collection::vec(proptest::collection::vec(cell(), 0..7), 0..12),
        delim in prop_oneof![Just(','), Just(';'), Just('\t')],
        gaps in prop_oneof![Just(GapPolicy::Refuse), Just(GapPolicy::FillHold), Just(GapPolicy::DropGaps)],
        require_pv in any::<bool>(),
        min_rows in 0usize..5,
    ) {
        let mut text = header.join(&delim.to_string());
        for r in &rows {
            text.push('\n');
            text.push_str(&r.join(&delim.to_string()));
        }
        let opts = ReadOptions { gaps, require_pv, min_rows, ..ReadOptions::default() };
        match read_csv(text.as_bytes(), "fuzz.csv", &opts) {
            Ok(d) => {
                let n = d.len();
                prop_assert!(n >= min_rows.max(1));
                prop_assert!(d.op.iter().all(|v| v.is_finite()));
                for s in [&d.t, &d.sp, &d.pv, &d.mv].into_iter().flatten() {
                    prop_assert_eq!(s.len(), n);
                    prop_assert!(s.iter().all(|v| v.is_finite()));
                }
            }
            Err(e) => prop_assert!(!e.to_string().contains('\n')),
        }
    }
}

/// A record of `n` rows `t,PV,OP,MODE` with moving PV and OP.
fn record(n: usize, mode: impl Fn(usize) -> String) -> String {
    let mut s = String::from("t,PV,OP,MODE\n");
    for i in 0..n {
        let x = (i as f64 * 0.7).sin();
        s.push_str(&format!(
            "{},{},{},{}\n",
            10 * i,
            5.0 + x,
            50.0 + 2.0 * x,
            mode(i)
        ));
    }
    s
}

#[test]
fn mode_keeps_the_longest_closed_loop_segment() {
    // Manual rows 0-6 and 30-34; auto (1, AUTO, CAS) elsewhere: rows 35-59 are the longest.
    let text = record(60, |i| match i {
        0..=6 => "0".into(),
        30..=34 => "MAN".into(),
        7..=29 => "AUTO".into(),
        _ => {
            if i % 2 == 0 {
                "1".into()
            } else {
                "cas".into()
            }
        }
    });
    let d = read(&text).unwrap();
    assert_eq!(d.len(), 25);
    assert_eq!(d.t.as_deref().unwrap()[0], 0.0);
    assert_eq!(d.op[0], 50.0 + 2.0 * (35.0f64 * 0.7).sin());
    assert_eq!(
        d.notes,
        vec!["column MODE: 12 of 60 rows not in closed loop (manual or unknown mode, 2 stretch(es)); kept rows 37-61 (25 rows), the longest closed-loop segment"]
    );
    assert_eq!(
        message(read(&record(30, |_| "0".into()))),
        "loop.csv: column MODE: no row in closed loop (all 30 rows manual or unknown mode)"
    );
    assert_eq!(
        message(read(&record(30, |i| if i == 3 {
            "weird".into()
        } else {
            "1".into()
        }))),
        r#"loop.csv: row 5, column MODE: "weird" is not a controller mode (a number, 0 = manual; or AUTO, CAS, MAN, ...)"#
    );
}

#[test]
fn repeated_time_stamps_are_refused() {
    let text = "t,PV,OP\n0,1,2\n10,2,3\n10,1,2\n20,2,3\n30,1,2\n";
    assert_eq!(
        message(read(text)),
        "loop.csv: row 4, column t: time does not increase (10 s after 10 s from the first sample); 1 repeated or backward time stamp(s): duplicated rows or a clock jump in the export, refused"
    );
    // the same row with CRLF line ends (the csv crate's own line count was one short)
    assert_eq!(
        message(read(&text.replace('\n', "\r\n"))),
        message(read(text))
    );
}

/// Stamps written at a coarser resolution than the sampling: a stamp repeating the previous one
/// whose next step restores the grid (`40, 40, 60` at 10 s) is read in file order on the grid,
/// with a note naming the first row and the count; a backward jump, or a repeat the next step
/// does not restore, is refused naming file, row and column.
#[test]
fn stamps_one_interval_off_the_grid_are_read_on_it_with_a_note() {
    let rows = |t: &dyn Fn(usize) -> f64| {
        let mut text = String::from("t,PV,OP\n");
        for k in 0..40 {
            let (pv, op) = (
                50.0 + (0.7 * k as f64).sin(),
                40.0 + 3.0 * (1.3 * k as f64).cos(),
            );
            text.push_str(&format!("{},{pv},{op}\n", t(k)));
        }
        text
    };
    // every tenth stamp repeats the previous one, and so does the last row's
    let glitched = |k: usize| {
        if (k.is_multiple_of(10) && k > 0) || k == 39 {
            10.0 * (k - 1) as f64
        } else {
            10.0 * k as f64
        }
    };
    let d = read(&rows(&glitched)).unwrap();
    let grid: Vec<f64> = (0..40).map(|k| 10.0 * k as f64).collect();
    assert_eq!(d.t.as_deref(), Some(grid.as_slice()));
    assert_eq!(d.len(), 40);
    assert_eq!(
        d.notes,
        vec!["column t: 4 time stamp(s) one sampling interval off the regular grid of their neighbours, the first at row 12 (4 repeating the previous stamp): stamps written at a coarser resolution than the sampling, not reordered rows; read in file order on the grid"]
    );
    // a clock that jumps back five seconds
    let back = |k: usize| 10.0 * k as f64 - if k == 20 { 15.0 } else { 0.0 };
    assert_eq!(
        message(read(&rows(&back))),
        "loop.csv: row 22, column t: time does not increase (185 s after 190 s from the first sample); 1 repeated or backward time stamp(s): duplicated rows or a clock jump in the export, refused"
    );
    // a duplicated row: the stamp repeats and the grid goes on from it
    let dup = |k: usize| 10.0 * k.saturating_sub(usize::from(k >= 20)) as f64;
    assert_eq!(
        message(read(&rows(&dup))),
        "loop.csv: row 22, column t: time does not increase (190 s after 190 s from the first sample); 1 repeated or backward time stamp(s): duplicated rows or a clock jump in the export, refused"
    );
}

#[test]
fn missing_samples_follow_the_gap_policy() {
    // 10 s sampling with one 30 s interval (two samples missing) before row 5.
    let text = "t,PV,OP\n0,1,2\n10,2,3\n20,1,2\n50,2,4\n60,1,2\n70,2,3\n80,1,2.5\n";
    assert_eq!(
        message(read(text)),
        "loop.csv: row 5, column t: 1 interval(s) longer than 1.5 x the median sampling time 10 s, the first ending here (30 s): samples are missing; fill them (hold the last value) or drop them (keep the longest regular segment) explicitly"
    );
    let fill = ReadOptions {
        gaps: GapPolicy::FillHold,
        ..ReadOptions::default()
    };
    let d = read_with(text, &fill).unwrap();
    assert_eq!(
        d.t.as_deref().unwrap(),
        &[0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0][..]
    );
    assert_eq!(d.op, vec![2.0, 3.0, 2.0, 2.0, 2.0, 4.0, 2.0, 3.0, 2.5]);
    assert!(
        d.notes[0].contains("inserted 2 row(s) holding the last values"),
        "{:?}",
        d.notes
    );
    let drop = ReadOptions {
        gaps: GapPolicy::DropGaps,
        ..ReadOptions::default()
    };
    let d = read_with(text, &drop).unwrap();
    assert_eq!(d.op, vec![4.0, 2.0, 3.0, 2.5]);
    assert!(
        d.notes[0].contains("kept rows 5-8 (4 rows)"),
        "{:?}",
        d.notes
    );
}

#[test]
fn flat_stretches_are_reported_or_refused() {
    // PV frozen for 8 samples: noted.
    let mut text = String::from("t,PV,OP\n");
    for i in 0..40 {
        let pv = if (10..18).contains(&i) {
            3.0
        } else {
            (i as f64).sin()
        };
        text.push_str(&format!("{i},{pv},{}\n", 50.0 + (i as f64 * 0.3).cos()));
    }
    let d = read(&text).unwrap();
    assert_eq!(d.notes, vec!["column PV: 7 of 40 samples repeat the previous value exactly, the longest flat stretch 8 samples from row 12 (historian compression or a frozen value?); kept"]);
    // OP frozen for 25 of 40 rows: refused.
    let mut text = String::from("t,PV,OP\n");
    for i in 0..40 {
        let op = if i >= 15 { 60.0 } else { 50.0 + i as f64 };
        text.push_str(&format!("{i},{},{op}\n", (i as f64).sin()));
    }
    assert_eq!(
        message(read(&text)),
        "loop.csv: row 17, column OP: the same value for 25 of 40 rows (historian compression, a frozen transmitter or a saturated valve): too little movement to identify"
    );
}

/// Under `accept_constant` (the detector's reading) a PV flat over more than half of the rows
/// is kept with a note: a flat PV under a moving OP is the detector's to answer.
#[test]
fn a_long_flat_stretch_is_kept_with_a_note_when_the_caller_accepts_it() {
    let mut text = String::from("t,PV,OP\n");
    for i in 0..40 {
        let pv = if i >= 15 { 60.0 } else { 50.0 + i as f64 };
        text.push_str(&format!("{i},{pv},{}\n", (i as f64).sin()));
    }
    let opts = ReadOptions {
        accept_constant: true,
        ..ReadOptions::default()
    };
    let d = read_with(&text, &opts).unwrap();
    assert_eq!(d.op.len(), 40);
    assert!(
        d.notes
            .iter()
            .any(|n| n.contains("the same value for 25 of 40 rows from row 17")),
        "{:?}",
        d.notes
    );
    assert!(read(&text).is_err());
}

#[test]
fn start_time_comes_from_time_stamps() {
    let d = read(
        "time,PV,OP\n2024-06-09 07:50:00,1,2\n2024-06-09 07:50:10,2,3\n2024-06-09 07:50:20,1,2\n",
    )
    .unwrap();
    assert_eq!(datasets::format_epoch(d.start.unwrap()), "2024-06-09 07:50");
    assert_eq!(d.t.as_deref(), Some(&[0.0, 10.0, 20.0][..]));
}

#[test]
fn a_constant_column_is_refused_unless_the_caller_accepts_it() {
    let text = "PV,OP\n1,2\n2,2\n1,2\n";
    assert_eq!(
        message(read(text)),
        "loop.csv: column OP: constant (2.0) over all 3 rows"
    );
    let opts = ReadOptions {
        accept_constant: true,
        ..ReadOptions::default()
    };
    let d = read_with(text, &opts).unwrap();
    assert_eq!(d.op, vec![2.0, 2.0, 2.0]);
    assert_eq!(
        d.notes,
        vec!["column OP: constant (2.0) over all 3 rows; kept"]
    );
}

/// A historian's export names columns by tag and parameter: the one column whose name ends in
/// the role's name after a separator takes the role, with a note; several leave it unfound.
#[test]
fn tag_suffixed_columns_take_their_role() {
    let d = read(
        "Timestamp,FIC101.SP,FIC101.PV,FIC101_OP\n\
         2024-01-01 00:00:00,1,2,3\n2024-01-01 00:00:10,1,2.5,3.5\n2024-01-01 00:00:20,1,2,3\n",
    )
    .unwrap();
    assert_eq!(d.pv.as_deref(), Some(&[2.0, 2.5, 2.0][..]));
    assert_eq!(d.op, vec![3.0, 3.5, 3.0]);
    assert_eq!(d.sp.as_deref(), Some(&[1.0, 1.0, 1.0][..]));
    assert_eq!(d.t.as_deref(), Some(&[0.0, 10.0, 20.0][..]));
    assert!(
        d.notes
            .iter()
            .any(|n| *n == r#"PV: read from column 3 ("FIC101.PV"), whose name ends in it; name another with --pv"#),
        "{:?}",
        d.notes
    );
    // units after the name
    let d = read("t [s],PV [m3/h],OP (%)\n0,1,2\n10,2,3\n20,1,2\n").unwrap();
    assert_eq!(d.pv.as_deref(), Some(&[1.0, 2.0, 1.0][..]));
    assert_eq!(d.t.as_deref(), Some(&[0.0, 10.0, 20.0][..]));
    let d = read("Timestamp,FIC101.PV (t/h),FIC101.OP [%]\n0,1,2\n10,2,3\n20,1,2\n").unwrap();
    assert_eq!(d.op, vec![2.0, 3.0, 2.0]);
    let opts = ReadOptions {
        pv: Some("PV [m3/h]".into()),
        ..ReadOptions::default()
    };
    let d = read_with("PV [m3/h],OP\n1,2\n2,3\n1,2\n", &opts).unwrap();
    assert_eq!(d.pv.as_deref(), Some(&[1.0, 2.0, 1.0][..]));
    // two loops' PVs: no guess
    assert_eq!(
        message(read("FIC101.PV,TIC7.PV,OP\n1,2,3\n2,3,4\n1,2,3\n")),
        r#"loop.csv: no column PV ("pv"; name yours with --pv) in the header (found: FIC101.PV, TIC7.PV, OP)"#
    );
    // a name that merely ends in the letters is no tag's parameter; MV is never guessed
    let d = read("PV,HOOP,FIC1.MV\n1,2,3\n2,3,4\n1,2,3\n");
    assert!(d.is_err(), "{d:?}");
    let d = read("PV,OP,FIC1.MV\n1,2,3\n2,3,4\n1,2,3\n").unwrap();
    assert_eq!(d.mv, None);
}
