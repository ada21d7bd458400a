//! Dense linear algebra through faer, always sequential (`Par::Seq`): the grid search
//! parallelises over nodes, and results must not depend on the thread count.
//!
//! Nothing here is public API: faer types never appear in public signatures.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::{householder, matmul, qr, svd, triangular_solve};
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par};

const PAR: Par = Par::Seq;

/// Relative pivot below which a column-equilibrated QR is declared rank deficient.
pub(crate) const RANK_TOL: f64 = 1e-10;

/// A Householder QR factorisation `A = Q R` of a tall matrix (faer, unpivoted, blocked).
pub(crate) struct Qr {
    /// Householder basis below the diagonal, R on and above.
    qr: Mat<f64>,
    coeff: Mat<f64>,
}

impl Qr {
    /// Factor `a` (consumed; `nrows >= ncols`).
    pub(crate) fn new(mut a: Mat<f64>) -> Qr {
        let (m, n) = a.shape();
        let bs = qr::no_pivoting::factor::recommended_block_size::<f64>(m, n).max(1);
        let mut coeff = Mat::<f64>::zeros(bs, m.min(n));
        let mut buf = MemBuffer::new(qr::no_pivoting::factor::qr_in_place_scratch::<f64>(
            m,
            n,
            bs,
            PAR,
            Default::default(),
        ));
        qr::no_pivoting::factor::qr_in_place(
            a.as_mut(),
            coeff.as_mut(),
            PAR,
            MemStack::new(&mut buf),
            Default::default(),
        );
        Qr { qr: a, coeff }
    }

    /// `b := Qᵀ b` (b has `nrows` rows).
    pub(crate) fn apply_qt(&self, b: MatMut<'_, f64>) {
        let k = b.ncols();
        let bs = self.coeff.nrows();
        let mut buf = MemBuffer::new(
            householder::apply_block_householder_sequence_transpose_on_the_left_in_place_scratch::<
                f64,
            >(self.qr.nrows(), bs, k),
        );
        householder::apply_block_householder_sequence_transpose_on_the_left_in_place_with_conj(
            self.qr.as_ref(),
            self.coeff.as_ref(),
            Conj::No,
            b,
            PAR,
            MemStack::new(&mut buf),
        );
    }

    /// Entry `R[i, j]`.
    pub(crate) fn r(&self, i: usize, j: usize) -> f64 {
        self.qr[(i, j)]
    }
}

/// Outcome of a least-squares solve.
pub(crate) struct LsSolution {
    /// Coefficients.
    pub x: Vec<f64>,
    /// Residual sum of squares.
    pub rss: f64,
}

/// Least squares `min ‖A x - b‖` for an augmented matrix `ab = [A | b]` (last column is b),
/// by Householder QR (faer) of the column-equilibrated augmented matrix, in place (no normal
/// equations). `x = R11⁻¹ r`, residual sum of squares `ρ²` where `R = [[R11, r], [0, ρ]]`.
///
/// Returns `Err(pivot)` with the smallest relative pivot if `A` is numerically rank deficient
/// (`min |R_ii| < RANK_TOL` after scaling every column of `A` to unit norm) or has a zero
/// column.
pub(crate) fn lstsq_augmented_in_place(ab: &mut Mat<f64>) -> Result<LsSolution, f64> {
    let (m, nc) = ab.shape();
    let d = nc - 1;
    assert!(m > d, "lstsq_augmented: need more rows than unknowns");
    let mut scale = vec![1.0; d];
    for (j, s) in scale.iter_mut().enumerate() {
        let col = ab.col_as_slice_mut(j);
        let norm = col.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return Err(0.0);
        }
        let inv = 1.0 / norm;
        col.iter_mut().for_each(|v| *v *= inv);
        *s = inv;
    }
    // Narrow matrices: unblocked Householder (block size 1) is the fastest in faer 0.24
    // (measured: 3000 x 5, 30 µs vs 50 µs with the recommended block size).
    let bs = if nc <= 16 {
        1
    } else {
        qr::no_pivoting::factor::recommended_block_size::<f64>(m, nc).max(1)
    };
    let mut coeff = Mat::<f64>::zeros(bs, nc);
    let mut buf = MemBuffer::new(qr::no_pivoting::factor::qr_in_place_scratch::<f64>(
        m,
        nc,
        bs,
        PAR,
        Default::default(),
    ));
    qr::no_pivoting::factor::qr_in_place(
        ab.as_mut(),
        coeff.as_mut(),
        PAR,
        MemStack::new(&mut buf),
        Default::default(),
    );
    let min_pivot = (0..d)
        .map(|i| ab[(i, i)].abs())
        .fold(f64::INFINITY, f64::min);
    if !(min_pivot >= RANK_TOL) {
        return Err(min_pivot);
    }
    let mut rhs = Mat::<f64>::from_fn(d, 1, |i, _| ab[(i, d)]);
    triangular_solve::solve_upper_triangular_in_place(ab.as_ref().get(..d, ..d), rhs.as_mut(), PAR);
    let rss = ab[(d, d)].powi(2);
    let x = (0..d).map(|i| rhs[(i, 0)] * scale[i]).collect();
    Ok(LsSolution { x, rss })
}

