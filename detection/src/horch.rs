//! Horch's two tests: the OP-PV cross-correlation (self-regulating loops) and the distribution
//! of the second difference of PV (integrating loops).
//!
//! * **Cross-correlation** — Horch, "A simple method for detection of stiction in control
//!   valves", Control Engineering Practice 7 (1999) 1221-1231. In a self-regulating loop
//!   oscillating through stiction, OP (the integral of a square-ish error) lags PV by about a
//!   quarter period, so the cross-correlation function (CCF) of OP and PV is *odd* around lag
//!   0; an oscillation from an external disturbance or an aggressive controller puts OP and PV
//!   in counter-phase, and the CCF is *even* with its extremum at lag 0. Our statistic is the
//!   odd share of the CCF over lags `|τ| <= T/2` (T the period):
//!   `Σ odd² / (Σ odd² + Σ even²)`, 1 for a pure odd and 0 for a pure even function.
//!   Verdict: stiction above 2/3, no stiction below 1/3, inconclusive between.
//! * **Integrating loops** — Horch & Isaksson, "Detection of valve stiction in integrating
//!   processes", European Control Conference (2001). Through stiction a level's PV becomes
//!   piecewise linear (the valve alternates between stuck and jumping positions, the level
//!   integrates a piecewise-constant flow), so its second derivative is near zero with spikes
//!   at the corners: a single-peaked distribution. A sinusoidal oscillation has a sinusoidal
//!   second derivative whose distribution has two peaks (at ± its amplitude). Horch compares
//!   a Gaussian with a two-peaked fit; we fit the symmetric two-Gaussian mixture
//!   `½N(−a, s²) + ½N(a, s²)` by its second and fourth moments (`a⁴ = (3m₂² − m₄)/2`), which
//!   has two peaks exactly when `a > s`, i.e. when the kurtosis `β₂ = m₄/m₂²` is below 2.5.
//!   The second difference is taken over a tenth of the period on PV smoothed over a
//!   twentieth, so measurement noise does not dominate it. Statistic: `β₂`. Verdict: two
//!   peaks (`β₂ < 2.5`) no stiction, `β₂ >= 3` (a peak at zero with tails: corners) stiction,
//!   inconclusive between.

use crate::signal::{ccf, smooth};
use crate::{DetectionError, DetectionTest, Registration, TestEntry, TestOutcome, Verdict};

/// The lags either side of 0 the test reads for an oscillation of `period` samples: `T/2`
/// rounded, at least 2.
pub(crate) fn max_lag(period: f64) -> usize {
    ((period / 2.0).round() as usize).max(2)
}

/// The odd share of the OP-PV cross-correlation over `|τ| <= max_lag`.
pub(crate) fn odd_share(op: &[f64], pv: &[f64], max_lag: usize) -> f64 {
    odd_share_of(&ccf(op, pv, max_lag))
}

/// The odd share of a cross-correlation `c` over lags `-m..=m` (index `τ + m`, as
/// [`ccf`] gives it): `Σ odd² / (Σ odd² + Σ even²)`, `0.5` when it is all zeros.
pub(crate) fn odd_share_of(c: &[f64]) -> f64 {
    if c.is_empty() {
        return 0.5;
    }
    let m = (c.len() - 1) / 2;
    let (mut odd, mut even) = (0.0, 0.0);
    for t in 0..=m {
        let (a, b) = (c[m + t], c[m - t]);
        let w = if t == 0 { 0.5 } else { 1.0 };
        odd += w * ((a - b) / 2.0).powi(2);
        even += w * ((a + b) / 2.0).powi(2);
    }
    if odd + even > 0.0 {
        odd / (odd + even)
    } else {
        0.5
    }
}

/// Horch's cross-correlation test (self-regulating loops).
#[derive(Debug, Clone, Copy, Default)]
pub struct HorchXcorr;

impl DetectionTest for HorchXcorr {
    fn name(&self) -> &'static str {
        "horch-xcorr"
    }
    fn run(&self, reg: &Registration<'_>) -> Result<TestOutcome, DetectionError> {
        let p = reg.prepared()?;
        if reg.is_integrating() {
            return Err(DetectionError::NotApplicable(
                "the cross-correlation test is for self-regulating loops (integrating: see horch-integrating)",
            ));
        }
        let o = p.oscillation;
        let period = o.regular_period()?;
        let max_lag = max_lag(period);
        let share = odd_share(&p.op, &p.pv, max_lag);
        let verdict = if share > 2.0 / 3.0 {
            Verdict::Stiction
        } else if share < 1.0 / 3.0 {
            Verdict::NoStiction
        } else {
            Verdict::Inconclusive
        };
        let shape = match verdict {
            Verdict::Stiction => "odd (OP lags PV by about a quarter period: stiction)",
            Verdict::NoStiction => "even (OP and PV in counter-phase: not stiction)",
            Verdict::Inconclusive => "neither odd nor even",
        };
        Ok(TestOutcome::new(
            "horch-xcorr",
            Some(share),
            verdict,
            format!(
                "OP-PV cross-correlation over ±{max_lag} lags is {shape}; odd share {share:.2}"
            ),
        ))
    }
}

