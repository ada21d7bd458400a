//! Linear identifiers for the process block (MV → PV) of the Hammerstein model.
//!
//! Five models of the paper (Bacci di Capaci & Scali, §2.2), one plugin trait
//! [`LinearIdentifier`], one fitted-model type [`LinearFit`]:
//!
//! | name | model | estimator | default orders |
//! |------|-------|-----------|----------------|
//! | `arx` | eq. 2 `A y = B u_{k-td} + e` | least squares, Householder QR | n = m = 2, delay 0 |
//! | `armax` | eq. 4 `A y = B u + C e` | recursive extended LS (Karra & Karim, no bias) | n = m = p = 2 |
//! | `earx` | eq. 7 `A y = B u + e + η_k` | decoupled recursive LS: θ and a time-varying bias β | n = m = 2 |
//! | `earmax` | eq. 8 `A y = B u + C e + η_k` | as earx with the C(q) part (a-posteriori residuals) | n = m = p = 2 |
//! | `ss` | eq. 6 innovation form (A, B, C, K, D = 0, x0) | PARSIM-K subspace | n = 2, f = p = 10 |
//!
//! ```
//! use linear_id::{Arx, LinearIdentifier};
//! let u: Vec<f64> = (0..200).map(|k| if (k / 7) % 2 == 0 { 1.0 } else { -1.0 }).collect();
//! let mut y = vec![0.0; 200];
//! for k in 2..200 {
//!     y[k] = 1.5 * y[k - 1] - 0.7 * y[k - 2] + 0.5 * u[k - 1] + 0.3 * u[k - 2];
//! }
//! let fit = Arx::params().n(2).m(2).delay(0).check()?.identify(&u, &y)?;
//! assert!((fit.static_gain() - 4.0).abs() < 1e-8);
//! let pv_est = fit.predict_one_step(&u, &y)?;
//! assert!(linear_id::fit_pv(&y[2..], &pv_est[2..]) > 99.999);
//! # Ok::<(), linear_id::IdError>(())
//! ```
//!
//! # Conventions
//!
//! * **Orders and delay** (paper eqs. 2-5): `A(q) = 1 + a1 q^-1 + … + an q^-n`,
//!   `B(q) = b1 q^-1 + … + bm q^-m` applied to `u_{k-delay}`: delay 0 means the first input lag
//!   is 1 (SIPPY's `theta`; its nk = 1 + delay). `C(q) = 1 + c1 q^-1 + … + cp q^-p`.
//!   [`Structure::Polynomial`] stores `a = [1, a1..]`, `b = [b1..]`, `c = [1, c1..]`, `delay`.
//! * **Centering**: every identifier works on data centered with the identification-window
//!   means and stores them ([`LinearFit::means`]); predictions are returned in raw units.
//!   ARX by default fits an intercept (each regression column centered over the regression
//!   rows) and folds it into the stored operating point, so noise-free ARX data with any
//!   offset is recovered exactly ([`Centering`]; `Centering::Mean` is SIPPY's "MeanVal").
//!   `ss` can skip centering (`center = false`, SIPPY's default) — needed for exact results
//!   on noise-free data, since sample means are not exactly in the static-gain ratio.
//! * **One-step prediction** ([`LinearFit::predict_one_step`]): measured PV lags, lags before
//!   sample 0 at the operating point, ε = 0 before the first full regressor; EARX/EARMAX keep
//!   running the bias recursion with θ frozen (spec §4.3 "use inside the grid search"),
//!   restarting from β = 0; `ss` runs the predictor form from the estimated `x0`.
//!   [`LinearFit::simulate`] is the deterministic free run (β̂ not added).
//! * **Stability** is reported, never silently assumed: [`LinearFit::is_stable`],
//!   [`LinearFit::is_predictor_stable`] (roots of C(q), eigenvalues of A − K C), and
//!   [`LinearFit::check_stable`] returns [`IdError::Unstable`] for the grid search to record.
//! * **Fit indices**: [`fit_pv`] / [`fit_mv`] are eqs. 9 and 14 with squared norms;
//!   [`e_g`] is eq. 13 on a grid of [`E_G_GRID_POINTS`] = 2048 frequencies over `[0, π]`
//!   (enough for `[0, 2π]` by conjugate symmetry of real models).
//! * **Errors**: degenerate data (constant u or y, too few samples for the orders, NaN,
//!   length mismatch, singular regression) give a typed [`IdError`], never a panic or NaN.
//! * **Numerics**: faer, always `Par::Seq` (deterministic, the grid search parallelises over
//!   nodes); least squares by Householder QR of the column-equilibrated augmented matrix
//!   `[Φ | y]` (rank deficient when a relative pivot < 1e-10); PARSIM-K uses QR + the
//!   pseudo-inverse of the small triangular factor (relative cut 1e-10), so rank-deficient
//!   noise-free data behave like SIPPY's `pinv`. Cross-checked against nalgebra in unit tests.
//!   Tall QRs (ARX with `n + m <= 15`, PARSIM-K's `N × (2p + 2f + 1)` step-2 and its step-6
//!   regressions) use our unblocked Householder on column-major slices, compiled through
//!   pulp's runtime SIMD dispatch (as faer); its loops use fixed lanes and no fused
//!   multiply-add, so results are the same bit for bit on every instruction set. Unit tests
//!   check it against faer's QR, and every closed form against its general route (roots of
//!   degree ≤ 2 and 2 × 2 eigenvalues vs the companion / real Schur eigenvalues, the
//!   triangular inverse vs the SVD pseudo-inverse, the Hankel Gram vs the product, ARX's
//!   QR diagnostics vs a full prediction).
//!
//! # Performance
//!
//! The grid search calls `identify`, `predict_one_step`, `simulate` and `check_stable` tens
//! of thousands of times, so each is kept allocation-light and O(N) passes over slices.
//! Instructions per call at N = 3000 with the default orders (`valgrind --tool=callgrind`,
//! `examples/profile_identify.rs`; deterministic) and divan medians
//! (`benches/identifiers.rs`, a loaded 2-core machine, so indicative only):
//!
//! | identifier | identify, instructions | identify, median | predict_one_step, instructions |
//! |------|------|------|------|
//! | `arx` | 0.29 M | 26 µs | 65 k |
//! | `armax` | 1.9 M | 165 µs | 0.25 M |
//! | `earx` | 1.2 M | 167 µs | 0.20 M |
//! | `earmax` | 2.1 M | 259 µs | 0.35 M |
//! | `ss` | 9.3 M | 0.91 ms | 0.17 M |
//!
//! * ARX takes its diagnostics (residual variance, F_PV on the identification window) from
//!   the QR (`ρ²` and the output column) instead of running a prediction.
//! * The recursive estimators run on fixed-size stack arrays for `d = n + m + p <= 8`; they
//!   are latency-bound (each step's divide and dot products depend on the previous step),
//!   so halving their instructions gains little wall-clock time.
//! * PARSIM-K: one QR of `[Zp | U_0 | Y_0 | targets]`, the Gram of `[Zp | Uf]` from its
//!   Hankel structure (`O((p + f) N)`), `R⁻¹` by back substitution when it is provably the
//!   pseudo-inverse (else the SVD), and the step-6 regressors in one pass of `3n` side-by-side
//!   predictor states.
//! * Polynomial prediction adds the A and B terms in one vectorised pass per coefficient;
//!   free runs and state-space runs have their orders as compile-time constants up to 3
//!   (polynomial) / 4 (state space); poles of degree ≤ 2 are closed form.
//!
//! # Recursive estimators (Karra & Karim) — decisions
//!
//! See [`RecursiveOptions`]: `P_θ(0) = 1e4 I`, λ_θ starts at 0.95 and tends to 1
//! (`λ_θ ← 0.99 λ_θ + 0.01`), `P_β(0) = 1e4`, constant bias forgetting λ_β, trace(P_θ) ≤ 1e8,
//! symmetrised P_θ, a-posteriori residuals as ELS regressors, θ(0) = 0, β(0) = 0. The
//! variable-forgetting rule of the original paper is not public (spec §7.6); these are ours.
//!
//! λ_β was chosen by a sweep on the paper's loop (plant eq. 10, PI 0.5/0.5, random-walk SP,
//! σ_e = 0.1, Kano valve S = 5, J = 2, 3000 samples, identified from the true MV, mean of 5
//! seeds; E_G in %, |gain − 1|):
//!
//! | λ_β | a = 0: E_G earx / earmax | a = 0.5: E_G earx / earmax | a = 0.5: gain err earx / earmax |
//! |-----|------|------|------|
//! | 0.7 | 93.8 / 93.6 | 95.9 / 94.8 | 0.030 / 0.035 |
//! | **0.8** | 95.9 / 94.9 | 95.7 / 93.5 | 0.035 / 0.043 |
//! | 0.9 (spec) | 97.7 / 96.3 | 90.4 / 87.5 | 0.053 / 0.062 |
//! | 0.95 | 98.3 / 97.0 | 83.7 / 82.8 | 0.079 / 0.081 |
//! | 0.99 | 98.6 / 97.5 | 75.4 / 77.9 | 0.111 / 0.111 |
//! | arx / armax | 98.6 / 97.5 | 74.8 / 76.8 | 0.035 / 0.046 |
//!
//! Default **λ_β = 0.8**: under the disturbance the extended models gain ≈ 20 points of E_G
//! over ARX/ARMAX, without it they lose ≈ 3 points. The static gain of ARX is already good in
//! this closed loop, so the extended models match it rather than beat it clearly (tests
//! `tests/recursive.rs` assert the E_G gap and "gain no worse than +0.01").
//!
//! # PARSIM-K — decisions
//!
//! Spec §4.4 with proper p-block past data (p ≠ f allowed), causality-enforcing row-wise
//! regressions sharing one QR, `W = (Zp Π⊥ Zpᵀ)^{1/2}` from Gram matrices and a symmetric
//! eigendecomposition, fixed order (default 2) or singular-value threshold, D = 0 unless
//! `d_required`, B_K/K/x0 by least squares on the predictor output over all samples. Horizons
//! default to f = p = 10 (SIPPY: 20) for speed. Matches SIPPY to 1e-13 on Markov parameters
//! (golden fixtures, p = f).
//!
//! # Grid-search reuse
//!
//! [`LinearIdentifier::prepare`] computes what depends only on PV once per search, for
//! [`LinearIdentifier::identify_prepared`] (ARX: the centered output) and for the batches of
//! [`LinearIdentifier::identify_predict_many`] ([`Batch::output`]; HARX: the notch's step
//! response and transient, and per identification window the filtered output and the
//! products of its regression columns). Thread-local state holds scratch buffers only (the
//! least-squares buffer, the SIMD lanes' buffers) and HARX's table of the notch's transient
//! at the last frequency solved (a function of ω alone).

