//! The search itself.

use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use linear_id::{fit_pv, LinearFit, LinearIdentifier, WindowStats};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use stiction_models::{
    run_valve_indexed, run_valve_with, Initialization, ModelEntry, OpIndex, RunInfo, StictionModel,
    ValveScratch,
};

use crate::skip::Skip;
use crate::trust::{self, Doubt, NEGLIGIBLE_S};
use crate::{grid, SearchError};

mod nodes;
mod summary;

use nodes::*;
use summary::*;

/// Which PV estimate ranks the nodes.
///
/// Decided by measurement (`docs/CRITERION.md`): in closed loop a free-run simulation fit can
/// prefer S = J = 0, because OP carries feedback information about the noise in PV, while the
/// one-step prediction peaks at the truth. Both fits are always computed and reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Criterion {
    /// One-step-ahead prediction with measured PV lags (default).
    #[default]
    Prediction,
    /// Free-run simulation of the deterministic part from MV.
    Simulation,
}

impl Criterion {
    /// The other criterion (reported beside the ranking one).
    pub fn other(self) -> Criterion {
        match self {
            Criterion::Prediction => Criterion::Simulation,
            Criterion::Simulation => Criterion::Prediction,
        }
    }

    /// `prediction` or `simulation`.
    pub fn label(self) -> &'static str {
        match self {
            Criterion::Prediction => "prediction",
            Criterion::Simulation => "simulation",
        }
    }

    /// `one-step prediction` or `free-run simulation`.
    pub fn describe(self) -> &'static str {
        match self {
            Criterion::Prediction => "one-step prediction",
            Criterion::Simulation => "free-run simulation",
        }
    }
}

/// How the grid is laid out.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum GridPlan {
    /// Every node at `step` (OP units) over the model's whole admissible region.
    Exhaustive {
        /// Grid step, OP units.
        step: f64,
    },
    /// A grid at `coarse`, then every node at `fine` within `radius` coarse steps of the best
    /// coarse node (spec §5.6).
    CoarseToFine {
        /// Coarse step, OP units.
        coarse: f64,
        /// Fine step, OP units.
        fine: f64,
        /// Half-width of the refinement box, in coarse steps.
        radius: f64,
    },
}

impl GridPlan {
    /// The default grid for OP span `span` (what `stiction quantify` uses without `--step`):
    /// coarse at span/40, refined within two coarse steps of the best coarse node at 0.1 % of
    /// valve span, or at the largest of 0.05, 0.02, 0.01, ... that is at most a fifth of the
    /// coarse step when the span is under 20 %. Coarse-to-fine finds the exhaustive grid's
    /// optimum on the paper's loops (`tests/search.rs`).
    ///
    /// Relative to the span: the 0.1 is 0.1 % of a 0-100 valve span; for an OP span above 100
    /// (OP not in %, its valve span unknown) the fine step is 0.1 % of the OP span, so the
    /// number of nodes is bounded whatever OP's units (41²/2 coarse nodes and a refinement box
    /// of at most 101² for two parameters).
    pub fn for_span(span: f64) -> GridPlan {
        let coarse = span / 40.0;
        let fine = if span > 100.0 {
            span / 1000.0
        } else {
            nice_step_at_most((coarse / 5.0).min(0.1))
        };
        if coarse <= fine {
            GridPlan::Exhaustive { step: fine }
        } else {
            GridPlan::CoarseToFine {
                coarse,
                fine,
                radius: 2.0,
            }
        }
    }

    /// The finest step of the plan.
    pub fn step(&self) -> f64 {
        match *self {
            GridPlan::Exhaustive { step } => step,
            GridPlan::CoarseToFine { fine, .. } => fine,
        }
    }
}

/// Options of [`quantify`].
///
/// | field | default | meaning |
/// |-------|---------|---------|
/// | `init` | In.3 | handling of the valve's unknown initial state (paper §2.4) |
/// | `grid` | exhaustive, step 0.1 | [`GridPlan`] |
/// | `split` | 2/3 | fraction of the record used for identification |
/// | `criterion` | prediction | [`Criterion`] ranking the nodes |
/// | `confidence` | 0.95 | level of the likelihood-ratio region behind [`Interval`] |
/// | `max_nodes` | 200 000 | node budget per grid stage |
/// | `max_work` | 5e10 | work budget per grid stage (nodes × samples × cost per sample) |
/// | `node_fits` | criterion | fits computed at every node ([`NodeFits`]) |
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SearchOptions {
    /// Initialization strategy.
    pub init: Initialization,
    /// Grid layout.
    pub grid: GridPlan,
    /// Identification fraction, in `(0, 1)`.
    pub split: f64,
    /// Ranking criterion.
    pub criterion: Criterion,
    /// Confidence level of the interval, in `(0, 1)`.
    pub confidence: f64,
    /// Node budget per grid stage ([`crate::budget`]): a grid over it is
    /// [`SearchError::Budget`], never an allocation failure.
    pub max_nodes: usize,
    /// Work budget per grid stage ([`crate::budget::check_work`]): nodes × the record's
    /// samples × the identifier's cost per sample; over it is [`SearchError::Work`].
    pub max_work: f64,
    /// Which fits the fast path computes at every node ([`NodeFits`]).
    pub node_fits: NodeFits,
}

