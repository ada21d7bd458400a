//! Model discrepancy: show what the stiction model's simulation gets wrong, name the cause,
//! extend the model for that cause and measure the gain (`stiction diagnose`).
//!
//! [`diagnose`] fits the baseline Hammerstein model (default Kano + ARX(2, 2), the paper's
//! real-data choice) with `grid_search::quantify`, characterises its residuals on the
//! validation window ([`ResidualAnalysis`]), then asks every registered [`Cause`] for its
//! detection statistic and its extended model. An extension is accepted only when its gain on
//! validation data passes the likelihood-ratio criterion of [`DiagnoseOptions`], which grows
//! with the number of parameters the extension adds; otherwise the cause is `none`. The method
//! and its measured rates are in `docs/DIAGNOSE.md`.
//!
//! Causes are plugins: a type implementing [`Cause`] plus one `inventory::submit!` of a
//! [`CauseEntry`]. The built-ins are `disturbance` (EARX/EARMAX), `asymmetric-stiction`
//! (`kano-asym`), `time-delay` (the dead time estimated), `valve-characteristic` (`kano-char`:
//! an installed flow characteristic after the valve), `no-stiction` (the oscillation is not
//! the valve's: S = J = 0 explains PV as well) and `compression` (PV read back from a
//! historian's compressed storage: named first, no other cause tested, [`Cause::reframe`]).
//! This crate does no IO.

mod causes;
mod characteristic;
mod compression;
mod consensus;
mod eval;
mod headline;
pub mod registration;
mod residuals;
mod stretches;

use std::fmt;
use std::time::Instant;

use grid_search::{GridPlan, Problem, SearchOptions};
use linear_id::IdentifierEntry;
use rayon::prelude::*;
use serde::Serialize;
use stiction_models::ModelEntry;

pub use run::{Combination, FitSummary, Fitted};

pub use causes::{AsymmetricStiction, Disturbance, NoStiction, TimeDelay};
pub use characteristic::ValveCharacteristic;
pub use compression::Compression;
pub use consensus::{consensus, Consensus, Disagreement};
pub use headline::{Headline, Standing};
pub use residuals::{ResidualAnalysis, LOW_BAND, MAX_LAG};
pub use stretches::{locate_change, StretchTest, Stretches, MIN_STRETCH};

/// Re-exported so that plugin crates use the same `inventory` as the registry.
pub use inventory;

/// Errors of the diagnosis.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DiagnoseError {
    /// The baseline (or an extension's) grid search failed.
    #[error(transparent)]
    Search(#[from] grid_search::SearchError),
    /// A linear identifier could not be built.
    #[error(transparent)]
    Identifier(#[from] linear_id::IdError),
    /// A stiction model could not be built.
    #[error(transparent)]
    Stiction(#[from] stiction_models::StictionError),
    /// A local search evaluated no node.
    #[error("{model}: no node could be evaluated (empty search)")]
    EmptySearch {
        /// The stiction model searched.
        model: String,
    },
    /// The run library refused (a setting, a write, ...).
    #[error(transparent)]
    Run(run::RunError),
    /// An option is out of range.
    #[error("invalid option {name} = {value}: expected {expected}")]
    InvalidOption {
        /// Option name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Valid range.
        expected: String,
    },
    /// A cause that acts through [`Cause::reframe`] was asked for an extension.
    #[error("{cause} acts on every model of the diagnosis, not as an extension")]
    NotAnExtension {
        /// The cause.
        cause: &'static str,
    },
    /// A search setting that cannot work for a diagnosis (the message names the CLI's flag).
    #[error("{0}")]
    Setting(String),
    /// A cause named in `disabled` or asked for does not exist.
    #[error("unknown cause {name:?}; registered: {known}")]
    UnknownCause {
        /// The name given.
        name: String,
        /// Registered names.
        known: String,
    },
}

impl From<run::RunError> for DiagnoseError {
    fn from(e: run::RunError) -> Self {
        match e {
            run::RunError::Stiction(e) => DiagnoseError::Stiction(e),
            run::RunError::Identification(e) => DiagnoseError::Identifier(e),
            run::RunError::Search(e) => DiagnoseError::Search(e),
            run::RunError::Setting { message, .. } => DiagnoseError::Setting(message),
            other => DiagnoseError::Run(other),
        }
    }
}

/// The model a diagnosis starts from: a [`Combination`] with a fixed dead time (its grid and
/// search options are the diagnosis's, [`DiagnoseOptions::search`]).
pub type Baseline = Combination;

/// The baseline of a diagnosis from the search settings as the CLI's flags spell them: the
/// combination with a fixed dead time (`--delay auto` is refused: the diagnosis tests the dead
/// time itself) and its orders in full (defaults filled in), so that an extension with another
/// identifier inherits the orders they share. The CLI and the Python package both start here.
pub fn baseline(
    args: &run::SearchArgs,
    stiction: &str,
    linear: &str,
) -> Result<Baseline, DiagnoseError> {
    let delay = match args.delay {
        run::DelayArg::Samples(d) => d,
        run::DelayArg::Auto => {
            return Err(DiagnoseError::Setting(
                "--delay auto: diagnose tests the dead time itself (cause time-delay); give the baseline's fixed dead time".into(),
            ))
        }
    };
    let mut baseline = args.settings(&[linear])?.combination(stiction, linear)?;
    baseline.orders = orders_without_delay(baseline.identifier(delay)?.as_ref());
    Ok(baseline)
}

/// The diagnosis's options for a record whose OP spans `span`, with the causes `without` left
/// out.
pub fn options_for(
    args: &run::SearchArgs,
    span: f64,
    without: &[String],
) -> Result<DiagnoseOptions, DiagnoseError> {
    let mut options = DiagnoseOptions::for_span(span);
    options.search = args.settings(&[])?.options(span);
    options.disabled = without.to_vec();
    options.select_orders = args.orders.is_none();
    Ok(options)
}

/// What a cause computes from the baseline's residuals and the data, before any refit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evidence {
    /// The detection statistic (its meaning is the cause's; see [`CauseEntry::statistic`]).
    pub statistic: f64,
    /// The evidence in words, with numbers.
    pub text: String,
}

/// An extended model and the comparison that decides it.
#[derive(Debug)]
pub struct Extension {
    /// The extended model.
    pub fitted: Fitted,
    /// Likelihood-ratio statistic of the comparison on validation residuals,
    /// `n_val · ln(SSE_reference / SSE_extended)` (negative when the extension is worse).
    pub lr: f64,
    /// Parameters the extension adds to its reference (negative when it removes some).
    pub extra_params: i32,
    /// What the LR compares against, in words (`baseline`, or a nested reference).
    pub reference: String,
}

/// Everything a cause may look at.
pub struct Context<'a> {
    /// The loop.
    pub problem: Problem<'a>,
    /// OP span.
    pub span: f64,
    /// The baseline specification.
    pub baseline_spec: &'a Baseline,
    /// The fitted baseline.
    pub baseline: &'a Fitted,
    /// Its residual analysis.
    pub residuals: &'a ResidualAnalysis,
    /// Options.
    pub options: &'a DiagnoseOptions,
    /// OP's own oscillation, computed once per record.
    pub(crate) own_cycle: &'a causes::OwnCycle,
}

