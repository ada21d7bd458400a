//! ARX from normal equations assembled out of sums, for grid searches that identify ARX with
//! one output record and many inputs (spec §5: one identification per stiction node).
//!
//! Per record ([`Arx::output_sums`]): compensated prefix sums of the output and of its lagged
//! products `y(t) y(t-l)`, `l = 0..=n`, so every output block of the normal equations of any
//! window costs O(1), and a min/max segment tree of the output for the constancy test.
//!
//! Per input ([`ArxOutputSums::identify_window`]), over the regression rows
//! `t ∈ [from + n0, to)`, with `yc = y - shift` (the record mean) and
//! `u_j(t) = u(t - delay - j) - ū` (the window mean, from [`WindowStats`], which a caller
//! that scanned the window already hands on: [`ArxOutputSums::identify_window_with`]):
//!
//! 1. *Lag products, one fused pass.* Only the first row of each input block is summed
//!    over the rows: `Σ yc(t-i) u_1` (`i = 0..=n`), `Σ yc(t) u_j` (`j = 2..=m`),
//!    `Σ u_1 u_j` (`j = 1..=m`) and `Σ u_1`. Every other entry is the entry one lag up-left
//!    shifted one row back, `Σ_t f(t-1) = Σ_t f(t) + f(r0-1) - f(r1-1)`: e.g.
//!    `Σ yc(t-i) u_j = Σ yc(t-i+1) u_{j-1} + yc(r0-i) u_j(r0) - yc(r1-i) u_j(r1)` (two
//!    products per entry, exact up to their rounding). For ARX(2, 2) that is 6 products per
//!    row instead of the 9 of one dot product per entry.
//! 2. The centered Gram matrix (the intercept of [`Centering::OperatingPoint`]), scaled to
//!    unit diagonal, and a Cholesky factorization.
//! 3. *The residual sum of squares.* When the scaled Gram matrix is well conditioned
//!    (`d · trace(A⁻¹) <= 1e4`, `d` its order: a bound on its condition number from the
//!    factor) and the residual is not small against the output (`RSS >= 1e-6 · y_c'y_c`, the
//!    centered output's sum of squares), `RSS = y_c'y_c - ‖z‖²` with `L z = D X'y`, from the
//!    factor alone: the RSS is stationary at the solution, so the solve's error enters it
//!    squared. Measured on simulated loops with and without noise (ARX(2, 2), (1, 3) and
//!    (3, 3) delay 2; 24 669 node windows; `docs/decisions/2026-11-29-factor-sse.md`): under
//!    that bound the coefficients were within 1.9e-12 (relative to the largest) of the
//!    refined ones below, and the RSS, under any bound, within 1.1e-14 · y_c'y_c of theirs,
//!    so the fit in % within 1e-12 of a point (test `the_factor_sse_is_the_refined_one`).
//!    The bound keeps the coefficients, which the stability check and the validation error
//!    read, as accurate as the refinement makes them. Otherwise, one fused
//!    pass: the one-step residual `r` of the solution (with the intercept the centering
//!    implies, so `Σ r ≈ 0`) from the data: `Σ r`, `Σ r²` and the products `X' r`. They give
//!    one step of iterative refinement, so a residual small against the output (noise-free
//!    data) or a poorly conditioned matrix does not cost cond² · eps; and the residual sum
//!    of squares after the step without a second pass: with the centered residual `r_c`, the
//!    scaled centered regressors `Z` (`Z'Z = A = L L'`) and the step `dx` (`A dx = Z' r_c`),
//!    `‖r_c - Z dx‖² = ‖r_c‖² - 2 dx' Z' r_c + ‖L' dx‖²`. Every term is a sum from the data or
//!    a small quadratic form in the step, so it has the accuracy of a direct sum of squared
//!    residuals (no `y'y - θ'X'y` cancellation; test `the_sse_is_the_direct_one`). The fit's
//!    [`crate::FitInfo`] (`fit_pv`, `residual_variance`) is this one-step prediction's over
//!    the rows, as the QR path's; grid searches read the identification fit from it.
//!
//! The two passes hold their products in four lanes (one AVX register; pulp's runtime
//! dispatch as in `la.rs`, with a plain-array twin elsewhere that gives the same bits, test
//! `passes_give_the_same_bits_everywhere`); orders above (3, 3) take one dot product per
//! product instead of a fused pass.
//!
//! Normal equations square the condition number, so the solve is only trusted when every
//! column keeps at least 1e-3 of its sum of squares through the centering (otherwise it is
//! numerically constant over the rows: the QR reports it singular) and every pivot of the
//! scaled Cholesky factor satisfies `L_ii² >= GRAM_PIVOT_TOL` = 1e-4 (`L_ii` is the
//! column-equilibrated QR's relative pivot, so this asks for QR pivots >= 1e-2, eight decades
//! above the QR's own rank threshold 1e-10; with 1e-6 the grid-search fits differed from the
//! QR path's by up to 5e-9 relative on noise-free loops). Otherwise, and in every case the QR
//! path treats specially (constant output or input, a dropped intercept), it returns `None`
//! and the caller takes [`LinearIdentifier::identify`]. The model built here equals the QR's
//! to round-off (test `gram_fit_matches_the_qr` and the grid-search equivalence tests; on
//! the paper loop the surface fits agree with the sample path's to 3.3e-15 relative).
//!
//! [`LinearIdentifier::identify`]: crate::LinearIdentifier::identify

