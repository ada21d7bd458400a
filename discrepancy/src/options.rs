//! The diagnosis's starting point and options: the baseline from the CLI's search settings,
//! [`DiagnoseOptions`] and its likelihood-ratio thresholds.

use grid_search::GridPlan;
use grid_search::SearchOptions;

use crate::{Combination, DiagnoseError};

/// The model a diagnosis starts from: a [`Combination`] with a fixed dead time (its grid and
/// search options are the diagnosis's, [`DiagnoseOptions::search`]).
pub type Baseline = Combination;

/// The baseline of a diagnosis from the search settings as the CLI's flags spell them: the
/// combination with a fixed dead time (`--delay auto` is refused: the diagnosis tests the dead
/// time itself) and its orders in full (defaults filled in), so that an extension with another
/// identifier inherits the orders they share. The CLI and the Python package both start here.
pub fn baseline(
    args: &run::SearchArgs,
    stiction: &str,
    linear: &str,
) -> Result<Baseline, DiagnoseError> {
    let delay = match args.delay {
        run::DelayArg::Samples(d) => d,
        run::DelayArg::Auto => {
            return Err(DiagnoseError::Setting(
                "--delay auto: diagnose tests the dead time itself (cause time-delay); give the baseline's fixed dead time".into(),
            ))
        }
    };
    let mut baseline = args.settings(&[linear])?.combination(stiction, linear)?;
    baseline.orders = orders_without_delay(baseline.identifier(delay)?.as_ref());
    Ok(baseline)
}

/// The diagnosis's options for a record whose OP spans `span`, with the causes `without` left
/// out.
pub fn options_for(
    args: &run::SearchArgs,
    span: f64,
    without: &[String],
) -> Result<DiagnoseOptions, DiagnoseError> {
    let mut options = DiagnoseOptions::for_span(span);
    options.search = args.settings(&[])?.options(span);
    options.disabled = without.to_vec();
    options.select_orders = args.orders.is_none();
    Ok(options)
}

/// Options of [`diagnose`](crate::diagnose).
///
/// | field | default | meaning |
/// |-------|---------|---------|
/// | `search` | In.3, coarse span/40 → fine 0.1 | grid of the baseline and of every refit |
/// | `max_delay` | 10 | largest dead time tried by `time-delay` |
/// | `lr_base` | 20 | LR an extension must exceed with one extra parameter ... |
/// | `lr_per_param` | 10 | ... plus this per further extra parameter |
/// | `lr_no_stiction` | 9.21 | `no-stiction` holds when removing S and J costs less than this (χ²₂ 99 %) |
/// | `disabled` | none | causes not tested (for ablation) |
#[derive(Debug, Clone)]
pub struct DiagnoseOptions {
    /// Search options (grid, initialization, split, criterion).
    pub search: SearchOptions,
    /// Largest dead time tried.
    pub max_delay: usize,
    /// LR threshold for one extra parameter.
    pub lr_base: f64,
    /// LR threshold increment per further parameter.
    pub lr_per_param: f64,
    /// LR a stiction model must gain over S = J = 0 to count as stiction.
    pub lr_no_stiction: f64,
    /// Causes not tested.
    pub disabled: Vec<String>,
    /// Whether the baseline's orders `n` and `m` are chosen from the data (see
    /// [`OrderSelection`](crate::OrderSelection)); off when the user gave the orders.
    pub select_orders: bool,
}

impl DiagnoseOptions {
    /// Defaults with the CLI's default grid for OP span `span`.
    pub fn for_span(span: f64) -> DiagnoseOptions {
        DiagnoseOptions {
            search: SearchOptions {
                grid: GridPlan::for_span(span),
                ..SearchOptions::default()
            },
            max_delay: 10,
            lr_base: 20.0,
            lr_per_param: 10.0,
            lr_no_stiction: 9.21,
            disabled: Vec::new(),
            select_orders: true,
        }
    }

    /// The LR an extension adding `extra` parameters must exceed.
    pub fn threshold(&self, extra: i32) -> f64 {
        if extra <= 0 {
            return f64::INFINITY;
        }
        self.lr_base + self.lr_per_param * (extra - 1) as f64
    }
}

/// An identifier's orders in full (its defaults filled in), without the dead time.
pub fn orders_without_delay(
    identifier: &dyn linear_id::LinearIdentifier,
) -> Vec<(String, linear_id::OrderValue)> {
    identifier
        .orders()
        .into_iter()
        .filter(|(k, _)| *k != "delay")
        .map(|(k, v)| (k.to_string(), v))
        .collect()
}
