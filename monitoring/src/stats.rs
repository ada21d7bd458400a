//! Small robust statistics the workflow needs: median, Theil-Sen slope, ROC.

pub use run::median;

/// Theil–Sen slope of `(x, y)`: the median of pairwise slopes (distinct x).
pub fn theil_sen(points: &[(f64, f64)]) -> Option<f64> {
    let mut slopes = Vec::new();
    for (i, a) in points.iter().enumerate() {
        for b in &points[i + 1..] {
            if (b.0 - a.0).abs() > 1e-9 {
                slopes.push((b.1 - a.1) / (b.0 - a.0));
            }
        }
    }
    (!slopes.is_empty()).then(|| median(&slopes))
}

/// The ROC of a score against labels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Roc {
    /// Area under the curve (ties count one half).
    pub auc: f64,
    /// The threshold maximising Youden's J = TPR − FPR (flag when score ≥ threshold).
    pub threshold: f64,
    /// True-positive rate at that threshold.
    pub tpr: f64,
    /// False-positive rate at that threshold.
    pub fpr: f64,
}

/// The ROC of `scores` for `positive` labels; `None` without both classes.
pub fn roc(scores: &[(f64, bool)]) -> Option<Roc> {
    let pos: Vec<f64> = scores.iter().filter(|s| s.1).map(|s| s.0).collect();
    let neg: Vec<f64> = scores.iter().filter(|s| !s.1).map(|s| s.0).collect();
    if pos.is_empty() || neg.is_empty() {
        return None;
    }
    let mut wins = 0.0;
    for p in &pos {
        for n in &neg {
            wins += if p > n {
                1.0
            } else if p == n {
                0.5
            } else {
                0.0
            };
        }
    }
    let auc = wins / (pos.len() * neg.len()) as f64;
    let mut cuts: Vec<f64> = scores.iter().map(|s| s.0).collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let mut best = (f64::NEG_INFINITY, 0.0, 0.0, 0.0);
    for c in cuts {
        let tpr = pos.iter().filter(|&&x| x >= c).count() as f64 / pos.len() as f64;
        let fpr = neg.iter().filter(|&&x| x >= c).count() as f64 / neg.len() as f64;
        if tpr - fpr > best.0 {
            best = (tpr - fpr, c, tpr, fpr);
        }
    }
    Some(Roc {
        auc,
        threshold: best.1,
        tpr: best.2,
        fpr: best.3,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roc_of_separable_and_random_scores() {
        let s = [(3.0, true), (2.0, true), (1.0, false), (0.5, false)];
        let r = roc(&s).map(|r| (r.auc, r.threshold, r.tpr, r.fpr));
        assert_eq!(r, Some((1.0, 2.0, 1.0, 0.0)));
        let s = [(1.0, true), (2.0, false), (3.0, true), (4.0, false)];
        assert_eq!(roc(&s).map(|r| r.auc), Some(0.25));
        assert_eq!(roc(&[(1.0, true)]), None);
    }

    #[test]
    fn theil_sen_ignores_one_wild_point() {
        let mut pts: Vec<(f64, f64)> = (0..9).map(|k| (k as f64, 1.0 + 0.5 * k as f64)).collect();
        pts[4].1 = 100.0;
        let m = theil_sen(&pts).unwrap_or(f64::NAN);
        assert!((m - 0.5).abs() < 1e-12, "{m}");
        assert!(median(&[]).is_nan());
        assert_eq!(median(&[3.0, 1.0, 2.0, 10.0]), 2.5);
    }
}