/// Which fits every grid node gets on the fast path. The best node is always refitted with
/// both (and F_MV when MV is measured); only the surface of the other nodes differs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NodeFits {
    /// The criterion's fits only (default): under [`Criterion::Prediction`] the free-run
    /// simulation, an O(N) recursion the ranking does not read, is not run, and the surface's
    /// `sim_id` / `sim_val` are NaN (the best node's are computed); F_MV (an O(N) pass, when
    /// MV is measured) is `None` but at the best node. Nothing a search reports reads them:
    /// the ranking, the region, the fit without stiction and the doubts are the criterion's or
    /// the best node's.
    #[default]
    Criterion,
    /// Both criteria's fits and F_MV at every node (for a surface written out,
    /// `quantify --surface`).
    Both,
}

impl Default for SearchOptions {
    fn default() -> Self {
        SearchOptions {
            init: Initialization::In3,
            grid: GridPlan::Exhaustive { step: 0.1 },
            split: 2.0 / 3.0,
            criterion: Criterion::Prediction,
            confidence: 0.95,
            max_nodes: crate::budget::DEFAULT_MAX_NODES,
            max_work: crate::budget::DEFAULT_MAX_WORK,
            node_fits: NodeFits::Criterion,
        }
    }
}

impl GridPlan {
    /// [`GridPlan::for_span`] of OP's span (max - min).
    pub fn for_op(op: &[f64]) -> GridPlan {
        let (lo, hi) = summary::min_max(op);
        GridPlan::for_span(hi - lo)
    }
}

/// The data of one loop registration.
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a> {
    /// Controller output.
    pub op: &'a [f64],
    /// Process variable.
    pub pv: &'a [f64],
    /// Measured valve position, when available (enables F_MV).
    pub mv: Option<&'a [f64]>,
}

impl<'a> Problem<'a> {
    /// OP and PV, without a measured valve position.
    pub fn new(op: &'a [f64], pv: &'a [f64]) -> Self {
        Problem { op, pv, mv: None }
    }
}

/// Fit indices of an evaluated node (all in %, the paper's squared-norm F of eq. 9).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Fits {
    /// One-step prediction, identification window.
    pub pred_id: f64,
    /// One-step prediction, validation window.
    pub pred_val: f64,
    /// Free-run simulation, identification window (NaN on a surface node the fast path did not
    /// simulate, see [`NodeFits`]).
    pub sim_id: f64,
    /// Free-run simulation, validation window (NaN as `sim_id`).
    pub sim_val: f64,
    /// F_MV (eq. 14) over the samples used, when MV is measured.
    pub mv: Option<f64>,
    /// First sample used (where MV no longer depends on the valve's initial state).
    pub valid_from: usize,
    /// In.3 fell back to In.2 for this node.
    pub init_fell_back: bool,
}

impl Fits {
    /// The (identification, validation) F_PV under criterion `c`.
    pub fn rank(&self, c: Criterion) -> (f64, f64) {
        match c {
            Criterion::Prediction => (self.pred_id, self.pred_val),
            Criterion::Simulation => (self.sim_id, self.sim_val),
        }
    }
}

/// One grid node and what became of it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NodeFit {
    /// The model's own parameters (order of its registry entry).
    pub params: Vec<f64>,
    /// Equivalent S.
    #[serde(rename = "S")]
    pub s: f64,
    /// Equivalent J.
    #[serde(rename = "J")]
    pub j: f64,
    /// The fits, or why the node was skipped.
    pub outcome: Result<Fits, Skip>,
}

impl NodeFit {
    /// Validation fit under `c`, `-inf` when skipped.
    pub fn score(&self, c: Criterion) -> f64 {
        self.outcome
            .as_ref()
            .map_or(f64::NEG_INFINITY, |f| f.rank(c).1)
    }
}

