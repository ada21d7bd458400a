//! Helpers shared by the detector's integration tests.

/// ROC AUC of `score` for `sticky` (ties count one half).
pub fn auc(v: &[(f64, bool)]) -> f64 {
    let (mut pairs, mut wins) = (0.0, 0.0);
    for &(a, pa) in v {
        for &(b, pb) in v {
            if pa && !pb {
                pairs += 1.0;
                wins += if a > b {
                    1.0
                } else if a == b {
                    0.5
                } else {
                    0.0
                };
            }
        }
    }
    wins / pairs
}
