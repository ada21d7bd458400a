//! PARSIM-K closed-loop subspace identification (Pannocchia & Calosi, 2010), spec §4.4.
//!
//! Steps (SISO): center and scale by the standard deviations; build past (`p` block rows)
//! and future (`f` block rows) data; estimate `Γ_i, H_i, G_i` row by row with causality
//! enforced (one QR of `[Zp; U_0; Y_0]` reused for every row, pseudo-inverse of its small
//! triangular factor so that rank-deficient noise-free data works); weighted SVD of
//! `Γ W`, `W = (Zp Π⊥ Zpᵀ)^{1/2}`; `A_K`, `C` by shift invariance; `B_K`, (`D`), `K`, `x0`
//! by least squares on the predictor output; unscale.

use faer::Mat;
use serde::{Deserialize, Serialize};

mod lanes;

use crate::error::{check_data, check_finite, check_order, check_real};
use crate::{la, IdError, LinearFit, OrderValue, Structure};

/// PARSIM-K state-space identification, eq. (6) in innovation form.
///
/// | name | default | meaning | valid range |
/// |------|---------|---------|-------------|
/// | `n` | 2 | model order; 0 = choose by `threshold` (at most `max_order`) | 0 ..= f |
/// | `f` | 10 | future horizon | 2 ..= 200 |
/// | `p` | 10 | past horizon (`p != f` allowed) | 1 ..= 200 |
/// | `threshold` | 0.1 | keep singular values `>= threshold · σ_1` when `n = 0` | [0, 1) |
/// | `max_order` | 0 | cap for the threshold rule, 0 = `f` | 0 ..= f |
/// | `d_required` | false | estimate a feedthrough `D` (else D = 0, as eq. 6) | |
/// | `center` | true | subtract the means of u and y first (false: SIPPY's default `centering="None"`) | |
///
/// Mean-centering makes noise-free data only approximately linear (the sample means are not
/// exactly in the ratio of the static gain): with `center = true` the noise-free invariants hold
/// to about 1e-3 instead of 1e-6; with `center = false` exactly as in SIPPY.
/// The horizons default to 10 rather than SIPPY's 20: the grid search identifies tens of
/// thousands of models and f = p = 10 is 3-4 times faster with the same results on the
/// paper's benchmark (spec §5.5 used f = p = 10).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ParsimKParams", into = "ParsimKParams")]
pub struct ParsimK {
    p: ParsimKParams,
}

/// Unchecked parameters of [`ParsimK`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ParsimKParams {
    /// Model order (0 = threshold rule).
    pub n: usize,
    /// Future horizon.
    pub f: usize,
    /// Past horizon.
    pub p: usize,
    /// Relative singular-value threshold (used when `n = 0`).
    pub threshold: f64,
    /// Cap on the order chosen by the threshold rule (0 = f).
    pub max_order: usize,
    /// Estimate D.
    pub d_required: bool,
    /// Subtract the means of u and y.
    pub center: bool,
}

impl Default for ParsimKParams {
    fn default() -> Self {
        ParsimKParams {
            n: 2,
            f: 10,
            p: 10,
            threshold: 0.1,
            max_order: 0,
            d_required: false,
            center: true,
        }
    }
}

impl ParsimKParams {
    crate::declare::setters!(
        n: usize,
        f: usize,
        p: usize,
        threshold: f64,
        max_order: usize,
        d_required: bool,
        center: bool,
    );
    /// Validate and build.
    pub fn check(self) -> Result<ParsimK, IdError> {
        check_order("ss", "f", self.f, 2, 200)?;
        check_order("ss", "p", self.p, 1, 200)?;
        check_order("ss", "n", self.n, 0, self.f)?;
        check_order("ss", "max_order", self.max_order, 0, self.f)?;
        if !(self.threshold < 1.0) {
            return Err(IdError::InvalidOrder {
                identifier: "ss",
                name: "threshold".into(),
                value: OrderValue::Real(self.threshold),
                expected: "a finite number in [0, 1)".into(),
            });
        }
        check_real("ss", "threshold", self.threshold, 0.0, 1.0)?;
        Ok(ParsimK { p: self })
    }
}

impl From<ParsimK> for ParsimKParams {
    fn from(s: ParsimK) -> Self {
        s.p
    }
}

/// Relative singular-value cut of the step-2 / step-6 pseudo-inverses.
const PINV_RTOL: f64 = 1e-10;

fn singular(detail: String) -> IdError {
    IdError::Singular {
        identifier: "ss",
        detail,
    }
}

fn svd_failed(what: &str) -> IdError {
    IdError::NotConverged {
        identifier: "ss",
        detail: format!("{what} did not converge"),
    }
}

/// Least squares with a pseudo-inverse: `[A | B] → Q [R | QᵀB]` by Householder QR
/// ([`la::householder_qr_colmajor_simd`]), then `x = pinv(R[..k, ..k]) (Qᵀ b)[..k]` for the
/// leading `k` columns; tolerance `max(PINV_RTOL, max(rows, k) · ε) · σ_max`.
struct PinvLs {
    /// `pinv(R_k)` for the requested leading sizes.
    pinvs: Vec<Mat<f64>>,
    /// `Qᵀ B` top rows (`ncols(A)` × targets).
    qtb: Mat<f64>,
}

