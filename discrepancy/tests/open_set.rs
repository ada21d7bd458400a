//! The open-set check (`unexplained`) sees a process change that happens before the final
//! valve's In.3 estimate settles: the grid search prefers a valve whose estimate starts after
//! the change, so a check confined to the samples from `k₀` on would find nothing there.
#![allow(clippy::unwrap_used)]

mod common;

use common::{case, Effect};

/// The open set's finding of a diagnosis (the check always runs on these loops).
fn open_set_finding(d: &discrepancy::Diagnosis) -> &discrepancy::Finding {
    d.findings
        .iter()
        .find(|f| f.cause == discrepancy::UNEXPLAINED)
        .expect("the open-set check ran")
}

#[test]
fn a_change_before_the_valve_estimate_settles_is_unexplained() {
    // seed 0: the paper plant, then from sample 964 the slow plant's dynamics (gain x0.65)
    let c = case(0, Effect::ProcessChange, 3000);
    let change = c.sim.scenario.plant_change.as_ref().unwrap().at;
    let d = c.diagnose(&[]);
    // the model the open set ran on (the final model is refitted after the change)
    let f = d.selected_fit().unwrap_or(&d.baseline_fit);
    let k0 = f.result.fits.valid_from;
    let open = open_set_finding(&d);
    println!(
        "change at {change}, k0 {k0}, causes {:?}, open-set LR {:.1} (threshold {:.0})",
        d.causes, open.lr, open.threshold
    );
    // the case this test is about: nothing of the old process after k0
    assert!(k0 >= change, "k0 {k0} before the change at {change}");
    assert!(
        d.causes.iter().any(|c| c == discrepancy::UNEXPLAINED),
        "causes {:?}: the open-set LR {:.1} is below its threshold {:.0}",
        d.causes,
        open.lr,
        open.threshold
    );
    assert!(open.evidence.contains("samples 0-"), "{}", open.evidence);
}

#[test]
fn a_cause_that_gains_only_from_the_change_is_not_named() {
    // suite seed 1015: the slow plant, then from sample 696 the paper plant's dynamics (gain
    // x0.78); on the whole window `valve-characteristic` gains significantly, on the changed
    // process alone (the last third of the identification window) it does not
    let c = case(1015, Effect::ProcessChange, 3000);
    let d = c.diagnose(&[]);
    let dropped: Vec<&discrepancy::Finding> = d
        .findings
        .iter()
        .chain(d.steps.iter().flatten())
        .filter(|f| f.evidence.contains("Not named: the process changed"))
        .collect();
    println!(
        "causes {:?}; dropped {:?}\n{}",
        d.causes,
        dropped.iter().map(|f| (f.cause, f.lr)).collect::<Vec<_>>(),
        d.summary
    );
    assert_eq!(d.causes, vec![discrepancy::UNEXPLAINED]);
    assert_eq!(d.cause, discrepancy::UNEXPLAINED);
    assert!(
        dropped
            .iter()
            .any(|f| f.cause == "valve-characteristic" && !f.significant),
        "no cause dropped"
    );
    assert!(
        d.selected_fit().is_none(),
        "the selected model is the baseline"
    );
}

#[test]
fn a_change_that_a_cause_absorbed_is_still_found() {
    // seed 2084 (outside the suite's seeds): `asymmetric-stiction` gains on the whole window
    // (LR 37) and its model leaves no significant change, but the baseline shows one and the
    // asymmetry does not hold on the recent window. (Suite seed 1085 served until the dead
    // time's extension fitted the dead times around the scan's best on the full grid: its
    // `time-delay` then holds on the recent window too, and the change is found on the final
    // model directly.) Without the check of the baseline the causes are
    // `[asymmetric-stiction]`.
    let c = case(2084, Effect::ProcessChange, 3000);
    println!("{}", c.what);
    let d = c.diagnose(&[]);
    let dropped: Vec<(&str, f64)> = d
        .findings
        .iter()
        .filter(|f| f.evidence.contains("Not named: the process changed"))
        .map(|f| (f.cause, f.lr))
        .collect();
    println!("causes {:?}; dropped {dropped:?}", d.causes);
    for f in d
        .findings
        .iter()
        .filter(|f| f.evidence.contains("Not named"))
    {
        println!("{}", f.evidence);
    }
    assert_eq!(d.causes, vec![discrepancy::UNEXPLAINED]);
    assert!(
        dropped.iter().any(|(c, _)| *c == "asymmetric-stiction"),
        "{dropped:?}"
    );
}

#[test]
fn an_early_change_is_seen_from_a_longer_recent_window() {
    // suite seed 1195: the paper plant, then from sample 719 the slow plant's dynamics (gain
    // x0.98). The last third of the identification window alone (from sample 1333) did not
    // predict the validation data significantly better than the whole window (nothing was
    // named); the window from a third of it (sample 666) holds the new process only and does.
    let c = case(1195, Effect::ProcessChange, 3000);
    let d = c.diagnose(&[]);
    let open = open_set_finding(&d);
    println!(
        "causes {:?}, open-set LR {:.1}: {}",
        d.causes, open.lr, open.evidence
    );
    assert_eq!(d.causes, vec![discrepancy::UNEXPLAINED]);
}
