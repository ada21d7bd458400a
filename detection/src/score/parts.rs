//! The parts of a record that [`super::settle`] judges, and the check of a `stiction` verdict
//! that runs a part's Hammerstein test only when a floor under its evidence cannot rule out
//! the part's `no-stiction`.
//!
//! A part contradicts a `stiction` verdict only by saying `no-stiction`, which needs its
//! score at most [`Model::no_stiction_at`]. Every input of the score but the Hammerstein
//! test's is computed; the Hammerstein test's two likelihood features grow with its
//! likelihood ratios (weights at least 0), and [`crate::hammerstein::floor`] bounds those
//! from below with the free valve and the whole record's best valve alone (one pass of the
//! test's lanes instead of the grid's dozen or more); its third, the free valve's explained
//! share, the floor gives exactly (the free valve's fit is the test's own). When the score
//! with the floor's features is above the threshold, the part cannot say `no-stiction` and
//! its Hammerstein test is not run; else it is, and the part is judged as [`super::parts`]
//! judges it. The verdict is the one
//! [`super::settle_on`] gives on [`super::parts`] (tests `the_fast_parts_check_is_the_full_one`
//! in `tests/population.rs`); a part's evidence itself is not reported.

use super::{features, Detection, Evidence, Model, FEATURES};
use crate::{hammerstein, registry, run_entry, Registration, TestOutcome, Verdict};

/// One part of a record: what it is, and its data.
pub(super) struct Part {
    pub(super) what: &'static str,
    pv: Vec<f64>,
    op: Vec<f64>,
    sp: Option<Vec<f64>>,
    ts: f64,
}

impl Part {
    /// The first half, the second half, every second sample (at twice the sampling time) and
    /// the means of each two samples (at twice the sampling time: a historian's average
    /// retrieval at twice the interval; averaging a band's slips away is what an averaged
    /// export does to the evidence, and it flipped records that every second sample did not).
    pub(super) fn of(reg: &Registration<'_>) -> [Part; 4] {
        let n = reg.len();
        let h = n / 2;
        let every_second = |x: &[f64]| -> Vec<f64> { x.iter().step_by(2).copied().collect() };
        let pair_means =
            |x: &[f64]| -> Vec<f64> { x.chunks_exact(2).map(|c| 0.5 * (c[0] + c[1])).collect() };
        let ts = reg.sample_time();
        let slice = |what, r: std::ops::Range<usize>| Part {
            what,
            pv: reg.pv()[r.clone()].to_vec(),
            op: reg.op()[r.clone()].to_vec(),
            sp: reg.sp().map(|s| s[r].to_vec()),
            ts,
        };
        // a part at twice the sampling time, each series through `f`
        let coarse = |what, f: &dyn Fn(&[f64]) -> Vec<f64>| Part {
            what,
            pv: f(reg.pv()),
            op: f(reg.op()),
            sp: reg.sp().map(f),
            ts: 2.0 * ts,
        };
        [
            slice("its first half", 0..h),
            slice("its second half", h..n),
            coarse("every second sample", &every_second),
            coarse("the means of each two samples", &pair_means),
        ]
    }

