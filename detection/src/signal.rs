//! Small signal-processing helpers the tests share: means, detrending, zero-phase smoothing,
//! correlation functions, zero crossings and a radix-2 FFT. Plain `f64` slices in and out.

/// Arithmetic mean (`0` for an empty slice).
pub(crate) fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        x.iter().sum::<f64>() / x.len() as f64
    }
}

/// Population variance.
pub(crate) fn variance(x: &[f64]) -> f64 {
    let m = mean(x);
    if x.is_empty() {
        0.0
    } else {
        x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / x.len() as f64
    }
}

/// Standard deviation (population).
pub(crate) fn std_dev(x: &[f64]) -> f64 {
    variance(x).sqrt()
}

/// `(x − mean) / standard deviation`, computed without forming squares of `x`'s magnitude
/// (the deviations are scaled by the largest first), so values up to `f64::MAX / n` do not
/// overflow. A flat `x` gives zeros.
pub(crate) fn standardise(x: &[f64]) -> Vec<f64> {
    let m = x.iter().map(|v| v / x.len() as f64).sum::<f64>();
    let dev: Vec<f64> = x.iter().map(|v| v - m).collect();
    let top = dev.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if !(top > 0.0 && top.is_finite()) {
        return vec![0.0; x.len()];
    }
    let sd = top * (dev.iter().map(|v| (v / top) * (v / top)).sum::<f64>() / x.len() as f64).sqrt();
    dev.iter().map(|v| v / sd).collect()
}

/// `x` minus its least-squares straight line.
pub(crate) fn detrend(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    if n < 2 {
        return vec![0.0; n];
    }
    let tm = (n as f64 - 1.0) / 2.0;
    let xm = mean(x);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (k, v) in x.iter().enumerate() {
        let dt = k as f64 - tm;
        sxy += dt * (v - xm);
        sxx += dt * dt;
    }
    let slope = sxy / sxx;
    x.iter()
        .enumerate()
        .map(|(k, v)| v - xm - slope * (k as f64 - tm))
        .collect()
}

/// Centred moving average over `2h + 1` samples (shorter windows at the ends): zero phase.
pub(crate) fn smooth(x: &[f64], h: usize) -> Vec<f64> {
    let n = x.len();
    if h == 0 || n == 0 {
        return x.to_vec();
    }
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0.0);
    let mut acc = 0.0;
    for v in x {
        acc += v;
        prefix.push(acc);
    }
    (0..n)
        .map(|k| {
            let lo = k.saturating_sub(h);
            let hi = (k + h + 1).min(n);
            (prefix[hi] - prefix[lo]) / (hi - lo) as f64
        })
        .collect()
}

/// Normalised autocorrelation `r(τ)`, `τ = 0..=max_lag`, of the mean-removed `x` (biased
/// estimator, `r(0) = 1`); all zeros when `x` has no variance.
pub(crate) fn acf(x: &[f64], max_lag: usize) -> Vec<f64> {
    let n = x.len();
    let m = mean(x);
    let d: Vec<f64> = x.iter().map(|v| v - m).collect();
    let c0: f64 = d.iter().map(|v| v * v).sum();
    let max_lag = max_lag.min(n.saturating_sub(1));
    if c0 <= 0.0 {
        return vec![0.0; max_lag + 1];
    }
    // Long records by FFT (O(n log n)): the direct sums are O(n · max_lag), and the oscillation
    // test asks for lags up to 2n/3 (60 000 samples: 2.4e9 products). Short records keep the
    // direct sums, and their results as they were.
    if n * max_lag > 50_000_000 {
        let size = (2 * n).next_power_of_two();
        let mut z: Vec<Complex> = d.iter().map(|&v| (v, 0.0)).collect();
        z.resize(size, (0.0, 0.0));
        fft(&mut z);
        for c in &mut z {
            *c = (c.0 * c.0 + c.1 * c.1, 0.0);
        }
        // inverse by the forward transform of the (real, even) power spectrum
        fft(&mut z);
        return z[..=max_lag]
            .iter()
            .map(|c| c.0 / size as f64 / c0)
            .collect();
    }
    direct_lag_sums(&d, max_lag)
        .into_iter()
        .map(|s| s / c0)
        .collect()
}

