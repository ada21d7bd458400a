//! The forward selection: every cause tested on the baseline (the first round), then on the
//! chosen extension the causes not chosen yet, added while one gains significantly.

use rayon::prelude::*;

use crate::framework::{
    diagnosis_combination, lr_of, registry, role_of, Cause, CauseEntry, Context, Role,
};
use crate::summary::Finding;
use crate::{
    causes, orders_without_delay, DiagnoseError, Diagnoser, Fitted, ResidualAnalysis, PAIRS,
};

/// The forward selection's model: the last step's pick, else the chosen first cause's
/// extension (`None`: the baseline).
pub(crate) fn selected_model<'a>(
    picks: &[usize],
    steps: &'a [Vec<Finding>],
    chosen: Option<usize>,
    findings: &'a [Finding],
) -> Option<&'a Fitted> {
    match (picks.len(), picks.last()) {
        (n, Some(&k)) if n > 0 => steps[n - 1][k].fitted.as_ref(),
        _ => chosen.and_then(|i| findings[i].fitted.as_ref()),
    }
}

/// One forward-selection path: the causes in the order added (the first is the start's) and
/// the steps that tested the rest.
#[derive(Default)]
struct Path {
    causes: Vec<&'static str>,
    steps: Vec<Vec<Finding>>,
    picks: Vec<usize>,
}

impl Path {
    fn final_fit(&self) -> Option<&Fitted> {
        match (self.picks.len(), self.picks.last()) {
            (n, Some(&k)) if n > 0 => self.steps[n - 1][k].fitted.as_ref(),
            _ => None,
        }
    }
}

impl Diagnoser<'_> {
    /// The forward selection from the first round's `start` (a significant finding).
    /// `first_only`: the first step tests that cause alone (the pair search's step).
    fn forward(
        &self,
        start: &Finding,
        tell: &(dyn Fn(usize, &str) + Sync),
        done: usize,
        first_only: Option<&'static str>,
    ) -> Result<Path, DiagnoseError> {
        let (problem, span, baseline, options) =
            (self.problem, self.span, self.baseline, self.options);
        let mut causes = vec![start.cause];
        let mut steps: Vec<Vec<Finding>> = Vec::new();
        let mut picks: Vec<usize> = Vec::new();
        loop {
            let at = match (steps.last(), picks.last()) {
                (Some(step), Some(&k)) => &step[k],
                _ => start,
            };
            let Some(current) = at.fitted.as_ref() else {
                break;
            };
            // the record as the current model sees it (a cause that transformed the data)
            let data = crate::framework::seen(problem, at.data.as_ref());
            // OP's own oscillation of the transformed record is its own
            let own_cycle = causes::OwnCycle::default();
            let mut spec = diagnosis_combination(
                baseline,
                options,
                current.stiction,
                linear_id::find_identifier(current.linear)?,
                current.delay,
            );
            // the current model's own orders (HARX's frequency among them)
            spec.orders = orders_without_delay(current.identifier.as_ref());
            let q = &current.result;
            let res =
                ResidualAnalysis::new(data.pv, &q.pv_pred, &q.pv_sim, &q.mv_est, q.split_index);
            let ctx = Context {
                problem: data,
                span,
                baseline_spec: &spec,
                baseline: current,
                residuals: &res,
                options,
                own_cycle: if at.data.is_some() {
                    &own_cycle
                } else {
                    self.own_cycle
                },
            };
            let prev = *causes.last().unwrap_or(&"baseline");
            let candidates: Vec<&'static CauseEntry> = registry()
                .into_iter()
                .filter(|entry| {
                    !(options.disabled.iter().any(|d| d == entry.name)
                    || causes.contains(&entry.name)
                    // every other cause is tested again, also one that gained nothing on
                    // the baseline: an asymmetric valve under a disturbance or a dead time
                    // shows only once they are modelled (docs/DIAGNOSE.md, item 5);
                    // a null hypothesis (`no-stiction`) is a finding about the first round,
                    // not an extension
                    || entry.role != Role::Extension
                    || (steps.is_empty() && first_only.is_some_and(|c| c != entry.name)))
                })
                .collect();
            // independent of each other: tested at once, in the registry's order
            let tested: Vec<Finding> = candidates
                .into_par_iter()
                .filter_map(|entry| {
                    let cause = (entry.build)();
                    if !cause.applies(&ctx) {
                        return None;
                    }
                    tell(done, entry.name);
                    Some(
                        test_cause(
                            &ctx,
                            cause.as_ref(),
                            entry.name,
                            current.fit_val(),
                            (q.s, q.j),
                        )
                        .0,
                    )
                })
                .collect();
            let mut step = Vec::new();
            for mut f in tested {
                if f.data.is_none() {
                    f.data.clone_from(&at.data);
                }
                if f.reference == "baseline" {
                    f.reference = format!("the {prev} extension");
                }
                if f.significant
                    && f.fitted.as_ref().is_some_and(|x| {
                        causes::notches_the_valves_cycle(self.own_cycle, problem.op, x)
                    })
                {
                    f.significant = false;
                    f.evidence = format!(
                        "{} Not admitted: on this model the disturbance's notch sits on the loop's own oscillation while the valve is sticky, so the notch removes the valve's cycle, not an external one.",
                        f.evidence
                    );
                }
                step.push(f);
            }
            let best = step
                .iter()
                .enumerate()
                .filter(|(_, f)| f.significant && f.fitted.is_some())
                .max_by(|a, b| (a.1.lr - a.1.threshold).total_cmp(&(b.1.lr - b.1.threshold)))
                .map(|(k, _)| k);
            let found = best.map(|k| step[k].cause);
            steps.push(step);
            match (best, found) {
                (Some(k), Some(name)) => {
                    picks.push(k);
                    causes.push(name);
                }
                _ => break,
            }
        }
        Ok(Path {
            causes,
            steps,
            picks,
        })
    }
}

