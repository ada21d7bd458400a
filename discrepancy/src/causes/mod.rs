//! The built-in causes, one module each (`disturbance`, `asymmetric-stiction`, `time-delay`,
//! `no-stiction`, `travel-limit`; `valve-characteristic` and `compression` beside this folder), and what
//! their extensions share: the current valve, the local searches from it, OP's own cycle.

mod asymmetric;
mod delay;
mod disturbance;
mod no_stiction;
mod travel_limit;

pub use asymmetric::AsymmetricStiction;
pub use delay::TimeDelay;
pub use disturbance::Disturbance;
pub use no_stiction::NoStiction;
pub use travel_limit::TravelLimit;

use crate::eval::{Evaluator, LocalFit, PatternSearch};
use crate::{Context, DiagnoseError, Extension, Fitted};

/// Whether the extensions that refit the model on a grid (or from its (S, J)) keep the
/// current stiction model: not `kano-char`, whose shape `a` a grid does not search (a grid
/// fixes `a = 0`) and `kano-asym` cannot carry. On a `kano-char` model found by
/// `valve-characteristic` these causes are not tested again (but for `time-delay`, whose
/// search on a valve of three parameters is local and keeps `a`); the forward selection's
/// second path (from the runner-up) finds a characteristic on top of them instead.
pub(super) fn keeps_stiction_model(ctx: &Context<'_>) -> bool {
    ctx.baseline.stiction.name != "kano-char"
}

/// How close (relative) a frequency must be to the loop's own oscillation, or to its second
/// or third harmonic, to be that oscillation: a stiction limit cycle's period varies from
/// cycle to cycle, so its periodogram line is wide.
const OWN_CYCLE_TOLERANCE: f64 = 0.2;

/// Whether `fitted` is a HARX model whose notch sits on the loop's own oscillation (the
/// dominant frequency of `op`, or its second or third harmonic) while its valve has
/// non-negligible stiction. Such a notch removes the valve's own limit cycle from the data
/// rather than an external disturbance, and its gain is the stiction model's misfit
/// (measured on the hidden-effect suite's loops with an unmodelled dead time: HARX at the
/// limit cycle gained LR 47-170 with S unchanged, and on one clean loop LR 76). An external
/// oscillation that *is* the loop's oscillation leaves a valve without stiction once it is
/// notched out. The forward selection applies the same rule to every model built on a HARX
/// model (a dead time found on top of a notch at the cycle that brings the stiction back
/// makes the notch the valve's cycle after all).
pub(crate) fn notches_the_valves_cycle(own: &OwnCycle, op: &[f64], fitted: &Fitted) -> bool {
    let Some(omega) = fitted.result.linear.harmonic() else {
        return false;
    };
    let Some(own) = own.of(op) else {
        return false;
    };
    let on_cycle = (1..=3).any(|k| {
        let w = own * k as f64;
        (omega - w).abs() <= OWN_CYCLE_TOLERANCE * w
    });
    on_cycle && fitted.result.s > grid_search::NEGLIGIBLE_S
}

/// The dominant frequency of OP (the loop's own oscillation, [`notches_the_valves_cycle`]),
/// computed on first use and kept for the rest of the diagnosis: every HARX model the
/// forward selection fits is checked against it, and its periodogram of a 3000-sample record
/// took 20-30 ms each time (8 % of a disturbance + dead-time diagnosis).
#[derive(Debug, Default)]
pub(crate) struct OwnCycle(std::sync::OnceLock<Option<f64>>);

impl OwnCycle {
    /// The dominant frequency of `op`, the same record at every call.
    pub(crate) fn of(&self, op: &[f64]) -> Option<f64> {
        *self.0.get_or_init(|| {
            linear_id::dominant_frequency(op, HARMONIC_MIN_PERIOD, op.len() as f64 / 2.0)
        })
    }
}

/// Periods (samples) HARX's frequency is sought in: from 8 samples to half the residual
/// record.
pub(super) const HARMONIC_MIN_PERIOD: f64 = 8.0;

/// The current model's valve parameters, on the grid's fine lattice.
pub(super) fn current_valve(ctx: &Context<'_>) -> Vec<f64> {
    let fine = ctx.options.search.grid.step();
    ctx.baseline
        .result
        .stiction
        .param_values()
        .iter()
        .map(|v| (v / fine).round() * fine)
        .collect()
}

/// A pattern search of the current valve's model with `evaluator`'s identifier from `start`,
/// one direction per parameter, at most 400 nodes.
pub(super) fn axis_search(
    ctx: &Context<'_>,
    evaluator: &Evaluator<'_>,
    start: &[f64],
) -> Result<Vec<grid_search::NodeFit>, DiagnoseError> {
    let k = start.len();
    let directions = (0..k)
        .map(|i| (0..k).map(|j| f64::from(u8::from(i == j))).collect())
        .collect();
    let fine = ctx.options.search.grid.step();
    pattern_search(
        ctx,
        ctx.baseline_spec.stiction,
        evaluator,
        fine,
        directions,
        start,
    )
}

/// A pattern search of `entry` with `evaluator` (built for `entry`) from `start` along
/// `directions`: steps from span/20 halved down to `fine` (also the rounding lattice), at
/// most 400 nodes, the model's own admissible region.
pub(super) fn pattern_search(
    ctx: &Context<'_>,
    entry: &'static stiction_models::ModelEntry,
    evaluator: &Evaluator<'_>,
    fine: f64,
    directions: Vec<Vec<f64>>,
    start: &[f64],
) -> Result<Vec<grid_search::NodeFit>, DiagnoseError> {
    PatternSearch {
        entry,
        options: &ctx.options.search,
        span: ctx.span,
        coarse: (ctx.span / 20.0).max(fine),
        fine,
        directions,
        budget: 400,
        scales: Vec::new(),
        admit: None,
    }
    .run(evaluator, start)
}

/// The extension a local search from the current valve found (`local_disturbance`,
/// `local_delay`), against the current model (one extra parameter).
pub(super) fn from_current_valve(
    ctx: &Context<'_>,
    fit: LocalFit,
    nodes: Vec<grid_search::NodeFit>,
) -> Result<Extension, DiagnoseError> {
    fit.extension(
        ctx,
        nodes,
        "the current valve",
        ctx.baseline.fit_val(),
        "baseline",
    )
}
