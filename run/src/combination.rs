//! One stiction model × one linear identifier with its orders, dead time, grid and criterion:
//! the sequence "build the identifier, choose the grid, (scan the dead time,) run the search"
//! written once. The CLI, the diagnosis (`discrepancy`), the reports and `xtask reproduce` all
//! run a loop through [`Combination::run`].

use std::time::Instant;

use grid_search::{
    estimate_delay, quantify, DelayScan, GridPlan, Problem, Quantification, SearchOptions,
};
use linear_id::{find_identifier, IdError, IdentifierEntry, LinearIdentifier, OrderValue};
use serde::{Deserialize, Serialize};
use stiction_models::{find_model, ModelEntry};

use crate::RunError;

/// Largest dead time `Delay::Auto` scans by default, samples.
pub const MAX_AUTO_DELAY: usize = 10;

/// The process dead time of a combination.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Delay {
    /// A fixed number of samples.
    Fixed(usize),
    /// Estimated by scanning `0..=max` samples (`grid_search::estimate_delay`).
    Auto {
        /// Largest dead time tried.
        max: usize,
    },
}

impl Default for Delay {
    fn default() -> Self {
        Delay::Fixed(0)
    }
}

/// What is searched: a stiction model, a linear identifier with its orders, the dead time and
/// the search options. The grid is `search.grid` when `grid` is `Some`, else the default grid
/// for the record's OP span ([`GridPlan::for_span`]).
#[derive(Debug, Clone)]
pub struct Combination {
    /// Stiction model (registry entry).
    pub stiction: &'static ModelEntry,
    /// Linear identifier (registry entry).
    pub linear: &'static IdentifierEntry,
    /// Orders as `NAME=value` pairs without the dead time (missing ones take the identifier's
    /// defaults).
    pub orders: Vec<(String, OrderValue)>,
    /// Dead time.
    pub delay: Delay,
    /// Grid plan; `None` = the default grid for the OP span.
    pub grid: Option<GridPlan>,
    /// Initialization, split and criterion (its `grid` is replaced by the plan above).
    pub search: SearchOptions,
}

impl Combination {
    /// `stiction` × `linear` by their registered names, the paper's orders, dead time 0, the
    /// default grid and search options.
    pub fn named(stiction: &str, linear: &str) -> Result<Combination, RunError> {
        Ok(Combination {
            stiction: find_model(stiction)?,
            linear: find_identifier(linear)?,
            orders: Vec::new(),
            delay: Delay::Fixed(0),
            grid: None,
            search: SearchOptions::default(),
        })
    }

    /// Kano + ARX(2, 2), dead time 0: the paper's default.
    pub fn paper() -> Result<Combination, RunError> {
        Combination::named("kano", "arx")
    }

    /// The same combination with another stiction model, identifier and fixed dead time (the
    /// orders the new identifier knows are kept).
    pub fn with(
        &self,
        stiction: &'static ModelEntry,
        linear: &'static IdentifierEntry,
        delay: usize,
    ) -> Combination {
        Combination {
            stiction,
            linear,
            delay: Delay::Fixed(delay),
            ..self.clone()
        }
    }

    /// The fixed dead time (0 for `Auto`, whose dead time is known only after [`run`]).
    ///
    /// [`run`]: Combination::run
    pub fn fixed_delay(&self) -> usize {
        match self.delay {
            Delay::Fixed(d) => d,
            Delay::Auto { .. } => 0,
        }
    }

    /// The identifier with this combination's orders and dead time `delay`.
    pub fn identifier(&self, delay: usize) -> Result<Box<dyn LinearIdentifier>, IdError> {
        let linear = self.linear;
        let known: Vec<(String, OrderValue)> = self
            .orders
            .iter()
            .filter(|(k, _)| linear.orders.iter().any(|o| o.name == k))
            .cloned()
            .collect();
        build_identifier(linear, &known, delay)
    }

    /// The search options for a record whose OP spans `span`.
    pub fn options(&self, span: f64) -> SearchOptions {
        SearchOptions {
            grid: self.grid.unwrap_or_else(|| GridPlan::for_span(span)),
            ..self.search
        }
    }

