//! One verdict: the tests' statistics combined into a score of the evidence for stiction in
//! [0, 1] (a logistic model fitted on simulated loops: a ranking, not a probability for a valve).
//!
//! The rule is a logistic model, `score = σ(b + Σ wᵢ xᵢ)`, on the few [`FEATURES`] below: each
//! is one test's statistic, centred so that 0 means "no information" (a test that could not
//! judge the registration, or does not apply to its loop kind, contributes 0); one,
//! `free_explains`, is evidence in one direction only (a free valve that explains PV speaks
//! against stiction; one that explains nothing, or a share not read, contributes 0). The
//! coefficients [`INTERCEPT`] and [`WEIGHTS`] were fitted by `cargo xtask detect-calibrate`
//! (ridge-penalised logistic regression, [`crate::logistic`]) on a simulated training
//! population only (`datasets::simulate::population`) and measured on validation populations
//! never fitted on; the shared plant registrations are a test set, never fitted on
//! (`docs/DETECTION.md` has the protocol and the numbers).
//!
//! The verdict: `stiction` when the score is at least [`STICTION_AT`] *and* the loop shows
//! the valve's dynamics — a regular oscillation (a limit cycle), stick-slip (the stick-slip
//! test's own verdict) or a sticky valve that explains PV (the Hammerstein test's own
//! verdict): the shape tests alone never call a loop that does not oscillate and does not
//! stick sticky; `no-stiction` when the score is at most [`NO_STICTION_AT`];
//! `inconclusive` between, and whenever the data cannot be judged (too short, flat, NaN),
//! with the reason.

use crate::logistic::sigmoid;
use crate::{run_all, DetectionError, Registration, TestOutcome, Verdict};

/// One input of the score: a test's statistic, centred and clipped.
#[derive(Debug, Clone, Copy)]
pub struct Feature {
    /// Short name (`stick_slip`).
    pub name: &'static str,
    /// The test it comes from.
    pub test: &'static str,
    /// What the number is.
    pub meaning: &'static str,
    /// From the test's outcome (`None`: the neutral 0).
    pub extract: fn(&TestOutcome) -> Option<f64>,
}

fn stat(o: &TestOutcome) -> Option<f64> {
    o.statistic.filter(|v| v.is_finite())
}

/// Rows a likelihood ratio of the score is expressed for (`per_rows`).
pub const REFERENCE_ROWS: f64 = 500.0;

/// A likelihood ratio `N ln(RSS₀/RSS₁)` as the score reads it: per row (the mean
/// log-likelihood gain, `ln(RSS₀/RSS₁)`, which does not grow with the record's length), times
/// [`REFERENCE_ROWS`]. A ratio that grew with `N` made the verdict depend on how much of a
/// record was exported: the first half of a sticky record scored lower than the whole.
fn per_rows(o: &TestOutcome, lr: f64) -> Option<f64> {
    let rows = o.value("rows").filter(|r| *r > 0.0)?;
    Some(REFERENCE_ROWS * lr.max(0.0) / rows)
}

