//! `stiction identify` end to end.

mod common;
use common::{run, run_ok};
use serde_json::Value;

fn loop_csv() -> String {
    let sim = run_ok(
        &[
            "simulate", "--param", "S=5", "--param", "J=2", "--seed", "3",
        ],
        b"",
    );
    sim.stdout
}

#[test]
fn identify_json_has_the_contract_keys_for_every_identifier() {
    let csv = loop_csv();
    for linear in ["arx", "armax", "earx", "earmax", "ss"] {
        let o = run(
            &["identify", "-", "--linear", linear, "--json"],
            csv.as_bytes(),
        );
        assert_eq!(o.code, 0, "{linear}: {}", o.stderr);
        let v: Value = serde_json::from_str(&o.stdout).unwrap();
        for key in [
            "linear_model",
            "orders",
            "delay",
            "static_gain",
            "poles",
            "model",
            "fit_pv_id",
            "fit_pv_val",
            "fit_kind",
            "disturbance",
        ] {
            assert!(v.get(key).is_some(), "{linear}: missing {key}");
        }
        assert_eq!(v["linear_model"], linear);
        assert_eq!(v["input"], "MV", "the measured MV is the default input");
        // The paper's plant has unit static gain; from the true MV every model finds it.
        let g = v["static_gain"].as_f64().unwrap();
        assert!((g - 1.0).abs() < 0.1, "{linear}: gain {g}");
        assert!(v["fit_pv_val"].as_f64().unwrap() > 90.0, "{linear}");
        let extended = linear.starts_with('e');
        assert_eq!(v["disturbance"].is_array(), extended, "{linear}");
        if linear == "ss" {
            assert!(v["model"]["A"].is_array() && v["model"]["K"].is_array());
        } else {
            assert_eq!(v["model"]["a"][0], 1.0);
        }
    }
}

#[test]
fn identify_text_and_column_choice() {
    let csv = loop_csv();
    let o = run_ok(
        &[
            "identify", "-", "--linear", "arx", "--orders", "3,3", "--input", "OP",
        ],
        csv.as_bytes(),
    );
    assert!(
        o.stdout.contains("arx from OP to PV (n=3, m=3, delay=0)"),
        "{}",
        o.stdout
    );
    assert!(o.stdout.contains("A(q) = [1.000000"), "{}", o.stdout);
    let o = run(
        &["identify", "-", "--linear", "arx", "--orders", "2,2,2"],
        csv.as_bytes(),
    );
    assert_eq!(o.code, 2);
    assert!(
        o.stderr.contains("at most 2 positional orders"),
        "{}",
        o.stderr
    );
    let o = run(
        &["identify", "-", "--linear", "arx", "--input", "nope"],
        csv.as_bytes(),
    );
    assert_eq!(o.code, 1);
    assert!(o.stderr.starts_with("error: -: no column"), "{}", o.stderr);
}

#[test]
fn identify_refuses_a_constant_input() {
    let mut csv = String::from("PV,OP\n");
    for k in 0..200 {
        csv.push_str(&format!("{},50\n", (k as f64 * 0.3).sin()));
    }
    let o = run(&["identify", "-", "--linear", "arx"], csv.as_bytes());
    assert_eq!(o.code, 1);
    assert!(
        o.stderr.starts_with("error: -:") && o.stderr.contains("constant"),
        "{}",
        o.stderr
    );
}
