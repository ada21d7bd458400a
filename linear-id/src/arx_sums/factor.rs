//! The small dense algebra of ARX from sums: the Cholesky factor of the scaled Gram matrix,
//! its solves, a bound on its condition number, and the refined RSS.

// Dense small-matrix code reads best with index loops.
#![allow(clippy::needless_range_loop)]

use super::{ResidualProducts, GRAM_PIVOT_TOL, MAX_COLS};

/// Cholesky `A = L L'` of the leading `d × d` block, in place (lower triangle); `None` when a
/// pivot is below [`GRAM_PIVOT_TOL`].
pub(crate) fn cholesky_in_place(a: &mut [[f64; MAX_COLS]; MAX_COLS], d: usize) -> Option<()> {
    for j in 0..d {
        let mut v = a[j][j];
        for k in 0..j {
            v -= a[j][k] * a[j][k];
        }
        if !(v >= GRAM_PIVOT_TOL) {
            return None;
        }
        let ljj = v.sqrt();
        a[j][j] = ljj;
        for i in j + 1..d {
            let mut w = a[i][j];
            for k in 0..j {
                w -= a[i][k] * a[j][k];
            }
            a[i][j] = w / ljj;
        }
    }
    Some(())
}

/// Solve `L L' x = rhs` (`L` the lower triangle of `l`, order `d`).
pub(crate) fn cholesky_solve(
    l: &[[f64; MAX_COLS]; MAX_COLS],
    rhs: &[f64; MAX_COLS],
    d: usize,
) -> [f64; MAX_COLS] {
    backward_solve(l, &forward_solve(l, rhs, d), d)
}

/// Solve `L z = rhs`.
pub(super) fn forward_solve(
    l: &[[f64; MAX_COLS]; MAX_COLS],
    rhs: &[f64; MAX_COLS],
    d: usize,
) -> [f64; MAX_COLS] {
    let mut z = [0.0; MAX_COLS];
    for i in 0..d {
        let mut v = rhs[i];
        for k in 0..i {
            v -= l[i][k] * z[k];
        }
        z[i] = v / l[i][i];
    }
    z
}

/// Solve `L' x = z`.
pub(super) fn backward_solve(
    l: &[[f64; MAX_COLS]; MAX_COLS],
    z: &[f64; MAX_COLS],
    d: usize,
) -> [f64; MAX_COLS] {
    let mut x = [0.0; MAX_COLS];
    for i in (0..d).rev() {
        let mut v = z[i];
        for k in i + 1..d {
            v -= l[k][i] * x[k];
        }
        x[i] = v / l[i][i];
    }
    x
}

/// `d · trace(A⁻¹)` for `A = L L'` (`L` the lower triangle of `l`): `trace(A⁻¹) = ‖L⁻¹‖²_F`
/// bounds `1 / λ_min`, and a unit-diagonal `A` has `λ_max <= d`, so this bounds `A`'s
/// condition number.
pub(super) fn condition_bound(l: &[[f64; MAX_COLS]; MAX_COLS], d: usize) -> f64 {
    let mut inv = [[0.0f64; MAX_COLS]; MAX_COLS];
    let mut trace = 0.0;
    for j in 0..d {
        inv[j][j] = 1.0 / l[j][j];
        trace += inv[j][j] * inv[j][j];
        for i in j + 1..d {
            let v: f64 = (j..i).map(|k| l[i][k] * inv[k][j]).sum();
            inv[i][j] = -v / l[i][i];
            trace += inv[i][j] * inv[i][j];
        }
    }
    d as f64 * trace
}

/// The residual sum of squares over the rows after the refinement step `dx` (scaled
/// coordinates), from the residual before it: with the centered residual `r_c` and the
/// centered, scaled regressors `Z` (`Z'Z = A = L L'`, `Z' r_c = rhs2`),
/// `‖r_c - Z dx‖² = ‖r_c‖² - 2 dx'rhs2 + ‖L' dx‖²`, and `‖r_c‖² = Σ r² - (Σ r)² / rows`.
pub(super) fn refined_sse(
    res: &ResidualProducts,
    rows: f64,
    l: &[[f64; MAX_COLS]; MAX_COLS],
    dx: &[f64; MAX_COLS],
    rhs2: &[f64; MAX_COLS],
    d: usize,
) -> f64 {
    let mut sse = res.sq - res.sum * res.sum / rows;
    for i in 0..d {
        let ltdx: f64 = (i..d).map(|k| l[k][i] * dx[k]).sum();
        sse += ltdx * ltdx - 2.0 * dx[i] * rhs2[i];
    }
    sse
}
