//! Is the loop integrating? Decided from how PV answers OP.
//!
//! A self-regulating process settles: PV's *level* follows OP (through a lag and a dead time).
//! An integrating one (a tank level) does not settle: PV's *rate* follows OP, so PV follows
//! OP's running sum. Both are fitted to the record as free-run models of OP alone (no PV
//! feedback, so measurement noise does not bias them), each with a constant and a linear trend
//! (a constant load on a level is a ramp):
//!
//! * self-regulating: `PV(k) ≈ a + b k + K x(k)`, `x` OP through a first-order lag of `τ`
//!   samples delayed by `d`, the best `(τ, d)` of a grid, `τ` at most a third of the record (a
//!   process that has not settled within the record cannot be told from an integrator);
//! * integrating: `PV(k) ≈ a + b k + g Σ_{i<=k} OP(i - d)`, the best `d`.
//!
//! Both gains must have the plant's sign, read from the controller's same-sample answer (a
//! PI controller moves OP against PV's change within the sample, so the plant's gain is the
//! sign opposite to that of `ΔOP·ΔPV`): a fit of the other sign explains PV by the controller
//! read backwards (PV's level "follows" OP through the proportional action), not by the plant.
//!
//! The statistic is unit-free: `ln(RSS_self / RSS_integrating)` of the two residual sums.
//! The rule: at least [`INTEGRATING_AT`] (the integrator leaves at most half the residual of
//! the best self-regulating model) is integrating; at most −[`INTEGRATING_AT`] is
//! self-regulating; between, the record does not decide (a tie: the caller may fall back on
//! the tag's letter).

use crate::signal::mean;

/// `|ln(RSS_self / RSS_integrating)|` at or above which the record decides (ln 2).
pub const INTEGRATING_AT: f64 = std::f64::consts::LN_2;

/// What the record says about its loop kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KindEvidence {
    /// `ln(RSS_self / RSS_integrating)`: positive when the running sum of OP explains PV
    /// better than a settling response does.
    pub log_ratio: f64,
    /// `Some(true)` integrating, `Some(false)` self-regulating, `None` a tie.
    pub integrating: Option<bool>,
}

/// Residual sum of squares of `y` on `[1, k, x]` by least squares (`f64::INFINITY` when
/// singular); a gain on `x` of the sign opposite to `sign` is no fit of the plant (the
/// residual of `[1, k]` alone).
// Index loops over a 3×3 elimination read as the algebra does.
#[allow(clippy::needless_range_loop)]
fn rss3(y: &[f64], x: &[f64], sign: f64) -> f64 {
    let n = y.len();
    let mut g = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    let scale = 1.0 / n as f64;
    for k in 0..n {
        let v = [1.0, k as f64 * scale, x[k]];
        for i in 0..3 {
            r[i] += v[i] * y[k];
            for j in 0..3 {
                g[i][j] += v[i] * v[j];
            }
        }
    }
    // Gaussian elimination with a tiny ridge.
    let tr = g[0][0] + g[1][1] + g[2][2];
    for (i, row) in g.iter_mut().enumerate() {
        row[i] += 1e-12 * tr;
    }
    let mut a = g;
    let mut b = r;
    for c in 0..3 {
        let p = a[c][c];
        if p.abs() < 1e-300 {
            return f64::INFINITY;
        }
        for rr in (c + 1)..3 {
            let f = a[rr][c] / p;
            for cc in c..3 {
                a[rr][cc] -= f * a[c][cc];
            }
            b[rr] -= f * b[c];
        }
    }
    let mut beta = [0.0f64; 3];
    for c in (0..3).rev() {
        let s: f64 = ((c + 1)..3).map(|j| a[c][j] * beta[j]).sum();
        beta[c] = (b[c] - s) / a[c][c];
    }
    if beta[2] * sign < 0.0 {
        return rss3(y, &vec![0.0; n], 0.0);
    }
    (0..n)
        .map(|k| {
            let e = y[k] - beta[0] - beta[1] * k as f64 * scale - beta[2] * x[k];
            e * e
        })
        .sum()
}

