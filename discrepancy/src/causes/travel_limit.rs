//! `travel-limit`: the valve cannot follow OP past a position L (a travel stop, a positioner's
//! travel cutoff, an undersized actuator): above L the controller's output winds up to its
//! clamp while the valve, and so PV, stays short.
//!
//! The extension transforms the data before the fit ([`Transformed`]): OP clipped at L, so
//! the valve model sees `min(OP, L)` and its position never passes L; L is fitted (one extra
//! parameter: a scan of limits, each with a coarse lattice of valves, then the limit refined)
//! and the model searched again on the clipped record at the best L (the diagnosis's grid for
//! a valve of two parameters, a local search from the current valve otherwise). The
//! likelihood ratio compares the predictions of the record's own validation PV, as for every
//! other extension.
//!
//! It applies only where a controller has wound up against the limit: OP held at its highest
//! value for at least [`MIN_PINNED`] consecutive samples (a controller's clamp). A limit the
//! controller never pushed against leaves nothing to fit.

use std::time::Instant;

use grid_search::Problem;
use rayon::prelude::*;

use super::{axis_search, current_valve, keeps_stiction_model};
use crate::eval::{Evaluator, LocalFit};
use crate::{Cause, CauseEntry, Context, DiagnoseError, Evidence, Extension, Transformed};

/// The valve cannot pass a position L (see the module documentation).
///
/// Statistic: the share of the samples at which OP sits at its highest value (within 0.1 %
/// of OP's span), where a controller facing a valve that stops short winds up.
#[derive(Debug, Clone, Copy, Default)]
pub struct TravelLimit;

/// OP within this share of its span of its maximum counts as pinned there.
const PINNED: f64 = 0.001;

/// The limits tried first: from OP's maximum down to its median, in steps of span/20.
const COARSE_STEPS: f64 = 20.0;

/// The shortest run of samples at OP's highest value that shows a controller wound up
/// against a limit (OP at its clamp); noise never repeats a maximum so long.
pub const MIN_PINNED: usize = 10;

/// The longest run of samples of `op` within [`PINNED`] of the span from its maximum.
fn longest_pinned_run(op: &[f64], span: f64) -> usize {
    let max = op.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (mut best, mut run) = (0, 0);
    for &u in op {
        run = if u >= max - PINNED * span { run + 1 } else { 0 };
        best = best.max(run);
    }
    best
}

/// `op` clipped at `limit`.
fn clipped(op: &[f64], limit: f64) -> Vec<f64> {
    op.iter().map(|&u| u.min(limit)).collect()
}

/// The share of samples of `op` within [`PINNED`] of the span from its maximum, and the
/// maximum.
fn pinned(op: &[f64], span: f64) -> (f64, f64) {
    let max = op.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let n = op.iter().filter(|&&u| u >= max - PINNED * span).count();
    (n as f64 / op.len().max(1) as f64, max)
}

impl TravelLimit {
    /// The best validation score of the valves `valves` on the record with OP clipped at
    /// `limit`, and that valve (`None` when no node can be evaluated).
    fn score_at(ctx: &Context<'_>, limit: f64, valves: &[Vec<f64>]) -> Option<(f64, Vec<f64>)> {
        let spec = ctx.baseline_spec;
        let identifier = spec.identifier(ctx.baseline.delay).ok()?;
        let op = clipped(ctx.problem.op, limit);
        let problem = Problem {
            op: &op,
            pv: ctx.problem.pv,
            mv: ctx.problem.mv,
        };
        let nodes = grid_search::evaluate_nodes(
            spec.stiction,
            identifier.as_ref(),
            problem,
            &ctx.options.search,
            valves.to_vec(),
        )
        .ok()?;
        let crit = ctx.options.search.criterion;
        nodes
            .iter()
            .filter(|n| n.score(crit).is_finite())
            .max_by(|a, b| a.score(crit).total_cmp(&b.score(crit)))
            .map(|n| (n.score(crit), n.params.clone()))
    }

