//! The diagnosis framework: what a cause is ([`Cause`], its [`Role`] and its registry entry
//! [`CauseEntry`]), what it may look at ([`Context`]) and what it returns ([`Evidence`],
//! [`Extension`], [`Reframe`]).

use std::fmt;

use grid_search::{Problem, SearchOptions};
use linear_id::IdentifierEntry;
use serde::Serialize;
use stiction_models::ModelEntry;

use crate::{
    causes, Baseline, Combination, DiagnoseError, DiagnoseOptions, Fitted, ResidualAnalysis,
};

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
    /// The record as the extended model sees it, when the extension transformed the data
    /// before the fit (`None`: the record itself).
    pub data: Option<Transformed>,
}

/// The record as an extension's model sees it when the extension transformed the data
/// before the fit (e.g. `travel-limit`: OP clipped at the fitted limit). PV's validation
/// samples stay the record's: every likelihood ratio compares predictions of them. The
/// forward selection tests the causes after it on these data, the open set runs the model's
/// valve on them, the final refit extends again from the record.
#[derive(Debug, Clone)]
pub struct Transformed {
    /// OP as the model sees it.
    pub op: Vec<f64>,
    /// PV as the model sees it.
    pub pv: Vec<f64>,
    /// The measured MV, if any.
    pub mv: Option<Vec<f64>>,
    /// What was done, in words (with the fitted values).
    pub what: String,
}

impl Transformed {
    /// The transformed record as a search problem.
    pub fn problem(&self) -> Problem<'_> {
        Problem {
            op: &self.op,
            pv: &self.pv,
            mv: self.mv.as_deref(),
        }
    }
}

/// The record `fitted`'s model sees: `data` when given, else `record`.
pub(crate) fn seen<'a>(record: Problem<'a>, data: Option<&'a Transformed>) -> Problem<'a> {
    data.map_or(record, Transformed::problem)
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

    /// The baseline's linear model (its registry entry) and its identifier at the baseline's
    /// dead time, for the valve model `stiction` (a cause's local search of another valve
    /// around the baseline's).
    pub fn identifier_with(
        &self,
        stiction: &'static ModelEntry,
    ) -> Result<
        (
            &'static IdentifierEntry,
            Box<dyn linear_id::LinearIdentifier>,
        ),
        DiagnoseError,
    > {
        let linear = linear_id::find_identifier(self.baseline.linear)?;
        let delay = self.baseline.delay;
        let identifier = self
            .combination(stiction, linear, delay)
            .identifier(delay)?;
        Ok((linear, identifier))
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
pub(crate) fn diagnosis_combination(
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

/// `n_val · ln(SSE_a / SSE_b)` from two validation fits in % (same window, same PV).
pub(crate) fn lr_of(n_val: f64, fit_a: f64, fit_b: f64) -> f64 {
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
    /// How the diagnosis uses the cause.
    pub role: Role,
    /// One line: what the cause is and which extension accounts for it.
    pub description: &'static str,
    /// What the detection statistic measures.
    pub statistic: &'static str,
    /// Build the cause.
    pub build: fn() -> Box<dyn Cause>,
}

inventory::collect!(CauseEntry);

/// How the diagnosis uses a cause: which of [`Cause`]'s methods it calls, and how a
/// significant finding is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Role {
    /// An extended model that accounts for the cause ([`Cause::extend`]: another stiction
    /// model, identifier or dead time, or the data transformed before the fit), chosen when it
    /// gains significantly on validation data; the forward selection adds several.
    Extension,
    /// The null hypothesis about the valve (`no-stiction`): its "extension" removes
    /// parameters and holds when that costs less than [`DiagnoseOptions::lr_no_stiction`]
    /// against every significant extension. When it holds it is the finding: reported ahead
    /// of the others, no forward selection, no refit.
    NullHypothesis,
    /// A property of the data that changes how every model is compared (`compression`,
    /// [`Cause::reframe`]): named first, no other cause tested.
    Reframe,
    /// What the final model leaves that no registered cause explains ([`UNEXPLAINED`]): not a
    /// plugin, the diagnosis's own last test.
    OpenSet,
}

impl Role {
    /// The role in words (the help's cause table).
    pub fn label(self) -> &'static str {
        match self {
            Role::Extension => "extension",
            Role::NullHypothesis => "null hypothesis",
            Role::Reframe => "reframe",
            Role::OpenSet => "open set",
        }
    }

    /// Whether a cause of this role is tested as an extension (first round, forward
    /// selection, stretches).
    pub fn is_tested(self) -> bool {
        matches!(self, Role::Extension | Role::NullHypothesis)
    }
}

/// The role registered for `name` ([`Role::OpenSet`] for [`UNEXPLAINED`], [`Role::Extension`]
/// for a name not registered).
pub(crate) fn role_of(name: &str) -> Role {
    if name == UNEXPLAINED {
        return Role::OpenSet;
    }
    inventory::iter::<CauseEntry>
        .into_iter()
        .find(|e| e.name == name)
        .map_or(Role::Extension, |e| e.role)
}

/// One line of the cause table: name, role, what it is and how it is accounted for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct CauseRow {
    /// The cause's name.
    pub name: &'static str,
    /// Its role.
    pub role: Role,
    /// One line: what the cause is and which extension accounts for it.
    pub description: &'static str,
}

