//! Scenario configs: JSON round trip, defaults, rejection of unknown fields and bad values.

#![allow(clippy::unwrap_used)]

use datasets::simulate::{
    Disturbance, DisturbanceEntry, Plant, PlantSpec, Scenario, Setpoint, SetpointStep,
};
use datasets::DataError;
use stiction_models::{InitialState, Kano};

#[test]
fn json_round_trip_gives_the_same_simulation() {
    let s = Scenario {
        plant: PlantSpec::Explicit(Plant {
            delay: 2,
            ..Plant::slow()
        }),
        valve: Box::new(Kano::params().s(4.0).j(1.5).check().unwrap()),
        valve_init: InitialState::up(),
        setpoint: Setpoint {
            steps: vec![SetpointStep { at: 10, size: 1.5 }],
            ..Setpoint::default()
        },
        controller: datasets::simulate::Controller { kc: 0.3, ki: 0.2 },
        disturbances: vec![
            Disturbance::Paper { a: 0.25 },
            Disturbance::Sine {
                amplitude: 0.5,
                frequency: 0.02,
                phase: 1.0,
            },
            Disturbance::Drift { slope: 1e-4 },
            Disturbance::Step {
                at: 300,
                size: -1.0,
            },
            Disturbance::RandomSteps {
                probability: 0.01,
                sigma: 0.5,
            },
        ],
        disturbance_entry: DisturbanceEntry::Output,
        noise_sigma: 0.05,
        samples: 800,
        warmup: 100,
        seed: 42,
        op_limits: Some([0.0, 100.0]),
        sample_time: 10.0,
        ..Scenario::default()
    };
    let json = s.to_json();
    let back = Scenario::from_json(&json).unwrap();
    assert_eq!(back.to_json(), json);
    let (a, b) = (s.simulate().unwrap(), back.simulate().unwrap());
    assert_eq!(a.pv, b.pv);
    assert_eq!(a.op, b.op);
    assert_eq!(a.mv, b.mv);
    assert_eq!(a.sp, b.sp);
    assert_eq!(a.t[1], 10.0);
    // Preset names and tags as documented.
    let v: serde_json::Value = serde_json::from_str(&Scenario::default().to_json()).unwrap();
    assert_eq!(v["plant"], "paper");
    assert_eq!(v["valve"]["kind"], "kano");
    assert_eq!(v["disturbance_entry"], "equation");
    assert!(json.contains(r#""kind": "random-steps""#));
}

#[test]
fn empty_json_is_the_default_scenario() {
    let s = Scenario::from_json("{}").unwrap();
    assert_eq!(s.to_json(), Scenario::default().to_json());
    assert_eq!(s.samples, 3000);
    assert_eq!(s.warmup, 500);
    assert_eq!(s.seed, 1);
    assert_eq!(s.noise_sigma, 0.1);
    assert_eq!((s.controller.kc, s.controller.ki), (0.5, 0.5));
    assert_eq!(
        (s.setpoint.step, s.setpoint.switch_probability),
        (2.0, 0.05)
    );
    assert_eq!((s.op_bias, s.pv_bias), (50.0, 50.0));
    assert_eq!(s.valve.param_values(), vec![0.0, 0.0]);
    let s = Scenario::from_json(r#"{"plant": "slow", "valve": {"kind": "he", "fs": 2, "fd": 1}}"#)
        .unwrap();
    assert_eq!(s.plant.plant(), Plant::slow());
    assert_eq!(s.valve.name(), "he");
}

fn config_error(json: &str) -> String {
    match Scenario::from_json(json) {
        Err(e @ DataError::Config { .. }) => e.to_string(),
        other => panic!("expected a config error, got {other:?}"),
    }
}

#[test]
fn unknown_fields_are_rejected() {
    let m = config_error(r#"{"sample": 100}"#);
    assert!(m.starts_with("scenario: unknown field `sample`"), "{m}");
    let m = config_error(r#"{"controller": {"kp": 1}}"#);
    assert!(
        m.starts_with("scenario: unknown field `kp`, expected `kc` or `ki`"),
        "{m}"
    );
    let m = config_error(r#"{"disturbances": [{"kind": "paper", "a": 1, "b": 2}]}"#);
    assert!(m.contains("unknown field `b`"), "{m}");
    let m = config_error(r#"{"disturbances": [{"kind": "ramp"}]}"#);
    assert!(m.contains("unknown variant `ramp`"), "{m}");
    let m = config_error(r#"{"valve": {"kind": "kano", "S": 3, "J": 1, "X": 2}}"#);
    assert!(m.contains("unknown field `X`"), "{m}");
    let m = config_error(r#"{"plant": {"a": [1], "b": [0, 1], "c": [1], "d": 3}}"#);
    assert!(m.contains("PlantSpec"), "{m}");
}

#[test]
fn invalid_valve_parameters_are_rejected_with_the_model_message() {
    let m = config_error(r#"{"valve": {"kind": "kano", "S": 3, "J": 5}}"#);
    assert!(
        m.contains("kano: parameter J = 5 is out of range: expected 0 <= J <= S (= 3)"),
        "{m}"
    );
    let m = config_error(r#"{"valve": {"kind": "nope"}}"#);
    assert!(m.contains("nope"), "{m}");
}

#[test]
fn invalid_settings_are_rejected() {
    let e = Scenario::from_json(r#"{"noise_sigma": -1}"#).unwrap_err();
    assert_eq!(
        e.to_string(),
        "scenario: noise_sigma = -1 is out of range: expected sigma >= 0"
    );
    let e = Scenario::from_json(r#"{"setpoint": {"switch_probability": 1.5}}"#).unwrap_err();
    assert_eq!(
        e.to_string(),
        "scenario: setpoint.switch_probability = 1.5 is out of range: expected 0 <= p <= 1"
    );
    let e = Scenario::from_json(r#"{"samples": 0}"#).unwrap_err();
    assert!(matches!(e, DataError::InvalidParameter { .. }));
    let e =
        Scenario::from_json(r#"{"plant": {"a": [2, 0.5], "b": [0, 1], "c": [1]}}"#).unwrap_err();
    assert_eq!(e.to_string(), "invalid plant: a[0] = 2 must be 1");
    let e = Scenario::from_json(r#"{"op_limits": [100, 0]}"#).unwrap_err();
    assert!(matches!(e, DataError::InvalidParameter { .. }), "{e}");
}

#[test]
fn absurd_lengths_are_refused_not_allocated() {
    let e = Scenario::from_json(r#"{"samples": 18446744073709551615, "warmup": 10}"#).unwrap_err();
    assert_eq!(
        e.to_string(),
        "scenario: samples + warmup = 18446744073709552000 is out of range: expected at most \
         50000000 samples in all"
    );
}
