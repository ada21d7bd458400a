//! The contract's quantify object (`docs/CLI.md`): what `quantify --json` prints and what every
//! `compare`, `diagnose`, `trend` and `batch` result carries, as one serialisable type.
//!
//! Non-finite numbers are written as `null` (JSON has no NaN) and read back as NaN. S, J and
//! the stiction parameters are rounded to the grid's resolution ([`on_grid`]).

use std::collections::BTreeMap;

use grid_search::{Criterion, GridPlan};
use linear_id::OrderValue;
use serde::{Deserialize, Deserializer, Serialize};
use stiction_models::Initialization;

use crate::Fitted;

/// `x` rounded to the resolution of a grid with step `step` (three decimals finer than the
/// step), so JSON says `0.3`, not `0.30000000000000004`, for a node at three steps of 0.1.
pub fn on_grid(x: f64, step: f64) -> f64 {
    if !(x.is_finite() && step.is_finite() && step > 0.0) {
        return x;
    }
    let decimals = (-step.log10()).ceil().clamp(0.0, 12.0) as i32 + 3;
    let f = 10f64.powi(decimals);
    let r = (x * f).round() / f;
    if r.is_finite() {
        r
    } else {
        x
    }
}

/// `x` to `digits` decimals; `None` when not finite.
pub(crate) fn rounded(x: f64, digits: i32) -> Option<f64> {
    x.is_finite().then(|| {
        let f = 10f64.powi(digits);
        (x * f).round() / f
    })
}

/// Reads `null` as NaN (the writer's non-finite number).
pub fn null_as_nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// The fit under the criterion that did not rank the nodes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OtherFit {
    /// That criterion.
    pub kind: Criterion,
    /// Its F_PV on the identification window, % (6 decimals).
    pub id: Option<f64>,
    /// Its F_PV on the validation window, % (6 decimals).
    pub val: Option<f64>,
}

/// One dead time of a scan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DelayScore {
    /// Dead time, samples.
    pub delay: usize,
    /// Validation F_PV at that dead time, % (6 decimals).
    pub fit_pv_val: Option<f64>,
}

/// The likelihood-ratio region of (S, J).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IntervalRecord {
    /// Range of S.
    #[serde(rename = "S")]
    pub s: [f64; 2],
    /// Range of J.
    #[serde(rename = "J")]
    pub j: [f64; 2],
    /// Nodes in the region.
    pub nodes: usize,
    /// The fit a node needs to be in the region, % (6 decimals).
    pub fit_threshold: Option<f64>,
    /// Confidence level.
    pub confidence: f64,
}

/// The grid that was searched.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridRecord {
    /// Nodes evaluated.
    pub nodes: usize,
    /// Nodes skipped.
    pub skipped: usize,
    /// Finest step.
    pub step: f64,
    /// The plan.
    pub plan: GridPlan,
    /// OP span.
    pub span: f64,
}