/// `Σ_{i < n - lag} d(i) d(i + lag)` for `lag = 0..=max_lag` (`max_lag < n`), each lag's sum
/// the chain `(((-0 + p_0) + p_1) + ...)` of `Iterator::sum`. The lags go [`LAG_LANES`] side
/// by side: one lag's additions are a chain of dependent operations that leaves the core's
/// units idle, which the other lags fill; each lane still adds its own products in their
/// order, so every lag's sum is the same bits as alone (test
/// `lag_sums_side_by_side_are_the_one_lag_sums`).
fn direct_lag_sums(d: &[f64], max_lag: usize) -> Vec<f64> {
    const L: usize = LAG_LANES;
    /// The lags `lag..lag + L`: lane l holds n - lag - l products, the first `common` of
    /// every lane side by side (in registers), then each lane's last ones.
    #[inline(always)]
    fn block(d: &[f64], lag: usize) -> [f64; L] {
        let n = d.len();
        let common = n - lag - (L - 1);
        let mut acc = [-0.0f64; L];
        for (&a, b) in d[..common].iter().zip(d[lag..].windows(L)) {
            acc = std::array::from_fn(|l| acc[l] + a * b[l]);
        }
        for (l, s) in acc.iter_mut().enumerate() {
            for i in common..n - lag - l {
                *s += d[i] * d[i + lag + l];
            }
        }
        acc
    }
    /// [`block`] as a kernel of [`linear_id::vectorized`].
    struct Block<'a>(&'a [f64], usize);
    impl linear_id::Kernel for Block<'_> {
        type Output = [f64; L];
        #[inline(always)]
        fn run(self) -> [f64; L] {
            block(self.0, self.1)
        }
    }
    let mut out = Vec::with_capacity(max_lag + 1);
    let mut lag = 0;
    while lag + L <= max_lag + 1 {
        // compiled for AVX2 where the processor has it: the same operations, so the same bits
        out.extend(linear_id::vectorized(Block(d, lag)));
        lag += L;
    }
    out.extend((lag..=max_lag).map(|lag| lag_sum(d, lag)));
    out
}

/// `Σ_{i < n - lag} d(i) d(i + lag)`, one lag, as `Iterator::sum` adds it (the chain every
/// lane of [`direct_lag_sums`] reproduces).
fn lag_sum(d: &[f64], lag: usize) -> f64 {
    d[..d.len() - lag]
        .iter()
        .zip(&d[lag..])
        .map(|(a, b)| a * b)
        .sum()
}

/// Lags summed side by side in [`direct_lag_sums`].
const LAG_LANES: usize = 8;

/// Normalised cross-correlation `r_xy(τ) = Σ x(k) y(k + τ) / (N σ_x σ_y)` for
/// `τ = -max_lag..=max_lag` (index `τ + max_lag`), of the mean-removed series.
pub(crate) fn ccf(x: &[f64], y: &[f64], max_lag: usize) -> Vec<f64> {
    let n = x.len().min(y.len());
    let (mx, my) = (mean(&x[..n]), mean(&y[..n]));
    let dx: Vec<f64> = x[..n].iter().map(|v| v - mx).collect();
    let dy: Vec<f64> = y[..n].iter().map(|v| v - my).collect();
    let sx = dx.iter().map(|v| v * v).sum::<f64>().sqrt();
    let sy = dy.iter().map(|v| v * v).sum::<f64>().sqrt();
    let max_lag = max_lag.min(n.saturating_sub(1));
    let norm = sx * sy;
    (0..=2 * max_lag)
        .map(|i| {
            if norm <= 0.0 {
                return 0.0;
            }
            let tau = i as isize - max_lag as isize;
            let s: f64 = if tau >= 0 {
                let t = tau as usize;
                dx[..n - t].iter().zip(&dy[t..]).map(|(a, b)| a * b).sum()
            } else {
                let t = (-tau) as usize;
                dx[t..].iter().zip(&dy[..n - t]).map(|(a, b)| a * b).sum()
            };
            s / norm
        })
        .collect()
}