/// The score's inputs, in the order of [`WEIGHTS`]. The oscillation's regularity is not one of
/// them: a regular oscillation is a condition of the `stiction` verdict (or stick-slip), not
/// evidence for it — healthy loops oscillate too (external disturbances, tuning), and on the
/// plant data the sticky valve's records are the irregular ones.
pub const FEATURES: [Feature; 9] = [
    Feature {
        name: "odd_share",
        test: "horch-xcorr",
        meaning: "odd share of the OP-PV cross-correlation − 0.5",
        extract: |o| stat(o).map(|s| s - 0.5),
    },
    Feature {
        name: "d2_kurtosis",
        test: "horch-integrating",
        meaning: "(kurtosis of PV's second difference − 2.75) / 1.5, clipped to [−1, 1]",
        extract: |o| stat(o).map(|k| ((k - 2.75) / 1.5).clamp(-1.0, 1.0)),
    },
    Feature {
        name: "triangularity",
        test: "curve-fit",
        meaning: "He's stiction index SI − 0.5",
        extract: |o| stat(o).map(|s| s - 0.5),
    },
    Feature {
        name: "ngi",
        test: "bicoherence",
        meaning: "100 · NGI, clipped to [−1, 1]",
        extract: |o| o.value("ngi").map(|g| (100.0 * g).clamp(-1.0, 1.0)),
    },
    Feature {
        name: "stuck_share",
        test: "stick-slip",
        meaning: "share of OP's motion with the valve's proxy steady − 0.15",
        extract: |o| stat(o).map(|r| r - 0.15),
    },
    Feature {
        name: "log_area_ratio",
        test: "area-ratio",
        meaning: "ln R, clipped to [−1, 1]",
        extract: |o| stat(o).map(|r| r.ln().clamp(-1.0, 1.0)),
    },
    Feature {
        name: "hammerstein_oe",
        test: "hammerstein",
        meaning: "ln(1 + LR₅₀₀) / ln 100 − 0.5 of the output-error Kano valve against a free one, LR₅₀₀ the likelihood ratio per row × 500",
        extract: |o| stat(o).and_then(|lr| per_rows(o, lr)).map(|lr| (1.0 + lr).ln() / 100f64.ln() - 0.5),
    },
    Feature {
        name: "hammerstein_arx",
        test: "hammerstein",
        meaning: "ln(1 + LR₅₀₀) / ln 100 − 0.5, at least 0, of the one-step ARX Kano valve against a free one",
        extract: |o| {
            o.value("lr_arx")
                .and_then(|lr| per_rows(o, lr))
                .map(|lr| ((1.0 + lr).ln() / 100f64.ln() - 0.5).max(0.0))
        },
    },
    Feature {
        name: "free_explains",
        test: "hammerstein",
        meaning: "− the share of PV's residual variance a free valve explains (self-regulating loops): evidence against stiction only",
        extract: |o| o.value("free_share").map(|s| -s.clamp(0.0, 1.0)),
    },
];

/// The calibrated intercept: printed by `cargo xtask detect-calibrate` (the training
/// population of `datasets::simulate::population`, 960 loops, seed 1, ridge 0.1, every weight
/// at least 0; no plant registration in the fit).
pub const INTERCEPT: f64 = 0.9252;
/// The calibrated weights, one per entry of [`FEATURES`] (same fit as [`INTERCEPT`]). Each
/// feature is centred so that a positive value is its test's evidence for stiction, and the
/// fit keeps every weight at least 0 ([`crate::logistic::fit_nonnegative`]): a feature whose
/// weight would come out negative reads its test against the test's own physics, and is left
/// at 0 (on the training population: `d2_kurtosis` and `ngi`; their tests still report their
/// own verdicts). `free_explains` is the free valve's explained share negated, so its weight
/// too is at least 0.
pub const WEIGHTS: [f64; 9] = [
    0.2725, 0.0000, 3.7961, 0.0000, 0.5592, 0.9381, 5.1095, 1.2235, 3.0681,
];

/// Score at or above which the verdict may be `stiction`: with [`NO_STICTION_AT`], the pair
/// of a 0.05 grid that decides the training population best with at most 20 % of it
/// inconclusive, judged without the parts' rule; with the parts' rule ([`settle`]) in place,
/// no pair leaves 2 % of the training population fewer inconclusive while right on as large a
/// share of the conclusive (`cargo xtask detect-calibrate`).
pub const STICTION_AT: f64 = 0.5;
/// Score at or below which the verdict may be `no-stiction` (chosen with [`STICTION_AT`]).
pub const NO_STICTION_AT: f64 = 0.5;

/// Stiction band (% of span) that a `no-stiction` verdict must exclude: when the Hammerstein
/// test's likelihood region still holds a Kano valve with this S or more
/// ([`crate::hammerstein::Comparison::s_upper`]), the data cannot tell that valve from a free
/// one (a valve dithered by noise, slips hidden under the noise), and a low score is absence of
/// evidence, not a healthy valve.
pub const HIDDEN_S: f64 = 2.0;

/// Likelihood ratio of the free valve against a valve that never moves
/// ([`crate::hammerstein::Comparison::lr_moving`]) below which PV shows no answer to OP's
/// moves, and `no-stiction` is refused: χ²₃(95 %), the free valve's three parameters (gain,
/// lag, delay) that a motionless valve does not have. With the other condition of the rule
/// (the Hammerstein test's likelihood region reaches the widest band OP's range allows), a
/// physical requirement, not fitted: on the training population it changes the verdict of a
/// few loops only (three draws, `cargo xtask detect-calibrate`: 1409 right and 151 wrong of
/// the conclusive without it, 1406 and 147 with it), and it keeps `no-stiction` off a valve
/// stuck over the whole record whose OP moves a little
/// (`docs/decisions/2026-11-30-stuck-over-the-record.md`).
pub const MOVING_LR: f64 = 7.81;

