//! `stiction identify`: a linear model from an input column to PV (e.g. a measured MV).

use std::path::PathBuf;

use anyhow::anyhow;

use super::load::{load, DataFlags};
use crate::{usage, CmdResult, Streams};

/// Arguments of `stiction identify`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// CSV or MAT file (`-` for standard input, CSV).
    file: PathBuf,
    /// Registered linear identifier (arx, armax, earx, earmax, harx, larx, ss; `stiction models`).
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
    #[arg(long, value_name = "F", default_value = "0.6666666666666666", value_parser = super::search_flags::parse_split, allow_hyphen_values = true)]
    split: f64,
    #[command(flatten)]
    data: DataFlags,
    /// Print one JSON document.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    if !(args.split > 0.0 && args.split < 1.0) {
        return Err(usage(anyhow!(
            "--split {}: expected a fraction strictly between 0 and 1",
            args.split
        )));
    }
    let orders = args.orders.as_deref().unwrap_or("");
    let (identifier, _) = run::identifier_for(&args.linear, orders, args.delay).map_err(usage)?;
    let flags = args
        .data
        .with_columns(args.input.as_ref(), args.output.as_ref());
    let d = load(&args.file, &flags, true, identifier.min_samples().max(3), s)?;
    let input = run::identify::input_of(&d, args.input.as_deref());
    let output = (d.require_pv()?, args.output.as_deref().unwrap_or("PV"));
    let id = run::identify::identify(&*identifier, &d.source, input, output, args.split)?;
    if !id.fit.is_stable() {
        writeln!(
            s.stderr,
            "warning: {}: the identified {} model is unstable (pole outside the unit circle); do not use it for simulation",
            d.source, id.linear
        )?;
    }
    if args.json {
        return s.json(&id.record(args.delay));
    }
    s.text(report::text::identify(&d.source, &id)?)
}