// Dense small-matrix code (Gram, Cholesky, triangular solves) reads best with index loops.
#![allow(clippy::needless_range_loop)]

use crate::arx::{Arx, Centering};
use crate::error::WindowStats;
use crate::{LinearFit, Structure};
use factor::{backward_solve, condition_bound, forward_solve, refined_sse};
pub(crate) use factor::{cholesky_in_place, cholesky_solve};
use faer::traits::pulp::{bytemuck, Arch, Simd, WithSimd};
pub use sse22::arx22_one_step_sse;
#[cfg(test)]
use sse22::Sse22Pass;

/// Smallest accepted squared pivot of the unit-diagonal Cholesky factor (see the module
/// documentation).
pub const GRAM_PIVOT_TOL: f64 = 1e-4;

/// A centered diagonal entry must keep this fraction of its uncentered value (see
/// `identify_window`).
const CENTERING_LOSS: f64 = 1e-3;

/// Largest `n + m` handled from sums (the Gram matrix lives on the stack).
pub(crate) const MAX_COLS: usize = 12;

/// Largest condition bound `d · trace(A⁻¹)` of the scaled Gram matrix whose factor alone gives
/// the RSS (module documentation, step 3).
const FACTOR_SSE_COND: f64 = 1e4;

/// Smallest `RSS / y_c'y_c` taken from the factor alone (module documentation, step 3).
const FACTOR_SSE_MIN: f64 = 1e-6;

/// What [`Arx::output_sums`] precomputes from the output record.
#[derive(Debug, Clone)]
pub struct ArxOutputSums {
    arx: Arx,
    /// The output minus `shift`.
    yc: Vec<f64>,
    /// Global mean subtracted before the products.
    shift: f64,
    /// `prefix[l][s] = Σ_{l <= r < s} yc(r) yc(r - l)` (hi and lo parts), `l = 0..=n`; `l = n+1`
    /// holds `Σ_{r < s} yc(r)`.
    prefix: Vec<Vec<(f64, f64)>>,
    /// Segment tree of the output's `[min, max]`: leaf `len + k` is sample `k`, node `p` covers
    /// its children `2p` and `2p + 1` (the constancy test of a window in O(log len)).
    extremes: Vec<[f64; 2]>,
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

/// Lane-wise dot product of `x` and `(y - sy)`.
#[inline]
fn dot_shifted(x: &[f64], y: &[f64], sy: f64) -> f64 {
    const L: usize = 8;
    let mut acc = [0.0; L];
    let (xc, yc) = (x.chunks_exact(L), y.chunks_exact(L));
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for l in 0..L {
            acc[l] += a[l] * (b[l] - sy);
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
    for (a, b) in xr.iter().zip(yr) {
        s += a * (b - sy);
    }
    s
}

/// The lag products of the regression rows `t ∈ [r0, r1)` that the input blocks of the
/// normal equations are assembled from (module documentation), with `yc` the shifted output
/// and `u_j(t) = u(t - delay - j) - u_mean`.
#[derive(Debug, Default)]
struct LagProducts {
    /// `Σ yc(t - i) u_1(t)`, `i = 0..=n`.
    yu: [f64; MAX_COLS + 1],
    /// `Σ yc(t) u_{1+l}(t)` at `l`, `l = 1..m` (`l = 0` is `yu[0]`, not stored).
    y0u: [f64; MAX_COLS],
    /// `Σ u_1(t) u_{1+l}(t)`, `l = 0..m`.
    uu: [f64; MAX_COLS],
    /// `Σ u_1(t)`.
    u: f64,
}

/// The one-step residual `r(t) = yc(t) - c + Σ a_i yc(t - i) - Σ b_j u_j(t)` of a solution
/// over the regression rows, and its products with the columns.
#[derive(Debug, Default)]
struct ResidualProducts {
    /// `Σ r`.
    sum: f64,
    /// `Σ r²`.
    sq: f64,
    /// `Σ r yc(t - i)` at `i - 1` (`i = 1..=n`), then `Σ r u_j` at `n + j - 1` (`j = 1..=m`).
    cols: [f64; MAX_COLS],
}

/// The regression rows' lagged columns, each resliced to the rows' count: `ys[i] = yc(t - i)`
/// for `i < NY` and `us[j] = u(t - delay - 1 - j)` for `j < NU`, `t ∈ [r0, r1)`.
#[allow(clippy::type_complexity)]
fn lagged<'a, const NY: usize, const NU: usize>(
    yc: &'a [f64],
    u: &'a [f64],
    delay: usize,
    (r0, r1): (usize, usize),
) -> ([&'a [f64]; NY], [&'a [f64]; NU]) {
    let len = r1 - r0;
    (
        std::array::from_fn(|i| &yc[r0 - i..][..len]),
        std::array::from_fn(|j| &u[r0 - delay - 1 - j..][..len]),
    )
}

/// Four rows side by side, and their arithmetic: the fused passes are written once against
/// this, and run either on an AVX register ([`Native`]) or on a plain array ([`Portable`]),
/// element-wise with the same operations in the same order (no fused multiply-add), so both
/// give the same bits. Four accumulators per product also keep the additions' latency hidden.
trait Quad: Copy {
    /// Four `f64`.
    type V: Copy;
    fn splat(self, v: f64) -> Self::V;
    /// The four samples of `x` (of length 4).
    fn load(self, x: &[f64]) -> Self::V;
    fn add(self, a: Self::V, b: Self::V) -> Self::V;
    fn sub(self, a: Self::V, b: Self::V) -> Self::V;
    fn mul(self, a: Self::V, b: Self::V) -> Self::V;
    fn lanes(self, a: Self::V) -> [f64; 4];

