//! `stiction batch` with hostile registrations (issue 15): one bad file (a panic, OP x 1e9, a
//! grid over the node budget) is that row's error and the rest go on; a torn last JSONL line
//! is recomputed with a note.
// Test helpers outside #[test] functions may unwrap too: a panic is how a test fails.
#![allow(clippy::unwrap_used)]

mod common;

use std::path::Path;

use common::{jsonl, run, run_ok, temp_dir};
use datasets::simulate::Scenario;
use serde_json::Value;
use stiction_models::Kano;

/// Four good registrations of `valve`, and `<valve>_20240901-0800.csv` with OP x 1e9.
fn write(dir: &Path, valve: &str) {
    for k in 0..5u64 {
        let sim = Scenario {
            valve: Box::new(Kano::params().s(3.0).j(1.0).check().unwrap()),
            samples: 600,
            seed: 20 + k,
            ..Scenario::default()
        }
        .simulate()
        .unwrap();
        let mut csv = String::from("t,SP,PV,OP\n");
        let scale = if k == 4 { 1e9 } else { 1.0 };
        for i in 0..sim.len() {
            csv.push_str(&format!(
                "{},{},{},{}\n",
                sim.t[i],
                sim.sp[i],
                sim.pv[i],
                sim.op[i] * scale
            ));
        }
        std::fs::write(
            dir.join(format!("{valve}_2024{:02}01-0800.csv", k + 5)),
            csv,
        )
        .unwrap();
    }
}

/// A registration with OP x 1e9 among good ones aborted the process (allocation failure) with
/// no CSV written, and resuming aborted at the same file.
#[test]
fn a_scaled_op_file_does_not_end_the_batch() {
    let dir = temp_dir("iso-scale");
    write(&dir, "V1");
    let outs = temp_dir("iso-scale-out");
    let out = outs.join("res");
    run_ok(
        &["batch", dir.to_str().unwrap(), "-o", out.to_str().unwrap()],
        b"",
    );
    let rows = jsonl(&outs.join("res.jsonl"));
    assert_eq!(rows.len(), 5);
    assert!(outs.join("res.csv").exists());
    // With an explicit fine step the scaled file's grid is over the budget: its row's error.
    let out2 = outs.join("res2");
    run_ok(
        &[
            "batch",
            dir.to_str().unwrap(),
            "-o",
            out2.to_str().unwrap(),
            "--step",
            "0.05",
        ],
        b"",
    );
    let rows = jsonl(&outs.join("res2.jsonl"));
    assert_eq!(rows.len(), 5);
    let bad: Vec<&Value> = rows.iter().filter(|r| r["status"] == "error").collect();
    assert_eq!(bad.len(), 1, "{rows:?}");
    assert_eq!(bad[0]["file"], "V1_20240901-0800.csv");
    assert!(
        bad[0]["error"].as_str().unwrap().contains("node budget"),
        "{}",
        bad[0]["error"]
    );
}

/// A panic while evaluating one registration is that row's error.
#[test]
fn a_panicking_registration_is_its_rows_error() {
    let dir = temp_dir("iso-panic");
    write(&dir, "P9");
    // Only this test's file name (the tests of this binary run in parallel).
    std::env::set_var("STICTION_TEST_PANIC_ON", "P9_20240601-0800.csv");
    let out = dir.join("res");
    run_ok(
        &["batch", dir.to_str().unwrap(), "-o", out.to_str().unwrap()],
        b"",
    );
    let rows = jsonl(&dir.join("res.jsonl"));
    assert_eq!(rows.len(), 5);
    let row = rows
        .iter()
        .find(|r| r["file"] == "P9_20240601-0800.csv")
        .unwrap();
    assert_eq!(row["status"], "error");
    assert!(
        row["error"].as_str().unwrap().contains("internal error"),
        "{row}"
    );
    assert_eq!(rows.iter().filter(|r| r["status"] == "ok").count(), 4);
}

/// A torn last JSONL line (an interrupted run) was dropped silently; it is recomputed with a
/// note.
#[test]
fn a_torn_last_line_is_recomputed_with_a_note() {
    let dir = temp_dir("iso-torn");
    write(&dir, "V1");
    std::fs::remove_file(dir.join("V1_20240901-0800.csv")).unwrap();
    let out = dir.join("res");
    let args = ["batch", dir.to_str().unwrap(), "-o", out.to_str().unwrap()];
    assert_eq!(run(&args, b"").code, 0);
    let path = dir.join("res.jsonl");
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text.lines().count(), 4);
    // Tear the last line in the middle.
    let cut = text.trim_end().len() - 40;
    std::fs::write(&path, &text[..cut]).unwrap();
    let o = run_ok(&args, b"");
    assert!(
        o.stderr.contains("line 4 is torn") && o.stderr.contains("computed again"),
        "{}",
        o.stderr
    );
    let rows = jsonl(&path);
    assert_eq!(rows.len(), 4, "{rows:?}");
}
