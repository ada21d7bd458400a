//! Each cause on its own evidence after a change of the process.
//!
//! When the open set finds that the process changed during the record (`unexplained`), a cause
//! chosen on the whole record may have gained from the change rather than from what it models:
//! a model that fits neither process well gains from any extra freedom. So the change is
//! located ([`locate_change`]), the record is split into its stationary stretches (before and
//! after the change; a stretch shorter than [`MIN_STRETCH`] samples is not tested), and every
//! cause is tested again on each stretch alone: the baseline refitted on that stretch, the
//! cause's extension on it, the same likelihood-ratio test with the validation split inside
//! the stretch ([`retest`]). A cause is named only where it gains on a stretch, and an
//! extension that fits a stretch significantly worse than that stretch's baseline, its
//! prediction errors' autocorrelation counted ([`gain_z`], [`STRETCH_Z`]), holds on none.

use grid_search::Problem;
use rayon::prelude::*;
use serde::Serialize;
use stiction_models::Initialization;

use crate::{
    causes, diagnosis_combination, registry, test_cause, Baseline, Context, DiagnoseOptions,
    Finding, Fitted, ResidualAnalysis, Role,
};

/// The shortest stretch tested, in samples: with the validation split inside the stretch
/// (a third), 500 samples leave about 330 to identify the model and 170 to judge it.
pub const MIN_STRETCH: usize = 500;

/// Candidate change points are this many samples apart.
const CHANGE_STEP: usize = 25;

/// Samples left out on either side of the located change: the transient from one process to
/// the other, and the location's error.
const CHANGE_GUARD: usize = 100;

/// An extension whose gain's z ([`gain_z`]) on a stretch is below `−STRETCH_Z` fits that
/// stretch significantly worse than the stretch's baseline, its prediction errors'
/// autocorrelation counted: a property of the loop does not, so the cause holds on no stretch
/// (`no-stiction`'s rule is about a loss and keeps its own). One-sided at the 1 % level with
/// the Bonferroni correction for the two stretches, `Φ⁻¹(1 − 0.01/2)`.
pub const STRETCH_Z: f64 = 2.576;

/// Samples at the start of each segment left out of its prediction error (the regression's
/// start-up: the one-step predictor needs past samples).
const SEGMENT_SKIP: usize = 10;

/// One cause tested on one stationary stretch.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StretchTest {
    /// The cause.
    pub cause: &'static str,
    /// The stretch's first sample.
    pub from: usize,
    /// One past its last sample.
    pub to: usize,
    /// The likelihood ratio of the extension against the baseline refitted on the stretch,
    /// on the stretch's own validation samples (for `no-stiction`: minus the cost of removing
    /// the stiction).
    pub lr: f64,
    /// The threshold it had to pass (the cause's own rule).
    pub threshold: f64,
    /// The gain's z on the stretch's validation samples, the prediction errors' own
    /// autocorrelation counted ([`gain_z`]); `NaN` when it cannot be computed.
    pub z: f64,
    /// Whether the cause gains significantly on this stretch (its likelihood ratio over its
    /// threshold) and, for an extension, fits no stretch significantly worse than that
    /// stretch's baseline (`z` over `−`[`STRETCH_Z`] on every stretch).
    pub holds: bool,
    /// Why the test could not be made (the stretch's baseline or the extension failed).
    pub error: Option<String>,
    /// The causes of the forward selection the extension was built on (their extensions on
    /// the stretch, in its order); empty: on the stretch's baseline.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub on: Vec<&'static str>,
}

/// The causes tested again on the stationary stretches of a record whose process changed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stretches {
    /// The sample where the change was located.
    pub change_at: usize,
    /// The stretches tested, `[from, to)`.
    pub stretches: Vec<[usize; 2]>,
    /// Every cause tested on every stretch.
    pub tests: Vec<StretchTest>,
    /// The causes the diagnosis chose on the whole record (the forward selection's), before
    /// the stretches were tested: each is named only where it holds on a stretch.
    pub chosen_on_record: Vec<&'static str>,
}

impl Stretches {
    /// Whether `cause` gains significantly on at least one stretch.
    pub fn holds(&self, cause: &str) -> bool {
        self.tests.iter().any(|t| t.cause == cause && t.holds)
    }

