//! The JSON documents of the workflow (docs/CLI.md lists their keys; they are a contract): the
//! CLI prints them with `--json`, the Python package returns them as dicts, batch rows are built
//! from them. Numbers of S, J and the stiction parameters are rounded to the grid's resolution
//! ([`on_grid`]); a number that could not be computed is `null`.

use serde_json::{json, Value};

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

/// `x` rounded to `digits` decimals, `null` when not finite.
pub fn round(x: f64, digits: i32) -> Value {
    if x.is_finite() {
        let f = 10f64.powi(digits);
        json!((x * f).round() / f)
    } else {
        Value::Null
    }
}

/// The quantify object (`stiction quantify --json` without `source`, and each element of
/// `compare`'s `results`); `init` is the initialization's label (`In.3`).
pub fn quantify(r: &Fitted, init: &str) -> Value {
    let q = &r.result;
    let step = q.grid.step();
    let g = |x: f64| on_grid(x, step);
    let mut params = serde_json::Map::new();
    for (spec, v) in r.stiction.params.iter().zip(q.stiction.param_values()) {
        params.insert(spec.name.to_string(), json!(g(v)));
    }
    for (name, v) in q.stiction.derived_values() {
        params.insert(name.to_string(), json!(g(v)));
    }
    let orders: serde_json::Map<String, Value> = r
        .identifier
        .orders()
        .into_iter()
        .map(|(k, v)| (k.to_string(), json!(v)))
        .collect();
    let (fit_id, fit_val) = q.fits.rank(q.criterion);
    let (other_id, other_val) = q.fits.rank(q.criterion.other());
    json!({
        "stiction_model": r.stiction.name,
        "linear_model": r.linear,
        "S": g(q.s),
        "J": g(q.j),
        "params": params,
        "fit_pv_id": fit_id,
        "fit_pv_val": fit_val,
        "fit_kind": q.criterion.label(),
        "fit_pv_other": {
            "kind": q.criterion.other().label(),
            "id": round(other_id, 6),
            "val": round(other_val, 6),
        },
        "fit_mv": q.fits.mv,
        "fit_no_stiction": q.fit_no_stiction,
        "delay": r.delay,
        "delay_scan": r.delay_scan.as_ref().map(|d| d.scores.iter().map(|(k, f)| json!({"delay": k, "fit_pv_val": round(*f, 6)})).collect::<Vec<_>>()),
        "orders": orders,
        "interval": {
            "S": q.interval.s.map(g), "J": q.interval.j.map(g), "nodes": q.interval.nodes,
            "fit_threshold": round(q.interval.fit_threshold, 6), "confidence": q.interval.confidence,
        },
        "grid": {
            "nodes": q.nodes_evaluated,
            "skipped": q.nodes_skipped,
            "step": q.grid.step(),
            "plan": q.grid,
            "span": q.span,
        },
        "init": init,
        "valid_from": q.fits.valid_from,
        "split_index": q.split_index,
        "stable": q.linear.is_stable(),
        "static_gain": round(q.linear.static_gain(), 9),
        "elapsed_ms": round(r.elapsed_ms, 3),
        "warnings": q.warnings,
    })
}

/// The `compare --json` document.
pub fn compare(source: &str, results: Vec<Value>, errors: Vec<Value>) -> Value {
    json!({"source": source, "results": results, "errors": errors})
}

/// One element of `compare`'s `errors`.
pub fn compare_error(stiction_model: &str, linear_model: &str, error: &str) -> Value {
    json!({"stiction_model": stiction_model, "linear_model": linear_model, "error": error})
}
