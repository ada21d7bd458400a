//! ARX from normal equations assembled out of sums, for grid searches that identify ARX with
//! one output record and many inputs (spec §5: one identification per stiction node).
//!
//! Per record ([`Arx::output_sums`]): compensated prefix sums of the output and of its lagged
//! products `y(t) y(t-l)`, `l = 0..=n`, so every output block of the normal equations of any
//! window costs O(1). Per input ([`ArxOutputSums::identify_window`]): the input sums and the
//! input-input and input-output products over the window's regression rows (vectorised dot
//! products), the centered Gram matrix (the intercept of [`Centering::OperatingPoint`]),
//! scaled to unit diagonal, and a Cholesky factorization.
//!
//! Normal equations square the condition number, so the solve is only trusted when every
//! column keeps at least 1e-3 of its sum of squares through the centering (otherwise it is
//! numerically constant over the rows: the QR reports it singular) and every pivot of the
//! scaled Cholesky factor satisfies `L_ii² >= GRAM_PIVOT_TOL` = 1e-4 (`L_ii` is the
//! column-equilibrated QR's relative pivot, so this asks for QR pivots >= 1e-2, eight decades
//! above the QR's own rank threshold 1e-10; with 1e-6 the grid-search fits differed from the
//! QR path's by up to 5e-9 relative on noise-free loops). When a squared pivot is below 1e-2
//! one step of iterative refinement follows, with the residual computed from the data, so a
//! residual small against the output does not cost cond² · eps. Otherwise, and in every case
//! the QR path treats specially (constant output, a dropped intercept), it returns `None` and
//! the caller takes [`LinearIdentifier::identify`]. The model built here equals the QR's to
//! round-off (test `gram_fit_matches_the_qr` and the grid-search equivalence tests, where
//! surface fits agree to 1e-9 relative; measured 1e-12 to 8.5e-10 on the paper loop and the
//! plant data).
//!
//! [`LinearIdentifier::identify`]: crate::LinearIdentifier::identify

// Dense small-matrix code (Gram, Cholesky, triangular solves) reads best with index loops.
#![allow(clippy::needless_range_loop)]

use crate::arx::{Arx, Centering};
use crate::{LinearFit, Structure};

/// Smallest accepted squared pivot of the unit-diagonal Cholesky factor (see the module
/// documentation).
pub const GRAM_PIVOT_TOL: f64 = 1e-4;

/// A centered diagonal entry must keep this fraction of its uncentered value (see
/// `identify_window`).
const CENTERING_LOSS: f64 = 1e-3;

/// Iterative refinement runs when the smallest squared pivot is below this (see
/// `identify_window`).
const REFINE_BELOW: f64 = 1e-2;

/// Largest `n + m` handled from sums (the Gram matrix lives on the stack).
const MAX_COLS: usize = 12;

/// What [`Arx::output_sums`] precomputes from the output record.
#[derive(Debug, Clone)]
pub struct ArxOutputSums {
    arx: Arx,
    y: Vec<f64>,
    /// Global mean subtracted before the products.
    shift: f64,
    /// `prefix[l][s] = Σ_{l <= r < s} yc(r) yc(r - l)` (hi and lo parts), `l = 0..=n`; `l = n+1`
    /// holds `Σ_{r < s} yc(r)`.
    prefix: Vec<Vec<(f64, f64)>>,
}

/// Neumaier's compensated running sum: `(hi, lo)` after every term.
fn compensated_prefix(terms: impl Iterator<Item = f64>, out: &mut Vec<(f64, f64)>) {
    let (mut s, mut c) = (0.0f64, 0.0f64);
    out.push((0.0, 0.0));
    for x in terms {
        let t = s + x;
        if s.abs() >= x.abs() {
            c += (s - t) + x;
        } else {
            c += (x - t) + s;
        }
        s = t;
        out.push((s, c));
    }
}

fn range(p: &[(f64, f64)], a: usize, b: usize) -> f64 {
    (p[b].0 - p[a].0) + (p[b].1 - p[a].1)
}