/// Zero crossings of `x` with hysteresis: a crossing counts only once the signal has been
/// beyond `±band` on each side. Returns the interpolated positions (fractional samples) where
/// the sign changed.
pub(crate) fn zero_crossings(x: &[f64], band: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let mut state = 0i8; // sign of the last excursion beyond the band
    let mut last_on_side = 0usize; // last sample on the current side (sign of state)
    for (k, &v) in x.iter().enumerate() {
        let s = if v > band {
            1
        } else if v < -band {
            -1
        } else {
            0
        };
        if s != 0 && state != 0 && s != state {
            // The sign changed between `last_on_side` and `k`: find the crossing of zero.
            let mut pos = k as f64;
            for j in last_on_side..k {
                let (a, b) = (x[j], x[j + 1]);
                if (a >= 0.0) != (b >= 0.0) {
                    pos = j as f64 + a / (a - b);
                    break;
                }
            }
            out.push(pos);
        }
        if s != 0 {
            state = s;
        }
        if state != 0 && (v >= 0.0) == (state > 0) {
            last_on_side = k;
        }
    }
    out
}

/// A complex number as `(re, im)`.
pub(crate) type Complex = (f64, f64);

/// In-place radix-2 FFT (`x.len()` a power of two), twiddles exact
/// ([`linear_id::fft`]).
pub(crate) fn fft(x: &mut [Complex]) {
    linear_id::fft(x, linear_id::Twiddles::Exact);
}

/// Samples between the exact `sin_cos` anchors of [`sin_cos_series`].
const ROTATION_RUN: usize = 64;

/// `(sin ωk, cos ωk)` for `k` in `0..n`, in order: a rotation by `ω` per sample (four multiplies instead
/// of a `sin_cos` call), anchored on `sin_cos` every [`ROTATION_RUN`] samples so the rounding
/// cannot build up: within 1e-11 of `sin_cos(ω·k)` over 5000 samples and over a million at a
/// slow tone, about the rounding of the product `ω·k` itself (one rotation throughout drifts
/// to 3e-11 there; test `the_rotated_series_is_the_sine_and_cosine`).
pub(crate) fn sin_cos_series(omega: f64, n: usize) -> impl Iterator<Item = (f64, f64)> {
    let (sw, cw) = omega.sin_cos();
    (0..n).step_by(ROTATION_RUN).flat_map(move |start| {
        let first = (omega * start as f64).sin_cos();
        std::iter::successors(Some(first), move |&(s, c)| {
            Some((s * cw + c * sw, c * cw - s * sw))
        })
        .take(ROTATION_RUN.min(n - start))
    })
}

/// Least-squares fit of `x(k) ≈ a cos(ωk) + b sin(ωk) + c`; returns `(a, b, c)` and the
/// fraction of `x`'s variance it explains.
pub(crate) fn harmonic_fit(x: &[f64], omega: f64) -> ((f64, f64, f64), f64) {
    // 3x3 normal equations (small, well-conditioned for ω away from 0 and π over many cycles).
    let mut m = [[0.0; 3]; 3];
    let mut r = [0.0; 3];
    for (k, &v) in x.iter().enumerate() {
        let (s, c) = (omega * k as f64).sin_cos();
        let phi = [c, s, 1.0];
        for i in 0..3 {
            r[i] += phi[i] * v;
            for j in 0..3 {
                m[i][j] += phi[i] * phi[j];
            }
        }
    }
    let sol = solve3(m, r).unwrap_or([0.0; 3]);
    let var = variance(x) * x.len() as f64;
    let mut res = 0.0;
    for (k, &v) in x.iter().enumerate() {
        let (s, c) = (omega * k as f64).sin_cos();
        let e = v - sol[0] * c - sol[1] * s - sol[2];
        res += e * e;
    }
    let explained = if var > 0.0 { 1.0 - res / var } else { 0.0 };
    ((sol[0], sol[1], sol[2]), explained)
}

/// Solve a 3x3 system by Gaussian elimination with partial pivoting.
fn solve3(mut m: [[f64; 3]; 3], mut r: [f64; 3]) -> Option<[f64; 3]> {
    for col in 0..3 {
        let p = (col..3).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if m[p][col].abs() < 1e-12 {
            return None;
        }
        m.swap(col, p);
        r.swap(col, p);
        let pivot_row = m[col];
        for row in col + 1..3 {
            let f = m[row][col] / pivot_row[col];
            for (mj, pj) in m[row][col..].iter_mut().zip(&pivot_row[col..]) {
                *mj -= f * pj;
            }
            r[row] -= f * r[col];
        }
    }
    let mut x = [0.0; 3];
    for i in (0..3).rev() {
        let s: f64 = (i + 1..3).map(|j| m[i][j] * x[j]).sum();
        x[i] = (r[i] - s) / m[i][i];
    }
    Some(x)
}

/// Median (NaN for an empty slice).
pub(crate) fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => s[n / 2],
        _ => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// Robust scale of white-ish noise in `x`: the median absolute first difference / (√2 · 0.6745).
