//! The Hammerstein test's one-step ARX fits: the output's side of the normal equations once
//! per record, the cross-correlations of the output with each valve's input (alone, or four
//! valves side by side in the output-error lanes' pass), and the solve for every delay.
//!
//! The model is `y(t) = Σ_{a=1}^{NA} a_a y(t−a) + Σ_{j=0}^{NB−1} b_j u(t−1−d−j) + c`, `d` from
//! 0 to `MAX_DELAY`. Its autoregressive part is the noise model: what the valve does not
//! explain (a load that wanders, an external oscillation, the lag of a slow process) has
//! dynamics of its own, and [`NA`] past outputs whiten it so that the valve's slips stand out
//! of the one-step innovations. The orders were chosen on the simulated training populations'
//! cross-validated AUC, three draws (`cargo xtask detect-calibrate --train-seed 1|2|3`;
//! docs/decisions/2026-11-29-one-step-orders.md): two outputs and two inputs gave 0.869 /
//! 0.828 / 0.828, eight and four 0.876 / 0.844 / 0.844.

// The sums index several lagged arrays at once: index loops say what is summed.
#![allow(clippy::needless_range_loop)]

use super::MAX_DELAY;
use nalgebra::{SMatrix, SVector};

/// Past outputs of the one-step model.
pub(super) const NA: usize = 8;
/// Past inputs of the one-step model (from `t−1−d` on).
pub(super) const NB: usize = 4;
/// Regressors: [`NA`] outputs, [`NB`] inputs, a constant.
pub(super) const P: usize = NA + NB + 1;
/// The largest input lag of any delay.
const KMAX: usize = NB + MAX_DELAY;
/// Cross-correlation lags `m = k − b` of an input lag `k` in `1..=KMAX` against an output lag
/// `b` in `0..=NA`: from `1 − NA` to `KMAX`, index `m + NA − 1`.
pub(super) const NM: usize = NA + KMAX;
/// The first row of the one-step fits: every lag is inside the record.
pub(super) const ARX_START: usize = if NA > KMAX { NA } else { KMAX };

/// The one-step residual `yᵀy − bᵀG⁻¹b` of the normal equations `G`, `b` (a ridge of 1e-10
/// of G's trace: the projection without a rank decision).
pub(super) fn arx_solve(mut gram: SMatrix<f64, P, P>, b: SVector<f64, P>, yy: f64) -> f64 {
    let ridge = 1e-10 * gram.trace().max(f64::MIN_POSITIVE);
    gram += SMatrix::<f64, P, P>::identity() * ridge;
    // RSS = yᵀy − zᵀz with L z = b (L the Cholesky factor): the projection of y on the
    // regressors.
    let Some(chol) = gram.cholesky() else {
        return yy;
    };
    let Some(z) = chol.l().solve_lower_triangular(&b) else {
        return yy;
    };
    (yy - z.norm_squared()).max(0.0)
}

/// The output's side of the one-step ARX normal equations (the same for every valve).
pub(super) struct ArxTarget<'a> {
    y: &'a [f64],
    /// The first row (at least [`ARX_START`]).
    start: usize,
    /// `Σ y(t−a)·y(t−b)` for `a, b` in `0..=NA`, over the rows.
    yy: [[f64; NA + 1]; NA + 1],
    /// `Σ y(t−a)` for `a` in `0..=NA`, over the rows.
    sum: [f64; NA + 1],
}

