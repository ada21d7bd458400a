//! The decision a diagnosis leads to, in the words a maintenance planner acts on: what to do,
//! the S to put on the work order with its range, and the causes that hold in the final model
//! with the step of the forward selection that added each.

use grid_search::{Severity, MAINTENANCE_S, NEGLIGIBLE_S};
use serde::Serialize;

use crate::{Diagnosis, Finding, UNEXPLAINED};

/// How one cause stands in the final model.
#[derive(Debug, Clone, Copy)]
pub struct Standing<'a> {
    /// The test that decided it: the forward selection's step that added the cause (its
    /// finding in that step), or the first step's finding for a cause never added.
    pub finding: &'a Finding,
    /// The step that added it (1 = tested against the baseline; `k` = on top of the causes of
    /// steps `1..k`), `None` when it was not added by a step (a cause that reframes the
    /// diagnosis, `unexplained`, or a cause not held).
    pub step: Option<usize>,
    /// Whether the cause holds in the final model (it is one of [`Diagnosis::causes`]).
    pub held: bool,
}

/// The headline of a diagnosis ([`Diagnosis::headline`]).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Headline {
    /// What to do, e.g. `schedule valve maintenance`.
    pub action: String,
    /// Why, in one clause (the level S reaches, or what the diagnosis found instead).
    pub reason: String,
    /// The S to use (in [`Headline::s_unit`]): the final model's.
    #[serde(rename = "S")]
    pub s: f64,
    /// Its 95 % likelihood-ratio region in the final model.
    #[serde(rename = "S_range")]
    pub s_range: [f64; 2],
    /// The final model's J.
    #[serde(rename = "J")]
    pub j: f64,
    /// The unit of S and J: `% of valve span`, or [`RANGE_SEEN_UNIT`] when OP's valve span
    /// is unknown.
    #[serde(rename = "S_unit")]
    pub s_unit: &'static str,
    /// The model those numbers come from, e.g. `kano-asym + earx, dead time 2`.
    pub model: String,
    /// The causes that hold in the final model, each with the step that added it
    /// (`None`: found outside the forward selection).
    pub causes: Vec<(String, Option<usize>)>,
    /// After a change of the process: per cause named, the stationary stretches `[from, to)`
    /// on which it gains ([`Diagnosis::stretches`]; empty when no change was named).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub holds_on: Vec<(String, Vec<[usize; 2]>)>,
    /// What limits the statement, when something does (a change of the process, a weak fit).
    pub caution: Option<String>,
}

/// The unit of S and J when OP's valve span is unknown: the reader took the range seen for it.
pub const RANGE_SEEN_UNIT: &str = "% of the OP range seen";

/// `x` with two decimals in its unit, as `quantify` prints S: `1.23 %` (% of valve span), or
/// `1.23 (% of the OP range seen)` when OP's valve span is unknown (`span_unknown`).
pub fn in_unit(x: f64, span_unknown: bool) -> String {
    if span_unknown {
        format!("{x:.2} ({RANGE_SEEN_UNIT})")
    } else {
        format!("{x:.2} %")
    }
}