/// `ab` is column-major `rows × (k + targets)`: the `k` regressor columns, then the targets;
/// it is overwritten by the factorisation.
fn pinv_ls(ab: &mut [f64], rows: usize, k: usize, sizes: &[usize]) -> Result<PinvLs, IdError> {
    let nc = ab.len() / rows;
    la::householder_qr_colmajor_simd(ab, rows, nc, k);
    let r = |i: usize, j: usize| ab[j * rows + i];
    let qtb = Mat::<f64>::from_fn(k, nc - k, |i, j| r(i, k + j));
    let rk = Mat::<f64>::from_fn(k, k, |i, j| if j >= i { r(i, j) } else { 0.0 });
    PinvLs::from_r(rk, qtb, rows, sizes)
}

impl PinvLs {
    /// The pseudo-inverses of the leading `sizes` blocks of the upper-triangular `r`.
    fn from_r(r: Mat<f64>, qtb: Mat<f64>, rows: usize, sizes: &[usize]) -> Result<Self, IdError> {
        let mut pinvs = Vec::with_capacity(sizes.len());
        for &s in sizes {
            let rs = r.as_ref().get(..s, ..s);
            let rtol = PINV_RTOL.max(rows.max(s) as f64 * f64::EPSILON);
            let pi = match la::upper_inverse_if_well_conditioned(rs, rtol) {
                Some(inv) => inv,
                None => la::pinv_rtol(rs, rtol).ok_or_else(|| svd_failed("SVD of R"))?,
            };
            pinvs.push(pi);
        }
        Ok(PinvLs { pinvs, qtb })
    }
}

/// How the small dense problems of steps 2, 3 and 6 are solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Route {
    /// Step 2 from the Gram matrix when it is well conditioned ([`step2_from_gram`]), else
    /// the QR; `W²` with a Cholesky inverse of `Uf Ufᵀ` ([`weight_squared`]); the Cholesky
    /// factor of `W²` ([`weight_factor`]) and nalgebra's SVD ([`la::left_svd`]).
    Fast,
    /// The spec's literal route: Householder QR of the step-2 data matrix, SVD
    /// pseudo-inverse of `Uf Ufᵀ`, symmetric square root `W` and faer's thin SVD of `Γ W`
    /// (the reference in tests).
    #[cfg_attr(not(test), allow(dead_code))]
    Reference,
}

/// Smallest accepted squared pivot of the unit-diagonal Cholesky factor of the step-2 Gram
/// matrix ([`step2_from_gram`]); the same bound as the ARX sums' (`arx_sums::GRAM_PIVOT_TOL`,
/// where it is argued).
const STEP2_PIVOT_TOL: f64 = crate::arx_sums::GRAM_PIVOT_TOL;

/// Step 2's `R` and `Qᵀ targets` from the Gram matrix of its columns instead of a Householder
/// QR of the `N × (k + targets)` data matrix.
///
/// Every column is a shift of the scaled u or y (`cols[c] = (is_y, shift)`), so the whole
/// Gram matrix comes from shifted products ([`shifted_products`], `O((p + f) N)` instead of
/// the QR's `O((k + targets)² N)`). With `D` scaling the regressor block to unit diagonal and
/// `D G D = L Lᵀ` (Cholesky), `R = Lᵀ D⁻¹` is the QR's triangular factor up to the signs of
/// its rows and `Qᵀ B = R⁻ᵀ Xᵀ B`; every product `pinv(R) Qᵀ b` the steps use is unchanged by
/// those signs. Normal equations square the condition number, so this is used only when every
/// pivot `L_ii² >= 1e-4` (the QR's relative pivots >= 1e-2, eight decades above the
/// pseudo-inverse cut); otherwise `None` and the caller takes the QR ([`pinv_ls`]). Test:
/// `fast_route_matches_the_reference` (fits equal to 1e-9 relative).
fn step2_from_gram(
    h: &ShiftedProducts,
    cols: &[(bool, usize)],
    k: usize,
) -> Option<(Mat<f64>, Mat<f64>)> {
    let g = |i: usize, j: usize| h.get(cols[i], cols[j]);
    let nt = cols.len() - k;
    let mut scale = vec![0.0; k];
    for (i, s) in scale.iter_mut().enumerate() {
        let d = g(i, i);
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        *s = 1.0 / d.sqrt();
    }
    // Cholesky of D G D in place (lower triangle, row-major k × k)
    let mut l = vec![0.0; k * k];
    for j in 0..k {
        let mut v = g(j, j) * scale[j] * scale[j];
        for m in 0..j {
            v -= l[j * k + m] * l[j * k + m];
        }
        if !(v >= STEP2_PIVOT_TOL) {
            return None;
        }
        let ljj = v.sqrt();
        l[j * k + j] = ljj;
        for i in j + 1..k {
            let mut w = g(i, j) * scale[i] * scale[j];
            for m in 0..j {
                w -= l[i * k + m] * l[j * k + m];
            }
            l[i * k + j] = w / ljj;
        }
    }
    // R = Lᵀ D⁻¹; Qᵀ B = R⁻ᵀ Xᵀ B = L⁻¹ D Xᵀ B (forward substitution per target)
    let r = Mat::<f64>::from_fn(
        k,
        k,
        |i, j| {
            if j >= i {
                l[j * k + i] / scale[j]
            } else {
                0.0
            }
        },
    );
    let mut qtb = Mat::<f64>::zeros(k, nt);
    for t in 0..nt {
        for i in 0..k {
            let mut v = g(i, k + t) * scale[i];
            for m in 0..i {
                v -= l[i * k + m] * qtb[(m, t)];
            }
            qtb[(i, t)] = v / l[i * k + i];
        }
    }
    (r.as_ref().is_all_finite() && qtb.as_ref().is_all_finite()).then_some((r, qtb))
}