impl Context<'_> {
    /// The quantisation step of OP (`datasets::quantisation::step`), `None` when OP is not
    /// on a lattice.
    pub fn op_step(&self) -> Option<f64> {
        op_step(self.problem.op)
    }

    /// Validation samples.
    pub fn n_val(&self) -> f64 {
        (self.problem.op.len() - self.baseline.result.split_index) as f64
    }

    /// `n_val · ln(SSE_a / SSE_b)` from two validation fits in % (same window, same PV).
    pub fn lr(&self, fit_a: f64, fit_b: f64) -> f64 {
        lr_of(self.n_val(), fit_a, fit_b)
    }

    /// Quantify with `stiction` × `linear` and dead time `delay` on the diagnosis's grid plan
    /// (the baseline's orders).
    pub fn quantify(
        &self,
        stiction: &'static ModelEntry,
        linear: &'static IdentifierEntry,
        delay: usize,
    ) -> Result<Fitted, DiagnoseError> {
        Ok(self
            .combination(stiction, linear, delay)
            .run(self.problem, None)?)
    }

    /// The baseline's combination with another stiction model, identifier and dead time, on
    /// the diagnosis's grid and search options.
    pub fn combination(
        &self,
        stiction: &'static ModelEntry,
        linear: &'static IdentifierEntry,
        delay: usize,
    ) -> Combination {
        diagnosis_combination(self.baseline_spec, self.options, stiction, linear, delay)
    }
}

/// `baseline` with another stiction model, identifier and dead time, searched with the
/// diagnosis's options.
/// How the final model's linear orders were chosen (`diagnose` without `--orders`).
///
/// The paper's ARX(2, 2) under-models a slower, higher-order process and is biased by coloured
/// noise that a longer regression absorbs; the stiction estimate carries that bias (a deadband
/// that stands in for missing lag). So after the causes are found at the given orders, the
/// baseline is fitted again with `n` and `m` each raised by one, and the raised orders are kept
/// for the final refit ([`Diagnosis::refined`]) when they gain on validation data by the
/// likelihood-ratio rule of an extension adding two parameters
/// ([`DiagnoseOptions::threshold`]). The causes are not judged at the raised orders: an AR(3)
/// absorbs part of a sinusoidal or drifting disturbance, which then gains nothing as a cause;
/// and one step only: ARX(4, 4) cost the causes more (measured in `docs/decisions/2026-11-26-diagnose-logbook.md`, item 12).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OrderSelection {
    /// The orders given (`n=2, m=2`).
    pub from: String,
    /// The raised orders tried (`n=3, m=3`).
    pub to: String,
    /// `n_val · ln(SSE_from / SSE_to)` on validation data.
    pub lr: f64,
    /// The threshold it had to pass.
    pub threshold: f64,
    /// Whether the raised orders were kept.
    pub raised: bool,
}

/// An identifier's orders in full (its defaults filled in), without the dead time.
pub fn orders_without_delay(
    identifier: &dyn linear_id::LinearIdentifier,
) -> Vec<(String, linear_id::OrderValue)> {
    identifier
        .orders()
        .into_iter()
        .filter(|(k, _)| *k != "delay")
        .map(|(k, v)| (k.to_string(), v))
        .collect()
}

/// The orders `n` and `m` of `orders` raised by one (`None` when it has neither).
fn raised_orders(
    orders: &[(String, linear_id::OrderValue)],
) -> Option<(Vec<(String, linear_id::OrderValue)>, i32)> {
    let mut extra = 0;
    let raised = orders
        .iter()
        .map(|(k, v)| match v {
            linear_id::OrderValue::Int(x) if k == "n" || k == "m" => {
                extra += 1;
                (k.clone(), linear_id::OrderValue::Int(x + 1))
            }
            _ => (k.clone(), *v),
        })
        .collect();
    (extra > 0).then_some((raised, extra))
}

