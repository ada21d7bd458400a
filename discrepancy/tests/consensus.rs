//! The causes a valve's registrations agree on (`discrepancy::consensus`): three generated
//! records, two with an extra dead time and one with a disturbance, stand for one valve on
//! three days.
#![allow(clippy::unwrap_used)]

mod common;

use common::{case, Effect};

#[test]
fn the_causes_of_most_registrations_hold_and_the_other_says_why() {
    // suite loops diagnosed right alone: [time-delay], [time-delay], [disturbance]
    let runs = [
        ("7200", Effect::Delay),
        ("7201", Effect::Delay),
        ("7101", Effect::Disturbance),
    ];
    let diagnoses: Vec<(&str, discrepancy::Diagnosis)> = runs
        .iter()
        .map(|(label, e)| (*label, case(label.parse().unwrap(), *e, 3000).diagnose(&[])))
        .collect();
    let refs: Vec<(&str, &discrepancy::Diagnosis)> =
        diagnoses.iter().map(|(l, d)| (*l, d)).collect();
    let c = discrepancy::consensus(&refs);
    println!("{c:#?}");
    assert_eq!(c.registrations, 3);
    assert_eq!(c.causes, vec![("time-delay".to_string(), 2)]);
    assert_eq!(c.disagreeing.len(), 1);
    let d = &c.disagreeing[0];
    assert_eq!(d.label, "7101");
    assert_eq!(d.causes, ["disturbance"]);
    assert_eq!(d.why.len(), 2, "{:?}", d.why);
    assert!(
        d.why[0].starts_with("no time-delay: likelihood ratio")
            && d.why[0].ends_with("not significant"),
        "{}",
        d.why[0]
    );
    assert!(
        d.why[1].starts_with("also disturbance: likelihood ratio"),
        "{}",
        d.why[1]
    );
}

#[test]
fn no_cause_holds_when_the_registrations_split() {
    let a = case(7200, Effect::Delay, 3000).diagnose(&[]);
    let b = case(7101, Effect::Disturbance, 3000).diagnose(&[]);
    let c = discrepancy::consensus(&[("a", &a), ("b", &b)]);
    assert!(c.causes.is_empty(), "{:?}", c.causes);
    assert_eq!(c.disagreeing.len(), 2);
}