/// `Σ_{t < ncol} a[oa + t] b[ob + t]` for every `oa < ka`, `ob < kb` (row-major `ka × kb`),
/// by `ka + kb - 1` dot products and the shift recurrence
/// `H(i + 1, j + 1) = H(i, j) - a_i b_j + a_{i + ncol} b_{j + ncol}`.
#[inline(always)]
fn shifted_products(a: &[f64], ka: usize, b: &[f64], kb: usize, ncol: usize) -> Vec<f64> {
    let mut h = vec![0.0; ka * kb];
    for ob in 0..kb {
        h[ob] = la::dot(&a[..ncol], &b[ob..ob + ncol]);
    }
    for oa in 1..ka {
        h[oa * kb] = la::dot(&a[oa..oa + ncol], &b[..ncol]);
    }
    for oa in 1..ka {
        for ob in 1..kb {
            h[oa * kb + ob] = h[(oa - 1) * kb + ob - 1] - a[oa - 1] * b[ob - 1]
                + a[oa - 1 + ncol] * b[ob - 1 + ncol];
        }
    }
    h
}

/// [`shifted_products`] of `a` with itself: the first column is the first row and the
/// recurrence keeps the matrix symmetric, so only the upper triangle is computed (`k` dot
/// products instead of `2k - 1`) and mirrored; the same bits, since `x·y = y·x` exactly.
#[inline(always)]
fn shifted_self_products(a: &[f64], k: usize, ncol: usize) -> Vec<f64> {
    let mut h = vec![0.0; k * k];
    for ob in 0..k {
        h[ob] = la::dot(&a[..ncol], &a[ob..ob + ncol]);
        h[ob * k] = h[ob];
    }
    for oa in 1..k {
        for ob in oa..k {
            let v = h[(oa - 1) * k + ob - 1] - a[oa - 1] * a[ob - 1]
                + a[oa - 1 + ncol] * a[ob - 1 + ncol];
            h[oa * k + ob] = v;
            h[ob * k + oa] = v;
        }
    }
    h
}

/// The Gram matrix `XᵀX` of `X = [Zp | Uf]` (transposed layout: `ncol` rows; columns the
/// u shifts `0..p`, the y shifts `0..p`, the u shifts `p..p+f`), from the Hankel structure:
/// every entry is a shifted product of u or y with itself or the other
/// ([`shifted_products`]), `O((p + f) N)` instead of `O((2p + f)² N)`. Equal to the direct
/// product up to round-off (test `hankel_gram_matches_product`).
fn hankel_gram(h: &ShiftedProducts, p: usize, f: usize) -> Mat<f64> {
    // column c -> (is_y, shift)
    let col = |c: usize| -> (bool, usize) {
        if c < p {
            (false, c)
        } else if c < 2 * p {
            (true, c - p)
        } else {
            (false, c - p)
        }
    };
    let nz = 2 * p + f;
    Mat::<f64>::from_fn(nz, nz, |i, j| h.get(col(i), col(j)))
}

/// The shifted products of the scaled u and y with themselves and each other for every pair
/// of shifts below `k` ([`shifted_products`]): every entry of the step-2 and step-3 Gram
/// matrices, computed once per identification.
struct ShiftedProducts {
    k: usize,
    uu: Vec<f64>,
    yy: Vec<f64>,
    uy: Vec<f64>,
}

/// PARSIM-K's output-only quantities for one identification window: the mean (0 without
/// centering), the standard deviation, the scaled output and its shifted self-products.
struct Output {
    mean: f64,
    sd: f64,
    ys: Vec<f64>,
    yy: Vec<f64>,
}

/// `(mean, sd, (x - mean) / sd)`: the centering (mean 0 when `center` is false) and the scaling
/// by the standard deviation (as SIPPY: `np.std` of the data given to PARSIM-K), the sums with
/// independent partial sums (vectorised), the scaling by the reciprocal.
fn scaled(x: &[f64], center: bool) -> (f64, f64, Vec<f64>) {
    let mu = la::sum(x) / x.len() as f64;
    let m = if center { mu } else { 0.0 };
    let sd = (la::sum_sq_about(x, mu) / x.len() as f64).sqrt();
    let inv = 1.0 / sd;
    (m, sd, x.iter().map(|v| (v - m) * inv).collect())
}