    /// The stretches on which `cause` gains significantly.
    pub fn holds_on(&self, cause: &str) -> Vec<[usize; 2]> {
        self.tests
            .iter()
            .filter(|t| t.cause == cause && t.holds)
            .map(|t| [t.from, t.to])
            .collect()
    }

    /// Whether `cause` holds on the last stretch (the process as it is now).
    pub fn holds_now(&self, cause: &str) -> bool {
        let last = self.stretches.last().map_or(0, |s| s[0]);
        self.tests
            .iter()
            .any(|t| t.cause == cause && t.holds && t.from == last)
    }

    /// In words: where the change is, the stretches, and for each cause chosen on the whole
    /// record (and each that gains on a stretch) where it holds.
    pub fn describe(&self) -> String {
        let named = &self.chosen_on_record;
        let spans: Vec<String> = self
            .stretches
            .iter()
            .map(|s| format!("{}-{}", s[0], s[1]))
            .collect();
        let mut names: Vec<&'static str> = Vec::new();
        for t in &self.tests {
            if !names.contains(&t.cause) {
                names.push(t.cause);
            }
        }
        let per_cause: Vec<String> = names
            .iter()
            .filter(|c| named.contains(c) || self.holds(c))
            .map(|c| {
                let tests: Vec<String> = self
                    .tests
                    .iter()
                    .filter(|t| t.cause == *c)
                    .map(|t| match &t.error {
                        Some(_) => format!("samples {}-{}: not fitted", t.from, t.to),
                        None => format!(
                            "samples {}-{}{}: LR {:.0}, z {:.1}{}",
                            t.from,
                            t.to,
                            if t.on.is_empty() {
                                String::new()
                            } else {
                                format!(" on top of {}", t.on.join(" and "))
                            },
                            t.lr,
                            t.z,
                            if t.holds { ", holds" } else { "" }
                        ),
                    })
                    .collect();
                let verdict = match (named.contains(c), self.holds(c)) {
                    (true, true) => "",
                    (true, false) => " gains on no stretch (not named)",
                    _ => " not chosen on the whole record (not named)",
                };
                format!("{c}{verdict} ({})", tests.join("; "))
            })
            .collect();
        let causes = if per_cause.is_empty() {
            "no cause gains on a stretch".to_string()
        } else {
            per_cause.join(", ")
        };
        format!(
            "The change of the process located at sample {}; the causes tested again on each stationary stretch alone (samples {}; the baseline refitted on the stretch, validated on its last third; a cause is named where it gains on a stretch, unless it fits another significantly worse than the stretch's baseline, the gain's z with the prediction errors' autocorrelation counted under -{STRETCH_Z}): {causes}.",
            self.change_at,
            spans.join(" and "),
        )
    }
}

/// Where the process changed: the sample `k` (a multiple of `CHANGE_STEP`, 25 samples, at least
/// [`MIN_STRETCH`] samples from either end) at which the model's linear part identified
/// separately on `[0, k)` and `[k, N)` leaves the smallest total one-step prediction error,
/// with the valve of `model` run from each of its four initial states (In.3's starts; the
/// one that fits best decides) or the measured MV when there is one. `None` when the record
/// is shorter than two stretches or nothing could be fitted.
pub fn locate_change(problem: Problem<'_>, model: &Fitted) -> Option<usize> {
    let (op, pv) = (problem.op, problem.pv);
    let n = pv.len();
    if n < 2 * MIN_STRETCH {
        return None;
    }
    let runs: Vec<Vec<f64>> = match problem.mv {
        Some(mv) => vec![mv.to_vec()],
        None => crate::open_set::four_initial_states()
            .filter_map(|state| {
                stiction_models::run_valve(
                    model.result.stiction.as_ref(),
                    op,
                    &Initialization::In1(state),
                )
                .ok()
                .map(|r| r.mv)
            })
            .collect(),
    };
    let identifier = model.identifier.as_ref();
    let sse = |mv: &[f64], a: usize, b: usize| -> Option<f64> {
        let fit = identifier.identify(&mv[a..b], &pv[a..b]).ok()?;
        let p = fit.predict_one_step(&mv[a..b], &pv[a..b]).ok()?;
        let s: f64 = p
            .iter()
            .zip(&pv[a..b])
            .skip(SEGMENT_SKIP)
            .map(|(e, y)| (e - y) * (e - y))
            .sum();
        s.is_finite().then_some(s)
    };
    let candidates: Vec<(usize, usize)> = (0..runs.len())
        .flat_map(|r| {
            (MIN_STRETCH..=n - MIN_STRETCH)
                .step_by(CHANGE_STEP)
                .map(move |k| (r, k))
        })
        .collect();
    candidates
        .into_par_iter()
        .filter_map(|(r, k)| {
            let mv = &runs[r];
            Some((k, sse(mv, 0, k)? + sse(mv, k, n)?))
        })
        .collect::<Vec<_>>()
        .into_iter()
        // the first of equal errors: the same answer on any number of threads
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
        .map(|(k, _)| k)
}

