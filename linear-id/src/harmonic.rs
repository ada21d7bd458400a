//! HARX: ARX with a harmonic (sinusoidal) disturbance of known frequency, and the periodogram
//! peak that finds such a frequency.
//!
//! A sinusoidal disturbance at ω in `A(q) y = B(q) u + d + e` (an external oscillation, at the
//! output or inside the loop: `A(q)` keeps it a sinusoid at ω) is annihilated by
//! `N(q) = 1 − 2 cos ω q⁻¹ + q⁻²` whatever its amplitude and phase. Filtering both signals
//! with `N` alone would colour the noise (`N e`, a moving average with zeros on the unit
//! circle, six times white noise's variance at low ω), so HARX uses the notch filter
//! `L(q) = N(q) / N(q/ρ)`, `N(q/ρ) = 1 − 2ρ cos ω q⁻¹ + ρ² q⁻²`: zero gain at ω, close to 1
//! away from it, and the ARX of the filtered signals `A(q) (L y) = B(q) (L u) + e` has white
//! residuals again, the sinusoid gone after the filter's transient. The pole radius
//! `ρ = 1 − ω/4` gives a notch about ω/2 wide: narrow beside the process's band for the
//! periods of 8 samples and more that are sought, wide enough to follow an oscillation whose
//! amplitude drifts over a few periods. This is to a sinusoid what EARX's random-walk bias is
//! to a drift. The one-step predictor follows from `L y_k = y_k + (terms in the past)`; the
//! process (poles, gain, free-run simulation) is `B / A`, and the simulation does not contain
//! the disturbance, which is only known through the measured output.

use crate::arx::MAX_DELAY;
use crate::error::{check_data, check_order, check_real};
use crate::{mean, IdError, LinearFit, LinearIdentifier, Structure};

/// The notch's pole radius for frequency ω (module docs).
pub(crate) fn pole_radius(omega: f64) -> f64 {
    (1.0 - omega / 4.0).clamp(0.5, 0.998)
}

/// `L(q) (x − centre)` from a zero state, full length (module docs).
pub(crate) fn notch_filter(x: &[f64], centre: f64, omega: f64) -> Vec<f64> {
    let (c, rho) = (omega.cos(), pole_radius(omega));
    let mut out = vec![0.0; x.len()];
    let (mut x1, mut x2, mut f1, mut f2) = (0.0, 0.0, 0.0, 0.0);
    for (o, &v) in out.iter_mut().zip(x) {
        let x0 = v - centre;
        let f0 = x0 - 2.0 * c * x1 + x2 + 2.0 * rho * c * f1 - rho * rho * f2;
        *o = f0;
        (x2, x1, f2, f1) = (x1, x0, f1, f0);
    }
    out
}

/// `L(1)`, the notch's gain at zero frequency.
fn dc_gain(omega: f64) -> f64 {
    let (c, rho) = (omega.cos(), pole_radius(omega));
    (2.0 - 2.0 * c) / (1.0 - 2.0 * rho * c + rho * rho)
}

crate::declare::identifier_params! {
    /// ARX with a harmonic disturbance at a known frequency ω,
    /// `A(q) y_k = B(q) u_{k-delay} + d_k + e_k` with `d` any sinusoid at ω, identified as the
    /// ARX of the notch-filtered signals (module docs).
    ///
    /// | name | default | meaning | valid range |
    /// |------|---------|---------|-------------|
    /// | `n` | 2 | order of A(q) | 0 ..= 50 |
    /// | `m` | 2 | order of B(q) | 1 ..= 50 |
    /// | `delay` | 0 | dead time `t_d` in samples | 0 ..= 10000 |
    /// | `omega` | 0.05 | the disturbance's frequency, rad/sample | [0.005, 3.1] |
    ///
    /// The frequency is not estimated here: a caller that does not know it takes the dominant
    /// frequency of a model's residuals ([`dominant_frequency`]), as `stiction diagnose` does.
    pub struct Harx;
    /// Unchecked parameters of [`Harx`]; [`HarxParams::check`] builds the identifier.
    pub struct HarxParams {
        /// Order of A(q).
        n: usize = 2,
        /// Order of B(q).
        m: usize = 2,
        /// Dead time in samples.
        delay: usize = 0,
        /// Frequency of the harmonic disturbance, rad/sample.
        omega: f64 = 0.05,
    }
    check |p| {
        check_order("harx", "n", p.n, 0, crate::arx::MAX_ORDER)?;
        check_order("harx", "m", p.m, 1, crate::arx::MAX_ORDER)?;
        check_order("harx", "delay", p.delay, 0, MAX_DELAY)?;
        check_real("harx", "omega", p.omega, HARX_MIN_OMEGA, HARX_MAX_OMEGA)?;
    }
}

