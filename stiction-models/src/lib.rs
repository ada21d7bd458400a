//! Data-driven valve stiction models behind one plugin trait.
//!
//! A stiction model maps the controller output `OP` (the commanded valve position, % of span)
//! to the actual valve position `MV`. The built-in models are
//! [`Kano`] (S, J), [`He`] (fs, fd), [`KanoAsym`] (D, J_up, J_dn) and [`KanoChar`] (S, J and
//! the shape a of an installed flow characteristic after the valve); a third party adds its
//! own by implementing [`StictionModel`] and submitting a [`ModelEntry`] with `inventory`.
//!
//! ```
//! use stiction_models::{Kano, InitialState, StictionModel};
//! let valve = Kano::params().s(4.0).j(1.0).check()?;
//! let op = [50.0, 50.5, 51.0, 52.0, 54.0];
//! let mv = valve.simulate(&op, &InitialState::up())?;
//! assert_eq!(mv, vec![48.5, 48.5, 48.5, 50.5, 52.5]);
//! # Ok::<(), stiction_models::StictionError>(())
//! ```
//!
//! Conventions (see `ARCHITECTURE.md`): all parameters are in OP units; threshold tests are
//! strict (`>`); OP is not clipped by the models (clip before calling, [`clip`]); non-finite
//! OP is rejected with the index of the first bad sample.

pub mod cancel;
#[doc(hidden)]
pub mod declare;
mod events;
mod he;
mod init;
mod kano;
mod kano_asym;
mod kano_char;
mod registry;

pub use declare::Bound;
pub use events::{run_valve_indexed, EventRule, OpIndex};
pub use he::{He, HeParams};
pub use init::{
    run_valve, run_valve_with, Direction, InitialState, Initialization, RunInfo, ValveRun,
    ValveScratch,
};
pub use kano::{Kano, KanoParams};
pub use kano_asym::{KanoAsym, KanoAsymParams};
pub use kano_char::{characteristic, KanoChar, KanoCharParams, MAX_SHAPE};
pub use registry::{find_model, registry, BuildFn, Constraint, ModelEntry, ParamSpec};

// The paths that `stiction_model!` writes (`stiction_models::serde`) resolve here too.
extern crate self as stiction_models;

/// Re-exported so that plugin crates use the same `inventory` as the registry.
pub use inventory;
/// Re-exported for the serde implementations that `stiction_model!` writes.
#[doc(hidden)]
pub use serde;
/// Re-exported so that plugin crates use the same `typetag` as the trait.
pub use typetag;

use std::fmt;

/// Errors of the stiction models. Every variant carries the offending values.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StictionError {
    /// A parameter is not finite, negative, or violates a constraint such as `J <= S`.
    #[error("{model}: parameter {name} = {value} is out of range: expected {expected}")]
    InvalidParameter {
        /// Registered model name.
        model: &'static str,
        /// Parameter name.
        name: String,
        /// The rejected value.
        value: f64,
        /// The valid range, in words.
        expected: String,
    },
    /// A parameter name that the model does not have.
    #[error("{model}: unknown parameter {name:?}; the model's parameters are {known}")]
    UnknownParameter {
        /// Registered model name.
        model: &'static str,
        /// The unknown name.
        name: String,
        /// Comma-separated list of valid names.
        known: String,
    },
    /// A model name that is not registered.
    #[error("unknown stiction model {name:?}; registered models are {known}")]
    UnknownModel {
        /// The unknown name.
        name: String,
        /// Comma-separated list of registered names.
        known: String,
    },
    /// A parameter vector of the wrong length was given to a registry builder.
    #[error("{model}: expected {expected} parameter values, got {got}")]
    WrongParameterCount {
        /// Registered model name.
        model: &'static str,
        /// Number of parameters of the model.
        expected: usize,
        /// Number given.
        got: usize,
    },
    /// An OP sample is NaN or infinite.
    #[error("OP sample {index} is not finite ({value})")]
    NonFiniteInput {
        /// Index of the first bad sample.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// Output buffer and input have different lengths.
    #[error("length mismatch: OP has {op} samples, the output buffer {out}")]
    LengthMismatch {
        /// OP length.
        op: usize,
        /// Output length.
        out: usize,
    },
    /// An initialization setting is invalid.
    #[error("invalid initialization: {0}")]
    InvalidInit(String),
}

