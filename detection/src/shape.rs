//! Stick-slip in the OP-PV plane, and Singhal & Salsbury's area ratio.
//!
//! * **Stick-slip** — after Kano, Maruta, Kugemoto & Shimizu, "Practical model and detection
//!   algorithm for valve stiction", IFAC DYCOPS (2004), and Yamashita, "An automatic method
//!   for detection of valve stiction in process control loops", Control Engineering Practice
//!   14 (2006) 503-510. A sticky valve stays put while OP moves (stuck), then jumps. Where the
//!   valve position is not logged, a fast self-regulating loop's PV (a flow) stands for it,
//!   and an integrating loop's PV *increment* ΔPV (the level's rate, proportional to the
//!   flow) does. Both papers look for stretches where OP changes and the valve's proxy does
//!   not; Yamashita's index is the share of OP's motion during which the proxy is steady.
//!   Our version, noise-aware where the papers threshold raw differences: OP and the proxy
//!   `y` are cut into windows in the loop's own time (`window`): an eighth of the
//!   oscillation's period when the loop oscillates regularly; without a regular oscillation,
//!   the same share of OP's correlation time (the lag where OP's autocovariance falls below
//!   1/e: an eighth of a sinusoid's period is 0.66 of its correlation time), so a record
//!   logged every second and the same record logged every ten seconds are cut into windows of
//!   the same duration; both at least 5 samples (fewer cannot tell a step from noise) and at
//!   most a twentieth of the record (the verdict needs ten informative windows). Each window's
//!   ends are means over 5 samples (against the noise, which is drawn per sample); the free
//!   valve's gain `K` is
//!   the median of `Δy/ΔOP` over the windows where both `y` and OP clearly moved (more than
//!   three noise deviations each; one such window is enough: a sticky valve slips rarely),
//!   since a least-squares gain over all windows
//!   is pulled towards 0 by the stuck ones; a window is *informative* when `K·ΔOP` is
//!   larger than four noise deviations of `Δy` (OP moved enough that a free valve would
//!   have moved `y` visibly), and *stuck* when besides `|Δy|` is below a quarter of `|K·ΔOP|`.
//!   Statistic: the stuck share of OP's motion over the informative windows,
//!   `ρ = Σ_stuck |ΔOP| / Σ_informative |ΔOP|`. Verdict: stiction above 0.1, no stiction
//!   below 0.05, inconclusive between or with fewer than ten informative windows (our
//!   thresholds). Without a regular oscillation the window doubles, up to a tenth of the
//!   record, until ten are informative (`stick_slip_scaled`).
//! * **Area ratio** — Singhal & Salsbury, "A simple method for detecting valve stiction in
//!   oscillating control loops", Journal of Process Control 15 (2005) 371-382. In a
//!   self-regulating PI loop oscillating through stiction the control error builds up while
//!   the valve is stuck and collapses at the slip, so in each half cycle the area of the error
//!   before its peak `A₁` exceeds the area after it `A₂`; a sinusoid gives `R = A₁/A₂ = 1`.
//!   Statistic: the median `R` over the half cycles of the error smoothed over a fortieth of
//!   the period. Verdict: stiction when `R >= 1.5`, no stiction when `R <= 1.2`,
//!   inconclusive between. It applies to self-regulating loops only.

use crate::signal::{correlation_time, median, noise_scale, smooth, std_dev, zero_crossings};
use crate::{DetectionError, DetectionTest, Registration, TestEntry, TestOutcome, Verdict};