    /// The sum of the lanes, pairwise.
    #[inline(always)]
    fn sum(self, a: Self::V) -> f64 {
        let x = self.lanes(a);
        (x[0] + x[2]) + (x[1] + x[3])
    }

    /// `acc + a · b`, rounded twice.
    #[inline(always)]
    fn add_mul(self, acc: Self::V, a: Self::V, b: Self::V) -> Self::V {
        self.add(acc, self.mul(a, b))
    }
}

/// [`Quad`] on `[f64; 4]`.
#[derive(Debug, Clone, Copy)]
struct Portable;

impl Quad for Portable {
    type V = [f64; 4];
    #[inline(always)]
    fn splat(self, v: f64) -> [f64; 4] {
        [v; 4]
    }
    #[inline(always)]
    fn load(self, x: &[f64]) -> [f64; 4] {
        let mut a = [0.0; 4];
        a.copy_from_slice(x);
        a
    }
    #[inline(always)]
    fn add(self, a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        std::array::from_fn(|l| a[l] + b[l])
    }
    #[inline(always)]
    fn sub(self, a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        std::array::from_fn(|l| a[l] - b[l])
    }
    #[inline(always)]
    fn mul(self, a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        std::array::from_fn(|l| a[l] * b[l])
    }
    #[inline(always)]
    fn lanes(self, a: [f64; 4]) -> [f64; 4] {
        a
    }
}

/// [`Quad`] on an instruction set whose `f64` vectors have four lanes (AVX2: pulp's `V3`);
/// only built when `S::F64_LANES == 4`.
#[derive(Debug, Clone, Copy)]
struct Native<S>(S);

impl<S: Simd> Quad for Native<S> {
    type V = S::f64s;
    #[inline(always)]
    fn splat(self, v: f64) -> S::f64s {
        self.0.splat_f64s(v)
    }
    #[inline(always)]
    fn load(self, x: &[f64]) -> S::f64s {
        // one vector load (assembling it from scalars lets the compiler share the samples of
        // overlapping lags, and shuffle them into place)
        bytemuck::pod_read_unaligned(bytemuck::cast_slice(x))
    }
    #[inline(always)]
    fn add(self, a: S::f64s, b: S::f64s) -> S::f64s {
        self.0.add_f64s(a, b)
    }
    #[inline(always)]
    fn sub(self, a: S::f64s, b: S::f64s) -> S::f64s {
        self.0.sub_f64s(a, b)
    }
    #[inline(always)]
    fn mul(self, a: S::f64s, b: S::f64s) -> S::f64s {
        self.0.mul_f64s(a, b)
    }
    #[inline(always)]
    fn lanes(self, a: S::f64s) -> [f64; 4] {
        bytemuck::cast(a)
    }
}

/// Rows `[k, k + 4)` of the lagged columns, the input centered; rows past the rows' count
/// are zeros in both. `FULL`: the four rows exist (the passes' blocks before the last), so
/// no test for the padding.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn rows_at<Q: Quad, const NY: usize, const NU: usize, const FULL: bool>(
    q: Q,
    ys: &[&[f64]; NY],
    us: &[&[f64]; NU],
    u_mean: f64,
    k: usize,
) -> ([Q::V; NY], [Q::V; NU]) {
    let load = |x: &[f64], fill: f64| -> Q::V {
        if FULL {
            return q.load(&x[k..k + 4]);
        }
        match x.get(k..k + 4) {
            Some(four) => q.load(four),
            None => q.load(&std::array::from_fn::<_, 4, _>(|l| {
                x.get(k + l).copied().unwrap_or(fill)
            })),
        }
    };
    let um = q.splat(u_mean);
    (
        std::array::from_fn(|i| load(ys[i], 0.0)),
        std::array::from_fn(|j| q.sub(load(us[j], u_mean), um)),
    )
}

