//! What the baseline gets wrong: statistics of its residuals on the validation window.

use serde::Serialize;

/// Lags of the whiteness and cross-correlation tests.
pub const MAX_LAG: usize = 20;
/// Upper edge of the "low-frequency" band, rad/sample (periods longer than ~63 samples).
pub const LOW_BAND: f64 = 0.1;

/// Residual statistics of a fitted model on the validation window `[split, N)`.
///
/// `prediction` residuals are PV minus the one-step prediction (what the identification
/// minimises); `simulation` residuals are PV minus the free-run simulation from the estimated
/// MV (what the model says the loop does without measured PV).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResidualAnalysis {
    /// Validation samples used.
    pub samples: usize,
    /// Ljung–Box Q of the prediction residuals over lags 1..=20.
    pub ljung_box_q: f64,
    /// The 99 % point of χ²(20): Q above it rejects whiteness.
    pub ljung_box_limit: f64,
    /// Largest |cross-correlation| of the prediction residuals with past estimated MV
    /// (lags 0..=20), in units of its white-noise standard error 1/√n.
    pub cross_mv_z: f64,
    /// Lag (samples) of that largest cross-correlation.
    pub cross_mv_lag: usize,
    /// Fraction of the simulation residuals' power below 0.1 rad/sample, divided by the
    /// fraction white noise would have there (0.1/π): 1 for white, ≫ 1 for slow content.
    pub low_frequency_ratio: f64,
    /// Simulation-residual variance over prediction-residual variance (≫ 1 when the free run
    /// misses something slow the one-step predictor hides behind measured PV).
    pub sim_to_pred_variance: f64,
    /// t statistic of a linear trend in the simulation residuals.
    pub trend_t: f64,
    /// Mean prediction residual while the estimated valve moves up, and while it moves down.
    pub mean_up: f64,
    /// See `mean_up`.
    pub mean_down: f64,
    /// Welch t statistic of `mean_up - mean_down`.
    pub direction_t: f64,
    /// Prediction-residual variance while the valve moves over the variance while it is stuck.
    pub moving_to_stuck_variance: f64,
    /// Fraction of validation samples with the estimated valve stuck.
    pub stuck_fraction: f64,
}

fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        x.iter().sum::<f64>() / x.len() as f64
    }
}

fn var(x: &[f64]) -> f64 {
    if x.len() < 2 {
        return 0.0;
    }
    let m = mean(x);
    x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - 1) as f64
}

fn autocorr(x: &[f64], lag: usize) -> f64 {
    let m = mean(x);
    let d: f64 = x.iter().map(|v| (v - m) * (v - m)).sum();
    if d <= 0.0 || lag >= x.len() {
        return 0.0;
    }
    let n: f64 = (lag..x.len()).map(|k| (x[k] - m) * (x[k - lag] - m)).sum();
    n / d
}

fn cross(r: &[f64], u: &[f64], lag: usize) -> f64 {
    let (mr, mu) = (mean(r), mean(u));
    let (sr, su) = (
        r.iter().map(|v| (v - mr).powi(2)).sum::<f64>(),
        u.iter().map(|v| (v - mu).powi(2)).sum::<f64>(),
    );
    if sr <= 0.0 || su <= 0.0 || lag >= r.len() {
        return 0.0;
    }
    let n: f64 = (lag..r.len())
        .map(|k| (r[k] - mr) * (u[k - lag] - mu))
        .sum();
    n / (sr * su).sqrt()
}

/// Fraction of the power of `x` (mean removed) at DFT frequencies `0 < ω <= band`.
fn low_band_fraction(x: &[f64], band: f64) -> f64 {
    let n = x.len();
    let m = mean(x);
    let total: f64 = x.iter().map(|v| (v - m) * (v - m)).sum();
    if n < 4 || total <= 0.0 {
        return 0.0;
    }
    let kmax = ((band * n as f64) / (2.0 * std::f64::consts::PI)).floor() as usize;
    let mut low = 0.0;
    for k in 1..=kmax.min(n / 2) {
        let w = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
        let (mut re, mut im) = (0.0, 0.0);
        for (t, v) in x.iter().enumerate() {
            let a = w * t as f64;
            re += (v - m) * a.cos();
            im -= (v - m) * a.sin();
        }
        // Two-sided: bins k and n-k carry the same power.
        low += 2.0 * (re * re + im * im) / n as f64;
    }
    low / total
}

