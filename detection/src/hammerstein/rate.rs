//! The integrating loop's output for the output-error fit: the level's rate through a noise
//! filter ([`rate_noise_filter`]).

use super::{best_oe_many, mean, Target, MAX_DELAY};

/// The poles `b` of the integrating loop's noise filter ([`rate_noise_filter`]), chosen by the
/// training population's cross-validated AUC against a longer set
/// (`docs/decisions/2026-11-29-level-rate-filter.md`).
const RATE_FILTER_POLES: [f64; 5] = [0.0, 0.5, 0.8, 0.9, 0.95];

/// An integrating loop's output for the output-error fit: its rate `ΔPV` through the monic
/// filter `1/(1 − b q⁻¹)`, with the pole `b` of [`RATE_FILTER_POLES`] whose free valve leaves
/// the least residual; returns the filtered rate and `b`.
///
/// Why: a level's rate carries two noises of other colours. A load (an inflow that wanders)
/// enters the rate as it is, white or slow; the transmitter's own noise enters it
/// differenced, `e(t) − e(t−1)`, whose power grows with frequency. Least squares on the raw
/// rate then fits that differenced noise first — the high frequencies, where a free and a
/// sticky valve differ least — and a deadband's evidence at the oscillation's frequency
/// drowns. The filter is the noise model's inverse (b → 1 undoes the difference, b = 0 keeps
/// the rate), and because it is monic the residuals of different `b` are comparable as
/// likelihoods: the least residual of the free valve is the noise model the data support
/// (the free valve decides, so the sticky valves cannot pick a filter in their favour; every
/// valve is then fitted to the same filtered output). The valve inputs are not filtered: the
/// model's one lag absorbs the filter's in part (the same for every valve), which holds `b`
/// below the noise's own value (0.8 on a rate whose only noise is the transmitter's,
/// differenced, where the noise model alone would ask for 1; test
/// `the_rate_filter_undoes_the_difference_of_the_transmitter_noise_only`).
pub(super) fn rate_noise_filter(y: &[f64], op: &[f64], omegas: &[f64]) -> (Vec<f64>, f64) {
    let n = y.len().min(op.len());
    let start = MAX_DELAY + 2;
    if n < start + 20 {
        return (y.to_vec(), 0.0);
    }
    let om = mean(&op[..n]);
    let u0: Vec<f64> = op[..n].iter().map(|v| v - om).collect();
    let filt = |b: f64| -> Vec<f64> {
        let mut out = Vec::with_capacity(n);
        let mut prev = 0.0;
        for &v in &y[..n] {
            prev = v + b * prev;
            out.push(prev);
        }
        let m = mean(&out);
        out.iter().map(|v| v - m).collect()
    };
    let mut best = (f64::INFINITY, Vec::new(), 0.0);
    for b in RATE_FILTER_POLES {
        let yb = filt(b);
        let rss = best_oe_many(&Target::new(&yb, start, omegas), &[&u0])[0].0;
        if rss < best.0 {
            best = (rss, yb, b);
        }
    }
    if best.1.is_empty() {
        // no residual compared (a NaN throughout): the rate as it is, centred
        return (filt(0.0), 0.0);
    }
    (best.1, best.2)
}
