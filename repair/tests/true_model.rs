//! The repair estimate with the loop's true model (the simulator's plant, valve and MV): the
//! "now" run must reproduce the record, the controller must be the simulator's, and the
//! repaired run must match the healthy twin simulated with the same seed.

#![allow(clippy::unwrap_used)]

use datasets::simulate::{Plant, Scenario, SimulatedLoop};
use linear_id::{LinearFit, Structure};
use repair::{assess, identify_controller, ControllerKind, FittedLoop, NoRepair, Signals};
use stiction_models::StictionModel;

fn scenario(valve: &str, seed: u64, plant: &str) -> Scenario {
    Scenario::from_json(&format!(
        r#"{{"plant": "{plant}", "valve": {valve}, "samples": 2000, "warmup": 300, "seed": {seed}, "sample_time": 10}}"#
    ))
    .unwrap()
}

/// The plant as a fitted model (deviation variables around the scenario's operating point).
fn true_model(sim: &SimulatedLoop) -> LinearFit {
    let plant: Plant = sim.scenario.plant.plant();
    assert_eq!(plant.b[0], 0.0);
    let structure = Structure::Polynomial {
        a: plant.a.clone(),
        b: plant.b[1..].to_vec(),
        c: plant.c.clone(),
        delay: plant.delay,
    };
    LinearFit::new(
        "true",
        structure,
        sim.scenario.op_bias,
        sim.scenario.pv_bias,
        None,
        &sim.mv,
        &sim.pv,
    )
    .unwrap()
}

fn signals(sim: &SimulatedLoop) -> Signals<'_> {
    Signals {
        sp: Some(&sim.sp),
        pv: &sim.pv,
        op: &sim.op,
        sample_time: 10.0,
    }
}

#[test]
fn the_controller_is_the_simulators_pi() {
    let sim = scenario(r#"{"kind": "kano", "S": 4, "J": 1}"#, 3, "paper")
        .simulate()
        .unwrap();
    let c = identify_controller(&signals(&sim)).unwrap();
    assert_eq!(c.kind, ControllerKind::Pi);
    assert_eq!(c.lag, 0);
    // the scenario's PI: kc = 0.5, ki = 0.5, so ti = kc Ts / ki = 10 s
    approx::assert_relative_eq!(c.kc, 0.5, max_relative = 1e-9);
    approx::assert_relative_eq!(c.ti, 10.0, max_relative = 1e-9);
    assert!(c.fit > 99.999_999, "{}", c.fit);
}

#[test]
fn now_run_reproduces_the_record_and_repaired_matches_the_healthy_twin() {
    for (seed, plant, s, j) in [
        (1, "paper", 9.0, 3.0),
        (4, "slow", 3.0, 1.0),
        (7, "paper", 2.0, 0.0),
    ] {
        let valve = format!(r#"{{"kind": "kano", "S": {s}, "J": {j}}}"#);
        let sticky = scenario(&valve, seed, plant).simulate().unwrap();
        let twin = scenario(r#"{"kind": "kano", "S": 0, "J": 0}"#, seed, plant)
            .simulate()
            .unwrap();
        assert_eq!(sticky.sp, twin.sp, "the twin shares the set point");
        let model = true_model(&sticky);
        let fitted = FittedLoop {
            valve: sticky.scenario.valve.as_ref() as &dyn StictionModel,
            mv_est: &sticky.mv,
            linear: &model,
            integrating: false,
            indistinguishable: false,
        };
        // the replayed loop is the record, until round-off meets a stick-or-slip decision
        // (the valve is discontinuous, so the runs part after a while; their spread stays)
        let runs = repair::replay(&signals(&sticky), &fitted).unwrap();
        for i in 0..runs.given + 100 {
            assert!((runs.now.pv[i] - sticky.pv[i]).abs() < 1e-6, "sample {i}");
            assert!((runs.now.mv[i] - sticky.mv[i]).abs() < 1e-6, "sample {i}");
        }
        let r = assess(&signals(&sticky), &fitted).unwrap();
        approx::assert_relative_eq!(r.error_std_now, r.error_std_measured, max_relative = 0.05);
        let from = sticky.pv.len() - r.samples;
        let truth = 1.0 - twin.error_std(from) / sticky.error_std(from);
        assert!(
            (r.reduction - truth).abs() < 0.02,
            "seed {seed} {plant} S {s}: predicted {:.4}, twin {:.4}",
            r.reduction,
            truth
        );
        assert!(
            r.reduction > 0.1,
            "a sticky valve's repair buys something: {}",
            r.reduction
        );
        assert!(r.reversals_per_hour_repaired > r.reversals_per_hour_now);
    }
}

#[test]
fn a_healthy_valve_buys_nothing() {
    let sim = scenario(r#"{"kind": "kano", "S": 0, "J": 0}"#, 5, "paper")
        .simulate()
        .unwrap();
    let model = true_model(&sim);
    let fitted = FittedLoop {
        valve: sim.scenario.valve.as_ref(),
        mv_est: &sim.mv,
        linear: &model,
        integrating: false,
        indistinguishable: false,
    };
    let r = assess(&signals(&sim), &fitted).unwrap();
    assert!(r.reduction < 1e-6, "{}", r.reduction);
}

#[test]
fn loops_that_cannot_be_replayed_say_why() {
    let sim = scenario(r#"{"kind": "kano", "S": 3, "J": 1}"#, 2, "paper")
        .simulate()
        .unwrap();
    let mut s = signals(&sim);
    s.sp = None;
    assert_eq!(identify_controller(&s), Err(NoRepair::NoSetPoint));
    // an operator's OP: still for long stretches, moved by hand now and then
    let manual: Vec<f64> = (0..sim.op.len()).map(|k| 40.0 + (k / 400) as f64).collect();
    let s = Signals {
        op: &manual,
        ..signals(&sim)
    };
    assert!(matches!(
        identify_controller(&s),
        Err(NoRepair::Manual { .. })
    ));
    // OP that has nothing to do with the error
    let noise: Vec<f64> = (0..sim.op.len())
        .map(|k| 50.0 + ((k as f64 * 12.9898).sin() * 43758.5453).fract())
        .collect();
    let s = Signals {
        op: &noise,
        ..signals(&sim)
    };
    let e = identify_controller(&s).unwrap_err();
    assert!(matches!(e, NoRepair::NotPiLike { .. }), "{e}");
    assert!(e.to_string().starts_with("the loop is not PI-like"));
}
