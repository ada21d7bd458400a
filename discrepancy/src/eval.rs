//! Node evaluation outside the rectangular grid of `grid-search`: a local pattern search that
//! starts from a given node (so the extended model nests the baseline exactly), and the
//! assembly of a [`Quantification`] from the nodes it visited.
//!
//! One node is evaluated exactly as `grid_search::quantify` does: the stiction model under the
//! search's initialization → identification on `[valid_from, split)` → one-step prediction and
//! free-run simulation scored by F_PV on `[split, N)`.

use std::time::Instant;

use grid_search::{NodeEvaluator, NodeFit, SearchOptions};
use linear_id::{IdentifierEntry, LinearIdentifier};
use stiction_models::ModelEntry;

use crate::{Context, DiagnoseError, Extension, Fitted};

/// An extended model found by a local search rather than a grid: the stiction model, the
/// identifier (at the dead time `delay`) and when the extension started.
pub(crate) struct LocalFit {
    pub entry: &'static ModelEntry,
    pub linear: &'static IdentifierEntry,
    pub identifier: Box<dyn LinearIdentifier>,
    /// The dead time `identifier` was built for.
    pub delay: usize,
    pub started: Instant,
}

impl LocalFit {
    /// The extension from every node the searches visited: a quantification over `nodes`
    /// (its notes say the search started at `start`, not a full grid), compared with the
    /// nested reference's best validation fit `ref_fit` (one extra parameter).
    pub fn extension(
        self,
        ctx: &Context<'_>,
        nodes: Vec<NodeFit>,
        start: &str,
        ref_fit: f64,
        reference: &str,
    ) -> Result<Extension, DiagnoseError> {
        let count = nodes.len();
        let result = grid_search::quantify_from_surface(
            self.entry,
            self.identifier.as_ref(),
            ctx.problem,
            &ctx.options.search,
            nodes,
            grid_search::GridPlan::Exhaustive {
                step: ctx.options.search.grid.step(),
            },
            vec![format!(
                "{count} nodes of a local search started at {start}, not a full grid"
            )],
        )?;
        let fitted = Fitted {
            stiction: self.entry,
            linear: self.linear.name,
            identifier: self.identifier,
            delay: self.delay,
            delay_scan: None,
            result,
            elapsed_ms: self.started.elapsed().as_secs_f64() * 1e3,
        };
        let lr = ctx.lr(ref_fit, fitted.fit_val());
        Ok(Extension {
            fitted,
            lr,
            extra_params: 1,
            reference: reference.into(),
        })
    }
}

/// A node evaluator with a boxed identifier's model.
pub(crate) type Evaluator<'a> = NodeEvaluator<'a, dyn LinearIdentifier + 'a>;

/// Which parameter vectors a search may evaluate.
pub(crate) type Admit = dyn Fn(&[f64]) -> bool + Sync;

/// A pattern search over a model's parameters, started at a given node: each round tries a
/// step along every direction (both signs), moves to the best improvement, and halves the
/// step down to `fine` when nothing improves. Nodes are evaluated by a
/// [`grid_search::NodeEvaluator`], exactly as grid nodes are.
pub(crate) struct PatternSearch<'a> {
    pub entry: &'static ModelEntry,
    pub options: &'a SearchOptions,
    pub span: f64,
    pub coarse: f64,
    pub fine: f64,
    /// Directions (unit moves in parameter space) tried at each step.
    pub directions: Vec<Vec<f64>>,
    /// Maximum number of node evaluations.
    pub budget: usize,
    /// Per-parameter step multipliers (steps and the rounding lattice of parameter `i` are
    /// `scales[i]` times the OP-unit ones); empty: all 1.
    pub scales: Vec<f64>,
    /// Which nodes may be evaluated; `None`: the model's `admissible` for `span`.
    pub admit: Option<&'a Admit>,
}

impl PatternSearch<'_> {
    /// The search from `start`, its nodes evaluated by `evaluator` (built for `entry`, the
    /// search's identifier and data: shared by searches and lattices on the same model, its
    /// checks and OP's index built once).
    pub fn run(
        &self,
        evaluator: &Evaluator<'_>,
        start: &[f64],
    ) -> Result<Vec<NodeFit>, DiagnoseError> {
        let crit = self.options.criterion;
        let eval = |nodes: Vec<Vec<f64>>| evaluator.evaluate(nodes);
        let mut visited = eval(vec![start.to_vec()])?;
        let mut best = 0usize;
        let mut step = self.coarse.max(self.fine);
        loop {
            let centre = visited[best].params.clone();
            let candidates: Vec<Vec<f64>> = self
                .directions
                .iter()
                .flat_map(|d| [1.0, -1.0].map(|sgn| (d, sgn)))
                .map(|(d, sgn)| {
                    centre
                        .iter()
                        .zip(d)
                        .enumerate()
                        .map(|(i, (c, di))| {
                            let k = self.scales.get(i).copied().unwrap_or(1.0);
                            let lattice = self.fine * k;
                            ((c + sgn * step * k * di) / lattice).round() * lattice
                        })
                        .collect::<Vec<f64>>()
                })
                .filter(|p| match self.admit {
                    Some(admit) => admit(p),
                    None => self.entry.admissible(p, self.span),
                })
                .filter(|p| {
                    !visited
                        .iter()
                        .any(|v| v.params.iter().zip(p).all(|(a, b)| (a - b).abs() < 1e-9))
                })
                .collect();
            let fresh = eval(candidates)?;
            let start_len = visited.len();
            visited.extend(fresh);
            let current = visited[best].score(crit);
            let improved = (start_len..visited.len())
                .filter(|&i| visited[i].score(crit) > current + 1e-9)
                .max_by(|&a, &b| visited[a].score(crit).total_cmp(&visited[b].score(crit)));
            match improved {
                Some(i) => best = i,
                None if step > self.fine * 1.000_001 => step = (step / 2.0).max(self.fine),
                None => break,
            }
            if visited.len() >= self.budget {
                break;
            }
        }
        Ok(visited)
    }
}
