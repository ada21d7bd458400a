//! `stiction quantify` and `stiction compare` end to end, in memory.

mod common;
use common::{run, run_ok, simulate_dead_time};
use serde_json::Value;

#[test]
fn quantify_example_json_has_the_contract_keys() {
    let o = run_ok(
        &["quantify", "--example", "paper", "--json", "--step", "0.5"],
        b"",
    );
    let v: Value = serde_json::from_str(&o.stdout).expect("one JSON document");
    for key in [
        "stiction_model",
        "linear_model",
        "S",
        "J",
        "params",
        "fit_pv_id",
        "fit_pv_val",
        "fit_mv",
        "delay",
        "orders",
        "grid",
        "elapsed_ms",
    ] {
        assert!(v.get(key).is_some(), "missing {key} in {v}");
    }
    assert_eq!(v["stiction_model"], "kano");
    assert_eq!(v["linear_model"], "arx");
    assert_eq!(v["params"]["S"], v["S"]);
    assert!(v["grid"]["nodes"].as_u64().unwrap() > 100);
    assert_eq!(v["grid"]["step"], 0.5);
    let s = v["S"].as_f64().unwrap();
    assert!((s - 9.0).abs() <= 0.5, "S = {s}");
    assert!(v["fit_mv"].as_f64().unwrap() > 95.0);
}

#[test]
fn quantify_reads_a_file_and_writes_the_surface() {
    let sim = run_ok(
        &[
            "simulate", "--param", "S=4", "--param", "J=1", "--seed", "2",
        ],
        b"",
    );
    let dir = std::env::temp_dir().join(format!("stiction-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let surface = dir.join("surface.csv");
    let o = run_ok(
        &[
            "quantify",
            "-",
            "--step",
            "0.5",
            "--surface",
            surface.to_str().unwrap(),
        ],
        sim.stdout.as_bytes(),
    );
    assert!(o.stdout.contains("S = 4.00"), "{}", o.stdout);
    let text = std::fs::read_to_string(&surface).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("S,J,S,J,fit_pred_id,fit_pred_val,fit_sim_id,fit_sim_val,fit_mv,valid_from,skipped")
    );
    assert!(lines.count() > 50);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn quantify_he_reports_equivalent_s_and_j() {
    let o = run_ok(
        &[
            "quantify",
            "--example",
            "paper",
            "--stiction",
            "he",
            "--json",
            "--step",
            "0.5",
        ],
        b"",
    );
    let v: Value = serde_json::from_str(&o.stdout).unwrap();
    let (fs, fd) = (
        v["params"]["fs"].as_f64().unwrap(),
        v["params"]["fd"].as_f64().unwrap(),
    );
    assert!((v["S"].as_f64().unwrap() - (fs + fd)).abs() < 1e-9);
    assert!((v["J"].as_f64().unwrap() - (fs - fd)).abs() < 1e-9);
}

#[test]
fn delay_auto_finds_an_added_dead_time() {
    let sim = simulate_dead_time("3", "4");
    let o = run_ok(
        &[
            "quantify", "-", "--delay", "auto", "--json", "--step", "0.5",
        ],
        sim.as_bytes(),
    );
    let v: Value = serde_json::from_str(&o.stdout).unwrap();
    assert_eq!(v["delay"], 3, "{}", v["delay_scan"]);
    assert!((v["S"].as_f64().unwrap() - 5.0).abs() <= 0.5, "{}", v["S"]);
}

#[test]
fn compare_prints_one_row_per_combination() {
    let o = run_ok(
        &[
            "compare",
            "--example",
            "paper",
            "--stiction",
            "kano,he",
            "--linear",
            "arx,earx",
            "--step",
            "0.5",
        ],
        b"",
    );
    // the table's rows, then the loop kind's line
    let rows: Vec<&str> = o.stdout.lines().skip(2).collect();
    assert_eq!(rows.len(), 5, "{}", o.stdout);
    assert!(rows[0].starts_with("kano") && rows[0].contains("arx"));
    assert!(rows[4].starts_with("loop: self-regulating"), "{}", o.stdout);
    assert!(o.stdout.lines().nth(1).unwrap().contains("F_PV val"));
    let j = run(
        &[
            "compare",
            "--example",
            "paper",
            "--stiction",
            "kano",
            "--linear",
            "arx",
            "--step",
            "0.5",
            "--json",
        ],
        b"",
    );
    let v: Value = serde_json::from_str(&j.stdout).unwrap();
    assert_eq!(v["results"].as_array().unwrap().len(), 1);
}

#[test]
fn quantify_refuses_data_it_cannot_use() {
    let flat_pv = "PV,OP\n1,1\n1,2\n1,3\n1,4\n1,5\n1,6\n1,5\n1,4\n1,3\n1,2\n1,1\n1,2\n1,3\n1,4\n1,5\n1,6\n1,5\n1,4\n1,3\n1,2\n1,1\n1,2\n1,3\n1,4\n1,5\n1,6\n1,5\n1,4\n1,3\n1,2\n1,1\n";
    let o = run(&["quantify", "-"], flat_pv.as_bytes());
    assert_eq!(o.code, 1);
    assert!(
        o.stderr.starts_with("error: -:") && o.stderr.contains("PV"),
        "{}",
        o.stderr
    );
    let o = run(&["quantify", "--example", "paper", "--linear", "nope"], b"");
    assert_eq!(o.code, 2);
    assert!(
        o.stderr.contains("unknown linear identifier \"nope\""),
        "{}",
        o.stderr
    );
    let o = run(&["quantify", "--example", "paper", "--step", "-1"], b"");
    assert_eq!(o.code, 2, "{}", o.stderr);
    let o = run(&["quantify"], b"");
    assert_eq!(o.code, 2);
}