/// The causes a diagnosis can name: every registered cause (by name) and the open set's
/// [`UNEXPLAINED`] last: `diagnose --help` prints this table.
pub fn cause_table() -> Vec<CauseRow> {
    let mut rows: Vec<CauseRow> = registry()
        .into_iter()
        .map(|e| CauseRow {
            name: e.name,
            role: e.role,
            description: e.description,
        })
        .collect();
    rows.push(CauseRow {
        name: UNEXPLAINED,
        role: Role::OpenSet,
        description: "the process changed during the record: the final model identified on a recent part of its identification window predicts validation data better",
    });
    rows
}

/// Every registered cause, sorted by name.
pub fn registry() -> Vec<&'static CauseEntry> {
    let mut v: Vec<_> = inventory::iter::<CauseEntry>.into_iter().collect();
    v.sort_by_key(|e| e.name);
    v
}

/// OP's quantisation step (`datasets::quantisation::step`), `None` when OP is not on a
/// lattice: what the thresholds of `asymmetric-stiction` and of the open set allow for.
pub fn op_step(op: &[f64]) -> Option<f64> {
    datasets::quantisation::step(op)
}

pub(crate) fn span_of(op: &[f64]) -> f64 {
    let (lo, hi) = op
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    hi - lo
}

/// The name of the open-set finding (`open_set`): structure the final model leaves that no
/// registered cause explains. Not a plugin: it names no extension.
pub const UNEXPLAINED: &str = "unexplained";

/// The name that disables the search for two causes that mask each other (the forward
/// selection started from a cause that gained on the baseline below its threshold, beside a
/// chosen first cause or, when none is significant, as a pair of weak causes; see
/// `diagnose`); like [`UNEXPLAINED`], not a plugin.
pub const PAIRS: &str = "pairs";

/// A cause named in `options.disabled` that no registered cause (nor [`UNEXPLAINED`] or
/// [`PAIRS`]) answers to.
pub(crate) fn check_disabled(
    known: &[&'static CauseEntry],
    options: &DiagnoseOptions,
) -> Result<(), DiagnoseError> {
    for d in &options.disabled {
        if !known.iter().any(|e| e.name == d) && d != UNEXPLAINED && d != PAIRS {
            return Err(DiagnoseError::UnknownCause {
                name: d.clone(),
                known: known.iter().map(|e| e.name).collect::<Vec<_>>().join(", "),
            });
        }
    }
    Ok(())
}

/// A diagnosis reframed by a cause in the data ([`Role::Reframe`]).
pub(crate) struct Reframed {
    /// The cause.
    pub name: &'static str,
    /// Its evidence.
    pub evidence: Evidence,
    /// The options the diagnosis runs with instead.
    pub options: DiagnoseOptions,
    /// The baseline it fits instead.
    pub baseline: Baseline,
}

/// The first cause of [`Role::Reframe`] (not disabled) that holds for `problem`, in the
/// registry's order.
pub(crate) fn reframe(
    problem: Problem<'_>,
    baseline: &Baseline,
    options: &DiagnoseOptions,
    known: &[&'static CauseEntry],
) -> Option<Reframed> {
    known
        .iter()
        .filter(|e| e.role == Role::Reframe && !options.disabled.iter().any(|d| d == e.name))
        .find_map(|entry| {
            let r = (entry.build)().reframe(problem, baseline, &options.search)?;
            Some(Reframed {
                name: entry.name,
                evidence: r.evidence,
                options: DiagnoseOptions {
                    search: r.search,
                    ..options.clone()
                },
                baseline: r.baseline,
            })
        })
}

/// The record and the settings one diagnosis runs with, shared by its phases.
pub(crate) struct Diagnoser<'a> {
    /// The loop.
    pub problem: Problem<'a>,
    /// OP's span.
    pub span: f64,
    /// The baseline specification (reframed when a cause in the data says so).
    pub baseline: &'a Baseline,
    /// The fitted baseline.
    pub base: &'a Fitted,
    /// The options (reframed likewise).
    pub options: &'a DiagnoseOptions,
    /// OP's own oscillation, computed once per record.
    pub own_cycle: &'a causes::OwnCycle,
}

impl<'a> Diagnoser<'a> {
    /// The context of a cause tested on the baseline.
    pub fn context(&self, residuals: &'a ResidualAnalysis) -> Context<'a> {
        Context {
            problem: self.problem,
            span: self.span,
            baseline_spec: self.baseline,
            baseline: self.base,
            residuals,
            options: self.options,
            own_cycle: self.own_cycle,
        }
    }

    /// Validation samples of the baseline.
    pub fn n_val(&self) -> f64 {
        (self.problem.op.len() - self.base.result.split_index) as f64
    }
}
