//! Oscillation detection by the regularity of the autocorrelation function's zero crossings.
//!
//! After Thornhill, Huang & Zhang, "Detection of multiple oscillations in control loops",
//! Journal of Process Control 13 (2003) 91-100: the autocorrelation function (ACF) of an
//! oscillating signal is itself an oscillation, with the noise filtered out. The intervals
//! between alternate zero crossings of the ACF estimate the period `T_p`; the oscillation is
//! *regular* when `r = mean(T_p) / (3 σ(T_p)) > 1`, i.e. when the period varies by less than
//! a third of its mean. Stiction in a self-regulating or integrating loop under integral
//! action produces such a limit cycle; a loop without a regular oscillation gives the shape
//! tests nothing to judge.
//!
//! Our choices where the paper leaves room: the ACF is the biased estimate of the detrended
//! control error up to two thirds of the record; a zero crossing counts only after the ACF has
//! left the band `±1.5/√N` (the ACF of white noise stays inside it), so noise does not create
//! crossings; at least four crossings (two period estimates) are required; `r` is capped at 10
//! (a perfectly constant period).

use crate::signal::{acf, mean, std_dev, zero_crossings};
use crate::{DetectionError, DetectionTest, Registration, TestEntry, TestOutcome, Verdict};

/// Largest regularity reported (a perfectly constant period would be infinite).
pub const MAX_REGULARITY: f64 = 10.0;

/// The oscillation of a loop's control error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Oscillation {
    /// Thornhill's regularity `r = mean(T_p) / (3 σ(T_p))` (0 when fewer than two period
    /// estimates were found), capped at [`MAX_REGULARITY`].
    pub regularity: f64,
    /// Mean period in samples, when at least one period estimate was found.
    pub period: Option<f64>,
    /// Number of ACF zero crossings used.
    pub crossings: usize,
    /// The ACF at the mean period (near 1 for a clean oscillation, near 0 for noise).
    pub acf_at_period: f64,
}

impl Oscillation {
    /// Whether the oscillation is regular (`r > 1` with at least two period estimates).
    pub fn is_regular(&self) -> bool {
        self.regularity > 1.0 && self.crossings >= 4 && self.period.is_some()
    }

    /// The period in samples when the oscillation is regular, else
    /// [`DetectionError::NoOscillation`]: what the shape tests need before they judge.
    pub fn regular_period(&self) -> Result<f64, crate::DetectionError> {
        self.period
            .filter(|_| self.is_regular())
            .ok_or(crate::DetectionError::NoOscillation {
                regularity: self.regularity,
            })
    }
}

/// Analyse the (detrended) control error.
pub(crate) fn analyse(error: &[f64]) -> Oscillation {
    let n = error.len();
    let r = acf(error, 2 * n / 3);
    let band = 1.5 / (n.max(1) as f64).sqrt();
    // The ACF starts at 1: skip lag 0 so the first crossing is a real one.
    let z = zero_crossings(&r, band);
    let periods: Vec<f64> = z.windows(3).map(|w| w[2] - w[0]).collect();
    let period = (!periods.is_empty()).then(|| mean(&periods));
    let regularity = if periods.len() >= 2 {
        let s = std_dev(&periods);
        let m = mean(&periods);
        if s > 0.0 {
            (m / (3.0 * s)).min(MAX_REGULARITY)
        } else {
            MAX_REGULARITY
        }
    } else {
        0.0
    };
    let acf_at_period = period
        .map(|p| {
            let k = p.round() as usize;
            r.get(k).copied().unwrap_or(0.0)
        })
        .unwrap_or(0.0);
    // A "period" of a few samples is noise, not a limit cycle.
    let period = period.filter(|&p| p >= 4.0);
    Oscillation {
        regularity: if period.is_some() { regularity } else { 0.0 },
        period,
        crossings: z.len(),
        acf_at_period,
    }
}

