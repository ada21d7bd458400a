//! Flags shared by `quantify`, `compare` (and later `diagnose`): the linear model's orders,
//! the dead time, and the grid.

use anyhow::anyhow;
use grid_search::SearchOptions;
use linear_id::{find_identifier, LinearIdentifier};
use monitoring::{parse_orders, Combination, Orders, SearchArgs, Settings};
use stiction_models::Initialization;

use super::valve::parse_init;
use crate::{usage, Failure};

/// The dead time: fixed or estimated.
/// `--delay N|auto` (the library's [`DelayArg`]).
pub(crate) use monitoring::DelayArg as DelayFlag;

pub(crate) fn parse_delay(s: &str) -> Result<DelayFlag, String> {
    DelayFlag::parse(s)
}

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
    /// The ranking criterion in words.
    pub(crate) fn criterion_label(&self) -> &'static str {
        match self.criterion {
            CriterionFlag::Prediction => "one-step prediction",
            CriterionFlag::Simulation => "free-run simulation",
        }
    }

    /// Search options for a record with OP span `span`.
    pub fn options(&self, span: f64) -> Result<SearchOptions, Failure> {
        Ok(self.settings(&[])?.options(span))
    }

    /// The settings these flags describe, checked against the identifiers `linear` (their
    /// names, the orders and the dead time are bad usage here, with the flags' names): orders,
    /// dead time (`auto` scans 0..=`monitoring::MAX_AUTO_DELAY`), grid (`--step` =
    /// exhaustive, else the default for each record's span), initialization, split, criterion
    /// and node budget.
    /// The flags as the library's [`SearchArgs`].
    pub(crate) fn args(&self) -> SearchArgs {
        SearchArgs {
            orders: self.orders.clone(),
            delay: self.delay,
            step: self.step,
            init: self.init.label().to_string(),
            criterion: match self.criterion {
                CriterionFlag::Prediction => "prediction",
                CriterionFlag::Simulation => "simulation",
            }
            .to_string(),
            split: self.split,
            max_nodes: self.max_nodes,
        }
    }

    /// The settings of a run over the identifiers `linear` (usage errors name the flag).
    pub(crate) fn settings(&self, linear: &[String]) -> Result<Settings, Failure> {
        let names: Vec<&str> = linear.iter().map(String::as_str).collect();
        self.args().settings(&names).map_err(usage)
    }

    pub(crate) fn combination(&self, stiction: &str, linear: &str) -> Result<Combination, Failure> {
        stiction_models::find_model(stiction).map_err(usage)?;
        self.settings(&[linear.to_string()])?
            .combination(stiction, linear)
            .map_err(usage)
    }
}

/// `--orders` split into `(name, value)` items (a name for `NAME=VALUE`).
pub(crate) fn check_identifier(
    name: &str,
    orders: &str,
    delay: usize,
) -> Result<(Box<dyn LinearIdentifier>, Orders), Failure> {
    let entry = find_identifier(name).map_err(usage)?;
    let orders = parse_orders(orders, Some(entry)).map_err(usage)?;
    if delay != 0 && !entry.orders.iter().any(|o| o.name == "delay") {
        return Err(usage(anyhow!(
            "{}: this identifier has no dead-time option",
            entry.name
        )));
    }
    let named = orders.resolve(entry).map_err(usage)?;
    let id = monitoring::build_identifier(entry, &named, delay).map_err(usage)?;
    Ok((id, orders))
}
