//! The training population's cross-validated AUC: the figure that design choices between
//! score structures are made on (the in-sample AUC favours whichever has more to fit).

use super::*;

/// Folds of [`cross_validated`].
const FOLDS: usize = 5;

/// Print [`cross_validated`]'s figures.
pub(super) fn print_cross_validated(cases: &[&Case], ridge: f64) -> Result<()> {
    let (all, own, integrating) = cross_validated(cases, ridge)?;
    println!(
        "training population, {FOLDS}-fold cross-validated AUC (the figure a choice between score structures is made on): all {}, self-regulating {}, integrating {}",
        fmt_auc(all),
        fmt_auc(own),
        fmt_auc(integrating)
    );
    Ok(())
}

/// The score's AUC on the judgeable training loops, each scored by a model fitted (as [`fit`]
/// fits it, without the thresholds) on the other folds (loop `i` in fold `i mod FOLDS`):
/// `(all, self-regulating, integrating)`.
fn cross_validated(cases: &[&Case], ridge: f64) -> Result<(Option<f64>, Option<f64>, Option<f64>)> {
    let cases: Vec<&&Case> = cases.iter().filter(|c| c.judgeable).collect();
    let mut scored: Vec<(f64, bool, bool)> = Vec::with_capacity(cases.len());
    for fold in 0..FOLDS {
        let rest: Vec<&&&Case> = (0..cases.len())
            .filter(|i| i % FOLDS != fold)
            .map(|i| &cases[i])
            .collect();
        let x: Vec<Vec<f64>> = rest.iter().map(|c| c.x.clone()).collect();
        let y: Vec<bool> = rest.iter().map(|c| c.sticky).collect();
        let f = coefficients(&x, &y, ridge)?;
        for c in (0..cases.len())
            .filter(|i| i % FOLDS == fold)
            .map(|i| cases[i])
        {
            let z = f.intercept + f.weights.iter().zip(&c.x).map(|(w, v)| w * v).sum::<f64>();
            scored.push((z, c.sticky, c.integrating));
        }
    }
    let of = |kind: Option<bool>| -> Option<f64> {
        let v: Vec<(f64, bool)> = scored
            .iter()
            .filter(|s| kind.is_none_or(|k| s.2 == k))
            .map(|s| (s.0, s.1))
            .collect();
        auc(&v)
    };
    Ok((of(None), of(Some(false)), of(Some(true))))
}

/// The score's coefficients on rows `x` with labels `y`: ridge-penalised logistic regression
/// with every weight at least 0 ([`logistic::fit_nonnegative`]; each feature is centred so
/// that a positive value is its test's evidence for stiction).
pub(super) fn coefficients(x: &[Vec<f64>], y: &[bool], ridge: f64) -> Result<logistic::Fit> {
    logistic::fit_nonnegative(x, y, &vec![1.0; x.len()], ridge)
        .context("the logistic fit failed (singular)")
}
