//! Fit indices of the paper: F_PV (eq. 9), F_MV (eq. 14) and E_G (eq. 13).

use std::f64::consts::PI;

/// F_PV of the paper, eq. (9), with **squared** Euclidean norms, in %:
/// `100 (1 - ‖est - measured‖² / ‖measured - mean(measured)‖²)`.
///
/// 100 is a perfect fit, 0 is as good as the mean, negative is worse. Returns `-inf` when the
/// lengths differ, the input is empty, an estimate is not finite, or `measured` is constant
/// (no variance to explain), so that a grid search can rank the node last.
pub fn fit_pv(measured: &[f64], estimate: &[f64]) -> f64 {
    match pv_sums(measured, estimate) {
        Some((num, den)) => fit_of_sums(num, den),
        None => f64::NEG_INFINITY,
    }
}

/// `(‖est - measured‖², ‖measured - mean(measured)‖²)` as [`fit_pv`] sums them; `None` when
/// the lengths differ or the input is empty.
pub(crate) fn pv_sums(measured: &[f64], estimate: &[f64]) -> Option<(f64, f64)> {
    if measured.len() != estimate.len() || measured.is_empty() {
        return None;
    }
    let mean = measured.iter().sum::<f64>() / measured.len() as f64;
    let mut num = 0.0;
    let mut den = 0.0;
    for (&m, &e) in measured.iter().zip(estimate) {
        num += (e - m) * (e - m);
        den += (m - mean) * (m - mean);
    }
    Some((num, den))
}

/// F_PV from [`pv_sums`]' sums.
pub(crate) fn fit_of_sums(num: f64, den: f64) -> f64 {
    if !num.is_finite() || !(den > 0.0) {
        return f64::NEG_INFINITY;
    }
    100.0 * (1.0 - num / den)
}

/// F_MV of the paper, eq. (14): the same formula as [`fit_pv`] applied to the valve position
/// (measured MV vs the stiction model's MV estimate). The sums run in eight lanes (a grid
/// search computes it at every node when MV is measured), so the last bits may differ from
/// [`fit_pv`]'s sequential sums.
pub fn fit_mv(measured: &[f64], estimate: &[f64]) -> f64 {
    const L: usize = 8;
    if measured.len() != estimate.len() || measured.is_empty() {
        return f64::NEG_INFINITY;
    }
    let lanes = |x: [f64; L]| ((x[0] + x[4]) + (x[2] + x[6])) + ((x[1] + x[5]) + (x[3] + x[7]));
    let (mc, ec) = (measured.chunks_exact(L), estimate.chunks_exact(L));
    let (mr, er) = (mc.remainder(), ec.remainder());
    // pass 1: the sum (for the mean) and the squared errors; pass 2: the squares about the mean
    let (mut sum, mut num) = ([0.0; L], [0.0; L]);
    for (m, e) in mc.clone().zip(ec) {
        for l in 0..L {
            sum[l] += m[l];
            num[l] += (e[l] - m[l]) * (e[l] - m[l]);
        }
    }
    let (mut sum, mut num) = (lanes(sum), lanes(num));
    for (&m, &e) in mr.iter().zip(er) {
        sum += m;
        num += (e - m) * (e - m);
    }
    let mean = sum / measured.len() as f64;
    let mut den = [0.0; L];
    for m in mc {
        for l in 0..L {
            den[l] += (m[l] - mean) * (m[l] - mean);
        }
    }
    let den = lanes(den) + mr.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>();
    if !num.is_finite() || !(den > 0.0) {
        return f64::NEG_INFINITY;
    }
    100.0 * (1.0 - num / den)
}

/// The MATLAB/SIPPY "fit percent" with non-squared norms, `100 (1 - ‖est - y‖ / ‖y - ȳ‖)`.
/// Ranks models like [`fit_pv`]; reported under this distinct name only.
pub fn fit_percent_unsquared(measured: &[f64], estimate: &[f64]) -> f64 {
    let f = fit_pv(measured, estimate);
    if f == f64::NEG_INFINITY {
        return f;
    }
    100.0 * (1.0 - (1.0 - f / 100.0).sqrt())
}

/// Default number of points of the frequency grid used by E_G.
pub const E_G_GRID_POINTS: usize = 2048;

/// `n` equally spaced frequencies over `[0, π]` (both ends included).
///
/// `[0, π]` suffices for eq. (13)'s `max over [0, 2π]`: for real-coefficient models
/// `G(e^{-iω}) = conj G(e^{iω})`, so `|G|` on `[π, 2π]` mirrors `[0, π]`.
pub fn frequency_grid(n: usize) -> Vec<f64> {
    match n {
        0 => Vec::new(),
        1 => vec![0.0],
        _ => (0..n).map(|i| PI * i as f64 / (n - 1) as f64).collect(),
    }
}