/// Every cause that is not disabled tested on each stationary stretch of the record: the
/// change located on `model` (the model the open set found the change on), the stretches
/// `[0, k)` and `[k, N)` of at least [`MIN_STRETCH`] samples, on each the baseline refitted
/// with the diagnosis's grid and split, and each cause that applies to it extended and judged
/// by its own rule against that baseline. `None` when the change cannot be located.
pub(crate) fn retest(
    problem: Problem<'_>,
    span: f64,
    baseline: &Baseline,
    model: &Fitted,
    options: &DiagnoseOptions,
    chain: &[&'static str],
) -> Option<Stretches> {
    let n = problem.op.len();
    let at = locate_change(problem, model)?;
    let stretches: Vec<[usize; 2]> = [[0, at.saturating_sub(CHANGE_GUARD)], [at + CHANGE_GUARD, n]]
        .into_iter()
        .filter(|s| s[1] - s[0] >= MIN_STRETCH)
        .collect();
    let mut tests: Vec<StretchTest> = stretches
        .par_iter()
        .map(|s| test_stretch(problem, span, baseline, options, *s, chain))
        .collect::<Vec<_>>()
        .into_iter()
        .flatten()
        .collect();
    // an extension that fits a stretch significantly worse than its baseline is no property
    // of the loop: it holds nowhere (a gain on the other stretch alone came from that
    // stretch's noise or process; docs/decisions/2026-11-27-stretches.md)
    let against: Vec<&'static str> = tests
        .iter()
        .filter(|t| crate::framework::role_of(t.cause) == Role::Extension && t.z < -STRETCH_Z)
        .map(|t| t.cause)
        .collect();
    for t in &mut tests {
        t.holds &= !against.contains(&t.cause);
    }
    Some(Stretches {
        change_at: at,
        stretches,
        tests,
        chosen_on_record: Vec::new(),
    })
}

/// The causes tested on the stretch `[from, to)` alone.
fn test_stretch(
    problem: Problem<'_>,
    span: f64,
    baseline: &Baseline,
    options: &DiagnoseOptions,
    [from, to]: [usize; 2],
    chain: &[&'static str],
) -> Vec<StretchTest> {
    let data = Problem {
        op: &problem.op[from..to],
        pv: &problem.pv[from..to],
        mv: problem.mv.map(|m| &m[from..to]),
    };
    let entries: Vec<_> = registry()
        .into_iter()
        .filter(|e| !options.disabled.iter().any(|d| d == e.name))
        .collect();
    let base = diagnosis_combination(
        baseline,
        options,
        baseline.stiction,
        baseline.linear,
        baseline.fixed_delay(),
    )
    .run(data, None);
    let base = match base {
        Ok(b) => b,
        Err(e) => {
            // the stretch cannot be fitted: no cause holds on it (a reframe, a property of the
            // data rather than a model, is not a stretch's cause)
            let error = crate::DiagnoseError::from(e).to_string();
            return entries
                .iter()
                .filter(|e| e.role != Role::Reframe)
                .map(|e| StretchTest {
                    cause: e.name,
                    from,
                    to,
                    lr: f64::NAN,
                    threshold: f64::NAN,
                    z: f64::NAN,
                    holds: false,
                    error: Some(error.clone()),
                    on: Vec::new(),
                })
                .collect();
        }
    };
    let q = &base.result;
    let residuals = ResidualAnalysis::new(data.pv, &q.pv_pred, &q.pv_sim, &q.mv_est, q.split_index);
    let own_cycle = causes::OwnCycle::default();
    let ctx = Context {
        problem: data,
        span,
        baseline_spec: baseline,
        baseline: &base,
        residuals: &residuals,
        options,
        own_cycle: &own_cycle,
    };
    let found: Vec<Finding> = entries
        .into_par_iter()
        .filter_map(|entry| {
            let cause = (entry.build)();
            if !cause.applies(&ctx) {
                return None;
            }
            let (f, _) = test_cause(&ctx, cause.as_ref(), entry.name, base.fit_val(), (q.s, q.j));
            Some(f)
        })
        .collect();
    // the gain's z of a finding's extension over the model it extends (`reference`, its
    // one-step predictions validated from `split`)
    let test = |f: &Finding, on: &[&'static str], reference: &[f64], split: usize| StretchTest {
        cause: f.cause,
        from,
        to,
        lr: f.lr,
        threshold: f.threshold,
        z: f.fitted.as_ref().map_or(f64::NAN, |x| {
            gain_z(
                data.pv,
                reference,
                &x.result.pv_pred,
                split.max(x.result.split_index),
            )
        }),
        holds: f.significant && f.error.is_none(),
        error: f.error.clone(),
        on: on.to_vec(),
    };
    let mut tests: Vec<StretchTest> = found
        .iter()
        .map(|f| test(f, &[], &q.pv_pred, q.split_index))
        .collect();
    let alone: Vec<&'static str> = found
        .iter()
        .filter(|f| f.significant)
        .map(|f| f.cause)
        .collect();
    // A cause the forward selection added on top of others is tested on top of them on the
    // stretch too, while they hold there: the test it passed on the record (a characteristic
    // on a loop detuned for it and a dead time gains little on a model without the dead time).
    let Some(mut model) = chain.first().and_then(|c| {
        found
            .into_iter()
            // a model of transformed data is not extended on the record itself
            .find(|f| f.cause == *c && f.significant && f.data.is_none())
            .and_then(|f| f.fitted)
    }) else {
        return tests;
    };
    for k in 1..chain.len() {
        let Some(f) = on_top(data, span, baseline, options, &model, chain[k]) else {
            break;
        };
        let holds = f.significant && f.error.is_none();
        if !alone.contains(&chain[k]) {
            tests.push(test(
                &f,
                &chain[..k],
                &model.result.pv_pred,
                model.result.split_index,
            ));
        }
        match f.fitted.filter(|_| holds) {
            Some(next) => model = next,
            None => break,
        }
    }
    tests
}

/// `cause` tested on the stretch `data` on top of `model` (an extension fitted on it), by
/// its own rule against that model; `None` when it does not apply there.
fn on_top(
    data: Problem<'_>,
    span: f64,
    baseline: &Baseline,
    options: &DiagnoseOptions,
    model: &Fitted,
    cause: &'static str,
) -> Option<Finding> {
    let entry = registry().into_iter().find(|e| e.name == cause)?;
    let mut spec = diagnosis_combination(
        baseline,
        options,
        model.stiction,
        linear_id::find_identifier(model.linear).ok()?,
        model.delay,
    );
    spec.orders = crate::orders_without_delay(model.identifier.as_ref());
    let q = &model.result;
    let residuals = ResidualAnalysis::new(data.pv, &q.pv_pred, &q.pv_sim, &q.mv_est, q.split_index);
    let own_cycle = causes::OwnCycle::default();
    let ctx = Context {
        problem: data,
        span,
        baseline_spec: &spec,
        baseline: model,
        residuals: &residuals,
        options,
        own_cycle: &own_cycle,
    };
    let built = (entry.build)();
    built
        .applies(&ctx)
        .then(|| test_cause(&ctx, built.as_ref(), cause, model.fit_val(), (q.s, q.j)).0)
}

/// The gain of `extended`'s one-step predictions over `reference`'s on the samples from
/// `from` on, as a z: the mean of the loss differential `d_t = e_ref,t² − e_ext,t²` over its
/// standard error, the standard error from the differential's own autocorrelation
/// (Diebold–Mariano, Newey–West long-run variance with Bartlett weights up to lag
/// `⌊4 (n/100)^(2/9)⌋`). `NaN` when fewer than 50 samples or the variance is not positive.
///
/// The likelihood ratio reads the gain as if the errors were white; the errors of a model
/// that cannot describe the plant's coloured noise are not, and on a stretch of a few hundred
/// validation samples a few bursts of that noise can carry the whole gain.
pub fn gain_z(pv: &[f64], reference: &[f64], extended: &[f64], from: usize) -> f64 {
    let d: Vec<f64> = (from..pv.len().min(reference.len()).min(extended.len()))
        .map(|t| {
            let (a, b) = (reference[t] - pv[t], extended[t] - pv[t]);
            a * a - b * b
        })
        .filter(|v| v.is_finite())
        .collect();
    if d.len() < 50 {
        return f64::NAN;
    }
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let gamma = |k: usize| -> f64 {
        d[k..]
            .iter()
            .zip(&d)
            .map(|(x, y)| (x - mean) * (y - mean))
            .sum::<f64>()
            / n
    };
    let lags = (4.0 * (n / 100.0).powf(2.0 / 9.0)).floor() as usize;
    let variance = gamma(0)
        + (1..=lags)
            .map(|k| 2.0 * (1.0 - k as f64 / (lags as f64 + 1.0)) * gamma(k))
            .sum::<f64>();
    if variance > 0.0 {
        mean / (variance / n).sqrt()
    } else {
        f64::NAN
    }
}

/// The open set tested on the model of each cause the first round found significant but the
/// forward selection did not choose (its extension of the baseline; not `no-stiction`, not a
/// cause of `chain`): the one whose likelihood ratio passes its threshold by the most, its
/// evidence saying on which model, `None` when it passes on none.
///
/// A cause with extra freedom can absorb a change of the process: on its model, and on the
/// final model built on it, the recent part of the record no longer predicts better than the
/// whole, and on a baseline whose valve the change misplaced neither. A competing cause's
/// model, one that fits the record significantly better than the baseline without absorbing
/// the change, still shows it. Then the chosen causes are tested on the stationary stretches
/// as for a change seen on the final model ([`retest`]). The models of the chosen path are not
/// asked: a change seen on the first cause's model and gone once the next chosen cause is
/// added is what that cause explains (an installed characteristic's gain, which varies with
/// the operating point, reads as a change on a model without it: on the suite's
/// characteristic + dead time loops 6021 and 6022 the dead time's model showed it, LR 99 over
/// 50, and counting it dropped both true causes). A change seen so is named only when it is
/// located before the validation window: the open set compares identifications on the
/// identification window, so a change it sees lies there (suite loop 6021, a characteristic
/// and a dead time without change, had it located at sample 2425 of 3000, inside the
/// validation window, from the model of `disturbance`).
pub(crate) fn change_on_causes(
    problem: Problem<'_>,
    findings: &[Finding],
    chain: &[&'static str],
    options: &DiagnoseOptions,
) -> Option<Finding> {
    let tested: Vec<(&'static str, Finding)> = findings
        .par_iter()
        .filter(|f| f.significant && f.role == Role::Extension && !chain.contains(&f.cause))
        .filter_map(|f| {
            let data = crate::framework::seen(problem, f.data.as_ref());
            Some((
                f.cause,
                crate::open_set::open_set(data, f.fitted.as_ref()?, options)?,
            ))
        })
        .collect();
    let (cause, mut open) = tested
        .into_iter()
        .filter(|(_, o)| o.significant)
        // the first of equal margins (the registry's order): the same answer on any thread count
        .fold(None::<(&'static str, Finding)>, |best, (c, o)| match best {
            Some(b) if b.1.lr - b.1.threshold >= o.lr - o.threshold => Some(b),
            _ => Some((c, o)),
        })?;
    open.evidence = open
        .evidence
        .replacen(
            "the final model's linear part",
            &format!("the {cause} extension's linear part"),
            1,
        )
        .replacen(
            "In the final model,",
            &format!("In the {cause} extension's model,"),
            1,
        );
    open.evidence.push_str(&format!(
        " The change was tested on the model of each cause the first round found significant: it is not significant on the final model nor on the baseline, where a cause absorbed it, but it is on the {cause} extension's model."
    ));
    open.reference = format!("the {cause} extension");
    Some(open)
}