impl Diagnosis {
    /// How `cause` stands: the finding of the step that added it to the final model, or its
    /// first-step finding.
    pub fn standing(&self, cause: &str) -> Option<Standing<'_>> {
        let held = self.causes.iter().any(|c| c == cause);
        if let Some(f) = self
            .chosen
            .and_then(|i| self.findings.get(i))
            .filter(|f| f.cause == cause)
        {
            return Some(Standing {
                finding: f,
                step: Some(1),
                held,
            });
        }
        for (k, (step, &pick)) in self.steps.iter().zip(&self.picks).enumerate() {
            if let Some(f) = step.get(pick).filter(|f| f.cause == cause) {
                return Some(Standing {
                    finding: f,
                    step: Some(k + 2),
                    held,
                });
            }
        }
        self.findings
            .iter()
            .find(|f| f.cause == cause)
            .map(|finding| Standing {
                finding,
                step: None,
                held,
            })
    }

    /// The decision: what to do, the S to use with its range, the causes in the final model
    /// (S in % of valve span; [`Diagnosis::headline_in`] for a record whose span is unknown).
    pub fn headline(&self) -> Headline {
        self.headline_in(false)
    }

    /// [`Diagnosis::headline`] for a record whose OP valve span is unknown or not
    /// (`span_unknown`). With the span unknown, S is in % of the OP range seen and the action
    /// is judged against no threshold in % of valve span: it asks for the span instead.
    pub fn headline_in(&self, span_unknown: bool) -> Headline {
        let final_fit = self.final_fit();
        // the cause is the chosen finding's: a null hypothesis that holds (`no-stiction`)
        let no_stiction = self
            .chosen
            .and_then(|i| self.findings.get(i))
            .is_some_and(|f| f.role == crate::Role::NullHypothesis);
        let (fit, model_note) = match final_fit {
            Some(f) => (f, ""),
            None => (&self.baseline_fit, " (the baseline)"),
        };
        let q = &fit.result;
        let model = format!(
            "{} + {}, dead time {}{model_note}",
            fit.stiction.name, fit.linear, fit.delay
        );
        let causes: Vec<(String, Option<usize>)> = self
            .causes
            .iter()
            .map(|c| (c.clone(), self.standing(c).and_then(|s| s.step)))
            .collect();
        let holds_on: Vec<(String, Vec<[usize; 2]>)> = self
            .stretches
            .as_ref()
            .map(|check| {
                self.causes
                    .iter()
                    .filter(|c| *c != UNEXPLAINED)
                    .map(|c| (c.clone(), check.holds_on(c)))
                    .collect()
            })
            .unwrap_or_default();
        let (action, reason) = if no_stiction {
            (
                "look elsewhere".to_string(),
                format!(
                    "the oscillation is not the valve's: a valve with S at most {} explains PV as well",
                    if span_unknown {
                        in_unit(NEGLIGIBLE_S, true)
                    } else {
                        format!("{NEGLIGIBLE_S} %")
                    }
                ),
            )
        } else if span_unknown {
            (
                "state OP's valve span to judge S".to_string(),
                format!(
                    "OP's valve span is unknown, so S is in {RANGE_SEEN_UNIT} and no threshold in % of valve span applies; the verdict is the detector's"
                ),
            )
        } else {
            match Severity::of(q.s) {
                Severity::Harmful if q.s >= MAINTENANCE_S => (
                    "schedule valve maintenance".to_string(),
                    format!("S is at or above the {MAINTENANCE_S} % maintenance threshold"),
                ),
                Severity::Harmful => (
                    "plan valve maintenance".to_string(),
                    format!(
                        "S of 1 % or more degrades control; below the {MAINTENANCE_S} % maintenance threshold, re-register to follow it"
                    ),
                ),
                Severity::Slight => (
                    "no valve work now".to_string(),
                    "slight stiction; re-register to follow S".to_string(),
                ),
                Severity::Negligible => (
                    "no valve work".to_string(),
                    "stiction is negligible; if the loop oscillates, look elsewhere".to_string(),
                ),
            }
        };
        let mut cautions = Vec::new();
        if let Some(f) = self
            .causes
            .iter()
            .any(|c| c == UNEXPLAINED)
            .then(|| self.standing(UNEXPLAINED))
            .flatten()
        {
            cautions.push(match f.finding.window_from {
                Some(from) => format!(
                    "the process changed during the record (seen from sample {from}): re-register on a steady stretch"
                ),
                None => "something no registered cause explains remains: re-register on a steady stretch".to_string(),
            });
        }
        let weakening: Vec<String> = q
            .doubts
            .iter()
            .filter(|d| d.weakens_s())
            .map(grid_search::Doubt::short)
            .collect();
        if !no_stiction && !weakening.is_empty() {
            cautions.push(format!(
                "S is not to be trusted alone: {}",
                weakening.join("; ")
            ));
        }
        Headline {
            action,
            reason,
            s: q.s,
            s_range: q.interval.s,
            j: q.j,
            s_unit: if span_unknown {
                RANGE_SEEN_UNIT
            } else {
                "% of valve span"
            },
            model,
            causes,
            holds_on,
            caution: (!cautions.is_empty()).then(|| cautions.join("; ")),
        }
    }
}

impl Headline {
    /// The first line: the action and the S to use, e.g. `schedule valve maintenance: S =
    /// 1.74 % [1.70, 1.80], J = 1.56 % (kano-asym + earx, dead time 2); S is at or above ...`.
    pub fn action_line(&self) -> String {
        let unknown = self.s_unit == RANGE_SEEN_UNIT;
        format!(
            "{}: S = {} [{:.2}, {:.2}], J = {} ({}); {}",
            self.action,
            in_unit(self.s, unknown),
            self.s_range[0],
            self.s_range[1],
            in_unit(self.j, unknown),
            self.model,
            self.reason
        )
    }

    /// The causes that hold in the final model, each with its step, then the caution:
    /// `disturbance (step 1), time-delay (step 2), unexplained; caution: ...`.
    pub fn causes_line(&self) -> String {
        let mut s = if self.causes.is_empty() {
            "none: the baseline explains PV as well as any extension".to_string()
        } else {
            self.causes
                .iter()
                .map(|(c, step)| {
                    let on = self
                        .holds_on
                        .iter()
                        .find(|(name, _)| name == c)
                        .map(|(_, spans)| {
                            spans
                                .iter()
                                .map(|s| format!("samples {}-{}", s[0], s[1]))
                                .collect::<Vec<_>>()
                                .join(" and ")
                        });
                    match (step, on) {
                        (Some(k), Some(on)) => format!("{c} (step {k}; holds on {on})"),
                        (None, Some(on)) => format!("{c} (holds on {on})"),
                        (Some(k), None) => format!("{c} (step {k})"),
                        (None, None) => c.clone(),
                    }
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        if let Some(c) = &self.caution {
            s.push_str("; caution: ");
            s.push_str(c);
        }
        s
    }
}