/// [`LagProducts`] in one pass over the rows, for `n = NY - 1` and `m = NU` known at compile
/// time (so the products stay in registers). Inlined into [`Dispatch`].
#[inline(always)]
fn lag_products_fixed<Q: Quad, const NY: usize, const NU: usize>(
    q: Q,
    pass: &LagPass<'_>,
) -> LagProducts {
    let (ys, us) = pass.lagged::<NY, NU>();
    let (u_mean, rows) = (pass.u_mean, pass.rows);
    let zero = q.splat(0.0);
    let (mut yu, mut y0u, mut uu, mut su) = ([zero; NY], [zero; NU], [zero; NU], zero);
    // (a macro, not a closure: a closure is compiled on its own, outside the dispatched code)
    macro_rules! add {
        ($rows:expr) => {{
            let (y, v) = $rows;
            su = q.add(su, v[0]);
            for i in 0..NY {
                yu[i] = q.add_mul(yu[i], y[i], v[0]);
            }
            for j in 1..NU {
                y0u[j] = q.add_mul(y0u[j], y[0], v[j]);
            }
            for j in 0..NU {
                uu[j] = q.add_mul(uu[j], v[0], v[j]);
            }
        }};
    }
    // the blocks of four rows, then the last one, whose padding adds zeros
    let len = rows.1 - rows.0;
    let full = len / 4 * 4;
    for k in (0..full).step_by(4) {
        add!(rows_at::<Q, NY, NU, true>(q, &ys, &us, u_mean, k));
    }
    if full < len {
        add!(rows_at::<Q, NY, NU, false>(q, &ys, &us, u_mean, full));
    }
    let mut p = LagProducts {
        u: q.sum(su),
        ..LagProducts::default()
    };
    for i in 0..NY {
        p.yu[i] = q.sum(yu[i]);
    }
    for j in 0..NU {
        p.y0u[j] = q.sum(y0u[j]);
        p.uu[j] = q.sum(uu[j]);
    }
    p
}

/// [`ResidualProducts`] in one pass over the rows, for `n = NY - 1` and `m = NU` known at
/// compile time; `x` holds `a_1..a_n, b_1..b_m`. Inlined into [`Dispatch`].
#[inline(always)]
fn residual_products_fixed<Q: Quad, const NY: usize, const NU: usize>(
    q: Q,
    lags: &LagPass<'_>,
    x: &[f64; MAX_COLS],
    c: f64,
) -> ResidualProducts {
    let (ys, us) = lags.lagged::<NY, NU>();
    let (u_mean, rows) = (lags.u_mean, lags.rows);
    let len = rows.1 - rows.0;
    let a: [Q::V; NY] = std::array::from_fn(|i| q.splat(if i == 0 { 1.0 } else { x[i - 1] }));
    let b: [Q::V; NU] = std::array::from_fn(|j| q.splat(x[NY - 1 + j]));
    let (cv, zero) = (q.splat(c), q.splat(0.0));
    let (mut sum, mut sq, mut ry, mut ru) = (zero, zero, [zero; NY], [zero; NU]);
    // (macros, not closures: a closure is compiled on its own, outside the dispatched code)
    macro_rules! residual {
        ($y:expr, $v:expr) => {{
            let (y, v) = ($y, $v);
            let mut r = q.sub(y[0], cv);
            for i in 1..NY {
                r = q.add_mul(r, a[i], y[i]);
            }
            for j in 0..NU {
                r = q.sub(r, q.mul(b[j], v[j]));
            }
            r
        }};
    }
    macro_rules! add {
        ($r:expr, $y:expr, $v:expr) => {{
            let (r, y, v) = ($r, $y, $v);
            sum = q.add(sum, r);
            sq = q.add_mul(sq, r, r);
            for i in 1..NY {
                ry[i] = q.add_mul(ry[i], r, y[i]);
            }
            for j in 0..NU {
                ru[j] = q.add_mul(ru[j], r, v[j]);
            }
        }};
    }
    // the blocks of four rows, then the last one
    let full = len / 4 * 4;
    for k in (0..full).step_by(4) {
        let (y, v) = rows_at::<Q, NY, NU, true>(q, &ys, &us, u_mean, k);
        add!(residual!(y, v), y, v);
    }
    if full < len {
        let (y, v) = rows_at::<Q, NY, NU, false>(q, &ys, &us, u_mean, full);
        // the padding's residual is -c: not a row
        let mut lanes = q.lanes(residual!(y, v));
        lanes[len - full..].fill(0.0);
        add!(q.load(&lanes), y, v);
    }
    let mut p = ResidualProducts {
        sum: q.sum(sum),
        sq: q.sum(sq),
        cols: [0.0; MAX_COLS],
    };
    for i in 1..NY {
        p.cols[i - 1] = q.sum(ry[i]);
    }
    for j in 0..NU {
        p.cols[NY - 1 + j] = q.sum(ru[j]);
    }
    p
}