    /// The part as a registration of the same loop kind as `whole` (`None`: it cannot be one).
    pub(super) fn registration(&self, whole: &Registration<'_>) -> Option<Registration<'_>> {
        let r = Registration::new(&self.pv, &self.op, self.ts)
            .ok()?
            .integrating(whole.is_integrating());
        match &self.sp {
            Some(sp) => r.with_sp(sp).ok(),
            None => Some(r),
        }
    }
}

/// `d` made `inconclusive` because `what` alone says `opposite`.
pub(super) fn contradicted(d: Detection, what: &str, opposite: Verdict) -> Detection {
    Detection {
        verdict: Verdict::Inconclusive,
        reason: format!(
            "{}, but {what} alone says {opposite}: the evidence does not hold across the record",
            d.reason
        ),
        ..d
    }
}

/// [`super::settle`] of a `stiction` verdict `d`.
pub(super) fn settle_stiction(reg: &Registration<'_>, model: &Model, d: Detection) -> Detection {
    let hammer = d.tests.iter().find(|t| t.name == "hammerstein");
    // the whole record's best valve (output error), where its test gave one
    let hint: Vec<(f64, f64)> = hammer
        .and_then(|t| Some((t.value("S")?, t.value("J")?)))
        .into_iter()
        .collect();
    for part in Part::of(reg) {
        let Some(r) = part.registration(reg) else {
            continue;
        };
        if says_no_stiction(&r, model, &hint) {
            return contradicted(d, part.what, Verdict::NoStiction);
        }
    }
    d
}

/// Whether the part `r` alone says `no-stiction` under `model`, its Hammerstein test run only
/// when a floor under its evidence does not rule that out.
fn says_no_stiction(r: &Registration<'_>, model: &Model, hint: &[(f64, f64)]) -> bool {
    let entries = registry();
    let mut tests: Vec<TestOutcome> = Vec::with_capacity(entries.len());
    let mut hammer_at = None;
    for (i, e) in entries.iter().enumerate() {
        if e.name == "hammerstein" {
            hammer_at = Some(i);
        } else {
            tests.push(run_entry(e, r));
        }
    }
    let Some(at) = hammer_at else {
        return Evidence::of(r, tests).judge(model).verdict == Verdict::NoStiction;
    };
    if cannot_say_no_stiction(r, model, &tests, hint) {
        return false;
    }
    tests.insert(at, run_entry(entries[at], r));
    Evidence::of(r, tests).judge(model).verdict == Verdict::NoStiction
}

/// Whether the part `r`, with `tests` (every test but the Hammerstein one), cannot say
/// `no-stiction` whatever the Hammerstein test gives at or above its floor.
fn cannot_say_no_stiction(
    r: &Registration<'_>,
    model: &Model,
    tests: &[TestOutcome],
    hint: &[(f64, f64)],
) -> bool {
    if r.check().is_err() {
        // the part cannot be judged: `inconclusive`, whatever the test gives
        return true;
    }
    let hammer_features: Vec<usize> = FEATURES
        .iter()
        .enumerate()
        .filter(|(_, f)| f.test == "hammerstein")
        .map(|(i, _)| i)
        .collect();
    // a negative weight would read a floor under the ratio as a ceiling on the score
    if hammer_features
        .iter()
        .any(|&i| model.weights.get(i).is_none_or(|w| w.is_nan() || *w < 0.0))
    {
        return false;
    }
    let Ok(Some(f)) = hammerstein::floor(r, hint) else {
        return false;
    };
    let mut with = tests.to_vec();
    with.push(floor_outcome(&f));
    let mut x = features(&with);
    let lift: f64 = hammer_features
        .iter()
        .map(|&i| model.weights[i] * x[i])
        .sum();
    if f.edge && lift > 0.0 {
        // an optimum on the grid's edge gives no statistic: the features' neutral 0
        for &i in &hammer_features {
            x[i] = 0.0;
        }
    }
    // a margin far above the rounding of the score's sum
    model.score(&x) > model.no_stiction_at + 1e-9
}

/// The Hammerstein outcome the score reads at a floor: its likelihood ratios at their floors,
/// and the test's own explained share (exact: its feature is the same at the floor as in the
/// test).
fn floor_outcome(f: &hammerstein::Floor) -> TestOutcome {
    let mut floor = TestOutcome::new("hammerstein", Some(f.lr), Verdict::Inconclusive, "");
    floor.values = vec![("lr_arx", f.lr_arx), ("rows", f.rows as f64)];
    floor.values.extend(f.free_share.map(|s| ("free_share", s)));
    floor
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{kano_first_order, triangle};

    /// OP a triangle of span 10 through a Kano valve `(s, j)` into a first-order process with
    /// noise: `(PV, OP)`.
    fn simulated_loop(s: f64, j: f64) -> (Vec<f64>, Vec<f64>) {
        let op: Vec<f64> = triangle(800, 200.0).iter().map(|v| 5.0 * v).collect();
        (kano_first_order(&op, s, j), op)
    }

    /// Every Hammerstein feature of the score at the floor from the record's best valve is
    /// the test's own: the likelihood features because that floor is the test's ratios, the
    /// explained share because the floor carries the test's own.
    #[test]
    fn the_floor_outcome_gives_the_tests_own_features() {
        for (s, j) in [(3.0, 1.0), (0.0, 0.0)] {
            let (pv, op) = simulated_loop(s, j);
            let r = Registration::new(&pv, &op, 1.0).unwrap();
            let out = run_entry(
                registry().iter().find(|e| e.name == "hammerstein").unwrap(),
                &r,
            );
            let best = (out.value("S").unwrap(), out.value("J").unwrap());
            let f = hammerstein::floor(&r, &[best]).unwrap().unwrap();
            let (at_floor, full) = (features(&[floor_outcome(&f)]), features(&[out]));
            for (i, feature) in FEATURES.iter().enumerate() {
                if feature.name == "hammerstein_oe" || feature.name == "free_explains" {
                    assert_eq!(at_floor[i], full[i], "S = {s}: {}", feature.name);
                }
            }
            let free = FEATURES
                .iter()
                .position(|f| f.name == "free_explains")
                .unwrap();
            assert!(
                full[free] < 0.0,
                "S = {s}: the free valve explains some of PV"
            );
        }
    }
}