// `!(x > 0.0)` is used on purpose: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod arx;
mod arx_sums;
#[doc(hidden)]
pub mod declare;
mod error;
mod fit;
mod harmonic;
mod harmonic_sums;
mod la;
mod lagged;
mod lanes;
mod model;
mod order;
mod parsim;
mod recursive;
mod registry;
#[cfg(test)]
mod test_data;

/// A computation for [`vectorized`]; its `run` must be `#[inline(always)]`, and so must what
/// it calls for the loops, so that they are compiled into the dispatched code.
pub trait Kernel {
    /// The result.
    type Output;
    /// The computation.
    fn run(self) -> Self::Output;
}

/// [`Kernel`] as pulp's [`WithSimd`](faer::traits::pulp::WithSimd).
struct KernelSimd<K>(K);

impl<K: Kernel> faer::traits::pulp::WithSimd for KernelSimd<K> {
    type Output = K::Output;
    #[inline(always)]
    fn with_simd<S: faer::traits::pulp::Simd>(self, _: S) -> K::Output {
        self.0.run()
    }
}

/// Runs `kernel` compiled for the best instruction set the processor has (pulp's runtime
/// dispatch, through faer, as this crate's fused passes are): a loop written lane-wise over
/// `f64` arrays and inlined into [`Kernel::run`] gets AVX2's four-wide registers where the
/// processor has them. The IEEE operations are the same either way (no multiply-add is fused
/// unless asked for), so are the bits. A kernel, not a closure: a closure's body is a
/// function of its own, which the compiler need not inline into the dispatched code (the
/// grid's validation SSE, called through a closure, ran on SSE2's two lanes).
#[inline(always)]
pub fn vectorized<K: Kernel>(kernel: K) -> K::Output {
    faer::traits::pulp::Arch::new().dispatch(KernelSimd(kernel))
}