/// The state of a valve while it is being simulated sample by sample.
///
/// Obtained from [`StictionModel::start`], which also fixes `MV(0)`; each call of
/// [`ValveState::step`] consumes `OP(k)` (finite, checked by the caller) for `k >= 1` and
/// returns `MV(k)`.
pub trait ValveState: Send {
    /// Advance one sample with the (finite) controller output `op`; returns the valve position.
    fn step(&mut self, op: f64) -> f64;
    /// The current valve position (MV of the last sample).
    fn position(&self) -> f64;
    /// Whether the valve is currently at rest (stuck).
    fn is_stuck(&self) -> bool;
}

impl<S: ValveState + ?Sized> ValveState for Box<S> {
    fn step(&mut self, op: f64) -> f64 {
        (**self).step(op)
    }
    fn position(&self) -> f64 {
        (**self).position()
    }
    fn is_stuck(&self) -> bool {
        (**self).is_stuck()
    }
}

/// MV for the whole OP record into `mv` (same length as `op`): the state `start` gives for
/// `OP(0)` (its position is `MV(0)`), then a [`ValveState::step`] per sample. The loop of
/// [`StictionModel::simulate_into`], monomorphic for a concrete state.
pub fn simulate_states<S: ValveState>(
    op: &[f64],
    mv: &mut [f64],
    start: impl FnOnce(f64) -> Result<S, StictionError>,
) -> Result<(), StictionError> {
    check_io(op, mv)?;
    let Some(&op0) = op.first() else {
        return Ok(());
    };
    let mut state = start(op0)?;
    mv[0] = state.position();
    for (m, &u) in mv[1..].iter_mut().zip(&op[1..]) {
        *m = state.step(u);
    }
    Ok(())
}

/// Stiction parameters in the common (S, J) language of the paper, in OP units.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Equivalent {
    /// Deadband plus stickband.
    #[serde(rename = "S")]
    pub s: f64,
    /// Slip jump.
    #[serde(rename = "J")]
    pub j: f64,
}

/// A data-driven valve stiction model: OP in, MV out.
///
/// Object safe and serialisable through `typetag` (`{"kind": "kano", "S": 4, "J": 1}`); every
/// implementation must also be registered with an [`inventory::submit!`] of a [`ModelEntry`]
/// whose `name` equals the typetag name, so that it can be listed and built from a parameter
/// vector by a generic grid search.
#[typetag::serde(tag = "kind")]
pub trait StictionModel: Send + Sync + fmt::Debug {
    /// Registered name (equal to the typetag tag).
    fn name(&self) -> &'static str;

    /// The model's own parameter values, in the order of its [`ModelEntry::params`].
    fn param_values(&self) -> Vec<f64>;

    /// Derived quantities worth reporting besides the parameters (e.g. `S_up`, `S_dn`).
    fn derived_values(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }

    /// The equivalent Kano (S, J) of this model, in OP units.
    fn equivalent(&self) -> Equivalent;

    /// Start a simulation: the valve state at sample 0 given `OP(0)` and the initial state.
    /// `MV(0)` is the returned state's [`ValveState::position`].
    fn start(&self, op0: f64, init: &InitialState) -> Result<Box<dyn ValveState>, StictionError>;

    /// Simulate MV for the whole OP record into `mv` (same length as `op`).
    ///
    /// The default implementation steps a boxed [`ValveState`]; built-in models override it
    /// with a monomorphic loop.
    fn simulate_into(
        &self,
        op: &[f64],
        init: &InitialState,
        mv: &mut [f64],
    ) -> Result<(), StictionError> {
        simulate_states(op, mv, |op0| self.start(op0, init))
    }

