//! Choudhury's higher-order statistics: is the loop nonlinear, and how wide is the PV-OP
//! ellipse?
//!
//! After Choudhury, Shah & Thornhill, "Diagnosis of poor control-loop performance using
//! higher-order statistics", Automatica 40 (2004) 1719-1728, and Choudhury, Thornhill & Shah,
//! "Modelling valve stiction", Control Engineering Practice 13 (2005) 641-658 / "Detection and
//! quantification of control valve stiction", IFAC DYCOPS (2004). A linear loop driven by
//! Gaussian noise has a flat (zero) squared bicoherence; a valve nonlinearity couples the
//! oscillation's harmonics in phase and raises it at their bifrequencies. Choudhury's
//! non-Gaussianity index NGI and nonlinearity index NLI summarise the squared bicoherence of
//! the control error; a loop that is nonlinear and oscillating is then checked in the PV-OP
//! plane, where an ellipse fitted to the oscillation gives the *apparent stiction*: its width
//! along OP.
//!
//! Our estimate, where the papers leave room: the detrended control error, decimated by block
//! means of `⌊T/16⌋` samples when it oscillates with a period `T` of more than 32 samples (so
//! the oscillation and its first harmonics fall on the bins of a short segment), cut into
//! independent segments of 64 samples (at least four), Hann window, FFT; the squared bicoherence
//! `|Σ X(f₁)X(f₂)X*(f₁+f₂)|² / (Σ|X(f₁)X(f₂)|² Σ|X(f₁+f₂)|²)` over the principal domain
//! `1 <= f₂ <= f₁`, `f₁ + f₂ < 32` (bins); with `K` segments `bic²` of Gaussian data averages
//! `1/K` (a `χ²(2)/(2K)` variable), so `NGI = mean(bic²) − 1/K`, and
//! `NLI = max(bic²) − (mean(bic²) + 2σ(bic²))`. Nonlinear when `NGI > 0.001` and
//! `NLI > 0.01` (Choudhury's thresholds). The ellipse is the fundamental harmonic at the
//! oscillation's frequency fitted to OP and PV by least squares (`OP ≈ A cos ωk + B sin ωk`,
//! `PV ≈ C cos ωk + D sin ωk`: the Lissajous figure of two sinusoids of one frequency is an
//! ellipse, the fit Choudhury makes on band-pass filtered data); its chord along OP through
//! its centre is `2|AD − BC| / √(C² + D²)`, in OP units (% of valve span).
//!
//! Statistic: NLI. Verdict: stiction when nonlinear, oscillating and the ellipse has a width;
//! no stiction when NGI shows Gaussian (linear) data; inconclusive otherwise.

use crate::signal::{fft, harmonic_fit, mean, std_dev, Complex};
use crate::{
    DetectionError, DetectionTest, Prepared, Registration, TestEntry, TestOutcome, Verdict,
};

/// Segment length of the bicoherence estimate.
pub const SEGMENT: usize = 64;

/// Choudhury's indices of a signal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Indices {
    /// Non-Gaussianity index (mean squared bicoherence above its Gaussian level).
    pub ngi: f64,
    /// Nonlinearity index (largest squared bicoherence above the mean plus two deviations).
    pub nli: f64,
    /// Segments averaged.
    pub segments: usize,
}

impl Indices {
    /// Choudhury's rule: nonlinear when `NGI > 0.001` and `NLI > 0.01`.
    pub fn nonlinear(&self) -> bool {
        self.ngi > 0.001 && self.nli > 0.01
    }
}

/// Fewest segments the estimate needs.
pub const MIN_SEGMENTS: usize = 4;