/// A logistic model on [`FEATURES`] and the thresholds of its verdict.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    /// Intercept.
    pub intercept: f64,
    /// One weight per feature.
    pub weights: Vec<f64>,
    /// Score at or above which the verdict may be `stiction`.
    pub stiction_at: f64,
    /// Score at or below which the verdict may be `no-stiction`.
    pub no_stiction_at: f64,
    /// Stiction band (% of span) that a `no-stiction` verdict must exclude ([`HIDDEN_S`]).
    pub hidden_s: f64,
}

impl Model {
    /// The calibrated model ([`INTERCEPT`], [`WEIGHTS`]).
    pub fn calibrated() -> Model {
        Model {
            intercept: INTERCEPT,
            weights: WEIGHTS.to_vec(),
            stiction_at: STICTION_AT,
            no_stiction_at: NO_STICTION_AT,
            hidden_s: HIDDEN_S,
        }
    }

    /// The score of the evidence for stiction for feature values `x` (logistic, in [0, 1]).
    pub fn score(&self, x: &[f64]) -> f64 {
        let z: f64 = self.intercept + self.weights.iter().zip(x).map(|(w, v)| w * v).sum::<f64>();
        sigmoid(z)
    }
}

/// The feature values of a registration's outcomes (0 where a test is missing or gave no
/// statistic).
pub fn features(outcomes: &[TestOutcome]) -> Vec<f64> {
    FEATURES
        .iter()
        .map(|f| {
            outcomes
                .iter()
                .find(|o| o.name == f.test)
                .and_then(f.extract)
                .filter(|v| v.is_finite())
                .unwrap_or(0.0)
        })
        .collect()
}

/// The combined answer for one registration.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Detection {
    /// Probability of stiction in `[0, 1]` from the logistic model (with no usable evidence,
    /// the model's base rate `σ(b)`).
    pub score: f64,
    /// The verdict.
    pub verdict: Verdict,
    /// Why, in one sentence.
    pub reason: String,
    /// Whether the control error oscillates regularly.
    pub oscillating: bool,
    /// The oscillation's period in seconds, when it oscillates regularly.
    pub period_s: Option<f64>,
    /// Whether the loop was treated as integrating.
    pub integrating: bool,
    /// What decided the loop kind, for people (set by the caller that decided it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integrating_by: Option<String>,
    /// Every test's outcome, in registry order.
    pub tests: Vec<TestOutcome>,
}

/// Run every registered test on `reg` and combine them with the calibrated model.
pub fn detect(reg: &Registration<'_>) -> Detection {
    detect_with(reg, &Model::calibrated())
}

/// Run every registered test on `reg` and combine them with `model`; a conclusive verdict
/// stands only when the parts of the record do not contradict it ([`settle`]).
pub fn detect_with(reg: &Registration<'_>, model: &Model) -> Detection {
    settle(reg, model, combine(reg, run_all(reg), model))
}

/// A conclusive verdict stands only when no part of the record says the opposite: its first
/// half, its second half, every second sample and the means of each two samples (both at
/// twice the sampling time), each judged on its own (tests and score, as [`combine`] judges a
/// record). A part may be `inconclusive` (less data); a part that says `no-stiction` of a
/// record called `stiction`, or the reverse, makes the verdict `inconclusive` with the reason.
/// So a record exported in part (either half, every second row, averaged over each two rows)
/// never gets the opposite verdict of the whole: the part's own verdict is one of those
/// checked here.
pub fn settle(reg: &Registration<'_>, model: &Model, d: Detection) -> Detection {
    match d.verdict {
        Verdict::Inconclusive => d,
        Verdict::Stiction => parts::settle_stiction(reg, model, d),
        Verdict::NoStiction => settle_on(d, &parts(reg), model),
    }
}

/// The parts of a record [`settle`] judges, each with what [`combine`] judges it on (`None`:
/// the part cannot be built, e.g. too short for a registration).
pub fn parts(reg: &Registration<'_>) -> [(&'static str, Option<Evidence>); 4] {
    parts::Part::of(reg).map(|p| {
        let e = p.registration(reg).map(|r| Evidence::of(&r, run_all(&r)));
        (p.what, e)
    })
}

