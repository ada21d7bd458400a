//! The cause `valve-characteristic`: an installed flow characteristic (equal-percentage,
//! quick-opening) between the valve position and the process, which a linear model after the
//! stiction model cannot represent.

use std::time::Instant;

use grid_search::NodeFit;
use rayon::prelude::*;
use stiction_models::{find_model, MAX_SHAPE};

use crate::eval::{Admit, Evaluator, LocalFit, PatternSearch};
use crate::{Cause, CauseEntry, Context, DiagnoseError, Evidence, Extension};

/// Largest |a| the extension searches: `e^6 ≈ 400` is the gain ratio over the whole span, more
/// than any installed valve (equal-percentage rangeability 50 is `a = 3.9`).
const SEARCH_SHAPE: f64 = 6.0;
/// The coarse (S, J) lattice the free search starts from, in the search's coarse steps
/// (span/20): every other node of the search's lattice. At the search's own coarse step the
/// lattice was 60-70 % of the extension's time, and the extension is tested again at every
/// step of the forward selection (docs/decisions/2026-11-27-diagnose-speed.md); the free
/// searches from its best nodes start at the coarse step.
const LATTICE_STEPS: f64 = 2.0;

/// |a| of the coarse lattice the free search starts from (rangeability e³ = 20).
const SHAPE_START: f64 = 3.0;
/// Lags (after the dead time) of the residual's correlation with the squared opening.
const LAGS: usize = 5;
/// A characteristic is negligible when the local gain changes by at most this factor over the
/// range OP covers (its 5th to 95th percentile): the nested reference of the extension is the
/// best valve with a negligible characteristic, as `no-stiction`'s is the best valve with
/// negligible S (a tiny curvature that only helps re-fit S and J is not a characteristic).
pub const NEGLIGIBLE_GAIN_RATIO: f64 = 1.1;