impl ShiftedProducts {
    /// [`shifted_self_products`] compiled for the best instruction set (the same bits).
    fn self_products(a: &[f64], k: usize, ncol: usize) -> Vec<f64> {
        struct Run<'a> {
            a: &'a [f64],
            k: usize,
            ncol: usize,
        }
        impl faer::traits::pulp::WithSimd for Run<'_> {
            type Output = Vec<f64>;
            #[inline(always)]
            fn with_simd<S: faer::traits::pulp::Simd>(self, _: S) -> Vec<f64> {
                shifted_self_products(self.a, self.k, self.ncol)
            }
        }
        faer::traits::pulp::Arch::new().dispatch(Run { a, k, ncol })
    }

    /// [`ShiftedProducts::new`] with the output's self-products `yy` already computed.
    fn with_yy(us: &[f64], ys: &[f64], yy: Vec<f64>, k: usize, ncol: usize) -> Self {
        struct Run<'a> {
            us: &'a [f64],
            ys: &'a [f64],
            k: usize,
            ncol: usize,
        }
        impl faer::traits::pulp::WithSimd for Run<'_> {
            type Output = (Vec<f64>, Vec<f64>);
            #[inline(always)]
            fn with_simd<S: faer::traits::pulp::Simd>(self, _: S) -> (Vec<f64>, Vec<f64>) {
                let Run { us, ys, k, ncol } = self;
                (
                    shifted_self_products(us, k, ncol),
                    shifted_products(us, k, ys, k, ncol),
                )
            }
        }
        let (uu, uy) = faer::traits::pulp::Arch::new().dispatch(Run { us, ys, k, ncol });
        ShiftedProducts { k, uu, yy, uy }
    }

    /// Every product of the scaled u and y (the tests' reference for [`Self::with_yy`]).
    #[cfg(test)]
    fn new(us: &[f64], ys: &[f64], k: usize, ncol: usize) -> Self {
        Self::with_yy(us, ys, Self::self_products(ys, k, ncol), k, ncol)
    }

    /// `Σ_t s_a(t + a) s_b(t + b)` for the columns `(is_y, shift)` `a` and `b`.
    fn get(&self, (ya, a): (bool, usize), (yb, b): (bool, usize)) -> f64 {
        let k = self.k;
        match (ya, yb) {
            (false, false) => self.uu[a * k + b],
            (true, true) => self.yy[a * k + b],
            (false, true) => self.uy[a * k + b],
            (true, false) => self.uy[b * k + a],
        }
    }
}

/// The inputs of step 6's regressors: the predictor matrix `ak` (`A_K`, `n × n` row-major),
/// `c` (`C`), the scaled data `us`, `ys`, and whether `D` is estimated.
struct Step6<'a> {
    ak: &'a [f64],
    c: &'a [f64],
    us: &'a [f64],
    ys: &'a [f64],
    d_required: bool,
}

impl Step6<'_> {
    /// Step-6 regressors in one pass over the data: the predictor output
    /// `ŷ = C x`, `x+ = A_K x + B_K u + K y` from `x0` is linear in `(B_K, K, x0)`, and its
    /// column for the unit vector `e_r` of each block is written to `ab` (column-major, `len`
    /// rows): `B_K = e_r` (columns `0..n`), then `u` itself if `d_required`, `K = e_r`,
    /// `x0 = e_r`.
    ///
    /// The `n` columns of a block come from one row recursion instead of `n` state recursions
    /// (spec §4.4: "equivalently by filtering u and y through `(zI - A_K)⁻¹`"): with
    /// `h_k = C A_Kᵏ`, the `B_K = e_r` output is `z_t[r]`, `z_t = Σ_{k<t} u_k h_{t-1-k}`, so
    /// `z_{t+1} = z_t A_K + u_t C` (`z_0 = 0`); likewise `w_{t+1} = w_t A_K + y_t C` for `K`,
    /// and `v_t = C A_Kᵗ`, `v_{t+1} = v_t A_K` (`v_0 = C`) for `x0`: `3n²` multiply-adds per
    /// sample instead of `3n (n² + n)`.
    #[inline(always)]
    fn columns(&self, n: usize, ab: &mut [f64]) {
        let (us, ys, d_required) = (self.us, self.ys, self.d_required);
        let len = us.len();
        let (ak, c) = (&self.ak[..n * n], &self.c[..n]);
        let d_off = usize::from(d_required);
        let (col_z, col_w, col_v) = (0, n + d_off, 2 * n + d_off);
        let (mut z, mut w, mut v) = (vec![0.0; n], vec![0.0; n], c.to_vec());
        let (mut zn, mut wn, mut vn) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for t in 0..len {
            let (ut, yt) = (us[t], ys[t]);
            for r in 0..n {
                ab[(col_z + r) * len + t] = z[r];
                ab[(col_w + r) * len + t] = w[r];
                ab[(col_v + r) * len + t] = v[r];
            }
            for j in 0..n {
                let (mut zj, mut wj, mut vj) = (ut * c[j], yt * c[j], 0.0);
                for i in 0..n {
                    let aij = ak[i * n + j];
                    zj += z[i] * aij;
                    wj += w[i] * aij;
                    vj += v[i] * aij;
                }
                (zn[j], wn[j], vn[j]) = (zj, wj, vj);
            }
            std::mem::swap(&mut z, &mut zn);
            std::mem::swap(&mut w, &mut wn);
            std::mem::swap(&mut v, &mut vn);
        }
        if d_required {
            ab[n * len..(n + 1) * len].copy_from_slice(us);
        }
    }

    /// [`Step6::columns`] for the compile-time state dimension `N`: the recursions' states in
    /// registers, the same operations in the same order (so the same bits).
    #[inline(always)]
    fn columns_fixed<const N: usize>(&self, ab: &mut [f64]) {
        let (ak, us, ys) = (self.ak, self.us, self.ys);
        let len = us.len().min(ys.len());
        let a: [[f64; N]; N] = std::array::from_fn(|i| std::array::from_fn(|j| ak[i * N + j]));
        let c: [f64; N] = std::array::from_fn(|j| self.c[j]);
        let d_off = usize::from(self.d_required);
        let (mut z, mut w, mut v) = ([0.0; N], [0.0; N], c);
        // the columns B_K, D (when estimated), K, x0 (and whatever follows x0)
        let (bk, rest) = ab.split_at_mut(N * len);
        let (dcol, rest) = rest.split_at_mut(d_off * len);
        let (kk, x0) = rest.split_at_mut(N * len);
        for t in 0..len {
            let (ut, yt) = (us[t], ys[t]);
            for r in 0..N {
                bk[r * len + t] = z[r];
                kk[r * len + t] = w[r];
                x0[r * len + t] = v[r];
            }
            let (mut zn, mut wn, mut vn) = ([0.0; N], [0.0; N], [0.0; N]);
            for j in 0..N {
                let (mut zj, mut wj, mut vj) = (ut * c[j], yt * c[j], 0.0);
                for i in 0..N {
                    zj += z[i] * a[i][j];
                    wj += w[i] * a[i][j];
                    vj += v[i] * a[i][j];
                }
                (zn[j], wn[j], vn[j]) = (zj, wj, vj);
            }
            (z, w, v) = (zn, wn, vn);
        }
        if self.d_required {
            dcol.copy_from_slice(&us[..len]);
        }
    }

    /// [`Step6::columns`] with the state dimension a compile-time constant for `n <= 4`.
    fn write(&self, n: usize, ab: &mut [f64]) {
        match n {
            1 => self.columns_fixed::<1>(ab),
            2 => self.columns_fixed::<2>(ab),
            3 => self.columns_fixed::<3>(ab),
            4 => self.columns_fixed::<4>(ab),
            _ => self.columns(n, ab),
        }
    }
}

