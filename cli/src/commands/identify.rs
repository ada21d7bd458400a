//! `stiction identify`: a linear model from an input column to PV (e.g. a measured MV).

use std::path::PathBuf;

use anyhow::anyhow;
use linear_id::{fit_pv, Structure};
use serde_json::{json, Value};

use super::load::{load, DataFlags};
use super::search_flags::check_identifier;
use crate::{data, usage, CmdResult, Streams};

pub(crate) const AFTER_HELP: &str = "\
Identifies on the first 2/3 of the record and validates the one-step prediction on the last
1/3 (F_PV, paper eq. 9, squared norms, in %). The input is the MV column when the file has
one, otherwise OP; --input and --output choose any columns. An unstable identified model is
reported (exit 0, `stable: false`, a warning on stderr), never silently used.

Examples:
  stiction identify loop.csv --linear arx
  stiction identify loop.csv --linear armax --orders 2,2,2 --delay 1 --json
  stiction identify loop.csv --linear ss --orders n=3 --input OP
  stiction identify plant.csv --linear earx --input u --output y";

/// Arguments of `stiction identify`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// CSV file (`-` for standard input).
    file: PathBuf,
    /// Registered linear identifier (arx, armax, earx, earmax, ss).
    #[arg(long, value_name = "NAME", default_value = "arx")]
    linear: String,
    /// Orders: values in the identifier's order (`2,2`) or NAME=VALUE pairs (`n=3,m=2`).
    #[arg(long, value_name = "ORDERS")]
    orders: Option<String>,
    /// Dead time in samples.
    #[arg(long, value_name = "N", default_value_t = 0)]
    delay: usize,
    /// Input column (default: MV if present, else OP).
    #[arg(long, value_name = "COL")]
    input: Option<String>,
    /// Output column (default: PV).
    #[arg(long, value_name = "COL")]
    output: Option<String>,
    /// Fraction of the record used for identification.
    #[arg(long, value_name = "F", default_value = "0.6666666666666666")]
    split: f64,
    #[command(flatten)]
    data: DataFlags,
    /// Print one JSON document.
    #[arg(long)]
    json: bool,
}

/// An identifier's error with its signals `u`, `y` named by the user's columns.
fn in_user_words(e: &linear_id::IdError, input: &str, output: &str) -> String {
    let column = |signal: &str| match signal {
        "u" => format!("column {input}"),
        "y" => format!("column {output}"),
        other => other.to_string(),
    };
    match e {
        linear_id::IdError::ConstantInput { signal, value } => format!(
            "{} is constant over the identification window (value {value})",
            column(signal)
        ),
        linear_id::IdError::NonFinite {
            signal,
            index,
            value,
        } => format!("{} sample {index} is not finite ({value})", column(signal)),
        other => other.to_string(),
    }
}

