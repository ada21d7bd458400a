//! What a diagnosis returns: each tested hypothesis ([`Finding`]), the [`Diagnosis`], its
//! summary for the engineer, its one action line and its JSON record.

use grid_search::Problem;
use serde::Serialize;

use crate::framework::{diagnosis_combination, Evidence, Role, UNEXPLAINED};
use crate::refit::FinalRefit;
use crate::selection::{selected_model, Selection};
use crate::{
    Baseline, DiagnoseError, DiagnoseOptions, FitSummary, Fitted, OrderSelection, ResidualAnalysis,
    Stretches,
};

/// One tested hypothesis.
#[derive(Debug, Serialize)]
pub struct Finding {
    /// Cause name.
    pub cause: &'static str,
    /// Its role (how the finding is read).
    #[serde(skip)]
    pub role: Role,
    /// The evidence in words.
    pub evidence: String,
    /// The detection statistic.
    pub statistic: f64,
    /// The extended model (summary; the full fit is in `fitted`).
    pub extended: Option<FitSummary>,
    /// The full extended fit.
    #[serde(skip)]
    pub fitted: Option<Fitted>,
    /// Extended minus baseline F_PV on validation data, points.
    pub gain_fit_pv_val: f64,
    /// Extended minus baseline S and J.
    pub delta_s: f64,
    /// See `delta_s`.
    pub delta_j: f64,
    /// The likelihood-ratio statistic of the decision.
    pub lr: f64,
    /// The threshold it had to pass.
    pub threshold: f64,
    /// What the LR compared against.
    pub reference: String,
    /// Whether the gain is significant.
    pub significant: bool,
    /// Why the extension could not be fitted, if it could not.
    pub error: Option<String>,
    /// The record as the extended model sees it, when its extension (or one before it)
    /// transformed the data ([`crate::Transformed`]).
    #[serde(skip)]
    pub data: Option<crate::Transformed>,
    /// For `unexplained`: the first sample of the recent window whose linear part predicts
    /// the validation data better (where the changed process is seen).
    #[serde(skip)]
    pub window_from: Option<usize>,
}

/// The result of [`diagnose`](crate::diagnose).
#[derive(Debug, Serialize)]
pub struct Diagnosis {
    /// The baseline (summary).
    pub baseline: FitSummary,
    /// The fitted baseline.
    #[serde(skip)]
    pub baseline_fit: Fitted,
    /// The residual analysis of the baseline.
    pub residuals: ResidualAnalysis,
    /// The chosen cause (`none` when no extension is significant): the first of `causes`.
    pub cause: String,
    /// Every cause found, in the order the forward selection added them (empty: none).
    pub causes: Vec<String>,
    /// Index in `findings` of the first cause with an extension (a cause that reframes the
    /// diagnosis, `compression`, comes before it in `causes` and has none).
    pub chosen: Option<usize>,
    /// One per hypothesis tested, best first (chosen first, then by LR margin).
    pub findings: Vec<Finding>,
    /// The forward selection's later steps: the causes not chosen yet, tested on the model
    /// extended by every cause chosen before (step `k` on the model of `causes[..=k]`).
    pub steps: Vec<Vec<Finding>>,
    /// Index in each step of the cause it added (one fewer than `steps` when the last step
    /// found nothing, or when the open set dropped the cause that step had picked: that
    /// finding is then marked not significant, see `stretches::retest`).
    pub picks: Vec<usize>,
    /// Final (joint) model minus baseline F_PV on validation data (0 when none).
    pub gain_fit_pv_val: f64,
    /// The final model refitted: on the samples after a change of the process (`unexplained`)
    /// and/or with the orders raised when that gains significantly; it is then the final
    /// model ([`Diagnosis::final_fit`]).
    #[serde(skip)]
    pub refined: Option<Fitted>,
    /// How the final model's orders were chosen (`None` when the orders were given, or the
    /// cause is `no-stiction`).
    pub order_selection: Option<OrderSelection>,
    /// After a change of the process (`unexplained`): every cause tested again on each
    /// stationary stretch alone, and where each holds (`None` when no change was named).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stretches: Option<Stretches>,
    /// One paragraph for the engineer.
    pub summary: String,
    /// Wall time of the whole diagnosis, ms.
    pub elapsed_ms: f64,
}