/// The registered test: is there a regular oscillation, and of which period.
///
/// Statistic: the regularity `r`. Verdict: `no-stiction` without a regular oscillation (no
/// limit cycle), `inconclusive` with one (stiction is one candidate cause among external
/// oscillations, aggressive tuning and others; the other tests tell them apart).
#[derive(Debug, Clone, Copy, Default)]
pub struct OscillationTest;

impl DetectionTest for OscillationTest {
    fn name(&self) -> &'static str {
        "oscillation"
    }
    fn run(&self, reg: &Registration<'_>) -> Result<TestOutcome, DetectionError> {
        let o = reg.oscillation()?;
        let ts = reg.sample_time();
        let mut out = if o.is_regular() {
            let p = o.period.unwrap_or(f64::NAN);
            TestOutcome::new(
                "oscillation",
                Some(o.regularity),
                Verdict::Inconclusive,
                format!(
                    "regular oscillation of the control error: period {:.0} s ({:.1} samples), regularity r = {:.2} > 1; stiction is one candidate cause",
                    p * ts,
                    p,
                    o.regularity
                ),
            )
        } else {
            TestOutcome::new(
                "oscillation",
                Some(o.regularity),
                // No limit cycle is no evidence against stiction: a sticky valve in a loop
                // with slow integral action, or stuck through the record, need not oscillate.
                Verdict::Inconclusive,
                format!(
                    "no regular oscillation of the control error (regularity r = {:.2}, {} ACF zero crossings): no limit cycle, which says nothing for or against stiction",
                    o.regularity, o.crossings
                ),
            )
        };
        out.values = vec![
            ("regularity", o.regularity),
            ("acf_at_period", o.acf_at_period),
        ];
        // Only a period found: a NaN in its place made every record without one read as "its
        // statistic is not a finite number" (`run_all`'s guard) instead of this sentence.
        if let Some(p) = o.period {
            out.values.push(("period_samples", p));
        }
        Ok(out)
    }
}

inventory::submit! {
    TestEntry {
        name: "oscillation",
        description: "regular oscillation of the control error: ACF zero-crossing regularity r > 1",
        reference: "Thornhill, Huang & Zhang (2003), J. Process Control 13:91-100",
        order: 0,
        test: &OscillationTest,
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::testing::{noise, sine};

    #[test]
    fn a_noisy_sine_is_regular_with_its_period() {
        let x: Vec<f64> = sine(750, 50.0)
            .iter()
            .zip(noise(750, 0.3, 1))
            .map(|(a, b)| a + b)
            .collect();
        let o = analyse(&x);
        assert!(o.is_regular(), "{o:?}");
        let p = o.period.unwrap();
        assert!((p - 50.0).abs() < 2.0, "{p}");
    }

    #[test]
    fn a_record_without_an_oscillation_says_so_with_its_regularity() {
        // a random walk: its ACF crosses zero too few times for a period
        let pv: Vec<f64> = noise(750, 1.0, 3)
            .iter()
            .scan(0.0, |acc, v| {
                *acc += v;
                Some(*acc)
            })
            .collect();
        let op: Vec<f64> = noise(750, 1.0, 4).iter().map(|v| 50.0 + v).collect();
        let reg = Registration::new(&pv, &op, 1.0).unwrap();
        let o = crate::run_all(&reg)
            .into_iter()
            .find(|o| o.name == "oscillation")
            .unwrap();
        assert_eq!(o.statistic, Some(0.0), "{o:?}");
        assert_eq!(o.value("period_samples"), None, "{o:?}");
        assert!(
            o.evidence.starts_with("no regular oscillation"),
            "{}",
            o.evidence
        );
    }

    #[test]
    fn white_noise_is_not_regular() {
        for seed in 1..6 {
            let o = analyse(&noise(750, 1.0, seed));
            assert!(!o.is_regular(), "seed {seed}: {o:?}");
        }
    }
}
