//! Flags shared by `quantify`, `compare` (and later `diagnose`): the linear model's orders,
//! the dead time, and the grid.

use anyhow::anyhow;
use grid_search::SearchOptions;
use linear_id::{find_identifier, IdentifierEntry, LinearIdentifier};
use monitoring::settings::parse_orders;
use monitoring::SearchSettings;
use stiction_models::Initialization;

use super::valve::parse_init;
use crate::{usage, Failure};

/// The dead time: fixed or estimated.
/// `--delay N|auto` (the library's [`DelaySetting`]).
pub(crate) use monitoring::DelaySetting as DelayFlag;

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
    /// Search options for a record with OP span `span`.
    /// The ranking criterion in words.
    pub(crate) fn criterion_label(&self) -> &'static str {
        match self.criterion {
            CriterionFlag::Prediction => "one-step prediction",
            CriterionFlag::Simulation => "free-run simulation",
        }
    }

    /// The library's settings for these flags.
    pub(crate) fn settings(&self) -> SearchSettings {
        SearchSettings {
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

    pub fn options(&self, span: f64) -> Result<SearchOptions, Failure> {
        self.settings().options(span).map_err(usage)
    }
}

impl SearchFlags {
    /// `stiction` × `linear` with these flags (`SearchSettings::combination`).
    pub(crate) fn combination(
        &self,
        stiction: &str,
        linear: &str,
    ) -> Result<monitoring::Combination, Failure> {
        self.settings().combination(stiction, linear).map_err(usage)
    }
}

/// The identifier `name` with `--orders` text and a dead time (usage errors for unknown names,
/// bad orders, a dead time the identifier has no option for).
pub(crate) fn build_identifier(
    name: &str,
    orders: Option<&str>,
    delay: usize,
) -> Result<(Box<dyn LinearIdentifier>, &'static IdentifierEntry), Failure> {
    let entry = find_identifier(name).map_err(usage)?;
    let mut pairs = parse_orders(entry, orders.unwrap_or("")).map_err(usage)?;
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