/// Smallest accepted ω: a period of about 1250 samples (below it `N(q)` tends to the double
/// difference, and EARX's bias is the model for such drifts).
pub const HARX_MIN_OMEGA: f64 = 0.005;
/// Largest accepted ω (just below the Nyquist frequency π).
pub const HARX_MAX_OMEGA: f64 = 3.1;

impl Harx {
    /// The disturbance's frequency, rad/sample.
    pub fn omega(&self) -> f64 {
        self.omega
    }

    /// `(n, m, delay)`.
    pub(crate) fn orders_tuple(&self) -> (usize, usize, usize) {
        (self.n, self.m, self.delay)
    }
}

thread_local! {
    /// The notch's transient `(ρ^k cos ωk, ρ^k sin ωk)` for `k = 0, 1, ...` at the frequency
    /// of the last HARX solved by QR on this thread (a function of ω alone, no data): a grid
    /// search solves thousands of regressions at one ω, and one sine, cosine and power per
    /// row were most of each (a disturbance + dead-time diagnosis: 14 % of its CPU time). The
    /// batches take it from the prepared output instead (`harmonic_sums.rs`).
    static TRANSIENT: std::cell::RefCell<(u64, Vec<(f64, f64)>)> =
        const { std::cell::RefCell::new((0, Vec::new())) };
}

/// The notch's transient pair `(ρ^k cos ωk, ρ^k sin ωk)` at frequency `omega` (pole radius
/// `rho`), computed as `(ρ.powf(k) · cos ωk, ρ.powf(k) · sin ωk)`.
pub(crate) fn transient_pair(omega: f64, rho: f64, k: usize) -> (f64, f64) {
    let k = k as f64;
    let decay = rho.powf(k);
    let (sn, cs) = (omega * k).sin_cos();
    (decay * cs, decay * sn)
}

/// Run `f` on the transient pairs `k = 0..len` at frequency `omega` (pole radius `rho`,
/// [`transient_pair`]), cached per thread.
pub(crate) fn with_transient<R>(
    omega: f64,
    rho: f64,
    len: usize,
    f: impl FnOnce(&[(f64, f64)]) -> R,
) -> R {
    let pair = |k: usize| transient_pair(omega, rho, k);
    TRANSIENT.with(|cell| match cell.try_borrow_mut() {
        Ok(mut cache) => {
            let (key, pairs) = &mut *cache;
            if *key != omega.to_bits() {
                *key = omega.to_bits();
                pairs.clear();
            }
            for k in pairs.len()..len {
                pairs.push(pair(k));
            }
            f(&pairs[..len])
        }
        // re-entrant use: computed afresh
        Err(_) => f(&(0..len).map(pair).collect::<Vec<_>>()),
    })
}

impl Harx {
    /// Least squares of the filtered signals: `L y_k` on `-L y_{k-i}` (i = 1..n),
    /// `L u_{k-delay-j}` (j = 1..m), an intercept and the filter's transient
    /// `ρ^k cos ωk`, `ρ^k sin ωk` (what a sinusoid leaves after `L` from a zero state, at any
    /// amplitude and phase). Returns the model and the intercept.
    fn solve(&self, uf: &[f64], yf: &[f64]) -> Result<(Structure, f64), IdError> {
        let (n, m, delay) = (self.n, self.m, self.delay);
        let n0 = n.max(m + delay);
        let len = yf.len();
        let rows = len - n0;
        let d = n + m + 3;
        let rho = pole_radius(self.omega);
        let mut ab = vec![0.0; rows * (d + 1)];
        let mut cols = ab.chunks_exact_mut(rows);
        for i in 1..=n {
            let col = cols.next().unwrap_or_default();
            for (dst, &v) in col.iter_mut().zip(&yf[n0 - i..len - i]) {
                *dst = -v;
            }
        }
        for j in 1..=m {
            let lag = delay + j;
            let col = cols.next().unwrap_or_default();
            col.copy_from_slice(&uf[n0 - lag..len - lag]);
        }
        cols.next().unwrap_or_default().fill(1.0);
        let (cos_col, sin_col) = (cols.next().unwrap_or_default(), cols.next());
        let sin_col = sin_col.unwrap_or_default();
        with_transient(self.omega, rho, n0 + rows, |transient| {
            let pairs = &transient[n0..n0 + rows];
            for ((c, s), &(tc, ts)) in cos_col.iter_mut().zip(sin_col.iter_mut()).zip(pairs) {
                *c = tc;
                *s = ts;
            }
        });
        cols.next().unwrap_or_default().copy_from_slice(&yf[n0..]);
        let sol = crate::la::lstsq_colmajor(&mut ab, rows, d + 1).map_err(|pivot| {
            IdError::Singular {
                identifier: "harx",
                detail: format!(
                    "regression matrix {rows}x{d} of the signals notched at {:.4} rad/sample: smallest relative QR pivot {pivot:.3e} < 1e-10",
                    self.omega
                ),
            }
        })?;
        let mut a = Vec::with_capacity(n + 1);
        a.push(1.0);
        a.extend_from_slice(&sol.x[..n]);
        let structure = Structure::Polynomial {
            a,
            b: sol.x[n..n + m].to_vec(),
            c: vec![1.0],
            delay,
        };
        Ok((structure, sol.x[n + m]))
    }
}