/// The set of nodes not significantly worse than the best, and the ranges of S and J over it.
///
/// Criterion: the likelihood-ratio region of nonlinear least squares on the validation
/// residuals, `n_val · ln(SSE_node / SSE_best) <= χ²_p(confidence)` with `p` the number of
/// stiction parameters. It assumes white Gaussian residuals, which the one-step predictor's
/// are approximately when the model is right; treat it as a guide to how well the data pin
/// S and J down, not as an exact probability.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interval {
    /// Smallest and largest S in the region.
    #[serde(rename = "S")]
    pub s: [f64; 2],
    /// Smallest and largest J in the region.
    #[serde(rename = "J")]
    pub j: [f64; 2],
    /// Nodes in the region.
    pub nodes: usize,
    /// The region's fit threshold (validation F_PV, %).
    pub fit_threshold: f64,
    /// Confidence level used.
    pub confidence: f64,
}

/// The result of [`quantify`].
#[derive(Debug)]
pub struct Quantification {
    /// The best stiction model.
    pub stiction: Box<dyn StictionModel>,
    /// Its equivalent S (OP units).
    pub s: f64,
    /// Its equivalent J (OP units).
    pub j: f64,
    /// The linear model identified at the best node.
    pub linear: LinearFit,
    /// Fits at the best node.
    pub fits: Fits,
    /// Ranking criterion used.
    pub criterion: Criterion,
    /// Uncertainty of S and J.
    pub interval: Interval,
    /// Every node, in grid order (for surfaces).
    pub surface: Vec<NodeFit>,
    /// Estimated MV over the whole record at the best node.
    pub mv_est: Vec<f64>,
    /// PV estimate (the criterion's) from `fits.valid_from` on; `NaN` before.
    pub pv_est: Vec<f64>,
    /// One-step prediction of PV from `fits.valid_from` on; `NaN` before.
    pub pv_pred: Vec<f64>,
    /// Free-run simulation of PV from `fits.valid_from` on; `NaN` before.
    pub pv_sim: Vec<f64>,
    /// First validation sample.
    pub split_index: usize,
    /// Grid layout used and its finest step.
    pub grid: GridPlan,
    /// OP span (max - min), the upper bound of the grid.
    pub span: f64,
    /// Nodes evaluated (including refinement) and skipped.
    pub nodes_evaluated: usize,
    /// Nodes skipped (valve never moves, singular regression, unstable model, ...).
    pub nodes_skipped: usize,
    /// Best validation fit among the evaluated nodes with negligible stiction
    /// (equivalent S <= [`NEGLIGIBLE_S`]), if any could be evaluated.
    pub fit_no_stiction: Option<f64>,
    /// Wall time of the search, ms.
    pub elapsed_ms: f64,
    /// What limits the estimate, in words (empty when S and J are well determined): the
    /// [`doubts`](Self::doubts) as text, then the caller's notes.
    pub warnings: Vec<String>,
    /// What limits the estimate, typed (see [`crate::trust`]).
    pub doubts: Vec<Doubt>,
    /// Fast path only: nodes whose ARX was solved from sums, and nodes that fell back to the
    /// QR (poorly conditioned normal equations, see [`linear_id::GRAM_PIVOT_TOL`]).
    pub arx_from_sums: [usize; 2],
}

impl Quantification {
    /// The validation fit of the best node under `c`.
    pub fn fits_score(&self, c: Criterion) -> f64 {
        self.fits.rank(c).1
    }

    /// What the estimate says about the valve and how far to trust it.
    pub fn verdict(&self) -> trust::Verdict {
        trust::assess(self.s, &self.doubts)
    }
}

/// How the grid nodes are evaluated. Both give the same surface: the same MV at every node,
/// the same skip reasons, fits equal to round-off (`tests/fast_path.rs`); the best node is
/// always refitted by the sample path, so the reported model and series are the same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum NodePath {
    /// Events and segment sums (default): the valve run interval by interval
    /// ([`stiction_models::run_valve_indexed`]); MV's window statistics in one pass (the
    /// "hardly moves" check and ARX's input mean); ARX from normal equations assembled from
    /// prefix sums and two fused passes over the node's rows (with a per-node QR fallback
    /// when poorly conditioned), whose residual pass also gives the identification fit
    /// ([`linear_id::ArxOutputSums::identify_window_with`]); the validation fit in one
    /// vectorised pass; the other identifiers by batches of nodes
    /// ([`LinearIdentifier::identify_predict_many`]: the recursive ones and PARSIM-K's
    /// predictions four nodes at a time in SIMD lanes); the free run in independent chunks.
    #[default]
    Fast,
    /// Sample by sample, as before issue 16: every node's valve stepped sample by sample, the
    /// identifier's own `identify`, a full prediction and simulation.
    Sample,
}

