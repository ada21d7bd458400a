//! Flags shared by `quantify`, `compare`, `diagnose`, `trend` and `batch`: the linear model's
//! orders, the dead time, the grid and the search; the loop's kind (`--integrating`, also
//! `detect` and `audit`).

use grid_search::Criterion;
use run::{Combination, DelayArg, SearchArgs, Settings};
use stiction_models::Initialization;

use super::valve::parse_init;
use crate::{usage, Failure};

/// `--split`: a decimal or a fraction `A/B`, strictly between 0 and 1.
pub(crate) fn parse_split(s: &str) -> Result<f64, String> {
    let number = |t: &str| t.trim().parse::<f64>().ok();
    let (v, what) = match s.split_once('/') {
        Some((a, b)) => (number(a).zip(number(b)).map(|(a, b)| a / b), "a fraction"),
        None => (number(s), "a number"),
    };
    match v.ok_or_else(|| format!("{s:?} is not {what}"))? {
        v if v.is_finite() && v > 0.0 && v < 1.0 => Ok(v),
        _ => Err(format!("{s}: expected a fraction strictly between 0 and 1")),
    }
}

/// `--integrating`: how every command that analyses a loop decides its kind (one rule,
/// `monitoring::Integrating::decide`).
#[derive(Debug, Clone, Copy, clap::Args)]
pub(crate) struct KindFlags {
    /// Whether the loop is integrating (a level; identified from MV to ΔPV): `auto` decides
    /// from the record (whether PV's rate or PV's level follows OP); the tag's first letter `L`
    /// (ISA-5.1) in the file name only breaks a tie. The output says which decided.
    #[arg(long, value_enum, default_value = "auto")]
    integrating: IntegratingFlag,
}

impl KindFlags {
    /// The library's value.
    pub(crate) fn integrating(&self) -> monitoring::Integrating {
        match self.integrating {
            IntegratingFlag::Auto => monitoring::Integrating::Auto,
            IntegratingFlag::Yes => monitoring::Integrating::Yes,
            IntegratingFlag::No => monitoring::Integrating::No,
        }
    }
}

/// `--integrating`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum IntegratingFlag {
    /// Decided from each record (whether PV's rate or level follows OP); a level tag (letter
    /// `L`) breaks a tie.
    Auto,
    /// The loop is integrating: identify MV → ΔPV.
    Yes,
    /// The loop is not integrating: identify MV → PV.
    No,
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
    #[arg(long, value_name = "N|auto", default_value = "0", value_parser = DelayArg::parse)]
    pub delay: DelayArg,
    /// Grid step in OP units (% of span): exhaustive grid at this step. Default: a coarse grid
    /// at span/40 refined at step 0.1 around its best node.
    #[arg(long, value_name = "X", allow_hyphen_values = true, value_parser = super::numbers::positive)]
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
    #[arg(long, value_name = "N", default_value_t = grid_search::budget::DEFAULT_MAX_NODES, value_parser = super::numbers::count)]
    pub max_nodes: usize,
    /// Work budget per grid stage: nodes × the record's samples × the linear model's cost per
    /// sample (its number of parameters squared; 10 × for ARX). A stage over it is refused (a
    /// usage error) rather than run for minutes.
    #[arg(long, value_name = "W", default_value_t = grid_search::budget::DEFAULT_MAX_WORK, value_parser = super::numbers::positive)]
    pub max_work: f64,
}

/// `--criterion`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum CriterionFlag {
    /// One-step-ahead prediction (default).
    Prediction,
    /// Free-run simulation.
    Simulation,
}

impl From<CriterionFlag> for Criterion {
    fn from(c: CriterionFlag) -> Criterion {
        match c {
            CriterionFlag::Prediction => Criterion::Prediction,
            CriterionFlag::Simulation => Criterion::Simulation,
        }
    }
}

impl SearchFlags {
    /// The flags as the library's [`SearchArgs`].
    pub(crate) fn args(&self) -> SearchArgs {
        SearchArgs {
            orders: self.orders.clone(),
            delay: self.delay,
            step: self.step,
            init: self.init.label().to_string(),
            criterion: Criterion::from(self.criterion).label().to_string(),
            split: self.split,
            max_nodes: self.max_nodes,
            max_work: self.max_work,
        }
    }

    /// The settings of a run over the identifiers `linear` (orders, dead time, grid, search;
    /// usage errors name the flag).
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