crate::linear_identifier! {
    Harx("harx") from HarxParams;
    description "ARX with a sinusoidal disturbance of frequency omega (ARX of the signals notch-filtered at omega)";
    orders {
        n: Int(2), crate::Arx::ORDERS[0].meaning, |p| p.n;
        m: Int(2), crate::Arx::ORDERS[1].meaning, |p| p.m;
        delay: Int(0), crate::Arx::ORDERS[2].meaning, |p| p.delay;
        omega: Real(0.05),
            "frequency of the sinusoidal disturbance, rad/sample (2 pi / period in samples)",
            |p| p.omega;
    }
    impl {
        fn min_samples(&self) -> usize {
            // strictly more equations than the regression's n + m + 3 unknowns (intercept and
            // the notch's transient pair)
            self.n.max(self.m + self.delay) + self.n + self.m + 4
        }
        /// The notch's step response and transient over the record, and the output's side of
        /// the normal equations per identification window as batches ask for it
        /// (`harmonic_sums.rs`).
        fn prepare(&self, y: &[f64]) -> Result<crate::PreparedOutput, IdError> {
            Ok(crate::PreparedOutput::with_cache(
                y,
                Box::new(crate::harmonic_sums::HarxOutput::new(self, y)),
            ))
        }
        crate::declare::identify_from_bare!(fit_bare, many |this, batch| {
            crate::harmonic_sums::identify_predict_many(this, batch)
        });
    }
}

impl Harx {
    /// The fitted model without its diagnostics (`info` not computed).
    pub(crate) fn fit_bare(&self, u: &[f64], y: &[f64]) -> Result<LinearFit, IdError> {
        check_data(u, y, self.min_samples())?;
        let (um, ym) = (mean(u), mean(y));
        let (uf, yf) = (
            notch_filter(u, um, self.omega),
            notch_filter(y, ym, self.omega),
        );
        let (structure, c0) = self.solve(&uf, &yf)?;
        Ok(self.folded(structure, c0, (um, ym)))
    }

    /// The fit from the filtered regression's model and intercept `c0`, the signals having
    /// been centred by their window means `(um, ym)`.
    pub(crate) fn folded(&self, structure: Structure, c0: f64, (um, ym): (f64, f64)) -> LinearFit {
        // the intercept c0 of the filtered regression is the operating point's offset,
        // times A(1) (or -B(1)) and the notch's gain L(1)
        let Structure::Polynomial { a, b, .. } = &structure else {
            unreachable!("harx builds a polynomial model")
        };
        let (a1, b1): (f64, f64) = (a.iter().sum(), b.iter().sum());
        let gain = dc_gain(self.omega);
        let (mut u_op, mut y_op) = (um, ym);
        if a1.abs() >= b1.abs() && a1 != 0.0 {
            y_op += c0 / a1 / gain;
        } else if b1 != 0.0 {
            u_op -= c0 / b1 / gain;
        }
        let mut fit = LinearFit::bare("harx", structure, u_op, y_op, None);
        fit.harmonic = Some(self.omega);
        fit
    }
}

/// Golden-section steps of the frequency refinement (the bracket of two Fourier steps shrinks
/// by 0.618 per step, to 0.3 % of it).
const GOLDEN_STEPS: usize = 12;

/// Above this many sample × frequency products, [`dominant_frequency`] finds its peak with an
/// FFT instead of the direct sums (records of a few thousand samples keep the direct grid and
/// their results as they were).
const DIRECT_GRID_WORK: usize = 20_000_000;

/// How [`fft`] computes its twiddle factors `e^(-2πik/len)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Twiddles {
    /// Each by its own `sin_cos` (exact to round-off).
    Exact,
    /// By a rotation recurrence within each stage (one `sin_cos` per stage, cheaper; its
    /// round-off accumulates along the stage).
    Recurrence,
}