/// The contract's quantify object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QuantifyRecord {
    /// Stiction model.
    pub stiction_model: String,
    /// Linear identifier.
    pub linear_model: String,
    /// Equivalent S, % of valve span.
    #[serde(rename = "S", deserialize_with = "null_as_nan")]
    pub s: f64,
    /// Equivalent J.
    #[serde(rename = "J", deserialize_with = "null_as_nan")]
    pub j: f64,
    /// The stiction model's own parameters and derived values.
    pub params: BTreeMap<String, f64>,
    /// F_PV of the ranking criterion, identification window, %.
    #[serde(deserialize_with = "null_as_nan")]
    pub fit_pv_id: f64,
    /// F_PV of the ranking criterion, validation window, %.
    #[serde(deserialize_with = "null_as_nan")]
    pub fit_pv_val: f64,
    /// The ranking criterion.
    pub fit_kind: Criterion,
    /// The other criterion's fits.
    pub fit_pv_other: OtherFit,
    /// F_MV, % (when MV is logged).
    pub fit_mv: Option<f64>,
    /// Best validation fit with negligible stiction, %.
    pub fit_no_stiction: Option<f64>,
    /// Dead time, samples.
    pub delay: usize,
    /// The dead-time scan, when the dead time was estimated.
    pub delay_scan: Option<Vec<DelayScore>>,
    /// The identifier's orders (with the dead time), each of its type (`2`, `true`, `0.8`).
    pub orders: BTreeMap<String, OrderValue>,
    /// The likelihood-ratio region.
    pub interval: IntervalRecord,
    /// The grid.
    pub grid: GridRecord,
    /// Initialization label (`In.3`).
    pub init: String,
    /// First sample whose MV does not depend on the valve's initial state.
    pub valid_from: usize,
    /// First validation sample.
    pub split_index: usize,
    /// Whether the identified linear model is stable.
    pub stable: bool,
    /// Static gain of the linear model (9 decimals).
    pub static_gain: Option<f64>,
    /// Wall time, ms (3 decimals).
    pub elapsed_ms: Option<f64>,
    /// What limits the estimate, in words.
    pub warnings: Vec<String>,
    /// What a repair of the valve would buy ([`repair::Repair`]): `null` when it could not be
    /// estimated ([`QuantifyRecord::repair_reason`] says why).
    #[serde(default)]
    pub repair: Option<repair::Repair>,
    /// Why `repair` is `null` (`null` when it is not).
    #[serde(default)]
    pub repair_reason: Option<String>,
}

impl QuantifyRecord {
    /// Fill `repair` and `repair_reason` from an assessment ([`Fitted::repair`]).
    pub fn set_repair(&mut self, outcome: Result<repair::Repair, repair::NoRepair>) {
        match outcome {
            Ok(r) => {
                self.repair = Some(r);
                self.repair_reason = None;
            }
            Err(e) => {
                self.repair = None;
                self.repair_reason = Some(e.to_string());
            }
        }
    }
}

impl Fitted {
    /// The contract's quantify object of this run; `init` is the initialization it was
    /// searched with.
    pub fn record(&self, init: &Initialization) -> QuantifyRecord {
        let q = &self.result;
        let step = q.grid.step();
        let g = |x: f64| on_grid(x, step);
        let mut params: BTreeMap<String, f64> = self
            .stiction
            .params
            .iter()
            .zip(q.stiction.param_values())
            .map(|(spec, v)| (spec.name.to_string(), g(v)))
            .collect();
        for (name, v) in q.stiction.derived_values() {
            params.insert(name.to_string(), g(v));
        }
        let (fit_id, fit_val) = q.fits.rank(q.criterion);
        let (other_id, other_val) = q.fits.rank(q.criterion.other());
        QuantifyRecord {
            stiction_model: self.stiction.name.to_string(),
            linear_model: self.linear.to_string(),
            s: g(q.s),
            j: g(q.j),
            params,
            fit_pv_id: fit_id,
            fit_pv_val: fit_val,
            fit_kind: q.criterion,
            fit_pv_other: OtherFit {
                kind: q.criterion.other(),
                id: rounded(other_id, 6),
                val: rounded(other_val, 6),
            },
            fit_mv: q.fits.mv,
            fit_no_stiction: q.fit_no_stiction,
            delay: self.delay,
            delay_scan: self.delay_scan.as_ref().map(|d| {
                d.scores
                    .iter()
                    .map(|(k, f)| DelayScore {
                        delay: *k,
                        fit_pv_val: rounded(*f, 6),
                    })
                    .collect()
            }),
            orders: self
                .identifier
                .orders()
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
            interval: IntervalRecord {
                s: q.interval.s.map(g),
                j: q.interval.j.map(g),
                nodes: q.interval.nodes,
                fit_threshold: rounded(q.interval.fit_threshold, 6),
                confidence: q.interval.confidence,
            },
            grid: GridRecord {
                nodes: q.nodes_evaluated,
                skipped: q.nodes_skipped,
                step,
                plan: q.grid,
                span: q.span,
            },
            init: init.label().to_string(),
            valid_from: q.fits.valid_from,
            split_index: q.split_index,
            stable: q.linear.is_stable(),
            static_gain: rounded(q.linear.static_gain(), 9),
            elapsed_ms: rounded(self.elapsed_ms, 3),
            warnings: q.warnings.clone(),
            repair: None,
            repair_reason: Some("not assessed (the record's set point was not at hand)".into()),
        }
    }
}