pub(crate) fn noise_scale(x: &[f64]) -> f64 {
    let d: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    median(&d) / (std::f64::consts::SQRT_2 * 0.6745)
}

/// The correlation time of `x` in samples: the lag at which its autocovariance (mean removed)
/// first falls below `1/e` of its value at lag 0, interpolated linearly between lags; the
/// signal's own time scale, whatever its sampling. The lag-0 value is extrapolated from lags 1
/// and 2 (`c₁²/c₂`, at most `c₀`): white noise (measurement noise through the controller's
/// gain, quantisation) is correlated at lag 0 only, and with `c₀` a noisy signal's time would
/// be one sample at any sampling rate. `None` when it stays above `1/e` up to `max_lag`;
/// `Some(1.0)` when even lag 1 is uncorrelated.
pub(crate) fn correlation_time(x: &[f64], max_lag: usize) -> Option<f64> {
    let n = x.len();
    let max_lag = max_lag.min(n.saturating_sub(1));
    if max_lag < 2 {
        return None;
    }
    let m = mean(x);
    let d: Vec<f64> = x.iter().map(|v| v - m).collect();
    let c = |lag: usize| lag_sum(&d, lag);
    let (c0, c1, c2) = (c(0), c(1), c(2));
    if c1 <= 0.0 || c0 <= 0.0 {
        return Some(1.0);
    }
    let top = if c2 > 0.0 { (c1 * c1 / c2).min(c0) } else { c0 };
    let level = top / std::f64::consts::E;
    let (mut prev, mut prev_lag) = (top, 0usize);
    for lag in 1..=max_lag {
        let v = match lag {
            1 => c1,
            2 => c2,
            _ => c(lag),
        };
        if v < level {
            return Some(prev_lag as f64 + (prev - level) / (prev - v));
        }
        (prev, prev_lag) = (v, lag);
    }
    None
}

/// The longest run of exactly repeated values: `(first index, length)` (`(0, 0)` when empty).
pub(crate) fn longest_run(x: &[f64]) -> (usize, usize) {
    let (mut best, mut best_start, mut run_start) = (0usize, 0usize, 0usize);
    for i in 1..=x.len() {
        if i == x.len() || x[i] != x[i - 1] {
            if i - run_start > best {
                best = i - run_start;
                best_start = run_start;
            }
            run_start = i;
        }
    }
    (best_start, best)
}

