//! Single-sample spikes: one sample far from both of its neighbours, which agree with each
//! other — a transmitter glitch, a historian's bad value (`-0`, `1000` in a % record), never
//! a valve's or a process' motion, which lasts more than one sample. Left in, one such sample
//! defines the fit: one OP sample of 1000 in a % record gave S = 973.8, one `-0` cell in a
//! simulated loop turned S = 4.0 into 0.7 and the cause into `disturbance`.
//!
//! The rule (fixed, not fitted to any data): with `T` = 10 × the column's interquartile range,
//! sample `i` is a spike when it differs from both neighbours by more than `T` in the same
//! direction while the neighbours differ by at most `T / 10`. A spike is replaced by the
//! previous sample (the next one for the first sample) and the reader's note names the rows.
//! A column whose interquartile range is 0 (mostly constant) is not examined, and when more
//! than 1 % of the samples are spikes they are not spikes but the signal: nothing is replaced
//! and the note says so.

/// The spikes of `x` replaced; `(index, value it had)` of each, or `Err(count)` when more than
/// 1 % of the samples look like spikes (nothing replaced).
pub(crate) fn remove(x: &mut [f64]) -> Result<Vec<(usize, f64)>, usize> {
    let n = x.len();
    if n < 5 {
        return Ok(Vec::new());
    }
    let mut sorted: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if sorted.len() < 5 {
        return Ok(Vec::new());
    }
    sorted.sort_by(f64::total_cmp);
    let q = |p: f64| sorted[((sorted.len() - 1) as f64 * p).round() as usize];
    let iqr = q(0.75) - q(0.25);
    if !(iqr > 0.0 && iqr.is_finite()) {
        return Ok(Vec::new());
    }
    let t = 10.0 * iqr;
    let mut found = Vec::new();
    for i in 0..n {
        let (a, b) = match i {
            0 => (x[1], x[2]),
            _ if i == n - 1 => (x[n - 2], x[n - 3]),
            _ => (x[i - 1], x[i + 1]),
        };
        let v = x[i];
        if !(v.is_finite() && a.is_finite() && b.is_finite()) {
            continue;
        }
        let (da, db) = (v - a, v - b);
        if da.abs() > t && db.abs() > t && da.signum() == db.signum() && (a - b).abs() <= t / 10.0 {
            found.push(i);
        }
    }
    if found.len() * 100 > n {
        return Err(found.len());
    }
    Ok(found
        .into_iter()
        .map(|i| {
            let old = x[i];
            x[i] = if i == 0 { x[1] } else { x[i - 1] };
            (i, old)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wave(n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| 50.0 + 2.0 * (k as f64 / 20.0).sin())
            .collect()
    }

    #[test]
    fn a_single_sample_spike_is_replaced_and_a_step_is_not() {
        let mut x = wave(400);
        x[100] = 1000.0;
        x[0] = -0.0;
        let r = remove(&mut x).unwrap();
        assert_eq!(r.iter().map(|p| p.0).collect::<Vec<_>>(), [0, 100]);
        assert_eq!(x[100], x[99]);
        let mut step = wave(400);
        for v in &mut step[200..] {
            *v += 200.0;
        }
        let before = step.clone();
        assert!(remove(&mut step).unwrap().is_empty());
        assert_eq!(step, before);
    }

    #[test]
    fn many_outliers_are_the_signal_and_are_kept() {
        let mut x = wave(400);
        for k in (0..400).step_by(50) {
            x[k + 3] = 500.0;
        }
        assert_eq!(remove(&mut x.clone()), Err(8));
        let mut flat = vec![1.0; 100];
        flat[50] = 9.0;
        assert!(remove(&mut flat).unwrap().is_empty());
    }
}