/// E_G of the paper, eq. (13), in %: `100 (1 - ‖G_est - G‖∞ / ‖G‖∞)`, with the H∞ norms
/// taken as maxima over the given frequency responses (same grid, `(re, im)` pairs; use
/// [`frequency_grid`]`(`[`E_G_GRID_POINTS`]`)`). Returns `-inf` for mismatched or empty
/// inputs, a zero true model, or a non-finite estimate.
pub fn e_g(true_response: &[(f64, f64)], est_response: &[(f64, f64)]) -> f64 {
    if true_response.len() != est_response.len() || true_response.is_empty() {
        return f64::NEG_INFINITY;
    }
    let mut diff: f64 = 0.0;
    let mut norm: f64 = 0.0;
    for (&(tr, ti), &(er, ei)) in true_response.iter().zip(est_response) {
        let d = (er - tr).hypot(ei - ti);
        if !d.is_finite() {
            return f64::NEG_INFINITY;
        }
        diff = diff.max(d);
        norm = norm.max(tr.hypot(ti));
    }
    if !(norm > 0.0) || !norm.is_finite() {
        return f64::NEG_INFINITY;
    }
    100.0 * (1.0 - diff / norm)
}

/// Frequency response of a transfer function `G(q) = q^-delay (b1 q^-1 + … + bm q^-m) / A(q)`
/// with `a = [1, a1, …]`, `b = [b1, …]` (the paper's eqs. 2-3 convention), at each ω.
/// Use it for the true model in [`e_g`].
pub fn polynomial_frequency_response(
    a: &[f64],
    b: &[f64],
    delay: usize,
    omegas: &[f64],
) -> Vec<(f64, f64)> {
    crate::Structure::Polynomial {
        a: a.to_vec(),
        b: b.to_vec(),
        c: vec![1.0],
        delay,
    }
    .frequency_response(omegas)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn fit_mv_is_fit_pv_up_to_round_off() {
        let m: Vec<f64> = (0..1003)
            .map(|k| 40.0 + (k as f64 * 0.37).sin() * 5.0)
            .collect();
        let e: Vec<f64> = m
            .iter()
            .enumerate()
            .map(|(k, v)| v + ((k % 13) as f64 - 6.0) * 0.1)
            .collect();
        let (a, b) = (fit_mv(&m, &e), fit_pv(&m, &e));
        assert!((a - b).abs() <= 1e-12 * b.abs(), "{a} vs {b}");
        assert_eq!(fit_mv(&[1.0, 1.0], &[1.0, 1.0]), f64::NEG_INFINITY);
        assert_eq!(fit_mv(&m, &[1.0]), f64::NEG_INFINITY);
        assert_eq!(fit_mv(&[2.0; 9], &[f64::NAN; 9]), f64::NEG_INFINITY);
    }

    #[test]
    fn fit_pv_is_squared_r2() {
        let y = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(fit_pv(&y, &y), 100.0);
        let mean = [2.5; 4];
        assert!((fit_pv(&y, &mean)).abs() < 1e-12);
        // est off by 0.5 everywhere: ‖e‖² = 1, ‖y - ȳ‖² = 5 → 80 %
        let est = [1.5, 2.5, 3.5, 4.5];
        assert!((fit_pv(&y, &est) - 80.0).abs() < 1e-12);
        assert!((fit_percent_unsquared(&y, &est) - 100.0 * (1.0 - 0.2f64.sqrt())).abs() < 1e-12);
        assert_eq!(fit_pv(&[1.0, 1.0], &[1.0, 1.0]), f64::NEG_INFINITY);
        assert_eq!(fit_pv(&y, &[1.0]), f64::NEG_INFINITY);
        assert_eq!(fit_pv(&y, &[f64::NAN, 0.0, 0.0, 0.0]), f64::NEG_INFINITY);
    }

    #[test]
    fn e_g_of_exact_and_scaled_models() {
        let w = frequency_grid(E_G_GRID_POINTS);
        assert_eq!(w.len(), 2048);
        assert_eq!(w[0], 0.0);
        assert!((w[2047] - PI).abs() < 1e-15);
        let g = polynomial_frequency_response(&[1.0, -0.5], &[0.5], 0, &w);
        // static gain 1, peak at ω = 0
        assert!((g[0].0 - 1.0).abs() < 1e-12 && g[0].1.abs() < 1e-12);
        assert_eq!(e_g(&g, &g), 100.0);
        let g2 = polynomial_frequency_response(&[1.0, -0.5], &[0.55], 0, &w);
        assert!((e_g(&g, &g2) - 90.0).abs() < 1e-9);
    }
}
