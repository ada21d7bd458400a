//! He et al.'s curve fitting: is the oscillation triangular or sinusoidal?
//!
//! After He, Wang, Pottmann & Qin, "A curve fitting method for detecting valve stiction in
//! oscillating control loops", Industrial & Engineering Chemistry Research 46 (2007)
//! 4549-4560. A sticky valve in a self-regulating loop holds MV while the integral action
//! ramps OP, so OP is a *triangular* wave; in an integrating loop PV integrates the
//! piecewise-constant flow and is triangular instead. An oscillation from a linear cause
//! (external sinusoid, aggressive tuning) is close to a *sinusoid*. He et al. fit both shapes
//! to every half cycle of that signal (OP for self-regulating, PV for integrating loops) and
//! compare the errors through the stiction index `SI = MSE_sin / (MSE_sin + MSE_tri)`:
//! `SI <= 0.4` no stiction, `SI >= 0.6` stiction, undetermined between (their thresholds).
//!
//! Our fits, per half cycle between two zero crossings (with hysteresis at 0.2 standard
//! deviations) of the signal smoothed over a fortieth of the period: the sine half-wave
//! `a sin(π (k − k₀)/L) + c` spanning the half cycle, and the triangle `a·hat_p(k) + c` whose
//! apex `p` is the best of nine positions between 10 % and 90 % of the half cycle; `a` and `c`
//! by least squares. The apex position is the one freedom the sine lacks, as in He's
//! two-segment line fit.

use crate::signal::{smooth, std_dev, zero_crossings};
use crate::{DetectionError, DetectionTest, Registration, TestEntry, TestOutcome, Verdict};

/// Least squares of `y ≈ a·f + c`; returns the residual sum of squares.
fn fit_affine(y: &[f64], f: &[f64]) -> f64 {
    let n = y.len() as f64;
    let (sf, sy) = (f.iter().sum::<f64>(), y.iter().sum::<f64>());
    let sff: f64 = f.iter().map(|v| v * v).sum();
    let sfy: f64 = f.iter().zip(y).map(|(a, b)| a * b).sum();
    let det = n * sff - sf * sf;
    let (a, c) = if det.abs() > 1e-12 * (n * sff).max(1e-300) {
        ((n * sfy - sf * sy) / det, (sff * sy - sf * sfy) / det)
    } else {
        (0.0, sy / n)
    };
    y.iter()
        .zip(f)
        .map(|(yv, fv)| (yv - a * fv - c).powi(2))
        .sum()
}

/// Residual sums of squares `(sine, triangle)` of one half cycle `y` starting at fractional
/// offset `k0` (samples before the first element) and lasting `len` samples.
fn fit_half_cycle(y: &[f64], k0: f64, len: f64) -> (f64, f64) {
    let t: Vec<f64> = (0..y.len()).map(|i| (i as f64 + k0) / len).collect();
    let sine: Vec<f64> = t
        .iter()
        .map(|u| (std::f64::consts::PI * u.clamp(0.0, 1.0)).sin())
        .collect();
    let rs = fit_affine(y, &sine);
    let mut rt = f64::INFINITY;
    for i in 1..=9 {
        let apex = 0.1 * i as f64; // 0.1 .. 0.9
        let hat: Vec<f64> = t
            .iter()
            .map(|&u| {
                let u = u.clamp(0.0, 1.0);
                if u <= apex {
                    u / apex
                } else {
                    (1.0 - u) / (1.0 - apex)
                }
            })
            .collect();
        rt = rt.min(fit_affine(y, &hat));
    }
    (rs, rt)
}

/// He's stiction index of the signal `x` with oscillation period `period` (samples), and the
/// number of half cycles fitted.
pub(crate) fn stiction_index(x: &[f64], period: f64) -> Option<(f64, usize)> {
    let h = ((period / 80.0).round() as usize).max(1);
    let s = smooth(x, h);
    let m = crate::signal::mean(&s);
    let d: Vec<f64> = s.iter().map(|v| v - m).collect();
    let z = zero_crossings(&d, 0.2 * std_dev(&d));
    let (mut es, mut et, mut halves) = (0.0, 0.0, 0usize);
    for w in z.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = b - a;
        if len < 4.0 || len > 1.5 * period {
            continue;
        }
        let first = a.ceil() as usize;
        let last = (b.floor() as usize).min(d.len() - 1);
        if last <= first + 2 {
            continue;
        }
        let (rs, rt) = fit_half_cycle(&d[first..=last], first as f64 - a, len);
        es += rs;
        et += rt;
        halves += 1;
    }
    (halves >= 2 && es + et > 0.0).then(|| (es / (es + et), halves))
}

/// He et al.'s curve-fitting test.
#[derive(Debug, Clone, Copy, Default)]
pub struct CurveFit;

impl DetectionTest for CurveFit {
    fn name(&self) -> &'static str {
        "curve-fit"
    }
    fn run(&self, reg: &Registration<'_>) -> Result<TestOutcome, DetectionError> {
        let p = reg.prepared()?;
        let o = p.oscillation;
        let period = o.regular_period()?;
        let (signal, x) = if reg.is_integrating() {
            ("PV", &p.pv)
        } else {
            ("OP", &p.op)
        };
        let (si, halves) = stiction_index(x, period).ok_or(DetectionError::NoOscillation {
            regularity: o.regularity,
        })?;
        let verdict = if si >= 0.6 {
            Verdict::Stiction
        } else if si <= 0.4 {
            Verdict::NoStiction
        } else {
            Verdict::Inconclusive
        };
        let shape = match verdict {
            Verdict::Stiction => "triangular (stiction)",
            Verdict::NoStiction => "sinusoidal (not stiction)",
            Verdict::Inconclusive => "between triangular and sinusoidal",
        };
        Ok(TestOutcome::new(
            "curve-fit",
            Some(si),
            verdict,
            format!("{signal} is {shape} over {halves} half cycles: SI = {si:.2}"),
        ))
    }
}

inventory::submit! {
    TestEntry {
        name: "curve-fit",
        description: "triangular (stiction) or sinusoidal half cycles of OP (self-regulating) or PV (integrating)",
        reference: "He, Wang, Pottmann & Qin (2007), Ind. Eng. Chem. Res. 46:4549-4560",
        order: 20,
        test: &CurveFit,
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::testing::{noise, sine, triangle};

    #[test]
    fn triangle_and_sine_are_told_apart() {
        let tri: Vec<f64> = triangle(800, 80.0)
            .iter()
            .zip(noise(800, 0.02, 5))
            .map(|(a, b)| a + b)
            .collect();
        let sin: Vec<f64> = sine(800, 80.0)
            .iter()
            .zip(noise(800, 0.02, 6))
            .map(|(a, b)| a + b)
            .collect();
        let (st, _) = stiction_index(&tri, 80.0).unwrap();
        let (ss, _) = stiction_index(&sin, 80.0).unwrap();
        assert!(st >= 0.6, "triangle SI {st}");
        assert!(ss <= 0.4, "sine SI {ss}");
    }
}