/// Calls `$fixed::<n + 1, m>($args)` for the orders up to (3, 3), `$general` otherwise.
macro_rules! by_orders {
    ($n:expr, $m:expr, $fixed:ident($($arg:expr),*), $general:expr) => {
        match ($n, $m) {
            (0, 1) => $fixed::<_, 1, 1>($($arg),*),
            (0, 2) => $fixed::<_, 1, 2>($($arg),*),
            (0, 3) => $fixed::<_, 1, 3>($($arg),*),
            (1, 1) => $fixed::<_, 2, 1>($($arg),*),
            (1, 2) => $fixed::<_, 2, 2>($($arg),*),
            (1, 3) => $fixed::<_, 2, 3>($($arg),*),
            (2, 1) => $fixed::<_, 3, 1>($($arg),*),
            (2, 2) => $fixed::<_, 3, 2>($($arg),*),
            (2, 3) => $fixed::<_, 3, 3>($($arg),*),
            (3, 1) => $fixed::<_, 4, 1>($($arg),*),
            (3, 2) => $fixed::<_, 4, 2>($($arg),*),
            (3, 3) => $fixed::<_, 4, 3>($($arg),*),
            _ => $general,
        }
    };
}

/// A pass over the regression rows, written against [`Quad`].
trait RowsPass {
    type Output;
    fn run<Q: Quad>(self, q: Q) -> Self::Output;
}

/// A [`RowsPass`] compiled for the best instruction set of the machine (pulp's runtime
/// dispatch, as `la.rs`): on four `f64` lanes (AVX2) a [`Quad`] is one register, elsewhere an
/// array; the same bits either way.
struct Dispatch<P>(P);

impl<P: RowsPass> WithSimd for Dispatch<P> {
    type Output = P::Output;
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) -> P::Output {
        if S::F64_LANES == 4 {
            self.0.run(Native(simd))
        } else {
            self.0.run(Portable)
        }
    }
}

/// The [`LagProducts`] of an input over the rows.
struct LagPass<'a> {
    sums: &'a ArxOutputSums,
    u: &'a [f64],
    u_mean: f64,
    rows: (usize, usize),
}

impl<'a> LagPass<'a> {
    /// The rows' lagged columns ([`lagged`]).
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn lagged<const NY: usize, const NU: usize>(&self) -> ([&'a [f64]; NY], [&'a [f64]; NU]) {
        let (_, _, delay) = self.sums.arx.orders_tuple();
        lagged::<NY, NU>(&self.sums.yc, self.u, delay, self.rows)
    }
}

impl RowsPass for LagPass<'_> {
    type Output = LagProducts;
    #[inline(always)]
    fn run<Q: Quad>(self, q: Q) -> LagProducts {
        let (n, m, _) = self.sums.arx.orders_tuple();
        by_orders!(
            n,
            m,
            lag_products_fixed(q, &self),
            self.sums.lag_products(self.u, self.u_mean, self.rows)
        )
    }
}

/// The [`ResidualProducts`] of solution `x` with intercept `c` over the rows.
struct ResidualPass<'a> {
    lags: LagPass<'a>,
    x: &'a [f64; MAX_COLS],
    c: f64,
}

