//! The batch API as a Python worker calls it: one file at a time, rows that survive JSON, a
//! resumable run over many files.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

use datasets::simulate::Scenario;
use grid_search::GridPlan;
use monitoring::batch::{self, BatchOptions, Label, Labels, Row, Status};
use run::Settings;
use stiction_models::Kano;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("monitoring-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write_loop(path: &Path, s: f64, seed: u64) {
    let sim = Scenario {
        valve: Box::new(Kano::params().s(s).j(s / 4.0).check().unwrap()),
        samples: 600,
        seed,
        ..Scenario::default()
    }
    .simulate()
    .unwrap();
    sim.write_csv(std::fs::File::create(path).unwrap()).unwrap();
}

fn options() -> BatchOptions {
    BatchOptions {
        stiction: vec!["kano".into(), "he".into()],
        settings: Settings {
            grid: Some(GridPlan::Exhaustive { step: 1.0 }),
            ..Settings::default()
        },
        ..BatchOptions::default()
    }
}

#[test]
fn one_file_gives_one_row_per_combination_and_a_bad_file_its_error() {
    let dir = temp_dir("run-file");
    let good = dir.join("V1_20240101-0800.csv");
    write_loop(&good, 4.0, 3);
    let opts = options();
    let rows = batch::run_file(&good, &opts);
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0].combination(), ("kano", "arx"));
    assert_eq!(rows[1].combination(), ("he", "arx"));
    let kano = rows[0].ok().unwrap();
    assert!((kano.s - 4.0).abs() <= 1.0, "S = {}", kano.s);
    assert_eq!(rows[0].valve, "V1");
    assert_eq!(rows[0].time.as_deref(), Some("2024-01-01 08:00"));
    // Rows travel as JSON and come back equal.
    for r in &rows {
        let back: Row = serde_json::from_str(&r.to_json_line()).unwrap();
        assert_eq!(&back, r);
    }
    // A missing file, a refused file and bad options are rows with their error.
    let missing = batch::run_file(&dir.join("nope.csv"), &opts);
    assert_eq!(missing.len(), 1);
    assert!(missing[0].error().is_some_and(|e| e.contains("nope.csv")));
    let flat = dir.join("V2_20240101-0800.csv");
    let mut text = String::from("t,PV,OP\n");
    for i in 0..100 {
        text.push_str(&format!("{i},5.0,{}\n", 50 + i % 7));
    }
    std::fs::write(&flat, text).unwrap();
    let refused = batch::run_file(&flat, &opts);
    assert!(
        matches!(&refused[0].status, Status::Error(e) if e.error.contains("column PV: constant")),
        "{refused:?}"
    );
    let bad = BatchOptions {
        linear: vec!["no-such-identifier".into()],
        ..options()
    };
    let rows = batch::run_file(&good, &bad);
    assert_eq!(rows.len(), 1);
    assert!(rows[0]
        .error()
        .is_some_and(|e| e.contains("no-such-identifier")));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_run_resumes_and_labels_measure_s() {
    let dir = temp_dir("resume");
    let mut files = Vec::new();
    for (k, s) in [0.2, 0.3, 4.0, 5.0].iter().enumerate() {
        let f = dir.join(format!("V1_2024{:02}01-0800.csv", k + 1));
        write_loop(&f, *s, 10 + k as u64);
        files.push(f);
    }
    let labels_path = dir.join("labels.csv");
    std::fs::write(
        &labels_path,
        "file,label\nV1_20240101-0800.csv,no-stiction\nV1_20240201-0800.csv,0\n\
         V1_20240301-0800.csv,stiction\nV1_20240401-0800.csv,yes\n",
    )
    .unwrap();
    let labels = Labels::read(&labels_path).unwrap();
    assert_eq!(labels.get("V1_20240401-0800.csv"), Some(Label::Stiction));
    let opts = BatchOptions {
        stiction: vec!["kano".into()],
        ..options()
    };
    let jsonl = dir.join("out.jsonl");
    let first = batch::run(&files, &opts, Some(&labels), Some(&jsonl), None).unwrap();
    assert_eq!((first.computed, first.skipped), (4, 0));
    assert_eq!(std::fs::read_to_string(&jsonl).unwrap().lines().count(), 4);
    let summary = batch::label_summary(&first.rows, "kano", "arx");
    assert_eq!((summary.rows, summary.stiction), (4, 2));
    assert!(summary.roc.is_some_and(|r| r.auc > 0.9), "{summary:?}");
    // Again: nothing to do; with a torn last line, that file again.
    let again = batch::run(&files, &opts, Some(&labels), Some(&jsonl), None).unwrap();
    assert_eq!((again.computed, again.skipped), (0, 4));
    assert_eq!(again.rows, first.rows);
    let text = std::fs::read_to_string(&jsonl).unwrap();
    std::fs::write(&jsonl, &text[..text.trim_end().len() - 30]).unwrap();
    let torn = batch::run(&files, &opts, Some(&labels), Some(&jsonl), None).unwrap();
    assert_eq!((torn.computed, torn.skipped, torn.torn), (1, 3, vec![4]));
    // Other options: everything again.
    let other = BatchOptions {
        min_fit: 60.0,
        ..opts.clone()
    };
    let redo = batch::run(&files, &other, None, Some(&jsonl), None).unwrap();
    assert_eq!(redo.computed, 4);
    let csv = dir.join("out.csv");
    batch::write_csv(&csv, &redo.rows).unwrap();
    let table = std::fs::read_to_string(&csv).unwrap();
    assert!(table.starts_with("file,valve,time,status,stiction_model,linear_model,S,S_lo"));
    assert_eq!(table.lines().count(), 5);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The detector's answer travels with every row: the same score and verdict as the detection
/// crate gives on the record as read, in the last two CSV columns; rows written before these
/// keys existed still read; `--labels` measures the score on the same rows as S.
#[test]
fn rows_carry_the_detector_answer_and_old_rows_still_read() {
    let dir = temp_dir("detect");
    let good = dir.join("V1_20240101-0800.csv");
    write_loop(&good, 4.0, 3);
    let opts = options();
    let rows = batch::run_file(&good, &opts);
    let d = datasets::read_path(&good, &opts.read).unwrap();
    let direct = monitoring::detect_loop(&d, false);
    let score = direct.score().unwrap();
    assert!((0.0..=1.0).contains(&score), "{score}");
    for r in &rows {
        assert_eq!(r.detect_score, Some(score));
        assert_eq!(r.detect_verdict, direct.verdict().as_str());
    }
    let header = batch::CSV_COLUMNS.join(",");
    assert!(
        header.ends_with(
            ",error,detect_score,detect_verdict,reduction,repair_reason,S_from,S_unit,S_one_step,S_one_step_lo,S_one_step_hi,detect_reason"
        ),
        "{header}"
    );
    let cells = rows[0].csv_record();
    let cell = |name: &str| {
        let k = batch::CSV_COLUMNS.iter().position(|c| *c == name).unwrap();
        cells[k].clone()
    };
    assert_eq!(cell("detect_score"), score.to_string());
    assert_eq!(cell("detect_verdict"), direct.verdict().as_str());
    assert_eq!(cell("detect_reason"), direct.reason());
    // the repair columns: the reduction, or the reason there is none
    let q = &rows[0].ok().unwrap().quantify;
    match &q.repair {
        Some(r) => assert_eq!(cell("reduction"), r.reduction.to_string()),
        None => assert_eq!(Some(&cell("repair_reason")), q.repair_reason.as_ref()),
    }
    // A file that cannot be read: no score, no verdict.
    let missing = batch::run_file(&dir.join("V9_nope.csv"), &opts);
    assert_eq!(missing[0].detect_score, None);
    assert_eq!(missing[0].detect_verdict, "");
    // A JSONL line of an older version (without the two keys) still reads.
    let mut old: serde_json::Value = serde_json::from_str(&rows[0].to_json_line()).unwrap();
    let obj = old.as_object_mut().unwrap();
    assert!(obj.remove("detect_score").is_some() && obj.remove("detect_verdict").is_some());
    let back: Row = serde_json::from_value(old).unwrap();
    assert_eq!(
        (back.detect_score, back.detect_verdict.as_str()),
        (None, "")
    );
    assert_eq!(back.status, rows[0].status);
    // A line written before the registration's one answer (no `S_from`, `S_one_step*`,
    // `S_unit`, `detect_reason`) still reads; a resumed run computes it again.
    let mut old: serde_json::Value = serde_json::from_str(&rows[0].to_json_line()).unwrap();
    let obj = old.as_object_mut().unwrap();
    // the keys after `repair_reason` (the header's tail, checked above)
    let answer_keys = &batch::CSV_COLUMNS[batch::CSV_COLUMNS.len() - 6..];
    for key in answer_keys {
        assert!(obj.remove(*key).is_some(), "{key}");
    }
    let back: Row = serde_json::from_value(old.clone()).unwrap();
    let ok = back.ok().unwrap();
    assert_eq!(
        (ok.s_from, ok.s_one_step, ok.s_unit.as_str()),
        (None, None, "")
    );
    assert_eq!(back.detect_reason, "");
    let jsonl = dir.join("old.jsonl");
    std::fs::write(&jsonl, format!("{old}\n")).unwrap();
    let resumed = batch::run(std::slice::from_ref(&good), &opts, None, Some(&jsonl), None).unwrap();
    assert_eq!((resumed.computed, resumed.skipped), (1, 0));
    assert!(resumed
        .rows
        .iter()
        .all(|r| r.ok().is_some_and(|o| o.s_from.is_some())));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_detector_score_is_measured_on_the_same_labelled_rows_as_s() {
    let dir = temp_dir("detect-auc");
    let f = dir.join("V1_20240101-0800.csv");
    write_loop(&f, 4.0, 3);
    let template = batch::run_file(&f, &options());
    // kano + arx rows: S and the score rank the labels in opposite orders.
    let row = |file: &str, s: f64, score: Option<f64>, label: Label| {
        let mut r = template[0].clone();
        r.file = file.into();
        r.label = Some(label);
        r.detect_score = score;
        if let Status::Ok(ok) = &mut r.status {
            ok.s = s;
        }
        r
    };
    let mut rows = vec![
        row("a", 1.0, Some(0.9), Label::NoStiction),
        row("b", 2.0, Some(0.8), Label::NoStiction),
        row("c", 3.0, Some(0.2), Label::Stiction),
        row("d", 4.0, Some(0.1), Label::Stiction),
        // no score: left out of the detector's ROC only
        row("e", 5.0, None, Label::Stiction),
        // S not finite: left out of both
        row("f", f64::NAN, Some(0.95), Label::Stiction),
    ];
    // another combination: left out of both
    let mut he = template[1].clone();
    he.label = Some(Label::Stiction);
    he.detect_score = Some(0.99);
    rows.push(he);
    let s = batch::label_summary(&rows, "kano", "arx");
    assert_eq!((s.rows, s.stiction), (5, 3));
    assert_eq!(s.roc.map(|r| r.auc), Some(1.0));
    let det = batch::detect_label_summary(&rows, "kano", "arx");
    assert_eq!((det.rows, det.stiction), (4, 2));
    assert_eq!(det.roc.map(|r| r.auc), Some(0.0));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A resumed run computes again the ok rows written before the detector existed (no verdict),
/// and keeps the others.
#[test]
fn rows_without_the_detector_are_computed_again_on_resume() {
    let dir = temp_dir("resume-detect");
    let (a, b) = (
        dir.join("V1_20240101-0800.csv"),
        dir.join("V2_20240101-0900.csv"),
    );
    write_loop(&a, 4.0, 3);
    write_loop(&b, 3.0, 4);
    let opts = options();
    let jsonl = dir.join("out.jsonl");
    let files = vec![a.clone(), b.clone()];
    batch::run(&files, &opts, None, Some(&jsonl), None).unwrap();
    // strip the detector's keys from V1's rows, as an older build wrote them
    let text = std::fs::read_to_string(&jsonl).unwrap();
    let old: Vec<String> = text
        .lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            if v["file"] == "V1_20240101-0800.csv" {
                let o = v.as_object_mut().unwrap();
                o.remove("detect_score");
                o.remove("detect_verdict");
            }
            v.to_string()
        })
        .collect();
    std::fs::write(&jsonl, old.join("\n") + "\n").unwrap();
    let r = batch::resume(&files, &opts, Some(&jsonl)).unwrap();
    assert_eq!(r.todo, vec![a.clone()]);
    assert!(r.kept.iter().all(|row| row.file == "V2_20240101-0900.csv"));
    let again = batch::run(&files, &opts, None, Some(&jsonl), None).unwrap();
    assert_eq!((again.computed, again.skipped), (1, 1));
    assert!(again.rows.iter().all(|row| !row.detect_verdict.is_empty()));
    let _ = std::fs::remove_dir_all(&dir);
}
