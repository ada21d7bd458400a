//! The Hammerstein test's one-step ARX fits: the output's side of the normal equations once
//! per record, the products with each valve's input (alone, or four valves side by side in the
//! output-error lanes' pass), and the solve for every delay.

use super::MAX_DELAY;
use nalgebra::{SMatrix, SVector};

/// Regressors: two outputs, two inputs, a constant.
pub(super) const P: usize = 5;

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
    start: usize,
    /// `Σ y(t−a)·y(t−b)` for `a, b` in 0..=2, over the rows.
    yy: [[f64; 3]; 3],
    /// `Σ y(t−1)`, `Σ y(t−2)`, `Σ y(t)`.
    sum: [f64; 3],
}

impl<'a> ArxTarget<'a> {
    pub(super) fn new(y: &'a [f64], start: usize) -> ArxTarget<'a> {
        let mut yy = [[0.0; 3]; 3];
        let mut sum = [0.0; 3];
        for t in start..y.len() {
            let v = [y[t], y[t - 1], y[t - 2]];
            for a in 0..3 {
                sum[a] += v[a];
                for b in 0..3 {
                    yy[a][b] += v[a] * v[b];
                }
            }
        }
        ArxTarget {
            y,
            start,
            yy,
            sum: [sum[1], sum[2], sum[0]],
        }
    }
}

/// Input lags the ARX fits use: `u(t−1−d)` and `u(t−2−d)` for `d` in `0..=MAX_DELAY`.
pub(super) const ARX_LAGS: usize = MAX_DELAY + 2;

/// The best one-step ARX residual over the delays for input `u` (the tests' `arx_rss` for
/// every delay, from one pass: the products of the output's lags with the input's lags 1 to
/// `MAX_DELAY + 2`, and the input's lagged sums, squares and neighbour products).
pub(super) fn best_arx(tg: &ArxTarget<'_>, u: &[f64]) -> f64 {
    arx_all(tg, u).into_iter().fold(f64::INFINITY, f64::min)
}

/// The one-step ARX residual of every delay `0..=MAX_DELAY`.
pub(super) fn arx_all(tg: &ArxTarget<'_>, u: &[f64]) -> [f64; MAX_DELAY + 1] {
    let (y, start) = (tg.y, tg.start);
    let n = y.len();
    // c[b][k−1] = Σ y(t−b)·u(t−k)
    let mut c = [[0.0; ARX_LAGS]; 3];
    for t in start..n {
        let (y0, y1, y2) = (y[t], y[t - 1], y[t - 2]);
        for k in 1..=ARX_LAGS {
            let uk = u[t - k];
            c[0][k - 1] += y0 * uk;
            c[1][k - 1] += y1 * uk;
            c[2][k - 1] += y2 * uk;
        }
    }
    arx_from_products(tg, u, &c)
}

/// [`arx_all`]'s products `c[b][k−1] = Σ y(t−b)·u(t−k)` of `L` inputs side by side
/// (`u[t][l]`: input `l` at `t`), lane `l` of `out[l]`: each sum the same operations in the
/// same order as [`arx_all`]'s, so the same bits. Inlined into the dispatched pass of
/// [`super::best_oe_many`].
#[inline(always)]
pub(super) fn arx_products_lanes<const L: usize>(
    tg: &ArxTarget<'_>,
    u: &[[f64; L]],
) -> [[[f64; ARX_LAGS]; 3]; L] {
    let (y, start) = (tg.y, tg.start);
    let n = y.len().min(u.len());
    let mut c = [[[0.0; L]; ARX_LAGS]; 3];
    // one output lag at a time: five sums of four lanes stay in registers
    for (b, cb) in c.iter_mut().enumerate() {
        for t in start.max(ARX_LAGS)..n {
            let yb = y[t - b];
            let w = &u[t - ARX_LAGS..t];
            for k in 1..=ARX_LAGS {
                let uk = &w[ARX_LAGS - k];
                for l in 0..L {
                    cb[k - 1][l] += yb * uk[l];
                }
            }
        }
    }
    std::array::from_fn(|l| c.map(|cb| cb.map(|v| v[l])))
}

/// [`arx_all`] from the products `c` of the output's lags with the input's lags.
pub(super) fn arx_from_products(
    tg: &ArxTarget<'_>,
    u: &[f64],
    c: &[[f64; ARX_LAGS]; 3],
) -> [f64; MAX_DELAY + 1] {
    let (y, start) = (tg.y, tg.start);
    let n = y.len();
    // Over τ = t − k in start−k ..= n−1−k: the full sums less the ends.
    let (mut s1, mut s2, mut s12) = (0.0, 0.0, 0.0);
    for tau in 0..n {
        s1 += u[tau];
        s2 += u[tau] * u[tau];
        if tau > 0 {
            s12 += u[tau] * u[tau - 1];
        }
    }
    let window = |total: f64, k: usize, f: &dyn Fn(usize) -> f64| -> f64 {
        total - (0..start - k).map(f).sum::<f64>() - (n - k..n).map(f).sum::<f64>()
    };
    let rows = (n - start) as f64;
    let mut out = [0.0; MAX_DELAY + 1];
    for (d, o) in out.iter_mut().enumerate() {
        let (k1, k2) = (1 + d, 2 + d);
        let u1 = window(s1, k1, &|t| u[t]);
        let u2 = window(s1, k2, &|t| u[t]);
        let u11 = window(s2, k1, &|t| u[t] * u[t]);
        let u22 = window(s2, k2, &|t| u[t] * u[t]);
        // Σ u(t−1−d)·u(t−2−d): τ = t−1−d, u(τ)·u(τ−1)
        let u12 = s12
            - (1..start - k1).map(|t| u[t] * u[t - 1]).sum::<f64>()
            - (n - k1..n).map(|t| u[t] * u[t - 1]).sum::<f64>();
        let gram = SMatrix::<f64, P, P>::from_row_slice(&[
            tg.yy[1][1],
            tg.yy[1][2],
            c[1][k1 - 1],
            c[1][k2 - 1],
            tg.sum[0],
            tg.yy[2][1],
            tg.yy[2][2],
            c[2][k1 - 1],
            c[2][k2 - 1],
            tg.sum[1],
            c[1][k1 - 1],
            c[2][k1 - 1],
            u11,
            u12,
            u1,
            c[1][k2 - 1],
            c[2][k2 - 1],
            u12,
            u22,
            u2,
            tg.sum[0],
            tg.sum[1],
            u1,
            u2,
            rows,
        ]);
        let b = SVector::<f64, P>::from([
            tg.yy[0][1],
            tg.yy[0][2],
            c[0][k1 - 1],
            c[0][k2 - 1],
            tg.sum[2],
        ]);
        *o = arx_solve(gram, b, tg.yy[0][0]);
    }
    out
}
