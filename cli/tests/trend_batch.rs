//! `stiction trend` and `stiction batch` on registrations generated with a seed (a valve whose
//! stiction grows), a bad file, resumability, and the real plant data in `../shared` (skipped
//! when absent).

#![allow(clippy::unwrap_used)]

mod common;

use std::path::Path;

use common::{jsonl, run, run_ok, temp_dir};
use datasets::simulate::Scenario;
use serde_json::Value;
use stiction_models::Kano;

/// Registrations of valve V1 a month apart with S = 2, 3, 4, 5, 6 % (J = 1), plus a file whose
/// PV is constant.
fn write_registrations(dir: &Path) -> Vec<f64> {
    let s_true = vec![2.0, 3.0, 4.0, 5.0, 6.0];
    for (k, s) in s_true.iter().enumerate() {
        let scenario = Scenario {
            valve: Box::new(Kano::params().s(*s).j(1.0).check().unwrap()),
            samples: 900,
            seed: 10 + k as u64,
            ..Scenario::default()
        };
        let sim = scenario.simulate().unwrap();
        let f = std::fs::File::create(dir.join(format!("V1_2024{:02}01-0800.csv", k + 1))).unwrap();
        sim.write_csv(f).unwrap();
    }
    let mut bad = String::from("t,PV,OP\n");
    for i in 0..100 {
        bad.push_str(&format!("{i},5.0,{}\n", 50.0 + (i % 7) as f64));
    }
    std::fs::write(dir.join("V1_20240615-0800.csv"), bad).unwrap();
    s_true
}