impl RowsPass for ResidualPass<'_> {
    type Output = ResidualProducts;
    #[inline(always)]
    fn run<Q: Quad>(self, q: Q) -> ResidualProducts {
        let ResidualPass { lags, x, c } = self;
        let (n, m, _) = lags.sums.arx.orders_tuple();
        by_orders!(
            n,
            m,
            residual_products_fixed(q, &lags, x, c),
            lags.sums
                .residual_products(lags.u, lags.u_mean, lags.rows, x, c)
        )
    }
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
        let len = y.len();
        let mut extremes = vec![[0.0; 2]; 2 * len];
        for (e, &v) in extremes[len..].iter_mut().zip(y) {
            *e = [v, v];
        }
        for p in (1..len).rev() {
            let (a, b) = (extremes[2 * p], extremes[2 * p + 1]);
            extremes[p] = [a[0].min(b[0]), a[1].max(b[1])];
        }
        Some(ArxOutputSums {
            arx: *self,
            yc,
            shift,
            prefix,
            extremes,
        })
    }
}

impl ArxOutputSums {
    /// The output is constant over `[from, to)` to [`crate::CONSTANT_SPREAD`] (the QR path's
    /// test), from the segment tree.
    fn output_constant(&self, from: usize, to: usize) -> bool {
        let len = self.yc.len();
        let (mut lo, mut hi) = (from + len, to + len);
        let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
        while lo < hi {
            if lo % 2 == 1 {
                min = min.min(self.extremes[lo][0]);
                max = max.max(self.extremes[lo][1]);
                lo += 1;
            }
            if hi % 2 == 1 {
                hi -= 1;
                min = min.min(self.extremes[hi][0]);
                max = max.max(self.extremes[hi][1]);
            }
            lo /= 2;
            hi /= 2;
        }
        crate::error::spread_is_constant(min, max)
    }

    /// `identify(&u[from..to], &y[from..to])` from sums, where `u` is an input over the whole
    /// record (same length as `y`). `None` when the caller must take the QR path instead:
    /// the Gram matrix is poorly conditioned (a pivot below [`GRAM_PIVOT_TOL`]), the window is
    /// too short, the output is constant there, the input is not finite, or the QR path would
    /// drop the intercept.
    ///
    /// The fit's diagnostics ([`LinearFit::info`]: `fit_pv`, `residual_variance`) are the
    /// one-step prediction's over the regression rows `[from + n0, to)`, from a pass over the
    /// data (module documentation), as the QR path's.
    pub fn identify_window(&self, u: &[f64], from: usize, to: usize) -> Option<LinearFit> {
        if to > u.len() || from >= to {
            return None;
        }
        let stats = WindowStats::of(&u[from..to])?;
        self.identify_window_with(u, from, to, &stats)
    }

    /// [`identify_window`](Self::identify_window) with the input window's statistics
    /// `stats = WindowStats::of(&u[from..to])` already at hand (a caller that scans the window
    /// for checks of its own saves the pass).
    pub fn identify_window_with(
        &self,
        u: &[f64],
        from: usize,
        to: usize,
        stats: &WindowStats,
    ) -> Option<LinearFit> {
        self.identify(u, from, to, stats, false).map(|(fit, _)| fit)
    }