/// Test one cause on the model of `ctx`: its evidence, its extension and the decision.
/// Returns the finding and whether it is a significant null hypothesis ([`Role::NullHypothesis`],
/// `no-stiction`), reported ahead of the others.
pub(crate) fn test_cause(
    ctx: &Context<'_>,
    cause: &dyn Cause,
    name: &'static str,
    base_fit: f64,
    (bs, bj): (f64, f64),
) -> (Finding, bool) {
    let ev = cause.evidence(ctx);
    let options = ctx.options;
    let role = role_of(name);
    let null = role == Role::NullHypothesis;
    let mut overrides = false;
    let finding = match cause.extend(ctx) {
        Ok(ext) => {
            let (threshold, significant) = if null {
                // Removing parameters: significant when the loss is small.
                (-options.lr_no_stiction, ext.lr > -options.lr_no_stiction)
            } else {
                let t = options.threshold(ext.extra_params);
                (t, ext.lr > t)
            };
            overrides = significant && null;
            let s = ext.fitted.summary();
            let evidence = match &ext.data {
                Some(t) => format!(
                    "{} The extension fits the data transformed: {}.",
                    ev.text, t.what
                ),
                None => ev.text,
            };
            Finding {
                cause: name,
                role,
                evidence,
                statistic: ev.statistic,
                gain_fit_pv_val: ext.fitted.fit_val() - base_fit,
                delta_s: ext.fitted.result.s - bs,
                delta_j: ext.fitted.result.j - bj,
                extended: Some(s),
                fitted: Some(ext.fitted),
                lr: ext.lr,
                threshold,
                reference: ext.reference,
                significant,
                error: None,
                data: ext.data,
                window_from: None,
            }
        }
        Err(e) => Finding {
            cause: name,
            role,
            evidence: ev.text,
            statistic: ev.statistic,
            extended: None,
            fitted: None,
            gain_fit_pv_val: f64::NAN,
            delta_s: f64::NAN,
            delta_j: f64::NAN,
            lr: f64::NEG_INFINITY,
            threshold: f64::INFINITY,
            reference: "baseline".into(),
            significant: false,
            error: Some(e.to_string()),
            data: None,
            window_from: None,
        },
    };
    (finding, overrides)
}

