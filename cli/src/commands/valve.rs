//! `stiction valve`: run a stiction model over a recorded OP.

use std::path::PathBuf;

use anyhow::Context;
use stiction_models::{clip, find_model, run_valve, Initialization};

use super::{initial_state, parse_clip, parse_param, with_output, StartFlag};
use crate::commands::load::{load, DataFlags};
use crate::{usage, CmdResult, Streams};

/// Arguments of `stiction valve`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// CSV or MAT file with an OP column (`-` for standard input, CSV).
    file: PathBuf,
    /// Registered stiction model (see `stiction models`).
    #[arg(long, value_name = "NAME")]
    model: String,
    /// A model parameter, NAME=VALUE in OP units (repeatable); missing ones default to 0.
    #[arg(long = "param", value_name = "K=V", value_parser = parse_param)]
    params: Vec<(String, f64)>,
    /// Initialization strategy of the paper: In.1 (one fixed start), In.2, In.3.
    #[arg(long, default_value = "In.1", value_parser = parse_init)]
    init: Initialization,
    /// In.1 start: the valve's state at the first sample.
    #[arg(long, value_enum, default_value = "down")]
    start: StartFlag,
    /// In.1 start: OP value where the valve stopped (u_s0); default OP(0).
    #[arg(long, value_name = "X", allow_negative_numbers = true, value_parser = super::numbers::finite)]
    us0: Option<f64>,
    /// In.1 start: valve position at the first sample (MV(0)); default: consistent with the start.
    #[arg(long, value_name = "X", allow_negative_numbers = true, value_parser = super::numbers::finite)]
    mv0: Option<f64>,
    /// Clip OP to [LO, HI] before the model (as public implementations do for OP in %).
    #[arg(long, value_name = "LO,HI", value_parser = parse_clip, allow_hyphen_values = true)]
    clip: Option<(f64, f64)>,
    #[command(flatten)]
    data: DataFlags,
    /// Output file (default: standard output).
    #[arg(short, long, value_name = "OUT.csv")]
    output: Option<PathBuf>,
}

pub(crate) fn parse_init(s: &str) -> Result<Initialization, String> {
    Initialization::parse(s).ok_or_else(|| format!("expected In.1, In.2 or In.3, got {s:?}"))
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    let entry = find_model(&args.model).map_err(usage)?;
    let model = entry.build_named(&args.params).map_err(usage)?;
    let init = match args.init {
        Initialization::In1(_) => {
            Initialization::In1(initial_state(args.start, args.us0, args.mv0)?)
        }
        other => other,
    };
    let d = load(&args.file, &args.data, false, 1, s)?;
    let mut op = d.op.clone();
    if let Some((lo, hi)) = args.clip {
        clip(&mut op, lo, hi);
    }
    let run = run_valve(model.as_ref(), &op, &init)?;
    if let Some(note) = run.start_note(&init) {
        writeln!(s.stderr, "note: {note}")?;
    }
    with_output(args.output.as_deref(), s.stdout, |w| {
        let mut out = csv::Writer::from_writer(w);
        out.write_record(["OP", "MV"])?;
        for (o, m) in d.op.iter().zip(&run.mv) {
            out.write_record([o.to_string(), m.to_string()])?;
        }
        out.flush().context("writing CSV")?;
        Ok(())
    })
}
