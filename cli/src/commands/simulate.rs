//! `stiction simulate`: the paper's closed-loop benchmark (§3.1).

use std::path::PathBuf;

use anyhow::Context;
use datasets::simulate::{Overrides, Scenario};

use super::{parse_param, with_output};
use crate::{usage, CmdResult, Failure, Streams};

/// Arguments of `stiction simulate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scenario JSON (see --print-config for its form); flags override its values.
    #[arg(long, value_name = "SCENARIO.json")]
    config: Option<PathBuf>,
    /// Plant preset: `paper` (eq. 10) or `slow` (a slower third-order plant).
    #[arg(long, value_name = "NAME")]
    plant: Option<String>,
    /// Registered stiction model of the valve (default kano with S = J = 0, a linear valve).
    #[arg(long, value_name = "NAME")]
    valve: Option<String>,
    /// A valve parameter NAME=VALUE in OP units (repeatable); unset ones keep their values.
    #[arg(long = "param", value_name = "K=V", value_parser = parse_param)]
    params: Vec<(String, f64)>,
    /// PI proportional gain.
    #[arg(long, value_name = "KC", allow_negative_numbers = true, value_parser = super::numbers::finite)]
    kc: Option<f64>,
    /// PI integral gain.
    #[arg(long, value_name = "KI", allow_negative_numbers = true, value_parser = super::numbers::finite)]
    ki: Option<f64>,
    /// Amplitude a of the paper's disturbance a (sin(0.03k) + 0.5 sin(0.07k)) (eq. 11).
    #[arg(long, value_name = "A", value_parser = super::numbers::non_negative)]
    disturbance: Option<f64>,
    /// Extra process dead time in samples.
    #[arg(long, value_name = "N")]
    delay: Option<usize>,
    /// Standard deviation σ_e of the white noise.
    #[arg(long, value_name = "SIGMA", value_parser = super::numbers::non_negative)]
    noise: Option<f64>,
    /// Number of samples written (after the warm-up).
    #[arg(long, value_name = "N")]
    samples: Option<usize>,
    /// Number of samples simulated first and discarded.
    #[arg(long, value_name = "N")]
    warmup: Option<usize>,
    /// Random seed (same seed, same output).
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
    /// Print the resolved scenario as JSON instead of simulating.
    #[arg(long)]
    print_config: bool,
    /// Output file (default: standard output).
    #[arg(short, long, value_name = "OUT.csv")]
    output: Option<PathBuf>,
}

fn scenario(args: &Args, s: &mut Streams<'_>) -> Result<Scenario, Failure> {
    let mut sc = match &args.config {
        Some(path) => {
            let text = if path.as_os_str() == "-" {
                let bytes = crate::read_all(s.stdin).context("reading standard input")?;
                String::from_utf8(bytes).context("-: not UTF-8")?
            } else {
                std::fs::read_to_string(path)
                    .with_context(|| format!("cannot read {}", path.display()))?
            };
            Scenario::from_json(&text).with_context(|| path.display().to_string())?
        }
        None => Scenario::default(),
    };
    sc.apply(&Overrides {
        plant: args.plant.clone(),
        delay: args.delay,
        valve: args.valve.clone(),
        params: args.params.clone(),
        kc: args.kc,
        ki: args.ki,
        disturbance: args.disturbance,
        noise: args.noise,
        samples: args.samples,
        warmup: args.warmup,
        seed: args.seed,
    })
    .map_err(usage)?;
    match sc.validate() {
        // Flags are usage: a bad value given on the command line exits 2.
        Err(e) if args.config.is_none() => Err(usage(e)),
        result => Ok(result.map(|()| sc)?),
    }
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    let sc = scenario(&args, s)?;
    let output = args.output.as_deref();
    if args.print_config {
        return with_output(output, s.stdout, |w| Ok(writeln!(w, "{}", sc.to_json())?));
    }
    let sim = sc.simulate()?;
    writeln!(s.stderr, "{}", sim.summary(&sc))?;
    with_output(output, s.stdout, |w| {
        sim.write_csv(w).context("writing CSV")
    })
}
