//! Hostile input (issue 15): size limits with one short line, and messages naming the column.
// Test helpers outside #[test] functions may unwrap too: a panic is how a test fails.
#![allow(clippy::unwrap_used)]

use std::io::Read;

use datasets::{read_csv, read_mat, Limits, ReadOptions};

fn err(bytes: impl Read, opts: &ReadOptions) -> String {
    let e = read_csv(bytes, "f.csv", opts).unwrap_err().to_string();
    assert!(!e.contains('\n'), "{e}");
    e
}

/// A huge cell was echoed whole into the error line (1 GB on stderr).
#[test]
fn a_huge_cell_is_quoted_as_a_short_excerpt() {
    // Under the cell limit but not a number: the excerpt, not the cell.
    let cell = "x".repeat(50_000);
    let csv = format!("PV,OP\n1,2\n{cell},3\n");
    let e = err(csv.as_bytes(), &ReadOptions::default());
    assert!(
        e.len() < 200 && e.contains("(50000 bytes)") && e.contains("column PV"),
        "{e}"
    );
    // Over the cell limit (64 KiB), on a line under the line limit.
    let cell = "7".repeat(100_000);
    let csv = format!("PV,OP\n1,2\n{cell},3\n");
    let e = err(csv.as_bytes(), &ReadOptions::default());
    assert!(
        e.len() < 200 && e.contains("over the limit of 64 KiB"),
        "{e}"
    );
    // A header cell: the list of columns found is quoted in excerpts too.
    let csv = format!("{},Q\n1,2\n", "h".repeat(50_000));
    let e = err(csv.as_bytes(), &ReadOptions::default());
    assert!(e.len() < 300, "{e}");
}

/// `/dev/zero` was read until memory ran out; here 64 MiB of zeros (a 64 MiB "line").
#[test]
fn endless_bytes_stop_at_the_line_limit() {
    let zeros = std::io::repeat(0).take(64 << 20);
    let e = err(zeros, &ReadOptions::default());
    assert!(e.contains("longer than 1024 KiB"), "{e}");
    let e = read_mat(
        std::io::repeat(0).take(600 << 20),
        "z.mat",
        &ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("MiB of input"), "{e}");
}

/// 10 M rows ran for minutes; the row count is limited (and configurable).
#[test]
fn the_row_count_is_limited() {
    let mut csv = String::from("PV,OP\n");
    for i in 0..500 {
        csv.push_str(&format!("{},{}\n", i % 7, i % 5));
    }
    let opts = ReadOptions {
        limits: Limits {
            max_rows: 100,
            ..Limits::default()
        },
        ..ReadOptions::default()
    };
    let e = err(csv.as_bytes(), &opts);
    assert!(
        e.contains("more than 100 data rows") && e.contains("--max-rows"),
        "{e}"
    );
    assert!(read_csv(csv.as_bytes(), "f.csv", &ReadOptions::default()).is_ok());
}

/// An alternating MODE column ended as "too few data rows" without naming MODE.
#[test]
fn an_alternating_mode_column_is_named() {
    let mut csv = String::from("PV,OP,MODE\n");
    for i in 0..100 {
        csv.push_str(&format!(
            "{},{},{}\n",
            i % 7,
            i % 5,
            if i % 2 == 0 { "AUTO" } else { "MAN" }
        ));
    }
    let opts = ReadOptions {
        min_rows: 30,
        ..ReadOptions::default()
    };
    let e = err(csv.as_bytes(), &opts);
    assert!(
        e.contains("column MODE") && e.contains("closed-loop segment has 1 of 100 rows"),
        "{e}"
    );
}

/// "Is a directory (os error 21): Is a directory (os error 21)": the cause once.
#[test]
fn io_errors_say_their_cause_once() {
    let dir = std::env::temp_dir();
    let e = datasets::read_path(&dir, &ReadOptions::default()).unwrap_err();
    let chain = format!("{:#}", anyhow_like(&e));
    assert_eq!(chain.matches("os error").count(), 1, "{chain}");
}

/// `{:#}` of an anyhow error: the message and its sources joined by ": ".
fn anyhow_like(e: &(dyn std::error::Error + 'static)) -> String {
    let mut s = e.to_string();
    let mut cur = e.source();
    while let Some(c) = cur {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cur = c.source();
    }
    s
}
