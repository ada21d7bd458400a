//! The verdict and the score do not depend on PV's and SP's engineering units: PV and SP
//! changed by `a·x + b` (scales 1e-6 to 1e12) give the same detection as the loop in %.
#![allow(clippy::unwrap_used)]

use datasets::simulate::{Scenario, SimulatedLoop};
use detection::{detect, Detection, Registration, Verdict};
use stiction_models::Kano;

/// The simulator's default loop (`stiction simulate --valve kano --param S=4 --param J=1`).
fn kano(s: f64, j: f64, seed: u64) -> SimulatedLoop {
    Scenario {
        valve: Box::new(Kano::params().s(s).j(j).check().unwrap()),
        seed,
        ..Scenario::default()
    }
    .simulate()
    .unwrap()
}

fn run(l: &SimulatedLoop, scale: f64, offset: f64) -> Detection {
    let pv: Vec<f64> = l.pv.iter().map(|v| v * scale + offset).collect();
    let sp: Vec<f64> = l.sp.iter().map(|v| v * scale + offset).collect();
    let reg = Registration::new(&pv, &l.op, 1.0)
        .unwrap()
        .with_sp(&sp)
        .unwrap();
    detect(&reg)
}

#[test]
fn pv_and_sp_units_do_not_change_the_verdict_or_the_score() {
    for (s, j, seed) in [(4.0, 1.0, 1), (0.0, 0.0, 2), (2.0, 0.5, 3)] {
        let l = kano(s, j, seed);
        let base = run(&l, 1.0, 0.0);
        for (scale, offset) in [
            (1e-6, 0.0),
            (1e-3, 3.0),
            (2.5, -40.0),
            (1e5, 0.0),
            (2e6, 1e7),
            (1e9, 0.0),
            (1e12, 5e13),
        ] {
            let d = run(&l, scale, offset);
            assert_eq!(
                d.verdict, base.verdict,
                "S = {s}, J = {j}, PV × {scale} + {offset}: {} against {}",
                d.reason, base.reason
            );
            assert!(
                (d.score - base.score).abs() < 1e-6,
                "S = {s}, J = {j}, PV × {scale} + {offset}: score {} against {}",
                d.score,
                base.score
            );
        }
    }
}

/// Values that overflow the tests' sums (three PV samples of 1e150 in a sticky loop) give no
/// verdict from NaN statistics: the old code said `no-stiction` from "NGI NaN, NLI NaN".
#[test]
fn overflowing_values_give_no_verdict_from_nan() {
    let mut l = kano(4.0, 1.0, 1);
    for k in [500, 1500, 2500] {
        l.pv[k] = 1e150;
    }
    let d = run(&l, 1.0, 0.0);
    for t in &d.tests {
        assert!(
            !t.evidence.contains("NaN") && t.statistic.is_none_or(f64::is_finite),
            "{}: {}",
            t.name,
            t.evidence
        );
    }
    assert!(!d.reason.contains("NaN"), "{}", d.reason);
    let json = serde_json::to_string(&d).unwrap();
    assert!(!json.contains("NaN"), "{json}");
}

/// When no test could judge the record the verdict is `inconclusive`, not the base rate's
/// `no-stiction` (score 0.30).
#[test]
fn no_test_that_could_judge_is_inconclusive() {
    let l = kano(4.0, 1.0, 1);
    let reg = Registration::new(&l.pv, &l.op, 1.0).unwrap();
    let none: Vec<detection::TestOutcome> = detection::registry()
        .iter()
        .map(|e| detection::TestOutcome::new(e.name, None, Verdict::Inconclusive, "cannot judge"))
        .collect();
    let d = detection::combine(&reg, none, &detection::Model::calibrated());
    assert_eq!(d.verdict, Verdict::Inconclusive, "{}", d.reason);
}