impl<'a> ArxTarget<'a> {
    /// The output `y` with rows from `start` on (moved to [`ARX_START`] when earlier).
    pub(super) fn new(y: &'a [f64], start: usize) -> ArxTarget<'a> {
        let start = start.max(ARX_START);
        let mut yy = [[0.0; NA + 1]; NA + 1];
        let mut sum = [0.0; NA + 1];
        for t in start..y.len() {
            for a in 0..=NA {
                let va = y[t - a];
                sum[a] += va;
                for b in a..=NA {
                    yy[a][b] += va * y[t - b];
                }
            }
        }
        for a in 0..=NA {
            for b in 0..a {
                yy[a][b] = yy[b][a];
            }
        }
        ArxTarget { y, start, yy, sum }
    }

    /// The rows of the one-step fits.
    pub(super) fn rows(&self) -> usize {
        self.y.len().saturating_sub(self.start)
    }
}

/// The best one-step ARX residual over the delays for input `u`.
pub(super) fn best_arx(tg: &ArxTarget<'_>, u: &[f64]) -> f64 {
    arx_all(tg, u).into_iter().fold(f64::INFINITY, f64::min)
}

/// The one-step ARX residual of every delay `0..=MAX_DELAY`.
pub(super) fn arx_all(tg: &ArxTarget<'_>, u: &[f64]) -> [f64; MAX_DELAY + 1] {
    let lanes: Vec<[f64; 1]> = u.iter().map(|&v| [v]).collect();
    let [f] = cross_lanes::<1>(tg, &lanes);
    arx_from_products(tg, u, &f)
}

/// The cross-correlations `F[m + NA − 1] = Σ_{s ≥ start − NA} y(s)·u(s − m)` (an input
/// outside the record counts 0) of `L` inputs side by side (`u[t][l]`: input `l` at `t`),
/// lane `l` of `out[l]`; [`arx_all`] takes them for one input, so both are the same
/// operations in the same order, the same bits. Inlined into the dispatched pass of
/// [`super::best_oe_many`].
#[inline(always)]
pub(super) fn cross_lanes<const L: usize>(tg: &ArxTarget<'_>, u: &[[f64; L]]) -> [[f64; NM]; L] {
    let (y, start) = (tg.y, tg.start);
    let n = y.len().min(u.len());
    let lo = start - NA;
    let mut f = [[0.0; L]; NM];
    // The input index of lag m = i + 1 − NA at row s is s − m = s + NA − 1 − i. The rows at
    // the ends, where some lags fall outside the record, one by one; the middle rows in two
    // halves of the lags (each half's sums of L lanes stay in registers).
    let (mid_lo, mid_hi) = (lo.max(KMAX), n.saturating_sub(NA - 1));
    let at =
        |s: usize, i: usize| -> Option<usize> { (s + NA - 1).checked_sub(i).filter(|&k| k < n) };
    for s in (lo..mid_lo.min(n)).chain(mid_hi.max(mid_lo)..n) {
        for (i, fi) in f.iter_mut().enumerate() {
            if let Some(k) = at(s, i) {
                for l in 0..L {
                    fi[l] += y[s] * u[k][l];
                }
            }
        }
    }
    for half in [(0, NM / 2), (NM / 2, NM)] {
        let mut acc = [[0.0; L]; NM];
        for s in mid_lo..mid_hi {
            let ys = y[s];
            let w = &u[s + NA - NM..s + NA];
            for i in half.0..half.1 {
                let ui = &w[NM - 1 - i];
                for l in 0..L {
                    acc[i][l] += ys * ui[l];
                }
            }
        }
        for i in half.0..half.1 {
            for l in 0..L {
                f[i][l] += acc[i][l];
            }
        }
    }
    std::array::from_fn(|l| std::array::from_fn(|i| f[i][l]))
}

/// [`arx_all`] from the cross-correlations `f` of the output with the input ([`cross_lanes`]).
pub(super) fn arx_from_products(
    tg: &ArxTarget<'_>,
    u: &[f64],
    f: &[f64; NM],
) -> [f64; MAX_DELAY + 1] {
    let (y, start) = (tg.y, tg.start);
    let n = y.len().min(u.len());
    let rows = n.saturating_sub(start) as f64;
    let uat = |k: isize| -> f64 {
        if k >= 0 && (k as usize) < n {
            u[k as usize]
        } else {
            0.0
        }
    };
    // c(b, k) = Σ_{t ≥ start} y(t−b)·u(t−k): the cross-correlation at m = k − b less the rows
    // before `start − b` and after `n − 1 − b`
    let lo = start - NA;
    let c = |b: usize, k: usize| -> f64 {
        let m = k as isize - b as isize;
        let mut v = f[(m + NA as isize - 1) as usize];
        for s in lo..start - b {
            v -= y[s] * uat(s as isize - m);
        }
        for s in n - b..n {
            v -= y[s] * uat(s as isize - m);
        }
        v
    };
    // Σ_τ u(τ)·u(τ−j) over the record, j < NB, and Σ u
    let mut auto = [0.0; NB];
    let mut total = 0.0;
    for tau in 0..n {
        total += u[tau];
        for (j, a) in auto.iter_mut().enumerate() {
            if tau >= j {
                *a += u[tau] * u[tau - j];
            }
        }
    }
    // Σ_{t ≥ start} u(t−k)·u(t−k−j): τ = t − k from start − k to n − 1 − k
    let uu = |k: usize, j: usize| -> f64 {
        auto[j]
            - (j..start - k).map(|t| u[t] * u[t - j]).sum::<f64>()
            - (n - k..n).map(|t| u[t] * u[t - j]).sum::<f64>()
    };
    let usum = |k: usize| -> f64 {
        total - (0..start - k).map(|t| u[t]).sum::<f64>() - (n - k..n).map(|t| u[t]).sum::<f64>()
    };
    // the output lags' block, the same for every delay
    let mut gram0 = SMatrix::<f64, P, P>::zeros();
    let mut b0 = SVector::<f64, P>::zeros();
    for a in 0..NA {
        for b in 0..NA {
            gram0[(a, b)] = tg.yy[a + 1][b + 1];
        }
        gram0[(a, P - 1)] = tg.sum[a + 1];
        gram0[(P - 1, a)] = tg.sum[a + 1];
        b0[a] = tg.yy[0][a + 1];
    }
    gram0[(P - 1, P - 1)] = rows;
    b0[P - 1] = tg.sum[0];
    let mut out = [0.0; MAX_DELAY + 1];
    for (d, o) in out.iter_mut().enumerate() {
        let (mut gram, mut b) = (gram0, b0);
        for j in 0..NB {
            let k = 1 + d + j;
            let r = NA + j;
            for a in 0..NA {
                let v = c(a + 1, k);
                gram[(a, r)] = v;
                gram[(r, a)] = v;
            }
            for i in 0..=j {
                let v = uu(1 + d + i, j - i);
                gram[(NA + i, r)] = v;
                gram[(r, NA + i)] = v;
            }
            let s = usum(k);
            gram[(r, P - 1)] = s;
            gram[(P - 1, r)] = s;
            b[r] = c(0, k);
        }
        *o = arx_solve(gram, b, tg.yy[0][0]);
    }
    out
}