/// The span between the 1st and the 99th percentiles (0 when empty).
pub(crate) fn percentile_span(x: &[f64]) -> f64 {
    let mut v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    at(0.99) - at(0.01)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn fft_matches_direct_dft() {
        let x: Vec<Complex> = (0..16).map(|k| ((k as f64 * 0.7).sin(), 0.0)).collect();
        let mut y = x.clone();
        fft(&mut y);
        for (f, yf) in y.iter().enumerate() {
            let (mut re, mut im) = (0.0, 0.0);
            for (k, xk) in x.iter().enumerate() {
                let a = -2.0 * std::f64::consts::PI * (f * k) as f64 / 16.0;
                re += xk.0 * a.cos();
                im += xk.0 * a.sin();
            }
            assert!((re - yf.0).abs() < 1e-9 && (im - yf.1).abs() < 1e-9);
        }
    }

    #[test]
    fn lag_sums_side_by_side_are_the_one_lag_sums() {
        // every lag alone as `Iterator::sum` adds it, against the lanes, bit for bit: lengths
        // and lag ranges that end inside a block of lanes, on it, and with a negative zero
        let x: Vec<f64> = (0..203)
            .map(|k| (k as f64 * 0.37).sin() * 1e3 + ((k * 7919 % 101) as f64 - 50.0) / 7.0)
            .collect();
        for (n, max_lag) in [
            (203, 202),
            (203, 135),
            (64, 7),
            (64, 8),
            (9, 8),
            (1, 0),
            (17, 16),
        ] {
            let d = &x[..n];
            let sums = direct_lag_sums(d, max_lag);
            assert_eq!(sums.len(), max_lag + 1);
            for (lag, s) in sums.iter().enumerate() {
                let one: f64 = d[..n - lag].iter().zip(&d[lag..]).map(|(a, b)| a * b).sum();
                assert_eq!(s.to_bits(), one.to_bits(), "n {n}, lag {lag}: {s} {one}");
            }
        }
        // zeros of alternating sign: the odd lags' products are all -0, so is their sum
        let d: Vec<f64> = (0..20)
            .map(|k| if k % 2 == 0 { 0.0 } else { -0.0 })
            .collect();
        let z = direct_lag_sums(&d, 19);
        for (lag, v) in z.iter().enumerate() {
            assert_eq!(v.is_sign_negative(), lag % 2 == 1, "lag {lag}: {v}");
        }
    }

    #[test]
    fn the_fft_acf_of_a_long_record_is_the_direct_one() {
        let x: Vec<f64> = (0..12_000)
            .map(|k| (k as f64 * 0.013).sin() + 0.3 * ((k * 7919 % 1000) as f64 / 1000.0))
            .collect();
        let fast = acf(&x, 8000);
        let n = x.len();
        let m = mean(&x);
        let d: Vec<f64> = x.iter().map(|v| v - m).collect();
        let c0: f64 = d.iter().map(|v| v * v).sum();
        for lag in [0, 1, 17, 999, 4321, 8000] {
            let direct: f64 = d[..n - lag]
                .iter()
                .zip(&d[lag..])
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / c0;
            assert!(
                (fast[lag] - direct).abs() < 1e-9,
                "lag {lag}: {} {direct}",
                fast[lag]
            );
        }
    }

    #[test]
    fn zero_crossings_of_a_sine_with_hysteresis() {
        let x: Vec<f64> = (0..200).map(|k| (k as f64 * 0.1).sin()).collect();
        let z = zero_crossings(&x, 0.2);
        // sin(0.1 k) crosses zero at k = 10π·m: 31.4, 62.8, 94.2, 125.7, 157.1, 188.5
        assert_eq!(z.len(), 6, "{z:?}");
        assert!((z[0] - 31.416).abs() < 0.05);
    }

    #[test]
    fn detrend_removes_a_line_and_ccf_of_a_lagged_copy_peaks_at_the_lag() {
        let x: Vec<f64> = (0..100).map(|k| 3.0 + 0.5 * k as f64).collect();
        assert!(detrend(&x).iter().all(|v| v.abs() < 1e-9));
        let s: Vec<f64> = (0..300).map(|k| (k as f64 * 0.13).sin()).collect();
        let y: Vec<f64> = (0..300).map(|k| ((k as f64 - 5.0) * 0.13).sin()).collect();
        let c = ccf(&s, &y, 20);
        let best = (0..c.len()).max_by(|&a, &b| c[a].total_cmp(&c[b])).unwrap();
        assert_eq!(best as isize - 20, 5);
    }

    #[test]
    fn harmonic_fit_recovers_amplitude() {
        let x: Vec<f64> = (0..500)
            .map(|k| 2.0 * (0.1 * k as f64).cos() - (0.1 * k as f64).sin() + 4.0)
            .collect();
        let ((a, b, c), ex) = harmonic_fit(&x, 0.1);
        assert!((a - 2.0).abs() < 1e-9 && (b + 1.0).abs() < 1e-9 && (c - 4.0).abs() < 1e-9);
        assert!(ex > 0.999_999);
    }

    #[test]
    fn the_rotated_series_is_the_sine_and_cosine() {
        for &w in &[0.001, 0.0123, 0.5, 1.3, 3.1] {
            let n = 5000;
            let (s, c): (Vec<f64>, Vec<f64>) = sin_cos_series(w, n).unzip();
            assert_eq!((s.len(), c.len()), (n, n));
            for k in 0..n {
                let (es, ec) = (w * k as f64).sin_cos();
                assert!(
                    (s[k] - es).abs() < 1e-11 && (c[k] - ec).abs() < 1e-11,
                    "{w} {k}: {} {}",
                    s[k] - es,
                    c[k] - ec
                );
            }
        }
        // a million samples (a long record): the anchors hold the rotation to the rounding of
        // `ω·k` (2e-12 here); one rotation throughout drifts to 3e-11
        let w = 0.0123;
        let worst = sin_cos_series(w, 1_000_000)
            .enumerate()
            .map(|(k, (s, c))| {
                let (es, ec) = (w * k as f64).sin_cos();
                (s - es).abs().max((c - ec).abs())
            })
            .fold(0.0, f64::max);
        assert!(worst < 1e-11, "{worst}");
        assert_eq!(sin_cos_series(0.3, 0).count(), 0);
    }
}