/// Smoothing half-width (samples) of the stick-slip test: means over 5 samples. Counted in
/// samples on purpose: it averages the measurement noise, which is drawn per sample; one over
/// a share of the window (the same time at any sampling) was measured and not kept.
const SMOOTH: usize = 2;
/// Shortest window (samples): with fewer, a window's ends are means over overlapping samples
/// and a step cannot be told from the noise.
const MIN_WINDOW: usize = 5;
/// Fewest windows in a record: the verdict needs ten informative ones.
const MIN_WINDOWS: usize = 20;
/// An eighth of a sinusoid's period in units of its correlation time: its autocorrelation
/// `cos(2πk/T)` falls to 1/e at `k = T·acos(1/e)/2π`, so `T/8 = 0.658 τ`. Without a regular
/// oscillation the window is this share of OP's correlation time, the rule of the oscillating
/// loop carried over to a loop that moves without one.
const WINDOW_PER_TAU: f64 = std::f64::consts::PI / (4.0 * 1.194_528_049_465_325);

/// The stick-slip test's window (samples), in the loop's own time: an eighth of the period
/// when the loop oscillates regularly, else [`WINDOW_PER_TAU`] of OP's correlation time `tau`
/// (samples; `None`: longer than the record can show); at least [`MIN_WINDOW`] samples and at
/// most a [`MIN_WINDOWS`]th of the record's `n` samples.
pub(crate) fn window(period: Option<f64>, tau: Option<f64>, n: usize) -> usize {
    let longest = (n / MIN_WINDOWS).max(MIN_WINDOW);
    let w = match (period, tau) {
        (Some(p), _) => p / 8.0,
        (None, Some(t)) => WINDOW_PER_TAU * t,
        (None, None) => longest as f64,
    };
    (w.round() as usize).clamp(MIN_WINDOW, longest)
}

/// OP's correlation time (samples) as [`window`] reads it: of the detrended OP, looked for up
/// to the lag that gives the longest window.
pub(crate) fn op_time_scale(op: &[f64]) -> Option<f64> {
    let longest = (op.len() / MIN_WINDOWS).max(MIN_WINDOW);
    correlation_time(op, (longest as f64 / WINDOW_PER_TAU).ceil() as usize)
}

/// The stick-slip index of OP and the valve's proxy `y` over windows of `window` samples;
/// `(ρ, informative windows)`.
pub(crate) fn stick_slip(op: &[f64], y: &[f64], window: usize) -> Option<(f64, usize)> {
    let n = op.len().min(y.len());
    let window = window.max(2);
    if n < 3 * window {
        return None;
    }
    let xs = smooth(&op[..n], SMOOTH);
    let ys = smooth(&y[..n], SMOOTH);
    let windows: Vec<(f64, f64)> = (0..n / window)
        .map(|w| {
            let (a, b) = (w * window, (w + 1) * window - 1);
            (xs[b] - xs[a], ys[b] - ys[a])
        })
        .collect();
    // Noise of a difference of two 5-sample means of white noise of deviation σ: σ·√(2/5). At
    // least the round-off of the smoothing's sums (1e-9 of the signal's magnitude): on a PV
    // that mostly repeats its value (quantised, held) the median change is 0, and a residue
    // of 1e-17 left by the sums would count as the proxy having moved — a residue that any
    // change of PV's units changes.
    let rounding = |x: &[f64]| 1e-9 * x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let sigma_dy =
        (noise_scale(&y[..n]) * (2.0 / (2 * SMOOTH + 1) as f64).sqrt()).max(rounding(&y[..n]));
    // The free valve's gain from the windows where the proxy clearly moved (a stuck valve's
    // windows would pull a least-squares gain towards 0).
    // OP must have moved in such a window too (a gain from a window where only a disturbance
    // moved the proxy would be arbitrary).
    let sigma_dx =
        (noise_scale(&op[..n]) * (2.0 / (2 * SMOOTH + 1) as f64).sqrt()).max(rounding(&op[..n]));
    let moved: Vec<f64> = windows
        .iter()
        .filter(|(dx, dy)| dy.abs() > 3.0 * sigma_dy && dx.abs() > 3.0 * sigma_dx && *dx != 0.0)
        .map(|(dx, dy)| dy / dx)
        .collect();
    if moved.is_empty() {
        return None;
    }
    let gain = median(&moved);
    let (mut informative, mut stuck, mut count) = (0.0, 0.0, 0usize);
    for (dx, dy) in windows {
        let expected = (gain * dx).abs();
        if expected > 4.0 * sigma_dy && expected > 0.0 {
            informative += dx.abs();
            count += 1;
            if dy.abs() < 0.25 * expected {
                stuck += dx.abs();
            }
        }
    }
    (informative > 0.0).then(|| (stuck / informative, count))
}

