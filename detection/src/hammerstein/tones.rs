//! The nuisance tones of the output-error fits: OP's dominant frequency and its next tone.

use super::Target;

/// The dominant frequency (rad/sample) of `x` with its mean and linear trend removed, over
/// periods from 8 samples to a quarter of the record: the periodogram's peak on the Fourier
/// grid, refined by a golden-section search between its neighbours. `None` when the record is
/// too short for such periods or has no power in them.
pub fn dominant_frequency(x: &[f64]) -> Option<f64> {
    if x.len() < 64 {
        return None;
    }
    linear_id::dominant_frequency(x, 8.0, x.len() as f64 / 4.0)
}

/// Least share of OP's variance (what the first tones leave) at its next tone for
/// [`second_frequency`] to keep it. Set once, before measuring, at the 15 % that the first
/// tone's former condition used (DETECTION.md, "Choices measured"); not tuned.
const SECOND_TONE_SHARE: f64 = 0.15;

/// OP's dominant frequency once a constant and the sines at `omegas` are projected out, when
/// it carries at least [`SECOND_TONE_SHARE`] of what they leave of OP's variance and is not a
/// harmonic of one of them (within a tenth of the fundamental: a limit cycle's OP has
/// harmonics, an external disturbance of several tones has incommensurate frequencies) nor
/// within two Fourier bins of one.
pub(super) fn second_frequency(op: &[f64], omegas: &[f64]) -> Option<f64> {
    let n = op.len();
    if omegas.is_empty() || n < 64 {
        return None;
    }
    let tg = Target::new(op, 0, omegas);
    let w = dominant_frequency(&tg.ry)?;
    let resolution = 2.0 * std::f64::consts::PI / n as f64;
    let harmonic = omegas.iter().any(|&v| {
        let k = (w / v).round();
        (w - v).abs() <= 2.0 * resolution || (k >= 2.0 && (w / v - k).abs() <= 0.1)
    });
    // Enough power: the residual's share at w (a pair's projection) at least 15 %.
    let (mut a, mut b) = (0.0, 0.0);
    for (v, (sn, cs)) in tg.ry.iter().zip(crate::signal::sin_cos_series(w, n)) {
        a += v * cs;
        b += v * sn;
    }
    let share = 2.0 * (a * a + b * b) / n as f64 / tg.yy.max(f64::MIN_POSITIVE);
    (!harmonic && share >= SECOND_TONE_SHARE).then_some(w)
}