    /// [`identify_window_with`](Self::identify_window_with); with `pass`, the residual pass
    /// and its refinement step even where the factor alone would give the RSS. Also returns
    /// whether the pass was taken.
    fn identify(
        &self,
        u: &[f64],
        from: usize,
        to: usize,
        stats: &WindowStats,
        pass: bool,
    ) -> Option<(LinearFit, bool)> {
        let (n, m, delay) = self.arx.orders_tuple();
        let yc = &self.yc;
        if u.len() != yc.len() || to > yc.len() || from >= to {
            return None;
        }
        let n0 = n.max(m + delay);
        let len = to - from;
        if len < n0 + n + m + 1 {
            return None;
        }
        debug_assert_eq!(
            WindowStats::of(&u[from..to]).as_ref(),
            Some(stats),
            "statistics of another window"
        );
        if !stats.is_finite() || stats.is_constant() || self.output_constant(from, to) {
            return None;
        }
        let d = n + m;
        let rows = (from + n0, to);
        let (r0, r1) = rows;
        let nrows = (r1 - r0) as f64;
        let u_mean = stats.sum / len as f64;
        let y_mean = self.shift + range(&self.prefix[n + 1], from, to) / len as f64;
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
        // the input blocks: the first row of each from the data, the rest by shifting the
        // rows one sample back (module documentation)
        let lags = || LagPass {
            sums: self,
            u,
            u_mean,
            rows,
        };
        let p = Arch::new().dispatch(Dispatch(lags()));
        let uc = |k: usize| u[k] - u_mean;
        sums[n + 1] = p.u;
        for i in 0..=n {
            g[i][n + 1] = p.yu[i];
        }
        for j in 1..=m {
            g[n + 1][n + j] = p.uu[j - 1];
        }
        for j in 2..=m {
            let (head, tail) = (r0 - delay - j, r1 - delay - j);
            sums[n + j] = sums[n + j - 1] + uc(head) - uc(tail);
            g[0][n + j] = p.y0u[j - 1];
            for i in 1..=n {
                g[i][n + j] = g[i - 1][n + j - 1] + yc[r0 - i] * uc(head) - yc[r1 - i] * uc(tail);
            }
            for j2 in j..=m {
                let (head2, tail2) = (r0 - delay - j2, r1 - delay - j2);
                g[n + j][n + j2] =
                    g[n + j - 1][n + j2 - 1] + uc(head) * uc(head2) - uc(tail) * uc(tail2);
            }
        }
        // center (the intercept) and symmetrise; a diagonal that loses more than three digits
        // to the centering (a column constant over the rows, or far from its shift) is left
        // to the QR, which reports what it makes of it
        center_products(&mut g, &sums, d, nrows)?;
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
        cholesky_in_place(&mut a, d)?;
        let z = forward_solve(&a, &rhs, d);
        let mut x = backward_solve(&a, &z, d);
        for k in 0..d {
            x[k] *= scale[k];
        }
        let y_ss = g[0][0];
        // the RSS from the factor where that is accurate, else from the data's residual with
        // one step of iterative refinement (module documentation, step 3)
        let factor_rss = y_ss - z[..d].iter().map(|v| v * v).sum::<f64>();
        let from_factor = !pass
            && factor_rss >= FACTOR_SSE_MIN * y_ss
            && condition_bound(&a, d) <= FACTOR_SSE_COND;
        let rss = if from_factor {
            factor_rss
        } else {
            let normal = Normal {
                l: &a,
                scale: &scale,
                sums: &sums,
                rows: nrows,
                n,
                d,
            };
            normal.refine(lags(), &mut x)
        };
        // intercept, as the QR path folds it (`arx.rs`): the column means over the rows, in
        // the QR path's coordinates (y centered by y_mean, u by u_mean)
        let col_mean = |a: usize| {
            if a <= n {
                sums[a] / nrows + self.shift - y_mean
            } else {
                sums[a] / nrows
            }
        };
        let c0 = col_mean(0)
            - (0..d)
                .map(|k| x[k] * sign(k + 1) * col_mean(k + 1))
                .sum::<f64>();
        if !rss.is_finite() || x[..d].iter().any(|v| !v.is_finite()) {
            return None;
        }
        let (structure, um, ym) = fold_intercept(&x[..d], n, delay, c0, (u_mean, y_mean))?;
        let fit = LinearFit::with_diagnostics("arx", structure, um, ym, len, n0, rss, y_ss);
        Some((fit, !from_factor))
    }

    /// [`LagProducts`] for orders without a fused pass: one dot product per product.
    fn lag_products(&self, u: &[f64], u_mean: f64, (r0, r1): (usize, usize)) -> LagProducts {
        let (n, m, delay) = self.arx.orders_tuple();
        let y = |i: usize| &self.yc[r0 - i..r1 - i];
        let u_lag = |j: usize| &u[r0 - delay - j..r1 - delay - j];
        let mut p = LagProducts::default();
        for i in 0..=n {
            p.yu[i] = dot_shifted(y(i), u_lag(1), u_mean);
        }
        let u1: Vec<f64> = u_lag(1).iter().map(|v| v - u_mean).collect();
        p.u = crate::la::sum(&u1);
        for l in 0..m {
            if l > 0 {
                p.y0u[l] = dot_shifted(y(0), u_lag(1 + l), u_mean);
            }
            p.uu[l] = dot_shifted(&u1, u_lag(1 + l), u_mean);
        }
        p
    }

    /// [`ResidualProducts`] for orders without a fused pass: the residual in a buffer, then
    /// one dot product per column.
    fn residual_products(
        &self,
        u: &[f64],
        u_mean: f64,
        (r0, r1): (usize, usize),
        x: &[f64; MAX_COLS],
        c: f64,
    ) -> ResidualProducts {
        let (n, m, delay) = self.arx.orders_tuple();
        let y = |i: usize| &self.yc[r0 - i..r1 - i];
        let u_lag = |j: usize| &u[r0 - delay - j..r1 - delay - j];
        let mut p = ResidualProducts::default();
        crate::la::with_buffer(r1 - r0, |res| {
            res.iter_mut().zip(y(0)).for_each(|(r, v)| *r = v - c);
            for i in 1..=n {
                for (r, v) in res.iter_mut().zip(y(i)) {
                    *r += x[i - 1] * v;
                }
            }
            for j in 1..=m {
                for (r, v) in res.iter_mut().zip(u_lag(j)) {
                    *r -= x[n + j - 1] * (v - u_mean);
                }
            }
            p.sum = crate::la::sum(res);
            p.sq = dot_shifted(res, res, 0.0);
            for i in 1..=n {
                p.cols[i - 1] = dot_shifted(res, y(i), 0.0);
            }
            for j in 1..=m {
                p.cols[n + j - 1] = dot_shifted(res, u_lag(j), u_mean);
            }
        });
        p
    }
}