pub use arx::{Arx, ArxParams, Centering};
pub use arx_sums::{arx22_one_step_sse, ArxOutputSums, GRAM_PIVOT_TOL};
pub use error::{IdError, WindowStats, CONSTANT_SPREAD};
pub use fit::{
    e_g, fit_mv, fit_percent_unsquared, fit_pv, frequency_grid, polynomial_frequency_response,
    E_G_GRID_POINTS,
};
pub use harmonic::{
    dominant_frequency, fft, Harx, HarxParams, Twiddles, HARX_MAX_OMEGA, HARX_MIN_OMEGA,
};
pub use lagged::{Larx, LarxParams, LARX_MAX_LAG};
pub use model::{BiasTracking, FitInfo, LinearFit, Structure, STABILITY_MARGIN};
pub use order::{OrderKind, OrderParseError, OrderValue};
pub use parsim::{ParsimK, ParsimKParams};
pub use recursive::{
    armax_batch, Armax, ArmaxParams, Earmax, EarmaxParams, Earx, EarxParams, RecursiveOptions,
};
pub use registry::{
    find_identifier, registry, resolve, BuildFn, IdentifierEntry, OrderSpec, ResolvedOrders,
};

/// Re-exported so that plugin crates use the same `inventory` as the registry.
pub use inventory;
/// Re-exported so that plugin crates use the same `typetag` as the trait.
pub use typetag;