/// Step 3's `W² = Zp Zpᵀ - (Zp Ufᵀ) pinv(Uf Ufᵀ) (Uf Zpᵀ)` from the Gram matrix of
/// `[Zp | Uf]` (`zp_cols` columns of Zp first).
///
/// When `Uf Ufᵀ = L Lᵀ` is provably well conditioned for the pseudo-inverse's cut
/// (`rtol = f ε`, as [`la::pinv`]: `cond(Uf Ufᵀ) = cond(L)² <= (‖L‖_F ‖L⁻¹‖_F)² < 1 / rtol`),
/// its pseudo-inverse is its inverse and `W² = Zp Zpᵀ - Xᵀ X` with `X = L⁻¹ (Uf Zpᵀ)`
/// (symmetric by construction, a Cholesky factor and a triangular inverse instead of an SVD);
/// otherwise (and on the reference route) the SVD pseudo-inverse. Test:
/// `fast_route_matches_the_reference`.
fn weight_squared(gram: &Mat<f64>, zp_cols: usize, route: Route) -> Result<Mat<f64>, IdError> {
    let gzz = gram.as_ref().get(..zp_cols, ..zp_cols);
    let gzu = gram.as_ref().get(..zp_cols, zp_cols..);
    let guu = gram.as_ref().get(zp_cols.., zp_cols..);
    let f = guu.nrows();
    let rtol = f as f64 * f64::EPSILON;
    let mut w2 = gzz.to_owned();
    let inverse_lt = (route == Route::Fast)
        .then(|| la::cholesky_lower(guu))
        .flatten()
        .and_then(|l| la::upper_inverse_if_well_conditioned(l.as_ref().transpose(), rtol.sqrt()));
    match inverse_lt {
        Some(l_inv_t) => {
            // X = L⁻¹ Uf Zpᵀ = (L⁻ᵀ)ᵀ gzuᵀ
            let x = la::mul(l_inv_t.as_ref().transpose(), gzu.transpose());
            la::mul_add(w2.as_mut(), x.as_ref().transpose(), x.as_ref(), -1.0);
        }
        None => {
            let guu_pinv = la::pinv(guu).ok_or_else(|| svd_failed("SVD of Uf Ufᵀ"))?;
            let t = la::mul(gzu, guu_pinv.as_ref());
            la::mul_add(w2.as_mut(), t.as_ref(), gzu.transpose(), -1.0);
        }
    }
    Ok(w2)
}

/// A factor `F` with `F Fᵀ = W²` for the weighted SVD: `Γ F` has the left singular vectors
/// and singular values of `Γ W` (both are the eigenvectors and square-rooted eigenvalues of
/// `Γ W² Γᵀ`), so any factor of `W²` serves. The Cholesky factor when `W²` is numerically
/// positive definite (one pass instead of an eigendecomposition; backward stable, see
/// [`la::cholesky_lower`]), else the symmetric square root of spec §4.4 with the tiny
/// negative eigenvalues clipped (rank-deficient past data, e.g. noise-free records).
/// Test: `fast_route_matches_the_reference`.
fn weight_factor(w2: faer::MatRef<'_, f64>) -> Result<Mat<f64>, IdError> {
    match la::cholesky_lower(w2) {
        Some(l) => Ok(l),
        None => la::sqrtm_psd(w2).ok_or_else(|| svd_failed("eigendecomposition of the weight")),
    }
}