/// Lane-wise dot product of `(x - sx)` and `(y - sy)`.
#[inline]
fn dot_shifted(x: &[f64], sx: f64, y: &[f64], sy: f64) -> f64 {
    const L: usize = 8;
    let mut acc = [0.0; L];
    let (xc, yc) = (x.chunks_exact(L), y.chunks_exact(L));
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for l in 0..L {
            acc[l] += (a[l] - sx) * (b[l] - sy);
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
    for (a, b) in xr.iter().zip(yr) {
        s += (a - sx) * (b - sy);
    }
    s
}

#[inline]
fn sum_shifted(x: &[f64], sx: f64) -> f64 {
    const L: usize = 8;
    let mut acc = [0.0; L];
    let xc = x.chunks_exact(L);
    let xr = xc.remainder();
    for a in xc {
        for l in 0..L {
            acc[l] += a[l] - sx;
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
    for a in xr {
        s += a - sx;
    }
    s
}

impl Arx {
    /// Precompute the output sums for [`ArxOutputSums::identify_window`]; `None` when this
    /// ARX is not handled from sums (`Centering::Mean`, `n + m > 12`) or `y` is not finite.
    pub fn output_sums(&self, y: &[f64]) -> Option<ArxOutputSums> {
        let (n, m, _) = self.orders_tuple();
        if self.centering_mode() != Centering::OperatingPoint || n + m > MAX_COLS {
            return None;
        }
        if y.iter().any(|v| !v.is_finite()) || y.is_empty() {
            return None;
        }
        let shift = crate::la::sum(y) / y.len() as f64;
        let yc: Vec<f64> = y.iter().map(|v| v - shift).collect();
        let mut prefix = Vec::with_capacity(n + 2);
        for l in 0..=n {
            let mut p = Vec::with_capacity(y.len() + 1);
            // prefix[l][s] for s <= l is 0
            let mut head = vec![(0.0, 0.0); l.min(y.len())];
            p.append(&mut head);
            compensated_prefix((l..y.len()).map(|r| yc[r] * yc[r - l]), &mut p);
            prefix.push(p);
        }
        let mut p = Vec::with_capacity(y.len() + 1);
        compensated_prefix(yc.iter().copied(), &mut p);
        prefix.push(p);
        Some(ArxOutputSums {
            arx: *self,
            y: y.to_vec(),
            shift,
            prefix,
        })
    }
}

impl ArxOutputSums {
    /// The output record.
    pub fn y(&self) -> &[f64] {
        &self.y
    }

    /// `identify(&u[from..to], &y[from..to])` from sums, where `u` is an input over the whole
    /// record (same length as `y`). `None` when the caller must take the QR path instead:
    /// the Gram matrix is poorly conditioned (a pivot below [`GRAM_PIVOT_TOL`]), the window is
    /// too short, the output is constant there, the input is not finite, or the QR path would
    /// drop the intercept.
    pub fn identify_window(&self, u: &[f64], from: usize, to: usize) -> Option<LinearFit> {
        let (n, m, delay) = self.arx.orders_tuple();
        let y = &self.y;
        if u.len() != y.len() || to > y.len() || from >= to {
            return None;
        }
        let n0 = n.max(m + delay);
        let len = to - from;
        if len < n0 + n + m + 1 {
            return None;
        }
        let (uw, yw) = (&u[from..to], &y[from..to]);
        if uw.iter().any(|v| !v.is_finite()) {
            return None;
        }
        if crate::error::numerically_constant(yw) || crate::error::numerically_constant(uw) {
            return None;
        }
        let d = n + m;
        let (r0, r1) = (from + n0, to);
        let rows = (r1 - r0) as f64;
        let u_mean = crate::la::sum(uw) / len as f64;
        let y_mean = crate::la::sum(yw) / len as f64;
        // column sums and centered products; column 0 is y(t), columns 1..=n are y(t-i),
        // n+1..=n+m are u(t-delay-j). y sums are of yc = y - shift, u sums of u - u_mean.
        let mut sums = [0.0; MAX_COLS + 1];
        let mut g = [[0.0; MAX_COLS + 1]; MAX_COLS + 1];
        let yp = &self.prefix[n + 1];
        for i in 0..=n {
            sums[i] = range(yp, r0 - i, r1 - i);
        }
        for i in 0..=n {
            for i2 in i..=n {
                let l = i2 - i;
                g[i][i2] = range(&self.prefix[l], r0 - i, r1 - i);
            }
        }
        let yc_slice = |i: usize| &y[r0 - i..r1 - i];
        let u_slice = |j: usize| &u[r0 - delay - j..r1 - delay - j];
        for j in 1..=m {
            sums[n + j] = sum_shifted(u_slice(j), u_mean);
        }
        for j in 1..=m {
            for j2 in j..=m {
                g[n + j][n + j2] = dot_shifted(u_slice(j), u_mean, u_slice(j2), u_mean);
            }
            for i in 0..=n {
                g[i][n + j] = dot_shifted(yc_slice(i), self.shift, u_slice(j), u_mean);
            }
        }
        // center (the intercept) and symmetrise; a diagonal that loses more than three digits
        // to the centering (a column constant over the rows, or far from its shift) is left
        // to the QR, which reports what it makes of it
        for a in 0..=d {
            let raw = g[a][a];
            let c = raw - sums[a] * sums[a] / rows;
            if !(c > CENTERING_LOSS * raw) {
                return None;
            }
        }
        for a in 0..=d {
            for b in a..=d {
                let c = g[a][b] - sums[a] * sums[b] / rows;
                g[a][b] = c;
                g[b][a] = c;
            }
        }
        // regressors x_k = -y(t-k) (k = 1..=n), u(t-delay-j): flip the signs of the y lags
        let sign = |a: usize| if (1..=n).contains(&a) { -1.0 } else { 1.0 };
        let mut scale = [0.0; MAX_COLS];
        for k in 0..d {
            let c = g[k + 1][k + 1];
            if !(c > 0.0 && c.is_finite()) {
                return None;
            }
            scale[k] = 1.0 / c.sqrt();
        }
        // A = D X'X D (unit diagonal), rhs = D X'y
        let mut a = [[0.0; MAX_COLS]; MAX_COLS];
        let mut rhs = [0.0; MAX_COLS];
        for p in 0..d {
            for q in 0..d {
                a[p][q] = sign(p + 1) * sign(q + 1) * g[p + 1][q + 1] * scale[p] * scale[q];
            }
            rhs[p] = sign(p + 1) * g[p + 1][0] * scale[p];
        }
        // Cholesky A = L L', in place (lower triangle)
        let mut min_pivot = f64::INFINITY;
        for j in 0..d {
            let mut v = a[j][j];
            for k in 0..j {
                v -= a[j][k] * a[j][k];
            }
            if !(v >= GRAM_PIVOT_TOL) {
                return None;
            }
            min_pivot = min_pivot.min(v);
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
        // L z = rhs, L' x = z
        let mut z = [0.0; MAX_COLS];
        for i in 0..d {
            let mut v = rhs[i];
            for k in 0..i {
                v -= a[i][k] * z[k];
            }
            z[i] = v / a[i][i];
        }
        let mut x = [0.0; MAX_COLS];
        for i in (0..d).rev() {
            let mut v = z[i];
            for k in i + 1..d {
                v -= a[k][i] * x[k];
            }
            x[i] = v / a[i][i];
        }
        for k in 0..d {
            x[k] *= scale[k];
        }
        // one step of iterative refinement with the residual computed from the data (not from
        // the sums): the solve then has the accuracy of the QR's even when the residual is
        // small against the output (noise-free data), where plain normal equations lose
        // cond² · eps
        if min_pivot < REFINE_BELOW {
            self.refine(&mut x, &a, &scale, &sums, u, u_mean, (r0, r1), rows);
        }
        // residual sum of squares and the output's about its mean over the rows
        let y_ss = g[0][0];
        let mut explained = 0.0;
        for k in 0..d {
            explained += x[k] * sign(k + 1) * g[k + 1][0];
        }
        let rss = (y_ss - explained).max(0.0);
        // intercept, as the QR path folds it (`arx.rs`): the column means over the rows, in
        // the QR path's coordinates (y centered by y_mean, u by u_mean)
        let col_mean = |a: usize| {
            if a <= n {
                sums[a] / rows + self.shift - y_mean
            } else {
                sums[a] / rows
            }
        };
        let c0 = col_mean(0)
            - (0..d)
                .map(|k| x[k] * sign(k + 1) * col_mean(k + 1))
                .sum::<f64>();
        let mut a_poly = Vec::with_capacity(n + 1);
        a_poly.push(1.0);
        a_poly.extend_from_slice(&x[..n]);
        let a1: f64 = a_poly.iter().sum();
        let b1: f64 = x[n..d].iter().sum();
        let (mut um, mut ym) = (u_mean, y_mean);
        if a1.abs() >= b1.abs() && a1 != 0.0 {
            ym += c0 / a1;
        } else if b1 != 0.0 {
            um -= c0 / b1;
        } else {
            return None;
        }
        if !rss.is_finite() || x[..d].iter().any(|v| !v.is_finite()) {
            return None;
        }
        let structure = Structure::Polynomial {
            a: a_poly,
            b: x[n..d].to_vec(),
            c: vec![1.0],
            delay,
        };
        Some(LinearFit::with_diagnostics(
            "arx", structure, um, ym, len, n0, rss, y_ss,
        ))
    }
}

impl ArxOutputSums {
    /// One step of iterative refinement of `x` (see `identify_window`).
    #[allow(clippy::too_many_arguments)]
    fn refine(
        &self,
        x: &mut [f64; MAX_COLS],
        a: &[[f64; MAX_COLS]; MAX_COLS],
        scale: &[f64; MAX_COLS],
        sums: &[f64; MAX_COLS + 1],
        u: &[f64],
        u_mean: f64,
        (r0, r1): (usize, usize),
        rows: f64,
    ) {
        let (n, m, delay) = self.arx.orders_tuple();
        let d = n + m;
        let y = &self.y;
        let sign = |a: usize| if (1..=n).contains(&a) { -1.0 } else { 1.0 };
        let yc_slice = |i: usize| &y[r0 - i..r1 - i];
        let u_slice = |j: usize| &u[r0 - delay - j..r1 - delay - j];
        let nrows = r1 - r0;
        let mut gr = [0.0; MAX_COLS];
        let mut r_sum = 0.0;
        crate::la::with_buffer(nrows, |res| {
            // res = yc(t) - Σ x_k col_k(t), columns in the shifted coordinates of the sums
            res.copy_from_slice(&y[r0..r1]);
            res.iter_mut().for_each(|v| *v -= self.shift);
            for i in 1..=n {
                let xi = x[i - 1];
                for (v, &yy) in res.iter_mut().zip(yc_slice(i)) {
                    *v += xi * (yy - self.shift);
                }
            }
            for j in 1..=m {
                let xj = x[n + j - 1];
                for (v, &uu) in res.iter_mut().zip(u_slice(j)) {
                    *v -= xj * (uu - u_mean);
                }
            }
            r_sum = sum_shifted(res, 0.0);
            for i in 1..=n {
                gr[i - 1] = -dot_shifted(yc_slice(i), self.shift, res, 0.0);
            }
            for j in 1..=m {
                gr[n + j - 1] = dot_shifted(u_slice(j), u_mean, res, 0.0);
            }
        });
        let mut rhs2 = [0.0; MAX_COLS];
        for k in 0..d {
            // centered: the intercept absorbs the residual's mean
            rhs2[k] = (gr[k] - sign(k + 1) * sums[k + 1] * r_sum / rows) * scale[k];
        }
        let mut z2 = [0.0; MAX_COLS];
        for i in 0..d {
            let mut v = rhs2[i];
            for k in 0..i {
                v -= a[i][k] * z2[k];
            }
            z2[i] = v / a[i][i];
        }
        let mut dx = [0.0; MAX_COLS];
        for i in (0..d).rev() {
            let mut v = z2[i];
            for k in i + 1..d {
                v -= a[k][i] * dx[k];
            }
            dx[i] = v / a[i][i];
        }
        for k in 0..d {
            x[k] += dx[k] * scale[k];
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::LinearIdentifier;

    /// The shared valve-like record with output noise 0.3.
    fn data(len: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
        crate::test_data::valve_loop(len, seed, 0.3)
    }

    #[test]
    fn gram_fit_matches_the_qr() {
        for seed in [1, 2, 3] {
            let (u, y) = data(3000, seed);
            for (n, m, delay) in [(2, 2, 0), (1, 3, 2), (4, 1, 0), (3, 3, 5)] {
                let arx = Arx::params().n(n).m(m).delay(delay).check().unwrap();
                let sums = arx.output_sums(&y).unwrap();
                for (from, to) in [(0, 2000), (137, 2000), (900, 1500)] {
                    let qr = arx.identify(&u[from..to], &y[from..to]).unwrap();
                    let gram = sums.identify_window(&u, from, to).unwrap();
                    let (
                        Structure::Polynomial { a: a1, b: b1, .. },
                        Structure::Polynomial { a: a2, b: b2, .. },
                    ) = (qr.structure(), gram.structure())
                    else {
                        panic!()
                    };
                    let big = a1.iter().chain(b1).fold(0.0f64, |m, v| m.max(v.abs()));
                    for (p, q) in a1.iter().chain(b1).zip(a2.iter().chain(b2)) {
                        assert!((p - q).abs() <= 1e-9 * big, "{n} {m} {delay}: {p} vs {q}");
                    }
                    let (m1, m2) = (qr.means(), gram.means());
                    assert!(
                        (m1.0 - m2.0).abs() < 1e-9 * m1.0.abs().max(1.0),
                        "{m1:?} {m2:?}"
                    );
                    assert!(
                        (m1.1 - m2.1).abs() < 1e-9 * m1.1.abs().max(1.0),
                        "{m1:?} {m2:?}"
                    );
                    let (f1, f2) = (qr.info().fit_pv, gram.info().fit_pv);
                    assert!((f1 - f2).abs() < 1e-9 * f1.abs(), "{f1} vs {f2}");
                }
            }
        }
    }

    #[test]
    fn poorly_conditioned_windows_fall_back() {
        let (u, y) = data(600, 4);
        let arx = Arx::params().n(2).m(2).check().unwrap();
        let sums = arx.output_sums(&y).unwrap();
        // a ramp: u(t-1) and u(t-2) collinear after centering, up to a 1e-6 wiggle
        let v: Vec<f64> = (0..u.len())
            .map(|k| k as f64 + 1e-6 * (k as f64).sin())
            .collect();
        assert!(sums.identify_window(&v, 0, 600).is_none());
        assert!(sums.identify_window(&u, 0, 600).is_some());
        // Centering::Mean is not handled from sums
        let mean = Arx::params().centering(Centering::Mean).check().unwrap();
        assert!(mean.output_sums(&y).is_none());
    }
}