/// The finding of a cause that reframed the diagnosis ([`Cause::reframe`]): the baseline
/// under the caller's search options (e.g. ranked by one-step prediction) against the
/// reframed baseline `base`, compared by the reframed criterion's validation fit.
pub(crate) fn reframed_finding(
    problem: Problem<'_>,
    baseline: &Baseline,
    original: &DiagnoseOptions,
    base: &Fitted,
    name: &'static str,
    ev: Evidence,
) -> Result<Finding, DiagnoseError> {
    let criterion = base.result.criterion;
    let (b, n_val) = (
        base.summary(),
        (problem.op.len() - base.result.split_index) as f64,
    );
    let mut finding = Finding {
        cause: name,
        role: Role::Reframe,
        evidence: format!("Cause: {name}. {}", ev.text),
        statistic: ev.statistic,
        extended: Some(b.clone()),
        fitted: None,
        gain_fit_pv_val: f64::NAN,
        delta_s: f64::NAN,
        delta_j: f64::NAN,
        lr: f64::NAN,
        threshold: f64::NAN,
        reference: format!(
            "the baseline ranked by {}",
            original.search.criterion.describe()
        ),
        // a property of the data, detected from the data: no likelihood ratio decides it
        significant: true,
        error: None,
        data: None,
        window_from: None,
    };
    if original.search.criterion == criterion {
        return Ok(finding);
    }
    let orig = diagnosis_combination(
        baseline,
        original,
        baseline.stiction,
        baseline.linear,
        baseline.fixed_delay(),
    )
    .run(problem, None)?;
    let fit = |f: &Fitted| f.result.fits_score(criterion);
    let sse = |f: f64| (1.0 - f / 100.0).max(1e-12);
    let (f0, f1) = (fit(&orig), fit(base));
    finding.gain_fit_pv_val = f1 - f0;
    finding.delta_s = b.s - orig.result.s;
    finding.delta_j = b.j - orig.result.j;
    finding.lr = n_val * (sse(f0) / sse(f1)).ln();
    finding.evidence = format!(
        "{} Ranked by {} the baseline would estimate S = {:.2} %, J = {:.2} % ({} fit {f0:.1} % on validation data); ranked by {}, S = {:.2} %, J = {:.2} % ({f1:.1} %).",
        finding.evidence,
        original.search.criterion.describe(),
        orig.result.s,
        orig.result.j,
        criterion.label(),
        criterion.describe(),
        b.s,
        b.j
    );
    Ok(finding)
}

/// The summary: the actionable sentence first (which model to use and its S, J), then the
/// evidence for the cause, then what the baseline and its residuals show.
fn summarise(
    base: &Fitted,
    res: &ResidualAnalysis,
    findings: &[Finding],
    chosen: Option<usize>,
) -> String {
    let b = base.summary();
    let baseline = format!(
        "The baseline {} + {} (dead time {}) estimates S = {:.2} %, J = {:.2} % and explains {:.1} % of PV on validation data (free-run simulation {:.1} %). {}",
        b.stiction_model,
        b.linear_model,
        b.delay,
        b.s,
        b.j,
        b.fit_pv_val,
        b.fit_sim_val,
        res.describe()
    );
    match chosen {
        Some(i) if findings[i].role == Role::NullHypothesis => {
            let f = &findings[i];
            let e = f.extended.as_ref();
            // the baseline's own valve without stiction may have no stable node; the test
            // then stands on the extension's (its evidence says which)
            let fitted = e.map_or(String::new(), |e| {
                format!("; fitted S = {:.2} %, J = {:.2} %", e.s, e.j)
            });
            format!(
                "Cause: no-stiction. The oscillation is not the valve's: a valve with negligible stiction (S at most {} %{fitted}) explains PV as well as the stiction model (likelihood-ratio cost {:.1}, below {:.2}); look for the cause elsewhere (tuning, an external oscillation, the process). {} {baseline}",
                grid_search::NEGLIGIBLE_S,
                -f.lr,
                f.threshold.abs(),
                f.evidence,
            )
        }
        Some(i) => {
            let f = &findings[i];
            let e = f.extended.as_ref();
            format!(
                "Cause: {}. Use the extension {} + {} (dead time {}) instead of the baseline: S = {:.2} %, J = {:.2} % (ΔS {:+.2}, ΔJ {:+.2} against the baseline); it changes validation F_PV by {:+.2} points (likelihood ratio {:.0} against the {}, threshold {:.0}). {} {baseline}",
                f.cause,
                e.map_or("-", |e| e.stiction_model),
                e.map_or("-", |e| e.linear_model),
                e.map_or(0, |e| e.delay),
                e.map_or(f64::NAN, |e| e.s),
                e.map_or(f64::NAN, |e| e.j),
                f.delta_s,
                f.delta_j,
                f.gain_fit_pv_val,
                f.lr,
                f.reference,
                f.threshold.abs(),
                f.evidence,
            )
        }
        // nothing tested (a cause in the data, `Cause::reframe`, says why before this)
        None if findings.is_empty() => baseline,
        None => {
            let tested: Vec<String> = findings
                .iter()
                .map(|f| {
                    if f.lr > f.threshold && f.threshold.is_finite() {
                        // significant on the whole window, dropped by `stretches::retest`
                        format!(
                            "{} (LR {:.0} vs {:.0} on the whole window, gained from the process change)",
                            f.cause,
                            f.lr,
                            f.threshold.abs()
                        )
                    } else {
                        format!("{} (LR {:.0} vs {:.0})", f.cause, f.lr, f.threshold.abs())
                    }
                })
                .collect();
            format!(
                "Cause: none. The baseline estimate stands (S = {:.2} %, J = {:.2} %): no extension gains significantly on validation data ({}). {baseline}",
                b.s,
                b.j,
                tested.join(", ")
            )
        }
    }
}