/// [`stick_slip`] at window `w`, or — without a regular oscillation and with fewer than ten
/// informative windows — at the shortest doubling of it (up to a tenth of the record) that has
/// enough: a slowly moving OP needs longer windows before a free valve's proxy would move
/// visibly. (With a regular oscillation the window stays tied to the period: a longer one
/// would span the half cycle over which the proxy's change cancels.) A doubling that gives
/// fewer informative windows than the last result ends the search. `(ρ, informative windows,
/// window)`.
pub(crate) fn stick_slip_scaled(
    op: &[f64],
    y: &[f64],
    w: usize,
    regular: bool,
) -> Option<(f64, usize, usize)> {
    let mut found = stick_slip(op, y, w).map(|(rho, count)| (rho, count, w));
    let mut w = w;
    while !regular && found.is_none_or(|(_, count, _)| count < 10) && 2 * w <= op.len() / 10 {
        w *= 2;
        if let Some((rho, count)) = stick_slip(op, y, w) {
            if found.is_none_or(|(_, c, _)| count >= c) {
                found = Some((rho, count, w));
            } else {
                break;
            }
        }
    }
    found
}

/// The stick-slip test (Kano et al. 2004; Yamashita 2006).
#[derive(Debug, Clone, Copy, Default)]
pub struct StickSlip;

impl DetectionTest for StickSlip {
    fn name(&self) -> &'static str {
        "stick-slip"
    }
    fn run(&self, reg: &Registration<'_>) -> Result<TestOutcome, DetectionError> {
        let p = reg.prepared()?;
        let o = p.oscillation;
        let period = o.period.filter(|_| o.is_regular());
        let tau = if period.is_some() {
            None
        } else {
            op_time_scale(&p.op)
        };
        let first = window(period, tau, reg.len());
        let px = reg.valve_proxy();
        let (proxy, y, op) = (px.name, px.y, px.op);
        let found = stick_slip_scaled(op, &y, first, o.is_regular());
        let Some((rho, windows, w)) = found else {
            return Ok(TestOutcome::new(
                "stick-slip",
                None,
                Verdict::Inconclusive,
                format!("OP never moved enough to move {proxy} visibly above its noise"),
            ));
        };
        let verdict = if windows < 10 {
            Verdict::Inconclusive
        } else if rho > 0.1 {
            Verdict::Stiction
        } else if rho < 0.05 {
            Verdict::NoStiction
        } else {
            Verdict::Inconclusive
        };
        let mut out = TestOutcome::new(
            "stick-slip",
            Some(rho),
            verdict,
            format!(
                "{proxy} stayed put during {:.0} % of OP's motion ({windows} informative windows of {w} samples, {:.0} s)",
                100.0 * rho,
                w as f64 * reg.sample_time()
            ),
        );
        out.values = vec![
            ("windows", windows as f64),
            ("window", w as f64),
            ("first_window", first as f64),
        ];
        Ok(out)
    }
}

/// Median area ratio `A₁/A₂` over the half cycles of `e`, and the number of half cycles.
pub(crate) fn area_ratio(e: &[f64], period: f64) -> Option<(f64, usize)> {
    let h = ((period / 80.0).round() as usize).max(1);
    let s = smooth(e, h);
    let z = zero_crossings(&s, 0.2 * std_dev(&s));
    let mut ratios = Vec::new();
    for w in z.windows(2) {
        let (a, b) = (
            w[0].ceil() as usize,
            (w[1].floor() as usize).min(s.len() - 1),
        );
        if b <= a + 3 || (w[1] - w[0]) > 1.5 * period {
            continue;
        }
        let seg = &s[a..=b];
        let peak = (0..seg.len())
            .max_by(|&i, &j| seg[i].abs().total_cmp(&seg[j].abs()))
            .unwrap_or(0);
        let a1: f64 = seg[..=peak].iter().map(|v| v.abs()).sum::<f64>() - 0.5 * seg[peak].abs();
        let a2: f64 = seg[peak..].iter().map(|v| v.abs()).sum::<f64>() - 0.5 * seg[peak].abs();
        if a1 > 0.0 && a2 > 0.0 {
            ratios.push(a1 / a2);
        }
    }
    (ratios.len() >= 2).then(|| (median(&ratios), ratios.len()))
}

