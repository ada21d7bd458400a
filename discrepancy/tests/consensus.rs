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

/// `stiction trend` (`monitoring::trend::follow` with this crate's diagnoser) diagnoses every
/// registration once and reports what they agree on: the three loops above written as one
/// valve's registrations on three days.
#[test]
fn the_trend_reports_the_causes_its_registrations_agree_on() {
    let dir = std::env::temp_dir().join(format!("stiction-consensus-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let runs = [
        ("20240101-0800", 7200, Effect::Delay),
        ("20240102-0800", 7201, Effect::Delay),
        ("20240103-0800", 7101, Effect::Disturbance),
    ];
    let files: Vec<std::path::PathBuf> = runs
        .iter()
        .map(|(day, seed, effect)| {
            let sim = case(*seed, *effect, 3000).sim;
            let mut text = String::from("t,SP,PV,OP\n");
            for i in 0..sim.op.len() {
                text.push_str(&format!(
                    "{},{},{},{}\n",
                    sim.t[i], sim.sp[i], sim.pv[i], sim.op[i]
                ));
            }
            let f = dir.join(format!("V7_{day}.csv"));
            std::fs::write(&f, text).unwrap();
            f
        })
        .collect();
    let options = monitoring::trend::TrendOptions::default();
    let diagnoser = discrepancy::registration::RegistrationDiagnosis;
    let vt = monitoring::trend::follow("V7", &files, &options, Some(&diagnoser), None).unwrap();
    let c = vt
        .causes
        .as_ref()
        .expect("the registrations were diagnosed");
    println!("{c:#?}");
    assert_eq!(c.registrations, 3);
    assert_eq!(c.causes, vec![("time-delay".to_string(), 2)]);
    assert_eq!(c.disagreeing.len(), 1);
    assert_eq!(c.disagreeing[0].label, "2024-01-03 08:00");
    let json = serde_json::to_value(vt.record()).unwrap();
    assert_eq!(
        json["causes"]["causes"][0],
        serde_json::json!({"cause": "time-delay", "registrations": 2})
    );
    let _ = std::fs::remove_dir_all(&dir);
}
