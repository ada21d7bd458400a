//! The causes a valve's registrations agree on, as the trend reports them: three generated
//! records of the diagnosis's hidden-effect suite (`discrepancy/tests/common`), two with an
//! extra dead time and one with a disturbance, stand for one valve on three days.
#![allow(clippy::unwrap_used)]

#[path = "../../discrepancy/tests/common/mod.rs"]
mod common;

use common::{case, Effect};

/// `stiction trend` ([`monitoring::trend::follow`], diagnosing) diagnoses every
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
    let vt = monitoring::trend::follow("V7", &files, &options, true, None).unwrap();
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
