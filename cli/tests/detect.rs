//! `stiction detect` end to end, in memory: bad input (also with `--report`), a flat record, a
//! sticky loop, its report page.
#![allow(clippy::unwrap_used)]

mod common;
use common::{run, run_ok};
use serde_json::Value;

fn json(args: &[&str], stdin: &[u8]) -> Value {
    let o = run_ok(args, stdin);
    serde_json::from_str(&o.stdout).expect("one JSON document")
}

#[test]
fn bad_input_gets_the_same_one_line_error_as_quantify() {
    let bad = b"OP,PV\n1,2\nabc,3\n";
    let d = run(&["detect", "-"], bad);
    let q = run(&["quantify", "-"], bad);
    assert_eq!(d.code, 1);
    assert_eq!(d.code, q.code);
    assert_eq!(d.stderr, q.stderr);
    assert_eq!(d.stderr.lines().count(), 1, "{}", d.stderr);
    assert!(
        d.stderr.starts_with("error: -: row 3, column OP"),
        "{}",
        d.stderr
    );
    let missing = run(&["detect", "no-such-file.csv"], b"");
    assert_eq!(missing.code, 1);
    assert_eq!(missing.stderr.lines().count(), 1, "{}", missing.stderr);
}

/// A fresh directory under the system's temp dir, removed on drop.
struct TempDir(std::path::PathBuf);

