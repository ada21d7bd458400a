//! Dense linear algebra through faer, always sequential (`Par::Seq`): the grid search
//! parallelises over nodes, and results must not depend on the thread count.
//!
//! Nothing here is public API: faer types never appear in public signatures.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::{matmul, qr, svd};
use faer::{Accum, Mat, MatMut, MatRef, Par};

const PAR: Par = Par::Seq;

/// Relative pivot below which a column-equilibrated QR is declared rank deficient.
pub(crate) const RANK_TOL: f64 = 1e-10;

/// Outcome of a least-squares solve.
pub(crate) struct LsSolution {
    /// Coefficients.
    pub x: Vec<f64>,
    /// Residual sum of squares.
    pub rss: f64,
}

/// The narrow QR of [`lstsq_colmajor`] as a pulp SIMD operation: `with_simd` is compiled for
/// the best instruction set of the machine (runtime dispatch, as faer does; safe), and the
/// QR inlined into it is auto-vectorised for AVX2 / AVX-512 when available. Returns `ρ²`.
struct NarrowLstsq<'a> {
    ab: &'a mut [f64],
    m: usize,
    nc: usize,
    scale: &'a mut [f64],
}

impl faer::traits::pulp::WithSimd for NarrowLstsq<'_> {
    type Output = Result<f64, f64>;
    #[inline(always)]
    fn with_simd<S: faer::traits::pulp::Simd>(self, _simd: S) -> Result<f64, f64> {
        let (m, d) = (self.m, self.nc - 1);
        equilibrate(self.ab, m, self.scale)?;
        householder_qr_colmajor(self.ab, m, self.nc, d);
        let last = &self.ab[d * m + d..(d + 1) * m];
        Ok(dot(last, last))
    }
}

/// Scale the first `scale.len()` columns (`m` rows each) of `ab` to unit norm, storing the
/// factors; `Err(0.0)` on a zero or non-finite column.
#[inline(always)]
fn equilibrate(ab: &mut [f64], m: usize, scale: &mut [f64]) -> Result<(), f64> {
    for (s, col) in scale.iter_mut().zip(ab.chunks_exact_mut(m)) {
        let norm = dot(col, col).sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return Err(0.0);
        }
        let inv = 1.0 / norm;
        col.iter_mut().for_each(|v| *v *= inv);
        *s = inv;
    }
    Ok(())
}

