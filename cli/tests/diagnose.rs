//! `stiction diagnose` end to end, in memory.

mod common;
use common::{run, run_ok, simulate_dead_time};
use serde_json::Value;

#[test]
fn diagnose_json_has_the_contract_keys() {
    let o = run_ok(&["diagnose", "--example", "paper", "--json"], b"");
    let v: Value = serde_json::from_str(&o.stdout).expect("one JSON document");
    for key in [
        "baseline",
        "cause",
        "findings",
        "extended",
        "gain_fit_pv_val",
        "summary",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    // The example is a clean Kano loop (S = 9, J = 3): nothing to extend.
    assert_eq!(v["cause"], "none", "{}", v["summary"]);
    assert!(v["extended"].is_null());
    assert_eq!(v["gain_fit_pv_val"], 0.0);
    assert_eq!(v["baseline"]["stiction_model"], "kano");
    assert!((v["baseline"]["S"].as_f64().unwrap() - 9.0).abs() <= 0.25);
    let findings = v["findings"].as_array().unwrap();
    assert!(findings.len() >= 4, "{findings:?}");
    for f in findings {
        for key in [
            "cause",
            "evidence",
            "statistic",
            "extended",
            "gain_fit_pv_val",
        ] {
            assert!(f.get(key).is_some(), "finding without {key}: {f}");
        }
    }
    assert!(v["summary"].as_str().unwrap().len() > 100);
}

#[test]
fn diagnose_finds_a_hidden_dead_time_from_a_file() {
    let sim = simulate_dead_time("4", "9");
    let o = run_ok(&["diagnose", "-"], sim.as_bytes());
    assert!(o.stdout.contains("time-delay"), "{}", o.stdout);
    let j = run(&["diagnose", "-", "--json"], sim.as_bytes());
    let v: Value = serde_json::from_str(&j.stdout).unwrap();
    assert_eq!(v["cause"], "time-delay", "{}", v["summary"]);
    assert_eq!(v["extended"]["delay"], 4);
    assert!(v["gain_fit_pv_val"].as_f64().unwrap() > 0.0);
}

#[test]
fn diagnose_refuses_bad_input() {
    let o = run(&["diagnose", "-"], b"PV,OP\n1,2\n");
    assert_eq!(o.code, 1);
    assert!(o.stderr.starts_with("error: -:"), "{}", o.stderr);
    let o = run(
        &["diagnose", "--example", "paper", "--without", "nope"],
        b"",
    );
    assert_eq!(o.code, 2, "{}", o.stderr);
}
