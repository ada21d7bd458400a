//! Why a grid node was skipped, typed: a skipped node is never selected, and its reason
//! crosses crate boundaries (the surface CSV, the report's grey cells, the diagnosis) as this
//! enum, not as text.

use std::fmt;

use linear_id::IdError;
use serde::{Serialize, Serializer};
use stiction_models::StictionError;

/// Why a grid node could not be evaluated.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Skip {
    /// The stiction model rejected the node (parameters, OP, initialization).
    Stiction(StictionError),
    /// The valve's initial state matters until sample `valid_from`, leaving too few
    /// identification samples.
    InitialState {
        /// First sample where MV no longer depends on the unknown initial state.
        valid_from: usize,
    },
    /// The estimated MV takes fewer than three values in the identification window.
    ValveHardlyMoves,
    /// The linear identification failed (singular regression, too few samples, ...) or its
    /// model is unstable ([`IdError::Unstable`]).
    Identification(IdError),
    /// The one-step prediction is not finite.
    NonFinitePrediction,
    /// Not evaluated: a stop was requested ([`stiction_models::cancel`]).
    Cancelled,
}

impl Skip {
    /// Whether the node's linear model was unstable.
    pub fn is_unstable(&self) -> bool {
        matches!(self, Skip::Identification(IdError::Unstable { .. }))
    }
}

impl fmt::Display for Skip {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Skip::Stiction(e) => write!(f, "{e}"),
            Skip::InitialState { valid_from } => write!(
                f,
                "the valve's initial state matters until sample {valid_from}: too few identification samples left"
            ),
            Skip::ValveHardlyMoves => f.write_str(
                "estimated MV takes fewer than 3 values in the identification window (the valve hardly moves)",
            ),
            Skip::Identification(e) => write!(f, "{e}"),
            Skip::NonFinitePrediction => f.write_str("the prediction is not finite"),
            Skip::Cancelled => f.write_str("not evaluated: interrupted"),
        }
    }
}

impl From<StictionError> for Skip {
    fn from(e: StictionError) -> Self {
        Skip::Stiction(e)
    }
}

impl From<IdError> for Skip {
    fn from(e: IdError) -> Self {
        Skip::Identification(e)
    }
}

/// Serialised as its sentence (what the surface and JSON have always shown).
impl Serialize for Skip {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}