fn pairs(v: &[(f64, f64)]) -> Value {
    json!(v.iter().map(|(re, im)| [re, im]).collect::<Vec<_>>())
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    if !(args.split > 0.0 && args.split < 1.0) {
        return Err(usage(anyhow!(
            "--split {}: expected a fraction strictly between 0 and 1",
            args.split
        )));
    }
    let (identifier, _) = check_identifier(
        &args.linear,
        args.orders.as_deref().unwrap_or(""),
        args.delay,
    )?;
    let entry = linear_id::find_identifier(&args.linear).map_err(usage)?;
    let mut flags = args.data.clone();
    if let Some(col) = &args.input {
        flags.set_op(col.clone());
    }
    if let Some(col) = &args.output {
        flags.set_pv(col.clone());
    }
    let d = load(&args.file, &flags, true, identifier.min_samples().max(3), s)?;
    let (u, input_name): (&[f64], String) = match (&args.input, &d.mv) {
        (Some(col), _) => (&d.op, col.clone()),
        (None, Some(mv)) => (mv, "MV".into()),
        (None, None) => (&d.op, "OP".into()),
    };
    let y = d.require_pv().map_err(data)?;
    let n = y.len();
    let ni = (n as f64 * args.split).floor() as usize;
    if ni < identifier.min_samples() || n - ni < 2 {
        return Err(data(anyhow!(
            "{}: {n} rows: too few for {} with these orders ({} identification rows needed)",
            d.source,
            entry.name,
            identifier.min_samples()
        )));
    }
    let output_name = args.output.clone().unwrap_or_else(|| "PV".into());
    let fit = identifier.identify(&u[..ni], &y[..ni]).map_err(|e| {
        let msg = in_user_words(&e, &input_name, &output_name);
        data(anyhow!("{}: {msg}", d.source))
    })?;
    let pred = fit.predict_one_step(u, y).map_err(data)?;
    let first = fit.first_sample().min(ni);
    let fit_id = fit_pv(&y[first..ni], &pred[first..ni]);
    let fit_val = fit_pv(&y[ni..], &pred[ni..]);
    let sim = fit.simulate(u, &y[..fit.first_sample().min(n)]).ok();
    let sim_val = sim.as_ref().map(|p| fit_pv(&y[ni..], &p[ni..]));
    let stable = fit.is_stable();
    if !stable {
        writeln!(
            s.stderr,
            "warning: {}: the identified {} model is unstable (pole outside the unit circle); do not use it for simulation",
            d.source, entry.name
        )
        .map_err(data)?;
    }
    let model = match fit.structure() {
        Structure::Polynomial { a, b, c, delay } => json!({"a": a, "b": b, "c": c, "delay": delay}),
        Structure::StateSpace { a, b, c, d, k, x0 } => {
            json!({"A": a, "B": b, "C": c, "D": d, "K": k, "x0": x0})
        }
    };
    let orders: serde_json::Map<String, Value> = identifier
        .orders()
        .into_iter()
        .map(|(k, v)| (k.to_string(), json!(v)))
        .collect();
    if args.json {
        let finite = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
        let doc = json!({
            "linear_model": entry.name,
            "input": input_name,
            "orders": orders,
            "delay": args.delay,
            "static_gain": finite(fit.static_gain()),
            "poles": pairs(&fit.poles()),
            "stable": stable,
            "model": model,
            "fit_pv_id": finite(fit_id),
            "fit_pv_val": finite(fit_val),
            "fit_kind": "prediction",
            "fit_pv_sim_val": sim_val.map(finite),
            "disturbance": fit.disturbance(),
            "samples": {"identification": ni, "validation": n - ni},
        });
        serde_json::to_writer_pretty(&mut *s.stdout, &doc).map_err(data)?;
        writeln!(s.stdout).map_err(data)?;
        return Ok(());
    }
    let out = &mut *s.stdout;
    let o: Vec<String> = identifier
        .orders()
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    writeln!(
        out,
        "{}: {} from {input_name} to PV ({}), {ni} identification / {} validation samples",
        d.source,
        entry.name,
        o.join(", "),
        n - ni
    )
    .map_err(data)?;
    match fit.structure() {
        Structure::Polynomial { a, b, c, delay } => {
            let fmt = |v: &[f64]| {
                v.iter()
                    .map(|x| format!("{x:.6}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            writeln!(out, "  A(q) = [{}]", fmt(a)).map_err(data)?;
            writeln!(
                out,
                "  B(q) = [{}]  (q^-1 .. q^-{}, dead time {delay})",
                fmt(b),
                b.len()
            )
            .map_err(data)?;
            if c.len() > 1 {
                writeln!(out, "  C(q) = [{}]", fmt(c)).map_err(data)?;
            }
        }
        Structure::StateSpace { a, .. } => {
            writeln!(
                out,
                "  state space, order {} (A, B, C, D, K, x0 with --json)",
                a.len()
            )
            .map_err(data)?;
        }
    }
    let poles: Vec<String> = fit
        .poles()
        .iter()
        .map(|(re, im)| {
            if im.abs() < 1e-12 {
                format!("{re:.4}")
            } else {
                format!("{re:.4}{im:+.4}i")
            }
        })
        .collect();
    writeln!(
        out,
        "  static gain {:.4}, poles {} ({})",
        fit.static_gain(),
        poles.join(", "),
        if stable { "stable" } else { "UNSTABLE" }
    )
    .map_err(data)?;
    writeln!(
        out,
        "  F_PV one-step prediction: id {fit_id:.2} %, val {fit_val:.2} %; free-run simulation val {}",
        sim_val.filter(|v| v.is_finite()).map_or("-".into(), |v| format!("{v:.2} %"))
    )
    .map_err(data)?;
    if let Some(eta) = fit.disturbance() {
        let (lo, hi) = eta
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        writeln!(
            out,
            "  estimated disturbance η̂: {} samples, range [{lo:.4}, {hi:.4}] (series with --json)",
            eta.len()
        )
        .map_err(data)?;
    }
    Ok(())
}
