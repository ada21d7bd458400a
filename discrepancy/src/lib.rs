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
//! [`CauseEntry`] declaring its [`Role`]. The built-ins are `disturbance` (EARX/EARMAX), `asymmetric-stiction`
//! (`kano-asym`), `time-delay` (the dead time estimated), `valve-characteristic` (`kano-char`:
//! an installed flow characteristic after the valve), `no-stiction` (the oscillation is not
//! the valve's: S = J = 0 explains PV as well) and `compression` (PV read back from a
//! historian's compressed storage: named first, no other cause tested, [`Cause::reframe`]).
//! This crate does no IO.
//!
//! Modules: `framework` (the cause trait, its role, context, extension, registry), `options`
//! (the baseline and the options), `selection` (the first round and the forward selection),
//! `open_set` (`unexplained`), `stretches` (the causes re-tested after a change), `refit` (the
//! final refit), `summary` (findings, the diagnosis, its summary and record); the causes in
//! `causes/`, `characteristic.rs`, `compression.rs`; `eval` their local searches.

mod causes;
mod characteristic;
mod compression;
mod consensus;
mod eval;
mod framework;
mod headline;
mod open_set;
mod options;
mod refit;
pub mod registration;
mod residuals;
mod selection;
mod stretches;
mod summary;

use std::time::Instant;

use grid_search::Problem;

pub use run::{Combination, FitSummary, Fitted};

pub use causes::{AsymmetricStiction, Disturbance, NoStiction, TimeDelay, TravelLimit};
pub use characteristic::ValveCharacteristic;
pub use compression::Compression;
pub use consensus::{consensus, Consensus, Disagreement};
pub use headline::{in_unit, Headline, Standing, RANGE_SEEN_UNIT};
pub use residuals::{ResidualAnalysis, LOW_BAND, MAX_LAG};
pub use stretches::{gain_z, locate_change, StretchTest, Stretches, MIN_STRETCH, STRETCH_Z};

pub use framework::{
    cause_table, op_step, registry, Cause, CauseEntry, CauseRow, Context, Evidence, Extension,
    Reframe, Role, Transformed, PAIRS, UNEXPLAINED,
};
pub use options::{baseline, options_for, orders_without_delay, Baseline, DiagnoseOptions};
pub use refit::OrderSelection;
pub use summary::{action_line, Diagnosis, Finding};

// the paths the modules share
pub(crate) use framework::{diagnosis_combination, Diagnoser};
pub(crate) use selection::test_cause;

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
///
/// The phases: a cause in the data reframes the diagnosis (`framework::reframe`); the
/// baseline is fitted; every cause is tested on it (`Selection::first_round`); the forward
/// selection adds causes on the chosen extension (`Selection::select`); the final model is
/// refitted at the orders the data support (`Diagnoser::refit`); the open set asks what it
/// leaves (`open_set`), and after a change of the process the causes are tested again on
/// the stationary stretches (`Diagnoser::check_change`); the final refit
/// (`Diagnoser::final_refit`); the summary (`summary::Written`).
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
    framework::check_disabled(&known, options)?;
    // a cause in the data (compression) changes how every model is compared
    let reframed = framework::reframe(problem, baseline, options, &known);
    let (run_options, run_baseline) = reframed
        .as_ref()
        .map_or((options, baseline), |r| (&r.options, &r.baseline));
    let span = framework::span_of(problem.op);
    let t0 = Instant::now();
    let mut base = diagnosis_combination(
        run_baseline,
        run_options,
        run_baseline.stiction,
        run_baseline.linear,
        run_baseline.fixed_delay(),
    )
    .run(problem, None)?;
    base.elapsed_ms = t0.elapsed().as_secs_f64() * 1e3;
    // Residual series of the baseline at its best node.
    let residuals = {
        let q = &base.result;
        ResidualAnalysis::new(problem.pv, &q.pv_pred, &q.pv_sim, &q.mv_est, q.split_index)
    };
    let own_cycle = causes::OwnCycle::default();
    let d = Diagnoser {
        problem,
        span,
        baseline: run_baseline,
        base: &base,
        options: run_options,
        own_cycle: &own_cycle,
    };
    // a reframed diagnosis tests no other cause (see `Cause::reframe`)
    let testable = if reframed.is_some() {
        &[][..]
    } else {
        &known[..]
    };
    let (mut sel, done) =
        selection::Selection::first_round(&d.context(&residuals), testable, &tell);
    sel.select(&d, &tell, done)?;
    // The final model at the orders the data support (item 12): refitted before the open set,
    // which then asks what the best model leaves (a misfit of the given orders is not a
    // change of the process).
    let selected_chain: Vec<&'static str> = sel.causes.clone();
    let (pre_fit, pre_selection, pre_data) = if sel.healthy() {
        (None, None, None)
    } else {
        d.refit(&selected_chain, None)
    };
    // the open set: what the final model leaves that no registered cause explains
    let mut open = None;
    if reframed.is_none() && !run_options.disabled.iter().any(|c| c == UNEXPLAINED) {
        let last = sel.selected_model().unwrap_or(&base);
        // the record as that model sees it (a cause that transformed the data)
        let (last, data) = match pre_fit.as_ref().filter(|r| r.fit_val() > last.fit_val()) {
            Some(refit) => (refit, pre_data.as_ref()),
            None => (last, sel.selected_data()),
        };
        open = open_set::open_set(framework::seen(problem, data), last, run_options);
    }
    let stretch_check = d.check_change(&mut sel, &mut open);
    let pre = (pre_fit, pre_selection);
    let fin = d.final_refit(
        &sel,
        open.as_ref(),
        stretch_check.as_ref(),
        &selected_chain,
        pre,
    );
    let mut written = summary::Written::new(&base, &residuals, &sel);
    written.open_set(open, &mut sel, stretch_check.as_ref());
    written.refit(&fin, problem.op.len());
    if let Some(r) = reframed {
        let finding =
            summary::reframed_finding(problem, baseline, options, &base, r.name, r.evidence)?;
        written.reframed(finding, &mut sel);
    }
    Ok(Diagnosis {
        baseline: base.summary(),
        baseline_fit: base,
        residuals,
        cause: written.cause,
        causes: sel.causes.iter().map(|c| c.to_string()).collect(),
        chosen: sel.chosen,
        findings: sel.findings,
        steps: sel.steps,
        picks: sel.picks,
        gain_fit_pv_val: fin.gain,
        refined: fin.refined,
        order_selection: fin.order_selection,
        stretches: stretch_check,
        summary: written.summary,
        elapsed_ms: started.elapsed().as_secs_f64() * 1e3,
    })
}
