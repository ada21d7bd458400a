//! Hammerstein stiction quantification by grid search (Bacci di Capaci & Scali, §2.3-2.4).
//!
//! For every node of a grid over a stiction model's parameters ([`grid::nodes`]), the model
//! turns OP into an estimated valve position MV ([`stiction_models::run_valve`], In.1/In.2/In.3),
//! a linear identifier fits MV → PV on the identification window (the first `split` of the
//! record, from the sample where MV no longer depends on the valve's unknown initial state),
//! and the node is scored by the paper's F_PV (eq. 9, squared norms) on the validation window
//! (the rest). The best node is the estimate. See [`quantify`].
//!
//! The search is generic over the identifier (`I: LinearIdentifier + ?Sized`, so `&dyn` and
//! concrete callers share one code path) and takes the stiction model as a registry entry, so
//! any registered model (a third party's too) is searched over the grid its parameter
//! description defines. Nodes are evaluated in parallel (rayon); the result does not depend on
//! the number of threads. This crate does no IO.

pub mod budget;
pub mod degenerate;
pub mod grid;
mod search;
mod skip;
pub mod trust;

pub use search::{
    evaluate_nodes, quantify, quantify_from_surface, quantify_with, Criterion, Fits, GridPlan,
    Interval, NodeEvaluator, NodeFit, NodeFits, NodePath, Problem, Quantification, SearchOptions,
};
pub use skip::Skip;
pub use trust::{Doubt, Severity, Verdict, HARMFUL_S, MAINTENANCE_S, NEGLIGIBLE_S};

pub use linear_id;
pub use stiction_models;

/// Errors of the grid search.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SearchError {
    /// A stop was requested while the search ran ([`stiction_models::cancel`]).
    #[error("interrupted")]
    Interrupted,
    /// The stiction model failed (bad OP, bad initialization).
    #[error(transparent)]
    Stiction(#[from] stiction_models::StictionError),
    /// The linear identification failed where no node can be skipped (the final refit).
    #[error(transparent)]
    Identification(#[from] linear_id::IdError),
    /// OP and PV have different lengths.
    #[error("OP has {op} samples, PV has {pv}")]
    LengthMismatch {
        /// OP length.
        op: usize,
        /// PV length.
        pv: usize,
    },
    /// A signal that must vary is constant: nothing can be identified.
    #[error("{signal} is constant (value {value}): stiction is not identifiable from this record")]
    Constant {
        /// `OP` or `PV`.
        signal: &'static str,
        /// Its value.
        value: f64,
    },
    /// A sample is NaN or infinite.
    #[error("{signal} sample {index} is not finite ({value})")]
    NonFinite {
        /// `OP`, `PV` or `MV`.
        signal: &'static str,
        /// Index of the first bad sample.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// The record is too short for the identification/validation split and the orders.
    #[error("too few samples: {needed} needed ({why}), got {got}")]
    TooFewSamples {
        /// Samples needed.
        needed: usize,
        /// Samples given.
        got: usize,
        /// What they are needed for.
        why: String,
    },
    /// An option is out of range.
    #[error("invalid option {name} = {}: expected {expected}", short_number(*.value))]
    InvalidOption {
        /// Option name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Valid range.
        expected: String,
    },
    /// The record cannot determine the stiction parameters at all.
    #[error("stiction is not identifiable from this record: {reason}")]
    NotIdentifiable {
        /// Why.
        reason: String,
    },
    /// A grid stage has more nodes than the budget ([`SearchOptions::max_nodes`]).
    #[error(
        "the {what} at step {} over the OP span {span:.4} would have {} nodes, over the node budget of {budget}: give a coarser --step or a larger budget (--max-nodes)",
        short_number(*.step), if *.nodes < 1e9 { format!("{}", .nodes) } else { format!("{:.3e}", .nodes) }
    )]
    Budget {
        /// Which stage (`grid`, `coarse grid`).
        what: &'static str,
        /// Its step, OP units.
        step: f64,
        /// OP span.
        span: f64,
        /// Nodes it would have (an estimate when huge).
        nodes: f64,
        /// The budget.
        budget: usize,
    },
    /// A grid stage costs more than the work budget ([`SearchOptions::max_work`]): its nodes ×
    /// the record's samples × the identifier's cost per sample
    /// ([`linear_id::LinearIdentifier::cost_per_sample`]).
    #[error(
        "the {what} would cost {:.3e} work units ({nodes} nodes x {samples} samples x {} per sample for {identifier}), over the work budget of {:.3e}: give a coarser --step, lower --orders or a shorter --window, or a larger budget (--max-work)",
        .work, short_number(*.cost), .budget
    )]
    Work {
        /// Which stage (`grid`, `coarse grid`, `refinement`, `nodes`).
        what: &'static str,
        /// Its nodes.
        nodes: usize,
        /// The record's samples.
        samples: usize,
        /// The identifier.
        identifier: &'static str,
        /// Its cost per sample.
        cost: f64,
        /// nodes × samples × cost.
        work: f64,
        /// The budget.
        budget: f64,
    },
    /// Every node was skipped: no estimate exists.
    #[error("no grid node could be evaluated ({nodes} nodes); most common reason: {reason}")]
    NoValidNode {
        /// Number of nodes tried.
        nodes: usize,
        /// Why: the most frequent skip reason, or what else went wrong.
        reason: NoNode,
    },
}

/// Why a search has no valid node ([`SearchError::NoValidNode`]).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum NoNode {
    /// Every node was skipped; the most frequent reason.
    Skipped(Skip),
    /// The grid has no node.
    EmptyGrid,
    /// The best node could not be evaluated again for its model and series.
    RefitFailed(Skip),
    /// A dead-time scan found no delay with a valid node.
    NoDelay,
    /// The best node's evaluation kept no model.
    NotRefitted,
}

impl std::fmt::Display for NoNode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NoNode::Skipped(s) | NoNode::RefitFailed(s) => s.fmt(f),
            NoNode::EmptyGrid => f.write_str("no nodes in the grid"),
            NoNode::NoDelay => f.write_str("no delay candidate"),
            NoNode::NotRefitted => f.write_str("the best node could not be refitted"),
        }
    }
}

impl SearchError {
    /// Whether the error is the user's choice of options, not the data: a grid over the node
    /// budget or an option out of range (a command line calls it bad usage).
    pub fn is_usage(&self) -> bool {
        matches!(
            self,
            SearchError::Budget { .. }
                | SearchError::Work { .. }
                | SearchError::InvalidOption { .. }
        )
    }
}

mod delay;
pub use delay::{estimate_delay, DelayScan};

/// A number for a one-line message: plain when moderate, in exponent form when tiny or huge
/// (`5e-324`, not 324 digits).
pub(crate) fn short_number(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e9).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}