/// In-place radix-2 FFT of complex `(re, im)` values (`x.len()` a power of two).
pub fn fft(x: &mut [(f64, f64)], twiddles: Twiddles) {
    let n = x.len();
    if n < 2 {
        return;
    }
    debug_assert!(n.is_power_of_two());
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            x.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let ang = -2.0 * std::f64::consts::PI / len as f64;
        let (ws, wc) = ang.sin_cos();
        for start in (0..n).step_by(len) {
            let (mut cr, mut ci) = (1.0, 0.0);
            for k in 0..len / 2 {
                let (c, s) = match twiddles {
                    Twiddles::Exact => {
                        let (s, c) = (ang * k as f64).sin_cos();
                        (c, s)
                    }
                    Twiddles::Recurrence => (cr, ci),
                };
                let (ar, ai) = x[start + k];
                let (br, bi) = x[start + k + len / 2];
                let (tr, ti) = (br * c - bi * s, br * s + bi * c);
                x[start + k] = (ar + tr, ai + ti);
                x[start + k + len / 2] = (ar - tr, ai - ti);
                (cr, ci) = (cr * wc - ci * ws, cr * ws + ci * wc);
            }
        }
        len <<= 1;
    }
}

/// `|Σ r_t e^(iωt)|²` by the direct sums: the reference of [`goertzel_power`].
#[cfg(test)]
fn direct_power(r: &[f64], w: f64) -> f64 {
    let (mut a, mut b) = (0.0, 0.0);
    for (t, v) in r.iter().enumerate() {
        let (s, c) = (w * t as f64).sin_cos();
        a += v * c;
        b += v * s;
    }
    a * a + b * b
}

/// `|Σ r_t e^(iωt)|²` by Goertzel's recursion: the direct sums to a relative ~1e-10 at any
/// frequency (the magnitude formula holds off the Fourier grid too), without a sine and
/// cosine per sample. One frequency at a time: [`dominant_frequency`]'s refinement (it was
/// the direct sums, a sine and a cosine per sample at each of 15 frequencies: most of the
/// detector's `sincos`), and the reference of [`goertzel_powers`], which computes the grid.
#[cfg(test)]
fn goertzel_power(r: &[f64], w: f64) -> f64 {
    let c = 2.0 * w.cos();
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for &v in r {
        let s0 = v + c * s1 - s2;
        (s2, s1) = (s1, s0);
    }
    (s1 * s1 + s2 * s2 - c * s1 * s2).max(0.0)
}

/// Goertzel's `|Σ r_t e^(iωt)|²` at every frequency of `ws`, [`GOERTZEL_LANES`] side by side in
/// one pass over `r`: each frequency's recursion is a chain of dependent operations that leaves
/// the core's units idle, which the other lanes fill. Each lane performs the one-frequency
/// recursion's operations in its order, so the powers are the same bits (test
/// `goertzel_grid_peaks_where_the_direct_sums_do`).
fn goertzel_powers(r: &[f64], ws: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(ws.len());
    for chunk in ws.chunks(GOERTZEL_LANES) {
        out.extend_from_slice(&crate::vectorized(GoertzelLanes { r, ws: chunk })[..chunk.len()]);
    }
    out
}

/// Frequencies [`goertzel_powers`] runs side by side: six AVX registers of recursions, each a
/// chain of dependent operations, keep the core's units busy. Measured per
/// [`dominant_frequency`] on a 3000-sample record (`cargo bench -p linear-id --bench
/// identifiers dominant_frequency`, this machine, one run): 16 lanes 234 µs, 20 lanes 199 µs,
/// 24 lanes 174 µs, 28 lanes 467 µs and 32 lanes 302 µs (their sums no longer fit the sixteen
/// vector registers).
const GOERTZEL_LANES: usize = 24;

/// One chunk of [`goertzel_powers`]: up to [`GOERTZEL_LANES`] frequencies, one per lane (the
/// lanes past `ws` run with `2 cos ω = 0` and are dropped).
struct GoertzelLanes<'a> {
    r: &'a [f64],
    ws: &'a [f64],
}

impl crate::Kernel for GoertzelLanes<'_> {
    type Output = [f64; GOERTZEL_LANES];
    #[inline(always)]
    fn run(self) -> [f64; GOERTZEL_LANES] {
        const L: usize = GOERTZEL_LANES;
        let mut c = [0.0; L];
        for (cl, &w) in c.iter_mut().zip(self.ws) {
            *cl = 2.0 * w.cos();
        }
        let (mut s1, mut s2) = ([0.0f64; L], [0.0f64; L]);
        for &v in self.r {
            for l in 0..L {
                let s0 = v + c[l] * s1[l] - s2[l];
                (s2[l], s1[l]) = (s1[l], s0);
            }
        }
        let mut out = [0.0; L];
        for l in 0..L {
            out[l] = (s1[l] * s1[l] + s2[l] * s2[l] - c[l] * s1[l] * s2[l]).max(0.0);
        }
        out
    }
}

