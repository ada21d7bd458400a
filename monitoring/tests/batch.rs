//! The batch API as a Python worker calls it: one file at a time, rows that survive JSON, a
//! resumable run over many files.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

use datasets::simulate::Scenario;
use grid_search::GridPlan;
use monitoring::batch::{self, BatchOptions, Label, Labels, Row, Status};
use monitoring::Settings;
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
