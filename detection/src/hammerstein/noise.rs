//! What the Hammerstein test's fits see of a valve's position and of the output's noise: the
//! process's second lag ([`second_lag`], [`input`]), the noise model ([`noise_model`]) and the
//! whitening by it ([`whiten`]).

use super::{best_oe_many, Target, MAX_BASIS, MAX_DELAY, POLES};

/// Order of the noise model that whitens the output-error fits of a self-regulating loop
/// ([`noise_model`]).
const NOISE_ORDER: usize = 8;

/// Order of the noise model on the integrating path (the level's filtered rate), where five
/// rows per coefficient allow; never below [`NOISE_ORDER`].
///
/// Why longer: a level integrates its loads, and what its rate holds of a load that steps or
/// wanders is a slow, coloured signal that a short AR model leaves in the residual, where a
/// deadband's slips compete with it. The observer that knows the plant and the valve
/// (`datasets::simulate::population::known_model_lr`) sees the most of the sticky levels
/// through an AR model of order 40 (its AUC on the validation populations' levels, 400 loops
/// each: order 8 0.852, 20 0.868, 40 0.894, 80 0.877). Chosen on the training populations'
/// 5-fold cross-validated AUC of the integrating loops, three draws, the weights refitted:
/// order 8 0.824 / 0.782 / 0.793 (mean 0.800), 40 0.833 / 0.809 / 0.794 (0.812), 60 0.844 /
/// 0.791 / 0.798 (0.811), 80 0.851 / 0.803 / 0.786 (0.813); the three longer orders tie, and
/// the shortest of them costs least (docs/decisions/2026-11-30-known-model-ceiling.md). The
/// self-regulating loops keep order 8: the same observer sees them best at 8 (0.942 against
/// 0.938 at 40).
const NOISE_ORDER_INTEGRATING: usize = 40;

/// The noise model's order for a loop of this kind.
pub(super) fn noise_order(integrating: bool) -> usize {
    if integrating {
        NOISE_ORDER_INTEGRATING
    } else {
        NOISE_ORDER
    }
}

/// The poles `b` of the second lag that every valve's input goes through before the fits'
/// own first-order lag ([`second_lag`]): four, one pass of the fits' lanes.
const SECOND_LAGS: [f64; 4] = [0.0, 0.5, 0.8, 0.9];

/// The second lag of the process, `(1 − b)/(1 − b q⁻¹)` with the pole `b` of [`SECOND_LAGS`]
/// whose free valve leaves the least output-error residual on `tg` (OP about its mean `u0`,
/// the first lag and delay fitted as always).
///
/// Why: many processes have two lags (a pressure behind a vessel and its transmitter, a
/// composition behind a column's trays), and the fits' single lag misses the second. A free
/// valve's misfit is then a residual with structure that a sticky valve can take up in part
/// (its band holds the valve back as the second lag holds the process), so free loops gained
/// evidence; the noise model took that misfit out, and the sticky loops' slow evidence with it.
/// The free valve decides the lag, as it decides the noise model and a level's rate filter, so
/// the sticky valves cannot pick one in their favour; every valve's position then goes through
/// it (the process's lag acts on the valve's position, not on OP). Chosen on the simulated
/// training populations' cross-validated AUC, three draws: without 0.896 / 0.871 / 0.871, with
/// these poles 0.898 / 0.876 / 0.880 (four to six poles between 0 and 0.95 within 0.001 of it,
/// `{0, 0.8}` 0.873 on the third draw: docs/decisions/2026-11-29-second-lag.md).
pub(super) fn second_lag(tg: &Target, u0: &[f64]) -> f64 {
    let inputs: Vec<Vec<f64>> = SECOND_LAGS.iter().map(|&b| input(u0, &[], b)).collect();
    let refs: Vec<&[f64]> = inputs.iter().map(Vec::as_slice).collect();
    best_oe_many(tg, &refs)
        .iter()
        .zip(SECOND_LAGS)
        .filter(|((r, _), _)| r.is_finite() && *r > 0.0)
        .min_by(|a, b| a.0 .0.total_cmp(&b.0 .0))
        .map_or(0.0, |(_, b)| b)
}