/// The factored normal equations of a window (see [`ArxOutputSums::identify_window_with`]).
struct Normal<'a> {
    /// The Cholesky factor of the scaled, centered Gram matrix `A = D X'X D`.
    l: &'a [[f64; MAX_COLS]; MAX_COLS],
    /// `D`'s diagonal.
    scale: &'a [f64; MAX_COLS],
    /// The columns' sums over the rows (column 0 the output).
    sums: &'a [f64; MAX_COLS + 1],
    rows: f64,
    n: usize,
    d: usize,
}

impl Normal<'_> {
    /// One step of iterative refinement of the solution `x` (unscaled; updated) from the
    /// data's one-step residual, and the RSS after it (module documentation, step 3).
    fn refine(&self, lags: LagPass<'_>, x: &mut [f64; MAX_COLS]) -> f64 {
        let Normal {
            l,
            scale,
            sums,
            rows,
            n,
            d,
        } = *self;
        let sign = |a: usize| if (1..=n).contains(&a) { -1.0 } else { 1.0 };
        let intercept = (sums[0]
            - (0..d)
                .map(|k| x[k] * sign(k + 1) * sums[k + 1])
                .sum::<f64>())
            / rows;
        let res = Arch::new().dispatch(Dispatch(ResidualPass {
            lags,
            x,
            c: intercept,
        }));
        let mut rhs2 = [0.0; MAX_COLS];
        for k in 0..d {
            // centered: the intercept absorbs the residual's mean
            rhs2[k] = sign(k + 1) * (res.cols[k] - sums[k + 1] * res.sum / rows) * scale[k];
        }
        let dx = cholesky_solve(l, &rhs2, d);
        for k in 0..d {
            x[k] += dx[k] * scale[k];
        }
        refined_sse(&res, rows, l, &dx, &rhs2, d).max(0.0)
    }
}

/// The ARX polynomials from the solution `x = (a1..an, b1..bm)` and the intercept `c0`, which is
/// folded into the operating point as the QR path folds it (`arx.rs`): into the output mean
/// when `|A(1)| >= |B(1)|`, else into the input mean; `None` when both are 0.
fn fold_intercept(
    x: &[f64],
    n: usize,
    delay: usize,
    c0: f64,
    (u_mean, y_mean): (f64, f64),
) -> Option<(Structure, f64, f64)> {
    let mut a_poly = Vec::with_capacity(n + 1);
    a_poly.push(1.0);
    a_poly.extend_from_slice(&x[..n]);
    let a1: f64 = a_poly.iter().sum();
    let b1: f64 = x[n..].iter().sum();
    let (mut um, mut ym) = (u_mean, y_mean);
    if a1.abs() >= b1.abs() && a1 != 0.0 {
        ym += c0 / a1;
    } else if b1 != 0.0 {
        um -= c0 / b1;
    } else {
        return None;
    }
    let structure = Structure::Polynomial {
        a: a_poly,
        b: x[n..].to_vec(),
        c: vec![1.0],
        delay,
    };
    Some((structure, um, ym))
}

/// Center the column products `g` (the intercept) over `nrows` rows and symmetrise them; `None`
/// when a diagonal loses more than three digits to the centering (a column constant over the
/// rows, or far from its shift), which is left to the QR.
fn center_products(
    g: &mut [[f64; MAX_COLS + 1]; MAX_COLS + 1],
    sums: &[f64; MAX_COLS + 1],
    d: usize,
    nrows: f64,
) -> Option<()> {
    for a in 0..=d {
        let raw = g[a][a];
        let c = raw - sums[a] * sums[a] / nrows;
        if !(c > CENTERING_LOSS * raw) {
            return None;
        }
    }
    for a in 0..=d {
        for b in a..=d {
            let c = g[a][b] - sums[a] * sums[b] / nrows;
            g[a][b] = c;
            g[b][a] = c;
        }
    }
    Some(())
}

mod factor;
mod sse22;
#[cfg(test)]
mod tests;