/// Kurtosis `m₄/m₂²` of the mean-removed `x` (`NaN` without variance).
pub(crate) fn kurtosis(x: &[f64]) -> f64 {
    let m = crate::signal::mean(x);
    let (mut m2, mut m4) = (0.0, 0.0);
    for v in x {
        let d = (v - m) * (v - m);
        m2 += d;
        m4 += d * d;
    }
    let n = x.len() as f64;
    let (m2, m4) = (m2 / n, m4 / n);
    if m2 > 0.0 {
        m4 / (m2 * m2)
    } else {
        f64::NAN
    }
}

/// Second difference of PV over `period / 10`, PV smoothed over `period / 20`.
pub(crate) fn second_difference(pv: &[f64], period: f64) -> Vec<f64> {
    let h = ((period / 40.0).round() as usize).max(1);
    let lag = ((period / 10.0).round() as usize).max(1);
    let s = smooth(pv, h);
    if s.len() <= 2 * lag {
        return Vec::new();
    }
    (lag..s.len() - lag)
        .map(|k| s[k + lag] - 2.0 * s[k] + s[k - lag])
        .collect()
}

/// Horch's test for integrating loops.
#[derive(Debug, Clone, Copy, Default)]
pub struct HorchIntegrating;

impl DetectionTest for HorchIntegrating {
    fn name(&self) -> &'static str {
        "horch-integrating"
    }
    fn run(&self, reg: &Registration<'_>) -> Result<TestOutcome, DetectionError> {
        let p = reg.prepared()?;
        if !reg.is_integrating() {
            return Err(DetectionError::NotApplicable(
                "the second-difference test is for integrating loops (self-regulating: see horch-xcorr)",
            ));
        }
        let o = p.oscillation;
        let period = o.regular_period()?;
        let d2 = second_difference(&p.pv, period);
        if d2.len() < 20 {
            return Err(DetectionError::TooShort {
                needed: 20 + 2 * ((period / 10.0).round() as usize).max(1),
                got: reg.len(),
            });
        }
        let b2 = kurtosis(&d2);
        if !b2.is_finite() {
            return Err(DetectionError::Flat {
                signal: "PV",
                why: "its second difference does not vary",
            });
        }
        let q = ((3.0 - b2) / 2.0).max(0.0).sqrt(); // a²/m₂
        let separation = if q < 1.0 {
            (q / (1.0 - q)).sqrt()
        } else {
            f64::INFINITY
        };
        let verdict = if b2 < 2.5 {
            Verdict::NoStiction
        } else if b2 >= 3.0 {
            Verdict::Stiction
        } else {
            Verdict::Inconclusive
        };
        let what = match verdict {
            Verdict::NoStiction => "two peaks (sinusoidal PV: not stiction)",
            Verdict::Stiction => "one peak with tails (piecewise-linear PV: stiction)",
            Verdict::Inconclusive => "between one and two peaks",
        };
        let mut out = TestOutcome::new(
            "horch-integrating",
            Some(b2),
            verdict,
            format!(
                "distribution of PV's second difference has {what}: kurtosis {b2:.2}, peak separation a/s = {separation:.2}"
            ),
        );
        out.values = vec![("separation", separation)];
        Ok(out)
    }
}

inventory::submit! {
    TestEntry {
        name: "horch-xcorr",
        description: "self-regulating loops: OP-PV cross-correlation odd (stiction) or even (not)",
        reference: "Horch (1999), Control Eng. Practice 7:1221-1231",
        order: 10,
        test: &HorchXcorr,
    }
}

inventory::submit! {
    TestEntry {
        name: "horch-integrating",
        description: "integrating loops: PV's second difference single-peaked (stiction) or two-peaked (not)",
        reference: "Horch & Isaksson (2001), European Control Conference",
        order: 11,
        test: &HorchIntegrating,
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::testing::{noise, sine, triangle};

    #[test]
    fn quarter_period_lag_is_odd_and_counter_phase_is_even() {
        let pv = sine(600, 60.0);
        let op_lag: Vec<f64> = (0..600)
            .map(|k| -(2.0 * std::f64::consts::PI * k as f64 / 60.0).cos())
            .collect();
        let op_anti: Vec<f64> = pv.iter().map(|v| -v).collect();
        assert!(odd_share(&op_lag, &pv, 30) > 0.95);
        assert!(odd_share(&op_anti, &pv, 30) < 0.05);
    }

    #[test]
    fn integrating_triangle_is_single_peaked_and_sine_two_peaked() {
        let n = 1500;
        let tri: Vec<f64> = triangle(n, 100.0)
            .iter()
            .zip(noise(n, 0.01, 3))
            .map(|(a, b)| a + b)
            .collect();
        let sin: Vec<f64> = sine(n, 100.0)
            .iter()
            .zip(noise(n, 0.01, 4))
            .map(|(a, b)| a + b)
            .collect();
        let kt = kurtosis(&second_difference(&tri, 100.0));
        let ks = kurtosis(&second_difference(&sin, 100.0));
        assert!(kt >= 3.0, "triangle {kt}");
        assert!(ks < 2.5, "sine {ks}");
    }
}
