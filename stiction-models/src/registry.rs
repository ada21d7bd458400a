//! The registry of stiction models, filled by `inventory::submit!` in each model's crate.

use crate::{Bound, StictionError, StictionModel};

/// One parameter of a registered model.
#[derive(Debug, Clone, Copy)]
pub struct ParamSpec {
    /// Name as used in `--param NAME=V` and in JSON.
    pub name: &'static str,
    /// One-line meaning.
    pub meaning: &'static str,
    /// Value when not given.
    pub default: f64,
    /// The upper end of the range a grid search scans, as a fraction of the OP span (the lower
    /// end is 0): a grid over OP span `span` takes values in `[0, max_span_fraction * span]`,
    /// and [`ModelEntry::admissible`] rejects values above it. 1 for a width that may reach
    /// the whole span (`S`), 0.5 for one bounded by half of it (He's `fd <= fs`, `fs + fd <=
    /// span`), 0 for a parameter the grid does not scan (it stays at its default, e.g.
    /// `kano-char`'s shape `a`).
    pub max_span_fraction: f64,
    /// The valid values, checked whenever a model is built.
    pub bound: Bound,
}

/// A constraint between parameters that a grid must respect.
#[derive(Debug, Clone, Copy)]
pub enum Constraint {
    /// `param <= bound` (e.g. `J <= S`).
    AtMost {
        /// The constrained parameter.
        param: &'static str,
        /// The parameter that bounds it.
        bound: &'static str,
    },
    /// The sum of these parameters is at most the OP span (e.g. `D + J_up <= span`).
    SumAtMostSpan {
        /// The parameters summed.
        params: &'static [&'static str],
    },
}

impl Constraint {
    /// Whether `values` (in the order of `params`) satisfy the constraint for OP span `span`.
    pub fn holds(&self, params: &[ParamSpec], values: &[f64], span: f64) -> bool {
        let get = |name: &str| {
            params
                .iter()
                .position(|p| p.name == name)
                .and_then(|i| values.get(i).copied())
        };
        match self {
            Constraint::AtMost { param, bound } => match (get(param), get(bound)) {
                (Some(p), Some(b)) => p <= b,
                _ => false,
            },
            Constraint::SumAtMostSpan { params: names } => {
                let sum: Option<f64> = names.iter().map(|n| get(n)).sum();
                sum.is_some_and(|s| s <= span * (1.0 + 1e-12))
            }
        }
    }

    /// The constraint in words (`J <= S`).
    pub fn describe(&self) -> String {
        match self {
            Constraint::AtMost { param, bound } => format!("{param} <= {bound}"),
            Constraint::SumAtMostSpan { params } => format!("{} <= span", params.join(" + ")),
        }
    }
}

/// Builds a checked model from a parameter vector (in the order of [`ModelEntry::params`]).
pub type BuildFn = fn(&[f64]) -> Result<Box<dyn StictionModel>, StictionError>;

/// A registered stiction model: what `stiction models` lists and what a grid search builds.
#[derive(Debug)]
pub struct ModelEntry {
    /// Registered name, equal to the typetag tag.
    pub name: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// Parameters, in the order `build` takes them.
    pub params: &'static [ParamSpec],
    /// Constraints between parameters.
    pub constraints: &'static [Constraint],
    /// Build a checked model from a parameter vector.
    pub build: BuildFn,
}

inventory::collect!(ModelEntry);

impl ModelEntry {
    /// Build from `NAME=value` pairs (names case-sensitive first, then case-insensitive);
    /// missing parameters take their default.
    pub fn build_named(
        &self,
        pairs: &[(String, f64)],
    ) -> Result<Box<dyn StictionModel>, StictionError> {
        let mut values: Vec<f64> = self.params.iter().map(|p| p.default).collect();
        for (name, value) in pairs {
            let idx = self
                .params
                .iter()
                .position(|p| p.name == name)
                .or_else(|| {
                    self.params
                        .iter()
                        .position(|p| p.name.eq_ignore_ascii_case(name))
                })
                .ok_or_else(|| StictionError::UnknownParameter {
                    model: self.name,
                    name: name.clone(),
                    known: self.param_names().join(", "),
                })?;
            values[idx] = *value;
        }
        (self.build)(&values)
    }

    /// Parameter names in order.
    pub fn param_names(&self) -> Vec<&'static str> {
        self.params.iter().map(|p| p.name).collect()
    }

    /// Whether a parameter vector lies in the valid region for OP span `span`: every value in
    /// `[0, max_span_fraction * span]` and every constraint satisfied.
    pub fn admissible(&self, values: &[f64], span: f64) -> bool {
        values.len() == self.params.len()
            && self
                .params
                .iter()
                .zip(values)
                .all(|(p, &v)| v >= 0.0 && v <= p.max_span_fraction * span * (1.0 + 1e-12))
            && self
                .constraints
                .iter()
                .all(|c| c.holds(self.params, values, span))
    }
}

/// Every registered model, sorted by name.
pub fn registry() -> Vec<&'static ModelEntry> {
    let mut v: Vec<_> = inventory::iter::<ModelEntry>.into_iter().collect();
    v.sort_by_key(|e| e.name);
    v
}

/// The registered model called `name`, or an error listing the registered names.
pub fn find_model(name: &str) -> Result<&'static ModelEntry, StictionError> {
    let all = registry();
    all.iter()
        .find(|e| e.name == name)
        .or_else(|| all.iter().find(|e| e.name.eq_ignore_ascii_case(name)))
        .copied()
        .ok_or_else(|| StictionError::UnknownModel {
            name: name.to_string(),
            known: all.iter().map(|e| e.name).collect::<Vec<_>>().join(", "),
        })
}
