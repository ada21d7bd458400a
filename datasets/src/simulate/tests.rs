use super::*;

#[test]
fn default_scenario_runs_around_the_operating_point() {
    let s = Scenario {
        samples: 500,
        warmup: 100,
        ..Scenario::default()
    };
    let sim = s.simulate().unwrap();
    assert_eq!(sim.len(), 500);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!((mean(&sim.op) - 50.0).abs() < 10.0);
    assert!((mean(&sim.pv) - 50.0).abs() < 10.0);
    assert_eq!(sim.t[3], 3.0);
}

/// 400 samples from rest, the set point stepping by `size` at sample 50, OP clamped to
/// [0, 100].
fn setpoint_step(size: f64) -> Scenario {
    Scenario {
        samples: 400,
        warmup: 0,
        setpoint: Setpoint {
            steps: vec![SetpointStep { at: 50, size }],
            ..Setpoint::constant()
        },
        op_limits: Some([0.0, 100.0]),
        ..Scenario::default()
    }
}

#[test]
fn op_clipping_holds_limits() {
    let sim = setpoint_step(80.0).simulate().unwrap();
    assert!(sim.op.iter().all(|&v| (0.0..=100.0).contains(&v)));
    assert!(sim.op.contains(&100.0));
}

/// A travel limit: the valve stops at L while OP winds up to its clamp; without it the
/// same loop's valve passes L.
#[test]
fn travel_limit_stops_the_valve() {
    let s = Scenario {
        travel_limit: Some(60.0),
        ..setpoint_step(20.0)
    };
    let sim = s.simulate().unwrap();
    assert!(sim.mv.iter().all(|&m| m <= 60.0));
    assert!(sim.mv.contains(&60.0));
    assert!(sim.op.contains(&100.0));
    let free = Scenario {
        travel_limit: None,
        ..s
    }
    .simulate()
    .unwrap();
    assert!(free.mv.iter().any(|&m| m > 60.0));
}

#[test]
fn output_entry_adds_eta_to_pv() {
    let base = Scenario {
        samples: 300,
        warmup: 0,
        noise_sigma: 0.0,
        setpoint: Setpoint::constant(),
        disturbances: vec![Disturbance::Step { at: 0, size: 1.0 }],
        disturbance_entry: DisturbanceEntry::Output,
        ..Scenario::default()
    };
    let sim = base.simulate().unwrap();
    // First sample: no MV history, no noise: PV = pv_bias + η exactly.
    assert_eq!(sim.pv[0], 51.0);
    let eq = Scenario {
        disturbance_entry: DisturbanceEntry::Equation,
        ..base
    }
    .simulate()
    .unwrap();
    assert_eq!(eq.pv[0], 51.0);
    // One sample later the equation form has propagated η through A(q): 1 + 0.5215.
    let a1 = 0.5215;
    assert!(
        (eq.pv[1] - sim.pv[1] - a1).abs() < 1e-9,
        "{} {}",
        eq.pv[1],
        sim.pv[1]
    );
}

#[test]
fn a_plant_change_acts_from_its_sample_on_and_is_optional_in_json() {
    let plain = Scenario {
        samples: 600,
        ..Scenario::default()
    };
    assert!(!plain.to_json().contains("plant_change"));
    let changed = Scenario {
        plant_change: Some(PlantChange {
            at: 300,
            plant: Plant::slow(),
        }),
        ..plain.clone()
    };
    let back = Scenario::from_json(&changed.to_json()).unwrap();
    assert_eq!(back.plant_change, changed.plant_change);
    let (a, b) = (plain.simulate().unwrap(), changed.simulate().unwrap());
    assert_eq!(a.pv[..300], b.pv[..300]);
    assert!(a.pv[300..].iter().zip(&b.pv[300..]).any(|(x, y)| x != y));
    // a new plant that the controller cannot hold is refused, like the first
    let unstable = Scenario {
        plant_change: Some(PlantChange {
            at: 10,
            plant: Plant {
                b: Plant::slow().b.iter().map(|v| v * 40.0).collect(),
                ..Plant::slow()
            },
        }),
        ..plain
    };
    assert!(unstable.simulate().is_err());
}

#[test]
fn characteristic_is_optional_in_json_and_keeps_the_local_gain() {
    let plain = Scenario::default().to_json();
    assert!(!plain.contains("characteristic"), "{plain}");
    let s = Scenario::from_json(
        r#"{"characteristic": {"kind": "equal-percentage", "rangeability": 50}, "samples": 200}"#,
    )
    .unwrap();
    let c = s.characteristic.unwrap();
    assert!((c.shape() - 50f64.ln()).abs() < 1e-12);
    assert!(s.to_json().contains("equal-percentage"));
    // local gain 1 at the operating point, growing with the opening (×R^0.1 over 10 %)
    let g = |x: f64| (c.deviation(x + 1e-6) - c.deviation(x - 1e-6)) / 2e-6;
    assert!((g(0.0) - 1.0).abs() < 1e-6);
    assert!((g(10.0) / g(0.0) - 50f64.powf(0.1)).abs() < 1e-6);
    let q = Characteristic::QuickOpening { rangeability: 50.0 };
    assert!((q.shape() + 50f64.ln()).abs() < 1e-12);
    assert!(Scenario::from_json(
        r#"{"characteristic": {"kind": "quick-opening", "rangeability": 0.5}}"#
    )
    .is_err());
    // the valve model still reproduces the recorded MV (the stem position)
    let sim = s.simulate().unwrap();
    assert_eq!(s.valve.simulate(&sim.op, &s.valve_init).unwrap(), sim.mv);
}