/// Quantify stiction: search the grid of `entry`'s parameters with `identifier` as the linear
/// block, and return the best node with its fits, uncertainty and the whole surface.
///
/// `progress`, when given, is called with (nodes done, nodes planned) from worker threads.
pub fn quantify<I: LinearIdentifier + ?Sized>(
    entry: &ModelEntry,
    identifier: &I,
    problem: Problem<'_>,
    options: &SearchOptions,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> Result<Quantification, SearchError> {
    quantify_with(
        entry,
        identifier,
        problem,
        options,
        progress,
        NodePath::Fast,
    )
}

/// [`quantify`] with the node evaluation chosen: [`NodePath::Sample`] is the sample-by-sample
/// path (kept for comparison and benchmarks); both give the same result.
pub fn quantify_with<I: LinearIdentifier + ?Sized>(
    entry: &ModelEntry,
    identifier: &I,
    problem: Problem<'_>,
    options: &SearchOptions,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
    path: NodePath,
) -> Result<Quantification, SearchError> {
    let start = Instant::now();
    let prep = prepare(entry, identifier, problem, options, path)?;
    let crit = options.criterion;
    let interrupted = || {
        if stiction_models::cancel::requested() {
            Err(SearchError::Interrupted)
        } else {
            Ok(())
        }
    };
    let done = AtomicUsize::new(0);
    let work = |nodes: usize, what: &'static str| {
        crate::budget::check_work(nodes, problem.op.len(), identifier, options.max_work, what)
    };
    let eval_all = |nodes: Vec<Vec<f64>>| -> Vec<NodeFit> {
        let planned = nodes.len();
        done.store(0, Ordering::Relaxed);
        prep.ctx.evaluate_all(nodes, &|| {
            if let Some(p) = progress {
                p(done.fetch_add(1, Ordering::Relaxed) + 1, planned);
            }
        })
    };
    let max_nodes = options.max_nodes;
    let mut notes = Vec::new();
    let surface = match options.grid {
        GridPlan::Exhaustive { step } => {
            let n = crate::budget::check_grid(entry, prep.span, step, max_nodes, "grid")?;
            work(n, "grid")?;
            eval_all(grid::nodes(entry, prep.span, step))
        }
        GridPlan::CoarseToFine {
            coarse,
            fine,
            radius,
        } => {
            let n = crate::budget::check_grid(entry, prep.span, coarse, max_nodes, "coarse grid")?;
            work(n, "coarse grid")?;
            let mut all = eval_all(grid::nodes(entry, prep.span, coarse));
            if let Some(b) = best_index(&all, crit) {
                let bounds: Vec<(f64, f64)> = all[b]
                    .params
                    .iter()
                    .map(|&c| (c - radius * coarse, c + radius * coarse))
                    .collect();
                let fine = match crate::budget::fit_refinement(
                    entry, prep.span, fine, coarse, &bounds, max_nodes,
                ) {
                    Some((f, coarsened)) => {
                        if coarsened {
                            notes.push(format!(
                                "refinement step coarsened to {f} to stay within the node budget of {max_nodes}"
                            ));
                        }
                        f
                    }
                    None => coarse,
                };
                // the coarse nodes by their lattice key: a linear scan per fine node was
                // quadratic (72 % of a diagnosis that refits a 3-parameter valve's grid)
                let seen: std::collections::HashSet<Vec<i64>> =
                    all.iter().map(|nf| node_key(&nf.params, fine)).collect();
                let fine_nodes: Vec<Vec<f64>> =
                    grid::nodes_in_box(entry, prep.span, fine, Some(&bounds))
                        .into_iter()
                        .filter(|p| !seen.contains(&node_key(p, fine)))
                        .collect();
                work(fine_nodes.len(), "refinement")?;
                all.extend(eval_all(fine_nodes));
            }
            all
        }
    };
    interrupted()?;
    finish(&prep, surface, options.grid, start, notes)
}

/// Evaluate an explicit list of nodes (parameter vectors of `entry`) exactly as [`quantify`]
/// evaluates grid nodes, in parallel, in the given order. For searches of one's own (local
/// pattern searches, refinements) that then call [`quantify_from_surface`].
pub fn evaluate_nodes<I: LinearIdentifier + ?Sized>(
    entry: &ModelEntry,
    identifier: &I,
    problem: Problem<'_>,
    options: &SearchOptions,
    nodes: Vec<Vec<f64>>,
) -> Result<Vec<NodeFit>, SearchError> {
    NodeEvaluator::new(entry, identifier, problem, options)?.evaluate(nodes)
}