/// The causes a diagnosis selects, through its phases: the first round's findings (best
/// first), the forward selection's later steps and picks, and the causes in the order added.
pub(crate) struct Selection {
    /// One per hypothesis tested on the baseline, best first.
    pub findings: Vec<Finding>,
    /// Index in `findings` of the first cause chosen.
    pub chosen: Option<usize>,
    /// Whether a null hypothesis (`no-stiction`) holds: it is then the finding, reported
    /// ahead of the others.
    pub null_holds: bool,
    /// The causes in the order added.
    pub causes: Vec<&'static str>,
    /// The forward selection's later steps.
    pub steps: Vec<Vec<Finding>>,
    /// Index in each step of the cause it added.
    pub picks: Vec<usize>,
}

/// Progress: `(done, what)`.
pub(crate) type Tell<'a> = &'a (dyn Fn(usize, &str) + Sync);

/// What every forward-selection path of one diagnosis shares: the diagnosis, its progress
/// report and the progress count reached.
struct Run<'r, 'a> {
    d: &'r Diagnoser<'a>,
    tell: Tell<'r>,
    done: usize,
}

impl Selection {
    /// Every cause of `testable` that is not disabled tested on the baseline of `ctx`, judged
    /// and ordered (significant null hypothesis, then significant by margin, then the rest by
    /// margin); the first is chosen when significant. Returns the progress count reached.
    pub fn first_round(
        ctx: &Context<'_>,
        testable: &[&'static CauseEntry],
        tell: Tell<'_>,
    ) -> (Selection, usize) {
        let options = ctx.options;
        let base_fit = ctx.baseline.fit_val();
        let (bs, bj) = (ctx.baseline.result.s, ctx.baseline.result.j);
        let mut done = 1;
        // the causes are independent of each other here: tested at once (their local
        // searches evaluate a few nodes at a time and would leave a core idle)
        let enabled: Vec<(usize, &'static CauseEntry)> = testable
            .iter()
            .filter(|e| !options.disabled.iter().any(|d| d == e.name))
            .enumerate()
            .map(|(k, &e)| (done + k, e))
            .collect();
        done += enabled.len();
        let tested: Vec<(Finding, bool)> = enabled
            .into_par_iter()
            .filter_map(|(at, entry)| {
                tell(at, entry.name);
                let cause = (entry.build)();
                (entry.role.is_tested() && cause.applies(ctx))
                    .then(|| test_cause(ctx, cause.as_ref(), entry.name, base_fit, (bs, bj)))
            })
            .collect();
        let mut sel = Selection {
            findings: Vec::new(),
            chosen: None,
            null_holds: false,
            causes: Vec::new(),
            steps: Vec::new(),
            picks: Vec::new(),
        };
        for (finding, overrides) in tested {
            sel.null_holds |= overrides;
            sel.findings.push(finding);
        }
        let n_val = (ctx.problem.op.len() - ctx.baseline.result.split_index) as f64;
        sel.judge_null(n_val, options);
        sel.order();
        (sel, done)
    }

    /// The null hypothesis is judged against the significant extensions, not against the
    /// baseline: an unmodelled dead time or disturbance can make the baseline's stiction look
    /// dispensable (or indispensable). Each extension's own grid contains the linear-valve
    /// node (all parameters 0), so the test costs no extra fit. It must hold against every one
    /// of them (the largest cost decides): a valve is not healthy because one explanation does
    /// without its stiction while another significant one needs it (measured: suite loop 1177,
    /// a sine and 6 samples of dead time, S = 3.4: with the sine notched out, the valve without
    /// stiction cost LR 0.9; with the dead time modelled it was sticky, S = 4.7).
    fn judge_null(&mut self, n_val: f64, options: &crate::DiagnoseOptions) {
        let best_extension = self
            .findings
            .iter()
            .filter(|f| f.significant && f.role != Role::NullHypothesis)
            .filter_map(|f| f.fitted.as_ref().map(|x| (f.cause, x)))
            .filter_map(|(cause, x)| {
                let fb = x.fit_val();
                x.result.fit_no_stiction.map(|f0| {
                    let cost = n_val
                        * ((1.0 - f0 / 100.0).max(1e-300) / (1.0 - fb / 100.0).max(1e-300)).ln();
                    (cause, cost)
                })
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((cause, cost)) = best_extension {
            let holds = cost < options.lr_no_stiction;
            for f in self
                .findings
                .iter_mut()
                .filter(|f| f.role == Role::NullHypothesis)
            {
                f.lr = -cost;
                f.threshold = -options.lr_no_stiction;
                f.significant = holds;
                f.reference = format!("the {cause} extension");
                f.evidence = format!(
                    "{} After accounting for {cause}, a valve without stiction costs LR {cost:.1} (holds when < {:.2}).",
                    f.evidence, options.lr_no_stiction
                );
            }
            self.null_holds = holds;
        }
    }

    /// Order: a significant null hypothesis, then significant by margin, then the rest by
    /// margin; the first is chosen when significant.
    fn order(&mut self) {
        let margin = |f: &Finding| {
            if f.lr.is_finite() && f.threshold.is_finite() {
                f.lr - f.threshold
            } else if f.lr.is_finite() {
                f.lr
            } else {
                f64::NEG_INFINITY
            }
        };
        let null_holds = self.null_holds;
        let overriding = |f: &Finding| null_holds && f.role == Role::NullHypothesis;
        self.findings.sort_by(|a, b| {
            let ka = (overriding(a), a.significant);
            let kb = (overriding(b), b.significant);
            kb.cmp(&ka).then(margin(b).total_cmp(&margin(a)))
        });
        self.chosen = self.findings.first().filter(|f| f.significant).map(|_| 0);
    }

    /// Whether the chosen first cause is the null hypothesis (a valve found healthy).
    pub fn healthy(&self) -> bool {
        self.chosen
            .is_some_and(|i| self.findings[i].role == Role::NullHypothesis)
    }

    /// The chosen first cause when it is an extension (not the null hypothesis).
    pub fn first_extension(&self) -> Option<usize> {
        self.chosen
            .filter(|&i| self.findings[i].role != Role::NullHypothesis)
    }

    /// The record as the forward selection's model sees it ([`crate::Transformed`]; `None`:
    /// the record itself).
    pub fn selected_data(&self) -> Option<&crate::Transformed> {
        let finding = match (self.picks.len(), self.picks.last()) {
            (n, Some(&k)) if n > 0 => Some(&self.steps[n - 1][k]),
            _ => self.chosen.map(|i| &self.findings[i]),
        };
        finding.and_then(|f| f.data.as_ref())
    }

    /// The forward selection's model: the last step's pick, else the chosen first cause's
    /// extension (`None`: the baseline).
    pub fn selected_model(&self) -> Option<&Fitted> {
        selected_model(&self.picks, &self.steps, self.chosen, &self.findings)
    }

    /// Forward selection: on the chosen extension, test the causes not chosen yet; add the
    /// one with the largest significant gain; repeat until none is significant. Each step's
    /// model carries every extension chosen before it (its stiction model, identifier and
    /// dead time), so the last is the joint model. Two starts when the runner-up of the first
    /// round is significant too ([`Selection::two_starts`]), then the pairs that mask each
    /// other ([`Selection::pairs`]).
    pub fn select(
        &mut self,
        d: &Diagnoser<'_>,
        tell: Tell<'_>,
        done: usize,
    ) -> Result<(), DiagnoseError> {
        let mut path = Path::default();
        let run = Run { d, tell, done };
        let pairs = !d.options.disabled.iter().any(|c| c == PAIRS) && !self.null_holds;
        if let Some(i) = self.first_extension() {
            path = self.two_starts(&run, i)?;
            if pairs {
                path = self.pairs(&run, i, path)?;
            }
        } else if pairs && self.chosen.is_none() {
            path = self.pair_of_weak_causes(&run)?;
        }
        let Path {
            causes,
            steps,
            picks,
        } = path;
        self.causes = causes;
        self.steps = steps;
        self.picks = picks;
        if self.causes.is_empty() {
            // the null hypothesis (no forward selection after it)
            let chosen = self.chosen.map(|i| self.findings[i].cause);
            self.causes.extend(chosen);
        }
        Ok(())
    }

    /// The forward selection from the first cause `i` and, when the runner-up of the first
    /// round is significant too, from the runner-up (extensions do not commute: EARX at a
    /// scanned dead time is not the scan of EARX's dead time): the runner-up's path wins only
    /// when its final model fits the validation data significantly better (LR over
    /// `lr_base`), never for naming more causes.
    fn two_starts(&mut self, run: &Run<'_, '_>, i: usize) -> Result<Path, DiagnoseError> {
        let Run { d, tell, done } = *run;
        let findings = &self.findings;
        let runner_up = findings
            .iter()
            .enumerate()
            .skip(1)
            .find(|(_, f)| f.significant && f.role != Role::NullHypothesis && f.fitted.is_some())
            .map(|(k, _)| k)
            .filter(|_| !self.null_holds);
        // the two starts are independent: run at once (their local searches evaluate a few
        // nodes at a time and leave a core idle; the grids share the pool)
        let (first, second) = rayon::join(
            || d.forward(&findings[i], tell, done, None),
            || runner_up.map(|k| d.forward(&findings[k], tell, done, None)),
        );
        let mut path = first?;
        if let (Some(k), Some(other)) = (runner_up, second) {
            let other = other?;
            let fit = |p: &Path, start: usize| {
                p.final_fit()
                    .or(findings[start].fitted.as_ref())
                    .map_or(f64::NEG_INFINITY, Fitted::fit_val)
            };
            // the other path replaces the best first cause only when its final model is
            // significantly better (the LR between the two final models over `lr_base`)
            let sse = |f: f64| (1.0 - f / 100.0).max(1e-12);
            let lr = d.n_val() * (sse(fit(&path, i)) / sse(fit(&other, k))).ln();
            if lr > d.options.lr_base {
                path = other;
                self.chosen = Some(k);
            }
        }
        Ok(path)
    }

    /// Two causes that mask each other when neither gains significantly on the baseline alone:
    /// every cause that gained on the baseline (LR > 0) is a start, on its extension every
    /// other cause is tested (the forward selection's step, its own LR rule), and the pair is
    /// named when its model gains significantly over each of the two causes' extensions alone
    /// (over the start's: the step's test; over the other's: LR over the one-parameter
    /// threshold). The best-fitting such pair wins; the forward selection goes on from it.
    /// An installed characteristic with a dead time on a loop detuned for both (suite loops
    /// 6000-6023, PI gains 3-6 times lower than either effect's alone).
    fn pair_of_weak_causes(&mut self, run: &Run<'_, '_>) -> Result<Path, DiagnoseError> {
        let Run { d, tell, done } = *run;
        let findings = &self.findings;
        let starts: Vec<usize> = findings
            .iter()
            .enumerate()
            .filter(|(_, f)| {
                !f.significant && f.role == Role::Extension && f.fitted.is_some() && f.lr > 0.0
            })
            .map(|(k, _)| k)
            .collect();
        let paths: Vec<(usize, Result<Path, DiagnoseError>)> = starts
            .into_par_iter()
            .map(|k| (k, d.forward(&findings[k], tell, done, None)))
            .collect();
        let n_val = d.n_val();
        let alone = |cause: &str| {
            findings
                .iter()
                .find(|f| f.cause == cause)
                .and_then(|f| f.fitted.as_ref())
                .map_or(f64::NEG_INFINITY, Fitted::fit_val)
        };
        let mut best: Option<(usize, f64, f64, Path)> = None;
        for (k, path) in paths {
            let path = path?;
            let (Some(&p), Some(&other)) = (path.picks.first(), path.causes.get(1)) else {
                continue;
            };
            let Some(pair) = path.steps[0][p].fitted.as_ref() else {
                continue;
            };
            let lr = lr_of(n_val, alone(other), pair.fit_val());
            if lr.is_finite()
                && lr > d.options.threshold(1)
                && best.as_ref().is_none_or(|b| pair.fit_val() > b.2)
            {
                best = Some((k, lr, pair.fit_val(), path));
            }
        }
        let Some((k, lr, _, path)) = best else {
            return Ok(Path::default());
        };
        let other = path.causes[1];
        self.name_pair(
            k,
            &format!(
                " and {other} alone does not gain significantly either; with {other} on top, the pair's model gains significantly over this cause's extension (the next step) and likelihood ratio {lr:.0} over {other}'s alone (threshold {:.0})",
                d.options.threshold(1)
            ),
        );
        Ok(path)
    }

    /// The first round's finding `k` named as the first of a pair (significant, chosen), its
    /// evidence saying so: what it gains alone, then `why` (from its separator on).
    fn name_pair(&mut self, k: usize, why: &str) {
        let f = &mut self.findings[k];
        f.significant = true;
        f.evidence = format!(
            "{} Named as a pair: alone it gains likelihood ratio {:.0} (threshold {:.0}){why}.",
            f.evidence, f.lr, f.threshold
        );
        self.chosen = Some(k);
    }

    /// Two causes that mask each other: a cause that gained on the baseline but not enough
    /// (a dead time part of which a disturbance absorbs, and the other way round; a dead time
    /// under an asymmetric valve) is a start too. On its extension the selected path's first
    /// cause is tested alone; the pair replaces the selected path when its model gains
    /// significantly over that first cause's extension alone (one extra parameter) and its
    /// path's final model fits no worse. Judging the whole path instead named a third
    /// cause's gain as a pair (docs/DIAGNOSE.md, item 5).
    fn pairs(&mut self, run: &Run<'_, '_>, i: usize, path: Path) -> Result<Path, DiagnoseError> {
        let Run { d, tell, done } = *run;
        let Some(first) = path.causes.first().copied() else {
            return Ok(path);
        };
        let chosen = self.chosen;
        let findings = &self.findings;
        let held = path.causes.clone();
        let masked: Vec<usize> = findings
            .iter()
            .enumerate()
            .filter(|(k, f)| {
                Some(*k) != chosen
                    && !f.significant
                    && f.role != Role::NullHypothesis
                    && f.fitted.is_some()
                    && f.lr > 0.0
                    && !held.contains(&f.cause)
            })
            .map(|(k, _)| k)
            .collect();
        let others: Vec<(usize, Result<Path, DiagnoseError>)> = masked
            .into_par_iter()
            .map(|k| (k, d.forward(&findings[k], tell, done, Some(first))))
            .collect();
        let n_val = d.n_val();
        let start = chosen.unwrap_or(i);
        let fit_of = |p: &Path, k: usize| {
            p.final_fit()
                .or(findings[k].fitted.as_ref())
                .map_or(f64::NEG_INFINITY, Fitted::fit_val)
        };
        let current = fit_of(&path, start);
        let alone = findings[start]
            .fitted
            .as_ref()
            .map_or(f64::NEG_INFINITY, Fitted::fit_val);
        let mut best: Option<(usize, f64, Path)> = None;
        for (k, other) in others {
            let other = other?;
            // the pair's model: the selected first cause added on the start's
            let Some(pair) = other
                .picks
                .first()
                .and_then(|&p| other.steps[0][p].fitted.as_ref())
            else {
                continue;
            };
            // significant over the first cause alone (over the start alone: the step that
            // added the first cause was significant), and its path's final model no worse
            // than the selected path's
            let lr = lr_of(n_val, alone, pair.fit_val());
            if lr > d.options.threshold(1)
                && fit_of(&other, k) >= current
                && best.as_ref().is_none_or(|b| lr > b.1)
            {
                best = Some((k, lr, other));
            }
        }
        let Some((k, lr, other)) = best else {
            return Ok(path);
        };
        self.name_pair(
            k,
            &format!(
                "; with {first} on top, the pair's model gains likelihood ratio {lr:.0} over {first}'s alone (threshold {:.0})",
                d.options.threshold(1)
            ),
        );
        Ok(other)
    }
}
