//! What a new user meets first: verdicts that say how far to trust them, one-line errors,
//! readable defaults, folders with non-loop files, JSON numbers on the grid, and a diagnosis
//! that says what to do first.

mod common;
use std::path::{Path, PathBuf};

use common::{run, run_ok, temp_dir};
use serde_json::Value;

fn plant(file: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/plant")
        .join(file);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!("skipped: {} is absent (shared plant data)", p.display());
        None
    }
}

fn simulated(s: &str, j: &str, seed: &str) -> String {
    let sim = run_ok(
        &[
            "simulate",
            "--param",
            &format!("S={s}"),
            "--param",
            &format!("J={j}"),
            "--seed",
            seed,
        ],
        b"",
    );
    sim.stdout
}

#[test]
fn a_clear_sticky_loop_gets_a_plain_verdict() {
    let o = run_ok(&["quantify", "-"], simulated("4", "1", "2").as_bytes());
    assert!(
        o.stdout.contains("  verdict: stiction: S = 4.00 %"),
        "{}",
        o.stdout
    );
    assert!(!o.stdout.contains("warning:"), "{}", o.stdout);
}

#[test]
fn a_slight_stiction_is_not_called_sticking() {
    let o = run_ok(&["quantify", "-"], simulated("0.6", "0.2", "3").as_bytes());
    let verdict = o
        .stdout
        .lines()
        .find(|l| l.trim_start().starts_with("verdict:"))
        .expect("a verdict line");
    assert!(!verdict.contains("the valve sticks"), "{}", o.stdout);
}

#[test]
fn weak_evidence_is_said_on_plant_data() {
    let Some(p) = plant("2411FIC20102_20241206-2155.csv") else {
        return;
    };
    let p = p.to_str().expect("utf-8");
    let o = run_ok(&["quantify", p], b"");
    for w in [
        "identification and validation fits disagree",
        "grid nodes were skipped",
        "In.3 fell back",
    ] {
        assert!(o.stdout.contains(w), "no warning {w:?}: {}", o.stdout);
    }
    let j = run(&["quantify", p, "--json"], b"");
    let v: Value = serde_json::from_str(&j.stdout).expect("json");
    let warnings = v["warnings"].as_array().expect("warnings");
    assert!(warnings.len() >= 3, "{warnings:?}");
}

#[test]
fn a_missing_file_is_one_line_without_repeats_and_gets_no_report() {
    let dir = temp_dir("missing");
    let report = dir.join("rep");
    let o = run(
        &[
            "quantify",
            "no-such-loop.csv",
            "--report",
            report.to_str().expect("utf-8"),
        ],
        b"",
    );
    assert_eq!(o.code, 1);
    assert_eq!(o.stderr.lines().count(), 1, "{}", o.stderr);
    assert_eq!(
        o.stderr.matches("No such file or directory").count(),
        1,
        "{}",
        o.stderr
    );
    assert!(!report.exists(), "a report was written for a missing file");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_folder_skips_files_that_are_not_loops() {
    let dir = temp_dir("folder");
    for (k, seed) in ["5", "6"].iter().enumerate() {
        std::fs::write(
            dir.join(format!("V7_2024{:02}01-0800.csv", k + 1)),
            simulated("3", "1", seed),
        )
        .expect("write");
    }
    std::fs::write(
        dir.join("labels.csv"),
        "file,label\nV7_20240101-0800.csv,stiction\n",
    )
    .expect("write");
    std::fs::write(dir.join("results.csv"), "valve,S\nV7,3\n").expect("write");
    let d = dir.to_str().expect("utf-8");
    let o = run_ok(&["trend", d, "--no-diagnose", "--json"], b"");
    // a results table is skipped with a note; a labels table quietly
    assert!(o.stderr.contains("skipped"), "{}", o.stderr);
    assert!(o.stderr.contains("results.csv"), "{}", o.stderr);
    assert!(!o.stderr.contains("labels.csv"), "{}", o.stderr);
    let v: Value = serde_json::from_str(&o.stdout).expect("json");
    assert_eq!(v["valve"], "V7");
    let out = dir.join("rows");
    run_ok(&["batch", d, "-o", out.to_str().expect("utf-8")], b"");
    let rows = std::fs::read_to_string(dir.join("rows.jsonl")).expect("rows");
    assert!(!rows.contains("labels.csv"), "{rows}");
    assert!(!rows.contains("results.csv"), "{rows}");
    assert_eq!(rows.lines().count(), 2, "{rows}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn json_numbers_sit_on_the_grid() {
    let o = run_ok(
        &["quantify", "-", "--json", "--step", "0.1"],
        simulated("3", "0.3", "4").as_bytes(),
    );
    // No float noise like 0.30000000000000004 in the text of the document.
    assert!(!o.stdout.contains("0000000000"), "{}", o.stdout);
    let v: Value = serde_json::from_str(&o.stdout).expect("json");
    for key in ["S", "J"] {
        let x = v[key].as_f64().expect("number");
        assert_eq!((x * 1e4).round() / 1e4, x, "{key} = {x}");
    }
}

#[test]
fn split_reads_fractions_and_shows_a_readable_default() {
    let h = run(&["quantify", "--help"], b"");
    assert!(h.stdout.contains("[default: 2/3]"), "{}", h.stdout);
    assert!(!h.stdout.contains("0.6666666666666666"), "{}", h.stdout);
    assert!(h.stdout.contains("Data options"), "{}", h.stdout);
    let data = simulated("3", "1", "5");
    let a = run(
        &["quantify", "-", "--json", "--split", "2/3"],
        data.as_bytes(),
    );
    let b = run(&["quantify", "-", "--json"], data.as_bytes());
    let (a, b): (Value, Value) = (
        serde_json::from_str(&a.stdout).expect("json"),
        serde_json::from_str(&b.stdout).expect("json"),
    );
    assert_eq!(a["split_index"], b["split_index"]);
    for bad in ["0", "1", "NaN", "3/2"] {
        let o = run(&["quantify", "-", "--split", bad], data.as_bytes());
        assert_eq!(o.code, 2, "--split {bad}: {}", o.stderr);
    }
}

#[test]
fn diagnose_says_what_to_do_first() {
    let o = run_ok(&["diagnose", "--example", "paper"], b"");
    // The decision first: the action with the S to use and its range, then the causes held.
    let second = o.stdout.lines().nth(1).expect("two lines");
    assert!(
        second.starts_with("action: schedule valve maintenance: S = 9.00 % [9.00, 9.00]"),
        "{}",
        o.stdout
    );
    let third = o.stdout.lines().nth(2).expect("three lines");
    assert!(third.starts_with("causes: none"), "{}", o.stdout);
    // One meaning per column: F_PV val is absolute on every row, ΔF_PV the difference.
    assert!(o.stdout.contains("F_PV val"), "{}", o.stdout);
    assert!(o.stdout.contains("ΔF_PV"), "{}", o.stdout);
}
