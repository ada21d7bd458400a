//! The error type of the crate.

/// Errors of the linear identifiers and of the fitted models. Every variant carries the
/// offending values.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum IdError {
    /// An order, horizon or tuning value is out of range.
    #[error("{identifier}: {name} = {value} is out of range: expected {expected}")]
    InvalidOrder {
        /// Registered identifier name.
        identifier: &'static str,
        /// Order / option name.
        name: String,
        /// The rejected value.
        value: crate::OrderValue,
        /// The valid range, in words.
        expected: String,
    },
    /// An order name the identifier does not have (registry builder).
    #[error("{identifier}: unknown order {name:?}; its orders are {known}")]
    UnknownOrder {
        /// Registered identifier name.
        identifier: &'static str,
        /// The unknown name.
        name: String,
        /// Comma-separated list of valid names.
        known: String,
    },
    /// An identifier name that is not registered.
    #[error("unknown linear identifier {name:?}; registered identifiers are {known}")]
    UnknownIdentifier {
        /// The unknown name.
        name: String,
        /// Comma-separated list of registered names.
        known: String,
    },
    /// Not enough samples for the orders / horizons.
    #[error("too few samples: {needed} needed for these orders, got {got}")]
    TooFewSamples {
        /// Minimum number of samples.
        needed: usize,
        /// Samples given.
        got: usize,
    },
    /// Input and output have different lengths.
    #[error("length mismatch: u has {u} samples, y has {y}")]
    LengthMismatch {
        /// Input length.
        u: usize,
        /// Output length.
        y: usize,
    },
    /// The input (or the output) is constant over the identification window: nothing to identify.
    #[error("{signal} is constant over the identification window (value {value})")]
    ConstantInput {
        /// `"u"` or `"y"`.
        signal: &'static str,
        /// The constant value.
        value: f64,
    },
    /// The regression is rank deficient (e.g. an input that is a linear combination of lags).
    #[error("{identifier}: singular regression ({detail})")]
    Singular {
        /// Registered identifier name.
        identifier: &'static str,
        /// What was singular and how (ratio of smallest to largest pivot, ...).
        detail: String,
    },
    /// An iterative algorithm (SVD, eigenvalues, recursive estimator) did not converge or
    /// diverged.
    #[error("{identifier}: {detail}")]
    NotConverged {
        /// Registered identifier name.
        identifier: &'static str,
        /// What did not converge.
        detail: String,
    },
    /// A sample is NaN or infinite (or an estimate became non-finite).
    #[error("{signal} sample {index} is not finite ({value})")]
    NonFinite {
        /// `"u"`, `"y"`, `"omega"` or `"estimate"`.
        signal: &'static str,
        /// Index of the first bad value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The identified model (or its one-step predictor) has a pole on or outside the unit
    /// circle.
    #[error("{identifier}: unstable {part} (largest pole modulus {max_modulus:.6})")]
    Unstable {
        /// Registered identifier name.
        identifier: &'static str,
        /// `"process"` (A(q) / A) or `"predictor"` (C(q) / A - K C).
        part: &'static str,
        /// Largest pole modulus.
        max_modulus: f64,
    },
}

/// Reject NaN / infinite samples, naming the first.
pub(crate) fn check_finite(signal: &'static str, x: &[f64]) -> Result<(), IdError> {
    if crate::la::all_finite(x) {
        return Ok(());
    }
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(IdError::NonFinite {
            signal,
            index,
            value: x[index],
        }),
        None => Ok(()),
    }
}

/// The output's part of [`check_data`], for inputs that share an output window (computed once
/// per window, [`check_shared`] per input).
#[derive(Debug, Clone)]
pub(crate) struct OutputChecks {
    len: usize,
    finite: Result<(), IdError>,
    /// `Some(first sample)` when the output is numerically constant.
    constant: Option<f64>,
}

impl OutputChecks {
    pub(crate) fn of(y: &[f64]) -> OutputChecks {
        let finite = check_finite("y", y);
        OutputChecks {
            len: y.len(),
            constant: (finite.is_ok() && numerically_constant(y))
                .then(|| y.first().copied().unwrap_or(0.0)),
            finite,
        }
    }
}

/// [`check_data`] of `u` against an output window checked once ([`OutputChecks`]): the same
/// checks in the same order, so the same error.
pub(crate) fn check_shared(u: &[f64], y: &OutputChecks, needed: usize) -> Result<(), IdError> {
    if u.len() != y.len {
        return Err(IdError::LengthMismatch {
            u: u.len(),
            y: y.len,
        });
    }
    if u.len() < needed {
        return Err(IdError::TooFewSamples {
            needed,
            got: u.len(),
        });
    }
    check_finite("u", u)?;
    y.finite.clone()?;
    if numerically_constant(u) {
        return Err(IdError::ConstantInput {
            signal: "u",
            value: u.first().copied().unwrap_or(0.0),
        });
    }
    match y.constant {
        Some(value) => Err(IdError::ConstantInput { signal: "y", value }),
        None => Ok(()),
    }
}