use std::fmt;

/// A linear identifier: `(u, y)` data in, a fitted [`LinearFit`] out.
///
/// Object safe and serialisable through `typetag` (`{"kind": "arx", "n": 2, "m": 2,
/// "delay": 0}`); every implementation is also registered with an `inventory::submit!` of an
/// [`IdentifierEntry`] whose `name` equals the typetag name.
#[typetag::serde(tag = "kind")]
pub trait LinearIdentifier: Send + Sync + fmt::Debug {
    /// Registered name (equal to the typetag tag).
    fn name(&self) -> &'static str;

    /// The identifier's orders and options, in the order of its [`IdentifierEntry::orders`],
    /// each of its spec's type ([`OrderSpec::kind`]).
    fn orders(&self) -> Vec<(&'static str, OrderValue)>;

    /// Minimum number of samples `identify` accepts with these orders.
    fn min_samples(&self) -> usize;

    /// Identify a model from input `u` (MV) and output `y` (PV), equal lengths, finite.
    ///
    /// Both signals are centered with their means first (the model stores them). Errors:
    /// [`IdError::LengthMismatch`], [`IdError::TooFewSamples`], [`IdError::NonFinite`],
    /// [`IdError::ConstantInput`], [`IdError::Singular`], [`IdError::NotConverged`].
    /// Instability is *reported* by the fit ([`LinearFit::is_stable`],
    /// [`LinearFit::check_stable`]), not an error here.
    fn identify(&self, u: &[f64], y: &[f64]) -> Result<LinearFit, IdError>;

    /// Precompute what depends only on `y`, for repeated identification with different
    /// inputs and the same output (one call per grid search): for
    /// [`LinearIdentifier::identify_prepared`] and the batches of
    /// [`LinearIdentifier::identify_predict_many`].
    fn prepare(&self, y: &[f64]) -> Result<PreparedOutput, IdError> {
        Ok(PreparedOutput::plain(y))
    }

    /// Identify from a [`PreparedOutput`] of this identifier; same result as
    /// `identify(u, prepared.y())` up to round-off.
    fn identify_prepared(
        &self,
        prepared: &PreparedOutput,
        u: &[f64],
    ) -> Result<LinearFit, IdError> {
        self.identify(u, prepared.y())
    }

    /// For each input `(start, u)` of the batch (`u` as long as `y`, the output record
    /// `batch.output.y()`): [`LinearIdentifier::identify`] on `(u[start..split], y[start..split])`, then
    /// [`LinearFit::predict_one_step_into`] over `(u[start..], y[start..])` into the matching
    /// buffer of `outs` (resized to `y.len() - start`), whatever the fit's stability (`split`
    /// and `start` are clamped to the length). Grid searches call it with the nodes that share
    /// an output record, each from the sample its valve's initial state washed out. The
    /// results are bit for bit those of the two calls, which the default makes. Overrides save
    /// work: the recursive identifiers run four inputs side by side in SIMD lanes, and they
    /// and PARSIM-K take the fit's diagnostics from the prediction's identification window
    /// instead of predicting that window twice.
    fn identify_predict_many(&self, batch: Batch<'_>) -> Vec<Result<Identified, IdError>> {
        let (inputs, y, split, outs) = (batch.inputs, batch.output.y(), batch.split, batch.outs);
        inputs
            .iter()
            .zip(outs.iter_mut())
            .map(|(&(start, u), out)| identify_then_predict(self, (start, u), y, split, out))
            .collect()
    }

    /// The identifier's optional fast paths ([`FastPaths`]), if it has any (`None` by
    /// default: every fit is a regression of its own).
    fn fast_paths(&self) -> Option<&dyn FastPaths> {
        None
    }

    /// The relative cost of identifying from one sample, for the grid search's work budget
    /// (`grid_search::budget`: nodes × samples × this cost must stay under it). The default is
    /// p² for p the sum of the integer orders other than `delay` (at least 1): a recursive
    /// least-squares update
    /// and a Gram matrix both cost p² per sample (measured with ARMAX:
    /// `docs/decisions/2026-11-27-long-records-and-fuzz.md`).
    fn cost_per_sample(&self) -> f64 {
        let p: usize = self
            .orders()
            .iter()
            .filter(|(name, _)| *name != "delay")
            .map(|(_, v)| match v {
                OrderValue::Int(n) => *n,
                _ => 0,
            })
            .sum();
        let p = p.max(1) as f64;
        p * p
    }

    /// A boxed copy.
    fn box_clone(&self) -> Box<dyn LinearIdentifier>;
}

/// Optional fast paths of a [`LinearIdentifier`], reached through
/// [`LinearIdentifier::fast_paths`]; the fits are those of the plain methods.
pub trait FastPaths {
    /// The output's sums from which the fit on any window of an input comes without a
    /// regression ([`ArxOutputSums::identify_window`]; grid searches then fit node by node from
    /// them), or `None` when these orders and options or `y` do not allow it.
    fn output_sums(&self, y: &[f64]) -> Option<ArxOutputSums>;
}

/// One input's result from [`LinearIdentifier::identify_predict_many`]: the fit, and whether
/// its one-step prediction over the whole record came out (the error
/// [`LinearFit::predict_one_step_into`] gives otherwise).
#[derive(Debug, Clone)]
pub struct Identified {
    /// The model identified on the first `split` samples.
    pub fit: LinearFit,
    /// `Ok` when the prediction in the caller's buffer is complete and finite.
    pub prediction: Result<(), IdError>,
}

/// The inputs of [`LinearIdentifier::identify_predict_many`]: the MV records `(start, u)` that
/// share one output record, and a prediction buffer for each.
#[derive(Debug)]
pub struct Batch<'a> {
    /// The inputs `(start, u)`, each `u` as long as the output, fit from sample `start`.
    pub inputs: &'a [(usize, &'a [f64])],
    /// The output record (`output.y()`) with what the identifier's
    /// [`LinearIdentifier::prepare`] computed from it once for all the batches of a search
    /// (any other [`PreparedOutput`] of the same record, e.g. [`PreparedOutput::plain`], gives
    /// the same results, computing that part batch by batch).
    pub output: &'a PreparedOutput,
    /// The end of the identification windows (clamped to `y.len()`).
    pub split: usize,
    /// One buffer per input, for its one-step prediction from its start.
    pub outs: &'a mut [Vec<f64>],
}

