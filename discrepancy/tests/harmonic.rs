//! The `disturbance` cause's harmonic form (HARX, an ARX of the signals notch-filtered at the
//! dominant frequency of the simulation residuals) and its guard against notching the valve's
//! own limit cycle, on loops of the hidden-effect suite (same generator and seeds).
#![allow(clippy::unwrap_used)]

mod common;

use common::{case, Effect};

fn linear_of(d: &discrepancy::Diagnosis) -> String {
    d.final_fit()
        .map_or("-".to_string(), |f| f.linear.to_string())
}

#[test]
fn a_linear_valve_under_an_external_sine_is_not_sticky() {
    // suite seed 1043: slow plant, linear valve, a sine of amplitude 1.22 at 0.055
    // rad/sample. With EARX alone the disturbance extension explained part of the sine with a
    // valve of S = 14.6 and the answer was `disturbance`; the notch removes the sine and the
    // valve needs no stiction.
    let c = case(1043, Effect::Oscillation, 3000);
    let d = c.diagnose(&[]);
    let dist = d
        .findings
        .iter()
        .find(|f| f.cause == "disturbance")
        .unwrap();
    println!(
        "causes {:?}; disturbance LR {:.1} ({})\n{}",
        d.causes,
        dist.lr,
        dist.extended.as_ref().map_or("-".to_string(), |e| format!(
            "{} S {:.2}",
            e.linear_model, e.s
        )),
        d.summary
    );
    assert_eq!(d.cause, "no-stiction", "causes {:?}", d.causes);
    assert_eq!(
        dist.extended.as_ref().map(|e| e.linear_model),
        Some("harx"),
        "the disturbance is a sine"
    );
}

#[test]
fn a_sine_disturbance_beside_a_dead_time_is_found() {
    // suite seed 1007: slow plant, a sine of amplitude 0.83 at 0.031 rad/sample and 6 samples
    // of extra dead time; with EARX alone only `time-delay` was found
    let c = case(1007, Effect::DisturbanceDelay, 3000);
    let d = c.diagnose(&[]);
    println!(
        "causes {:?}, final linear model {}",
        d.causes,
        linear_of(&d)
    );
    let mut causes = d.causes.clone();
    causes.sort();
    assert_eq!(causes, vec!["disturbance", "time-delay"]);
}

#[test]
fn a_notch_on_the_valves_own_cycle_is_not_a_disturbance() {
    // suite seed 1172: paper plant, Kano valve S = 4.14, 5 samples of extra dead time and no
    // disturbance. A notch at the limit cycle (0.26 rad/sample) with a valve of S = 0 gains
    // LR 48 on the baseline; a dead time found on top brings the stiction back (S = 4.0), so
    // the notch was the valve's own cycle: the forward selection does not admit that model
    let c = case(1172, Effect::Delay, 3000);
    let d = c.diagnose(&[]);
    println!(
        "causes {:?}, final linear model {}",
        d.causes,
        linear_of(&d)
    );
    assert_eq!(d.causes, vec!["time-delay"]);
}

#[test]
fn a_valve_sticky_under_another_explanation_is_not_called_healthy() {
    // suite seed 1177: slow plant, Kano S = 3.4, a sine of amplitude 0.97 at 0.040 rad/sample
    // and 6 samples of extra dead time. With the sine notched out (the best first-round
    // extension) the valve without stiction cost LR 0.9, so `no-stiction` held against it;
    // with the dead time modelled the valve is sticky (S = 4.7). `no-stiction` must hold
    // against every significant extension.
    let c = case(1177, Effect::DisturbanceDelay, 3000);
    let d = c.diagnose(&[]);
    let ns = d
        .findings
        .iter()
        .find(|f| f.cause == "no-stiction")
        .unwrap();
    println!("causes {:?}; no-stiction: {}", d.causes, ns.evidence);
    let mut causes = d.causes.clone();
    causes.sort();
    assert_eq!(causes, vec!["disturbance", "time-delay"]);
}