impl ParsimK {
    fn run(&self, u: &[f64], y: &[f64], route: Route) -> Result<LinearFit, IdError> {
        self.run_with(u, &self.output(y), route)
    }

    /// What PARSIM-K computes from the output alone ([`Output`]): the grid's nodes share PV,
    /// so the nodes of a batch with the same identification window share it.
    fn output(&self, y: &[f64]) -> Output {
        let (f, p) = (self.p.f, self.p.p);
        let (mean, sd, ys) = scaled(y, self.p.center);
        let ncol = (y.len() + 1).saturating_sub(p + f);
        let yy = if ncol > 0 {
            ShiftedProducts::self_products(&ys, p + f, ncol)
        } else {
            Vec::new()
        };
        Output { mean, sd, ys, yy }
    }

    /// Step 4: the order, given or by the singular-value threshold (at most `max_order`, else
    /// `f`); an error when the weighted SVD has fewer non-zero singular values.
    fn order(&self, sv: &[f64]) -> Result<usize, IdError> {
        let prm = self.p;
        let f = prm.f;
        let n = if prm.n > 0 {
            prm.n
        } else {
            let cap = if prm.max_order == 0 { f } else { prm.max_order };
            let s0 = sv.first().copied().unwrap_or(0.0);
            sv.iter()
                .take(cap)
                .take_while(|&&s| s >= prm.threshold * s0 && s > 0.0)
                .count()
                .max(1)
        };
        if n > sv.len() || !(sv[n - 1] > 0.0) {
            return Err(singular(format!(
                "weighted SVD has fewer than {n} non-zero singular values ({sv:?})"
            )));
        }
        Ok(n)
    }

