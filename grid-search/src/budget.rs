//! The node budget: every grid is counted before anything is allocated.
//!
//! A grid's size follows from the OP span and the step: `(span / step + 1)^p` boxes for `p`
//! parameters, filtered by the model's constraints. Without a bound, OP logged in counts, a
//! tiny `step` or an absurd scale asks for millions (or 10^20) of nodes and ends in an
//! allocation failure. Here every stage of a [`GridPlan`] is counted in floating point first
//! (so `span / step = 1e300` is a number, not an overflow); a stage over the budget is
//! [`SearchError::Budget`], which names the budget and how to change it.
//!
//! Decisions:
//! * The budget counts the nodes of one stage (the exhaustive grid, or the coarse grid, or the
//!   refinement box). The default, [`DEFAULT_MAX_NODES`], is about 7 s of search on this
//!   2-core machine with ARX and 751 samples; the default plans of [`GridPlan::for_span`] stay
//!   far below it for two-parameter models (about 3 000 nodes).
//! * An explicit grid (`Exhaustive`) over the budget is an error: the user asked for it.
//! * The refinement stage of the default coarse-to-fine plan is coarsened (the next round step
//!   up) until it fits, with a warning: the user did not ask for that step.
//! * A step coarser than a quarter of the OP span leaves fewer than five values per parameter
//!   (one node when the step exceeds the span): the "estimate" would be the grid, not the data.
//!   It is refused ([`SearchError::InvalidOption`]).
//! * The work budget ([`DEFAULT_MAX_WORK`], [`check_work`]) counts what a stage costs: its
//!   nodes × the record's samples × the identifier's cost per sample. Over it is
//!   [`SearchError::Work`], a usage error like the node budget.

use linear_id::LinearIdentifier;
use stiction_models::ModelEntry;

use crate::{GridPlan, SearchError};

/// The default node budget per stage (see the module documentation).
pub const DEFAULT_MAX_NODES: usize = 200_000;

/// The default work budget per stage: nodes × samples × the identifier's
/// [`LinearIdentifier::cost_per_sample`].
///
/// A node's cost grows with the record's length and, for the recursive identifiers, with the
/// square of their orders, which the node budget alone does not see (`--linear armax --orders
/// 50,50,50` on 3000 samples ran for minutes within it). The default is about 20 s of CPU for
/// one stage on a 2-core machine, far above the default plans (the calibration is in
/// `docs/decisions/2026-11-27-long-records-and-fuzz.md`).
pub const DEFAULT_MAX_WORK: f64 = 5e10;

/// Check `nodes` evaluations of `identifier` on `samples` samples against `max_work`.
// `!(a <= b)` is deliberate: it is true for NaN too.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn check_work<I: LinearIdentifier + ?Sized>(
    nodes: usize,
    samples: usize,
    identifier: &I,
    max_work: f64,
    what: &'static str,
) -> Result<(), SearchError> {
    let cost = identifier.cost_per_sample();
    let work = nodes as f64 * samples as f64 * cost;
    if !(work <= max_work) {
        return Err(SearchError::Work {
            what,
            nodes,
            samples,
            identifier: identifier.name(),
            cost,
            work,
            budget: max_work,
        });
    }
    Ok(())
}

/// Boxes larger than this many times the budget are not enumerated: the model's constraints
/// keep at least a sixth of a box for the built-in models (kano-asym: a third), so such a box
/// is over the budget anyway.
const ENUMERATE_FACTOR: f64 = 8.0;

/// The number of multiples of `step` in `[lo, hi]`, as `f64` (may be huge or infinite).
// `!(a >= b)` is deliberate: it is true for NaN too.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn axis_len(lo: f64, hi: f64, step: f64) -> f64 {
    if !(hi >= lo) || !(step > 0.0) {
        return 0.0;
    }
    let first = (lo / step - 1e-9).ceil().max(0.0);
    let last = (hi / step + 1e-9).floor();
    if !(last >= first) {
        return 0.0;
    }
    last - first + 1.0
}

/// The per-parameter bounds `[lo_i, hi_i]` of a grid (the whole region without `bounds`).
pub(crate) fn box_bounds(
    entry: &ModelEntry,
    span: f64,
    bounds: Option<&[(f64, f64)]>,
) -> Vec<(f64, f64)> {
    entry
        .params
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let top = p.max_span_fraction * span;
            bounds.map_or((0.0, top), |b| (b[i].0.max(0.0), b[i].1.min(top)))
        })
        .collect()
}

/// The number of nodes of [`crate::grid::nodes_in_box`] for these arguments, counted without
/// storing them; `Err(estimate)` when the box alone has more than `ENUMERATE_FACTOR · limit`
/// nodes (then the count is at least over `limit`, and `estimate` is the box's size).
// `!(a <= b)` is deliberate: it is true for NaN too.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn count_nodes(
    entry: &ModelEntry,
    span: f64,
    step: f64,
    bounds: Option<&[(f64, f64)]>,
    limit: usize,
) -> Result<usize, f64> {
    let bx = box_bounds(entry, span, bounds);
    let lens: Vec<f64> = bx.iter().map(|&(lo, hi)| axis_len(lo, hi, step)).collect();
    let product: f64 = lens.iter().product();
    if product == 0.0 {
        return Ok(0);
    }
    if !(product <= ENUMERATE_FACTOR * limit as f64) {
        return Err(product);
    }
    let axes: Vec<Vec<f64>> = bx
        .iter()
        .map(|&(lo, hi)| {
            let first = (lo / step - 1e-9).ceil().max(0.0) as usize;
            let last = (hi / step + 1e-9).floor() as usize;
            (first..=last).map(|i| i as f64 * step).collect()
        })
        .collect();
    let mut count = 0usize;
    let mut current = Vec::with_capacity(axes.len());
    count_product(&axes, &mut current, &mut |v| {
        if entry.admissible(v, span) {
            count += 1;
        }
    });
    Ok(count)
}