/// The 5th-to-95th percentile range of `x`.
fn travel(x: &[f64]) -> f64 {
    let mut v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if v.len() < 2 {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let at = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    at(0.95) - at(0.05)
}

/// An installed flow characteristic: the process sees a static monotone function of the valve
/// position, so its gain depends on the opening. Extend `kano` to `kano-char` (S, J and the
/// shape `a` of `f(x) = 100 (e^(a x/100) − 1)/(e^a − 1)`, OP in % of span), a Hammerstein chain
/// stiction → characteristic → linear.
///
/// The extension is a pattern search started at the baseline's `(S, J, a = 0)`; its nested
/// reference is the best valve with a negligible characteristic (the local gain changing by at
/// most `NEGLIGIBLE_GAIN_RATIO` over OP's 5-95 % range) the same search finds (searched
/// from the start and again from the projection of the optimum), so one extra parameter. Statistic: the largest
/// correlation, in standard errors, of the baseline's prediction residual with the squared
/// deviation of the estimated valve position from its mean at lags `delay + 1 ..= delay + 5`
/// (the term a curved characteristic adds to a linear model).
#[derive(Debug, Clone, Copy, Default)]
pub struct ValveCharacteristic;

/// `(z, lag)`: the largest |correlation| · √n of the validation prediction residuals with
/// `(MV(t − lag) − mean)²`.
fn curvature_z(ctx: &Context<'_>) -> (f64, usize) {
    let q = &ctx.baseline.result;
    let (pv, pred, mv) = (ctx.problem.pv, &q.pv_pred, &q.mv_est);
    let n = pv.len().min(pred.len()).min(mv.len());
    let from = q.split_index.min(n);
    let m = if from < n {
        mv[from..n].iter().sum::<f64>() / (n - from) as f64
    } else {
        0.0
    };
    let mut best = (0.0, 0);
    for lag in ctx.baseline.delay + 1..=ctx.baseline.delay + LAGS {
        let rows: Vec<(f64, f64)> = (from.max(lag)..n)
            .map(|t| (pv[t] - pred[t], (mv[t - lag] - m).powi(2)))
            .filter(|(r, z)| r.is_finite() && z.is_finite())
            .collect();
        let k = rows.len() as f64;
        if k < 10.0 {
            continue;
        }
        let (mr, mz) = rows
            .iter()
            .fold((0.0, 0.0), |(a, b), (r, z)| (a + r / k, b + z / k));
        let (mut srz, mut srr, mut szz) = (0.0, 0.0, 0.0);
        for (r, z) in &rows {
            srz += (r - mr) * (z - mz);
            srr += (r - mr) * (r - mr);
            szz += (z - mz) * (z - mz);
        }
        if srr > 0.0 && szz > 0.0 {
            let zval = (srz / (srr * szz).sqrt()).abs() * k.sqrt();
            if zval > best.0 {
                best = (zval, lag);
            }
        }
    }
    best
}

/// The dead times next to the current model's when the diagnosis estimated it (a
/// `time-delay` extension: its scan is kept), within `0..=max_delay`; none otherwise (a dead
/// time the user gave is kept).
fn estimated_neighbours(ctx: &Context<'_>) -> Vec<usize> {
    let d = ctx.baseline.delay;
    if ctx.baseline.delay_scan.is_none() {
        return Vec::new();
    }
    [
        d.checked_sub(1),
        Some(d + 1).filter(|&k| k <= ctx.options.max_delay),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// The directions of the searches over (S, J, a): the shape, S, J, and S with J.
const DIRECTIONS: [[f64; 3]; 4] = [
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [1.0, 1.0, 0.0],
];

/// The extension's pattern searches of `kano-char`: steps from `coarse` halved to `fine`,
/// the shape's steps scaled by `scales`.
struct Searcher<'c, 'a> {
    ctx: &'c Context<'a>,
    entry: &'static stiction_models::ModelEntry,
    coarse: f64,
    fine: f64,
    scales: Vec<f64>,
}

impl Searcher<'_, '_> {
    /// A search with `evaluator` from `from` along `directions`, at most `budget` nodes,
    /// those `admit` lets in.
    fn run(
        &self,
        evaluator: &Evaluator<'_>,
        directions: Vec<Vec<f64>>,
        from: &[f64],
        budget: usize,
        admit: &Admit,
    ) -> Result<Vec<NodeFit>, DiagnoseError> {
        PatternSearch {
            entry: self.entry,
            options: &self.ctx.options.search,
            span: self.ctx.span,
            coarse: self.coarse,
            fine: self.fine,
            directions,
            budget,
            scales: self.scales.clone(),
            admit: Some(admit),
        }
        .run(evaluator, from)
    }
}

/// The pair's model searched at a dead time from a valve: every node visited.
type AtDelay<'f> = dyn Fn(usize, &[f64]) -> Result<Vec<NodeFit>, DiagnoseError> + Sync + 'f;
/// A search's best valve and its fit.
type BestOf<'f> = dyn Fn(&[NodeFit]) -> Option<(Vec<f64>, f64)> + 'f;

/// The best of the pair's model searched so far: its valve, fit, dead time and nodes, and
/// the nested reference's fit.
struct Best {
    valve: Vec<f64>,
    fit: f64,
    delay: usize,
    nodes: Vec<NodeFit>,
    ref_fit: f64,
}

/// The pair's model over the dead time: the dead times next to the estimated one
/// ([`estimated_neighbours`]), then further while the best is at an end, each searched by
/// `at_delay` from the best valve so far; `best_of` gives a search's best valve and fit,
/// `negligible` the reference's best fit over a search's nodes and a fit so far.
fn over_delays(
    ctx: &Context<'_>,
    mut best: Best,
    at_delay: &AtDelay<'_>,
    best_of: &BestOf<'_>,
    negligible: &(dyn Fn(&[NodeFit], f64) -> f64 + '_),
) -> Best {
    let mut want = estimated_neighbours(ctx);
    let mut tried = vec![best.delay];
    while !want.is_empty() {
        tried.extend(&want);
        let from = best.valve.clone();
        let found: Vec<(usize, Result<Vec<NodeFit>, DiagnoseError>)> = std::mem::take(&mut want)
            .into_par_iter()
            .map(|d| (d, at_delay(d, &from)))
            .collect();
        // a dead time that cannot be fitted (no stable node) is not a candidate
        for (d, found) in found {
            let Ok(found) = found else { continue };
            best.ref_fit = negligible(&found, best.ref_fit);
            if let Some((valve, fit)) = best_of(&found).filter(|b| b.1 > best.fit) {
                (best.fit, best.valve, best.delay, best.nodes) = (fit, valve, d, found);
            }
        }
        let (lo, hi) = (tried.iter().min(), tried.iter().max());
        if Some(&best.delay) == hi && best.delay < ctx.options.max_delay {
            want.push(best.delay + 1);
        } else if Some(&best.delay) == lo && best.delay > 0 {
            want.push(best.delay - 1);
        }
        want.retain(|d| !tried.contains(d));
    }
    best
}

impl Cause for ValveCharacteristic {
    fn name(&self) -> &'static str {
        "valve-characteristic"
    }
    fn applies(&self, ctx: &Context<'_>) -> bool {
        ctx.baseline.stiction.name == "kano"
    }
    fn evidence(&self, ctx: &Context<'_>) -> Evidence {
        let (z, lag) = curvature_z(ctx);
        Evidence {
            statistic: z,
            text: format!(
                "The prediction residuals correlate with the squared deviation of the estimated valve position from its mean {z:.1} standard errors at lag {lag} (a gain that changes with the opening)."
            ),
        }
    }
    fn extend(&self, ctx: &Context<'_>) -> Result<Extension, DiagnoseError> {
        let started = Instant::now();
        let entry = find_model("kano-char")?;
        let kano = find_model("kano")?;
        let (linear, identifier) = ctx.identifier_with(entry)?;
        let q = &ctx.baseline.result;
        let fine = ctx.options.search.grid.step();
        let coarse = (ctx.span / 20.0).max(fine);
        let snap = |v: f64| (v / fine).round() * fine;
        let span = ctx.span;
        let limit = SEARCH_SHAPE.min(MAX_SHAPE);
        let admit = move |p: &[f64]| {
            p.len() == 3 && kano.admissible(&p[..2], span) && p[2].abs() <= limit + 1e-9
        };
        // |a| of a negligible characteristic over the range OP covers
        let negligible = 100.0 * NEGLIGIBLE_GAIN_RATIO.ln() / travel(ctx.problem.op).max(fine);
        let admit_ref = move |p: &[f64]| admit(p) && p[2].abs() <= negligible + 1e-9;
        // the shape moves by 1 per coarse step of S, by fine/coarse at the finest
        let scales = vec![1.0, 1.0, 1.0 / coarse];
        let searcher = Searcher {
            ctx,
            entry,
            coarse,
            fine,
            scales,
        };
        let search_with = |evaluator: &Evaluator<'_>, d, from: &[f64], budget, admit: &Admit| {
            searcher.run(evaluator, d, from, budget, admit)
        };
        let evaluator =
            Evaluator::new(entry, identifier.as_ref(), ctx.problem, &ctx.options.search)?;
        let search = |directions: Vec<Vec<f64>>, from: &[f64], budget: usize, admit: &Admit| {
            search_with(&evaluator, directions, from, budget, admit)
        };
        let crit = ctx.options.search.criterion;
        let best_of = |nodes: &[NodeFit]| {
            nodes
                .iter()
                .max_by(|a, b| a.score(crit).total_cmp(&b.score(crit)))
                .map(|n| (n.params.clone(), n.score(crit)))
        };
        let dirs: Vec<Vec<f64>> = DIRECTIONS.iter().map(|d| d.to_vec()).collect();
        let start = vec![snap(q.s), snap(q.j.min(q.s)), 0.0];
        // The reference: the best valve with a negligible characteristic near the baseline's
        // estimate.
        let lin = search(dirs.clone(), &start, 150, &admit_ref)?;
        let (lin_best, lin_fit) = best_of(&lin).ok_or_else(|| DiagnoseError::EmptySearch {
            model: "kano-char".into(),
        })?;
        // Free search from the linear optimum and from a shape each way (the fit is often
        // flat in `a` near 0 while S and J are off).
        // A coarse (S, J) lattice at a = ±3 (the baseline's S can be far off when the gain
        // changes with the opening: 19.1 for a true 9.05), then free searches from the
        // linear optimum and from the best coarse node of each sign.
        let mut coarse_nodes = Vec::new();
        for a0 in [SHAPE_START, -SHAPE_START] {
            for (s0, j0) in grid_search::grid::nodes(kano, span, LATTICE_STEPS * coarse)
                .into_iter()
                .map(|p| (p[0], p[1]))
            {
                coarse_nodes.push(vec![s0, j0, a0]);
            }
        }
        let lattice = evaluator.evaluate(coarse_nodes)?;
        let best_sign = |sign: f64| {
            lattice
                .iter()
                .filter(|n| n.params[2] * sign > 0.0)
                .max_by(|a, b| a.score(crit).total_cmp(&b.score(crit)))
                .filter(|n| n.score(crit).is_finite())
                .map(|n| n.params.clone())
        };
        let mut starts = vec![lin_best.clone()];
        starts.extend(best_sign(1.0));
        starts.extend(best_sign(-1.0));
        let mut free = Vec::new();
        for st in starts.iter().filter(|p| admit(p)) {
            free.extend(search(dirs.clone(), st, 200, &admit)?);
        }
        free.extend(lattice);
        let (free_best, free_fit) = best_of(&free).unwrap_or((lin_best.clone(), lin_fit));
        // Fair reference: the reference search again from the optimum's linear projection.
        let lin2 = search(
            dirs.clone(),
            &[free_best[0], free_best[1], 0.0],
            150,
            &admit_ref,
        )?;
        drop(evaluator);
        let mut nodes = lin;
        nodes.extend(free);
        nodes.extend(lin2);
        // every node visited with a negligible characteristic counts for the reference
        let negligible_best = |nodes: &[NodeFit], from: f64| {
            nodes
                .iter()
                .filter(|n| admit_ref(&n.params))
                .map(|n| n.score(crit))
                .fold(from, f64::max)
        };
        let ref_fit = negligible_best(&nodes, lin_fit).max(ctx.baseline.fit_val());
        let delay = ctx.baseline.delay;
        // A dead time the model estimated (`time-delay`) was chosen with a linear
        // characteristic: the pair's model searches it again with the curvature free, as one
        // model. At dead time `d`: searches from the best valve so far and from its linear
        // projection (the nested reference there: a negligible characteristic at any dead
        // time searched counts, so the test stays one extra parameter, the shape).
        let at_delay = |d: usize, from: &[f64]| -> Result<Vec<NodeFit>, DiagnoseError> {
            let id = ctx.combination(entry, linear, d).identifier(d)?;
            let ev = Evaluator::new(entry, id.as_ref(), ctx.problem, &ctx.options.search)?;
            let mut v = search_with(&ev, dirs.clone(), from, 200, &admit)?;
            let projection = [from[0], from[1], 0.0];
            v.extend(search_with(
                &ev,
                dirs.clone(),
                &projection,
                150,
                &admit_ref,
            )?);
            Ok(v)
        };
        let found = over_delays(
            ctx,
            Best {
                valve: free_best,
                fit: free_fit,
                delay,
                nodes,
                ref_fit,
            },
            &at_delay,
            &best_of,
            &negligible_best,
        );
        let (delay, nodes, ref_fit) = (found.delay, found.nodes, found.ref_fit);
        let identifier = if delay == ctx.baseline.delay {
            identifier
        } else {
            ctx.combination(entry, linear, delay).identifier(delay)?
        };
        LocalFit {
            entry,
            linear,
            identifier,
            delay,
            started,
        }
        .extension(ctx, nodes, "the baseline's estimate (S, J, a = 0)", ref_fit, "best valve with a negligible characteristic (gain change <= 10 % over OP's range) of the same search")
    }
}

inventory::submit! {
    CauseEntry {
        name: "valve-characteristic",
        role: crate::Role::Extension,
        description: "installed flow characteristic (equal-percentage, quick-opening): kano -> kano-char (S, J, shape a)",
        statistic: "largest correlation of the prediction residual with the squared valve-position deviation, in standard errors",
        build: || Box::new(ValveCharacteristic),
    }
}