/// [`settle`] on parts already judged ([`parts`]) under `model`.
pub fn settle_on(d: Detection, parts: &[(&str, Option<Evidence>)], model: &Model) -> Detection {
    let opposite = match d.verdict {
        Verdict::Stiction => Verdict::NoStiction,
        Verdict::NoStiction => Verdict::Stiction,
        Verdict::Inconclusive => return d,
    };
    let says_opposite = |e: &Option<Evidence>| {
        e.as_ref()
            .is_some_and(|e| e.judge(model).verdict == opposite)
    };
    match parts.iter().find(|(_, e)| says_opposite(e)) {
        None => d,
        Some((what, _)) => parts::contradicted(d, what, opposite),
    }
}

/// What [`combine`] judges a registration on: the tests' outcomes, whether the loop
/// oscillates regularly, and whether the record can be judged at all.
#[derive(Debug, Clone)]
pub struct Evidence {
    /// Every test's outcome.
    pub tests: Vec<TestOutcome>,
    /// Whether the control error oscillates regularly.
    pub oscillating: bool,
    /// The oscillation's period in seconds, when it oscillates regularly.
    pub period_s: Option<f64>,
    /// Whether the loop was treated as integrating.
    pub integrating: bool,
    /// Why the record cannot be judged (`None`: it can).
    pub degenerate: Option<String>,
}

impl Evidence {
    /// The evidence of `tests` run on `reg`.
    pub fn of(reg: &Registration<'_>, tests: Vec<TestOutcome>) -> Evidence {
        let osc = reg.oscillation().ok().copied();
        let oscillating = osc.is_some_and(|o| o.is_regular());
        Evidence {
            tests,
            oscillating,
            period_s: osc
                .filter(|o| o.is_regular())
                .and_then(|o| o.period)
                .map(|p| p * reg.sample_time()),
            integrating: reg.is_integrating(),
            degenerate: reg.check().err().map(|e| degenerate_reason(&e)),
        }
    }

    /// Score and verdict under `model` (the rule of [`combine`]).
    pub fn judge(&self, model: &Model) -> Detection {
        decide(self.clone(), model)
    }
}

/// Combine already computed outcomes (e.g. with extra evidence appended by the caller).
pub fn combine(reg: &Registration<'_>, tests: Vec<TestOutcome>, model: &Model) -> Detection {
    decide(Evidence::of(reg, tests), model)
}

fn decide(e: Evidence, model: &Model) -> Detection {
    let Evidence {
        tests,
        oscillating,
        period_s,
        integrating,
        degenerate,
    } = e;
    let score = model.score(&features(&tests));
    let says = |name: &str| {
        tests
            .iter()
            .any(|t| t.name == name && t.verdict == Verdict::Stiction)
    };
    let stick_slip = says("stick-slip");
    let hammer_test = tests.iter().find(|t| t.name == "hammerstein");
    let s_upper = hammer_test.and_then(|t| t.value("S_upper"));
    // A valve that never moves, or moves least (the widest band OP's range allows), explains
    // PV as well as a free one: PV shows no answer to OP's moves that a stuck valve would not.
    let widest = s_upper
        .zip(hammer_test.and_then(|t| t.value("S_above")))
        .is_some_and(|(upper, above)| upper > 0.0 && above <= upper);
    let stuck_fits = widest
        || hammer_test
            .and_then(|t| t.value("lr_moving"))
            .is_some_and(|lr| lr < MOVING_LR);
    let hammer = says("hammerstein");
    let judged = tests.iter().any(|t| t.statistic.is_some());
    let (lo, hi) = (model.no_stiction_at, model.stiction_at);
    let (verdict, reason) = match degenerate {
        Some(why) => (Verdict::Inconclusive, why),
        // With no statistic at all the score is the model's base rate: no evidence either way
        // (it said `no-stiction`, score 0.30).
        None if !judged => (
            Verdict::Inconclusive,
            "no test could judge this record (each says why)".to_string(),
        ),
        None if score >= hi && (oscillating || stick_slip || hammer) => {
            let mut with = Vec::new();
            if oscillating {
                with.push("a regular oscillation");
            }
            if stick_slip {
                with.push("stick-slip");
            }
            if hammer {
                with.push("a sticky valve explaining PV");
            }
            (
                Verdict::Stiction,
                format!("score {score:.2} >= {hi:.2} with {}", with.join(" and ")),
            )
        }
        None if score >= hi => (
            Verdict::Inconclusive,
            format!(
                "score {score:.2} >= {hi:.2}, but no regular oscillation, no stick-slip and no sticky valve that explains PV: the shape tests alone do not make a sticky valve"
            ),
        ),
        None if score <= lo && stuck_fits => (
            Verdict::Inconclusive,
            format!(
                "score {score:.2} <= {lo:.2}, but a valve that moves little or not at all over the record explains the data as well as a free one (PV shows no answer to OP's moves that a stuck valve would not give): they cannot rule out a stuck valve"
            ),
        ),
        None if score <= lo && s_upper.is_some_and(|s| s >= model.hidden_s) => (
            Verdict::Inconclusive,
            format!(
                "score {score:.2} <= {lo:.2}, but a sticky valve with S up to {:.2} % explains the data as well as a free one: they cannot rule out a stiction band of {} % or more",
                s_upper.unwrap_or(model.hidden_s),
                model.hidden_s
            ),
        ),
        None if score <= lo => (
            Verdict::NoStiction,
            format!("score {score:.2} <= {lo:.2}"),
        ),
        None => (
            Verdict::Inconclusive,
            format!("score {score:.2} between {lo:.2} and {hi:.2}"),
        ),
    };
    Detection {
        score,
        verdict,
        reason,
        oscillating,
        period_s,
        integrating,
        integrating_by: None,
        tests,
    }
}