/// The one line to act on: the cause and the model to use, with its S and J in their unit
/// ([`crate::headline::in_unit`]: without `%` when OP's valve span is unknown).
pub fn action_line(dg: &Diagnosis, span_unknown: bool) -> String {
    let u = |x: f64| crate::headline::in_unit(x, span_unknown);
    let chosen = dg.chosen.and_then(|i| dg.findings.get(i));
    match chosen {
        Some(f) if f.role == Role::NullHypothesis => format!(
            "no-stiction: the oscillation is not the valve's (a valve with negligible stiction{} explains PV as well); look elsewhere",
            f.extended
                .as_ref()
                .map_or(String::new(), |e| format!(", fitted S = {},", u(e.s)))
        ),
        Some(f) => match dg.final_fit().map(Fitted::summary) {
            Some(e) => format!(
                "{}: use {} + {} (dead time {}): S = {}, J = {} (validation F_PV {:+.2} points over the baseline)",
                dg.causes.join(" + "),
                e.stiction_model,
                e.linear_model,
                e.delay,
                u(e.s),
                u(e.j),
                dg.gain_fit_pv_val
            ),
            None => f.cause.to_string(),
        },
        None if dg.cause == UNEXPLAINED => format!(
            "unexplained: something no registered cause explains remains (see the summary); the baseline S = {}, J = {} with caution",
            u(dg.baseline.s), u(dg.baseline.j)
        ),
        // a cause in the data named alone (`Cause::reframe`): the baseline with its warning
        None if dg.cause != "none" => format!(
            "{}: the baseline S = {}, J = {} with caution (no other cause tested); see the summary",
            dg.cause, u(dg.baseline.s), u(dg.baseline.j)
        ),
        None => format!(
            "none: the baseline stands, S = {}, J = {}",
            u(dg.baseline.s), u(dg.baseline.j)
        ),
    }
}

impl Diagnosis {
    /// The final model: the refit when there is one ([`Diagnosis::refined`]: identified after
    /// a change of the process, or at raised orders), else every chosen cause's extension at
    /// once ([`Diagnosis::selected_fit`]); `None` when neither (the baseline stands).
    pub fn final_fit(&self) -> Option<&Fitted> {
        self.refined.as_ref().or_else(|| self.selected_fit())
    }

    /// The forward selection's final model, before the refit of [`Diagnosis::refined`]: every
    /// chosen cause's extension at once; `None` when no cause was found. The open set ran on
    /// this model (or the baseline).
    pub fn selected_fit(&self) -> Option<&Fitted> {
        selected_model(&self.picks, &self.steps, self.chosen, &self.findings)
    }

    /// The document of `diagnose --json` for the loop of `source`, searched with `init`.
    pub fn record(
        &self,
        source: &str,
        init: &stiction_models::Initialization,
    ) -> serde_json::Value {
        use serde_json::{json, Value};
        let num = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
        let doc = |f: &Finding| {
            json!({
                "cause": f.cause,
                "evidence": f.evidence,
                "statistic": num(f.statistic),
                "extended": f.fitted.as_ref().map(|x| x.record(init)),
                "gain_fit_pv_val": num(f.gain_fit_pv_val),
                "delta_S": num(f.delta_s),
                "delta_J": num(f.delta_j),
                "lr": num(f.lr),
                "threshold": num(f.threshold),
                "reference": f.reference,
                "significant": f.significant,
                "error": f.error,
            })
        };
        let findings: Vec<Value> = self.findings.iter().map(doc).collect();
        let steps: Vec<Value> = self
            .steps
            .iter()
            .map(|step| Value::Array(step.iter().map(doc).collect()))
            .collect();
        let extended = self
            .final_fit()
            .map_or(Value::Null, |x| json!(x.record(init)));
        let mut doc = json!({
            "source": source,
            "headline": serde_json::to_value(self.headline()).unwrap_or_default(),
            "baseline": self.baseline_fit.record(init),
            "cause": self.cause,
            "causes": self.causes,
            "findings": findings,
            "steps": steps,
            "extended": extended,
            "gain_fit_pv_val": self.gain_fit_pv_val,
            "orders": serde_json::to_value(&self.order_selection).unwrap_or_default(),
            "summary": self.summary,
            "residuals": serde_json::to_value(&self.residuals).unwrap_or_default(),
            "elapsed_ms": self.elapsed_ms,
        });
        // after a change of the process: where each cause holds
        if let (Some(check), Some(map)) = (&self.stretches, doc.as_object_mut()) {
            map.insert(
                "stretches".into(),
                serde_json::to_value(check).unwrap_or_default(),
            );
        }
        doc
    }
}

