//! Dead-time estimation (paper §3.3: the delay is a grid dimension of its own).

use linear_id::{IdError, LinearIdentifier};
use serde::Serialize;
use stiction_models::ModelEntry;

use crate::{quantify, GridPlan, Problem, SearchError, SearchOptions};

/// The validation fit of the best stiction node at each candidate dead time.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DelayScan {
    /// The chosen dead time, samples.
    pub delay: usize,
    /// `(delay, best validation fit %)` for every candidate that could be evaluated.
    pub scores: Vec<(usize, f64)>,
}

/// Estimate the process dead time: for every `t_d` in `0..=max_delay`, search a coarse grid
/// (`span / 20`) with the identifier built for that delay and keep the delay whose best node
/// explains PV best on validation data. Ties (within 0.01 %) go to the smaller delay, so a
/// dead time is only added when it helps.
///
/// The grid dimension is scanned exhaustively rather than estimated from the MV–PV
/// cross-correlation, because in closed loop under stiction MV is unknown and OP–PV
/// correlation is dominated by the feedback path.
pub fn estimate_delay(
    entry: &ModelEntry,
    identifier_for: &(dyn Fn(usize) -> Result<Box<dyn LinearIdentifier>, IdError> + Sync),
    problem: Problem<'_>,
    options: &SearchOptions,
    max_delay: usize,
) -> Result<DelayScan, SearchError> {
    let (lo, hi) = problem
        .op
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let span = hi - lo;
    let coarse = SearchOptions {
        grid: GridPlan::Exhaustive {
            step: if span.is_finite() && span > 0.0 {
                span / 20.0
            } else {
                1.0
            },
        },
        ..*options
    };
    let mut scores = Vec::new();
    let mut last_err = None;
    for d in 0..=max_delay {
        let id = identifier_for(d)?;
        match quantify(entry, id.as_ref(), problem, &coarse, None) {
            Ok(q) => scores.push((d, q.fits_score(options.criterion))),
            Err(e @ SearchError::NoValidNode { .. }) => last_err = Some(e),
            Err(e) => return Err(e),
        }
    }
    let best = scores.iter().map(|s| s.1).fold(f64::NEG_INFINITY, f64::max);
    match scores.iter().find(|s| s.1 >= best - 0.01) {
        Some(&(delay, _)) => Ok(DelayScan { delay, scores }),
        None => Err(last_err.unwrap_or(SearchError::NoValidNode {
            nodes: 0,
            reason: crate::NoNode::NoDelay,
        })),
    }
}
