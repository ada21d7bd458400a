//! What the detection figures of a report draw, computed by the tests' own code so that the
//! picture shows what the verdict was judged on.
//!
//! * [`pv_op_ellipse`]: the PV-OP ellipse of the [`bicoherence`](crate::bicoherence) test —
//!   the fundamental harmonic of OP and of PV at the oscillation's frequency, fitted by least
//!   squares to the detrended signals — as a closed curve in the (OP, PV) plane of the record,
//!   with its chord along OP through the centre (the *apparent stiction*, the number the test
//!   reports). Only with a regular oscillation (the test fits none otherwise).
//! * [`cross_correlation`]: the OP-PV cross-correlation of the detrended signals that
//!   [`horch`](crate::horch)'s test reads, over lags `±T/2` (`T` the period) with a regular
//!   oscillation, else over a fixed `±`[`FIXED_LAGS`] lags, with the odd share over the same
//!   lags (Horch's statistic when the loop is self-regulating and oscillates regularly).
//!
//! Both are `None` when the registration cannot be judged at all (too short, not finite, PV or
//! OP flat: [`Registration::check`]).

use crate::bicoherence::{prepared_ellipse, Ellipse};
use crate::horch::{max_lag, odd_share_of};
use crate::signal::{ccf, mean};
use crate::Registration;

/// Points on the drawn ellipse (one every 2°; the curve repeats the first at the end).
pub const ELLIPSE_POINTS: usize = 180;

/// Lags either side of 0 of [`cross_correlation`] when the loop has no regular oscillation
/// (no period to scale them by).
pub const FIXED_LAGS: usize = 50;

/// The PV-OP ellipse of a registration, in the units of the record (OP in its units, % of
/// valve span as the workflow reads it; PV in its engineering units).
#[derive(Debug, Clone, PartialEq)]
pub struct PvOpEllipse {
    /// The ellipse as a closed curve of `(OP, PV)` points: [`ELLIPSE_POINTS`] + 1, the last
    /// equal to the first.
    pub curve: Vec<(f64, f64)>,
    /// Its centre `(OP, PV)`: the record's means plus the constant terms of the harmonic fits
    /// (the fit is made on the detrended signals, whose line passes through the means).
    pub centre: (f64, f64),
    /// The ends `(OP, PV)` of its chord along OP through the centre, left end first.
    pub chord: [(f64, f64); 2],
    /// The chord's length along OP: the bicoherence test's apparent stiction (OP units).
    pub apparent_stiction: f64,
    /// The oscillation's period in samples the harmonics were fitted at.
    pub period: f64,
    /// The fit itself (harmonic coefficients, OP amplitude, variance explained).
    pub fit: Ellipse,
}

/// The PV-OP ellipse of `reg` as the bicoherence test fits it, or `None` without a regular
/// oscillation (or when `reg` cannot be judged).
pub fn pv_op_ellipse(reg: &Registration<'_>) -> Option<PvOpEllipse> {
    let p = reg.prepared().ok()?;
    let period = p.oscillation.regular_period().ok()?;
    let (fit, [c_op, c_pv]) = prepared_ellipse(p, period);
    let [a, b, c, d] = fit.coefficients;
    let centre = (mean(reg.op()) + c_op, mean(reg.pv()) + c_pv);
    let curve = (0..=ELLIPSE_POINTS)
        .map(|i| {
            let th =
                2.0 * std::f64::consts::PI * (i % ELLIPSE_POINTS) as f64 / ELLIPSE_POINTS as f64;
            let (s, co) = th.sin_cos();
            (centre.0 + a * co + b * s, centre.1 + c * co + d * s)
        })
        .collect();
    // PV is at the centre's where C cos θ + D sin θ = 0; OP is there ±(AD − BC)/√(C² + D²).
    let half = fit.apparent_stiction / 2.0;
    Some(PvOpEllipse {
        curve,
        centre,
        chord: [(centre.0 - half, centre.1), (centre.0 + half, centre.1)],
        apparent_stiction: fit.apparent_stiction,
        period,
        fit,
    })
}