    fn run_with(&self, u: &[f64], out: &Output, route: Route) -> Result<LinearFit, IdError> {
        let prm = self.p;
        let (f, p) = (prm.f, prm.p);
        let len = out.ys.len();
        let (u_mean, su, us) = scaled(u, prm.center);
        let (y_mean, sy, ys) = (out.mean, out.sd, &out.ys);
        let ncol = len + 1 - p - f; // number of time columns N
                                    // --- Step 1 (transposed: one row per time t = p + j)
        let zp_cols = 2 * p;
        // Step 2 regressors [Zp | U_0 | Y_0], then the targets Y_0 .. Y_{f-1}, U_1 .. U_{f-1},
        // column-major in one buffer (one QR gives R and Qᵀ targets)
        let kreg = zp_cols + 2;
        let ntarg = 2 * f - 1;
        // (is_y, shift) of each column: the regressors, then the targets
        let cols: Vec<(bool, usize)> = (0..p)
            .map(|i| (false, i))
            .chain((0..p).map(|i| (true, i)))
            .chain([(false, p), (true, p)])
            .chain((0..f).map(|i| (true, p + i)))
            .chain((1..f).map(|i| (false, p + i)))
            .collect();
        // every column of steps 2 and 3 is a shift below p + f of u or y
        let products = ShiftedProducts::with_yy(&us, ys, out.yy.clone(), p + f, ncol);
        // Step 3 needs the Gram of [Zp | Uf] (Hankel structure, no product of the full data)
        let gram = hankel_gram(&products, p, f);

        // --- Step 2
        let sizes = [zp_cols + 1, kreg];
        let gram_step2 = match route {
            Route::Fast => step2_from_gram(&products, &cols, kreg),
            Route::Reference => None,
        };
        let ls = match gram_step2 {
            Some((r, qtb)) => PinvLs::from_r(r, qtb, ncol, &sizes)?,
            None => {
                let mut reg = Vec::with_capacity(ncol * (kreg + ntarg));
                for &(is_y, shift) in &cols {
                    let s = if is_y { ys } else { &us };
                    reg.extend_from_slice(&s[shift..shift + ncol]);
                }
                pinv_ls(&mut reg, ncol, kreg, &sizes)?
            }
        };
        let coef = |pi: &Mat<f64>, rhs: &[f64]| -> Vec<f64> {
            let s = pi.nrows();
            (0..s)
                .map(|r| (0..s).map(|c| pi[(r, c)] * rhs[c]).sum())
                .collect()
        };
        let col = |j: usize, s: usize| -> Vec<f64> { (0..s).map(|r| ls.qtb[(r, j)]).collect() };
        let mut gamma = Mat::<f64>::zeros(f, zp_cols);
        let mut h = vec![0.0; f]; // H_0 .. H_{f-1}
        let mut g = vec![0.0; f]; // G_1 .. G_{f-1} (g[0] unused)
        let th0 = coef(&ls.pinvs[0], &col(0, zp_cols + 1));
        for j in 0..zp_cols {
            gamma[(0, j)] = th0[j];
        }
        h[0] = th0[zp_cols];
        for i in 1..f {
            // projected target: Y_i - H_0 U_i - Σ_{j=1}^{i-1} (H_j U_{i-j} + G_j Y_{i-j})
            let mut rhs = col(i, kreg);
            let ui = col(f - 1 + i, kreg);
            for r in 0..kreg {
                rhs[r] -= h[0] * ui[r];
            }
            for j in 1..i {
                let uij = col(f - 1 + (i - j), kreg);
                let yij = col(i - j, kreg);
                for r in 0..kreg {
                    rhs[r] -= h[j] * uij[r] + g[j] * yij[r];
                }
            }
            let th = coef(&ls.pinvs[1], &rhs);
            for j in 0..zp_cols {
                gamma[(i, j)] = th[j];
            }
            h[i] = th[zp_cols];
            g[i] = th[zp_cols + 1];
        }

        // --- Step 3: W² = Zp Zpᵀ - (Zp Ufᵀ) pinv(Uf Ufᵀ) (Uf Zpᵀ), then the SVD of Γ W
        let w2 = weight_squared(&gram, zp_cols, route)?;
        let factor = match route {
            Route::Fast => weight_factor(w2.as_ref())?,
            Route::Reference => la::sqrtm_psd(w2.as_ref())
                .ok_or_else(|| svd_failed("eigendecomposition of the weight"))?,
        };
        let gw = la::mul(gamma.as_ref(), factor.as_ref());
        let (svd_u, sv) = match route {
            Route::Fast => la::left_svd(gw.as_ref()),
            Route::Reference => la::thin_svd(gw.as_ref()).map(|svd| (svd.u, svd.s)),
        }
        .ok_or_else(|| svd_failed("weighted SVD"))?;

        // --- Step 4: order
        let n = self.order(&sv)?;
        // --- Step 5: O = U_n Σ_n^{1/2}; C = O[0]; A_K = pinv(O[..f-1]) O[1..]
        let obs = Mat::<f64>::from_fn(f, n, |r, c| svd_u[(r, c)] * sv[c].sqrt());
        let c_s: Vec<f64> = (0..n).map(|j| obs[(0, j)]).collect();
        let o_up = obs.as_ref().get(..f - 1, ..);
        let o_dn = obs.as_ref().get(1.., ..);
        let ak_m = la::mul(
            la::pinv(o_up)
                .ok_or_else(|| svd_failed("SVD of the observability matrix"))?
                .as_ref(),
            o_dn,
        );
        let ak: Vec<Vec<f64>> = (0..n)
            .map(|i| (0..n).map(|j| ak_m[(i, j)]).collect())
            .collect();

        // --- Step 6: B_K, (D), K, x0 by least squares on the predictor output (all L samples)
        let npar = 3 * n + usize::from(prm.d_required);
        let ak_flat: Vec<f64> = ak.iter().flatten().copied().collect();
        let mut ab = vec![0.0; len * (npar + 1)];
        let step6 = Step6 {
            ak: &ak_flat,
            c: &c_s,
            us: &us,
            ys,
            d_required: prm.d_required,
        };
        step6.write(n, &mut ab);
        ab[npar * len..].copy_from_slice(ys);
        let ls6 = pinv_ls(&mut ab, len, npar, &[npar])?;
        let theta = coef(
            &ls6.pinvs[0],
            &(0..npar).map(|r| ls6.qtb[(r, 0)]).collect::<Vec<_>>(),
        );
        let mut idx = 0;
        let bk_s: Vec<f64> = theta[idx..idx + n].to_vec();
        idx += n;
        let d_s = if prm.d_required {
            idx += 1;
            theta[idx - 1]
        } else {
            0.0
        };
        let k_s: Vec<f64> = theta[idx..idx + n].to_vec();
        idx += n;
        let x0: Vec<f64> = theta[idx..idx + n].to_vec();

        // --- Step 7: unscale; A = A_K + K C, B = B_K + K D
        let structure = unscale(&ak, &c_s, (bk_s, d_s, k_s, x0), (su, sy))?;
        let mut fit = LinearFit::bare("ss", structure, u_mean, y_mean, None);
        fit.info.singular_values = sv;
        Ok(fit)
    }
}

/// Step 7 of PARSIM-K: the scaled estimates (`A_K`, `C`, and `B_K`, `D`, `K`, `x0` of step 6)
/// back in the data's units (`su`, `sy`), with `A = A_K + K C` and `B = B_K + K D`; an error
/// when a value is not finite.
fn unscale(
    ak: &[Vec<f64>],
    c_s: &[f64],
    (bk_s, d_s, k_s, x0): (Vec<f64>, f64, Vec<f64>, Vec<f64>),
    (su, sy): (f64, f64),
) -> Result<Structure, IdError> {
    let n = c_s.len();
    let bk: Vec<f64> = bk_s.iter().map(|v| v / su).collect();
    let d = d_s * sy / su;
    let k: Vec<f64> = k_s.iter().map(|v| v / sy).collect();
    let c: Vec<f64> = c_s.iter().map(|v| v * sy).collect();
    let a: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| ak[i][j] + k[i] * c[j]).collect())
        .collect();
    let b: Vec<f64> = (0..n).map(|i| bk[i] + k[i] * d).collect();
    if a.iter()
        .flatten()
        .chain(&b)
        .chain(&c)
        .chain(&k)
        .chain(&x0)
        .any(|v| !v.is_finite())
    {
        return Err(svd_failed("PARSIM-K (non-finite estimate)"));
    }
    Ok(Structure::StateSpace { a, b, c, d, k, x0 })
}