/// How PV answers OP ([`KindEvidence`]); `None` when the record is too short (fewer than 50
/// samples) or PV or OP does not move.
pub fn evidence(pv: &[f64], op: &[f64]) -> Option<KindEvidence> {
    let n = pv.len().min(op.len());
    if n < 50 || pv[..n].iter().chain(&op[..n]).any(|v| !v.is_finite()) {
        return None;
    }
    let (pm, om) = (mean(&pv[..n]), mean(&op[..n]));
    let spread = |x: &[f64], m: f64| (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>()).sqrt();
    let (ps, os) = (spread(&pv[..n], pm), spread(&op[..n], om));
    if !(ps > 0.0 && os > 0.0) {
        return None;
    }
    let u: Vec<f64> = op[..n].iter().map(|v| (v - om) / os).collect();
    // The plant's gain sign: in a feedback loop the controller moves OP against PV within the
    // same sample (its proportional action on the measurement, noise included), so the
    // same-sample changes of OP and PV are of opposite signs when the plant's gain is positive.
    let same_sample: f64 = (1..n)
        .map(|k| (op[k] - op[k - 1]) * (pv[k] - pv[k - 1]))
        .sum();
    let sign = if same_sample > 0.0 { -1.0 } else { 1.0 };
    let delays: Vec<usize> = [0usize, 1, 2, 4, 8, 16]
        .into_iter()
        .filter(|&d| d <= n / 10)
        .collect();
    let start = *delays.last().unwrap_or(&0);
    let y: Vec<f64> = pv[start..n].iter().map(|v| (v - pm) / ps).collect();
    let shifted = |x: &[f64], d: usize| -> Vec<f64> { x[start - d..n - d].to_vec() };
    // Self-regulating: lags from none up to a third of the record, doubling.
    let mut taus = vec![0.0f64];
    let mut t = 1.0;
    while t <= n as f64 / 3.0 {
        taus.push(t);
        t *= 2.0;
    }
    let mut best_self = f64::INFINITY;
    for &tau in &taus {
        let p = if tau > 0.0 { (-1.0 / tau).exp() } else { 0.0 };
        let mut x = vec![0.0; n];
        let mut acc = 0.0;
        for k in 0..n {
            acc = p * acc + (1.0 - p) * u[k];
            x[k] = acc;
        }
        for &d in &delays {
            best_self = best_self.min(rss3(&y, &shifted(&x, d), sign));
        }
    }
    let mut sum = vec![0.0; n];
    let mut acc = 0.0;
    for k in 0..n {
        acc += u[k];
        sum[k] = acc;
    }
    let best_int = delays
        .iter()
        .map(|&d| rss3(&y, &shifted(&sum, d), sign))
        .fold(f64::INFINITY, f64::min);
    if !(best_self.is_finite() && best_int.is_finite() && best_int > 0.0 && best_self > 0.0) {
        return None;
    }
    let log_ratio = (best_self / best_int).ln();
    let integrating = if log_ratio >= INTEGRATING_AT {
        Some(true)
    } else if log_ratio <= -INTEGRATING_AT {
        Some(false)
    } else {
        None
    };
    Some(KindEvidence {
        log_ratio,
        integrating,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// A PI loop around a tank filled by OP (integrating: the rate follows OP) or around a
    /// first-order process (the level follows OP), with set-point steps and measurement noise:
    /// `(op, pv)`.
    fn closed_loop(integrating: bool) -> (Vec<f64>, Vec<f64>) {
        let n = 1500;
        let (mut op, mut pv) = (vec![50.0; n], vec![50.0; n]);
        let mut y = 50.0;
        let mut seed = 12345u64;
        let mut noise = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.2
        };
        let (kc, ki) = if integrating { (2.0, 0.02) } else { (0.5, 0.1) };
        let mut e_prev = 0.0;
        for k in 1..n {
            y = if integrating {
                y + 0.02 * (op[k - 1] - 50.0)
            } else {
                0.9 * y + 0.1 * op[k - 1]
            };
            pv[k] = y + noise();
            let sp = if (k / 300) % 2 == 0 { 50.0 } else { 55.0 };
            let e = sp - pv[k];
            op[k] = op[k - 1] + kc * (e - e_prev) + ki * e;
            e_prev = e;
        }
        (op, pv)
    }

    #[test]
    fn the_rate_or_the_level_following_op_decides() {
        let (op, level) = closed_loop(true);
        let e = evidence(&level, &op).unwrap();
        assert_eq!(e.integrating, Some(true), "{e:?}");
        let (op_first, first) = closed_loop(false);
        let e = evidence(&first, &op_first).unwrap();
        assert_eq!(e.integrating, Some(false), "{e:?}");
        // in other units, the same decision
        let scaled: Vec<f64> = level.iter().map(|v| 1000.0 + 40.0 * v).collect();
        assert_eq!(evidence(&scaled, &op).unwrap().integrating, Some(true));
        // flat or short records say nothing
        assert!(evidence(&vec![1.0; 1500], &op).is_none());
        assert!(evidence(&level[..20], &op[..20]).is_none());
    }
}
