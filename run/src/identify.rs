//! A linear model from an input series to PV (`stiction identify`): identified on the first
//! part of the record, its one-step prediction and free-run simulation scored on the rest.

use linear_id::{fit_pv, IdError, LinearFit, LinearIdentifier, OrderValue, Structure};
use serde_json::{json, Value};

/// Why an identification gave no model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IdentifyError {
    /// Too few samples for the orders.
    #[error("{source_name}: {rows} rows: too few for {identifier} with these orders ({needed} identification rows needed)")]
    TooFew {
        /// The data's source.
        source_name: String,
        /// Rows in the record.
        rows: usize,
        /// The identifier.
        identifier: &'static str,
        /// Identification rows it needs.
        needed: usize,
    },
    /// The identification failed; the message names the user's columns.
    #[error("{source_name}: {}", in_columns(.error, .input, .output))]
    Identification {
        /// The data's source.
        source_name: String,
        /// What failed.
        error: Box<IdError>,
        /// The input column.
        input: String,
        /// The output column.
        output: String,
    },
    /// The prediction over the record failed.
    #[error(transparent)]
    Prediction(IdError),
}

/// An identifier's error with its signals `u`, `y` named by the columns.
fn in_columns(e: &IdError, input: &str, output: &str) -> String {
    let column = |signal: &str| match signal {
        "u" => format!("column {input}"),
        "y" => format!("column {output}"),
        other => other.to_string(),
    };
    match e {
        IdError::ConstantInput { signal, value } => format!(
            "{} is constant over the identification window (value {value})",
            column(signal)
        ),
        IdError::NonFinite {
            signal,
            index,
            value,
        } => format!("{} sample {index} is not finite ({value})", column(signal)),
        other => other.to_string(),
    }
}

/// An identified linear model and its fits.
#[derive(Debug)]
pub struct Identification {
    /// The identifier's registered name.
    pub linear: &'static str,
    /// The input column.
    pub input: String,
    /// The identifier's orders (with the dead time).
    pub orders: Vec<(&'static str, OrderValue)>,
    /// The model.
    pub fit: LinearFit,
    /// One-step F_PV on the identification window, %.
    pub fit_id: f64,
    /// One-step F_PV on the validation window, %.
    pub fit_val: f64,
    /// Free-run simulation F_PV on the validation window, % (when the simulation ran).
    pub sim_val: Option<f64>,
    /// Identification and validation samples.
    pub samples: [usize; 2],
}

/// The identification input of a record read with the column `column` as its OP, and its
/// name: that column; without one, the measured MV when the record has it, else OP.
pub fn input_of<'a>(d: &'a datasets::LoopData, column: Option<&'a str>) -> (&'a [f64], &'a str) {
    match (column, &d.mv) {
        (Some(col), _) => (&d.op, col),
        (None, Some(mv)) => (mv, "MV"),
        (None, None) => (&d.op, "OP"),
    }
}

/// Identify `identifier` from `u` (column `input`) to `y` (column
/// `output`) on the first `split` of the record of `source`, and score it on the rest.
pub fn identify(
    identifier: &dyn LinearIdentifier,
    source: &str,
    (u, input): (&[f64], &str),
    (y, output): (&[f64], &str),
    split: f64,
) -> Result<Identification, IdentifyError> {
    let linear = identifier.name();
    let n = y.len();
    let ni = (n as f64 * split).floor() as usize;
    if ni < identifier.min_samples() || n - ni < 2 {
        return Err(IdentifyError::TooFew {
            source_name: source.to_string(),
            rows: n,
            identifier: linear,
            needed: identifier.min_samples(),
        });
    }
    let fit =
        identifier
            .identify(&u[..ni], &y[..ni])
            .map_err(|error| IdentifyError::Identification {
                source_name: source.to_string(),
                error: Box::new(error),
                input: input.to_string(),
                output: output.to_string(),
            })?;
    let pred = fit
        .predict_one_step(u, y)
        .map_err(IdentifyError::Prediction)?;
    let first = fit.first_sample().min(ni);
    let sim = fit.simulate(u, &y[..fit.first_sample().min(n)]).ok();
    Ok(Identification {
        linear,
        input: input.to_string(),
        orders: identifier.orders(),
        fit_id: fit_pv(&y[first..ni], &pred[first..ni]),
        fit_val: fit_pv(&y[ni..], &pred[ni..]),
        sim_val: sim.as_ref().map(|p| fit_pv(&y[ni..], &p[ni..])),
        fit,
        samples: [ni, n - ni],
    })
}

impl Identification {
    /// The document of `identify --json` (`delay` is the dead time asked for).
    pub fn record(&self, delay: usize) -> Value {
        let fit = &self.fit;
        let finite = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
        let model = match fit.structure() {
            Structure::Polynomial { a, b, c, delay } => {
                json!({"a": a, "b": b, "c": c, "delay": delay})
            }
            Structure::StateSpace { a, b, c, d, k, x0 } => {
                json!({"A": a, "B": b, "C": c, "D": d, "K": k, "x0": x0})
            }
        };
        let orders: serde_json::Map<String, Value> = self
            .orders
            .iter()
            .map(|(k, v)| (k.to_string(), json!(v)))
            .collect();
        let poles: Vec<[f64; 2]> = fit.poles().iter().map(|(re, im)| [*re, *im]).collect();
        json!({
            "linear_model": self.linear,
            "input": self.input,
            "orders": orders,
            "delay": delay,
            "static_gain": finite(fit.static_gain()),
            "poles": poles,
            "stable": fit.is_stable(),
            "model": model,
            "fit_pv_id": finite(self.fit_id),
            "fit_pv_val": finite(self.fit_val),
            "fit_kind": "prediction",
            "fit_pv_sim_val": self.sim_val.map(finite),
            "disturbance": fit.disturbance(),
            "samples": {"identification": self.samples[0], "validation": self.samples[1]},
        })
    }
}
