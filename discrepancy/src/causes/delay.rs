//! `time-delay`: an unmodelled dead time, estimated and the model refitted.

use std::time::Instant;

use grid_search::estimate_delay;
use linear_id::{IdError, LinearIdentifier};

use super::{axis_search, current_valve, from_current_valve, keeps_stiction_model};
use crate::eval::{Evaluator, LocalFit};
use crate::{Cause, CauseEntry, Context, DiagnoseError, Evidence, Extension};

/// An unmodelled dead time: the delay is estimated (every `t_d` in `0..=max_delay` on a coarse
/// grid, `grid_search::estimate_delay`) and the model refitted at the best delay that differs
/// from the baseline's.
///
/// Statistic: the largest cross-correlation of the prediction residuals with past estimated
/// MV, in standard errors.
#[derive(Debug, Clone, Copy, Default)]
pub struct TimeDelay;

impl Cause for TimeDelay {
    fn name(&self) -> &'static str {
        "time-delay"
    }
    fn applies(&self, ctx: &Context<'_>) -> bool {
        // on kano-char too: the dead time is then searched with the valve's three parameters
        // from the current valve (`local_delay`), which keeps the characteristic's shape
        (keeps_stiction_model(ctx) || ctx.baseline.stiction.name == "kano-char")
            && ctx
                .baseline_spec
                .linear
                .orders
                .iter()
                .any(|o| o.name == "delay")
    }
    fn evidence(&self, ctx: &Context<'_>) -> Evidence {
        let r = ctx.residuals;
        Evidence {
            statistic: r.cross_mv_z,
            text: format!(
                "The prediction residuals correlate with the estimated valve position {:.1} standard errors at lag {}.",
                r.cross_mv_z, r.cross_mv_lag
            ),
        }
    }
    fn extend(&self, ctx: &Context<'_>) -> Result<Extension, DiagnoseError> {
        let spec = ctx.baseline_spec;
        if spec.stiction.params.len() > 2 {
            return local_delay(ctx);
        }
        if ctx.baseline.identifier.fast_paths().is_none() {
            return warm_delay(ctx);
        }
        let build = |d: usize| -> Result<Box<dyn LinearIdentifier>, IdError> { spec.identifier(d) };
        let scan = estimate_delay(
            spec.stiction,
            &build,
            ctx.problem,
            &ctx.options.search,
            ctx.options.max_delay,
        )?;
        // The scan's coarse grid (span/20) finds the neighbourhood; the dead times around its
        // best are fitted on the full grid and the best of those is taken (the range grows by
        // one while the best is at its end). On the coarse grid the valve's
        // misplacement outweighs a sample of dead time: on the hidden-effect suite's 24
        // dead-time loops the full default grid at every dead time found the true one in 16
        // and gave Kano's S within max(0.5, 10 %) of the truth there in 23, while the coarse
        // scan's choice left S within tolerance in 16 of 24 diagnoses; with this refinement,
        // 18 (dead time with a disturbance 14 -> 16, with an asymmetric valve 15 -> 16; the
        // set of causes right with the asymmetric valve 21 -> 23, `cargo xtask suite`). Taking
        // the largest dead time within the one-parameter threshold of the best instead (a dead
        // time one sample short costs a low-order model little, one sample long drops the start
        // of the response) reached 19 but dropped the disturbance pair to 13 (a disturbance
        // flattens the profile) and was not kept.
        let current = spec.fixed_delay();
        let coarse = pick_delay(&scan.scores, current);
        let max = ctx.options.max_delay.max(coarse);
        // a neighbour that cannot be fitted (e.g. no stable node) is not a candidate
        let (mut fits, i) = fit_around(coarse, current, max, spec.stiction.name, |d| {
            let f = ctx.quantify(spec.stiction, spec.linear, d)?;
            Ok(Some((f.fit_val(), f)))
        })?;
        let (best, _, mut fitted) = fits.swap_remove(i);
        fitted.delay_scan = Some(grid_search::DelayScan {
            delay: best,
            scores: scan.scores,
        });
        let lr = ctx.lr(ctx.baseline.fit_val(), fitted.fit_val());
        Ok(Extension {
            fitted,
            lr,
            extra_params: 1,
            reference: "baseline".into(),
            data: None,
        })
    }
}

/// The dead time of the extension from `(delay, validation fit %)` scores: the best one other
/// than the `current` one (`current + 1` when none could be evaluated).
fn pick_delay(scores: &[(usize, f64)], current: usize) -> usize {
    scores
        .iter()
        .filter(|(d, f)| *d != current && f.is_finite())
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(current + 1, |(d, _)| *d)
}

/// Fits at several dead times (dead time, score, fit) and the index of the best.
type DelayFits<T> = (Vec<(usize, f64, T)>, usize);

