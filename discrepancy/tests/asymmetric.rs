//! The `asymmetric-stiction` extension's free search finds a strongly asymmetric valve that
//! the symmetric fit sends far away (suite loops, same generator and seeds).
#![allow(clippy::unwrap_used)]

mod common;

use common::{case, Effect};

#[test]
fn an_asymmetric_valve_under_a_sine_is_found_beside_it() {
    // suite seed 1118: slow plant, a sine of amplitude 0.63 at 0.080 rad/sample, kano-asym
    // D = 3.55, J_up = 0.51, J_dn = 3.47. The symmetric fit on the disturbance's model has
    // J = 0 and a deadband near the larger band; from there the three starts of the free
    // search stayed at LR 0 (answer `disturbance, time-delay`). The coarse lattice scaled by
    // the symmetric band gives the search a start near the asymmetric optimum.
    let c = case(1118, Effect::DisturbanceAsymmetric, 3000);
    let d = c.diagnose(&[]);
    let asym = d
        .findings
        .iter()
        .chain(d.steps.iter().flatten())
        .filter(|f| f.cause == "asymmetric-stiction")
        .map(|f| f.lr)
        .fold(f64::NEG_INFINITY, f64::max);
    println!(
        "causes {:?}; largest asymmetric-stiction LR {asym:.1}",
        d.causes
    );
    let mut causes = d.causes.clone();
    causes.sort();
    assert_eq!(causes, vec!["asymmetric-stiction", "disturbance"]);
}