/// `v` through the noise model's inverse `A(q) = 1 − Σ φᵢ q⁻ⁱ`: `v(t) − Σ φᵢ v(t−i)` (the
/// terms before the record's start left out).
pub(super) fn whiten(v: &[f64], phi: &[f64]) -> Vec<f64> {
    let mut out = v.to_vec();
    whiten_in_place(&mut out, phi);
    out
}

/// A valve's input as the fits read it: through the second lag `1 − b` over `1 − b q⁻¹` (unit
/// gain; none for `b = 0`), then whitened by `phi`.
pub(super) fn input_in_place(v: &mut [f64], phi: &[f64], lag2: f64) {
    if lag2 > 0.0 {
        let mut prev = v.first().copied().unwrap_or(0.0);
        for x in v.iter_mut() {
            prev = lag2 * prev + (1.0 - lag2) * *x;
            *x = prev;
        }
    }
    whiten_in_place(v, phi);
}

/// [`input_in_place`] on a copy.
pub(super) fn input(v: &[f64], phi: &[f64], lag2: f64) -> Vec<f64> {
    let mut out = v.to_vec();
    input_in_place(&mut out, phi, lag2);
    out
}

/// [`whiten`] in place (from the last sample back, so every term reads the input).
pub(super) fn whiten_in_place(v: &mut [f64], phi: &[f64]) {
    if phi.is_empty() {
        return;
    }
    for t in (0..v.len()).rev() {
        v[t] = phi
            .iter()
            .enumerate()
            .take(t)
            .fold(v[t], |a, (i, f)| a - f * v[t - 1 - i]);
    }
}

/// A noise-model candidate's sums in one pass over the rows: `Σ x²`, `Σ x·ry` and `Σ q_j·x` for
/// each basis vector `q_j` (`rows[t][j]`). Each sum runs in the order of a dot product of its
/// own (the same bits), and the independent sums share the pass: as separate dot products each
/// waited on its own chain of additions, and they were a tenth of a `detect` on 3000 samples.
fn candidate_sums(
    x: &[f64],
    ry: &[f64],
    rows: &[[f64; MAX_BASIS]],
) -> (f64, f64, [f64; MAX_BASIS]) {
    // the starting value of `f64`'s `Sum`, so that the bits are a dot product's
    let zero = [0.0f64; 0].iter().sum::<f64>();
    let (mut xx, mut xy, mut qx) = (zero, zero, [zero; MAX_BASIS]);
    for ((&v, &y), row) in x.iter().zip(ry).zip(rows) {
        xx += v * v;
        xy += v * y;
        for (acc, &q) in qx.iter_mut().zip(row) {
            *acc += q * v;
        }
    }
    (xx, xy, qx)
}

