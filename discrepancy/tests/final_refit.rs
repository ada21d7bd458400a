//! The final model is refitted where the diagnosis found reason to (docs/DIAGNOSE.md, "The
//! final model"): after a change of the process on the samples after it, and with the linear
//! orders `n` and `m` raised by one when that gains significantly; the open set runs on the
//! model refitted at those orders. Each test fails when what it tests is disabled.
#![allow(clippy::unwrap_used)]

mod common;

use common::{case, Effect};

fn within(s: f64, truth: f64) -> bool {
    (s - truth).abs() <= (0.1 * truth).max(0.5)
}

#[test]
fn raised_orders_take_back_the_deadband_that_stood_in_for_lag() {
    // suite seed 1092: the slow (third-order) plant with 5 samples of extra dead time, Kano
    // S = 7.22. With the paper's ARX(2, 2) the time-delay extension put S at 10.30; ARX(3, 3)
    // gains likelihood ratio 80 on validation data and puts S at 7.30.
    let c = case(1092, Effect::Delay, 3000);
    let d = c.diagnose(&[]);
    let f = d.final_fit().unwrap();
    let o = d.order_selection.as_ref();
    println!(
        "{}: causes {:?}, orders {o:?}, S {:.2} (true {:.2}; the selected model's {:.2})",
        c.what,
        d.causes,
        f.result.s,
        c.s,
        d.selected_fit().unwrap().result.s
    );
    assert_eq!(d.causes, ["time-delay"]);
    assert!(
        within(f.result.s, c.s),
        "S {:.2} against the true {:.2}",
        f.result.s,
        c.s
    );
    assert!(o.is_some_and(|o| o.raised), "{o:?}");
}

#[test]
fn after_a_change_the_final_model_is_identified_on_the_new_process() {
    // suite seed 1155: the slow plant, then from sample 725 the paper plant's dynamics (gain
    // x0.73), Kano S = 4.10. On the whole record the baseline puts S at 2.45; on the samples
    // after the open set's recent window starts (1000) it is 4.10.
    let c = case(1155, Effect::ProcessChange, 3000);
    let d = c.diagnose(&[]);
    let f = d.final_fit().unwrap_or(&d.baseline_fit);
    println!(
        "{}: causes {:?}, S {:.2} (true {:.2}; baseline {:.2}), {:?}",
        c.what, d.causes, f.result.s, c.s, d.baseline.s, f.result.warnings
    );
    assert_eq!(d.causes, [discrepancy::UNEXPLAINED]);
    assert!(
        within(f.result.s, c.s),
        "S {:.2} against the true {:.2}",
        f.result.s,
        c.s
    );
    assert!(
        f.result
            .warnings
            .iter()
            .any(|w| w.contains("identified on samples 1000-2000")),
        "{:?}",
        f.result.warnings
    );
}

#[test]
fn the_open_set_asks_what_the_refitted_model_leaves() {
    // suite seed 1028: the paper disturbance and an asymmetric valve (kano-asym D = 2.99,
    // J_dn = 3.97), no change of the process. On the selected model (kano-asym + EARX at
    // ARX(2, 2)'s orders) the open set saw a change (`unexplained`); the model refitted at the
    // raised orders leaves none.
    let c = case(1028, Effect::DisturbanceAsymmetric, 3000);
    let d = c.diagnose(&[]);
    println!(
        "{}: causes {:?}, orders {:?}",
        c.what, d.causes, d.order_selection
    );
    assert_eq!(d.causes, ["asymmetric-stiction", "disturbance"]);
}