#[test]
fn trend_follows_growing_stiction_and_keeps_the_bad_file_in_its_row() {
    let dir = temp_dir("trend");
    let s_true = write_registrations(&dir);
    let out = run_ok(
        &["trend", dir.to_str().unwrap(), "--json", "--threshold", "3"],
        b"",
    );
    let doc: Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(doc["valve"], "V1");
    assert_eq!(doc["registrations"], 6);
    let regs = doc["combinations"][0]["registrations"].as_array().unwrap();
    // In time: Jan, Feb, Mar, Apr, May, then the bad file of 15 June.
    let times: Vec<&str> = regs.iter().map(|r| r["time"].as_str().unwrap()).collect();
    assert_eq!(times[0], "2024-01-01 08:00");
    assert_eq!(times[5], "2024-06-15 08:00");
    // PV constant under a moving OP: judged by the detector (inconclusive), nothing to fit
    let bad = &regs[5];
    assert_eq!(bad["flag"], "inconclusive");
    assert_eq!(bad["detection"]["verdict"], "inconclusive", "{bad}");
    let msg = bad["error"].as_str().unwrap();
    assert!(
        msg.contains("V1_20240615-0800.csv") && msg.contains("column PV: constant"),
        "{msg}"
    );
    // Estimates follow the true S, in order.
    let s: Vec<f64> = regs[..5].iter().map(|r| r["S"].as_f64().unwrap()).collect();
    for (est, truth) in s.iter().zip(&s_true) {
        assert!(
            (est - truth).abs() < 0.6,
            "S {est} for a valve with S = {truth}"
        );
    }
    assert!(
        doc["slope_per_30_days"].as_f64().unwrap() > 0.5,
        "{}",
        doc["slope_per_30_days"]
    );
    assert_eq!(doc["verdict"], "schedule maintenance");
    // A threshold above every S: not scheduled, but the level is over half of it: watched.
    let out = run(
        &[
            "trend",
            dir.to_str().unwrap(),
            "--json",
            "--threshold",
            "7.5",
        ],
        b"",
    );
    let doc: Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(doc["verdict"], "watch", "{}", doc["reason"]);
    let out = run(
        &[
            "trend",
            dir.to_str().unwrap(),
            "--json",
            "--threshold",
            "20",
        ],
        b"",
    );
    let doc: Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(doc["verdict"], "healthy", "{}", doc["reason"]);
    // Text output names the verdict and the rule.
    let out = run(&["trend", dir.to_str().unwrap()], b"");
    assert_eq!(out.code, 0);
    assert!(
        out.stdout.contains("valve V1: 6 registration(s)"),
        "{}",
        out.stdout
    );
    assert!(
        out.stdout.contains("verdict: schedule maintenance"),
        "{}",
        out.stdout
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn trend_refuses_several_valves_without_valve() {
    let dir = temp_dir("two-valves");
    let text = "t,PV,OP\n0,1,2\n1,2,3\n";
    std::fs::write(dir.join("A_20240101-0000.csv"), text).unwrap();
    std::fs::write(dir.join("B_20240101-0000.csv"), text).unwrap();
    let out = run(&["trend", dir.to_str().unwrap()], b"");
    assert_eq!(out.code, 2);
    assert!(
        out.stderr.contains("A (1), B (1): choose one with --valve"),
        "{}",
        out.stderr
    );
    let out = run(&["trend", dir.to_str().unwrap(), "--valve", "C"], b"");
    assert_eq!(out.code, 1);
    assert!(
        out.stderr
            .contains("no registration of valve C (found: A, B)"),
        "{}",
        out.stderr
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn batch_writes_rows_reports_failures_and_resumes() {
    let dir = temp_dir("batch");
    write_registrations(&dir);
    let out_prefix = dir.join("out");
    let args = [
        "batch",
        dir.to_str().unwrap(),
        "-o",
        out_prefix.to_str().unwrap(),
    ];
    let out = run_ok(&args, b"");
    assert!(
        out.stdout
            .contains("6 file(s): 5 row(s) ok, 1 error row(s); 6 file(s) computed, 0 skipped"),
        "{}",
        out.stdout
    );
    let rows = jsonl(&dir.join("out.jsonl"));
    assert_eq!(rows.len(), 6);
    let bad = rows
        .iter()
        .find(|r| r["file"] == "V1_20240615-0800.csv")
        .unwrap();
    assert_eq!(bad["status"], "error");
    assert!(bad["error"]
        .as_str()
        .unwrap()
        .contains("column PV: constant"));
    let good = rows
        .iter()
        .find(|r| r["file"] == "V1_20240301-0800.csv")
        .unwrap();
    assert_eq!(good["status"], "ok");
    assert!(
        (good["S"].as_f64().unwrap() - 4.0).abs() < 0.6,
        "{}",
        good["S"]
    );
    let csv = std::fs::read_to_string(dir.join("out.csv")).unwrap();
    assert_eq!(csv.lines().count(), 7, "{csv}");
    assert!(csv.starts_with("file,valve,time,status,stiction_model,linear_model,S,S_lo,S_hi"));
    // The detector's answer, the repair estimate, then the answer's S's provenance.
    assert!(
        csv.lines().next().unwrap().ends_with(
            ",error,detect_score,detect_verdict,reduction,repair_reason,S_from,S_unit,S_one_step,S_one_step_lo,S_one_step_hi,detect_reason"
        ),
        "{csv}"
    );
    let score = good["detect_score"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&score), "{good}");
    let verdict = good["detect_verdict"].as_str().unwrap();
    assert!(
        ["stiction", "no-stiction", "inconclusive"].contains(&verdict),
        "{good}"
    );
    // the constant PV: the detector's answer, and the fit's reason as the row's error
    assert_eq!(bad["detect_verdict"], "inconclusive", "{bad}");
    assert_eq!(bad["stiction_model"], "kano", "{bad}");

    // Again: everything is already done.
    let out = run_ok(&args, b"");
    assert!(
        out.stdout.contains("0 file(s) computed, 6 skipped"),
        "{}",
        out.stdout
    );
    assert_eq!(jsonl(&dir.join("out.jsonl")).len(), 6);

    // A changed file is done again, its old row replaced; a torn last line is dropped.
    let f = dir.join("V1_20240615-0800.csv");
    let mut text = std::fs::read_to_string(&f).unwrap();
    text.push_str("100,5.0,51\n");
    std::fs::write(&f, text).unwrap();
    let mut j = std::fs::read_to_string(dir.join("out.jsonl")).unwrap();
    j.push_str("{\"file\": \"torn");
    std::fs::write(dir.join("out.jsonl"), j).unwrap();
    let out = run(&args, b"");
    assert!(
        out.stdout.contains("1 file(s) computed, 5 skipped"),
        "{}",
        out.stdout
    );
    let rows = jsonl(&dir.join("out.jsonl"));
    assert_eq!(rows.len(), 6);
    std::fs::remove_dir_all(&dir).ok();
}

/// `--labels` reports the ROC AUC of S and, over the same rows, of the detector's score.
#[test]
fn batch_labels_report_the_auc_of_s_and_of_the_detector_score() {
    let dir = temp_dir("batch-labels");
    write_registrations(&dir);
    // S = 2, 3 % called healthy, 4, 5, 6 % sticky; the bad file's row has no estimate.
    let labels = dir.join("labels.csv");
    std::fs::write(
        &labels,
        "file,label\nV1_20240101-0800.csv,no-stiction\nV1_20240201-0800.csv,no-stiction\n\
         V1_20240301-0800.csv,stiction\nV1_20240401-0800.csv,stiction\n\
         V1_20240501-0800.csv,stiction\nV1_20240615-0800.csv,stiction\n",
    )
    .unwrap();
    let out = run_ok(
        &[
            "batch",
            dir.to_str().unwrap(),
            "--labels",
            labels.to_str().unwrap(),
        ],
        b"",
    );
    let lines: Vec<&str> = out.stdout.lines().collect();
    let s_line = lines
        .iter()
        .position(|l| l.contains("ROC AUC of S = "))
        .unwrap_or_else(|| panic!("{}", out.stdout));
    assert!(lines[s_line].contains("5 labelled rows: 3 stiction, 2 no-stiction"));
    let det = lines[s_line + 1];
    assert!(
        det.starts_with("labels (detector, same rows, 5 with a score: 3 stiction, 2 no-stiction): ROC AUC of detect_score = "),
        "{}",
        out.stdout
    );
    let auc: f64 = det
        .split("ROC AUC of detect_score = ")
        .nth(1)
        .and_then(|r| r.split(';').next())
        .unwrap()
        .parse()
        .unwrap();
    assert!((0.0..=1.0).contains(&auc), "{det}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A valve whose S reaches the threshold but whose latest usable registrations the detector
/// calls no-stiction gets no maintenance call, and the reason says why (the healthy level loop
/// of the plant data, with a threshold below its S; skipped when the data are absent).
#[test]
fn trend_makes_no_maintenance_call_on_a_valve_the_detector_finds_healthy() {
    let plant = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/plant");
    if !plant.is_dir() {
        println!("skipped: {} not found", plant.display());
        return;
    }
    let dir = temp_dir("trend-detector");
    for day in ["23", "24", "25"] {
        let f = format!("2111LIC31102B_202408{day}-2155.csv");
        std::fs::copy(plant.join(&f), dir.join(&f)).unwrap();
    }
    let out = run_ok(
        &[
            "trend",
            dir.to_str().unwrap(),
            "--json",
            "--threshold",
            "0.5",
            // a level (its tag's L): the test is about the trend's rule, so the loop kind is
            // given rather than decided from each record
            "--integrating",
            "yes",
        ],
        b"",
    );
    let doc: Value = serde_json::from_str(&out.stdout).unwrap();
    let level = doc["level"].as_f64().unwrap();
    assert!(
        level >= 0.5,
        "S alone would schedule maintenance: level {level}"
    );
    let regs = doc["combinations"][0]["registrations"].as_array().unwrap();
    // The rule: every conclusive verdict of the latest usable registrations is no-stiction,
    // and there is at least one.
    let mut healthy = 0;
    for r in regs {
        assert_eq!(r["flag"], "ok", "{r}");
        assert_ne!(r["detection"]["verdict"], "stiction", "{r}");
        if r["detection"]["verdict"] == "no-stiction" {
            healthy += 1;
            // the verdict's own rule, not a figure of these registrations
            assert!(
                r["detection"]["score"].as_f64().unwrap() <= detection::score::NO_STICTION_AT,
                "{r}"
            );
        }
    }
    assert!(healthy >= 1, "{regs:?}");
    assert_eq!(doc["verdict"], "watch", "{}", doc["reason"]);
    let reason = doc["reason"].as_str().unwrap();
    assert!(
        reason.contains("at or above the threshold")
            && reason.contains("detector finds no stiction"),
        "{reason}"
    );
    let text = run(
        &[
            "trend",
            dir.to_str().unwrap(),
            "--threshold",
            "0.5",
            "--integrating",
            "yes",
        ],
        b"",
    );
    assert!(
        text.stdout.contains("verdict: watch: ")
            && text.stdout.contains("detector finds no stiction"),
        "{}",
        text.stdout
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The plant data: the sticky valve's trend, the healthy level loop, the bad-data valve.
#[test]
fn plant_data_trend_and_batch() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/plant");
    if !dir.is_dir() {
        println!("skipped: {} not found", dir.display());
        return;
    }
    let d = dir.to_str().unwrap();
    let out = run_ok(&["trend", d, "--valve", "2411FIC20102", "--json"], b"");
    let doc: Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(doc["registrations"], 23);
    assert_eq!(doc["verdict"], "schedule maintenance", "{}", doc["reason"]);
    let regs = doc["combinations"][0]["registrations"].as_array().unwrap();
    let doubtful: Vec<&Value> = regs
        .iter()
        .filter(|r| r["flag"] == "outlier" || r["flag"] == "weak")
        .collect();
    assert!(!doubtful.is_empty());
    for r in &doubtful {
        assert!(!r["why"].as_array().unwrap().is_empty(), "{r}");
    }

    // a level (its tag's L), given as such: the trend's verdict is under test, not the kind
    let out = run_ok(
        &[
            "trend",
            d,
            "--valve",
            "2111LIC31102B",
            "--json",
            "--integrating",
            "yes",
        ],
        b"",
    );
    let doc: Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(doc["registrations"], 9);
    assert!(doc["level"].as_f64().unwrap() < 1.0, "{}", doc["level"]);
    assert_ne!(doc["verdict"], "schedule maintenance");

    let labels = format!("{d}/labels.csv");
    let out = run_ok(
        &["batch", d, "--valve", "FIC10112", "--labels", &labels],
        b"",
    );
    // without -o the table carries each registration's label
    assert!(
        out.stdout.lines().next().unwrap().contains(" label "),
        "{}",
        out.stdout
    );
    assert_eq!(
        out.stdout.matches(" stiction ").count(),
        2,
        "both FIC10112 registrations are labelled sticky: {}",
        out.stdout
    );
    assert!(
        out.stdout.contains("0 row(s) ok, 2 error row(s)"),
        "{}",
        out.stdout
    );
    // read on the grid (their stamps are one interval off every 30 rows), then refused by the
    // identification for their constant PV (`detect` answers them: cli/tests/detect.rs)
    assert!(
        out.stdout
            .contains("column PV: constant (3.503246e-44) over all 751 rows"),
        "{}",
        out.stdout
    );
}

/// A registration disturbed by a slow external disturbance is flagged and the diagnosis says
/// so (the paper's §5.2: outliers explained by a disturbance present in that registration).
#[test]
fn trend_explains_a_disturbed_registration_with_the_diagnosis() {
    let dir = temp_dir("diagnosed");
    for k in 0..6u64 {
        let disturbed = k == 3;
        let scenario = Scenario {
            valve: Box::new(Kano::params().s(4.0).j(1.0).check().unwrap()),
            samples: 1500,
            seed: 40 + k,
            disturbances: if disturbed {
                vec![datasets::simulate::Disturbance::Paper { a: 1.5 }]
            } else {
                Vec::new()
            },
            ..Scenario::default()
        };
        let sim = scenario.simulate().unwrap();
        let f = std::fs::File::create(dir.join(format!("V2_2024{:02}01-0800.csv", k + 1))).unwrap();
        sim.write_csv(f).unwrap();
    }
    let o = run_ok(&["trend", dir.to_str().unwrap(), "--json"], b"");
    let v: Value = serde_json::from_str(&o.stdout).unwrap();
    let rows = v["combinations"][0]["registrations"].as_array().unwrap();
    assert_eq!(rows.len(), 6);
    for (k, row) in rows.iter().enumerate() {
        let why: Vec<&str> = row["why"]
            .as_array()
            .map(|a| a.iter().filter_map(Value::as_str).collect())
            .unwrap_or_default();
        if row["flag"] != "ok" {
            assert!(
                why.first().is_some_and(|w| w.starts_with("diagnosis:")),
                "row {k}: {why:?}"
            );
        }
        if k == 3 {
            assert!(
                why.first()
                    .is_some_and(|w| w.starts_with("diagnosis: disturbance")),
                "the disturbed registration: flag {}, why {why:?}",
                row["flag"]
            );
        } else {
            assert_eq!(row["flag"], "ok", "row {k}: {why:?}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A PV frozen under a moving OP (the record `detect` answers `inconclusive`, a stuck valve or
/// a frozen transmitter) is judged, not refused, by `batch`, `trend` and `audit`: each row has
/// the detector's verdict and reason and says why there is no fit; the fleet page's verdict is
/// `inconclusive` with the reason as its tooltip. A file the reader cannot read stays an
/// error.
#[test]
fn a_frozen_pv_gets_the_detectors_answer_in_batch_trend_and_audit() {
    let dir = temp_dir("frozen");
    std::fs::write(dir.join("F8_20240102-0800.csv"), common::frozen_pv_csv()).unwrap();
    std::fs::write(dir.join("F8_20240103-0800.csv"), "t,SP,PV,OP\n0,1,2,x\n").unwrap();
    let path = dir.to_str().unwrap();
    let out = dir.join("out");
    run_ok(&["batch", path, "-o", out.to_str().unwrap()], b"");
    let rows = jsonl(&dir.join("out.jsonl"));
    let frozen = rows
        .iter()
        .find(|r| r["file"] == "F8_20240102-0800.csv")
        .unwrap();
    assert_eq!(frozen["status"], "error", "{frozen}");
    assert_eq!(frozen["stiction_model"], "kano", "{frozen}");
    assert_eq!(frozen["detect_verdict"], "inconclusive", "{frozen}");
    assert!(frozen["detect_score"].is_number(), "{frozen}");
    let reason = frozen["detect_reason"].as_str().unwrap();
    assert!(reason.contains("frozen transmitter"), "{reason}");
    let error = frozen["error"].as_str().unwrap();
    assert!(
        error.contains("column PV: constant") && !error.contains('\n'),
        "{error}"
    );
    let broken = rows
        .iter()
        .find(|r| r["file"] == "F8_20240103-0800.csv")
        .unwrap();
    assert_eq!(
        (&broken["status"], &broken["detect_verdict"]),
        (&Value::from("error"), &Value::from("")),
        "{broken}"
    );

    let doc: Value = serde_json::from_str(&run_ok(&["trend", path, "--json"], b"").stdout).unwrap();
    let regs = doc["combinations"][0]["registrations"].as_array().unwrap();
    assert_eq!(regs[0]["flag"], "inconclusive", "{}", regs[0]);
    assert_eq!(regs[0]["detection"]["verdict"], "inconclusive");
    assert_eq!(regs[1]["flag"], "error", "{}", regs[1]);
    let text = run_ok(&["trend", path], b"").stdout;
    assert!(
        text.contains("inconclusive: the data cannot be judged: PV holds one value")
            && text.contains("errors 1, inconclusive without a fit 1"),
        "{text}"
    );
    // its page shows the record it could not fit, with the detector's answer
    let page_dir = dir.join("trend-page");
    run_ok(
        &["trend", path, "--report", page_dir.to_str().unwrap()],
        b"",
    );
    let page = std::fs::read_to_string(page_dir.join("index.html")).unwrap();
    assert!(
        page.contains("refused or without a fit (2)")
            && page.contains("(detector: inconclusive)")
            && page.contains("<svg"),
        "the trend page shows neither the record without a fit nor a figure of it"
    );

    // the fleet page: valve F8's only registration is the frozen one; the unreadable file
    // becomes valve `broken`
    std::fs::rename(
        dir.join("F8_20240103-0800.csv"),
        dir.join("broken_20240101-0800.csv"),
    )
    .unwrap();
    let db = dir.join("audit.sqlite");
    let site = dir.join("site");
    let audit = run_ok(
        &[
            "audit",
            path,
            "--db",
            db.to_str().unwrap(),
            "--report",
            site.to_str().unwrap(),
        ],
        b"",
    );
    let ranked = |tag: &str| {
        let tag = format!(" {tag} ");
        audit
            .stdout
            .lines()
            .find(|l| l.contains(&tag))
            .unwrap_or_default()
    };
    assert!(
        ranked("F8").contains("inconclusive (0."),
        "{}",
        audit.stdout
    );
    assert!(ranked("broken").contains(" error "), "{}", audit.stdout);
    let html = std::fs::read_to_string(site.join("index.html")).unwrap();
    assert!(
        html.contains("<span class=\"badge b-inconclusive\" title=\"the data cannot be judged: PV holds one value"),
        "{html}"
    );
    assert!(html.contains("no fit: "), "{html}");
    std::fs::remove_dir_all(&dir).ok();
}

/// OP logged in units the reader cannot place (here 1000 + 7.3 × % of span: not 0-1, 0-100
/// or counts) is rescaled to % of the range each record shows, so S is in % of that range, a
/// unit that differs between registrations whose OP ranges differ and that no threshold in %
/// of valve span applies to: `trend` says so in its text, its figure's axis and its JSON
/// (`S_unit`), draws no threshold, and leaves the verdict `undetermined` with the reason.
#[test]
fn trend_in_unknown_op_units_judges_no_percent_threshold() {
    let dir = temp_dir("trend-units");
    for (k, seed) in ["3", "4", "5"].iter().enumerate() {
        let csv = common::simulate_kano_4_1(seed, "600");
        let mut lines = csv.lines();
        let header = lines.next().unwrap();
        let op = header.split(',').position(|h| h == "OP").unwrap();
        let mut out = format!("{header}\n");
        for l in lines {
            let cells: Vec<String> = l
                .split(',')
                .enumerate()
                .map(|(i, c)| {
                    if i == op {
                        format!("{}", 1000.0 + 7.3 * c.parse::<f64>().unwrap())
                    } else {
                        c.to_string()
                    }
                })
                .collect();
            out.push_str(&cells.join(","));
            out.push('\n');
        }
        std::fs::write(dir.join(format!("U1_2024010{}-0800.csv", k + 1)), out).unwrap();
    }
    let path = dir.to_str().unwrap();
    // a threshold S in % of the OP range seen would otherwise reach
    let doc: Value =
        serde_json::from_str(&run_ok(&["trend", path, "--json", "--threshold", "0.5"], b"").stdout)
            .unwrap();
    assert!(doc["level"].as_f64().unwrap() >= 0.5, "{}", doc["level"]);
    assert_eq!(doc["verdict"], "undetermined", "{}", doc["reason"]);
    let reason = doc["reason"].as_str().unwrap();
    assert!(
        reason.starts_with("OP's valve span is unknown in 3 of the 3 usable registration(s)")
            && !reason.contains("  "),
        "{reason}"
    );
    let regs = doc["combinations"][0]["registrations"].as_array().unwrap();
    assert!(
        regs.iter().all(|r| r["S_unit"] == "% of the OP range seen"),
        "{regs:?}"
    );
    let site = dir.join("site");
    let text = run_ok(
        &[
            "trend",
            path,
            "--threshold",
            "0.5",
            "--report",
            site.to_str().unwrap(),
        ],
        b"",
    )
    .stdout;
    assert!(
        text.contains("note: OP's valve span is unknown in some registration(s)"),
        "{text}"
    );
    let level = text
        .lines()
        .find(|l| l.contains("level (median S)"))
        .unwrap();
    assert!(!level.contains('%'), "{level}");
    let svg = std::fs::read_to_string(site.join("kano-arx-s-trend.svg")).unwrap();
    assert!(
        svg.contains("S (% of the OP range seen, per registration)"),
        "{svg}"
    );
    assert!(!svg.contains("maintenance threshold"), "{svg}");
    std::fs::remove_dir_all(&dir).ok();
}