    /// The limit that predicts the validation data best: OP's maximum less 1, 2, ... coarse
    /// steps down to its median, each with the current valve and a lattice of valves at twice
    /// the grid's coarse step, then steps halved down to the grid's fine step around the best
    /// with the best valve there.
    fn fit_limit(ctx: &Context<'_>, valve: &[f64]) -> Option<f64> {
        let op = ctx.problem.op;
        let fine = ctx.options.search.grid.step();
        let coarse = (ctx.span / COARSE_STEPS).max(fine);
        let mut sorted: Vec<f64> = op.to_vec();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        let max = sorted[sorted.len() - 1];
        let snap = |v: f64| (v / fine).round() * fine;
        let limits: Vec<f64> = (1..)
            .map(|k| snap(max - f64::from(k) * coarse))
            .take_while(|&l| l > median)
            .collect();
        let grid_coarse = match ctx.options.search.grid {
            grid_search::GridPlan::CoarseToFine { coarse, .. } => coarse,
            grid_search::GridPlan::Exhaustive { step } => step,
        }
        .max(fine);
        let mut valves =
            grid_search::grid::nodes(ctx.baseline_spec.stiction, ctx.span, 2.0 * grid_coarse);
        valves.push(valve.to_vec());
        let scored: Vec<(f64, (f64, Vec<f64>))> = limits
            .into_par_iter()
            .filter_map(|l| Some((l, Self::score_at(ctx, l, &valves)?)))
            .collect();
        let (mut best, (mut score, valve)) = scored
            .into_iter()
            .max_by(|a, b| a.1 .0.total_cmp(&b.1 .0).then(b.0.total_cmp(&a.0)))?;
        let valve = [valve];
        let mut step = coarse / 2.0;
        while step >= fine * 0.999 {
            let moves: Vec<(f64, f64)> = [best - step, best + step]
                .into_par_iter()
                .map(snap)
                .filter(|&l| l < max)
                .filter_map(|l| Some((l, Self::score_at(ctx, l, &valve)?.0)))
                .collect();
            match moves.into_iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
                Some((l, f)) if f > score + 1e-9 => (best, score) = (l, f),
                _ => step /= 2.0,
            }
        }
        Some(best)
    }
}

impl Cause for TravelLimit {
    fn name(&self) -> &'static str {
        "travel-limit"
    }
    fn applies(&self, ctx: &Context<'_>) -> bool {
        keeps_stiction_model(ctx) && longest_pinned_run(ctx.problem.op, ctx.span) >= MIN_PINNED
    }
    fn evidence(&self, ctx: &Context<'_>) -> Evidence {
        let (share, max) = pinned(ctx.problem.op, ctx.span);
        Evidence {
            statistic: share,
            text: format!(
                "OP sits at its highest value {max:.2} % on {:.1} % of the samples.",
                100.0 * share
            ),
        }
    }
    fn extend(&self, ctx: &Context<'_>) -> Result<Extension, DiagnoseError> {
        let started = Instant::now();
        let spec = ctx.baseline_spec;
        let start = current_valve(ctx);
        let limit = Self::fit_limit(ctx, &start).ok_or_else(|| DiagnoseError::EmptySearch {
            model: format!("{} with OP clipped", spec.stiction.name),
        })?;
        let op = clipped(ctx.problem.op, limit);
        let problem = Problem {
            op: &op,
            pv: ctx.problem.pv,
            mv: ctx.problem.mv,
        };
        let clipped_ctx = Context { problem, ..*ctx };
        let mut ext = if spec.stiction.params.len() <= 2 {
            // the diagnosis's grid on the clipped record: the valve fitted to a wound-up
            // record can be far from the one that fits below the limit
            let fitted = clipped_ctx.quantify(spec.stiction, spec.linear, ctx.baseline.delay)?;
            let lr = ctx.lr(ctx.baseline.fit_val(), fitted.fit_val());
            Extension {
                fitted,
                lr,
                extra_params: 1,
                reference: "baseline".into(),
                data: None,
            }
        } else {
            let identifier = spec.identifier(ctx.baseline.delay)?;
            let evaluator = Evaluator::new(
                spec.stiction,
                identifier.as_ref(),
                problem,
                &ctx.options.search,
            )?;
            let nodes = axis_search(&clipped_ctx, &evaluator, &start)?;
            drop(evaluator);
            LocalFit {
                entry: spec.stiction,
                linear: spec.linear,
                identifier,
                delay: ctx.baseline.delay,
                started,
            }
            .extension(
                &clipped_ctx,
                nodes,
                "the current valve",
                ctx.baseline.fit_val(),
                "baseline",
            )?
        };
        ext.data = Some(Transformed {
            op: op.clone(),
            pv: ctx.problem.pv.to_vec(),
            mv: ctx.problem.mv.map(<[f64]>::to_vec),
            what: format!("OP clipped at the fitted travel limit L = {limit:.2} %"),
        });
        Ok(ext)
    }
}

inventory::submit! {
    CauseEntry {
        name: "travel-limit",
        role: crate::Role::Extension,
        description: "the valve cannot follow OP past a position L: OP clipped at L before the fit (L fitted)",
        statistic: "share of the samples with OP at its highest value",
        build: || Box::new(TravelLimit),
    }
}