crate::linear_identifier! {
    ParsimK("ss") from ParsimKParams;
    description "state space (eq. 6, innovation form) by PARSIM-K subspace identification";
    orders {
        n: Int(2), "state dimension (0 = choose by the singular-value threshold)", |q| q.n;
        f: Int(10), "future horizon", |q| q.f;
        p: Int(10), "past horizon", |q| q.p;
        threshold: Real(0.1),
            "keep singular values >= threshold * largest (when n = 0)",
            |q| q.threshold;
        max_order: Int(0), "cap of the threshold rule (0 = f)", |q| q.max_order;
        d_required: Bool(false),
            "true = estimate a feedthrough D, false = D fixed to 0 (eq. 6)",
            |q| q.d_required;
        center: Bool(true),
            "true = subtract the means of u and y first, false = do not (SIPPY's default)",
            |q| q.center;
    }
    impl {
        fn min_samples(&self) -> usize {
            // N = L - p - f + 1 columns must exceed the 2p + 2 step-2 regressors
            let (f, p) = (self.p.f, self.p.p);
            (2 * p + 3) + p + f - 1
        }
        fn identify(&self, u: &[f64], y: &[f64]) -> Result<LinearFit, IdError> {
            check_data(u, y, self.min_samples())?;
            let mut fit = self.run(u, y, Route::Fast)?;
            fit.refresh_info(u, y)?;
            Ok(fit)
        }
        /// Identified one input at a time; the predictions of fits of order up to 4 run four at a
        /// time in SIMD lanes (`parsim/lanes.rs`, the same bits), the others one at a time; the
        /// prediction over the identification window is shared with the fit's diagnostics.
        fn identify_predict_many(
            &self,
            batch: crate::Batch<'_>,
        ) -> Vec<Result<crate::Identified, IdError>> {
            let (inputs, y, outs) = (batch.inputs, batch.output.y(), batch.outs);
            let split = batch.split.min(y.len());
            // the output's scaling and self-products, once per identification window
            let mut outputs: Vec<(usize, Output)> = Vec::new();
            let mut fits: Vec<Result<(LinearFit, usize), IdError>> = inputs
                .iter()
                .map(|&(start, u)| {
                    let start = crate::input_start(start, u, y, split)?;
                    let (u_id, y_id) = (&u[start..split], &y[start..split]);
                    check_data(u_id, y_id, self.min_samples())?;
                    let at = match outputs.iter().position(|(s, _)| *s == start) {
                        Some(at) => at,
                        None => {
                            outputs.push((start, self.output(y_id)));
                            outputs.len() - 1
                        }
                    };
                    Ok((self.run_with(u_id, &outputs[at].1, Route::Fast)?, start))
                })
                .collect();
            // the predictions: fits of one order up to 4 side by side, the others alone
            let mut predicted: Vec<Option<Result<(), IdError>>> = vec![None; inputs.len()];
            let mut by_order: [Vec<lanes::Lane<'_>>; 5] = Default::default();
            for (i, fit) in fits.iter_mut().enumerate() {
                let Ok((fit, start)) = fit else { continue };
                let (u, start) = (inputs[i].1, *start);
                outs[i].resize(y.len() - start, 0.0);
                let checked =
                    check_finite("u", &u[start..]).and_then(|()| check_finite("y", &y[start..]));
                let n = fit.structure().order();
                match checked {
                    Ok(()) if (1..=4).contains(&n) => by_order[n].push(lanes::Lane {
                        fit,
                        u,
                        start,
                        index: i,
                    }),
                    Ok(()) => {
                        predicted[i] =
                            Some(fit.predict_one_step_into(&u[start..], &y[start..], &mut outs[i]))
                    }
                    Err(e) => predicted[i] = Some(Err(e)),
                }
            }
            for (n, group) in by_order.iter_mut().enumerate() {
                group.sort_by_key(|lane| lane.start);
                for part in group.chunks(lanes::LANES) {
                    let members: [&lanes::Lane<'_>; lanes::LANES] =
                        std::array::from_fn(|l| &part[l.min(part.len() - 1)]);
                    let mut buf = crate::lanes::Scratch::zeroed(y.len());
                    match n {
                        1 => lanes::predict::<1>(members, y, &mut buf),
                        2 => lanes::predict::<2>(members, y, &mut buf),
                        3 => lanes::predict::<3>(members, y, &mut buf),
                        _ => lanes::predict::<4>(members, y, &mut buf),
                    }
                    for (l, lane) in part.iter().enumerate() {
                        let out = &mut outs[lane.index];
                        for (v, b) in out.iter_mut().zip(&buf[lane.start..]) {
                            *v = b[l];
                        }
                        predicted[lane.index] = Some(check_finite("estimate", out));
                    }
                }
            }
            drop(by_order);
            fits.into_iter()
                .zip(predicted)
                .enumerate()
                .map(|(i, (fit, predicted))| {
                    let (fit, start) = fit?;
                    let predicted = predicted.expect("every fit is predicted");
                    let record = (&inputs[i].1[start..], &y[start..]);
                    fit.diagnose_from_prediction(record, split - start, &outs[i], predicted)
                })
                .collect()
        }
    }
}

#[cfg(test)]
mod tests;
