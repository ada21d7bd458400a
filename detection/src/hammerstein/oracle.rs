//! What the true valve position shows through the test's own model: the oracle of the
//! simulated populations ([`oracle_lr`], [`oracle_lr_integrating`]).

use super::noise::{input, noise_model, noise_order, second_lag, whiten};
use super::rate::rate_noise_filter;
use super::{best_oe_many, mean, Target, MAX_DELAY};

/// How much better the valve position `mv` explains the output `y` (PV; for an integrating
/// loop see [`oracle_lr_integrating`]) than OP does, through this test's output-error model
/// (its second lag and noise model chosen by OP, as the test's by the free valve; constant
/// only, no nuisance sines): `N ln(RSS_OP / RSS_MV)`, at least 0. For simulated loops, where the true
/// valve position is known, this is the evidence any PV-OP test of this model family could
/// find at best: a sticky valve whose ratio is small never stuck visibly in the record (a valve
/// dithered by OP's noise, or held still by a constant load). `None` when a residual vanishes
/// or the record is too short.
pub fn oracle_lr(y: &[f64], op: &[f64], mv: &[f64]) -> Option<f64> {
    oracle_lr_kind(y, op, mv, false)
}

/// [`oracle_lr`] through the noise model of a loop of that kind (`noise::noise_order`).
fn oracle_lr_kind(y: &[f64], op: &[f64], mv: &[f64], integrating: bool) -> Option<f64> {
    let n = y.len().min(op.len()).min(mv.len());
    let start = MAX_DELAY + 2;
    if n < start + 20 {
        return None;
    }
    let ym = mean(&y[..n]);
    let y: Vec<f64> = y[..n].iter().map(|v| v - ym).collect();
    let om = mean(&op[..n]);
    let u: Vec<f64> = op[..n].iter().map(|v| v - om).collect();
    let m: Vec<f64> = mv[..n].iter().map(|v| v - om).collect();
    // the test's second lag and noise model, from OP (the free valve) as the test estimates
    // them
    let raw = Target::new(&y, start, &[]);
    let lag2 = second_lag(&raw, &u);
    let phi = noise_model(&raw, &input(&u, &[], lag2), noise_order(integrating));
    let start = start + phi.len();
    let tg = Target::new(&whiten(&y, &phi), start, &[]);
    let fits = best_oe_many(&tg, &[&input(&u, &phi, lag2), &input(&m, &phi, lag2)]);
    let (r_op, r_mv) = (fits[0].0, fits[1].0);
    (r_op > 0.0 && r_mv > 0.0 && r_op.is_finite() && r_mv.is_finite())
        .then(|| (n - start) as f64 * (r_op / r_mv).max(1.0).ln())
}

/// [`oracle_lr`] of an integrating loop, whose valve the test reads in the level's rate: `pv`
/// differenced, through the rate's noise filter that OP picks (as the test's free valve picks
/// it), against `op` and `mv` aligned with the rate (from their second sample on). Without the
/// filter the oracle weighed the transmitter's differenced noise first and missed sticky
/// levels the test itself sees.
pub fn oracle_lr_integrating(pv: &[f64], op: &[f64], mv: &[f64]) -> Option<f64> {
    let n = pv.len().min(op.len()).min(mv.len());
    if n < 2 {
        return None;
    }
    let rate: Vec<f64> = pv[..n].windows(2).map(|w| w[1] - w[0]).collect();
    let (filtered, _) = rate_noise_filter(&rate, &op[1..n], &[]);
    oracle_lr_kind(&filtered, &op[1..n], &mv[1..n], true)
}