/// Common input checks: equal lengths, finite, enough samples, non-constant input.
pub(crate) fn check_data(u: &[f64], y: &[f64], needed: usize) -> Result<(), IdError> {
    if u.len() != y.len() {
        return Err(IdError::LengthMismatch {
            u: u.len(),
            y: y.len(),
        });
    }
    if u.len() < needed {
        return Err(IdError::TooFewSamples {
            needed,
            got: u.len(),
        });
    }
    check_finite("u", u)?;
    check_finite("y", y)?;
    for (signal, x) in [("u", u), ("y", y)] {
        if numerically_constant(x) {
            return Err(IdError::ConstantInput {
                signal,
                value: x.first().copied().unwrap_or(0.0),
            });
        }
    }
    Ok(())
}

/// Largest spread (max - min) of a signal, relative to its largest magnitude, that still counts
/// as constant: 1e-10 is far below any logged signal's resolution (a historian's 32-bit float
/// keeps 7 digits) and far above round-off (1e-16). Exact equality was the rule before: a
/// noise-free simulated PV settling to 47.3147253065 with last-digit changes (spread 1e-12,
/// 14 samples) was then "identified", and the fit indices of that numerically constant window
/// were round-off that two exact solvers disagreed on (grid-search's `fast_path` test).
pub const CONSTANT_SPREAD: f64 = 1e-10;

/// Minimum, maximum and sum of a signal, from one lane-wise (vectorised) pass: what the
/// constancy test ([`WindowStats::is_constant`]) and the input mean of an identification
/// window need, so a caller that scans a window anyway can hand it on (grid-search's node
/// checks to [`crate::ArxOutputSums::identify_window_with`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowStats {
    /// Smallest sample.
    pub min: f64,
    /// Largest sample.
    pub max: f64,
    /// Sum of the samples, in eight partial sums combined pairwise (`la::sum`'s order).
    pub sum: f64,
}

impl WindowStats {
    /// The statistics of `x`; `None` when `x` is empty or holds a NaN. Compiled for the best
    /// instruction set the processor has (pulp's dispatch, through faer); the same bits on
    /// every one (the same IEEE operations in the same order).
    pub fn of(x: &[f64]) -> Option<WindowStats> {
        struct Of<'a>(&'a [f64]);
        impl faer::traits::pulp::WithSimd for Of<'_> {
            type Output = Option<WindowStats>;
            #[inline(always)]
            fn with_simd<S: faer::traits::pulp::Simd>(self, _: S) -> Self::Output {
                WindowStats::of_scalar(self.0)
            }
        }
        faer::traits::pulp::Arch::new().dispatch(Of(x))
    }

    #[inline(always)]
    fn of_scalar(x: &[f64]) -> Option<WindowStats> {
        const L: usize = 8;
        let &first = x.first()?;
        let (mut lo, mut hi) = ([first; L], [first; L]);
        let mut acc = [0.0; L];
        let chunks = x.chunks_exact(L);
        let rest = chunks.remainder();
        for c in chunks {
            for l in 0..L {
                lo[l] = if c[l] < lo[l] { c[l] } else { lo[l] };
                hi[l] = if c[l] > hi[l] { c[l] } else { hi[l] };
                acc[l] += c[l];
            }
        }
        let (mut min, mut max) = (first, first);
        for l in 0..L {
            min = min.min(lo[l]);
            max = max.max(hi[l]);
        }
        let mut sum =
            ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
        for &v in rest {
            min = min.min(v);
            max = max.max(v);
            sum += v;
        }
        // a NaN sample makes its lane's sum, so the sum, NaN: only then is there a NaN to
        // look for (an infinite sum of both signs is NaN too, without one); no per-sample
        // flag in the loop above, which kept the sums off AVX2
        if sum.is_nan() && x.iter().any(|v| v.is_nan()) {
            return None;
        }
        Some(WindowStats { min, max, sum })
    }

    /// Every sample is finite (a NaN has no statistics; an infinity is an extreme).
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    /// The signal is constant to [`CONSTANT_SPREAD`] of its largest magnitude (which is at
    /// one of the extremes).
    pub fn is_constant(&self) -> bool {
        spread_is_constant(self.min, self.max)
    }
}

/// `[min, max]` is constant to [`CONSTANT_SPREAD`] of its largest magnitude.
pub(crate) fn spread_is_constant(min: f64, max: f64) -> bool {
    max - min <= CONSTANT_SPREAD * min.abs().max(max.abs())
}

/// True when `x` (finite) is constant to [`CONSTANT_SPREAD`] of its largest magnitude (an
/// empty signal is not).
pub(crate) fn numerically_constant(x: &[f64]) -> bool {
    let Some(&first) = x.first() else {
        return false;
    };
    match WindowStats::of(x) {
        Some(stats) => stats.is_constant(),
        // a NaN: the fold, whose `min`/`max` skip it
        None => {
            let (lo, hi, big) = x.iter().fold((first, first, 0.0_f64), |(lo, hi, big), &v| {
                (lo.min(v), hi.max(v), big.max(v.abs()))
            });
            hi - lo <= CONSTANT_SPREAD * big
        }
    }
}