fn count_product(axes: &[Vec<f64>], current: &mut Vec<f64>, f: &mut dyn FnMut(&[f64])) {
    if current.len() == axes.len() {
        f(current);
        return;
    }
    for &v in &axes[current.len()] {
        current.push(v);
        count_product(axes, current, f);
        current.pop();
    }
}

/// Check a grid of `step` over the whole region against `max_nodes`; its node count.
pub fn check_grid(
    entry: &ModelEntry,
    span: f64,
    step: f64,
    max_nodes: usize,
    what: &'static str,
) -> Result<usize, SearchError> {
    match count_nodes(entry, span, step, None, max_nodes) {
        Ok(n) if n <= max_nodes => Ok(n),
        Ok(n) => Err(SearchError::Budget {
            what,
            step,
            span,
            nodes: n as f64,
            budget: max_nodes,
        }),
        Err(estimate) => Err(SearchError::Budget {
            what,
            step,
            span,
            nodes: estimate.min(f64::MAX),
            budget: max_nodes,
        }),
    }
}

/// Refuse a step that leaves fewer than five values per parameter (see the module docs).
pub fn check_step_against_span(
    step: f64,
    span: f64,
    name: &'static str,
) -> Result<(), SearchError> {
    if step > span / 4.0 * (1.0 + 1e-9) {
        return Err(SearchError::InvalidOption {
            name,
            value: step,
            expected: format!(
                "a step of at most a quarter of the OP span ({:.4}; OP span {span:.4}), so that S takes at least 5 values",
                span / 4.0
            ),
        });
    }
    Ok(())
}

/// The refinement step of a coarse-to-fine plan that fits the budget inside `bounds`: `fine`
/// when it fits, else the next round step (1, 2, 5 × 10^k) up that does; `None` when not even
/// the coarse step fits. The second value says whether it was coarsened.
pub fn fit_refinement(
    entry: &ModelEntry,
    span: f64,
    fine: f64,
    coarse: f64,
    bounds: &[(f64, f64)],
    max_nodes: usize,
) -> Option<(f64, bool)> {
    let mut step = fine;
    let mut coarsened = false;
    for _ in 0..64 {
        if step > coarse {
            return None;
        }
        match count_nodes(entry, span, step, Some(bounds), max_nodes) {
            Ok(n) if n <= max_nodes => return Some((step, coarsened)),
            _ => {
                step = next_round_step(step);
                coarsened = true;
            }
        }
    }
    None
}

/// The smallest of 1, 2, 5 × 10^k strictly larger than `x`.
fn next_round_step(x: f64) -> f64 {
    let decade = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * decade)
        .find(|v| *v > x * (1.0 + 1e-9))
        .unwrap_or(10.0 * decade)
}

/// The steps of a plan that must be validated against the span, with the option's name.
pub(crate) fn plan_steps(plan: &GridPlan) -> Vec<(&'static str, f64)> {
    match *plan {
        GridPlan::Exhaustive { step } => vec![("step", step)],
        GridPlan::CoarseToFine { coarse, .. } => vec![("coarse step", coarse)],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use stiction_models::find_model;

    #[test]
    fn counts_match_the_grid() {
        let kano = find_model("kano").unwrap();
        for (span, step) in [(1.0, 0.25), (9.4, 0.02), (22.6, 0.1), (3.0, 0.7)] {
            let n = crate::grid::nodes(kano, span, step).len();
            assert_eq!(count_nodes(kano, span, step, None, 1_000_000), Ok(n));
        }
        let asym = find_model("kano-asym").unwrap();
        let n = crate::grid::nodes(asym, 1.0, 0.1).len();
        assert_eq!(count_nodes(asym, 1.0, 0.1, None, 1_000_000), Ok(n));
    }

    #[test]
    fn huge_grids_are_counted_not_built() {
        let kano = find_model("kano").unwrap();
        // OP x 1e9 with the old absolute step 0.1, and a denormal step.
        for (span, step) in [(2.26e10, 0.1), (22.6, 5e-324), (22.6, 1e-4)] {
            match check_grid(kano, span, step, DEFAULT_MAX_NODES, "grid") {
                Err(SearchError::Budget { nodes, budget, .. }) => {
                    assert!(nodes > budget as f64, "{nodes}");
                }
                other => panic!("{span} {step}: {other:?}"),
            }
        }
    }

    #[test]
    fn refinement_is_coarsened_to_fit() {
        let asym = find_model("kano-asym").unwrap();
        let b = [(40.0, 50.0), (0.0, 10.0), (0.0, 10.0)];
        let (step, coarsened) = fit_refinement(asym, 100.0, 0.1, 2.5, &b, 20_000).unwrap();
        assert!(coarsened);
        assert!(count_nodes(asym, 100.0, step, Some(&b), 20_000).unwrap() <= 20_000);
        assert_eq!(next_round_step(0.1), 0.2);
        assert_eq!(next_round_step(0.2), 0.5);
        assert_eq!(next_round_step(0.5), 1.0);
    }

    #[test]
    fn steps_over_a_quarter_of_the_span_are_refused() {
        assert!(check_step_against_span(1e9, 20.0, "step").is_err());
        assert!(check_step_against_span(5.0, 20.0, "step").is_ok());
        assert!(check_step_against_span(5.1, 20.0, "step").is_err());
    }
}