/// Singhal & Salsbury's area-ratio test.
#[derive(Debug, Clone, Copy, Default)]
pub struct AreaRatio;

impl DetectionTest for AreaRatio {
    fn name(&self) -> &'static str {
        "area-ratio"
    }
    fn run(&self, reg: &Registration<'_>) -> Result<TestOutcome, DetectionError> {
        let p = reg.prepared()?;
        if reg.is_integrating() {
            return Err(DetectionError::NotApplicable(
                "the area ratio is for self-regulating loops",
            ));
        }
        let o = p.oscillation;
        let period = o.regular_period()?;
        let (r, halves) = area_ratio(&p.error, period).ok_or(DetectionError::NoOscillation {
            regularity: o.regularity,
        })?;
        let verdict = if r >= 1.5 {
            Verdict::Stiction
        } else if r <= 1.2 {
            Verdict::NoStiction
        } else {
            Verdict::Inconclusive
        };
        Ok(TestOutcome::new(
            "area-ratio",
            Some(r),
            verdict,
            format!(
                "control error's area before / after its peak: median R = {r:.2} over {halves} half cycles (1 for a sinusoid)"
            ),
        ))
    }
}

inventory::submit! {
    TestEntry {
        name: "stick-slip",
        description: "share of OP's motion during which PV (ΔPV for integrating loops) stays put",
        reference: "Kano et al. (2004), IFAC DYCOPS; Yamashita (2006), Control Eng. Practice 14:503-510",
        order: 40,
        test: &StickSlip,
    }
}