/// Validate an order: `lo <= value <= hi`.
pub(crate) fn check_order(
    identifier: &'static str,
    name: &str,
    value: usize,
    lo: usize,
    hi: usize,
) -> Result<(), IdError> {
    if value < lo || value > hi {
        return Err(IdError::InvalidOrder {
            identifier,
            name: name.to_string(),
            value: crate::OrderValue::Int(value),
            expected: format!("an integer in [{lo}, {hi}]"),
        });
    }
    Ok(())
}

/// Validate a real option: finite and `lo <= value <= hi` (`open_hi`: strictly below `hi`).
pub(crate) fn check_real(
    identifier: &'static str,
    name: &str,
    value: f64,
    lo: f64,
    hi: f64,
) -> Result<(), IdError> {
    if !(value.is_finite() && value >= lo && value <= hi) {
        return Err(IdError::InvalidOrder {
            identifier,
            name: name.to_string(),
            value: crate::OrderValue::Real(value),
            expected: format!("a finite number in [{lo}, {hi}]"),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vectorised test against the plain fold it replaces, NaN included.
    #[test]
    fn numerically_constant_equals_the_fold() {
        let fold = |x: &[f64]| {
            let Some(&first) = x.first() else {
                return false;
            };
            let (lo, hi, big) = x.iter().fold((first, first, 0.0_f64), |(lo, hi, big), &v| {
                (lo.min(v), hi.max(v), big.max(v.abs()))
            });
            hi - lo <= CONSTANT_SPREAD * big
        };
        let mut state = 99u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as usize
        };
        let values = [
            47.31,
            47.31 + 1e-12,
            47.31 - 3e-9,
            -0.0,
            0.0,
            1e-300,
            f64::NAN,
            -5.0,
        ];
        for _ in 0..20_000 {
            let len = next() % 30;
            let k = 1 + next() % values.len();
            let x: Vec<f64> = (0..len).map(|_| values[next() % k]).collect();
            assert_eq!(numerically_constant(&x), fold(&x), "{x:?}");
        }
    }

    /// The shared checks give `check_data`'s error, case by case.
    #[test]
    fn shared_checks_equal_check_data() {
        let ramp: Vec<f64> = (0..20).map(f64::from).collect();
        let flat = [3.0; 20];
        let mut nan = ramp.clone();
        nan[7] = f64::NAN;
        let signals = [&ramp[..], &flat[..], &nan[..], &ramp[..5]];
        for u in signals {
            for y in signals {
                for needed in [3, 10] {
                    // compared as text: a NaN in an error is not equal to itself
                    let shared = check_shared(u, &OutputChecks::of(y), needed);
                    let direct = check_data(u, y, needed);
                    assert_eq!(
                        format!("{shared:?}"),
                        format!("{direct:?}"),
                        "{u:?} / {y:?}"
                    );
                }
            }
        }
    }

    /// One pass gives the fold's extremes and `la::sum`'s bits.
    #[test]
    fn window_stats_equal_the_separate_passes() {
        let mut state = 7u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for len in 0..40 {
            let x: Vec<f64> = (0..len).map(|_| 100.0 * next() - 30.0).collect();
            let Some(stats) = WindowStats::of(&x) else {
                assert!(x.is_empty());
                continue;
            };
            let min = x.iter().copied().fold(f64::INFINITY, f64::min);
            let max = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            assert_eq!((stats.min, stats.max), (min, max));
            assert_eq!(stats.sum.to_bits(), crate::la::sum(&x).to_bits());
            let mut with_nan = x.clone();
            with_nan[len / 2] = f64::NAN;
            assert_eq!(WindowStats::of(&with_nan), None);
        }
    }

    /// `None` exactly when a sample is NaN, wherever it is (lanes and tail); infinities of
    /// both signs (a NaN sum without a NaN sample) keep their statistics.
    #[test]
    fn window_stats_refuse_a_nan_sample_only() {
        for len in 1..30 {
            for at in 0..len {
                let mut x: Vec<f64> = (0..len).map(|i| i as f64).collect();
                x[at] = f64::NAN;
                assert_eq!(WindowStats::of(&x), None, "NaN at {at} of {len}");
                if len >= 2 {
                    let mut y: Vec<f64> = (0..len).map(|i| i as f64).collect();
                    y[at] = f64::INFINITY;
                    y[(at + 1) % len] = f64::NEG_INFINITY;
                    let stats = WindowStats::of(&y).expect("no NaN sample");
                    assert_eq!((stats.min, stats.max), (f64::NEG_INFINITY, f64::INFINITY));
                    assert!(stats.sum.is_nan());
                }
            }
        }
    }
}