/// [`evaluate_nodes`] for searches that evaluate a few nodes at a time on the same problem
/// (pattern searches, lattices in stages): the data's checks and OP's event index are built
/// once, not at every call. Each node is evaluated as [`evaluate_nodes`] evaluates it (the
/// same bits).
pub struct NodeEvaluator<'a, I: ?Sized> {
    prep: Prepared<'a, I>,
    identifier: &'a I,
    samples: usize,
    max_work: f64,
}

impl<'a, I: LinearIdentifier + ?Sized> NodeEvaluator<'a, I> {
    /// Check the data and options (the errors of [`evaluate_nodes`]) and index OP.
    pub fn new(
        entry: &'a ModelEntry,
        identifier: &'a I,
        problem: Problem<'a>,
        options: &SearchOptions,
    ) -> Result<Self, SearchError> {
        Ok(NodeEvaluator {
            prep: prepare(entry, identifier, problem, options, NodePath::Fast)?,
            identifier,
            samples: problem.op.len(),
            max_work: options.max_work,
        })
    }

    /// The work budget's check of `count` nodes on this problem ([`crate::budget::check_work`]).
    pub fn check_work(&self, count: usize) -> Result<(), SearchError> {
        crate::budget::check_work(count, self.samples, self.identifier, self.max_work, "nodes")
    }

    /// Evaluate `nodes` in parallel, in the given order (within the work budget).
    pub fn evaluate(&self, nodes: Vec<Vec<f64>>) -> Result<Vec<NodeFit>, SearchError> {
        self.check_work(nodes.len())?;
        let fits = self.prep.ctx.evaluate_all(nodes, &|| {});
        if stiction_models::cancel::requested() {
            return Err(SearchError::Interrupted);
        }
        Ok(fits)
    }
}

/// The result of a search whose nodes were evaluated with [`evaluate_nodes`]: selects the best
/// node (same ranking and tie-breaking as [`quantify`]), refits it for its series, and computes
/// the interval and warnings. `grid` describes the search in the result; `notes` are added to
/// its warnings.
pub fn quantify_from_surface<I: LinearIdentifier + ?Sized>(
    entry: &ModelEntry,
    identifier: &I,
    problem: Problem<'_>,
    options: &SearchOptions,
    surface: Vec<NodeFit>,
    grid: GridPlan,
    notes: Vec<String>,
) -> Result<Quantification, SearchError> {
    let start = Instant::now();
    let prep = prepare(entry, identifier, problem, options, NodePath::Sample)?;
    finish(&prep, surface, grid, start, notes)
}

struct Prepared<'a, I: ?Sized> {
    ctx: Ctx<'a, I>,
    span: f64,
    confidence: f64,
    criterion: Criterion,
}

impl<I: LinearIdentifier + ?Sized> Ctx<'_, I> {
    fn evaluate_all(&self, nodes: Vec<Vec<f64>>, tick: &(dyn Fn() + Sync)) -> Vec<NodeFit> {
        let node_fit = |params: Vec<f64>, outcome: Result<Fits, Skip>| {
            let eq = (self.entry.build)(&params)
                .map(|m| m.equivalent())
                .unwrap_or(stiction_models::Equivalent {
                    s: f64::NAN,
                    j: f64::NAN,
                });
            tick();
            NodeFit {
                params,
                s: eq.s,
                j: eq.j,
                outcome,
            }
        };
        // an identifier with fast paths (ARX) keeps the node-by-node path: its fits come from
        // sums, without a prediction
        if self.path == NodePath::Fast && self.identifier.fast_paths().is_none() {
            let per_batch: Vec<Vec<NodeFit>> = nodes
                .par_chunks(BATCH)
                .map_init(BatchScratch::default, |scratch, batch| {
                    let outcomes = if stiction_models::cancel::requested() {
                        vec![Err(Skip::Cancelled); batch.len()]
                    } else {
                        self.evaluate_batch(batch, scratch)
                    };
                    batch
                        .iter()
                        .cloned()
                        .zip(outcomes)
                        .map(|(p, o)| node_fit(p, o))
                        .collect()
                })
                .collect();
            return per_batch.into_iter().flatten().collect();
        }
        nodes
            .into_par_iter()
            .map_init(Scratch::default, |scratch, params| {
                if stiction_models::cancel::requested() {
                    return node_fit(params, Err(Skip::Cancelled));
                }
                let outcome = match self.path {
                    NodePath::Fast => self.evaluate_fast(&params, scratch),
                    NodePath::Sample => self.evaluate(&params, scratch, false).map(|(f, _)| f),
                };
                node_fit(params, outcome)
            })
            .collect()
    }
}