/// The dead times around the scan's pick `coarse_pick` other than `current`, each fitted by
/// `fit` (a validation score and the fit; `None`: nothing to compare at that dead time):
/// `coarse_pick ± 1`, then, while the best so far is at an end of the range fitted, the dead
/// time beyond it (up to `max`). The dead times of a round are fitted in parallel. Returns
/// every fit with its dead time and score, and the index of the best (the first of equal
/// scores); when none could be fitted, the last error (or an empty search of `model`).
fn fit_around<T: Send>(
    coarse_pick: usize,
    current: usize,
    max: usize,
    model: &str,
    fit: impl Fn(usize) -> Result<Option<(f64, T)>, DiagnoseError> + Sync,
) -> Result<DelayFits<T>, DiagnoseError> {
    use rayon::prelude::*;
    let mut tried: Vec<usize> = Vec::new();
    let mut fits: Vec<(usize, f64, T)> = Vec::new();
    let mut want: Vec<usize> =
        (coarse_pick.saturating_sub(1)..=(coarse_pick + 1).min(max)).collect();
    let mut last_error = None;
    // index in `fits` of the best fit so far
    let mut best: Option<usize> = None;
    loop {
        let batch: Vec<usize> = want
            .drain(..)
            .filter(|&d| d != current && !tried.contains(&d))
            .collect();
        tried.extend(&batch);
        let results: Vec<_> = batch.into_par_iter().map(|d| (d, fit(d))).collect();
        for (d, r) in results {
            match r {
                Ok(Some((f, t))) => {
                    if best.is_none_or(|b| f > fits[b].1) {
                        best = Some(fits.len());
                    }
                    fits.push((d, f, t));
                }
                Ok(None) => {}
                Err(e) => last_error = Some(e),
            }
        }
        let Some(pick) = best.map(|b| fits[b].0) else {
            break;
        };
        // the best at an end of the fitted range: the dead time beyond it decides
        let (lo, hi) = (tried.iter().min(), tried.iter().max());
        let next = pick + 1 + usize::from(pick + 1 == current);
        if Some(&pick) == hi && next <= max && !tried.contains(&next) {
            want.push(next);
        } else if Some(&pick) == lo && pick > 0 {
            let prev = pick - 1 - usize::from(pick - 1 == current && pick >= 2);
            if prev != current && !tried.contains(&prev) {
                want.push(prev);
            }
        }
        if want.is_empty() {
            break;
        }
    }
    // every dead time tried failed: the last failure says why
    match best {
        Some(i) => Ok((fits, i)),
        None => Err(last_error.unwrap_or_else(|| DiagnoseError::EmptySearch {
            model: model.to_string(),
        })),
    }
}

/// Half-width, in coarse (span/20) steps, of the box around the current valve that the
/// warm-started dead-time scan ([`warm_delay`]) evaluates at every dead time.
const WARM_BOX: i32 = 3;