inventory::submit! {
    TestEntry {
        name: "area-ratio",
        description: "self-regulating loops: control error's area before vs after its peak per half cycle",
        reference: "Singhal & Salsbury (2005), J. Process Control 15:371-382",
        order: 41,
        test: &AreaRatio,
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::testing::{noise, sine, wandering};
    use stiction_models::{InitialState, Kano, StictionModel};

    /// A window of 10 samples, what a loop without a regular oscillation got before its
    /// windows were set by OP's correlation time.
    const WINDOW: usize = 10;

    /// Without a regular oscillation the window is a share of OP's correlation time, not a
    /// number of samples: the same wandering OP read every 1 s and every 2 s gets windows of
    /// the same duration within a sample of the coarser record (and a window of 10 samples at
    /// both, the former rule, would be twice as long in time at 2 s); its white noise does not
    /// shorten it. A sine gets an eighth of its period either way.
    #[test]
    fn the_window_is_the_same_time_at_any_sampling() {
        for seed in [3, 5, 8] {
            let (op1, op2) = (wandering(1.0, seed), wandering(2.0, seed));
            let w1 = window(None, op_time_scale(&op1), op1.len());
            let w2 = window(None, op_time_scale(&op2), op2.len());
            assert!(w1 > 12, "seed {seed}: {w1} samples at 1 s");
            assert!(
                (w1 as f64 - 2.0 * w2 as f64).abs() <= 2.0,
                "seed {seed}: {w1} s at 1 s, {} s at 2 s",
                2 * w2
            );
        }
        let s = sine(2000, 160.0);
        assert_eq!(window(Some(160.0), None, 2000), 20);
        let tau = op_time_scale(&s).unwrap();
        assert_eq!(window(None, Some(tau), 2000), 20, "tau {tau}");
        // bounded by what the record resolves: at least 5 samples, at most a twentieth of it
        assert_eq!(window(Some(16.0), None, 2000), 5);
        assert_eq!(window(None, None, 400), 20);
    }

    #[test]
    fn a_valve_that_moves_in_jumps_is_stuck_and_a_free_one_is_not() {
        // OP ramps up and down; the sticky PV follows in jumps of 1 after OP moved 1.
        let n = 1200;
        let op: Vec<f64> = (0..n)
            .map(|k| {
                let t = (k % 400) as f64;
                if t < 200.0 {
                    t / 20.0
                } else {
                    (400.0 - t) / 20.0
                }
            })
            .collect();
        let mut mv = vec![op[0]; n];
        for k in 1..n {
            mv[k] = if (op[k] - mv[k - 1]).abs() > 1.0 {
                op[k]
            } else {
                mv[k - 1]
            };
        }
        let nz = noise(n, 0.02, 21);
        let sticky: Vec<f64> = mv.iter().zip(&nz).map(|(a, b)| a + b).collect();
        let free: Vec<f64> = op.iter().zip(&nz).map(|(a, b)| a + b).collect();
        let (rs, _) = stick_slip(&op, &sticky, WINDOW).unwrap();
        let (rf, _) = stick_slip(&op, &free, WINDOW).unwrap();
        assert!(rs > 0.1, "sticky {rs}");
        assert!(rf < 0.05, "free {rf}");
    }

    /// OP creeping 1.5 over 400 samples and back: a free valve's PV moves too little in 10
    /// samples to judge, so the window doubles until it can (and a sticky valve's slips are
    /// still found); with a regular oscillation the window is not stretched.
    #[test]
    fn a_creeping_op_is_judged_over_longer_windows() {
        let n = 1600;
        let op: Vec<f64> = (0..n)
            .map(|k| {
                let t = (k % 800) as f64;
                if t < 400.0 {
                    t * 1.5 / 400.0
                } else {
                    (800.0 - t) * 1.5 / 400.0
                }
            })
            .collect();
        let nz = noise(n, 0.1, 7);
        // A Kano valve S = J = 1: at each reversal it holds while OP creeps by 1, then jumps.
        let mv = Kano::params()
            .s(1.0)
            .j(1.0)
            .check()
            .unwrap()
            .simulate(&op, &InitialState::up())
            .unwrap();
        let stuck: Vec<f64> = mv.iter().zip(&nz).map(|(a, b)| a + b).collect();
        let free: Vec<f64> = op.iter().zip(&nz).map(|(a, b)| a + b).collect();
        assert!(stick_slip(&op, &free, WINDOW).is_none());
        let (rf, count, w) = stick_slip_scaled(&op, &free, WINDOW, false).unwrap();
        assert!(
            rf < 0.05 && count >= 10 && w > WINDOW,
            "free {rf} {count} {w}"
        );
        let (rs, _, _) = stick_slip_scaled(&op, &stuck, WINDOW, false).unwrap();
        assert!(rs > 0.1, "sticky {rs}");
        assert!(stick_slip_scaled(&op, &free, WINDOW, true).is_none());
    }

    #[test]
    fn sawtooth_error_has_a_large_area_ratio_and_a_sine_one() {
        // Error builds up linearly and collapses: peak at the end of each half cycle.
        let n = 800;
        let saw: Vec<f64> = (0..n)
            .map(|k| {
                let t = (k % 80) as f64;
                if t < 40.0 {
                    0.2 + t / 40.0
                } else {
                    -(0.2 + (t - 40.0) / 40.0)
                }
            })
            .collect();
        let (rs, _) = area_ratio(&saw, 80.0).unwrap();
        let (r1, _) = area_ratio(&sine(n, 80.0), 80.0).unwrap();
        assert!(rs >= 1.5, "sawtooth {rs}");
        assert!((r1 - 1.0).abs() < 0.1, "sine {r1}");
    }
}
