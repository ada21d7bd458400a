//! Records that cannot identify stiction, refused before the search (issue 15): an estimate
//! with a confident region from such data would be a plausible wrong answer.
//!
//! * A sample so large (|x| >= 1e60) that sums of squares and their products overflow: every node would be a
//!   "singular regression"; the sample is named instead.
//! * PV an exact affine function of OP (PV = a + b·OP at every sample, e.g. a copied column):
//!   there are no process dynamics to separate the valve from; the ARX regression on OP is
//!   singular (what `identify` reports), yet a stiction model's MV breaks the collinearity
//!   and the search would return some S with a region excluding zero.
//!
//! (Constant OP or PV, a record too short, OP that never reverses and a grid step over the
//! span are refused in `search.rs` and `budget.rs`.)

use crate::SearchError;

/// Values of this magnitude or more are refused (the reader's limit): sums of squares over a
/// long record and products of such sums must stay finite.
pub const TOO_LARGE: f64 = 1e60;

/// Refuse records that cannot identify stiction (see the module documentation).
pub fn check_identifiable(op: &[f64], pv: &[f64]) -> Result<(), SearchError> {
    for (signal, x) in [("OP", op), ("PV", pv)] {
        if let Some(i) = x.iter().position(|v| v.abs() >= TOO_LARGE) {
            return Err(SearchError::NotIdentifiable {
                reason: format!(
                    "{signal} sample {i} is {:e}, too large to compute with (|value| >= 1e60); rescale it",
                    x[i]
                ),
            });
        }
    }
    if let Some((a, b)) = exact_affine(op, pv) {
        return Err(SearchError::NotIdentifiable {
            reason: format!(
                "PV is an exact linear function of OP (PV = {a:.6} + {b:.6} OP at every sample): no process dynamics to tell the valve from (a copied column?)"
            ),
        });
    }
    Ok(())
}

/// `Some((a, b))` when `y = a + b x` holds to rounding error at every sample.
fn exact_affine(x: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    let n = x.len().min(y.len());
    if n < 3 {
        return None;
    }
    let nf = n as f64;
    let mx = x[..n].iter().sum::<f64>() / nf;
    let my = y[..n].iter().sum::<f64>() / nf;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (dx, dy) = (x[i] - mx, y[i] - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    if !(sxx > 0.0 && syy > 0.0) {
        return None;
    }
    let b = sxy / sxx;
    let a = my - b * mx;
    let sse: f64 = (0..n).map(|i| (y[i] - a - b * x[i]).powi(2)).sum();
    (sse <= 1e-20 * syy).then_some((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn affine_copies_are_found_and_dynamics_are_not() {
        let op: Vec<f64> = (0..200)
            .map(|k| 50.0 + (k as f64 * 0.3).sin() * 5.0)
            .collect();
        assert!(check_identifiable(&op, &op).is_err());
        let scaled: Vec<f64> = op.iter().map(|v| 3.0 - 0.5 * v).collect();
        assert!(check_identifiable(&op, &scaled).is_err());
        let lagged: Vec<f64> = (0..200).map(|k| op[k.max(1) - 1]).collect();
        assert!(check_identifiable(&op, &lagged).is_ok());
        let mut big = op.clone();
        big[7] = 1e200;
        let e = check_identifiable(&big, &lagged).unwrap_err().to_string();
        assert!(e.contains("OP sample 7"), "{e}");
    }
}