/// One input of [`LinearIdentifier::identify_predict_many`]: its start clamped to `split`
/// (itself at most `y.len()`), or the error of an input not as long as the output.
pub(crate) fn input_start(
    start: usize,
    u: &[f64],
    y: &[f64],
    split: usize,
) -> Result<usize, IdError> {
    if u.len() != y.len() {
        return Err(IdError::LengthMismatch {
            u: u.len(),
            y: y.len(),
        });
    }
    Ok(start.min(split))
}

/// [`LinearIdentifier::identify_predict_many`] for an identifier whose fit comes out of
/// `fit_bare` without its diagnostics: each input's fit on its identification window, its
/// one-step prediction over the record, and the diagnostics from that prediction's
/// identification window instead of a second prediction of it (HARX, LARX).
pub(crate) fn predict_many_from_bare(
    batch: Batch<'_>,
    fit_bare: impl Fn(&[f64], &[f64]) -> Result<LinearFit, IdError>,
) -> Vec<Result<Identified, IdError>> {
    predict_many_with(batch, |_, (u, y), window, out| {
        let fit = fit_bare(&u[..window], &y[..window])?;
        let predicted = fit.predict_one_step_into(u, y, out);
        Ok((fit, predicted))
    })
}

/// [`predict_many_from_bare`] with `fit_predict(start, (u, y), window, out)` giving each
/// input's fit on `(u[..window], y[..window])` (`u` and `y` from the input's clamped `start`)
/// and its one-step prediction of all of `y` in `out` (with the outcome
/// [`LinearFit::predict_one_step_into`] gives).
#[allow(clippy::type_complexity)]
pub(crate) fn predict_many_with(
    batch: Batch<'_>,
    fit_predict: impl Fn(
        usize,
        (&[f64], &[f64]),
        usize,
        &mut [f64],
    ) -> Result<(LinearFit, Result<(), IdError>), IdError>,
) -> Vec<Result<Identified, IdError>> {
    let Batch {
        inputs,
        output,
        split,
        outs,
    } = batch;
    let y = output.y();
    inputs
        .iter()
        .zip(outs.iter_mut())
        .map(|(&(start, u), out)| {
            let split = split.min(y.len());
            let start = input_start(start, u, y, split)?;
            out.resize(y.len() - start, 0.0);
            let (u, y) = (&u[start..], &y[start..]);
            let (fit, predicted) = fit_predict(start, (u, y), split - start, out)?;
            fit.diagnose_from_prediction((u, y), split - start, out, predicted)
        })
        .collect()
}