    /// Search `problem`: scan the dead time when it is `Auto`, then the grid. `progress`
    /// receives `(nodes done, nodes in total)` from the search's worker threads.
    pub fn run(
        &self,
        problem: Problem<'_>,
        progress: Option<&(dyn Fn(usize, usize) + Sync)>,
    ) -> Result<Fitted, RunError> {
        let started = Instant::now();
        let options = self.options(span_of(problem.op));
        let (delay, delay_scan) = match self.delay {
            Delay::Fixed(d) => (d, None),
            Delay::Auto { max } => {
                let build = |d: usize| self.identifier(d);
                let scan = estimate_delay(self.stiction, &build, problem, &options, max)?;
                (scan.delay, Some(scan))
            }
        };
        let identifier = self.identifier(delay)?;
        let mut result = quantify(
            self.stiction,
            identifier.as_ref(),
            problem,
            &options,
            progress,
        )?;
        // a PV interpolated between a historian's kept points undermines every fit on it
        if let Some(c) = datasets::compression(problem.pv).filter(datasets::Compression::detected) {
            let doubt = grid_search::Doubt::CompressedPv {
                share: c.share,
                segments: c.segments,
            };
            result.warnings.push(doubt.to_string());
            result.doubts.push(doubt);
        }
        Ok(Fitted {
            stiction: self.stiction,
            linear: self.linear.name,
            identifier,
            delay,
            delay_scan,
            result,
            elapsed_ms: started.elapsed().as_secs_f64() * 1e3,
        })
    }
}

/// A fitted Hammerstein model: what was searched and what was found.
#[derive(Debug)]
pub struct Fitted {
    /// Stiction model.
    pub stiction: &'static ModelEntry,
    /// Linear identifier's registered name.
    pub linear: &'static str,
    /// The identifier (orders and dead time).
    pub identifier: Box<dyn LinearIdentifier>,
    /// Dead time, samples.
    pub delay: usize,
    /// The dead-time scan, when the dead time was estimated.
    pub delay_scan: Option<DelayScan>,
    /// The search result.
    pub result: Quantification,
    /// Wall time, ms.
    pub elapsed_ms: f64,
}

impl Fitted {
    /// Validation F_PV of the ranking criterion.
    pub fn fit_val(&self) -> f64 {
        self.result.fits_score(self.result.criterion)
    }

    /// The reported numbers.
    pub fn summary(&self) -> FitSummary {
        let q = &self.result;
        let (id, val) = q.fits.rank(q.criterion);
        FitSummary {
            stiction_model: self.stiction.name,
            linear_model: self.linear,
            s: q.s,
            j: q.j,
            params: self
                .stiction
                .params
                .iter()
                .map(|p| p.name)
                .zip(q.stiction.param_values())
                .collect(),
            delay: self.delay,
            fit_pv_id: id,
            fit_pv_val: val,
            fit_sim_val: q.fits.sim_val,
        }
    }
}

impl Fitted {
    /// What a repair of the valve would buy on the record `d` as read (SP, PV, OP and its
    /// time column; not the increments of an integrating loop): the identified controller and
    /// this fitted loop replayed with the fitted valve and with a free one
    /// ([`repair::assess`]). `integrating`: the linear model maps MV to ΔPV. A fit with
    /// negligible S ([`grid_search::trust::NEGLIGIBLE_S`]) or with S = 0 inside its region
    /// ([`grid_search::Doubt::NoEvidence`]) cannot tell the valve from a free one: its
    /// reduction is 0, with a note.
    pub fn repair(
        &self,
        d: &datasets::LoopData,
        integrating: bool,
    ) -> Result<repair::Repair, repair::NoRepair> {
        let pv = d.pv.as_deref().unwrap_or(&[]);
        let signals = repair::Signals {
            sp: d.sp.as_deref(),
            pv,
            op: &d.op,
            sample_time: crate::sample_time(d),
        };
        let fitted = repair::FittedLoop {
            valve: self.result.stiction.as_ref(),
            mv_est: &self.result.mv_est,
            linear: &self.result.linear,
            integrating,
            indistinguishable: self.result.s <= grid_search::trust::NEGLIGIBLE_S
                || self.result.doubts.contains(&grid_search::Doubt::NoEvidence),
        };
        repair::assess(&signals, &fitted)
    }

