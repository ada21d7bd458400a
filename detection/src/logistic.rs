//! Logistic regression by Newton's method (iteratively reweighted least squares) with a ridge
//! penalty: what `cargo xtask detect-calibrate` fits the score's coefficients with.

/// Fitted coefficients: `p = σ(intercept + Σ wᵢ xᵢ)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// Intercept (not penalised).
    pub intercept: f64,
    /// One weight per feature.
    pub weights: Vec<f64>,
    /// Newton iterations used.
    pub iterations: usize,
}

/// The logistic function.
pub fn sigmoid(z: f64) -> f64 {
    if z >= 0.0 {
        1.0 / (1.0 + (-z).exp())
    } else {
        let e = z.exp();
        e / (1.0 + e)
    }
}

/// Fit `y ~ σ(b + w·x)` to rows `x` (all of one length) with sample weights `sw`, minimising
/// the weighted negative log-likelihood plus `ridge/2 · |w|²`. `None` when the rows are
/// empty or of unequal length, or the Newton system is singular.
pub fn fit(x: &[Vec<f64>], y: &[bool], sw: &[f64], ridge: f64) -> Option<Fit> {
    let n = x.len();
    if n == 0 || y.len() != n || sw.len() != n {
        return None;
    }
    let d = x[0].len();
    if x.iter().any(|r| r.len() != d) {
        return None;
    }
    let p = d + 1; // intercept first
    let mut beta = vec![0.0; p];
    let row = |i: usize, j: usize| if j == 0 { 1.0 } else { x[i][j - 1] };
    let mut iterations = 0;
    for it in 0..100 {
        iterations = it + 1;
        let mut g = vec![0.0; p];
        let mut h = vec![vec![0.0; p]; p];
        for i in 0..n {
            let z: f64 = (0..p).map(|j| beta[j] * row(i, j)).sum();
            let mu = sigmoid(z);
            let r = sw[i] * (mu - if y[i] { 1.0 } else { 0.0 });
            let w = sw[i] * (mu * (1.0 - mu)).max(1e-12);
            for (a, (ga, ha)) in g.iter_mut().zip(h.iter_mut()).enumerate() {
                let xa = row(i, a);
                *ga += r * xa;
                for (b, hab) in ha.iter_mut().enumerate() {
                    *hab += w * xa * row(i, b);
                }
            }
        }
        for a in 1..p {
            g[a] += ridge * beta[a];
            h[a][a] += ridge;
        }
        let step = solve(h, g)?;
        let mut size = 0.0_f64;
        for a in 0..p {
            beta[a] -= step[a];
            size = size.max(step[a].abs());
        }
        if size < 1e-10 {
            break;
        }
    }
    Some(Fit {
        intercept: beta[0],
        weights: beta[1..].to_vec(),
        iterations,
    })
}

/// [`fit`] with every weight at least 0: a feature whose unconstrained weight comes out
/// negative is left out (its weight 0) and the rest refitted, until no weight is negative
/// (an active set: a left-out feature stays out). For features that are each centred so that
/// a positive value is their evidence *for* the class, a negative weight reads a test against
/// its own physics; such a weight fits the training population's accidents, not the mechanism,
/// and does not carry to data from elsewhere. `None` as [`fit`].
pub fn fit_nonnegative(x: &[Vec<f64>], y: &[bool], sw: &[f64], ridge: f64) -> Option<Fit> {
    let d = x.first().map_or(0, Vec::len);
    if x.iter().any(|r| r.len() != d) {
        return None;
    }
    let mut keep: Vec<usize> = (0..d).collect();
    loop {
        let reduced: Vec<Vec<f64>> = x
            .iter()
            .map(|r| keep.iter().map(|&j| r[j]).collect())
            .collect();
        let f = fit(&reduced, y, sw, ridge)?;
        if f.weights.iter().all(|&w| w >= 0.0) {
            let mut weights = vec![0.0; d];
            for (&j, &w) in keep.iter().zip(&f.weights) {
                weights[j] = w;
            }
            return Some(Fit { weights, ..f });
        }
        keep = keep
            .iter()
            .zip(&f.weights)
            .filter(|(_, &w)| w >= 0.0)
            .map(|(&j, _)| j)
            .collect();
    }
}

/// Solve `a x = b` by Gaussian elimination with partial pivoting.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for col in 0..n {
        let piv = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() <= 1e-14 || !a[piv][col].is_finite() {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        let pivot_row = a[col].clone();
        for r in col + 1..n {
            let f = a[r][col] / pivot_row[col];
            for (arc, pc) in a[r][col..].iter_mut().zip(&pivot_row[col..]) {
                *arc -= f * pc;
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|j| a[i][j] * x[j]).sum();
        x[i] = (b[i] - s) / a[i][i];
    }
    Some(x)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// A deterministic population: `y = 1` where a pseudo-random draw is below
    /// `σ(1 + 2 x₀ − 1.5 x₁)`, `x₀` and `x₁` on two interleaved grids.
    fn population() -> (Vec<Vec<f64>>, Vec<bool>) {
        let (mut x, mut y) = (Vec::new(), Vec::new());
        let mut state = 777u64;
        for i in 0..4000 {
            let a = -2.0 + 4.0 * (i as f64 / 4000.0);
            let b = -2.0 + 4.0 * ((i * 37 % 4000) as f64 / 4000.0);
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            x.push(vec![a, b]);
            y.push(u < sigmoid(1.0 + 2.0 * a - 1.5 * b));
        }
        (x, y)
    }

    #[test]
    fn a_weight_against_its_feature_is_left_out() {
        let (x, y) = population();
        let sw = vec![1.0; x.len()];
        let free = fit(&x, &y, &sw, 0.0).unwrap();
        assert!(free.weights[1] < -1.0, "{free:?}");
        let f = fit_nonnegative(&x, &y, &sw, 0.0).unwrap();
        assert_eq!(f.weights[1], 0.0, "{f:?}");
        assert!(
            (f.weights[0] - free.weights[0]).abs() < 1.0 && f.weights[0] > 1.0,
            "{f:?}"
        );
        // The kept feature's weight is the fit without the left-out one.
        let alone: Vec<Vec<f64>> = x.iter().map(|r| vec![r[0]]).collect();
        let g = fit(&alone, &y, &sw, 0.0).unwrap();
        assert!((f.weights[0] - g.weights[0]).abs() < 1e-9, "{f:?} {g:?}");
        // With every weight already non-negative, the constrained fit is the free one.
        let flipped: Vec<Vec<f64>> = x.iter().map(|r| vec![r[0], -r[1]]).collect();
        assert_eq!(
            fit_nonnegative(&flipped, &y, &sw, 0.0).unwrap(),
            fit(&flipped, &y, &sw, 0.0).unwrap()
        );
    }

    #[test]
    fn recovers_a_known_logistic_model() {
        // Deterministic design: x on a grid, y = 1 where a fixed pseudo-random draw < σ(1 + 2x).
        let mut x = Vec::new();
        let mut y = Vec::new();
        let mut state = 12345u64;
        for i in 0..4000 {
            let v = -2.0 + 4.0 * (i as f64 / 4000.0);
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            x.push(vec![v]);
            y.push(u < sigmoid(1.0 + 2.0 * v));
        }
        let f = fit(&x, &y, &vec![1.0; x.len()], 0.0).unwrap();
        assert!((f.intercept - 1.0).abs() < 0.2, "{f:?}");
        assert!((f.weights[0] - 2.0).abs() < 0.3, "{f:?}");
    }
}