mod parts;

fn degenerate_reason(e: &DetectionError) -> String {
    format!("the data cannot be judged: {e}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{noise, sine};

    /// A first-order process (gain 1, pole 0.9, one sample's delay) with white noise of
    /// deviation 0.2 on PV under a PI controller, its set point 40 plus `sp_swing` times a sine
    /// of period 150 samples; the valve stuck at 40 % or free. Detected as self-regulating.
    fn pi_loop(stuck: bool, sp_swing: f64, seed: u64) -> Detection {
        let n = 1500;
        let (mut x, mut integral) = (40.0, 40.0);
        let (mut pv, mut op) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for (e, w) in noise(n, 0.2, seed).into_iter().zip(sine(n, 150.0)) {
            let y = x + e;
            let error = 40.0 + sp_swing * w - y;
            integral += 0.02 * error;
            let u = integral + 0.5 * error;
            x = 0.9 * x + 0.1 * if stuck { 40.0 } else { u };
            pv.push(y);
            op.push(u);
        }
        detect(&Registration::new(&pv, &op, 1.0).expect("a valid record"))
    }

    /// A valve stuck over the whole record while OP moves a little (0.7-1.1 % here, so the
    /// band `no-stiction` must otherwise exclude, [`HIDDEN_S`], is wider than OP's range): PV is
    /// the noise alone, and a valve that never moves explains it as well as a free valve. The
    /// data cannot rule out a stuck valve: the verdict must not be `no-stiction` (it was on
    /// every seed before the rule). A free valve whose PV follows a set point that moves OP
    /// about as far (1.0-1.2 %) is called `no-stiction`: its PV answers OP's moves.
    #[test]
    fn a_valve_stuck_over_the_record_is_not_called_healthy() {
        let stuck_reason = "a valve that moves little or not at all";
        for seed in 1..=6 {
            let stuck = pi_loop(true, 0.0, seed);
            assert_ne!(
                stuck.verdict,
                Verdict::NoStiction,
                "seed {seed}: {}",
                stuck.reason
            );
            assert!(
                stuck.reason.contains(stuck_reason),
                "seed {seed}: {}",
                stuck.reason
            );
            let free = pi_loop(false, 0.5, seed);
            assert_eq!(
                free.verdict,
                Verdict::NoStiction,
                "seed {seed}: {}",
                free.reason
            );
            let moving = free
                .tests
                .iter()
                .find(|t| t.name == "hammerstein")
                .and_then(|t| t.value("lr_moving"));
            assert!(
                moving.is_some_and(|lr| lr > MOVING_LR),
                "seed {seed}: {moving:?}"
            );
        }
    }
}