/// Check the data and options; everything a node evaluation needs.
fn prepare<'a, I: LinearIdentifier + ?Sized>(
    entry: &'a ModelEntry,
    identifier: &'a I,
    problem: Problem<'a>,
    options: &SearchOptions,
    path: NodePath,
) -> Result<Prepared<'a, I>, SearchError> {
    let (op, pv) = (problem.op, problem.pv);
    if op.len() != pv.len() || problem.mv.is_some_and(|m| m.len() != op.len()) {
        return Err(SearchError::LengthMismatch {
            op: op.len(),
            pv: pv.len(),
        });
    }
    check_signal("OP", op)?;
    check_signal("PV", pv)?;
    if let Some(mv) = problem.mv {
        check_signal("MV", mv)?;
    }
    if !(options.split > 0.0 && options.split < 1.0) {
        return Err(SearchError::InvalidOption {
            name: "split",
            value: options.split,
            expected: "a fraction strictly between 0 and 1".into(),
        });
    }
    if !(options.confidence > 0.0 && options.confidence < 1.0) {
        return Err(SearchError::InvalidOption {
            name: "confidence",
            value: options.confidence,
            expected: "a level strictly between 0 and 1".into(),
        });
    }
    let n = op.len();
    let needed = 3 * (identifier.min_samples().max(10));
    if n < needed {
        return Err(SearchError::TooFewSamples {
            needed,
            got: n,
            why: format!("identification and validation with {}", identifier.name()),
        });
    }
    let (lo, hi) = min_max(op);
    if hi - lo <= 0.0 {
        return Err(SearchError::Constant {
            signal: "OP",
            value: lo,
        });
    }
    let (plo, phi) = min_max(pv);
    if phi - plo <= 0.0 {
        return Err(SearchError::Constant {
            signal: "PV",
            value: plo,
        });
    }
    crate::degenerate::check_identifiable(op, pv)?;
    let span = hi - lo;
    let reversal_band = 0.01 * span;
    if reversals(op, reversal_band) == 0 {
        return Err(SearchError::NotIdentifiable {
            reason: format!(
                "OP never reverses direction by more than 1 % of its span ({reversal_band:.3}); S is the band OP must cross to reverse the valve"
            ),
        });
    }
    for (name, step) in match options.grid {
        GridPlan::Exhaustive { step } => vec![("step", step)],
        GridPlan::CoarseToFine {
            coarse,
            fine,
            radius,
        } => {
            vec![("coarse step", coarse), ("step", fine), ("radius", radius)]
        }
    } {
        if !(step.is_finite() && step > 0.0) {
            return Err(SearchError::InvalidOption {
                name: if name == "step" { "step" } else { "grid" },
                value: step,
                expected: format!("{name} > 0 (OP units)"),
            });
        }
    }
    for (name, step) in crate::budget::plan_steps(&options.grid) {
        crate::budget::check_step_against_span(step, span, name)?;
    }
    let ctx = Ctx {
        entry,
        identifier,
        problem,
        init: options.init,
        split_index: ((n as f64) * options.split).floor() as usize,
        path,
        simulate: options.criterion == Criterion::Simulation || options.node_fits == NodeFits::Both,
        node_mv: options.node_fits == NodeFits::Both,
        index: match path {
            NodePath::Fast => Some(OpIndex::new(op)?),
            NodePath::Sample => None,
        },
        arx_sums: match path {
            NodePath::Fast => identifier.fast_paths().and_then(|f| f.output_sums(pv)),
            NodePath::Sample => None,
        },
        val_ss: {
            let val = &pv[((n as f64) * options.split).floor() as usize..];
            let mean = val.iter().sum::<f64>() / val.len().max(1) as f64;
            val.iter().map(|v| (v - mean) * (v - mean)).sum()
        },
        gram_count: [AtomicUsize::new(0), AtomicUsize::new(0)],
        output: std::sync::OnceLock::new(),
    };
    Ok(Prepared {
        ctx,
        span,
        confidence: options.confidence,
        criterion: options.criterion,
    })
}