impl TempDir {
    fn new(tag: &str) -> TempDir {
        let p = std::env::temp_dir().join(format!("stiction-detect-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }

    fn arg(&self, sub: &str) -> String {
        self.0.join(sub).display().to_string()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn bad_input_with_report_gets_the_same_one_line_error() {
    let dir = TempDir::new("bad-report");
    let bad = b"OP,PV\n1,2\nabc,3\n";
    let file = dir.arg("bad.csv");
    std::fs::write(&file, bad).unwrap();
    for input in [file.as_str(), "-"] {
        let plain = run(&["detect", input], bad);
        let out = dir.arg(&format!("report-{}", input.len()));
        let with = run(&["detect", input, "--report", &out], bad);
        assert_eq!(plain.code, 1, "{}", plain.stderr);
        assert_eq!(with.code, plain.code, "{}", with.stderr);
        let errors: Vec<&str> = with
            .stderr
            .lines()
            .filter(|l| l.starts_with("error:"))
            .collect();
        assert_eq!(errors, [plain.stderr.trim_end()], "{}", with.stderr);
        assert!(
            errors[0].contains("row 3, column OP") && errors[0].contains(input),
            "{}",
            errors[0]
        );
        // As `quantify --report` does: a page saying why, besides the error.
        let q = run(&["quantify", input, "--report", &dir.arg("q")], bad);
        assert_eq!(q.code, with.code);
        assert_eq!(
            q.stderr.lines().find(|l| l.starts_with("error:")),
            Some(errors[0])
        );
        let page = std::fs::read_to_string(format!("{out}/index.html")).unwrap();
        assert!(page.contains("detect: loop") && page.contains("refused"));
    }
    let missing = run(
        &["detect", "no-such-file.csv", "--report", &dir.arg("m")],
        b"",
    );
    assert_eq!(missing.code, 1);
    assert_eq!(missing.stderr.lines().count(), 1, "{}", missing.stderr);
    assert_eq!(
        missing.stderr,
        run(&["detect", "no-such-file.csv"], b"").stderr
    );
}

#[test]
fn a_flat_record_is_not_called_sticky_and_says_why() {
    let record = |pv: &dyn Fn(usize) -> f64, op: &dyn Fn(usize) -> f64| {
        let mut csv = String::from("t,SP,PV,OP\n");
        for k in 0..400 {
            csv.push_str(&format!("{k},50,{},{}\n", pv(k), op(k)));
        }
        csv
    };
    let wiggle = |k: usize| ((k * 37) % 11) as f64 * 0.1;
    for (what, csv, reason) in [
        ("all flat", record(&|_| 50.0, &|_| 30.0), "OP is flat"),
        (
            "OP flat",
            record(&|k| 50.0 + wiggle(k), &|_| 30.0),
            "OP is flat",
        ),
        (
            // PV flat under a moving OP: a stuck valve or a frozen transmitter
            "PV flat",
            record(&|_| 50.0, &|k| 30.0 + (k % 50) as f64 * 0.2),
            "frozen transmitter",
        ),
    ] {
        // Read with a note, judged `inconclusive` with the reason, exit 0.
        let o = run(&["detect", "-"], csv.as_bytes());
        assert_eq!(o.code, 0, "{what}: {}", o.stderr);
        assert!(o.stderr.contains("constant"), "{what}: {}", o.stderr);
        let first = o.stdout.lines().next().unwrap_or_default();
        assert!(first.starts_with("-: inconclusive"), "{what}: {first}");
        assert!(first.contains(reason), "{what}: {first}");
        let j = json(&["detect", "-", "--json"], csv.as_bytes());
        assert_eq!(j["verdict"], "inconclusive", "{what}");
        // Identification has nothing to fit: the reader's one-line error.
        let q = run(&["quantify", "-"], csv.as_bytes());
        assert_eq!(q.code, 1, "{what}");
        assert_eq!(q.stderr.lines().count(), 1, "{what}: {}", q.stderr);
        assert!(q.stderr.contains("constant"), "{what}: {}", q.stderr);
    }
    // PV frozen over more than half of the record under a moving OP: a stuck valve or a
    // frozen transmitter, which the data cannot tell apart; answered, not refused.
    let half = record(&|k| if k < 250 { 50.0 } else { 50.0 + wiggle(k) }, &|k| {
        30.0 + (k % 50) as f64 * 0.2
    });
    let o = run_ok(&["detect", "-"], half.as_bytes());
    let first = o.stdout.lines().next().unwrap_or_default();
    assert!(first.starts_with("-: inconclusive"), "{first}");
    assert!(first.contains("frozen transmitter"), "{first}");
    // Identification still refuses it with the reader's one-line error.
    let q = run(&["quantify", "-"], half.as_bytes());
    assert_eq!(q.code, 1);
    assert_eq!(q.stderr.lines().count(), 1, "{}", q.stderr);
}

/// A historian export whose stamps are written at a coarser resolution than its 10 s sampling
/// (every thirtieth stamp repeats the previous one and the next step, 20 s, restores the grid;
/// the first and last rows one step off), with PV frozen under a moving OP: read on the grid
/// with a one-line note, answered `inconclusive` with the reason, exit 0.
#[test]
fn coarse_stamps_and_a_frozen_pv_get_an_answer() {
    let csv = common::frozen_pv_csv();
    let o = run(&["detect", "-"], csv.as_bytes());
    assert_eq!(o.code, 0, "{}", o.stderr);
    let notes: Vec<&str> = o
        .stderr
        .lines()
        .filter(|l| l.contains("time stamp"))
        .collect();
    assert_eq!(
        notes,
        ["note: -: column t: 26 time stamp(s) one sampling interval off the regular grid of their neighbours, the first at row 2 (25 repeating the previous stamp): stamps written at a coarser resolution than the sampling, not reordered rows; read in file order on the grid"]
    );
    let first = o.stdout.lines().next().unwrap_or_default();
    assert!(first.starts_with("-: inconclusive"), "{first}");
    assert!(
        first.contains("a valve stuck that long and a frozen transmitter look the same"),
        "{first}"
    );
    // the same stamps with one repeat that does not restore the grid: refused, as before
    let dup = csv.replacen("\n3020,", "\n3010,", 1);
    let o = run(&["detect", "-"], dup.as_bytes());
    assert_eq!(o.code, 1, "{}", o.stdout);
    assert!(
        o.stderr
            .starts_with("error: -: row 32, column t: time does not increase"),
        "{}",
        o.stderr
    );
}

/// A slow self-regulating plant, PI 0.3/0.1, Kano S = 4, J = 1, constant set point: a limit
/// cycle (the same loop as the detection crate's tests), as CSV text.
fn sticky_loop(name: &str) -> common::Out {
    let dir = std::env::temp_dir().join(format!("stiction-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let config = dir.join("sticky.json");
    std::fs::write(
        &config,
        r#"{"plant": "slow", "controller": {"kc": 0.3, "ki": 0.1},
            "setpoint": {"step": 0, "switch_probability": 0},
            "valve": {"kind": "kano", "S": 4, "J": 1},
            "noise_sigma": 0.02, "samples": 1000, "warmup": 500, "seed": 1}"#,
    )
    .unwrap();
    let sim = run(&["simulate", "--config", config.to_str().unwrap()], b"");
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(sim.code, 0, "{}", sim.stderr);
    sim
}

#[test]
fn a_generated_sticky_loop_is_stiction_with_the_contract_keys() {
    let sim = sticky_loop("detect");
    let v = json(
        &["detect", "-", "--json", "--integrating", "no"],
        sim.stdout.as_bytes(),
    );
    for key in [
        "score",
        "verdict",
        "oscillating",
        "period_s",
        "integrating",
        "tests",
    ] {
        assert!(v.get(key).is_some(), "missing {key} in {v}");
    }
    let score = v["score"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&score));
    assert_eq!(v["verdict"], "stiction", "{v:#}");
    assert_eq!(v["oscillating"], true);
    assert!(v["period_s"].as_f64().unwrap() > 10.0);
    assert_eq!(v["integrating"], false);
    let tests = v["tests"].as_array().unwrap();
    assert!(tests.len() >= 7);
    for t in tests {
        for key in ["name", "statistic", "verdict", "evidence"] {
            assert!(t.get(key).is_some(), "{t}");
        }
    }
    // The same loop as text: the verdict line first, then the test table.
    let o = run_ok(
        &["detect", "-", "--integrating", "no"],
        sim.stdout.as_bytes(),
    );
    assert!(o.stdout.starts_with("-: stiction (score"), "{}", o.stdout);
    assert!(o.stdout.contains("horch-xcorr"), "{}", o.stdout);
}

/// `quantify` and `diagnose` end their text with the detector's line and add its object to
/// their JSON: the same answer as `stiction detect` on the same record.
#[test]
fn quantify_and_diagnose_carry_the_detectors_answer() {
    let sim = sticky_loop("detect-wired");
    let csv = sim.stdout.as_bytes();
    let det = json(&["detect", "-", "--json"], csv);
    let score = det["score"].as_f64().unwrap();
    assert_eq!(det["verdict"], "stiction", "{det:#}");
    let tests = det["tests"].as_array().unwrap();
    let says = |v: &str| tests.iter().filter(|t| t["verdict"] == v).count();
    let line = format!(
        "detection: stiction (score {score:.2}; tests: {} stiction, {} no-stiction, {} inconclusive): {}",
        says("stiction"),
        says("no-stiction"),
        says("inconclusive"),
        det["reason"].as_str().unwrap()
    );
    for cmd in ["quantify", "diagnose"] {
        let o = run(&[cmd, "-", "--step", "0.5"], csv);
        assert_eq!(o.code, 0, "{cmd}: {}", o.stderr);
        assert_eq!(o.stdout.lines().last(), Some(line.as_str()), "{}", o.stdout);
        assert_eq!(o.stdout.matches("detection:").count(), 1, "{}", o.stdout);
        let v = json(&[cmd, "-", "--step", "0.5", "--json"], csv);
        let d = &v["detection"];
        assert_eq!(d["verdict"], "stiction", "{cmd}: {v:#}");
        assert_eq!(d["score"].as_f64(), Some(score), "{cmd}");
        assert_eq!(d["reason"], det["reason"], "{cmd}");
    }
}

/// `detect --report DIR` writes the page: the verdict, the test table and the two detection
/// figures (PV-OP with the fitted ellipse, the cross-correlation), each passing the plot check.
#[test]
fn report_writes_the_test_table_and_the_two_figures() {
    let sim = sticky_loop("detect-report");
    let dir = TempDir::new("report");
    let file = dir.arg("sticky.csv");
    std::fs::write(&file, &sim.stdout).unwrap();
    let out = dir.arg("report");
    let o = run_ok(
        &["detect", &file, "--integrating", "no", "--report", &out],
        b"",
    );
    assert!(o.stdout.contains(": stiction (score"), "{}", o.stdout);
    assert!(o.stderr.contains("report: "), "{}", o.stderr);
    let html = std::fs::read_to_string(format!("{out}/index.html")).unwrap();
    assert!(html.contains("<h1>detect: loop sticky</h1>"), "{html}");
    assert!(html.contains("<p class=\"verdict\">Detection: stiction (score"));
    // The test table: its header and a row per test, with the evidence.
    assert!(html.contains(
        "<th class=\"t\">test</th><th>statistic</th><th class=\"t\">verdict</th><th class=\"t\">evidence</th>"
    ));
    for test in ["oscillation", "horch-xcorr", "bicoherence", "hammerstein"] {
        assert!(
            html.contains(&format!("<td class=\"t nw\">{test}</td>")),
            "no row for {test}"
        );
    }
    assert!(
        html.contains("OP-PV cross-correlation over ±"),
        "Horch's evidence"
    );
    // Two figures, inline and as files, each passing the plot check.
    assert_eq!(html.matches("<figure").count(), 2);
    assert_eq!(html.matches("<svg").count(), 2);
    for (name, legend) in [
        ("detection-pv-op", "ellipse, period"),
        ("detection-xcorr", "odd share"),
    ] {
        assert!(html.contains(&format!("<figure id=\"{name}\">")), "{name}");
        let svg = std::fs::read_to_string(format!("{out}/{name}.svg")).unwrap();
        let st = report::inspect::check_plot(&svg, "sticky").unwrap_or_else(|e| panic!("{e}"));
        assert!(
            st.legend.iter().any(|l| l.contains(legend)),
            "{name}: {:?}",
            st.legend
        );
    }
}