impl ResidualAnalysis {
    /// Analyse `pv` against the one-step prediction `pred` and the free-run simulation `sim`
    /// (full-length series, NaN where undefined) on `[split, N)`, with the estimated valve
    /// position `mv`.
    pub fn new(pv: &[f64], pred: &[f64], sim: &[f64], mv: &[f64], split: usize) -> Self {
        let n = pv.len();
        let idx: Vec<usize> = (split.max(1)..n)
            .filter(|&k| pred[k].is_finite() && sim[k].is_finite())
            .collect();
        let rp: Vec<f64> = idx.iter().map(|&k| pv[k] - pred[k]).collect();
        let rs: Vec<f64> = idx.iter().map(|&k| pv[k] - sim[k]).collect();
        let u: Vec<f64> = idx.iter().map(|&k| mv[k]).collect();
        let nv = rp.len().max(1) as f64;
        let q = nv
            * (nv + 2.0)
            * (1..=MAX_LAG)
                .map(|l| autocorr(&rp, l).powi(2) / (nv - l as f64).max(1.0))
                .sum::<f64>();
        let (mut cz, mut clag) = (0.0, 0);
        for l in 0..=MAX_LAG {
            let z = cross(&rp, &u, l).abs() * nv.sqrt();
            if z > cz {
                cz = z;
                clag = l;
            }
        }
        let lf = low_band_fraction(&rs, LOW_BAND) / (LOW_BAND / std::f64::consts::PI);
        let vp = var(&rp);
        let ratio = if vp > 0.0 { var(&rs) / vp } else { 1.0 };
        // Trend: OLS slope of rs on t, t statistic with the residual variance (not corrected
        // for autocorrelation: read it as a size, not a p-value).
        let trend_t = {
            let t: Vec<f64> = (0..rs.len()).map(|i| i as f64).collect();
            let (mt, mr) = (mean(&t), mean(&rs));
            let stt: f64 = t.iter().map(|v| (v - mt).powi(2)).sum();
            if stt > 0.0 && rs.len() > 2 {
                let b = t
                    .iter()
                    .zip(&rs)
                    .map(|(a, r)| (a - mt) * (r - mr))
                    .sum::<f64>()
                    / stt;
                let e: f64 = t
                    .iter()
                    .zip(&rs)
                    .map(|(a, r)| (r - mr - b * (a - mt)).powi(2))
                    .sum::<f64>()
                    / (rs.len() - 2) as f64;
                if e > 0.0 {
                    b / (e / stt).sqrt()
                } else {
                    0.0
                }
            } else {
                0.0
            }
        };
        let (mut up, mut dn, mut moving, mut stuck) = (vec![], vec![], vec![], vec![]);
        for (i, &k) in idx.iter().enumerate() {
            let d = mv[k] - mv[k - 1];
            if d > 0.0 {
                up.push(rp[i]);
                moving.push(rp[i]);
            } else if d < 0.0 {
                dn.push(rp[i]);
                moving.push(rp[i]);
            } else {
                stuck.push(rp[i]);
            }
        }
        let direction_t = {
            let se = (var(&up) / up.len().max(1) as f64 + var(&dn) / dn.len().max(1) as f64).sqrt();
            if se > 0.0 && up.len() > 1 && dn.len() > 1 {
                (mean(&up) - mean(&dn)) / se
            } else {
                0.0
            }
        };
        let vs = var(&stuck);
        ResidualAnalysis {
            samples: rp.len(),
            ljung_box_q: q,
            ljung_box_limit: 37.566,
            cross_mv_z: cz,
            cross_mv_lag: clag,
            low_frequency_ratio: lf,
            sim_to_pred_variance: ratio,
            trend_t,
            mean_up: mean(&up),
            mean_down: mean(&dn),
            direction_t,
            moving_to_stuck_variance: if vs > 0.0 {
                var(&moving) / vs
            } else {
                f64::NAN
            },
            stuck_fraction: stuck.len() as f64 / nv,
        }
    }

    /// One paragraph on what is left over and where.
    pub fn describe(&self) -> String {
        let white = if self.ljung_box_q > self.ljung_box_limit {
            format!(
                "are not white (Ljung-Box Q = {:.0} over 20 lags, 99 % limit {:.0})",
                self.ljung_box_q, self.ljung_box_limit
            )
        } else {
            format!(
                "are white (Ljung-Box Q = {:.0} over 20 lags, below the 99 % limit {:.0})",
                self.ljung_box_q, self.ljung_box_limit
            )
        };
        let cross = if self.cross_mv_z > 2.58 {
            format!(
                "they still depend on the valve position (cross-correlation {:.1} standard errors at lag {})",
                self.cross_mv_z, self.cross_mv_lag
            )
        } else {
            "they do not depend on past valve positions".to_string()
        };
        let slow = format!(
            "the free-run simulation leaves {:.1} times the prediction's residual variance, with {:.1} times the low-frequency power (below 0.1 rad/sample) of white noise",
            self.sim_to_pred_variance, self.low_frequency_ratio
        );
        let dir = format!(
            "the mean residual is {:+.3} while the valve opens and {:+.3} while it closes (t = {:.1}); moving/stuck variance ratio {:.2}, valve stuck {:.0} % of the time",
            self.mean_up,
            self.mean_down,
            self.direction_t,
            self.moving_to_stuck_variance,
            100.0 * self.stuck_fraction
        );
        format!("On the {} validation samples the prediction residuals {white}; {cross}; {slow}; {dir}.", self.samples)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn low_band_of_a_slow_sine_and_of_an_alternating_signal() {
        let slow: Vec<f64> = (0..1000).map(|k| (0.03 * k as f64).sin()).collect();
        let fast: Vec<f64> = (0..1000)
            .map(|k| if k % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        assert!(low_band_fraction(&slow, 0.1) > 0.9);
        assert!(low_band_fraction(&fast, 0.1) < 1e-9);
    }

    #[test]
    fn direction_t_sees_a_direction_dependent_offset() {
        let n = 400;
        let mv: Vec<f64> = (0..n)
            .map(|k| ((k / 10) % 2) as f64 * (k % 10) as f64)
            .collect();
        let pv = vec![0.0; n];
        // Residual +0.5 when mv rises, -0.5 otherwise, plus a deterministic wiggle.
        let pred: Vec<f64> = (0..n)
            .map(|k| {
                let up = k > 0 && mv[k] > mv[k - 1];
                (if up { -0.5 } else { 0.5 }) + 0.01 * ((k * 7919) % 13) as f64
            })
            .collect();
        let a = ResidualAnalysis::new(&pv, &pred, &pred, &mv, 100);
        assert!(a.direction_t > 10.0, "{}", a.direction_t);
    }
}