    /// Write the fit over the whole grid as CSV (`quantify --surface`): the model's
    /// parameters, S, J, the four fits, F_MV, the first valid sample, and the reason of a
    /// skipped node.
    pub fn write_surface(&self, path: &std::path::Path) -> Result<(), RunError> {
        let file = std::fs::File::create(path).map_err(|source| RunError::Create {
            path: path.to_path_buf(),
            source,
        })?;
        let csv_err = |source| RunError::Csv {
            path: path.to_path_buf(),
            source,
        };
        let mut w = csv::Writer::from_writer(std::io::BufWriter::new(file));
        let mut header: Vec<String> = self
            .stiction
            .params
            .iter()
            .map(|p| p.name.to_string())
            .collect();
        header.extend(
            [
                "S",
                "J",
                "fit_pred_id",
                "fit_pred_val",
                "fit_sim_id",
                "fit_sim_val",
                "fit_mv",
                "valid_from",
                "skipped",
            ]
            .map(String::from),
        );
        w.write_record(&header).map_err(csv_err)?;
        for n in &self.result.surface {
            let mut row: Vec<String> = n.params.iter().map(|v| v.to_string()).collect();
            row.push(n.s.to_string());
            row.push(n.j.to_string());
            match &n.outcome {
                Ok(f) => {
                    for v in [f.pred_id, f.pred_val, f.sim_id, f.sim_val] {
                        row.push(v.to_string());
                    }
                    row.push(f.mv.map(|v| v.to_string()).unwrap_or_default());
                    row.push(f.valid_from.to_string());
                    row.push(String::new());
                }
                Err(reason) => {
                    row.extend(std::iter::repeat_n(String::new(), 6));
                    row.push(reason.to_string());
                }
            }
            w.write_record(&row).map_err(csv_err)?;
        }
        w.flush().map_err(|source| RunError::Write {
            path: path.to_path_buf(),
            source,
        })
    }
}

/// The numbers of a [`Fitted`] model that a diagnosis reports (serialisable).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitSummary {
    /// Stiction model name.
    pub stiction_model: &'static str,
    /// Linear model name.
    pub linear_model: &'static str,
    /// Equivalent S.
    #[serde(rename = "S")]
    pub s: f64,
    /// Equivalent J.
    #[serde(rename = "J")]
    pub j: f64,
    /// The stiction model's own parameters, in registry order.
    pub params: Vec<(&'static str, f64)>,
    /// Dead time.
    pub delay: usize,
    /// F_PV of the ranking criterion, identification window.
    pub fit_pv_id: f64,
    /// F_PV of the ranking criterion, validation window.
    pub fit_pv_val: f64,
    /// Free-run simulation F_PV, validation window.
    pub fit_sim_val: f64,
}

/// The identifier `linear` with the orders `orders` (`NAME=value`; a `delay` among them is
/// replaced) and dead time `delay`: an error when an order is unknown or invalid, or when the
/// identifier has no dead-time option and `delay` is not 0.
pub fn build_identifier(
    linear: &IdentifierEntry,
    orders: &[(String, OrderValue)],
    delay: usize,
) -> Result<Box<dyn LinearIdentifier>, IdError> {
    let mut pairs: Vec<(String, OrderValue)> = orders
        .iter()
        .filter(|(k, _)| k != "delay")
        .cloned()
        .collect();
    if linear.orders.iter().any(|o| o.name == "delay") {
        pairs.push(("delay".into(), OrderValue::Int(delay)));
    } else if delay != 0 {
        return Err(IdError::InvalidOrder {
            identifier: linear.name,
            name: "delay".into(),
            value: OrderValue::Int(delay),
            expected: "0 (this identifier has no dead-time option)".into(),
        });
    }
    (linear.build)(&pairs)
}

/// The search problem of a record: its OP, PV (an error when the record has none) and MV.
pub fn problem(d: &datasets::LoopData) -> Result<Problem<'_>, datasets::DataError> {
    Ok(Problem {
        op: &d.op,
        pv: d.require_pv()?,
        mv: d.mv.as_deref(),
    })
}

/// The paper's benchmark loop (eq. 10, PI 0.5/0.5, σ = 0.1) with a Kano valve S = 9, J = 3,
/// 3000 samples, seed 1 (paper §3.2, Tables 1-2): the CLI's `--example paper`.
pub fn paper_example() -> Result<datasets::LoopData, RunError> {
    let scenario = datasets::simulate::Scenario {
        valve: Box::new(stiction_models::Kano::params().s(9.0).j(3.0).check()?),
        ..datasets::simulate::Scenario::default()
    };
    let mut d = scenario.simulate()?.to_loop_data();
    d.source = "example paper (kano S = 9, J = 3, seed 1)".into();
    Ok(d)
}

/// `max - min` of the finite values of `x` (0 when there are none).
pub fn span_of(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    if hi >= lo {
        hi - lo
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_example_is_a_searchable_problem() -> Result<(), RunError> {
        let d = paper_example()?;
        assert_eq!(d.len(), 3000);
        assert!(d.source.starts_with("example paper"));
        let p = problem(&d)?;
        assert_eq!((p.op.len(), p.pv.len()), (3000, 3000));
        assert!(p.mv.is_some());
        assert_eq!(crate::identify::input_of(&d, None).1, "MV");
        assert_eq!(crate::identify::input_of(&d, Some("u")).1, "u");
        let mut no_pv = d.clone();
        no_pv.pv = None;
        assert!(problem(&no_pv).is_err());
        Ok(())
    }
}