/// [`lstsq_augmented_in_place`] on an owned matrix.
pub(crate) fn lstsq_augmented(mut ab: Mat<f64>) -> Result<LsSolution, f64> {
    lstsq_augmented_in_place(&mut ab)
}

thread_local! {
    /// Reused regression buffer: avoids a large allocation (and its page faults) per call.
    static LS_BUFFER: std::cell::RefCell<Mat<f64>> = const { std::cell::RefCell::new(Mat::new()) };
}

/// Run `f` with a thread-local `rows × cols` buffer (contents unspecified on entry).
pub(crate) fn with_buffer<R>(rows: usize, cols: usize, f: impl FnOnce(&mut Mat<f64>) -> R) -> R {
    LS_BUFFER.with(|cell| match cell.try_borrow_mut() {
        Ok(mut buf) => {
            buf.resize_with(rows, cols, |_, _| 0.0);
            f(&mut buf)
        }
        // re-entrant use: fall back to a fresh matrix
        Err(_) => f(&mut Mat::<f64>::zeros(rows, cols)),
    })
}

/// `A Bᵀ`-style product helper: `dst = lhs * rhs`.
pub(crate) fn mul(lhs: MatRef<'_, f64>, rhs: MatRef<'_, f64>) -> Mat<f64> {
    let mut dst = Mat::<f64>::zeros(lhs.nrows(), rhs.ncols());
    matmul::matmul(dst.as_mut(), Accum::Replace, lhs, rhs, 1.0, PAR);
    dst
}

/// `dst += alpha * lhs * rhs`.
pub(crate) fn mul_add(
    dst: MatMut<'_, f64>,
    lhs: MatRef<'_, f64>,
    rhs: MatRef<'_, f64>,
    alpha: f64,
) {
    matmul::matmul(dst, Accum::Add, lhs, rhs, alpha, PAR);
}

/// A thin SVD `A = U diag(s) Vᵀ` (s non-increasing).
pub(crate) struct Svd {
    pub u: Mat<f64>,
    pub s: Vec<f64>,
    pub v: Mat<f64>,
}

