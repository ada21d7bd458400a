//! A PV read back from a historian's compressed storage is named among the doubts of every
//! search on it, and the verdict does not say "the valve sticks" on its strength alone.

use datasets::simulate::{Scenario, SimulatedLoop};
use grid_search::{Doubt, Problem};
use run::Settings;
use stiction_models::Kano;

/// A sticky loop (Kano S = 4, J = 1), its PV archived with the swinging door's `compression`
/// deviation when given.
fn simulated(compression: Option<f64>) -> SimulatedLoop {
    Scenario {
        valve: Box::new(Kano::params().s(4.0).j(1.0).check().expect("test data")),
        noise_sigma: 0.3,
        pv_compression: compression,
        ..Scenario::default()
    }
    .simulate()
    .expect("test data")
}

fn search(compression: Option<f64>) -> (f64, Vec<Doubt>, bool) {
    let sim = simulated(compression);
    let fitted = Settings::default()
        .combination("kano", "arx")
        .expect("test data")
        .run(
            Problem {
                op: &sim.op,
                pv: &sim.pv,
                mv: None,
            },
            None,
        )
        .expect("test data");
    let q = &fitted.result;
    let compressed = q.warnings.iter().any(|w| w.contains("compressed storage"));
    (q.s, q.doubts.clone(), compressed && !q.verdict().sticks())
}

#[test]
fn a_compressed_pv_is_a_doubt() {
    // the raw PV: no such doubt, the valve sticks
    let (s, doubts, _) = search(None);
    assert!(
        !doubts
            .iter()
            .any(|d| matches!(d, Doubt::CompressedPv { .. })),
        "{doubts:?}"
    );
    assert!((s - 4.0).abs() < 0.5, "S = {s}");
    // archived with a deviation of a tenth of PV's span (about 6): the doubt, no "sticks"
    let (_, doubts, flagged) = search(Some(0.6));
    assert!(
        doubts
            .iter()
            .any(|d| matches!(d, Doubt::CompressedPv { .. })),
        "{doubts:?}"
    );
    assert!(flagged, "warning and verdict: {doubts:?}");
}

/// The one answer on `d` (the loop kind decided from the record), with the analysis it rests on.
fn answer_on(d: &datasets::LoopData) -> (monitoring::Analysis, monitoring::Answer) {
    let a = monitoring::analyse(d, None, monitoring::Integrating::Auto);
    let view = a.detect(d);
    let answer = monitoring::Answer::new(&a, &view.detected, None);
    (a, answer)
}

/// `answer` is `stiction`, and its line holds `caution` exactly when `cautioned`.
fn assert_stiction(answer: &monitoring::Answer, caution: &str, cautioned: bool) {
    let line = answer.line();
    assert_eq!(answer.verdict, detection::Verdict::Stiction, "{line}");
    assert_eq!(line.contains(caution), cautioned, "{line}");
}

/// The detector's `stiction` on a compressed PV carries the caution of
/// [`monitoring::answer::compression_caution`], in every command's one answer; the raw PV of
/// the same loop does not.
#[test]
fn a_stiction_verdict_on_a_compressed_pv_carries_a_caution() {
    let caution = "caution: PV reads back from compressed storage";
    let (a, plain) = answer_on(&simulated(None).to_loop_data());
    assert!(a.pv_compression.is_none(), "{:?}", a.pv_compression);
    assert_stiction(&plain, caution, false);
    let (a, cautioned) = answer_on(&simulated(Some(0.6)).to_loop_data());
    let found = a.pv_compression;
    assert!(found.is_some_and(|c| c.share > 0.5), "{found:?}");
    assert_stiction(&cautioned, caution, true);
}

#[test]
fn only_a_stiction_verdict_on_a_compressed_pv_is_cautioned() {
    use detection::Verdict;
    use monitoring::answer::compression_caution;
    let c = datasets::Compression {
        share: 0.9,
        segments: 40,
        median_len: 8,
    };
    assert!(compression_caution(Verdict::Stiction, Some(c)).is_some());
    assert!(compression_caution(Verdict::NoStiction, Some(c)).is_none());
    assert!(compression_caution(Verdict::Inconclusive, Some(c)).is_none());
    assert!(compression_caution(Verdict::Stiction, None).is_none());
}

/// PV of `sim` held between updates every 5 samples (an analyser's cycle).
fn held_every_5(live: &datasets::LoopData) -> datasets::LoopData {
    let mut held = live.clone();
    let pv: Vec<f64> = live.pv.clone().expect("test data");
    held.pv = Some((0..pv.len()).map(|i| pv[i / 5 * 5]).collect());
    held
}

/// A PV held between updates every 5 samples is found, and the detector's `stiction` on it
/// carries the caution of [`monitoring::answer::held_caution`] where the score reaches the
/// held threshold (a valve of S = 8 with little noise); the live PV of the same loop does not.
/// A sticky valve whose held record scores below that threshold (S = 4, J = 1, the live PV
/// called `stiction`) is `inconclusive`, with the reason
/// (`monitoring::detect::hold_on_held_pv`).
#[test]
fn a_stiction_verdict_on_a_held_pv_carries_a_caution() {
    let caution = "caution: PV changes only every 5 samples";
    let strong = Scenario {
        valve: Box::new(Kano::params().s(8.0).j(0.0).check().expect("test data")),
        noise_sigma: 0.1,
        samples: 2000,
        ..Scenario::default()
    }
    .simulate()
    .expect("test data")
    .to_loop_data();
    let (a, plain) = answer_on(&strong);
    assert!(a.pv_held.is_none(), "{:?}", a.pv_held);
    assert_stiction(&plain, caution, false);
    let (a, cautioned) = answer_on(&held_every_5(&strong));
    assert_eq!(a.pv_held.map(|h| h.period), Some(5), "{:?}", a.pv_held);
    assert_stiction(&cautioned, caution, true);
    use monitoring::answer::held_caution;
    assert!(held_caution(detection::Verdict::NoStiction, a.pv_held).is_none());
    assert!(held_caution(detection::Verdict::Stiction, None).is_none());

    let live = simulated(None).to_loop_data();
    let (_, plain) = answer_on(&live);
    assert_stiction(&plain, caution, false);
    let held = held_every_5(&live);
    let a = monitoring::analyse(&held, None, monitoring::Integrating::Auto);
    let detected = a.detect(&held).detected;
    assert_eq!(detected.verdict(), detection::Verdict::Inconclusive);
    let reason = detected.reason();
    assert!(
        reason.starts_with("stiction (") && reason.contains("PV changes only every 5 samples"),
        "{reason}"
    );
    assert!(
        detected.score() < Some(monitoring::detect::HELD_STICTION_AT),
        "{reason}"
    );
}