/// The noise model of the output-error fits: the AR(`order`) model `φ` of the free
/// valve's output-error residual (its best pole of [`POLES`] and whole delay, the gain of the
/// process's sign), by least squares; empty when the record is too short for it.
///
/// Why: what the valve does not explain (a load that wanders, a drift, the controller's answer
/// to either) is most of PV's variance in many loops and has dynamics of its own. Least
/// squares on the raw output weighs that coloured noise where it is strongest, the low
/// frequencies, where a deadband and a lag look alike; through the inverse of its AR model
/// (output and every valve's input alike, as a prediction-error method does) the residuals
/// are about white and a valve's slips count for what they are. The free valve decides the
/// model, so the sticky valves cannot pick a filter in their favour, and the filter is monic,
/// so the residuals stay comparable as likelihoods (the integrating loop's rate filter,
/// `rate::rate_noise_filter`, is the one-pole case). Chosen on the simulated training
/// populations' cross-validated AUC, three draws: without it 0.876 / 0.844 / 0.844, with the
/// order 8 0.896 / 0.870 / 0.870 (order 4 0.894 and 16 0.896 on the first draw;
/// docs/decisions/2026-11-29-one-step-orders.md).
///
/// Its limit: the free valve's residual holds the stiction's effect too, and where that effect
/// is most of it (a band far wider than the noise, a small slip) the model takes up part of
/// it: a valve of S = 32, J = 1 under an open-loop triangle of OP is then fitted best with
/// S = 2 (still `stiction`), where with J = 16 the best band is the grid's top, as it should be
/// (test `an_optimum_on_the_grid_edge_is_no_evidence`).
///
/// `order` is [`noise_order`]'s for the loop's kind; above [`NOISE_ORDER`] it is cut to one
/// coefficient per five rows of the record (a record of 400 samples and its halves keep a
/// noise model), never below [`NOISE_ORDER`].
pub(super) fn noise_model(tg: &Target, u0: &[f64], order: usize) -> Vec<f64> {
    let n = u0.len();
    let start = tg.start;
    let order = if order > NOISE_ORDER {
        order.min(n.saturating_sub(start) / 5).max(NOISE_ORDER)
    } else {
        order
    };
    if order == 0 || n < start + order + 4 * order {
        return Vec::new();
    }
    // the nuisance regressors' orthonormal basis over the rows
    let basis: Vec<Vec<f64>> = tg
        .coef
        .iter()
        .map(|c| {
            (start..n)
                .map(|t| c.iter().zip(&tg.raw).map(|(a, r)| a * r[t]).sum::<f64>())
                .collect()
        })
        .collect();
    // the same basis sample by sample, for the candidates' one pass (0 beyond the basis)
    let mut rows = vec![[0.0; MAX_BASIS]; n - start];
    for (j, q) in basis.iter().enumerate() {
        for (row, &v) in rows.iter_mut().zip(q) {
            row[j] = v;
        }
    }
    let ry = &tg.ry[start..];
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    // Each candidate's residual sum of squares from dot products alone: `ry` is orthogonal to
    // the basis, so `x`'s projection on it changes `Σ x²` only. The residual itself is
    // formed once, for the best candidate.
    let mut best: Option<(f64, f64, usize)> = None;
    let mut lag = vec![0.0; n];
    let lagged = |lag: &mut Vec<f64>, p: f64, d: usize| {
        lag[..=d.min(n - 1)].fill(u0[0]);
        for t in d + 1..n {
            lag[t] = p * lag[t - 1] + (1.0 - p) * u0[t - d];
        }
    };
    for &p in &POLES {
        debug_assert!(start > MAX_DELAY);
        // The lag at delay `d` is the lag at delay 1 shifted by `d − 1` samples (the same
        // start-up values, the same recursion): one pass per pole serves every delay, bit
        // for bit (`start` is past every delay's start-up).
        lagged(&mut lag, p, 1);
        for d in 1..=MAX_DELAY + 1 {
            let x = &lag[start + 1 - d..n + 1 - d];
            let (xx, sxy, qx) = candidate_sums(x, ry, &rows);
            let sxx = xx - qx[..basis.len()].iter().map(|v| v.powi(2)).sum::<f64>();
            if sxx <= 0.0 || tg.sign * sxy < 0.0 {
                continue;
            }
            let rss = tg.yy - sxy * sxy / sxx;
            if best.is_none_or(|b| rss < b.0) {
                best = Some((rss, p, d));
            }
        }
    }
    let r: Vec<f64> = match best {
        None => ry.to_vec(),
        Some((_, p, d)) => {
            lagged(&mut lag, p, d);
            let mut x = lag[start..].to_vec();
            for q in &basis {
                let c = dot(q, &x);
                x.iter_mut().zip(q).for_each(|(v, qq)| *v -= c * qq);
            }
            let k = dot(&x, ry) / dot(&x, &x);
            ry.iter().zip(&x).map(|(y, v)| y - k * v).collect()
        }
    };
    ar_fit(&r, order)
}

/// The AR(`order`) model of `r` by least squares (ridge 1e-9 of the Gram matrix's trace).
fn ar_fit(r: &[f64], order: usize) -> Vec<f64> {
    let mut g = nalgebra::DMatrix::<f64>::zeros(order, order);
    let mut b = nalgebra::DVector::<f64>::zeros(order);
    // one buffer for the lagged values, refilled row by row (no allocation per row)
    let mut past = nalgebra::DVector::<f64>::zeros(order);
    for t in order..r.len() {
        for (i, p) in past.iter_mut().enumerate() {
            *p = r[t - 1 - i];
        }
        g.ger(1.0, &past, &past, 1.0);
        b.axpy(r[t], &past, 1.0);
    }
    let ridge = 1e-9 * g.trace().max(f64::MIN_POSITIVE);
    for i in 0..order {
        g[(i, i)] += ridge;
    }
    g.cholesky()
        .map(|c| c.solve(&b).iter().copied().collect())
        .filter(|phi: &Vec<f64>| phi.iter().all(|v| v.is_finite()))
        .unwrap_or_default()
}