/// Thin SVD of `a`; `None` if faer reports non-convergence or the matrix is not finite.
pub(crate) fn thin_svd(a: MatRef<'_, f64>) -> Option<Svd> {
    let (m, n) = a.shape();
    let k = m.min(n);
    let mut s = faer::diag::Diag::<f64>::zeros(k);
    let mut u = Mat::<f64>::zeros(m, k);
    let mut v = Mat::<f64>::zeros(n, k);
    let mut buf = MemBuffer::new(svd::svd_scratch::<f64>(
        m,
        n,
        svd::ComputeSvdVectors::Thin,
        svd::ComputeSvdVectors::Thin,
        PAR,
        Default::default(),
    ));
    svd::svd(
        a,
        s.as_mut(),
        Some(u.as_mut()),
        Some(v.as_mut()),
        PAR,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .ok()?;
    let s: Vec<f64> = s.column_vector().iter().copied().collect();
    if s.iter().any(|x| !x.is_finite()) {
        return None;
    }
    Some(Svd { u, s, v })
}

/// Moore–Penrose pseudo-inverse with relative tolerance `max(m, n) · ε · σ_max`.
pub(crate) fn pinv(a: MatRef<'_, f64>) -> Option<Mat<f64>> {
    let (m, n) = a.shape();
    pinv_tol(a, m.max(n))
}

/// Pseudo-inverse with tolerance `dim · ε · σ_max` (`dim` = the larger dimension of the
/// original problem when `a` is its triangular factor).
pub(crate) fn pinv_tol(a: MatRef<'_, f64>, dim: usize) -> Option<Mat<f64>> {
    pinv_rtol(a, dim as f64 * f64::EPSILON)
}

/// Pseudo-inverse discarding singular values below `rtol · σ_max`.
pub(crate) fn pinv_rtol(a: MatRef<'_, f64>, rtol: f64) -> Option<Mat<f64>> {
    let svd = thin_svd(a)?;
    let smax = svd.s.first().copied().unwrap_or(0.0);
    let tol = rtol * smax;
    // pinv = V diag(1/s) Uᵀ
    let k = svd.s.len();
    let mut vs = svd.v.clone();
    for j in 0..k {
        let inv = if svd.s[j] > tol { 1.0 / svd.s[j] } else { 0.0 };
        vs.col_as_slice_mut(j).iter_mut().for_each(|x| *x *= inv);
    }
    Some(mul(vs.as_ref(), svd.u.as_ref().transpose()))
}

/// Symmetric positive semi-definite square root via the symmetric eigendecomposition
/// (negative eigenvalues from round-off are clipped to 0).
pub(crate) fn sqrtm_psd(a: MatRef<'_, f64>) -> Option<Mat<f64>> {
    let n = a.nrows();
    let mut sym = Mat::<f64>::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let mut w = faer::diag::Diag::<f64>::zeros(n);
    let mut v = Mat::<f64>::zeros(n, n);
    let mut buf = MemBuffer::new(faer::linalg::evd::self_adjoint_evd_scratch::<f64>(
        n,
        faer::linalg::evd::ComputeEigenvectors::Yes,
        PAR,
        Default::default(),
    ));
    faer::linalg::evd::self_adjoint_evd(
        sym.as_ref(),
        w.as_mut(),
        Some(v.as_mut()),
        PAR,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .ok()?;
    let mut vs = v.clone();
    for j in 0..n {
        let l = w.column_vector()[j].max(0.0).sqrt();
        vs.col_as_slice_mut(j).iter_mut().for_each(|x| *x *= l);
    }
    sym = mul(vs.as_ref(), v.as_ref().transpose());
    Some(sym)
}

/// Eigenvalues `(re, im)` of a small real square matrix given row-major.
pub(crate) fn eigenvalues(rows: &[Vec<f64>]) -> Option<Vec<(f64, f64)>> {
    let n = rows.len();
    if n == 0 {
        return Some(Vec::new());
    }
    if rows.iter().flatten().any(|v| !v.is_finite()) {
        return None;
    }
    let a = Mat::<f64>::from_fn(n, n, |i, j| rows[i][j]);
    let mut re = faer::diag::Diag::<f64>::zeros(n);
    let mut im = faer::diag::Diag::<f64>::zeros(n);
    let mut buf = MemBuffer::new(faer::linalg::evd::evd_scratch::<f64>(
        n,
        faer::linalg::evd::ComputeEigenvectors::No,
        faer::linalg::evd::ComputeEigenvectors::No,
        PAR,
        Default::default(),
    ));
    faer::linalg::evd::evd_real(
        a.as_ref(),
        re.as_mut(),
        im.as_mut(),
        None,
        None,
        PAR,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .ok()?;
    Some(
        re.column_vector()
            .iter()
            .zip(im.column_vector().iter())
            .map(|(&r, &i)| (r, i))
            .collect(),
    )
}

/// Roots of `p[0] z^k + p[1] z^(k-1) + … + p[k]` (p[0] != 0) via companion-matrix eigenvalues.
pub(crate) fn poly_roots(p: &[f64]) -> Option<Vec<(f64, f64)>> {
    let k = p.len().saturating_sub(1);
    if k == 0 {
        return Some(Vec::new());
    }
    let lead = p[0];
    if lead == 0.0 || !lead.is_finite() {
        return None;
    }
    let mut comp = vec![vec![0.0; k]; k];
    for j in 0..k {
        comp[0][j] = -p[j + 1] / lead;
    }
    for i in 1..k {
        comp[i][i - 1] = 1.0;
    }
    eigenvalues(&comp)
}

/// Largest modulus of a set of complex numbers (0 for none).
pub(crate) fn max_modulus(z: &[(f64, f64)]) -> f64 {
    z.iter().map(|(r, i)| r.hypot(*i)).fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    //! faer results cross-checked against nalgebra on random problems.
    #![allow(clippy::unwrap_used)]
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random(rows: usize, cols: usize, seed: u64) -> (Mat<f64>, nalgebra::DMatrix<f64>) {
        let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let m = Mat::<f64>::from_fn(rows, cols, |_, _| r.random::<f64>() * 2.0 - 1.0);
        let n = nalgebra::DMatrix::from_fn(rows, cols, |i, j| m[(i, j)]);
        (m, n)
    }

    #[test]
    fn least_squares_matches_nalgebra_svd_solve() {
        for (seed, (rows, cols)) in [(200, 3), (1000, 6), (57, 10), (3000, 4)]
            .into_iter()
            .enumerate()
        {
            let (m, n) = random(rows, cols + 1, seed as u64);
            let sol = lstsq_augmented(m).unwrap();
            let a = n.columns(0, cols).into_owned();
            let b = n.column(cols).into_owned();
            let x = a.clone().svd(true, true).solve(&b, 1e-14).unwrap();
            let r = &b - &a * &x;
            for i in 0..cols {
                assert!(
                    (sol.x[i] - x[i]).abs() < 1e-10 * (1.0 + x[i].abs()),
                    "{rows}x{cols}: {} vs {}",
                    sol.x[i],
                    x[i]
                );
            }
            assert!((sol.rss - r.norm_squared()).abs() < 1e-9 * r.norm_squared());
        }
    }

    #[test]
    fn rank_deficient_least_squares_is_reported() {
        let (mut m, _) = random(100, 4, 9);
        let c0: Vec<f64> = m.col_as_slice(0).to_vec();
        m.col_as_slice_mut(2)
            .iter_mut()
            .zip(&c0)
            .for_each(|(v, c)| *v = 2.0 * c);
        assert!(lstsq_augmented(m).is_err());
    }

    #[test]
    fn svd_pinv_sqrtm_and_eigenvalues_match_nalgebra() {
        for (seed, (rows, cols)) in [(30, 20), (20, 40), (10, 10)].into_iter().enumerate() {
            let (m, n) = random(rows, cols, 100 + seed as u64);
            let s = thin_svd(m.as_ref()).unwrap();
            let sn = n.clone().svd(false, false).singular_values;
            let mut sn: Vec<f64> = sn.iter().copied().collect();
            sn.sort_by(|a, b| b.total_cmp(a));
            for (a, b) in s.s.iter().zip(&sn) {
                assert!((a - b).abs() < 1e-12 * sn[0], "{a} vs {b}");
            }
            let p = pinv(m.as_ref()).unwrap();
            let pn = n.clone().pseudo_inverse(1e-12).unwrap();
            for i in 0..cols {
                for j in 0..rows {
                    assert!((p[(i, j)] - pn[(i, j)]).abs() < 1e-9);
                }
            }
        }
        // PSD square root
        let (m, _) = random(8, 12, 7);
        let g = mul(m.as_ref(), m.as_ref().transpose());
        let r = sqrtm_psd(g.as_ref()).unwrap();
        let rr = mul(r.as_ref(), r.as_ref());
        for i in 0..8 {
            for j in 0..8 {
                assert!((rr[(i, j)] - g[(i, j)]).abs() < 1e-10);
            }
        }
        // eigenvalues of a random 5x5 vs nalgebra
        let (m, n) = random(5, 5, 3);
        let rows: Vec<Vec<f64>> = (0..5)
            .map(|i| (0..5).map(|j| m[(i, j)]).collect())
            .collect();
        let mut ours: Vec<(f64, f64)> = eigenvalues(&rows).unwrap();
        let mut theirs: Vec<(f64, f64)> = n
            .complex_eigenvalues()
            .iter()
            .map(|c| (c.re, c.im))
            .collect();
        let key = |z: &(f64, f64)| {
            (z.0 * 1e6).round() as i64 * 1_000_000_000 + (z.1 * 1e6).round() as i64
        };
        ours.sort_by_key(key);
        theirs.sort_by_key(key);
        for (a, b) in ours.iter().zip(&theirs) {
            assert!(
                (a.0 - b.0).abs() < 1e-10 && (a.1 - b.1).abs() < 1e-10,
                "{a:?} vs {b:?}"
            );
        }
        // polynomial roots: (z - 0.5)(z + 0.25)(z - 0.9)
        let mut r = poly_roots(&[1.0, -1.15, 0.1, 0.1125]).unwrap();
        r.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert!(
            (r[0].0 + 0.25).abs() < 1e-12
                && (r[1].0 - 0.5).abs() < 1e-12
                && (r[2].0 - 0.9).abs() < 1e-12
        );
    }
}
