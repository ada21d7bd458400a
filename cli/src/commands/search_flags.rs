//! Flags shared by `quantify`, `compare` (and later `diagnose`): the linear model's orders,
//! the dead time, and the grid.

use anyhow::anyhow;
use grid_search::{Criterion, GridPlan, SearchOptions};
use linear_id::{find_identifier, IdentifierEntry, LinearIdentifier};
use stiction_models::Initialization;

use super::valve::parse_init;
use crate::{usage, Failure};

/// The dead time: fixed or estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum DelayFlag {
    /// A fixed number of samples.
    Fixed(usize),
    /// Estimated by the search (`auto`).
    Auto,
}

pub(crate) fn parse_delay(s: &str) -> Result<DelayFlag, String> {
    if s.eq_ignore_ascii_case("auto") {
        return Ok(DelayFlag::Auto);
    }
    s.parse::<usize>()
        .map(DelayFlag::Fixed)
        .map_err(|_| format!("expected a number of samples or `auto`, got {s:?}"))
}

/// `--split`: a decimal or `a/b`, strictly between 0 and 1.
pub(crate) fn parse_split(s: &str) -> Result<f64, String> {
    let v = match s.split_once('/') {
        Some((a, b)) => {
            let a: f64 = a
                .trim()
                .parse()
                .map_err(|_| format!("{s:?} is not a fraction"))?;
            let b: f64 = b
                .trim()
                .parse()
                .map_err(|_| format!("{s:?} is not a fraction"))?;
            a / b
        }
        None => s
            .trim()
            .parse::<f64>()
            .map_err(|_| format!("{s:?} is not a number"))?,
    };
    if v.is_finite() && v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(format!("{s}: expected a fraction strictly between 0 and 1"))
    }
}

/// Grid and identification options.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Search options")]
pub(crate) struct SearchFlags {
    /// Orders of the linear model: values in the identifier's order (e.g. `2,2` for arx n,m;
    /// `2,2,2` for armax n,m,p) or NAME=VALUE pairs (`n=3,m=2`). Default: the paper's.
    #[arg(long, value_name = "ORDERS")]
    pub orders: Option<String>,
    /// Process dead time in samples, or `auto` to estimate it.
    #[arg(long, value_name = "N|auto", default_value = "0", value_parser = parse_delay)]
    pub delay: DelayFlag,
    /// Grid step in OP units (% of span): exhaustive grid at this step. Default: a coarse grid
    /// at span/40 refined at step 0.1 around its best node.
    #[arg(long, value_name = "X", allow_hyphen_values = true)]
    pub step: Option<f64>,
    /// Initialization of the valve model (paper §2.4).
    #[arg(long, default_value = "In.3", value_parser = parse_init)]
    pub init: Initialization,
    /// Fit that ranks the grid nodes: one-step `prediction` or free-run `simulation`.
    #[arg(long, value_enum, default_value = "prediction")]
    pub criterion: CriterionFlag,
    /// Fraction of the record used for identification (the rest validates): a decimal or a
    /// fraction such as `3/4`.
    #[arg(long, value_name = "F", default_value = "2/3", value_parser = parse_split, allow_hyphen_values = true)]
    pub split: f64,
    /// Node budget per grid stage: a grid with more nodes is refused (a usage error) rather
    /// than run for minutes or out of memory.
    #[arg(long, value_name = "N", default_value_t = grid_search::budget::DEFAULT_MAX_NODES)]
    pub max_nodes: usize,
}

/// `--criterion`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum CriterionFlag {
    /// One-step-ahead prediction (default).
    Prediction,
    /// Free-run simulation.
    Simulation,
}