    /// Simulate MV for the whole OP record.
    fn simulate(&self, op: &[f64], init: &InitialState) -> Result<Vec<f64>, StictionError> {
        let mut mv = vec![0.0; op.len()];
        self.simulate_into(op, init, &mut mv)?;
        Ok(mv)
    }

    /// The model's optional fast paths ([`FastPaths`]), if it has any (`None` by default:
    /// every start simulated on its own, sample by sample).
    fn fast_paths(&self) -> Option<&dyn FastPaths> {
        None
    }

    /// A boxed copy.
    fn box_clone(&self) -> Box<dyn StictionModel>;
}

/// Optional fast paths of a [`StictionModel`], reached through
/// [`StictionModel::fast_paths`]; the results are bit for bit those of the plain methods.
pub trait FastPaths {
    /// Simulate from several starts at once (In.2/In.3 use the four `(stp, d)` starts).
    ///
    /// Fills `runs.out[i]` (each as long as `op`) with the run from `starts[i]` up to the returned
    /// sample `merge`, and `out[0]` completely: from `merge` on every run is guaranteed equal to
    /// `out[0]` (their whole valve states coincided, so they stay identical), and the other
    /// buffers are not written there. Built-in models step the starts in lockstep and stop the
    /// extra runs once their states coincide, which makes In.3 cost little more than one run.
    fn simulate_starts(&self, runs: &mut Runs<'_>) -> Result<usize, StictionError>;

    /// The model as a Kano-type interval rule, if it is one: then [`run_valve_indexed`] runs
    /// it event by event (stuck and moving intervals found by range queries on OP) instead of
    /// sample by sample, with the same MV bit for bit. `None` (the default) keeps the sample
    /// path.
    fn event_rule(&self) -> Option<EventRule> {
        None
    }
}

/// Runs of one OP record from several initial states ([`FastPaths::simulate_starts`]).
#[derive(Debug)]
pub struct Runs<'a> {
    /// The OP record.
    pub op: &'a [f64],
    /// The initial states, one per run.
    pub starts: &'a [InitialState],
    /// The MV of each run, in the order of `starts` (at least as many buffers).
    pub out: &'a mut [Vec<f64>],
}

impl dyn StictionModel + '_ {
    /// [`FastPaths::simulate_starts`] when the model has it; otherwise every start run to the
    /// end (the returned merge sample is then `op.len()`).
    pub fn simulate_starts(&self, runs: &mut Runs<'_>) -> Result<usize, StictionError> {
        if let Some(fast) = self.fast_paths() {
            return fast.simulate_starts(runs);
        }
        let op = runs.op;
        for (s, o) in runs.starts.iter().zip(runs.out.iter_mut()) {
            o.resize(op.len(), 0.0);
            self.simulate_into(op, s, o)?;
        }
        Ok(op.len())
    }

    /// [`FastPaths::event_rule`] when the model has fast paths, else `None`.
    pub fn event_rule(&self) -> Option<EventRule> {
        self.fast_paths().and_then(FastPaths::event_rule)
    }
}

impl Clone for Box<dyn StictionModel> {
    fn clone(&self) -> Self {
        self.box_clone()
    }
}

/// Check that `op` is finite and `mv` has its length.
pub fn check_io(op: &[f64], mv: &[f64]) -> Result<(), StictionError> {
    if op.len() != mv.len() {
        return Err(StictionError::LengthMismatch {
            op: op.len(),
            out: mv.len(),
        });
    }
    check_finite(op)
}

/// Reject NaN and infinite OP samples, naming the first.
pub fn check_finite(op: &[f64]) -> Result<(), StictionError> {
    match op.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(StictionError::NonFiniteInput {
            index,
            value: op[index],
        }),
        None => Ok(()),
    }
}

/// Clip OP in place to `[lo, hi]`, as the public implementations do for OP in % of span.
pub fn clip(op: &mut [f64], lo: f64, hi: f64) {
    for v in op {
        *v = v.clamp(lo, hi);
    }
}