/// The dominant frequency (rad/sample) of `x` with its mean and linear trend removed, over
/// periods from `min_period` samples to `max_period` samples: the periodogram's peak on the
/// Fourier grid `2πk/N`, refined by a golden-section search between its neighbours. `None`
/// when the record holds no Fourier frequency in that range or has no power there.
pub fn dominant_frequency(x: &[f64], min_period: f64, max_period: f64) -> Option<f64> {
    let n = x.len();
    if n < 16 || !(min_period >= 2.0 && max_period >= min_period) {
        return None;
    }
    let nf = n as f64;
    let tm = 0.5 * (nf - 1.0);
    let xm = mean(x);
    let stt: f64 = (0..n).map(|t| (t as f64 - tm).powi(2)).sum();
    let slope = (0..n).map(|t| (t as f64 - tm) * (x[t] - xm)).sum::<f64>() / stt;
    let r: Vec<f64> = (0..n)
        .map(|t| x[t] - xm - slope * (t as f64 - tm))
        .collect();
    // period N / k within [min_period, max_period]
    let k0 = (nf / max_period).ceil().max(1.0) as usize;
    let k1 = (nf / min_period).floor() as usize;
    if k1 < k0 {
        return None;
    }
    let mut step = 2.0 * std::f64::consts::PI / nf;
    let w0 = if n * (k1 - k0 + 1) <= DIRECT_GRID_WORK {
        // the grid's powers by Goertzel's recursion (two multiply-adds per sample instead of
        // a sine and a cosine: the grid was 7 % of a diagnosis); the same peak as the direct
        // sums, which the refinement below evaluates
        let ws: Vec<f64> = (k0..=k1).map(|k| k as f64 * step).collect();
        let grid = goertzel_powers(&r, &ws);
        let i = (0..grid.len()).max_by(|&a, &b| grid[a].total_cmp(&grid[b]))?;
        if grid[i].is_nan() || grid[i] <= 0.0 {
            return None;
        }
        (k0 + i) as f64 * step
    } else {
        // Long records: the periodogram by FFT on a grid at least twice as fine (zero
        // padding), O(n log n) instead of n sines and cosines per frequency (60 000 samples:
        // 4.5e8 sincos, most of a `detect`'s 18 s), then the same golden refinement.
        let size = (2 * n).next_power_of_two();
        let mut z: Vec<(f64, f64)> = r.iter().map(|&v| (v, 0.0)).collect();
        z.resize(size, (0.0, 0.0));
        fft(&mut z, Twiddles::Recurrence);
        let fine = 2.0 * std::f64::consts::PI / size as f64;
        let (lo_w, hi_w) = (k0 as f64 * step, k1 as f64 * step);
        let j0 = (lo_w / fine).ceil() as usize;
        let j1 = ((hi_w / fine).floor() as usize).min(size / 2);
        let j = (j0..=j1).max_by(|&a, &b| {
            let p = |k: usize| z[k].0 * z[k].0 + z[k].1 * z[k].1;
            p(a).total_cmp(&p(b))
        })?;
        let p = z[j].0 * z[j].0 + z[j].1 * z[j].1;
        if p.is_nan() || p <= 0.0 {
            return None;
        }
        step = fine;
        j as f64 * fine
    };
    let (fw0, (fa, a), (fb, b)) = golden_peak(&r, w0, step);
    [(fw0, w0), (fa, a), (fb, b)]
        .into_iter()
        .max_by(|p, q| p.0.total_cmp(&q.0))
        .map(|p| p.1)
}

/// A golden-section bracket `lo < a < b < hi` of the refinement in [`dominant_frequency`].
#[derive(Clone, Copy)]
struct Bracket {
    lo: f64,
    hi: f64,
    a: f64,
    b: f64,
}

impl Bracket {
    /// The bracket after one golden-section step to the left (`f(a) > f(b)`: the peak is in
    /// `[lo, b]`) or to the right, and the one point it adds.
    fn step(self, left: bool) -> (Bracket, f64) {
        let g = 0.5 * (5f64.sqrt() - 1.0);
        let Bracket { lo, hi, a, b } = self;
        if left {
            let a2 = b - g * (b - lo);
            (
                Bracket {
                    lo,
                    hi: b,
                    a: a2,
                    b: a,
                },
                a2,
            )
        } else {
            let b2 = a + g * (hi - a);
            (
                Bracket {
                    lo: a,
                    hi,
                    a: b,
                    b: b2,
                },
                b2,
            )
        }
    }
}

/// Golden-section steps [`golden_peak`] takes per pass over the record: the points of every
/// outcome of the next three steps (2 + 4 + 8 = 14) run in the lanes of one pass.
const SPECULATE: usize = 3;