/// The OP-PV cross-correlation of a registration.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossCorrelation {
    /// `(τ, r(τ))` for `τ = −max_lag..=max_lag` samples, where
    /// `r(τ) = Σ OP(k) PV(k + τ) / (N σ_OP σ_PV)` of the detrended signals: a positive lag pairs
    /// OP with PV `τ` samples later, so a peak at `τ > 0` is PV following OP.
    pub values: Vec<(i64, f64)>,
    /// The largest lag: `T/2` rounded (at least 2) with a regular oscillation, else
    /// [`FIXED_LAGS`]; at most the record's length less one.
    pub max_lag: usize,
    /// The oscillation's period in samples when it is regular (the lags are then `±T/2`).
    pub period: Option<f64>,
    /// The odd share `Σ odd² / (Σ odd² + Σ even²)` of `values` (1: odd, 0: even).
    pub odd_share: f64,
    /// Whether the loop is integrating (Horch's reading of the cross-correlation is for
    /// self-regulating loops).
    pub integrating: bool,
}

/// The OP-PV cross-correlation of `reg` over `±T/2` with a regular oscillation of period `T`,
/// else over `±`[`FIXED_LAGS`] lags; `None` when `reg` cannot be judged.
pub fn cross_correlation(reg: &Registration<'_>) -> Option<CrossCorrelation> {
    let p = reg.prepared().ok()?;
    let period = p.oscillation.regular_period().ok();
    let c = ccf(&p.op, &p.pv, period.map_or(FIXED_LAGS, max_lag));
    let m = (c.len() - 1) / 2;
    Some(CrossCorrelation {
        values: c
            .iter()
            .enumerate()
            .map(|(i, &v)| (i as i64 - m as i64, v))
            .collect(),
        max_lag: m,
        period,
        odd_share: odd_share_of(&c),
        integrating: reg.is_integrating(),
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::testing::noise;
    use crate::DetectionTest;
    use std::f64::consts::PI;

    /// OP = 50 + 10 sin(ωk), PV = 20 + 4 sin(ωk − φ): period 50 samples, PV lagging OP by φ.
    fn lagged(n: usize, phi: f64) -> (Vec<f64>, Vec<f64>) {
        let w = 2.0 * PI / 50.0;
        let op = (0..n).map(|k| 50.0 + 10.0 * (w * k as f64).sin()).collect();
        let pv = (0..n)
            .map(|k| 20.0 + 4.0 * (w * k as f64 - phi).sin())
            .collect();
        (op, pv)
    }

    #[test]
    fn the_ellipse_of_a_lagged_sine_has_the_constructed_width_and_centre() {
        let phi = PI / 3.0;
        let (op, pv) = lagged(1000, phi);
        let reg = Registration::new(&pv, &op, 1.0).unwrap();
        let e = pv_op_ellipse(&reg).unwrap();
        assert!((e.period - 50.0).abs() < 0.5, "{}", e.period);
        // Where PV crosses its centre (ωk = φ, φ + π), OP = 50 ± 10 sin φ: width 20 sin φ.
        let width = 20.0 * phi.sin();
        assert!(
            (e.apparent_stiction - width).abs() < 0.05,
            "{} vs {width}",
            e.apparent_stiction
        );
        assert!((e.centre.0 - 50.0).abs() < 0.05 && (e.centre.1 - 20.0).abs() < 0.05);
        assert!((e.chord[1].0 - e.chord[0].0 - width).abs() < 0.05);
        assert!(e.chord.iter().all(|c| (c.1 - 20.0).abs() < 0.05));
        // The curve spans OP 40-60 and PV 16-24, and is closed.
        assert_eq!(e.curve.len(), ELLIPSE_POINTS + 1);
        assert_eq!(e.curve[0], e.curve[ELLIPSE_POINTS]);
        let span = |f: fn(&(f64, f64)) -> f64| {
            e.curve
                .iter()
                .map(f)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                    (l.min(v), h.max(v))
                })
        };
        let (lo, hi) = span(|p| p.0);
        assert!(
            (lo - 40.0).abs() < 0.05 && (hi - 60.0).abs() < 0.05,
            "{lo} {hi}"
        );
        let (lo, hi) = span(|p| p.1);
        assert!(
            (lo - 16.0).abs() < 0.05 && (hi - 24.0).abs() < 0.05,
            "{lo} {hi}"
        );
        // Every sample lies on the curve (to within the 2° spacing of its points).
        for (o, p) in op.iter().zip(&pv).step_by(7) {
            let near = e
                .curve
                .iter()
                .map(|c| (c.0 - o).hypot(c.1 - p))
                .fold(f64::INFINITY, f64::min);
            assert!(near < 0.25, "({o}, {p}) is {near} from the curve");
        }
        // The same number the bicoherence test reports.
        let o = crate::bicoherence::Bicoherence.run(&reg).unwrap();
        assert_eq!(o.value("apparent_stiction"), Some(e.apparent_stiction));
        // In phase: a line, no width.
        let (op, pv) = lagged(1000, 0.0);
        let reg = Registration::new(&pv, &op, 1.0).unwrap();
        assert!(pv_op_ellipse(&reg).unwrap().apparent_stiction < 0.05);
    }

    #[test]
    fn no_regular_oscillation_no_ellipse() {
        let op = noise(1000, 1.0, 5);
        let pv = noise(1000, 1.0, 6);
        let reg = Registration::new(&pv, &op, 1.0).unwrap();
        assert!(pv_op_ellipse(&reg).is_none());
        let flat = vec![1.0; 1000];
        let reg = Registration::new(&pv, &flat, 1.0).unwrap();
        assert!(pv_op_ellipse(&reg).is_none());
        assert!(cross_correlation(&reg).is_none());
    }

    #[test]
    fn the_cross_correlation_peaks_at_the_constructed_lag_over_half_a_period() {
        // PV = OP delayed by 5 samples, period 50: lags ±25, peak at +5.
        let (op, _) = lagged(1000, 0.0);
        let pv: Vec<f64> = (0..1000usize).map(|k| op[k.saturating_sub(5)]).collect();
        let reg = Registration::new(&pv, &op, 1.0).unwrap();
        let c = cross_correlation(&reg).unwrap();
        assert_eq!(c.max_lag, 25);
        assert_eq!(c.values.len(), 51);
        assert_eq!(c.values[0].0, -25);
        assert_eq!(c.values[50].0, 25);
        let best = c.values.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        assert_eq!(best.0, 5, "{:?}", c.values);
        assert!(best.1 > 0.95, "{}", best.1);
        // Horch's statistic is the same number.
        let o = crate::horch::HorchXcorr.run(&reg).unwrap();
        assert_eq!(o.statistic, Some(c.odd_share));
        // A quarter period late: odd.
        let (op, pv) = lagged(1000, PI / 2.0);
        let reg = Registration::new(&pv, &op, 1.0).unwrap();
        assert!(cross_correlation(&reg).unwrap().odd_share > 0.95);
    }

    #[test]
    fn without_an_oscillation_the_cross_correlation_spans_the_fixed_lags() {
        let op = noise(1000, 1.0, 7);
        let e = noise(1000, 0.1, 8);
        let pv: Vec<f64> = (0..1000usize)
            .map(|k| op[k.saturating_sub(3)] + e[k])
            .collect();
        let reg = Registration::new(&pv, &op, 1.0).unwrap();
        let c = cross_correlation(&reg).unwrap();
        assert_eq!(c.period, None);
        assert_eq!(c.max_lag, FIXED_LAGS);
        assert_eq!(c.values.len(), 2 * FIXED_LAGS + 1);
        let best = c.values.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        assert_eq!(best.0, 3);
    }
}
