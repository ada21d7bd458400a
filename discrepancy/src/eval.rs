//! Node evaluation outside the rectangular grid of `grid-search`: a local pattern search that
//! starts from a given node (so the extended model nests the baseline exactly), and the
//! assembly of a [`Quantification`] from the nodes it visited.
//!
//! One node is evaluated exactly as `grid_search::quantify` does: the stiction model under the
//! search's initialization → identification on `[valid_from, split)` → one-step prediction and
//! free-run simulation scored by F_PV on `[split, N)`.

use std::collections::{HashMap, HashSet};
use std::sync::Mutex;
use std::time::Instant;

use grid_search::{NodeEvaluator, NodeFit, Problem, SearchError, SearchOptions};
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
            data: None,
        })
    }
}

/// A node evaluator with a boxed identifier's model that remembers every node it evaluated:
/// the lattices and pattern searches of one extension share it and revisit nodes (a pattern
/// search starts at the best node of the lattice before it, and its first steps land on that
/// lattice), so a node already evaluated on this model is returned from memory (a node's
/// fits depend on its parameters only: the same bits).
pub(crate) struct Evaluator<'a> {
    inner: NodeEvaluator<'a, dyn LinearIdentifier + 'a>,
    seen: Mutex<HashMap<Vec<u64>, NodeFit>>,
}

impl<'a> Evaluator<'a> {
    /// [`NodeEvaluator::new`].
    pub fn new(
        entry: &'a ModelEntry,
        identifier: &'a (dyn LinearIdentifier + 'a),
        problem: Problem<'a>,
        options: &SearchOptions,
    ) -> Result<Self, SearchError> {
        Ok(Evaluator {
            inner: NodeEvaluator::new(entry, identifier, problem, options)?,
            seen: Mutex::new(HashMap::new()),
        })
    }

    /// Remember `fits`, nodes evaluated on the same model (entry, identifier, data and
    /// options) elsewhere, e.g. by [`grid_search::evaluate_nodes`].
    pub fn remember(&self, fits: impl IntoIterator<Item = NodeFit>) {
        let mut seen = self.seen.lock().unwrap_or_else(|e| e.into_inner());
        for f in fits {
            seen.insert(f.params.iter().map(|v| v.to_bits()).collect(), f);
        }
    }

    /// [`NodeEvaluator::evaluate`]: the nodes not evaluated before on this model evaluated
    /// (in parallel, in the given order), the others from memory; in the given order.
    pub fn evaluate(&self, nodes: Vec<Vec<f64>>) -> Result<Vec<NodeFit>, SearchError> {
        // the same work check as for the whole list
        self.inner.check_work(nodes.len())?;
        let key = |p: &[f64]| p.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
        let fresh: Vec<Vec<f64>> = {
            let seen = self.seen.lock().unwrap_or_else(|e| e.into_inner());
            let mut asked = HashSet::new();
            nodes
                .iter()
                .filter(|p| !seen.contains_key(&key(p)) && asked.insert(key(p)))
                .cloned()
                .collect()
        };
        let fits = if fresh.is_empty() {
            Vec::new()
        } else {
            self.inner.evaluate(fresh)?
        };
        let mut seen = self.seen.lock().unwrap_or_else(|e| e.into_inner());
        for f in fits {
            seen.insert(key(&f.params), f);
        }
        Ok(nodes
            .iter()
            .filter_map(|p| seen.get(&key(p)).cloned())
            .collect())
    }
}

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

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Every field (NaN fits compare equal; a float's shortest round-trip text is its value).
    fn shown(nodes: Vec<NodeFit>) -> String {
        format!("{nodes:?}")
    }

    /// Nodes asked for again (within one call, across calls, and remembered from an
    /// evaluation elsewhere) come back as a fresh evaluation gives them, in the order asked.
    #[test]
    fn remembered_nodes_are_the_evaluated_ones() {
        let sim = datasets::simulate::Scenario {
            valve: Box::new(
                stiction_models::Kano::params()
                    .s(9.0)
                    .j(3.0)
                    .check()
                    .unwrap(),
            ),
            samples: 1000,
            ..datasets::simulate::Scenario::default()
        }
        .simulate()
        .unwrap();
        let problem = Problem {
            op: &sim.op,
            pv: &sim.pv,
            mv: None,
        };
        let options = SearchOptions::default();
        let entry = stiction_models::find_model("kano").unwrap();
        for linear in ["arx", "earx"] {
            let combination = run::Combination::named("kano", linear).unwrap();
            let identifier = combination.identifier(0).unwrap();
            let fresh = |nodes: Vec<Vec<f64>>| {
                grid_search::evaluate_nodes(entry, identifier.as_ref(), problem, &options, nodes)
                    .unwrap()
            };
            let evaluator = Evaluator::new(entry, identifier.as_ref(), problem, &options).unwrap();
            evaluator.remember(fresh(vec![vec![8.0, 2.0]]));
            let first = vec![vec![9.0, 3.0], vec![6.0, 1.0], vec![9.0, 3.0]];
            assert_eq!(
                shown(evaluator.evaluate(first.clone()).unwrap()),
                shown(fresh(first))
            );
            let again = vec![
                vec![6.0, 1.0],
                vec![8.0, 2.0],
                vec![4.0, 4.0],
                vec![9.0, 2.0],
                vec![9.0, 3.0],
            ];
            assert_eq!(
                shown(evaluator.evaluate(again.clone()).unwrap()),
                shown(fresh(again))
            );
        }
    }
}