/// The cause and the summary of a diagnosis, written phase by phase.
pub(crate) struct Written {
    /// The cause (`none` when no cause was found).
    pub cause: String,
    /// The paragraph for the engineer.
    pub summary: String,
}

impl Written {
    /// The selected causes: the first cause's paragraph ([`summarise`]) and one sentence per
    /// cause the forward selection added.
    pub fn new(base: &Fitted, residuals: &ResidualAnalysis, sel: &Selection) -> Written {
        let cause = sel
            .chosen
            .map_or("none".to_string(), |i| sel.findings[i].cause.to_string());
        let mut summary = summarise(base, residuals, &sel.findings, sel.chosen);
        for (n, &k) in sel.picks.iter().enumerate() {
            let f = &sel.steps[n][k];
            if let Some(e) = &f.extended {
                summary = format!(
                    "{summary} Also {}: on top of {}, the extension {} + {} (dead time {}) gains {:+.2} points of validation F_PV (likelihood ratio {:.0}, threshold {:.0}): S = {:.2} %, J = {:.2} %.",
                    f.cause,
                    f.reference.trim_start_matches("the ").trim_end_matches(" extension"),
                    e.stiction_model,
                    e.linear_model,
                    e.delay,
                    f.gain_fit_pv_val,
                    f.lr,
                    f.threshold,
                    e.s,
                    e.j
                );
            }
        }
        Written { cause, summary }
    }

    /// The open set's finding: when significant, `unexplained` ends the causes (the cause
    /// when nothing else was found), with where the causes hold after the change.
    pub fn open_set(
        &mut self,
        open: Option<Finding>,
        sel: &mut Selection,
        stretch_check: Option<&Stretches>,
    ) {
        let Some(f) = open else {
            return;
        };
        if f.significant {
            sel.causes.push(UNEXPLAINED);
            let summary = &self.summary;
            if self.cause == "none" {
                self.cause = UNEXPLAINED.to_string();
                // the baseline's "Cause: none" paragraph follows the finding
                self.summary = format!("{} {summary}", f.evidence);
            } else {
                self.summary = format!("{summary} {}", f.evidence);
            }
            if let Some(check) = stretch_check {
                self.summary = format!("{} {}", self.summary, check.describe());
            }
        }
        sel.findings.push(f);
    }

    /// The final refit: declined (the selected model stands) or the final model, with its
    /// window and orders; `n` samples in the record.
    pub fn refit(&mut self, fin: &FinalRefit, n: usize) {
        let summary = &self.summary;
        let window = fin.changed_from.map_or(String::new(), |k| {
            format!(" on samples {k}-{n} alone (after the change)")
        });
        if let Some((refit, kept, s_refit)) = fin.declined {
            let orders = fin
                .order_selection
                .as_ref()
                .filter(|o| o.raised)
                .map_or(String::new(), |o| {
                    format!(" with the linear orders {}", o.to)
                });
            self.summary = format!(
                "{summary} Refitted{window}{orders}, the final model (S = {s_refit:.2} %) predicts the validation data worse (F_PV {refit:.2} % against {kept:.2} %): the selected model stands."
            );
        }
        if let Some(f) = &fin.refined {
            let summary = &self.summary;
            let e = f.summary();
            let orders = fin.order_selection.as_ref().filter(|o| o.raised).map_or(String::new(), |o| {
                format!(
                    " with the linear orders {} instead of {} (they explain validation PV significantly better: likelihood ratio {:.0}, threshold {:.0})",
                    o.to, o.from, o.lr, o.threshold
                )
            });
            self.summary = format!(
                "{summary} The final model refitted{window}{orders}: S = {:.2} %, J = {:.2} %.",
                e.s, e.j
            );
        }
    }

    /// A cause in the data that reframed the diagnosis: named first.
    pub fn reframed(&mut self, finding: Finding, sel: &mut Selection) {
        self.summary = format!("{} {}", finding.evidence, self.summary);
        let name = finding.cause;
        sel.findings.insert(0, finding);
        sel.chosen = sel.chosen.map(|i| i + 1);
        sel.causes.insert(0, name);
        self.cause = name.to_string();
    }
}