/// Select, refit and summarise.
fn finish<I: LinearIdentifier + ?Sized>(
    prep: &Prepared<'_, I>,
    mut surface: Vec<NodeFit>,
    grid: GridPlan,
    start: Instant,
    notes: Vec<String>,
) -> Result<Quantification, SearchError> {
    let ctx = &prep.ctx;
    let entry = ctx.entry;
    let crit = prep.criterion;
    let pv = ctx.problem.pv;
    let n = pv.len();
    let span = prep.span;
    // Grid order: lexicographic in the parameters (fixes tie-breaking).
    surface.sort_by(|a, b| {
        a.params
            .iter()
            .zip(&b.params)
            .map(|(x, y)| x.total_cmp(y))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    });

    let skipped = surface.iter().filter(|n| n.outcome.is_err()).count();
    let Some(best) = best_index(&surface, crit) else {
        // the most frequent reason, by its sentence (ties: the first in alphabetical order)
        let mut counts: HashMap<String, (usize, &Skip)> = HashMap::new();
        for nf in &surface {
            if let Err(r) = &nf.outcome {
                counts.entry(r.to_string()).or_insert((0, r)).0 += 1;
            }
        }
        let reason = counts
            .into_iter()
            .max_by(|a, b| a.1 .0.cmp(&b.1 .0).then(b.0.cmp(&a.0)))
            .map_or(crate::NoNode::EmptyGrid, |(_, (_, r))| {
                crate::NoNode::Skipped(r.clone())
            });
        return Err(SearchError::NoValidNode {
            nodes: surface.len(),
            reason,
        });
    };

    // Refit the best node to get the model and the series (deterministic: same as in the grid).
    let best_params = surface[best].params.clone();
    let (fits, full) = ctx
        .evaluate(&best_params, &mut Scratch::default(), true)
        .map_err(|r| SearchError::NoValidNode {
            nodes: surface.len(),
            reason: crate::NoNode::RefitFailed(r),
        })?;
    let ev = full.ok_or(SearchError::NoValidNode {
        nodes: surface.len(),
        reason: crate::NoNode::NotRefitted,
    })?;
    let stiction = (entry.build)(&best_params)?;
    let eq = stiction.equivalent();
    let interval = interval(
        &surface,
        best,
        crit,
        pv,
        ctx.split_index,
        prep.confidence,
        entry.params.len(),
    );
    let k0 = fits.valid_from;
    let pad = |x: &[f64]| {
        let mut v = vec![f64::NAN; n];
        v[k0..].copy_from_slice(x);
        v
    };
    let (pv_pred, pv_sim) = (pad(&ev.pred), pad(&ev.sim));
    let pv_est = match crit {
        Criterion::Prediction => pv_pred.clone(),
        Criterion::Simulation => pv_sim.clone(),
    };
    let fit_no_stiction = surface
        .iter()
        .filter(|nf| nf.s <= NEGLIGIBLE_S + 1e-12)
        .filter_map(|nf| nf.outcome.as_ref().ok().map(|f| f.rank(crit).1))
        .filter(|f| f.is_finite())
        .reduce(f64::max);
    let doubts = doubts(&surface, &interval, &fits, span, crit, skipped);
    let mut warnings: Vec<String> = doubts.iter().map(ToString::to_string).collect();
    warnings.extend(notes);
    Ok(Quantification {
        warnings,
        doubts,
        stiction,
        s: eq.s,
        j: eq.j,
        linear: ev.linear,
        fits,
        criterion: crit,
        interval,
        nodes_evaluated: surface.len(),
        nodes_skipped: skipped,
        surface,
        mv_est: ev.mv,
        pv_est,
        pv_pred,
        pv_sim,
        split_index: ctx.split_index,
        grid,
        span,
        fit_no_stiction,
        elapsed_ms: start.elapsed().as_secs_f64() * 1e3,
        arx_from_sums: [
            ctx.gram_count[0].load(Ordering::Relaxed),
            ctx.gram_count[1].load(Ordering::Relaxed),
        ],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// S whose region reaches 0.8 of the OP span seen is called a lower bound, and only then.
    #[test]
    fn s_at_the_op_span_is_a_doubt_that_names_a_lower_bound() {
        let fits = Fits {
            pred_id: 90.0,
            pred_val: 90.0,
            sim_id: 90.0,
            sim_val: 90.0,
            mv: None,
            valid_from: 0,
            init_fell_back: false,
        };
        let interval = |lo: f64, hi: f64| Interval {
            s: [lo, hi],
            j: [0.0, 0.1],
            nodes: 2,
            fit_threshold: 89.0,
            confidence: 0.95,
        };
        let at = |iv: &Interval, span: f64| {
            doubts(&[], iv, &fits, span, Criterion::Prediction, 0)
                .into_iter()
                .find(|d| matches!(d, Doubt::SAtSpan { .. }))
        };
        // 2.41-2.46 of an OP span of 2.71: the record cannot show more
        let d = at(&interval(2.41, 2.46), 2.71).expect("a lower bound");
        assert!(!d.weakens_s());
        assert!(d.to_string().contains("more OP movement"), "{d}");
        // 2.41-2.46 of 9.4: the OP moved far more than the band
        assert!(at(&interval(2.41, 2.46), 9.4).is_none());
        assert!(at(&interval(0.0, 0.0), 0.0).is_none());
    }

    #[test]
    fn chi2_table_and_fallback_agree() {
        assert_eq!(chi2_quantile(2, 0.95), 5.991);
        // Wilson–Hilferty is within 1 % of the table.
        let wh = {
            let z = normal_quantile(0.95);
            let k = 2.0f64;
            k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3)
        };
        assert!((wh - 5.991).abs() / 5.991 < 0.01, "{wh}");
        assert!((normal_quantile(0.975) - 1.95996).abs() < 1e-3);
    }

    #[test]
    fn reversals_count_direction_changes_beyond_the_band() {
        let ramp: Vec<f64> = (0..100).map(|k| k as f64).collect();
        assert_eq!(reversals(&ramp, 1.0), 0);
        let tri: Vec<f64> = (0..400).map(|k| ((k % 100) as f64 - 50.0).abs()).collect();
        assert_eq!(reversals(&tri, 1.0), 7);
        let noisy: Vec<f64> = (0..100)
            .map(|k| k as f64 + if k % 2 == 0 { 0.4 } else { 0.0 })
            .collect();
        assert_eq!(reversals(&noisy, 1.0), 0);
    }

    #[test]
    fn default_plan_uses_round_fine_steps() {
        assert_eq!(nice_step_at_most(0.1), 0.1);
        assert_eq!(nice_step_at_most(0.047), 0.02);
        assert_eq!(nice_step_at_most(0.05), 0.05);
        assert!((nice_step_at_most(0.0099) - 0.005).abs() < 1e-15);
        match GridPlan::for_span(22.6) {
            GridPlan::CoarseToFine {
                coarse,
                fine,
                radius,
            } => {
                assert!((coarse - 0.565).abs() < 1e-12);
                assert_eq!((fine, radius), (0.1, 2.0));
            }
            other => panic!("{other:?}"),
        }
        match GridPlan::for_span(9.4) {
            GridPlan::CoarseToFine { fine, .. } => assert_eq!(fine, 0.02),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn distinct_counts_up_to_the_cap() {
        assert_eq!(distinct_at_least(&[1.0; 16], 3), 1);
        assert_eq!(
            distinct_at_least(&[[1.0; 16], [2.0; 16], [1.0; 16]].concat(), 3),
            2
        );
        let mut x = vec![5.0; 40];
        x[37] = 6.0;
        x[39] = 7.0;
        assert_eq!(distinct_at_least(&x, 3), 3);
        assert_eq!(distinct_at_least(&[1.0, 1.0, 1.0], 3), 1);
        assert_eq!(distinct_at_least(&[1.0, 2.0, 1.0, 2.0], 3), 2);
        assert_eq!(distinct_at_least(&[1.0, 2.0, 3.0, 4.0], 3), 3);
    }

    #[test]
    fn three_distinct_agrees_with_the_count() {
        // small alphabets, so that two-valued arrays are common; lengths across the lane width
        let mut state = 12345u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as usize
        };
        let alphabet = [0.0, -0.0, 1.5, -2.0, 1e300, f64::NAN, 7.25];
        for _ in 0..20_000 {
            let len = next() % 40;
            let k = 1 + next() % alphabet.len();
            let x: Vec<f64> = (0..len).map(|_| alphabet[next() % k]).collect();
            assert_eq!(three_distinct(&x), distinct_at_least(&x, 3) >= 3, "{x:?}");
        }
        // a stuck valve's MV: long constant stretches, a third value anywhere or nowhere
        for _ in 0..5_000 {
            let k = 1 + next() % alphabet.len();
            let mut x = Vec::new();
            for _ in 0..1 + next() % 4 {
                let v = alphabet[next() % k];
                x.extend(std::iter::repeat_n(v, next() % 30));
            }
            assert_eq!(three_distinct(&x), distinct_at_least(&x, 3) >= 3, "{x:?}");
        }
    }
}