/// The golden-section search for the peak of `|Σ r_t e^(iωt)|²` in `[w0 − step, w0 + step]`
/// ([`GOLDEN_STEPS`] steps): the power at `w0` and the last `(power, ω)` at the bracket's two
/// inner points. Each step adds one point, which depends on the steps before it only through
/// which way they went, so the points of every outcome of the next [`SPECULATE`] steps are
/// known in advance and run side by side in one pass of [`goertzel_powers`] (whose lanes give
/// the one-frequency recursion's bits): the same points, powers and result as one Goertzel
/// pass per step, in a third of the passes.
fn golden_peak(r: &[f64], w0: f64, step: f64) -> (f64, (f64, f64), (f64, f64)) {
    const TREE: usize = 1 << (SPECULATE + 1);
    const _: () = assert!(TREE - 2 <= GOERTZEL_LANES);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (lo, hi) = (w0 - step, w0 + step);
    let mut br = Bracket {
        lo,
        hi,
        a: hi - g * (hi - lo),
        b: lo + g * (hi - lo),
    };
    let first = goertzel_powers(r, &[br.a, br.b, w0]);
    let (mut fa, mut fb) = (first[0], first[1]);
    let mut left = GOLDEN_STEPS;
    while left > 0 {
        let depth = left.min(SPECULATE);
        // node 1 is the bracket now; node i's children 2i (a step left) and 2i + 1 (right)
        let mut nodes = [br; TREE];
        let mut points = [0.0; TREE];
        for i in 2..1 << (depth + 1) {
            (nodes[i], points[i]) = nodes[i / 2].step(i % 2 == 0);
        }
        let powers = goertzel_powers(r, &points[2..1 << (depth + 1)]);
        let mut i = 1;
        for _ in 0..depth {
            // left (the even child) exactly when `fa > fb`, as the one-step search decides
            i = 2 * i + usize::from(!(fa > fb));
            let f = powers[i - 2];
            if i % 2 == 0 {
                (fb, fa) = (fa, f);
            } else {
                (fa, fb) = (fb, f);
            }
        }
        br = nodes[i];
        left -= depth;
    }
    (first[2], (fa, br.a), (fb, br.b))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::Arx;

    /// A second-order process driven by a switching input and by a sinusoidal disturbance in
    /// its difference equation (as the hidden-effect suite's loops), with a little white
    /// output noise.
    fn loop_with_sine(len: usize, omega: f64, amplitude: f64) -> (Vec<f64>, Vec<f64>) {
        let mut state: u64 = 7;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let (mut u, mut x) = (vec![0.0; len], vec![0.0; len]);
        let mut level = 1.0;
        for k in 0..len {
            if rnd() > 0.45 {
                level = -level;
            }
            u[k] = 50.0 + level;
            if k >= 2 {
                x[k] = 1.5 * x[k - 1] - 0.6 * x[k - 2]
                    + 0.3 * (u[k - 1] - 50.0)
                    + 0.1 * (u[k - 2] - 50.0)
                    + amplitude * (omega * k as f64 + 0.3).sin();
            }
        }
        let y = (0..len).map(|k| 20.0 + x[k] + 0.01 * rnd()).collect();
        (u, y)
    }

    /// Goertzel's grid powers agree with the direct sums and peak at the same frequency, on
    /// a sine in noise, a random walk and white noise of 3000 samples.
    #[test]
    fn goertzel_grid_peaks_where_the_direct_sums_do() {
        let mut state = 12345u64;
        let mut noise = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let n = 3000;
        let sine: Vec<f64> = (0..n)
            .map(|t| (0.07 * t as f64).sin() + 0.5 * noise())
            .collect();
        let mut walk = vec![0.0; n];
        for t in 1..n {
            walk[t] = walk[t - 1] + noise();
        }
        let white: Vec<f64> = (0..n).map(|_| noise()).collect();
        for x in [sine, walk, white] {
            let step = 2.0 * std::f64::consts::PI / n as f64;
            let grid = |p: fn(&[f64], f64) -> f64| -> Vec<f64> {
                (2..=375).map(|k| p(&x, k as f64 * step)).collect()
            };
            let (direct, fast) = (grid(direct_power), grid(goertzel_power));
            for (d, g) in direct.iter().zip(&fast) {
                assert!((d - g).abs() <= 1e-8 * d.abs().max(1e-300), "{d} vs {g}");
            }
            // off the grid too (the refinement's frequencies)
            for k in 2..=375 {
                let w = (k as f64 + 0.37) * step;
                let (d, g) = (direct_power(&x, w), goertzel_power(&x, w));
                assert!(
                    (d - g).abs() <= 1e-8 * d.abs().max(1e-300),
                    "{d} vs {g} at {w}"
                );
            }
            // the lanes (373 frequencies: a last chunk of 13) are each frequency's bits
            let ws: Vec<f64> = (2..=375).map(|k| k as f64 * step).collect();
            let lanes = goertzel_powers(&x, &ws);
            assert_eq!(lanes.len(), fast.len());
            for (l, g) in lanes.iter().zip(&fast) {
                assert_eq!(l.to_bits(), g.to_bits());
            }
            let peak = |v: &[f64]| (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b]));
            assert_eq!(peak(&direct), peak(&fast));
        }
    }

    /// The golden-section search one Goertzel pass per step, as [`golden_peak`] replaces it.
    fn golden_one_by_one(r: &[f64], w0: f64, step: f64) -> (f64, (f64, f64), (f64, f64)) {
        let power = |w: f64| goertzel_power(r, w);
        let (mut lo, mut hi) = (w0 - step, w0 + step);
        let g = 0.5 * (5f64.sqrt() - 1.0);
        let (mut a, mut b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        let (mut fa, mut fb) = (power(a), power(b));
        for _ in 0..GOLDEN_STEPS {
            if fa > fb {
                hi = b;
                (b, fb) = (a, fa);
                a = hi - g * (hi - lo);
                fa = power(a);
            } else {
                lo = a;
                (a, fa) = (b, fb);
                b = lo + g * (hi - lo);
                fb = power(b);
            }
        }
        (power(w0), (fa, a), (fb, b))
    }

    /// The speculative search (three steps' every outcome per pass) takes the one-step
    /// search's path: the same points and powers, bit for bit, wherever the peak lies in the
    /// bracket (left, right, centre, outside) and on records whose power is flat or random.
    #[test]
    fn the_speculative_golden_search_is_the_one_step_search() {
        let mut state = 777u64;
        let mut noise = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let n = 1200;
        let step = 2.0 * std::f64::consts::PI / n as f64;
        let mut records: Vec<Vec<f64>> = Vec::new();
        for w in [0.05, 0.1234, 0.3] {
            records.push(
                (0..n)
                    .map(|t| (w * t as f64).sin() + 0.3 * noise())
                    .collect(),
            );
        }
        records.push((0..n).map(|_| noise()).collect());
        records.push(vec![0.0; n]);
        let mut paths = std::collections::BTreeSet::new();
        for r in &records {
            for k in [10.0, 19.1, 19.5, 23.6, 57.3, 60.0, 100.0] {
                let w0 = k * step;
                let (p0, a, b) = golden_peak(r, w0, step);
                let (q0, c, d) = golden_one_by_one(r, w0, step);
                let bits = |(f, w): (f64, f64)| (f.to_bits(), w.to_bits());
                assert_eq!(p0.to_bits(), q0.to_bits());
                assert_eq!(bits(a), bits(c), "record, w0 {w0}");
                assert_eq!(bits(b), bits(d), "record, w0 {w0}");
                paths.insert(a.1.to_bits());
            }
        }
        // the cases take different paths (not one bracket end every time)
        assert!(paths.len() > 10, "{}", paths.len());
    }

    #[test]
    fn a_long_record_finds_its_tone_by_fft() {
        let n = 60_000;
        let x: Vec<f64> = (0..n)
            .map(|t| {
                let t = t as f64;
                0.01 * t + (0.0123 * t + 0.4).sin() + 0.5 * ((t * 7.3).sin() * 1e3).fract()
            })
            .collect();
        let w = dominant_frequency(&x, 8.0, n as f64 / 4.0).unwrap();
        assert!((w - 0.0123).abs() < 2e-5, "{w}");
    }

    #[test]
    fn harx_recovers_the_process_under_a_sine_that_biases_arx() {
        let (u, y) = loop_with_sine(1500, 0.07, 2.0);
        let harx = Harx::params().omega(0.07).check().unwrap();
        let fit = harx.identify(&u, &y).unwrap();
        let Structure::Polynomial { a, b, .. } = fit.structure() else {
            panic!("polynomial expected")
        };
        assert!(
            (a[1] + 1.5).abs() < 0.02 && (a[2] - 0.6).abs() < 0.02,
            "{a:?}"
        );
        assert!(
            (b[0] - 0.3).abs() < 0.02 && (b[1] - 0.1).abs() < 0.02,
            "{b:?}"
        );
        assert!(
            (fit.static_gain() - 4.0).abs() < 0.2,
            "{}",
            fit.static_gain()
        );
        // once the notch's transient has gone (time constant 1/(1-ρ) = 57 samples), the
        // one-step prediction leaves only the noise (A w: 3.6 times the variance 8.3e-6 of w)
        let tail_variance = |f: &LinearFit| {
            let p = f.predict_one_step(&u, &y).unwrap();
            (500..1500).map(|k| (y[k] - p[k]).powi(2)).sum::<f64>() / 1000.0
        };
        let own = tail_variance(&fit);
        assert!(own < 1e-4, "{own}");
        // plain ARX on the same data: the sine is left in its residuals
        let arx = Arx::params().check().unwrap().identify(&u, &y).unwrap();
        assert!(tail_variance(&arx) > 10.0 * own, "{}", tail_variance(&arx));
        // a wrong frequency does not annihilate the sine: more residual, a biased process
        let off = Harx::params()
            .omega(0.3)
            .check()
            .unwrap()
            .identify(&u, &y)
            .unwrap();
        assert!(tail_variance(&off) > 10.0 * own, "{}", tail_variance(&off));
        let Structure::Polynomial { a: a_off, .. } = off.structure() else {
            panic!("polynomial expected")
        };
        assert!((a_off[1] + 1.5).abs() > 0.1, "{a_off:?}");
    }

    #[test]
    fn harx_prediction_is_the_residual_of_the_filtered_regression() {
        let (u, y) = loop_with_sine(400, 0.11, 1.0);
        let fit = Harx::params()
            .omega(0.11)
            .check()
            .unwrap()
            .identify(&u, &y)
            .unwrap();
        let pred = fit.predict_one_step(&u, &y).unwrap();
        let Structure::Polynomial { a, b, .. } = fit.structure().clone() else {
            panic!("polynomial expected")
        };
        let (um, ym) = fit.means();
        let (uf, yf) = (notch_filter(&u, um, 0.11), notch_filter(&y, ym, 0.11));
        for k in 10..400 {
            // y_k - ŷ_k is the filtered ARX's residual
            let mut v = yf[k];
            for (i, ai) in a.iter().enumerate() {
                v += ai * yf[k - i] - if i == 0 { ai * yf[k] } else { 0.0 };
            }
            for (j, bj) in b.iter().enumerate() {
                v -= bj * uf[k - 1 - j];
            }
            assert!(
                (y[k] - pred[k] - v).abs() < 1e-9,
                "{k}: {} vs {v}",
                y[k] - pred[k]
            );
        }
        assert_eq!(fit.first_sample(), 4);
        assert!(fit.is_stable());
    }

    #[test]
    fn the_notch_removes_its_frequency_and_passes_the_others() {
        let sine = |w: f64| -> Vec<f64> { (0..3000).map(|k| (w * k as f64).sin()).collect() };
        let rms = |x: &[f64]| (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
        let at = notch_filter(&sine(0.05), 0.0, 0.05);
        assert!(rms(&at[1500..]) < 1e-3, "{}", rms(&at[1500..]));
        for w in [0.2, 0.5, 1.0] {
            let away = notch_filter(&sine(w), 0.0, 0.05);
            let g = rms(&away[1500..]) / rms(&sine(w)[1500..]);
            assert!((g - 1.0).abs() < 0.05, "gain {g} at {w}");
        }
        assert!((dc_gain(0.05) - 0.8).abs() < 0.2, "{}", dc_gain(0.05));
    }

    #[test]
    fn too_short_a_record_is_an_error() {
        let (u, y) = loop_with_sine(40, 0.1, 1.0);
        let harx = Harx::params().omega(0.1).check().unwrap();
        let k = harx.min_samples();
        assert!(matches!(
            harx.identify(&u[..k - 1], &y[..k - 1]),
            Err(IdError::TooFewSamples { .. })
        ));
        assert!(harx.identify(&u[..k], &y[..k]).is_ok());
    }

    #[test]
    fn harx_round_trips_and_checks_omega() {
        let h: Box<dyn LinearIdentifier> = Box::new(Harx::params().omega(0.3).check().unwrap());
        let s = serde_json::to_string(&h).unwrap();
        let back: Box<dyn LinearIdentifier> = serde_json::from_str(&s).unwrap();
        assert_eq!(back.orders(), h.orders());
        assert!(matches!(
            Harx::params().omega(0.0).check(),
            Err(IdError::InvalidOrder { .. })
        ));
        assert!(Harx::params().omega(f64::NAN).check().is_err());
    }

    #[test]
    fn the_dominant_frequency_is_the_sine_in_the_noise() {
        let (_, y) = loop_with_sine(1200, 0.05, 0.5);
        let w = dominant_frequency(&y, 8.0, 600.0).unwrap();
        assert!((w - 0.05).abs() < 0.002, "{w}");
        assert!(dominant_frequency(&y[..10], 8.0, 600.0).is_none());
        assert!(dominant_frequency(&vec![1.0; 100], 8.0, 50.0).is_none());
    }
}