/// The `compare --json` document: every combination's quantify object, and the combinations
/// that failed with their one-line errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompareRecord {
    /// The record's source.
    pub source: String,
    /// The combinations that ran.
    pub results: Vec<QuantifyRecord>,
    /// The combinations that failed.
    pub errors: Vec<CompareError>,
}

impl CompareRecord {
    /// No combination yet.
    pub fn new(source: &str) -> Self {
        CompareRecord {
            source: source.to_string(),
            results: Vec::new(),
            errors: Vec::new(),
        }
    }

    /// Add the outcome of `stiction` × `linear`: its quantify object, or its one-line error.
    pub fn push(&mut self, stiction: &str, linear: &str, outcome: Result<QuantifyRecord, String>) {
        match outcome {
            Ok(record) => self.results.push(record),
            Err(error) => self.errors.push(CompareError {
                stiction_model: stiction.to_string(),
                linear_model: linear.to_string(),
                error,
            }),
        }
    }
}

/// The `models --json` document: every registered stiction model (`params` with their
/// meaning, default and largest fraction of the OP span; `constraints` in words) and linear
/// identifier (`orders` with their `type`, `integer`, `boolean` or `real`, and their default).
pub fn models_record() -> serde_json::Value {
    use serde_json::json;
    let stiction: Vec<serde_json::Value> = stiction_models::registry()
        .iter()
        .map(|e| {
            json!({
                "name": e.name,
                "description": e.description,
                "params": e.params.iter().map(|p| json!({
                    "name": p.name,
                    "meaning": p.meaning,
                    "default": p.default,
                    "max_span_fraction": p.max_span_fraction,
                })).collect::<Vec<_>>(),
                "constraints": e.constraints.iter().map(|c| c.describe()).collect::<Vec<_>>(),
            })
        })
        .collect();
    let linear: Vec<serde_json::Value> = linear_id::registry()
        .iter()
        .map(|e| {
            json!({
                "name": e.name,
                "description": e.description,
                "orders": e.orders.iter().map(|o| json!({
                    "name": o.name, "type": o.kind(), "default": o.default, "meaning": o.meaning,
                })).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({"stiction": stiction, "linear": linear})
}

/// A combination of a `compare` that failed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompareError {
    /// Stiction model.
    pub stiction_model: String,
    /// Linear identifier.
    pub linear_model: String,
    /// The one-line error.
    pub error: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn on_grid_removes_float_noise_only() {
        assert_eq!(on_grid(0.30000000000000004, 0.1), 0.3);
        assert_eq!(on_grid(1.234_56, 0.5), 1.2346);
        assert!(on_grid(f64::NAN, 0.1).is_nan());
    }

    #[test]
    fn compare_errors_keep_their_combination() {
        let mut doc = CompareRecord::new("loop.csv");
        doc.push("kano", "ss", Err("too few samples".into()));
        assert!(doc.results.is_empty());
        assert_eq!(doc.errors[0].linear_model, "ss");
        assert_eq!(doc.errors[0].error, "too few samples");
    }

    #[test]
    fn models_record_types_every_order() {
        let doc = models_record();
        let ss = doc["linear"]
            .as_array()
            .and_then(|l| l.iter().find(|e| e["name"] == "ss"))
            .cloned()
            .unwrap_or_default();
        let order = |name: &str| {
            ss["orders"]
                .as_array()
                .and_then(|o| o.iter().find(|o| o["name"] == name))
                .cloned()
                .unwrap_or_default()
        };
        assert_eq!(order("n")["type"], "integer");
        assert_eq!(order("n")["default"], 2);
        assert_eq!(order("center")["type"], "boolean");
        assert_eq!(order("center")["default"], true);
        assert_eq!(order("threshold")["type"], "real");
        assert!(doc["stiction"].as_array().is_some_and(|s| !s.is_empty()));
    }
}