/// NGI and NLI of `x` (detrended), `None` with fewer than [`MIN_SEGMENTS`] segments.
pub fn indices(x: &[f64]) -> Option<Indices> {
    let step = SEGMENT;
    if x.len() < MIN_SEGMENTS * SEGMENT {
        return None;
    }
    let window: Vec<f64> = (0..SEGMENT)
        .map(|k| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / SEGMENT as f64).cos())
        .collect();
    let mut spectra: Vec<Vec<Complex>> = Vec::new();
    let mut start = 0;
    while start + SEGMENT <= x.len() {
        let seg = &x[start..start + SEGMENT];
        let m = mean(seg);
        let mut buf: Vec<Complex> = seg
            .iter()
            .zip(&window)
            .map(|(v, w)| ((v - m) * w, 0.0))
            .collect();
        fft(&mut buf);
        spectra.push(buf);
        start += step;
    }
    let k = spectra.len();
    let half = SEGMENT / 2;
    let mut bic = Vec::new();
    for f1 in 1..half {
        for f2 in 1..=f1 {
            let f3 = f1 + f2;
            if f3 >= half {
                continue;
            }
            let (mut br, mut bi, mut d12, mut d3) = (0.0, 0.0, 0.0, 0.0);
            for s in &spectra {
                let (a, b, c) = (s[f1], s[f2], s[f3]);
                // X1 X2 conj(X3)
                let pr = a.0 * b.0 - a.1 * b.1;
                let pi = a.0 * b.1 + a.1 * b.0;
                br += pr * c.0 + pi * c.1;
                bi += pi * c.0 - pr * c.1;
                d12 += pr * pr + pi * pi;
                d3 += c.0 * c.0 + c.1 * c.1;
            }
            let den = d12 * d3;
            if den > 0.0 {
                bic.push((br * br + bi * bi) / den);
            }
        }
    }
    if bic.is_empty() {
        return None;
    }
    let mb = mean(&bic);
    let sb = std_dev(&bic);
    let max = bic.iter().copied().fold(0.0, f64::max);
    Some(Indices {
        ngi: mb - 1.0 / k as f64,
        nli: max - (mb + 2.0 * sb),
        segments: k,
    })
}

/// The PV-OP ellipse of the oscillation at `omega` rad/sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipse {
    /// Chord along OP through the centre (apparent stiction, OP units).
    pub apparent_stiction: f64,
    /// Peak-to-peak OP of the fitted harmonic.
    pub op_amplitude: f64,
    /// Fraction of OP's and PV's variance the harmonics explain (the smaller of the two).
    pub explained: f64,
    /// OP's harmonic `(A, B)` and PV's `(C, D)`, for drawing.
    pub coefficients: [f64; 4],
}

/// Fit the ellipse of `op` and `pv` at `omega`.
pub fn ellipse(op: &[f64], pv: &[f64], omega: f64) -> Ellipse {
    ellipse_and_offsets(op, pv, omega).0
}

/// [`ellipse`] with the constant terms of the two harmonic fits, `[c_OP, c_PV]`: where the
/// ellipse's centre lies relative to the signals the fit was given (for drawing it,
/// [`crate::figures`]).
pub(crate) fn ellipse_and_offsets(op: &[f64], pv: &[f64], omega: f64) -> (Ellipse, [f64; 2]) {
    let ((a, b, c_op), eo) = harmonic_fit(op, omega);
    let ((c, d, c_pv), ep) = harmonic_fit(pv, omega);
    let r = (c * c + d * d).sqrt();
    let chord = if r > 0.0 {
        2.0 * (a * d - b * c).abs() / r
    } else {
        0.0
    };
    let e = Ellipse {
        apparent_stiction: chord,
        op_amplitude: 2.0 * (a * a + b * b).sqrt(),
        explained: eo.min(ep),
        coefficients: [a, b, c, d],
    };
    (e, [c_op, c_pv])
}

/// The test's ellipse of a prepared registration oscillating with `period` samples: fitted to
/// the detrended OP and PV at the oscillation's frequency; with the offsets of
/// [`ellipse_and_offsets`].
pub(crate) fn prepared_ellipse(p: &Prepared, period: f64) -> (Ellipse, [f64; 2]) {
    ellipse_and_offsets(&p.op, &p.pv, 2.0 * std::f64::consts::PI / period)
}

/// Choudhury's bicoherence test with the PV-OP ellipse.
#[derive(Debug, Clone, Copy, Default)]
pub struct Bicoherence;