/// The dead-time extension of a model whose identifier has no sums path (EARX, EARMAX, HARX:
/// every node is a recursion over the record, 5-10 times an ARX node), warm-started from the
/// current valve instead of grids over the whole admissible region:
///
/// * the scan: at every dead time in `0..=max_delay`, the nodes of the scan's coarse lattice
///   (span/20) within [`WARM_BOX`] coarse steps of the current valve, and the current valve;
/// * the dead times around the scan's best other than the current one (the range grows by one
///   while the best is at its end, as with grids): each by pattern searches down to the
///   grid's fine step, from the scan's best node at that dead time and from the current valve.
///
/// The full grids (a coarse grid per dead time, then a coarse-to-fine grid at each dead time
/// around the best) took 0.44-1.4 s of a diagnosis on these identifiers; these models are
/// only reached in the forward selection, where the current valve already carries the
/// disturbance's correction of the valve (measured figures:
/// docs/decisions/2026-11-27-diagnose-speed.md).
fn warm_delay(ctx: &Context<'_>) -> Result<Extension, DiagnoseError> {
    use rayon::prelude::*;
    let started = Instant::now();
    let spec = ctx.baseline_spec;
    let entry = spec.stiction;
    let crit = ctx.options.search.criterion;
    let fine = ctx.options.search.grid.step();
    let coarse = (ctx.span / 20.0).max(fine);
    let start = current_valve(ctx);
    let snap = |v: f64, step: f64| (v / step).round() * step;
    let mut boxed: Vec<Vec<f64>> = vec![start.clone()];
    for i in -WARM_BOX..=WARM_BOX {
        for j in -WARM_BOX..=WARM_BOX {
            let p = vec![
                snap(start[0], coarse) + f64::from(i) * coarse,
                snap(start[1], coarse) + f64::from(j) * coarse,
            ];
            if entry.admissible(&p, ctx.span) {
                boxed.push(p);
            }
        }
    }
    // (dead time, best score, its node, every node) at every dead time that could be
    // evaluated
    let scan: Vec<(usize, f64, Vec<f64>, Vec<grid_search::NodeFit>)> = (0..=ctx.options.max_delay)
        .into_par_iter()
        .filter_map(|d| {
            let id = spec.identifier(d).ok()?;
            let nodes = grid_search::evaluate_nodes(
                entry,
                id.as_ref(),
                ctx.problem,
                &ctx.options.search,
                boxed.clone(),
            )
            .ok()?;
            let best = nodes
                .iter()
                .filter(|n| n.score(crit).is_finite())
                .max_by(|a, b| a.score(crit).total_cmp(&b.score(crit)))?;
            Some((d, best.score(crit), best.params.clone(), nodes))
        })
        .collect();
    let scores: Vec<(usize, f64)> = scan.iter().map(|(d, f, _, _)| (*d, *f)).collect();
    let current = spec.fixed_delay();
    let coarse_pick = pick_delay(&scores, current);
    let max = ctx.options.max_delay.max(coarse_pick);
    // the pattern searches at dead time `d`: from the scan's best node there and from the
    // current valve
    let search = |d: usize| -> Result<Vec<grid_search::NodeFit>, DiagnoseError> {
        let identifier = spec.identifier(d)?;
        let evaluator =
            Evaluator::new(entry, identifier.as_ref(), ctx.problem, &ctx.options.search)?;
        // the scan's nodes at this dead time: the same model, not evaluated again
        if let Some((_, _, _, scanned)) = scan.iter().find(|(k, _, _, _)| *k == d) {
            evaluator.remember(scanned.iter().cloned());
        }
        let mut nodes = axis_search(ctx, &evaluator, &start)?;
        if let Some((_, _, p, _)) = scan.iter().find(|(k, _, _, _)| *k == d) {
            let p: Vec<f64> = p.iter().map(|v| snap(*v, fine)).collect();
            if p != start {
                nodes.extend(axis_search(ctx, &evaluator, &p)?);
            }
        }
        Ok(nodes)
    };
    let best_of = |nodes: &[grid_search::NodeFit]| {
        nodes
            .iter()
            .map(|n| n.score(crit))
            .filter(|f| f.is_finite())
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let (mut fits, i) = fit_around(coarse_pick, current, max, entry.name, |d| {
        let nodes = search(d)?;
        let f = best_of(&nodes);
        Ok(f.is_finite().then_some((f, nodes)))
    })?;
    let (best, _, nodes) = fits.swap_remove(i);
    at_delay(ctx, (spec.identifier(best)?, best), nodes, scores, started)
}

/// The extension with `identifier` at dead time `delay` (the baseline's valve model), from
/// the nodes searched there and the current valve, with the scan's `scores`.
fn at_delay(
    ctx: &Context<'_>,
    (identifier, delay): (Box<dyn LinearIdentifier>, usize),
    nodes: Vec<grid_search::NodeFit>,
    scores: Vec<(usize, f64)>,
    started: Instant,
) -> Result<Extension, DiagnoseError> {
    let spec = ctx.baseline_spec;
    let fit = LocalFit {
        entry: spec.stiction,
        linear: spec.linear,
        identifier,
        delay,
        started,
    };
    let mut ext = from_current_valve(ctx, fit, nodes)?;
    ext.fitted.delay_scan = Some(grid_search::DelayScan { delay, scores });
    Ok(ext)
}

/// The dead-time extension of a model whose valve has three parameters (`kano-asym`,
/// `kano-char`: the characteristic's shape searched with S and J): every
/// dead time in `0..=max_delay` scored at the current valve, then a pattern search from the
/// current valve at the best dead time other than the current one, instead of a coarse grid
/// per dead time and a full grid at the best. The grids took 1.0 s of a 2.2 s diagnosis (suite
/// seed 7400, disturbance and asymmetric valve).
fn local_delay(ctx: &Context<'_>) -> Result<Extension, DiagnoseError> {
    let started = Instant::now();
    let spec = ctx.baseline_spec;
    let entry = spec.stiction;
    let crit = ctx.options.search.criterion;
    let start = current_valve(ctx);
    let scores: Vec<(usize, f64)> = (0..=ctx.options.max_delay)
        .filter_map(|d| {
            let id = spec.identifier(d).ok()?;
            let nodes = grid_search::evaluate_nodes(
                entry,
                id.as_ref(),
                ctx.problem,
                &ctx.options.search,
                vec![start.clone()],
            )
            .ok()?;
            let f = nodes.first()?.score(crit);
            f.is_finite().then_some((d, f))
        })
        .collect();
    let best = pick_delay(&scores, spec.fixed_delay());
    let identifier = spec.identifier(best)?;
    let evaluator = Evaluator::new(entry, identifier.as_ref(), ctx.problem, &ctx.options.search)?;
    let nodes = axis_search(ctx, &evaluator, &start)?;
    drop(evaluator);
    at_delay(ctx, (identifier, best), nodes, scores, started)
}

inventory::submit! {
    CauseEntry {
        name: "time-delay",
        role: crate::Role::Extension,
        description: "unmodelled dead time: the delay is estimated (0..=max_delay) and the model refitted",
        statistic: "largest cross-correlation of the prediction residuals with past MV, in standard errors",
        build: || Box::new(TimeDelay),
    }
}