fn orders_text(orders: &[(String, linear_id::OrderValue)]) -> String {
    orders
        .iter()
        .filter(|(k, _)| k == "n" || k == "m")
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The final model refitted where the diagnosis found reason to: on the samples from `from`
/// on when the process changed during the record (the open set's recent window: the model
/// that holds now is identified after the change), and with `n` and `m` raised by one when
/// that gains significantly over the given orders on the same samples ([`OrderSelection`];
/// only with [`DiagnoseOptions::select_orders`]). The baseline is refitted so, then every
/// cause of `chain` is extended on it again in order (each on the previous one's model, as
/// the forward selection did). The model is `None` when there is nothing to refit, or a fit
/// fails (too few samples, an extension that cannot be fitted): the final model then stands.
/// `own_cycle`: OP's own oscillation over the whole record (used when `from` is `None`).
#[allow(clippy::too_many_arguments)]
fn refit_final(
    problem: Problem<'_>,
    span: f64,
    baseline: &Baseline,
    base: &Fitted,
    chain: &[&'static str],
    from: Option<usize>,
    options: &DiagnoseOptions,
    own_cycle: &causes::OwnCycle,
) -> (Option<Fitted>, Option<OrderSelection>) {
    let data = match from {
        Some(f) => Problem {
            op: &problem.op[f..],
            pv: &problem.pv[f..],
            mv: problem.mv.map(|m| &m[f..]),
        },
        None => problem,
    };
    // after a change: identified on `[from, N_id)`, validated on the baseline's own
    // validation window `[N_id, N)` (the open set's comparison, and the fits stay comparable)
    let recent_options;
    let options = match from {
        Some(f) => {
            let ni = base.result.split_index;
            if ni <= f {
                return (None, None);
            }
            let mut o = options.clone();
            o.search.split = ((ni - f) as f64 + 0.5) / data.op.len() as f64;
            recent_options = o;
            &recent_options
        }
        None => options,
    };
    let fit = |spec: &Baseline| {
        diagnosis_combination(spec, options, spec.stiction, spec.linear, base.delay)
            .run(data, None)
            .ok()
    };
    let given = orders_without_delay(base.identifier.as_ref());
    let mut spec = Baseline {
        orders: given.clone(),
        ..baseline.clone()
    };
    let recent = match from {
        Some(_) => match fit(&spec) {
            Some(f) => Some(f),
            None => return (None, None),
        },
        None => None,
    };
    let mut start = recent;
    let mut selection = None;
    if let Some((orders, extra)) = raised_orders(&given).filter(|_| options.select_orders) {
        let other = Baseline {
            orders,
            ..baseline.clone()
        };
        if let Some(raised) = fit(&other) {
            let reference = start.as_ref().unwrap_or(base);
            let n_val = (data.op.len() - reference.result.split_index) as f64;
            let lr = lr_of(n_val, reference.fit_val(), raised.fit_val());
            let threshold = options.threshold(extra);
            let o = OrderSelection {
                from: orders_text(&given),
                to: orders_text(&other.orders),
                lr,
                threshold,
                raised: lr > threshold,
            };
            if o.raised {
                start = Some(raised);
                spec = other;
            }
            selection = Some(o);
        }
    }
    let Some(mut current) = start else {
        return (None, selection);
    };
    let known = registry();
    // after a change, OP's own oscillation on the samples refitted
    let recent_cycle = causes::OwnCycle::default();
    let own_cycle = if from.is_some() {
        &recent_cycle
    } else {
        own_cycle
    };
    for name in chain {
        let Some(entry) = known.iter().find(|e| e.name == *name) else {
            return (None, selection);
        };
        let Ok(linear) = linear_id::find_identifier(current.linear) else {
            return (None, selection);
        };
        let mut step =
            diagnosis_combination(&spec, options, current.stiction, linear, current.delay);
        step.orders = orders_without_delay(current.identifier.as_ref());
        let q = &current.result;
        let res = ResidualAnalysis::new(data.pv, &q.pv_pred, &q.pv_sim, &q.mv_est, q.split_index);
        let ctx = Context {
            problem: data,
            span,
            baseline_spec: &step,
            baseline: &current,
            residuals: &res,
            options,
            own_cycle,
        };
        let Ok(ext) = (entry.build)().extend(&ctx) else {
            return (None, selection);
        };
        current = ext.fitted;
    }
    if let Some(f) = from {
        current.result.warnings.push(format!(
            "identified on samples {f}-{} only and validated on samples {}-{}: the process changed during the record (unexplained)",
            base.result.split_index,
            base.result.split_index,
            problem.op.len()
        ));
    }
    (Some(current), selection)
}

/// `n_val · ln(SSE_a / SSE_b)` from two validation fits in % (same window, same PV).
fn lr_of(n_val: f64, fit_a: f64, fit_b: f64) -> f64 {
    let sse = |f: f64| (1.0 - f / 100.0).max(1e-12);
    if !(fit_a.is_finite() && fit_b.is_finite()) {
        return if fit_b.is_finite() {
            f64::INFINITY
        } else {
            f64::NEG_INFINITY
        };
    }
    n_val * (sse(fit_a) / sse(fit_b)).ln()
}

fn diagnosis_combination(
    baseline: &Baseline,
    options: &DiagnoseOptions,
    stiction: &'static ModelEntry,
    linear: &'static IdentifierEntry,
    delay: usize,
) -> Combination {
    Combination {
        grid: Some(options.search.grid),
        search: options.search,
        ..baseline.with(stiction, linear, delay)
    }
}

/// A cause of model discrepancy: a detection statistic and the extension that accounts for it.
///
/// Object safe; built-ins have no configuration. Register with `inventory::submit!` of a
/// [`CauseEntry`] whose `name` equals [`Cause::name`].
pub trait Cause: Send + Sync + fmt::Debug {
    /// Registered name (`disturbance`, `asymmetric-stiction`, ...).
    fn name(&self) -> &'static str;
    /// Whether the cause can be tested with this baseline (e.g. `disturbance` not when the
    /// baseline is already an extended model).
    fn applies(&self, ctx: &Context<'_>) -> bool;
    /// The detection statistic from the baseline's residuals and the data.
    fn evidence(&self, ctx: &Context<'_>) -> Evidence;
    /// Fit the extension and compare it.
    fn extend(&self, ctx: &Context<'_>) -> Result<Extension, DiagnoseError>;
    /// When significant, this cause is reported ahead of causes with larger LR (used by
    /// `no-stiction`: if the valve explains nothing, that is the finding).
    fn overrides(&self) -> bool {
        false
    }
    /// A cause in the data rather than in the loop, which biases how models are compared
    /// (`compression`): when it holds for `problem`, the diagnosis fits the returned baseline
    /// instead, names this cause first with the returned evidence, and tests no other cause
    /// (their likelihood-ratio tests assume data the cause has altered). Default: never.
    fn reframe(
        &self,
        _problem: Problem<'_>,
        _baseline: &Baseline,
        _search: &SearchOptions,
    ) -> Option<Reframe> {
        None
    }
}

/// What a cause in the data changes ([`Cause::reframe`]).
#[derive(Debug, Clone)]
pub struct Reframe {
    /// The baseline to fit instead.
    pub baseline: Baseline,
    /// The search options of that fit.
    pub search: SearchOptions,
    /// The evidence, in words, and the cause's statistic.
    pub evidence: Evidence,
}

/// A registered cause.
#[derive(Debug)]
pub struct CauseEntry {
    /// Registered name.
    pub name: &'static str,
    /// One line: what the cause is and which extension accounts for it.
    pub description: &'static str,
    /// What the detection statistic measures.
    pub statistic: &'static str,
    /// Build the cause.
    pub build: fn() -> Box<dyn Cause>,
}

inventory::collect!(CauseEntry);

/// Every registered cause, sorted by name.
pub fn registry() -> Vec<&'static CauseEntry> {
    let mut v: Vec<_> = inventory::iter::<CauseEntry>.into_iter().collect();
    v.sort_by_key(|e| e.name);
    v
}

/// Options of [`diagnose`].
///
/// | field | default | meaning |
/// |-------|---------|---------|
/// | `search` | In.3, coarse span/40 → fine 0.1 | grid of the baseline and of every refit |
/// | `max_delay` | 10 | largest dead time tried by `time-delay` |
/// | `lr_base` | 20 | LR an extension must exceed with one extra parameter ... |
/// | `lr_per_param` | 10 | ... plus this per further extra parameter |
/// | `lr_no_stiction` | 9.21 | `no-stiction` holds when removing S and J costs less than this (χ²₂ 99 %) |
/// | `disabled` | none | causes not tested (for ablation) |
#[derive(Debug, Clone)]
pub struct DiagnoseOptions {
    /// Search options (grid, initialization, split, criterion).
    pub search: SearchOptions,
    /// Largest dead time tried.
    pub max_delay: usize,
    /// LR threshold for one extra parameter.
    pub lr_base: f64,
    /// LR threshold increment per further parameter.
    pub lr_per_param: f64,
    /// LR a stiction model must gain over S = J = 0 to count as stiction.
    pub lr_no_stiction: f64,
    /// Causes not tested.
    pub disabled: Vec<String>,
    /// Whether the baseline's orders `n` and `m` are chosen from the data (see
    /// [`OrderSelection`]); off when the user gave the orders.
    pub select_orders: bool,
}

impl DiagnoseOptions {
    /// Defaults with the CLI's default grid for OP span `span`.
    pub fn for_span(span: f64) -> DiagnoseOptions {
        DiagnoseOptions {
            search: SearchOptions {
                grid: GridPlan::for_span(span),
                ..SearchOptions::default()
            },
            max_delay: 10,
            lr_base: 20.0,
            lr_per_param: 10.0,
            lr_no_stiction: 9.21,
            disabled: Vec::new(),
            select_orders: true,
        }
    }

    /// The LR an extension adding `extra` parameters must exceed.
    pub fn threshold(&self, extra: i32) -> f64 {
        if extra <= 0 {
            return f64::INFINITY;
        }
        self.lr_base + self.lr_per_param * (extra - 1) as f64
    }
}

/// One tested hypothesis.
#[derive(Debug, Serialize)]
pub struct Finding {
    /// Cause name.
    pub cause: &'static str,
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
    /// For `unexplained`: the first sample of the recent window whose linear part predicts
    /// the validation data better (where the changed process is seen).
    #[serde(skip)]
    pub window_from: Option<usize>,
}

/// The result of [`diagnose`].
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

fn span_of(op: &[f64]) -> f64 {
    let (lo, hi) = op
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    hi - lo
}

/// Diagnose one loop: fit `baseline`, analyse its residuals, test every registered cause.
pub fn diagnose(
    problem: Problem<'_>,
    baseline: &Baseline,
    options: &DiagnoseOptions,
) -> Result<Diagnosis, DiagnoseError> {
    diagnose_with_progress(problem, baseline, options, None)
}

/// Progress of a diagnosis: `(done, total, what is being fitted now)`, steps being the
/// baseline and each cause tested.
pub type DiagnoseProgress<'a> = &'a (dyn Fn(usize, usize, &str) + Sync);

/// [`diagnose`], reporting each step (the baseline, then each cause) to `progress`.
pub fn diagnose_with_progress(
    problem: Problem<'_>,
    baseline: &Baseline,
    options: &DiagnoseOptions,
    progress: Option<DiagnoseProgress<'_>>,
) -> Result<Diagnosis, DiagnoseError> {
    let started = Instant::now();
    let known = registry();
    let steps = 1 + known
        .iter()
        .filter(|e| !options.disabled.iter().any(|d| d == e.name))
        .count();
    let tell = |done: usize, what: &str| {
        if let Some(p) = progress {
            p(done, steps, what);
        }
    };
    tell(0, "baseline");
    for d in &options.disabled {
        if !known.iter().any(|e| e.name == d) && d != UNEXPLAINED && d != PAIRS {
            return Err(DiagnoseError::UnknownCause {
                name: d.clone(),
                known: known.iter().map(|e| e.name).collect::<Vec<_>>().join(", "),
            });
        }
    }
    // a cause in the data (compression) changes how every model is compared
    let original = options;
    let mut reframed = None;
    for entry in &known {
        if options.disabled.iter().any(|d| d == entry.name) {
            continue;
        }
        if let Some(r) = (entry.build)().reframe(problem, baseline, &options.search) {
            let o = DiagnoseOptions {
                search: r.search,
                ..options.clone()
            };
            reframed = Some((entry.name, r.evidence, o, r.baseline));
            break;
        }
    }
    let original_baseline = baseline;
    let (options, baseline) = reframed
        .as_ref()
        .map_or((options, baseline), |r| (&r.2, &r.3));
    let span = span_of(problem.op);
    let t0 = Instant::now();
    let mut base = diagnosis_combination(
        baseline,
        options,
        baseline.stiction,
        baseline.linear,
        baseline.fixed_delay(),
    )
    .run(problem, None)?;
    base.elapsed_ms = t0.elapsed().as_secs_f64() * 1e3;
    // Residual series of the baseline at its best node.
    let residuals = {
        let q = &base.result;
        ResidualAnalysis::new(problem.pv, &q.pv_pred, &q.pv_sim, &q.mv_est, q.split_index)
    };
    let own_cycle = causes::OwnCycle::default();
    let ctx = Context {
        problem,
        span,
        baseline_spec: baseline,
        baseline: &base,
        residuals: &residuals,
        options,
        own_cycle: &own_cycle,
    };
    let base_fit = base.fit_val();
    let (bs, bj) = (base.result.s, base.result.j);
    let mut findings = Vec::new();
    let mut overriding = Vec::new();
    let mut done = 1;
    // a reframed diagnosis tests no other cause (see `Cause::reframe`)
    let testable = if reframed.is_some() {
        &[][..]
    } else {
        &known[..]
    };
    // the causes are independent of each other here: tested at once (their local searches
    // evaluate a few nodes at a time and would leave a core idle)
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
            cause
                .applies(&ctx)
                .then(|| test_cause(&ctx, cause.as_ref(), entry.name, base_fit, (bs, bj)))
        })
        .collect();
    for (finding, overrides) in tested {
        if overrides {
            overriding.push(finding.cause);
        }
        findings.push(finding);
    }
    // `no-stiction` is judged against the significant extensions, not against the baseline:
    // an unmodelled dead time or disturbance can make the baseline's stiction look
    // dispensable (or indispensable). Each extension's own grid contains the linear-valve node
    // (all parameters 0), so the test costs no extra fit. It must hold against every one of
    // them (the largest cost decides): a valve is not healthy because one explanation does
    // without its stiction while another significant one needs it (measured: suite loop 1177,
    // a sine and 6 samples of dead time, S = 3.4: with the sine notched out, the valve without
    // stiction cost LR 0.9; with the dead time modelled it was sticky, S = 4.7).
    let n_val = (problem.op.len() - base.result.split_index) as f64;
    let best_extension = findings
        .iter()
        .filter(|f| f.significant && f.cause != "no-stiction")
        .filter_map(|f| f.fitted.as_ref().map(|x| (f.cause, x)))
        .filter_map(|(cause, x)| {
            let fb = x.fit_val();
            x.result.fit_no_stiction.map(|f0| {
                let cost =
                    n_val * ((1.0 - f0 / 100.0).max(1e-300) / (1.0 - fb / 100.0).max(1e-300)).ln();
                (cause, cost)
            })
        })
        .max_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((cause, cost)) = best_extension {
        let holds = cost < options.lr_no_stiction;
        for f in findings.iter_mut().filter(|f| f.cause == "no-stiction") {
            f.lr = -cost;
            f.threshold = -options.lr_no_stiction;
            f.significant = holds;
            f.reference = format!("the {cause} extension");
            f.evidence = format!(
                "{} After accounting for {cause}, a valve without stiction costs LR {cost:.1} (holds when < {:.2}).",
                f.evidence, options.lr_no_stiction
            );
        }
        overriding.retain(|c| *c != "no-stiction");
        if holds {
            overriding.push("no-stiction");
        }
    }
    // Order: significant overriding causes, then significant by margin, then the rest by margin.
    let margin = |f: &Finding| {
        if f.lr.is_finite() && f.threshold.is_finite() {
            f.lr - f.threshold
        } else if f.lr.is_finite() {
            f.lr
        } else {
            f64::NEG_INFINITY
        }
    };
    findings.sort_by(|a, b| {
        let ka = (overriding.contains(&a.cause), a.significant);
        let kb = (overriding.contains(&b.cause), b.significant);
        kb.cmp(&ka).then(margin(b).total_cmp(&margin(a)))
    });
    let mut chosen = findings.first().filter(|f| f.significant).map(|_| 0);
    // Forward selection: on the chosen extension, test the causes not chosen yet; add the one
    // with the largest significant gain; repeat until none is significant. Each step's model
    // carries every extension chosen before it (its stiction model, identifier and dead
    // time), so the last is the joint model. Two starts when the runner-up of the first
    // round is significant too (extensions do not commute: EARX at a scanned dead time is
    // not the scan of EARX's dead time): the runner-up's path wins only when its final model
    // fits the validation data significantly better (LR over `lr_base`), never for naming
    // more causes.
    let fc = ForwardCtx {
        problem,
        span,
        baseline,
        options,
        own_cycle: &own_cycle,
    };
    let mut path = Path::default();
    if let Some(i) = chosen.filter(|&i| findings[i].cause != "no-stiction") {
        let runner_up = findings
            .iter()
            .enumerate()
            .skip(1)
            .find(|(_, f)| f.significant && f.cause != "no-stiction" && f.fitted.is_some())
            .map(|(k, _)| k)
            .filter(|_| !overriding.contains(&"no-stiction"));
        // the two starts are independent: run at once (their local searches evaluate a few
        // nodes at a time and leave a core idle; the grids share the pool)
        let (first, second) = rayon::join(
            || fc.forward(&findings[i], &tell, done, None),
            || runner_up.map(|k| fc.forward(&findings[k], &tell, done, None)),
        );
        path = first?;
        if let (Some(k), Some(other)) = (runner_up, second) {
            let other = other?;
            let fit = |p: &Path, start: usize| {
                p.final_fit()
                    .or(findings[start].fitted.as_ref())
                    .map_or(f64::NEG_INFINITY, Fitted::fit_val)
            };
            // the other path replaces the best first cause only when its final model is
            // significantly better (the LR between the two final models over `lr_base`)
            let n_val = (problem.op.len() - base.result.split_index) as f64;
            let sse = |f: f64| (1.0 - f / 100.0).max(1e-12);
            let lr = n_val * (sse(fit(&path, i)) / sse(fit(&other, k))).ln();
            if lr > options.lr_base {
                path = other;
                chosen = Some(k);
            }
        }
        // Two causes that mask each other: a cause that gained on the baseline but not enough
        // (a dead time part of which a disturbance absorbs, and the other way round; a dead
        // time under an asymmetric valve) is a start too. On its extension the selected
        // path's first cause is tested alone; the pair replaces the selected path when its
        // model gains significantly over that first cause's extension alone (one extra
        // parameter) and its path's final model fits no worse. Judging the whole path
        // instead named a third cause's gain as a pair (docs/DIAGNOSE.md, item 5).
        let first = path.causes.first().copied();
        if let Some(first) = first.filter(|_| {
            !options.disabled.iter().any(|d| d == PAIRS) && !overriding.contains(&"no-stiction")
        }) {
            let held = path.causes.clone();
            let masked: Vec<usize> = findings
                .iter()
                .enumerate()
                .filter(|(k, f)| {
                    Some(*k) != chosen
                        && !f.significant
                        && f.cause != "no-stiction"
                        && f.fitted.is_some()
                        && f.lr > 0.0
                        && !held.contains(&f.cause)
                })
                .map(|(k, _)| k)
                .collect();
            let others: Vec<(usize, Result<Path, DiagnoseError>)> = masked
                .into_par_iter()
                .map(|k| (k, fc.forward(&findings[k], &tell, done, Some(first))))
                .collect();
            let n_val = (problem.op.len() - base.result.split_index) as f64;
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
                // significant over the first cause alone (over the start alone: the step
                // that added the first cause was significant), and its path's final model
                // no worse than the selected path's
                let lr = lr_of(n_val, alone, pair.fit_val());
                if lr > options.threshold(1)
                    && fit_of(&other, k) >= current
                    && best.as_ref().is_none_or(|b| lr > b.1)
                {
                    best = Some((k, lr, other));
                }
            }
            if let Some((k, lr, other)) = best {
                let f = &mut findings[k];
                f.significant = true;
                f.evidence = format!(
                    "{} Named as a pair: alone it gains likelihood ratio {:.0} (threshold {:.0}); with {first} on top, the pair's model gains likelihood ratio {lr:.0} over {first}'s alone (threshold {:.0}).",
                    f.evidence,
                    f.lr,
                    f.threshold,
                    options.threshold(1)
                );
                path = other;
                chosen = Some(k);
            }
        }
    }
    let Path {
        mut causes,
        mut steps,
        mut picks,
    } = path;
    if causes.is_empty() {
        // `no-stiction` (no forward selection after it)
        causes.extend(chosen.map(|i| findings[i].cause));
    }
    // The final model at the orders the data support (item 12): refitted before the open set,
    // which then asks what the best model leaves (a misfit of the given orders is not a
    // change of the process).
    let healthy = chosen.is_some_and(|i| findings[i].cause == "no-stiction");
    let selected_chain: Vec<&'static str> = causes.clone();
    let selected_before = selected_model(&picks, &steps, chosen, &findings);
    let refit = |chain: &[&'static str], from: Option<usize>| {
        refit_final(
            problem, span, baseline, &base, chain, from, options, &own_cycle,
        )
    };
    let (pre_refit, pre_selection) = if healthy {
        (None, None)
    } else {
        refit(&selected_chain, None)
    };
    // the open set: what the final model leaves that no registered cause explains
    let mut open = None;
    if reframed.is_none() && !options.disabled.iter().any(|d| d == UNEXPLAINED) {
        let last = selected_before.unwrap_or(&base);
        let last = pre_refit
            .as_ref()
            .filter(|r| r.fit_val() > last.fit_val())
            .unwrap_or(last);
        open = open_set(problem, last, options);
    }
    // A change the chosen causes absorbed: the open set is not significant on the final model
    // but is on the baseline. The chosen causes are then re-tested on the changed process in
    // the same way; the change is named only if they drop and it shows on what remains.
    // ... or on the model of a cause the first round found significant and the selection did
    // not choose (`stretches::change_on_causes`)
    let mut seen = if open.as_ref().is_some_and(|f| !f.significant) {
        stretches::change_on_causes(problem, &findings, &causes, options)
    } else {
        None
    };
    let changed = open.as_ref().is_some_and(|f| f.significant)
        || seen.is_some()
        || (open.is_some()
            && chosen.is_some_and(|i| findings[i].cause != "no-stiction")
            && open_set(problem, &base, options).is_some_and(|f| f.significant));
    // Each cause on its own evidence (see `stretches`): the change located, every cause tested
    // again on each stationary stretch alone; a cause of the forward selection that gains on
    // no stretch gained from the change and is dropped. When the change was seen on the baseline only (the chosen causes absorbed it),
    // the drops stand only if it is significant on the model that remains (the open set is
    // tested again on it).
    let mut stretch_check = None;
    if changed {
        // located on the baseline (its linear part is fitted once per candidate sample)
        if let Some(mut check) = stretches::retest(problem, span, baseline, &base, options) {
            let chain = causes.clone();
            check.chosen_on_record = chain.clone();
            let prefix = chain.iter().take_while(|c| check.holds(c)).count();
            // a cause is named where it gains on a stretch; a cause the whole record did not
            // choose is not named for a gain on a stretch alone (measured on the suite's
            // process-change loops: short stretches before the change gave `disturbance` LR
            // 46-100 on loops with no disturbance, docs/decisions/2026-11-27-stretches.md)
            let kept: Vec<&'static str> =
                chain.iter().copied().filter(|c| check.holds(c)).collect();
            let first_round = chosen.filter(|&i| findings[i].cause != "no-stiction");
            let again = if kept == chain {
                None
            } else {
                // the forward selection's model of the causes that hold, in its order
                let remaining = match (first_round, prefix) {
                    (None, _) | (_, 0) => None,
                    (Some(i), 1) => findings[i].fitted.as_ref(),
                    (Some(_), k) => steps[k - 2][picks[k - 2]].fitted.as_ref(),
                };
                open_set(problem, remaining.unwrap_or(&base), options)
                    .filter(|f| f.significant)
                    .map(Some)
                    // named on the final model already: the change stands as found there
                    .or_else(|| open.as_ref().is_some_and(|f| f.significant).then_some(None))
                    // seen on a competing cause's model only: where the open set can see it,
                    // before the validation window (see `stretches::change_on_causes`)
                    .or_else(|| {
                        seen.take()
                            .filter(|_| check.change_at < base.result.split_index)
                            .map(Some)
                    })
            };
            if kept == chain {
                if open.as_ref().is_some_and(|f| f.significant) {
                    stretch_check = Some(check);
                }
            } else if let Some(again) = again {
                {
                    let at = check.change_at;
                    let spans = check
                        .stretches
                        .iter()
                        .map(|s| format!("samples {}-{}", s[0], s[1]))
                        .collect::<Vec<_>>()
                        .join(" and ");
                    for (k, c) in chain.iter().enumerate() {
                        if check.holds(c) {
                            continue;
                        }
                        let f = match (k, chosen) {
                            (0, Some(i)) => &mut findings[i],
                            (0, None) => continue,
                            (k, _) => &mut steps[k - 1][picks[k - 1]],
                        };
                        f.significant = false;
                        f.evidence = format!(
                            "{} Not named: the process changed during the record (unexplained, located at sample {at}), and on its stationary stretches alone ({spans}) the extension gains nothing significant: its gain on the whole record came from the change.",
                            f.evidence
                        );
                    }
                    // the steps that held, and the step that picked the first dropped cause
                    // with that pick marked
                    let held_steps = if first_round.is_some() { prefix } else { 0 };
                    picks.truncate(held_steps.saturating_sub(1));
                    steps.truncate(held_steps);
                    if held_steps == 0 {
                        picks.clear();
                        steps.clear();
                    }
                    causes = kept;
                    chosen = causes
                        .first()
                        .and_then(|c| findings.iter().position(|f| f.cause == *c));
                }
                if let Some(again) = again {
                    open = Some(again);
                }
                stretch_check = Some(check);
            }
        }
    }
    let mut cause = chosen.map_or("none".to_string(), |i| findings[i].cause.to_string());
    // the final model: the last step's pick, else the first cause's extension
    let final_fit = selected_model(&picks, &steps, chosen, &findings);
    // the final model refitted after a change of the process, and at raised orders when they
    // gain (not for a valve found healthy: its S is negligible by definition)
    let changed_from = open
        .as_ref()
        .filter(|f| f.significant)
        .and_then(|f| f.window_from);
    // the refit is on the samples after the change: the causes that hold there
    let chain: Vec<&'static str> = causes
        .iter()
        .copied()
        .filter(|c| *c != UNEXPLAINED)
        .filter(|c| stretch_check.as_ref().is_none_or(|s| s.holds_now(c)))
        .collect();
    let (refined, order_selection) = if cause == "no-stiction" {
        (None, None)
    } else if changed_from.is_none() && chain == selected_chain {
        (pre_refit, pre_selection)
    } else {
        refit(&chain, changed_from)
    };
    // The refit replaces the selected model only when it predicts the validation window (the
    // same samples: after a change too) better. Measured: on the suite's 20 process-change
    // loops with a significant change every refit after the change validated better; on the
    // plant's short registrations five of ten did not, with S collapsing from 1.6-2.2 % to
    // 0.04-0.9 % on the sticky valve (docs/DIAGNOSE.md item 12).
    let selected = final_fit.unwrap_or(&base);
    let mut declined = None;
    let refined = match refined {
        Some(r) if r.fit_val() <= selected.fit_val() => {
            declined = Some((r.fit_val(), selected.fit_val(), r.result.s));
            None
        }
        other => other,
    };
    let final_fit = refined.as_ref().or(final_fit);
    let gain = final_fit.map_or(0.0, |f| f.fit_val() - base_fit);
    let mut summary = summarise(&base, &residuals, &findings, chosen);
    for (n, &k) in picks.iter().enumerate() {
        let f = &steps[n][k];
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
    if let Some(f) = open {
        if f.significant {
            causes.push(UNEXPLAINED);
            if cause == "none" {
                cause = UNEXPLAINED.to_string();
                // the baseline's "Cause: none" paragraph follows the finding
                summary = format!("{} {summary}", f.evidence);
            } else {
                summary = format!("{summary} {}", f.evidence);
            }
            if let Some(check) = &stretch_check {
                summary = format!("{summary} {}", check.describe());
            }
        }
        findings.push(f);
    }
    if let Some((refit, kept, s_refit)) = declined {
        let window = changed_from.map_or(String::new(), |k| {
            format!(
                " on samples {k}-{} alone (after the change)",
                problem.op.len()
            )
        });
        let orders = order_selection
            .as_ref()
            .filter(|o| o.raised)
            .map_or(String::new(), |o| {
                format!(" with the linear orders {}", o.to)
            });
        summary = format!(
            "{summary} Refitted{window}{orders}, the final model (S = {s_refit:.2} %) predicts the validation data worse (F_PV {refit:.2} % against {kept:.2} %): the selected model stands."
        );
    }
    if let Some(f) = &refined {
        let e = f.summary();
        let orders = order_selection.as_ref().filter(|o| o.raised).map_or(String::new(), |o| {
            format!(
                " with the linear orders {} instead of {} (they explain validation PV significantly better: likelihood ratio {:.0}, threshold {:.0})",
                o.to, o.from, o.lr, o.threshold
            )
        });
        let window = changed_from.map_or(String::new(), |k| {
            format!(
                " on samples {k}-{} alone (after the change)",
                problem.op.len()
            )
        });
        summary = format!(
            "{summary} The final model refitted{window}{orders}: S = {:.2} %, J = {:.2} %.",
            e.s, e.j
        );
    }
    if let Some((name, ev, _, _)) = reframed {
        let finding = reframed_finding(problem, original_baseline, original, &base, name, ev)?;
        summary = format!("{} {summary}", finding.evidence);
        findings.insert(0, finding);
        chosen = chosen.map(|i| i + 1);
        causes.insert(0, name);
        cause = name.to_string();
    }
    Ok(Diagnosis {
        baseline: base.summary(),
        baseline_fit: base,
        residuals,
        cause,
        causes: causes.iter().map(|c| c.to_string()).collect(),
        chosen,
        findings,
        steps,
        picks,
        gain_fit_pv_val: gain,
        refined,
        order_selection,
        stretches: stretch_check,
        summary,
        elapsed_ms: started.elapsed().as_secs_f64() * 1e3,
    })
}

/// The forward selection's model: the last step's pick, else the chosen first cause's
/// extension (`None`: the baseline).
fn selected_model<'a>(
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

/// What the forward selection needs from a diagnosis.
struct ForwardCtx<'a> {
    problem: Problem<'a>,
    span: f64,
    baseline: &'a Baseline,
    options: &'a DiagnoseOptions,
    own_cycle: &'a causes::OwnCycle,
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

impl ForwardCtx<'_> {
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
            let current = match (steps.last(), picks.last()) {
                (Some(step), Some(&k)) => step[k].fitted.as_ref(),
                _ => start.fitted.as_ref(),
            };
            let Some(current) = current else { break };
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
                ResidualAnalysis::new(problem.pv, &q.pv_pred, &q.pv_sim, &q.mv_est, q.split_index);
            let ctx = Context {
                problem,
                span,
                baseline_spec: &spec,
                baseline: current,
                residuals: &res,
                options,
                own_cycle: self.own_cycle,
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
                    // `no-stiction` is a finding about the first round, not an extension
                    || entry.name == "no-stiction"
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
/// Returns the finding and whether it is a significant overriding cause (`no-stiction`).
fn test_cause(
    ctx: &Context<'_>,
    cause: &dyn Cause,
    name: &'static str,
    base_fit: f64,
    (bs, bj): (f64, f64),
) -> (Finding, bool) {
    let ev = cause.evidence(ctx);
    let options = ctx.options;
    let mut overrides = false;
    let finding = match cause.extend(ctx) {
        Ok(ext) => {
            let (threshold, significant) = if cause.overrides() {
                // Removing parameters: significant when the loss is small.
                (-options.lr_no_stiction, ext.lr > -options.lr_no_stiction)
            } else {
                let t = options.threshold(ext.extra_params);
                (t, ext.lr > t)
            };
            overrides = significant && cause.overrides();
            let s = ext.fitted.summary();
            Finding {
                cause: name,
                evidence: ev.text,
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
                window_from: None,
            }
        }
        Err(e) => Finding {
            cause: name,
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
            window_from: None,
        },
    };
    (finding, overrides)
}

/// The name of the open-set finding (`open_set`): structure the final model leaves that no
/// registered cause explains. Not a plugin: it names no extension.
pub const UNEXPLAINED: &str = "unexplained";

/// The name that disables the search for two causes that mask each other (the forward
/// selection started from a cause that gained on the baseline below its threshold, see
/// `diagnose`); like [`UNEXPLAINED`], not a plugin.
pub const PAIRS: &str = "pairs";

/// The number of coefficients of a fitted linear model (A, B, C; state space: A, B, C, K).
fn coefficients(fit: &linear_id::LinearFit) -> usize {
    match fit.structure() {
        linear_id::Structure::Polynomial { a, b, c, .. } => a.len() - 1 + b.len() + c.len() - 1,
        linear_id::Structure::StateSpace { a, .. } => {
            let n = a.len();
            n * n + 3 * n
        }
    }
}

/// The open-set check on the final model `last`: is something left that no registered cause
/// explains?
///
/// The decision is a gain on validation data, as for every cause. The final model's linear
/// part (same orders and dead time, same valve) is identified twice: on the whole
/// identification window `[0, N_id)`, and on its last third alone (`[max(k₀, 2N_id/3), N_id)`,
/// `k₀` the sample from which the valve's In.3 estimate holds). Their one-step predictions of
/// the validation window give `LR = n_val · ln(SSE_whole / SSE_recent)`, judged against the
/// threshold for as many parameters as the refit re-estimates (ARX(2,2): 4, threshold 50).
/// With a process that does not change, the recent window's model is the same model with a
/// third of the data and predicts worse (LR below 0 on most loops).
///
/// *Why the whole window from sample 0 and not from `k₀`.* Before `k₀` the valve's position
/// depends on its unknown initial state, and the grid search ranks nodes by their validation
/// fit with each node's own `k₀`: when the process changes, the winning valve is one whose
/// estimate starts after the change (measured on the suite's process-change loops: `k₀` 640-995
/// for changes at 600-984, against 2-277 on clean loops), so a window from `k₀` holds no change
/// to find. The whole-window fit therefore runs the final valve from each of its four initial
/// states (at rest or moving, last motion up or down: In.3's four starts) and keeps the one
/// that predicts the validation data best, so that an unlucky initial state does not pass for
/// a changed process. Measured (`cargo run --release -p discrepancy --example probe -- 24`,
/// docs/decisions/2026-11-26-diagnose-logbook.md item 6 has the table).
///
/// Residual whiteness, the correlation with past MV and the low-frequency power are reported
/// with the finding but do not decide: the paper's ARX(2,2) leaves coloured residuals on clean
/// loops (Ljung-Box Q 98-215 against the limit 38 on the clean loops above), and an ARX with
/// two more lags each gains LR 20-130 on clean loops as on loops with an unmodelled lag, so
/// neither separates "something else" from the model's ordinary misfit.
fn open_set(problem: Problem<'_>, last: &Fitted, options: &DiagnoseOptions) -> Option<Finding> {
    use stiction_models::{Direction, InitialState, Initialization};
    let q = &last.result;
    let (pv, mv) = (problem.pv, &q.mv_est);
    let (ni, n) = (q.split_index, pv.len());
    // the recent window, not before the valve's estimate holds (`k₀`): from a third, half or
    // two thirds of the identification window, the one that predicts validation best (after
    // an early change the longer window holds only the new process; docs/DIAGNOSE.md item 10)
    let (from, recent, s_recent) = [ni / 3, ni / 2, 2 * ni / 3]
        .into_iter()
        .filter_map(|f| recent_fit(pv, last, f))
        .min_by(|a, b| a.2.total_cmp(&b.2))?;
    let sse = |est: &[f64]| -> f64 {
        est.iter()
            .zip(&pv[ni..])
            .map(|(e, y)| (e - y) * (e - y))
            .sum()
    };
    let starts = [Direction::Up, Direction::Down]
        .into_iter()
        .flat_map(|direction| {
            [true, false].map(|stuck| InitialState {
                direction,
                stuck,
                stuck_at: None,
                position: None,
            })
        });
    // OP on a lattice: the valve from its best initial state and, as well, with its
    // thresholds moved by up to one quantisation step (see `rounding_band`)
    let mut valves = vec![q.stiction.box_clone()];
    if let Some(step) = op_step(problem.op) {
        let params = q.stiction.param_values();
        valves.extend(
            rounding_band(last.stiction, &params, step, span_of(problem.op))
                .iter()
                .filter_map(|p| (last.stiction.build)(p).ok()),
        );
    }
    let runs: Vec<(&dyn stiction_models::StictionModel, InitialState)> = valves
        .iter()
        .flat_map(|v| starts.clone().map(move |s| (v.as_ref(), s)))
        .collect();
    let s_whole = runs
        .into_par_iter()
        .filter_map(|(valve, state)| {
            let run =
                stiction_models::run_valve(valve, problem.op, &Initialization::In1(state)).ok()?;
            let fit = last.identifier.identify(&run.mv[..ni], &pv[..ni]).ok()?;
            let p = fit.predict_one_step(&run.mv, pv).ok()?;
            Some(sse(&p[ni..]))
        })
        .filter(|s| s.is_finite())
        .min_by(f64::total_cmp)?;
    if !(s_whole.is_finite() && s_recent.is_finite() && s_recent > 0.0) {
        return None;
    }
    let lr = (n - ni) as f64 * (s_whole / s_recent).ln();
    let d = coefficients(&recent) as i32;
    let threshold = options.threshold(d);
    let significant = lr > threshold;
    let res = ResidualAnalysis::new(pv, &q.pv_pred, &q.pv_sim, mv, ni);
    let evidence = if significant {
        format!(
            "Cause: unexplained. Something no registered cause explains remains: the final model's linear part identified on the recent part of the identification window alone (samples {from}-{ni}) predicts the validation data better than identified on the whole window (samples 0-{ni}, the valve from its best initial state; likelihood ratio {lr:.0}, threshold {threshold:.0} for {d} re-estimated coefficients): the process changed during the record (its gain, dynamics or operating point). In the final model, {}",
            res.describe().replacen("On the", "on the", 1)
        )
    } else {
        format!(
            "The final model identified on the recent part of its identification window (samples {from}-{ni}) does not predict the validation data significantly better than identified on the whole window (samples 0-{ni}; likelihood ratio {lr:.0}, threshold {threshold:.0}): no sign of a process that changed during the record."
        )
    };
    Some(Finding {
        cause: UNEXPLAINED,
        evidence,
        statistic: lr,
        extended: None,
        fitted: None,
        gain_fit_pv_val: f64::NAN,
        delta_s: f64::NAN,
        delta_j: f64::NAN,
        lr,
        threshold,
        reference: "the final model".into(),
        significant,
        error: None,
        window_from: Some(from),
    })
}

/// OP's quantisation step (`datasets::quantisation::step`), `None` when OP is not on a
/// lattice: what the thresholds of `asymmetric-stiction` and of the open set allow for.
pub fn op_step(op: &[f64]) -> Option<f64> {
    datasets::quantisation::step(op)
}

/// The valves whose parameters in OP units (`ParamSpec::max_span_fraction` > 0) are each
/// `params`' moved by `-step`, `-step/2`, 0, `+step/2` or `+step`, all but `params` itself
/// (admissible ones only): the band sampled at half its width.
///
/// OP written on a lattice of step `q` (counts, fixed decimals): every threshold a valve model
/// compares, `±(u - u_s)` against S or J, is off by up to `q` (two rounded values), so a slip
/// whose true excursion lies within `q` of its threshold falls on either side of it, and the
/// valve simulated from the record misses or invents that slip for as long as the valve then
/// stays stuck (measured: a Kano S = 4, J = 1 loop with OP in 14-bit counts, three such
/// episodes of 23-118 samples with MV off by up to J). Valves this close are the same valve
/// for this record. The open set gives the whole window the best of them, as it gives it the
/// valve's best initial state: an early missed slip does not pass for a changed process.
/// Measured on the suite's clean loops 0-15 (`cargo run --release -p discrepancy --example
/// quantisation -- 16`): `unexplained` named with OP in 14-bit counts, 12-bit counts, to 0.1 %
/// on 1, 1, 2 loops without the band; 0, 0, 1 with the band at `±q`; 0, 0, 0 sampled at half
/// steps. Process-change loops 0-11: `unexplained` among the causes on 10, 10, 11, 12 (as
/// simulated, 14-bit, 12-bit, 0.1 %).
fn rounding_band(
    entry: &'static ModelEntry,
    params: &[f64],
    step: f64,
    span: f64,
) -> Vec<Vec<f64>> {
    let mut out: Vec<Vec<f64>> = vec![params.to_vec()];
    for (i, spec) in entry.params.iter().enumerate().take(params.len()) {
        if spec.max_span_fraction <= 0.0 {
            continue;
        }
        out = out
            .into_iter()
            .flat_map(|p| {
                [-step, -step / 2.0, 0.0, step / 2.0, step].map(|d| {
                    let mut p = p.clone();
                    p[i] += d;
                    p
                })
            })
            .collect();
    }
    out.retain(|p| p != params && p.iter().all(|v| *v >= 0.0) && entry.admissible(p, span));
    out
}

/// `m`'s linear part identified on `[max(k₀, from), N_id)` alone (its own estimated MV, orders
/// and dead time): that window's first sample, the fit, and the validation SSE of its one-step
/// predictions (`None` when the window is too short, the fit fails or the SSE is not finite).
fn recent_fit(pv: &[f64], m: &Fitted, from: usize) -> Option<(usize, linear_id::LinearFit, f64)> {
    let q = &m.result;
    let (mv, ni) = (&q.mv_est, q.split_index);
    let from = q.fits.valid_from.max(from);
    if ni >= pv.len() || ni.saturating_sub(from) < m.identifier.min_samples() {
        return None;
    }
    let fit = m.identifier.identify(&mv[from..ni], &pv[from..ni]).ok()?;
    let p = fit.predict_one_step(&mv[from..], &pv[from..]).ok()?;
    let sse: f64 = p[ni - from..]
        .iter()
        .zip(&pv[ni..])
        .map(|(e, y)| (e - y) * (e - y))
        .sum();
    sse.is_finite().then_some((from, fit, sse))
}

/// The finding of a cause that reframed the diagnosis ([`Cause::reframe`]): the baseline
/// under the caller's search options (e.g. ranked by one-step prediction) against the
/// reframed baseline `base`, compared by the reframed criterion's validation fit.
fn reframed_finding(
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
        Some(i) if findings[i].cause == "no-stiction" => {
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

/// The one line to act on: the cause and the model to use, with its S and J.
pub fn action_line(dg: &Diagnosis) -> String {
    let chosen = dg.chosen.and_then(|i| dg.findings.get(i));
    match chosen {
        Some(f) if f.cause == "no-stiction" => format!(
            "no-stiction: the oscillation is not the valve's (a valve with negligible stiction{} explains PV as well); look elsewhere",
            f.extended
                .as_ref()
                .map_or(String::new(), |e| format!(", fitted S = {:.2} %,", e.s))
        ),
        Some(f) => match dg.final_fit().map(Fitted::summary) {
            Some(e) => format!(
                "{}: use {} + {} (dead time {}): S = {:.2} %, J = {:.2} % (validation F_PV {:+.2} points over the baseline)",
                dg.causes.join(" + "),
                e.stiction_model,
                e.linear_model,
                e.delay,
                e.s,
                e.j,
                dg.gain_fit_pv_val
            ),
            None => f.cause.to_string(),
        },
        None if dg.cause == UNEXPLAINED => format!(
            "unexplained: something no registered cause explains remains (see the summary); the baseline S = {:.2} %, J = {:.2} % with caution",
            dg.baseline.s, dg.baseline.j
        ),
        // a cause in the data named alone (`Cause::reframe`): the baseline with its warning
        None if dg.cause != "none" => format!(
            "{}: the baseline S = {:.2} %, J = {:.2} % with caution (no other cause tested); see the summary",
            dg.cause, dg.baseline.s, dg.baseline.j
        ),
        None => format!(
            "none: the baseline stands, S = {:.2} %, J = {:.2} %",
            dg.baseline.s, dg.baseline.j
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