/// `Σ x_i` with eight independent partial sums (vectorisable; deterministic).
#[inline(always)]
pub(crate) fn sum(x: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let c = x.chunks_exact(8);
    let r = c.remainder();
    for v in c {
        for l in 0..8 {
            acc[l] += v[l];
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
    for v in r {
        s += v;
    }
    s
}

/// `Σ (x_i - c)²` with eight independent partial sums.
#[inline(always)]
pub(crate) fn sum_sq_about(x: &[f64], c: f64) -> f64 {
    let mut acc = [0.0; 8];
    let ch = x.chunks_exact(8);
    let r = ch.remainder();
    for v in ch {
        for l in 0..8 {
            let t = v[l] - c;
            acc[l] += t * t;
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
    for v in r {
        s += (v - c) * (v - c);
    }
    s
}

/// Whether every value is finite, in one vectorisable pass (`x · 0` is NaN exactly for
/// infinite or NaN `x`).
#[inline]
pub(crate) fn all_finite(x: &[f64]) -> bool {
    let mut acc = [0.0; 8];
    let c = x.chunks_exact(8);
    let r = c.remainder();
    for v in c {
        for l in 0..8 {
            acc[l] += v[l] * 0.0;
        }
    }
    acc.iter().chain(r).all(|v| v.is_finite())
}

/// Widest augmented matrix `[A | b]` solved by the unblocked Householder QR of this module;
/// wider ones go through faer's blocked QR.
pub(crate) const NARROW_QR_MAX_COLS: usize = 16;

/// `Σ a_i b_i` with eight independent partial sums (vectorisable, deterministic: the same
/// result for any SIMD width the compiler picks).
#[inline(always)]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0; 8];
    let ca = a.chunks_exact(8);
    let cb = b.chunks_exact(8);
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..8 {
            acc[l] += x[l] * y[l];
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

/// `y += alpha x`.
#[inline(always)]
fn axpy(y: &mut [f64], alpha: f64, x: &[f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

/// Unblocked Householder QR in place of the column-major `m × nc` matrix `a` (column `j` is
/// `a[j m .. (j + 1) m]`), reflecting the first `k` columns: on return `R[i, j]` (`i <= j`,
/// `i < k`) is `a[j m + i]`, and rows `k..m` of the columns `k..nc` hold `Qᵀ` times the
/// original ones. The Householder vectors are not kept.
///
/// `H = I - v vᵀ / (β (β - α))`, `v = x - β e₁`, `β = -sign(α) ‖x‖` (LAPACK's `dlarfg`
/// without its rescaling loop: callers equilibrate the columns, so `‖x‖²` cannot overflow).
///
/// Inlined into a SIMD-dispatched operation by the callers (`NarrowLstsq`): the loops are
/// written with fixed lanes and no fused multiply-add, so the result is the same bit for bit
/// whatever instruction set runs them.
#[inline(always)]
pub(crate) fn householder_qr_colmajor(a: &mut [f64], m: usize, nc: usize, k: usize) {
    debug_assert!(a.len() >= m * nc && k <= nc && k <= m);
    for j in 0..k {
        let (left, right) = a[..m * nc].split_at_mut((j + 1) * m);
        let x = &mut left[j * m + j..];
        let alpha = x[0];
        let sigma = dot(&x[1..], &x[1..]);
        if sigma == 0.0 {
            // already upper triangular in this column: H = I
            continue;
        }
        let norm = (alpha * alpha + sigma).sqrt();
        let beta = if alpha >= 0.0 { -norm } else { norm };
        let v0 = alpha - beta;
        // β (β - α) = ‖x‖ (‖x‖ + |α|) > 0
        let inv = 1.0 / (norm * (norm + alpha.abs()));
        x[0] = beta;
        let x = &left[j * m + j..];
        for col in right.chunks_exact_mut(m) {
            let c = &mut col[j..];
            let w = v0 * c[0] + dot(&x[1..], &c[1..]);
            let s = -w * inv;
            c[0] += s * v0;
            axpy(&mut c[1..], s, &x[1..]);
        }
    }
}

/// [`householder_qr_colmajor`] compiled for the best instruction set of the machine.
pub(crate) fn householder_qr_colmajor_simd(a: &mut [f64], m: usize, nc: usize, k: usize) {
    struct Op<'a> {
        a: &'a mut [f64],
        m: usize,
        nc: usize,
        k: usize,
    }
    impl faer::traits::pulp::WithSimd for Op<'_> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: faer::traits::pulp::Simd>(self, _simd: S) {
            householder_qr_colmajor(self.a, self.m, self.nc, self.k);
        }
    }
    faer::traits::pulp::Arch::new().dispatch(Op { a, m, nc, k });
}

/// Least squares `min ‖A x - b‖` for a column-major augmented matrix `ab = [A | b]`
/// (`m × nc`, the last column is b), by Householder QR of the column-equilibrated augmented
/// matrix, in place (no normal equations). `x = R11⁻¹ r`, residual sum of squares `ρ²`
/// where `R = [[R11, r], [0, ρ]]`.
///
/// Narrow matrices (`nc <= NARROW_QR_MAX_COLS`) use [`householder_qr_colmajor`] (measured:
/// 3000 × 5 about 3 times fewer instructions than faer's QR with block size 1, whose scaled
/// pairwise norms dominate at this width); wider ones faer's blocked QR.
///
/// Returns `Err(pivot)` with the smallest relative pivot if `A` is numerically rank deficient
/// (`min |R_ii| < RANK_TOL` after scaling every column of `A` to unit norm) or has a zero
/// column.
pub(crate) fn lstsq_colmajor(ab: &mut [f64], m: usize, nc: usize) -> Result<LsSolution, f64> {
    let d = nc - 1;
    assert!(m > d, "lstsq_augmented: need more rows than unknowns");
    let ab = &mut ab[..m * nc];
    let mut scale = vec![1.0; d];
    let rss = if nc <= NARROW_QR_MAX_COLS {
        faer::traits::pulp::Arch::new().dispatch(NarrowLstsq {
            ab: &mut *ab,
            m,
            nc,
            scale: &mut scale,
        })?
    } else {
        equilibrate(ab, m, &mut scale)?;
        let mut mat = faer::MatMut::from_column_major_slice_mut(&mut *ab, m, nc);
        let bs = qr::no_pivoting::factor::recommended_block_size::<f64>(m, nc).max(1);
        faer_qr_in_place(mat.as_mut(), bs);
        mat[(d, d)].powi(2)
    };
    let r = |i: usize, j: usize| ab[j * m + i];
    let min_pivot = (0..d).map(|i| r(i, i).abs()).fold(f64::INFINITY, f64::min);
    if !(min_pivot >= RANK_TOL) {
        return Err(min_pivot);
    }
    // back substitution R11 x = r
    let mut x = vec![0.0; d];
    for i in (0..d).rev() {
        let mut v = r(i, d);
        for (j, xj) in x.iter().enumerate().skip(i + 1) {
            v -= r(i, j) * xj;
        }
        x[i] = v / r(i, i);
    }
    x.iter_mut().zip(&scale).for_each(|(xi, s)| *xi *= s);
    Ok(LsSolution { x, rss })
}

/// faer's blocked Householder QR of `mat` in place (block size `bs`): R in the upper
/// triangle, the reflectors below.
fn faer_qr_in_place(mat: MatMut<'_, f64>, bs: usize) {
    let (m, nc) = (mat.nrows(), mat.ncols());
    let mut coeff = Mat::<f64>::zeros(bs, nc);
    let mut buf = MemBuffer::new(qr::no_pivoting::factor::qr_in_place_scratch::<f64>(
        m,
        nc,
        bs,
        PAR,
        Default::default(),
    ));
    qr::no_pivoting::factor::qr_in_place(
        mat,
        coeff.as_mut(),
        PAR,
        MemStack::new(&mut buf),
        Default::default(),
    );
}

/// [`lstsq_colmajor`] on an owned faer matrix.
pub(crate) fn lstsq_augmented(ab: Mat<f64>) -> Result<LsSolution, f64> {
    let (m, nc) = ab.shape();
    let mut buf = Vec::with_capacity(m * nc);
    for j in 0..nc {
        buf.extend_from_slice(ab.col_as_slice(j));
    }
    lstsq_colmajor(&mut buf, m, nc)
}

thread_local! {
    /// Reused regression buffer: avoids a large allocation (and its page faults) per call.
    static LS_BUFFER: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Run `f` with a thread-local buffer of `len` values (contents unspecified on entry).
pub(crate) fn with_buffer<R>(len: usize, f: impl FnOnce(&mut [f64]) -> R) -> R {
    LS_BUFFER.with(|cell| match cell.try_borrow_mut() {
        Ok(mut buf) => {
            if buf.len() < len {
                buf.resize(len, 0.0);
            }
            f(&mut buf[..len])
        }
        // re-entrant use: fall back to a fresh buffer
        Err(_) => f(&mut vec![0.0; len]),
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

/// `R⁻¹` of an upper-triangular `R` by back substitution, when that is provably its
/// pseudo-inverse with relative cut `rtol` (no singular value below `rtol · σ_max`):
/// `σ_max / σ_min ≤ ‖R‖_F ‖R⁻¹‖_F < 1 / rtol`. `None` otherwise (the caller falls back to
/// the SVD, [`pinv_rtol`]). Same result as the SVD route up to round-off, at a fraction of
/// the cost.
pub(crate) fn upper_inverse_if_well_conditioned(r: MatRef<'_, f64>, rtol: f64) -> Option<Mat<f64>> {
    let n = r.nrows();
    let mut inv = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        // column j of R⁻¹: R x = e_j, x[i] = 0 for i > j
        for i in (0..=j).rev() {
            let mut v = if i == j { 1.0 } else { 0.0 };
            for k in i + 1..=j {
                v -= r[(i, k)] * inv[(k, j)];
            }
            inv[(i, j)] = v / r[(i, i)];
        }
    }
    let fro = |m: MatRef<'_, f64>| {
        let mut s = 0.0;
        for j in 0..n {
            for i in 0..=j {
                s += m[(i, j)] * m[(i, j)];
            }
        }
        s.sqrt()
    };
    let bound = fro(r) * fro(inv.as_ref());
    (bound.is_finite() && bound * rtol < 1.0).then_some(inv)
}

/// Lower Cholesky factor `L` (`L Lᵀ = a`) of a symmetric positive definite `a` (faer's
/// LLᵀ, which reads the lower triangle); `None` when a pivot is not positive or an entry is
/// not finite. Cholesky is backward stable whenever it completes (`L Lᵀ = a + E`,
/// `|E_ij| <= γ_{n+1} √(a_ii a_jj)`), so `L` serves wherever any factor of `a` does.
pub(crate) fn cholesky_lower(a: MatRef<'_, f64>) -> Option<Mat<f64>> {
    let l = a.llt(faer::Side::Lower).ok()?.L().to_owned();
    l.as_ref().is_all_finite().then_some(l)
}

/// Left singular vectors and singular values (descending) of a small dense matrix, `None`
/// if the iteration does not converge or the result is not finite.
///
/// nalgebra's Golub–Kahan SVD, not faer's: for the 10 × 20 matrix PARSIM-K factors at every
/// grid node it took 12.2 µs against faer's 19.3 µs (faer's blocked algorithms are built for
/// large matrices; measured with both in one run on this machine). The right singular
/// vectors are not formed.
pub(crate) fn left_svd(a: MatRef<'_, f64>) -> Option<(Mat<f64>, Vec<f64>)> {
    let (m, n) = a.shape();
    let na = nalgebra::DMatrix::<f64>::from_fn(m, n, |i, j| a[(i, j)]);
    let svd = na.try_svd(true, false, f64::EPSILON, 10_000)?;
    let u = svd.u?;
    let k = svd.singular_values.len();
    // nalgebra sorts the values in descending order; the permutation keeps that a property
    // of this function rather than of one nalgebra version
    let mut order: Vec<usize> = (0..k).collect();
    order.sort_by(|&x, &y| svd.singular_values[y].total_cmp(&svd.singular_values[x]));
    let s: Vec<f64> = order.iter().map(|&c| svd.singular_values[c]).collect();
    let u = Mat::<f64>::from_fn(m, k, |i, c| u[(i, order[c])]);
    (s.iter().all(|x| x.is_finite()) && u.as_ref().is_all_finite()).then_some((u, s))
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

/// Roots of the monic quadratic `z² - 2 h z + q` (`h` = half the trace, `q` the determinant
/// of a 2 × 2 matrix), given `disc = h² - q` computed by the caller in its most accurate form.
/// Real roots: the larger-magnitude one by `h ± √disc` without cancellation, the other as
/// `q / r₁` when `from_product` (polynomial roots: relative accuracy) or `h ∓ √disc`.
/// Complex pair: positive imaginary part first (LAPACK's order).
fn quadratic_roots(h: f64, q: f64, disc: f64, from_product: bool) -> [(f64, f64); 2] {
    if disc >= 0.0 {
        let sq = disc.sqrt();
        let r1 = if h >= 0.0 { h + sq } else { h - sq };
        let r2 = if r1 == 0.0 {
            0.0
        } else if from_product {
            q / r1
        } else if h >= 0.0 {
            h - sq
        } else {
            h + sq
        };
        [(r1, 0.0), (r2, 0.0)]
    } else {
        let im = (-disc).sqrt();
        [(h, im), (h, -im)]
    }
}

/// Eigenvalues of a real 2 × 2 matrix `[[a, b], [c, d]]` in closed form:
/// `λ = (a + d)/2 ± √(((a - d)/2)² + b c)` (the discriminant without the cancellation of
/// `tr²/4 - det`). Accurate to `ε ‖A‖`, like a backward-stable eigensolver.
pub(crate) fn eigenvalues_2x2(a: f64, b: f64, c: f64, d: f64) -> [(f64, f64); 2] {
    let h = 0.5 * (a + d);
    let g = 0.5 * (a - d);
    let disc = g * g + b * c;
    quadratic_roots(h, a * d - b * c, disc, false)
}

/// Eigenvalues `(re, im)` of a small real square matrix given row-major (closed form for
/// `n <= 2`, faer's real Schur otherwise).
pub(crate) fn eigenvalues(rows: &[Vec<f64>]) -> Option<Vec<(f64, f64)>> {
    let n = rows.len();
    if n == 0 {
        return Some(Vec::new());
    }
    if rows.iter().flatten().any(|v| !v.is_finite()) {
        return None;
    }
    match n {
        1 => return Some(vec![(rows[0][0], 0.0)]),
        2 => return Some(eigenvalues_2x2(rows[0][0], rows[0][1], rows[1][0], rows[1][1]).to_vec()),
        _ => {}
    }
    eigenvalues_schur(rows)
}

/// Eigenvalues through faer's real eigensolver (any size; the reference for the closed forms).
pub(crate) fn eigenvalues_schur(rows: &[Vec<f64>]) -> Option<Vec<(f64, f64)>> {
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
    if p.len() > 1 && p.iter().any(|v| !v.is_finite()) {
        return None;
    }
    match *p {
        [lead, p1] if lead != 0.0 => Some(vec![(-p1 / lead, 0.0)]),
        [lead, p1, p2] if lead != 0.0 => {
            // z² + b z + c: roots h ± √(h² - c), h = -b/2 (the companion matrix's eigenvalues)
            let (b, c) = (p1 / lead, p2 / lead);
            let h = -0.5 * b;
            Some(quadratic_roots(h, c, h * h - c, true).to_vec())
        }
        // a constant, a zero leading coefficient or a higher degree
        _ => poly_roots_companion(p),
    }
}

/// Roots through the companion matrix's eigenvalues (any degree; the reference for the closed
/// forms of [`poly_roots`]).
pub(crate) fn poly_roots_companion(p: &[f64]) -> Option<Vec<(f64, f64)>> {
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
    eigenvalues_schur(&comp)
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
    fn left_svd_and_cholesky_match_faer() {
        for (seed, (rows, cols)) in [(10, 20), (20, 10), (6, 6)].into_iter().enumerate() {
            let (m, _) = random(rows, cols, 200 + seed as u64);
            let (u, s) = left_svd(m.as_ref()).unwrap();
            let reference = thin_svd(m.as_ref()).unwrap();
            assert!(s.windows(2).all(|w| w[0] >= w[1]), "descending {s:?}");
            for (a, b) in s.iter().zip(&reference.s) {
                assert!((a - b).abs() < 1e-12 * s[0], "{a} vs {b}");
            }
            // the same singular vectors up to sign (distinct singular values)
            for c in 0..s.len() {
                let d: f64 = (0..rows).map(|i| u[(i, c)] * reference.u[(i, c)]).sum();
                assert!((d.abs() - 1.0).abs() < 1e-10, "column {c}: {d}");
            }
        }
        let (m, _) = random(8, 12, 7);
        let g = mul(m.as_ref(), m.as_ref().transpose());
        let l = cholesky_lower(g.as_ref()).unwrap();
        let ll = mul(l.as_ref(), l.as_ref().transpose());
        for i in 0..8 {
            for j in 0..8 {
                assert!((ll[(i, j)] - g[(i, j)]).abs() < 1e-12 * g[(i, i)].max(1.0));
                assert!(j <= i || l[(i, j)] == 0.0, "lower triangular");
            }
        }
        // indefinite: refused
        let mut h = g.clone();
        h[(3, 3)] = -1.0;
        assert!(cholesky_lower(h.as_ref()).is_none());
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

    /// Sorted by (re, im) for comparison.
    fn sorted(mut z: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
        z.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        z
    }

    #[test]
    fn closed_form_roots_match_companion_eigenvalues() {
        let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(42);
        let mut cases: Vec<Vec<f64>> = vec![
            vec![1.0, -1.5, 0.7],     // complex pair
            vec![1.0, -0.25, -0.125], // real, distinct
            vec![1.0, -1.0, 0.25],    // double root 0.5
            vec![1.0, 0.0, 0.0],      // double root 0
            vec![1.0, 0.3, 0.0],      // one zero root
            vec![2.0, 0.0, -0.5],     // ±0.5, non-monic
            vec![1.0, -1e8, 1.0],     // widely separated: small root by the product
            vec![1.0, 0.5],
            vec![-3.0, 1.2],
        ];
        for _ in 0..200 {
            let k = 1 + (r.random::<u32>() % 2) as usize;
            cases.push((0..=k).map(|_| r.random::<f64>() * 4.0 - 2.0).collect());
        }
        for p in &cases {
            let fast = sorted(poly_roots(p).unwrap());
            let reference = sorted(poly_roots_companion(p).unwrap());
            let scale = 1.0 + p.iter().map(|v| (v / p[0]).abs()).fold(0.0, f64::max);
            // a double root is only determined to √ε by the coefficients
            let tol = if (p.len() == 3) && ((p[1] / p[0]).powi(2) - 4.0 * p[2] / p[0]).abs() < 1e-6
            {
                1e-7
            } else {
                1e-10
            } * scale;
            assert_eq!(fast.len(), reference.len());
            for (a, b) in fast.iter().zip(&reference) {
                assert!(
                    (a.0 - b.0).abs() < tol && (a.1 - b.1).abs() < tol,
                    "{p:?}: {fast:?} vs {reference:?}"
                );
            }
            assert!((max_modulus(&fast) - max_modulus(&reference)).abs() < tol);
        }
        assert!(poly_roots(&[1.0, f64::NAN, 0.5]).is_none());
        assert!(poly_roots(&[0.0, 1.0, 0.5]).is_none());
    }

    #[test]
    fn closed_form_2x2_eigenvalues_match_schur() {
        let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut cases: Vec<[f64; 4]> = vec![
            [0.5, 0.0, 0.0, 0.5],
            [0.0, 1.0, -1.0, 0.0],
            [0.9, 1e-9, 0.0, 0.1],
            [1e6, 1.0, 1.0, 1e-6],
        ];
        for _ in 0..200 {
            cases.push([(); 4].map(|_| r.random::<f64>() * 4.0 - 2.0));
        }
        for m in &cases {
            let rows = vec![vec![m[0], m[1]], vec![m[2], m[3]]];
            let fast = sorted(eigenvalues(&rows).unwrap());
            let reference = sorted(eigenvalues_schur(&rows).unwrap());
            let norm = m.iter().map(|v| v.abs()).fold(0.0, f64::max);
            for (a, b) in fast.iter().zip(&reference) {
                assert!(
                    (a.0 - b.0).abs() < 1e-12 * (1.0 + norm)
                        && (a.1 - b.1).abs() < 1e-12 * (1.0 + norm),
                    "{m:?}: {fast:?} vs {reference:?}"
                );
            }
        }
        assert!(eigenvalues(&[vec![1.0, f64::INFINITY], vec![0.0, 1.0]]).is_none());
    }

    #[test]
    fn narrow_householder_matches_faer_qr() {
        // R of the hand-written QR equals faer's up to the signs of its rows
        for (seed, (rows, cols)) in [(300usize, 3usize), (3000, 5), (500, 16), (200, 41)]
            .into_iter()
            .enumerate()
        {
            let (m, _) = random(rows, cols, 50 + seed as u64);
            let mut ours: Vec<f64> = (0..cols).flat_map(|j| m.col_as_slice(j).to_vec()).collect();
            householder_qr_colmajor_simd(&mut ours, rows, cols, cols);
            let mut theirs = m.clone();
            faer_qr_in_place(theirs.as_mut(), 1);
            for i in 0..cols {
                let s = (ours[i * rows + i] * theirs[(i, i)]).signum();
                for j in i..cols {
                    let (a, b) = (ours[j * rows + i], s * theirs[(i, j)]);
                    assert!(
                        (a - b).abs() < 1e-12 * (rows as f64).sqrt(),
                        "R[{i},{j}]: {a} vs {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn triangular_inverse_is_the_pseudo_inverse_when_well_conditioned() {
        let (m, _) = random(40, 12, 11);
        let mut ab: Vec<f64> = (0..12).flat_map(|j| m.col_as_slice(j).to_vec()).collect();
        householder_qr_colmajor_simd(&mut ab, 40, 12, 12);
        let r = Mat::<f64>::from_fn(12, 12, |i, j| if j >= i { ab[j * 40 + i] } else { 0.0 });
        let inv = upper_inverse_if_well_conditioned(r.as_ref(), 1e-10).unwrap();
        let pi = pinv_rtol(r.as_ref(), 1e-10).unwrap();
        for i in 0..12 {
            for j in 0..12 {
                assert!((inv[(i, j)] - pi[(i, j)]).abs() < 1e-10 * (1.0 + pi[(i, j)].abs()));
            }
        }
        // rank deficient: refused (the SVD route cuts the tiny singular value)
        let mut rd = r.clone();
        rd[(11, 11)] = 1e-14;
        assert!(upper_inverse_if_well_conditioned(rd.as_ref(), 1e-10).is_none());
    }
}