/// The default of [`LinearIdentifier::identify_predict_many`] for one input.
fn identify_then_predict<I: LinearIdentifier + ?Sized>(
    identifier: &I,
    (start, u): (usize, &[f64]),
    y: &[f64],
    split: usize,
    out: &mut Vec<f64>,
) -> Result<Identified, IdError> {
    let split = split.min(y.len());
    let start = input_start(start, u, y, split)?;
    let fit = identifier.identify(&u[start..split], &y[start..split])?;
    out.resize(y.len() - start, 0.0);
    let prediction = fit.predict_one_step_into(&u[start..], &y[start..], out);
    Ok(Identified { fit, prediction })
}

impl Clone for Box<dyn LinearIdentifier> {
    fn clone(&self) -> Self {
        self.box_clone()
    }
}

/// The output record plus whatever an identifier precomputed from it
/// ([`LinearIdentifier::prepare`]).
pub struct PreparedOutput {
    y: Vec<f64>,
    cache: Option<Box<dyn std::any::Any + Send + Sync>>,
}

impl fmt::Debug for PreparedOutput {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PreparedOutput")
            .field("len", &self.y.len())
            .field("cached", &self.cache.is_some())
            .finish()
    }
}

impl PreparedOutput {
    /// Just the output, nothing precomputed.
    pub fn plain(y: &[f64]) -> Self {
        PreparedOutput {
            y: y.to_vec(),
            cache: None,
        }
    }
    /// The output with an identifier-specific cache.
    pub fn with_cache(y: &[f64], cache: Box<dyn std::any::Any + Send + Sync>) -> Self {
        PreparedOutput {
            y: y.to_vec(),
            cache: Some(cache),
        }
    }
    /// The output record.
    pub fn y(&self) -> &[f64] {
        &self.y
    }
    /// The cache, if it has type `T`.
    pub fn cache<T: 'static>(&self) -> Option<&T> {
        self.cache.as_ref().and_then(|c| c.downcast_ref::<T>())
    }
}

/// Identification-window mean of a signal.
pub(crate) fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        x.iter().sum::<f64>() / x.len() as f64
    }
}