impl DetectionTest for Bicoherence {
    fn name(&self) -> &'static str {
        "bicoherence"
    }
    fn run(&self, reg: &Registration<'_>) -> Result<TestOutcome, DetectionError> {
        let p = reg.prepared()?;
        let o = p.oscillation;
        let period = o.period.filter(|_| o.is_regular());
        let factor = period.map_or(1, |t| ((t / 16.0).floor() as usize).max(1));
        let decimated: Vec<f64> = p
            .error
            .chunks_exact(factor)
            .map(|c| c.iter().sum::<f64>() / factor as f64)
            .collect();
        let ix = indices(&decimated).ok_or(DetectionError::TooShort {
            needed: MIN_SEGMENTS * SEGMENT * factor,
            got: reg.len(),
        })?;
        let el = period.map(|t| prepared_ellipse(p, t).0);
        let (verdict, what) = match (ix.nonlinear(), el) {
            (true, Some(e)) if e.apparent_stiction > 0.0 => (
                Verdict::Stiction,
                format!(
                    "nonlinear and oscillating: PV-OP ellipse width (apparent stiction) {:.2} % of OP",
                    e.apparent_stiction
                ),
            ),
            (true, _) => (
                Verdict::Inconclusive,
                "nonlinear, but no regular oscillation to fit an ellipse to".to_string(),
            ),
            (false, _) if ix.ngi <= 0.001 => (
                Verdict::NoStiction,
                "Gaussian: no sign of a nonlinearity in the loop".to_string(),
            ),
            (false, _) => (
                Verdict::Inconclusive,
                "non-Gaussian but not nonlinear by the NLI".to_string(),
            ),
        };
        let mut out = TestOutcome::new(
            "bicoherence",
            Some(ix.nli),
            verdict,
            format!(
                "control error NGI {:.4}, NLI {:.3} ({} segments{}): {what}",
                ix.ngi,
                ix.nli,
                ix.segments,
                if factor > 1 {
                    format!(" after decimation by {factor}")
                } else {
                    String::new()
                }
            ),
        );
        out.values = vec![("ngi", ix.ngi), ("nli", ix.nli)];
        if let Some(e) = el {
            out.values.extend([
                ("apparent_stiction", e.apparent_stiction),
                ("op_amplitude", e.op_amplitude),
                ("ellipse_explained", e.explained),
                ("ellipse_a", e.coefficients[0]),
                ("ellipse_b", e.coefficients[1]),
                ("ellipse_c", e.coefficients[2]),
                ("ellipse_d", e.coefficients[3]),
            ]);
        }
        Ok(out)
    }
}

inventory::submit! {
    TestEntry {
        name: "bicoherence",
        description: "nonlinearity of the control error (NGI, NLI) and the PV-OP ellipse's width (apparent stiction)",
        reference: "Choudhury, Shah & Thornhill (2004), Automatica 40:1719-1728",
        order: 30,
        test: &Bicoherence,
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::testing::noise;

    #[test]
    fn gaussian_noise_is_linear_and_quadratic_coupling_is_not() {
        let n = 2048;
        let g = noise(n, 1.0, 11);
        let ig = indices(&g).unwrap();
        assert!(!ig.nonlinear(), "{ig:?}");
        // Quadratic phase coupling: x = cos(w1 k + φ1) + cos(w2 k + φ2) + cos((w1+w2) k + φ1+φ2)
        // with random phases per block.
        let ph = noise(n, 3.0, 12);
        let x: Vec<f64> = (0..n)
            .map(|k| {
                let b = k / 64;
                let (p1, p2) = (ph[2 * b], ph[2 * b + 1]);
                let (w1, w2) = (
                    2.0 * std::f64::consts::PI * 5.0 / 64.0,
                    2.0 * std::f64::consts::PI * 9.0 / 64.0,
                );
                (w1 * k as f64 + p1).cos()
                    + (w2 * k as f64 + p2).cos()
                    + ((w1 + w2) * k as f64 + p1 + p2).cos()
            })
            .zip(noise(n, 0.3, 13))
            .map(|(a, b)| a + b)
            .collect();
        let ix = indices(&x).unwrap();
        assert!(ix.nonlinear(), "{ix:?}");
    }

    #[test]
    fn ellipse_width_of_a_quarter_period_lag() {
        let w = 0.1;
        let op: Vec<f64> = (0..600).map(|k| 2.0 * (w * k as f64).sin()).collect();
        let pv: Vec<f64> = (0..600).map(|k| (w * k as f64).cos()).collect();
        let e = ellipse(&op, &pv, w);
        // PV = 0 where cos = 0, there OP = ±2: chord 4.
        assert!((e.apparent_stiction - 4.0).abs() < 1e-6, "{e:?}");
        let pv_in_phase: Vec<f64> = op.iter().map(|v| 0.5 * v).collect();
        assert!(ellipse(&op, &pv_in_phase, w).apparent_stiction < 1e-6);
    }
}