impl SearchFlags {
    /// Search options for a record with OP span `span`.
    /// The ranking criterion in words.
    pub(crate) fn criterion_label(&self) -> &'static str {
        match self.criterion {
            CriterionFlag::Prediction => "one-step prediction",
            CriterionFlag::Simulation => "free-run simulation",
        }
    }

    pub fn options(&self, span: f64) -> Result<SearchOptions, Failure> {
        let grid = match self.step {
            Some(step) if step.is_finite() && step > 0.0 => GridPlan::Exhaustive { step },
            Some(step) => {
                return Err(usage(anyhow!(
                    "--step {step}: expected a positive step in OP units"
                )))
            }
            None => GridPlan::for_span(span),
        };
        Ok(SearchOptions {
            init: self.init,
            grid,
            split: self.split,
            criterion: match self.criterion {
                CriterionFlag::Prediction => Criterion::Prediction,
                CriterionFlag::Simulation => Criterion::Simulation,
            },
            max_nodes: self.max_nodes,
            ..SearchOptions::default()
        })
    }
}

impl SearchFlags {
    /// The combination `stiction` × `linear` these flags describe: orders, dead time (`auto`
    /// scans 0..=`monitoring::MAX_AUTO_DELAY`), grid (`--step` = exhaustive, else the default
    /// for the record's span), initialization, split and criterion. Names, orders and the step
    /// are checked here (bad usage).
    pub(crate) fn combination(
        &self,
        stiction: &str,
        linear: &str,
    ) -> Result<monitoring::Combination, Failure> {
        let stiction = stiction_models::find_model(stiction).map_err(usage)?;
        let delay = match self.delay {
            DelayFlag::Fixed(d) => d,
            DelayFlag::Auto => 0,
        };
        // Builds the identifier once: unknown names, bad orders and a dead time the identifier
        // has no option for are usage errors.
        let (_, entry) = build_identifier(linear, self.orders.as_deref(), delay)?;
        let mut orders = parse_orders(entry, self.orders.as_deref().unwrap_or(""))?;
        orders.retain(|(k, _)| k != "delay");
        let options = self.options(1.0)?;
        Ok(monitoring::Combination {
            stiction,
            linear: entry,
            orders,
            delay: match self.delay {
                DelayFlag::Fixed(d) => monitoring::Delay::Fixed(d),
                DelayFlag::Auto => monitoring::Delay::Auto {
                    max: monitoring::MAX_AUTO_DELAY,
                },
            },
            grid: self.step.map(|_| options.grid),
            search: options,
        })
    }
}

/// Build a registered identifier from `--orders` and a delay.
pub(crate) fn build_identifier(
    name: &str,
    orders: Option<&str>,
    delay: usize,
) -> Result<(Box<dyn LinearIdentifier>, &'static IdentifierEntry), Failure> {
    let entry = find_identifier(name).map_err(usage)?;
    let mut pairs = parse_orders(entry, orders.unwrap_or(""))?;
    pairs.retain(|(k, _)| k != "delay");
    if entry.orders.iter().any(|o| o.name == "delay") {
        pairs.push(("delay".into(), delay as f64));
    } else if delay != 0 {
        return Err(usage(anyhow!(
            "{}: this identifier has no dead-time option",
            entry.name
        )));
    }
    let id = (entry.build)(&pairs).map_err(usage)?;
    Ok((id, entry))
}

fn parse_orders(entry: &IdentifierEntry, s: &str) -> Result<Vec<(String, f64)>, Failure> {
    let positional: Vec<&str> = entry
        .orders
        .iter()
        .map(|o| o.name)
        .filter(|n| *n != "delay")
        .collect();
    let mut out = Vec::new();
    for (i, item) in s
        .split(',')
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .enumerate()
    {
        let (name, value) = match item.split_once('=') {
            Some((k, v)) => (k.trim().to_string(), v.trim()),
            None => {
                let name = positional.get(i).ok_or_else(|| {
                    usage(anyhow!(
                        "--orders {s:?}: {} takes at most {} positional orders ({})",
                        entry.name,
                        positional.len(),
                        positional.join(", ")
                    ))
                })?;
                (name.to_string(), item)
            }
        };
        let value: f64 = value
            .parse()
            .map_err(|_| usage(anyhow!("--orders: {name} = {value:?} is not a number")))?;
        out.push((name, value));
    }
    Ok(out)
}
