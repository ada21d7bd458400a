//! The search settings of a command as data: what the CLI's flags (`--orders`, `--delay`,
//! `--step`, `--init`, `--criterion`, `--split`, `--max-nodes`), a Python call's keyword
//! arguments and a batch job's settings all become, checked in one place and turned into a
//! [`Combination`]. The messages name the CLI's flags, which the Python keywords mirror.

use grid_search::{Criterion, GridPlan, SearchOptions};
use linear_id::{find_identifier, IdentifierEntry};
use serde::{Deserialize, Serialize};
use stiction_models::{find_model, Initialization};

use crate::{Combination, Delay, MonitoringError, MAX_AUTO_DELAY};

/// The dead time as set: a number of samples or `"auto"` (scan `0..=MAX_AUTO_DELAY`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DelaySetting {
    /// A fixed number of samples.
    Samples(usize),
    /// Estimated.
    Auto,
}

impl Default for DelaySetting {
    fn default() -> Self {
        DelaySetting::Samples(0)
    }
}

impl DelaySetting {
    /// `N` or `auto` (the `--delay` flag's syntax).
    pub fn parse(s: &str) -> Result<DelaySetting, String> {
        if s.trim().eq_ignore_ascii_case("auto") {
            return Ok(DelaySetting::Auto);
        }
        s.trim()
            .parse::<usize>()
            .map(DelaySetting::Samples)
            .map_err(|_| format!("expected a number of samples or `auto`, got {s:?}"))
    }

    /// The fixed dead time (0 for `Auto`).
    pub fn fixed(self) -> usize {
        match self {
            DelaySetting::Auto => 0,
            DelaySetting::Samples(n) => n,
        }
    }

    fn delay(self) -> Delay {
        match self {
            DelaySetting::Auto => Delay::Auto {
                max: MAX_AUTO_DELAY,
            },
            DelaySetting::Samples(n) => Delay::Fixed(n),
        }
    }
}

impl Serialize for DelaySetting {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            DelaySetting::Auto => s.serialize_str("auto"),
            other => s.serialize_u64(other.fixed() as u64),
        }
    }
}

impl<'de> Deserialize<'de> for DelaySetting {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            N(u64),
            S(String),
        }
        match Raw::deserialize(d)? {
            Raw::N(n) => Ok(DelaySetting::Samples(n as usize)),
            Raw::S(s) => DelaySetting::parse(&s).map_err(serde::de::Error::custom),
        }
    }
}

/// The search settings (the CLI's defaults when absent).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SearchSettings {
    /// Orders of the identifier: positional (`2,2`) or named (`na=2,nb=2`); `None` = its
    /// defaults.
    pub orders: Option<String>,
    /// Dead time.
    pub delay: DelaySetting,
    /// Grid step in OP units (an exhaustive grid); `None` = the coarse-to-fine plan for the OP
    /// span.
    pub step: Option<f64>,
    /// Initialization: `In.1`, `In.2` or `In.3`.
    pub init: String,
    /// Ranking fit: `prediction` or `simulation`.
    pub criterion: String,
    /// Identification fraction of the record, strictly between 0 and 1.
    pub split: f64,
    /// Node budget of one grid stage.
    pub max_nodes: usize,
}

impl Default for SearchSettings {
    fn default() -> Self {
        SearchSettings {
            orders: None,
            delay: DelaySetting::default(),
            step: None,
            init: "In.3".into(),
            criterion: "prediction".into(),
            split: 2.0 / 3.0,
            max_nodes: grid_search::budget::DEFAULT_MAX_NODES,
        }
    }
}

/// A setting that cannot work; `message` is the whole sentence, naming the CLI's flag.
fn bad(flag: &'static str, message: String) -> MonitoringError {
    MonitoringError::Setting { flag, message }
}

impl SearchSettings {
    /// The initialization.
    pub fn initialization(&self) -> Result<Initialization, MonitoringError> {
        Initialization::parse(&self.init).ok_or_else(|| {
            bad(
                "--init",
                format!("--init: expected In.1, In.2 or In.3, got {:?}", self.init),
            )
        })
    }

    /// The ranking criterion.
    pub fn ranking(&self) -> Result<Criterion, MonitoringError> {
        match self.criterion.to_ascii_lowercase().as_str() {
            "prediction" => Ok(Criterion::Prediction),
            "simulation" => Ok(Criterion::Simulation),
            other => Err(bad(
                "--criterion",
                format!("--criterion: expected prediction or simulation, got {other:?}"),
            )),
        }
    }

    /// The search options for a record whose OP spans `span`.
    pub fn options(&self, span: f64) -> Result<SearchOptions, MonitoringError> {
        let grid = match self.step {
            Some(step) if step.is_finite() && step > 0.0 => GridPlan::Exhaustive { step },
            Some(step) => {
                return Err(bad(
                    "--step",
                    format!("--step {step}: expected a positive step in OP units"),
                ))
            }
            None => GridPlan::for_span(span),
        };
        if !(self.split.is_finite() && self.split > 0.0 && self.split < 1.0) {
            return Err(bad(
                "--split",
                format!(
                    "--split {}: expected a fraction strictly between 0 and 1",
                    self.split
                ),
            ));
        }
        Ok(SearchOptions {
            init: self.initialization()?,
            grid,
            split: self.split,
            criterion: self.ranking()?,
            max_nodes: self.max_nodes,
            ..SearchOptions::default()
        })
    }

    /// `stiction` × `linear` (registered names) with these settings. The identifier is built
    /// once here, so unknown names, bad orders and a dead time the identifier has no option
    /// for are errors now, not in the search.
    pub fn combination(
        &self,
        stiction: &str,
        linear: &str,
    ) -> Result<Combination, MonitoringError> {
        let stiction = find_model(stiction)?;
        let entry = find_identifier(linear)?;
        let mut orders = parse_orders(entry, self.orders.as_deref().unwrap_or(""))?;
        orders.retain(|(k, _)| k != "delay");
        let options = self.options(1.0)?;
        let combination = Combination {
            stiction,
            linear: entry,
            orders,
            delay: self.delay.delay(),
            grid: self.step.map(|_| options.grid),
            search: options,
        };
        if combination.linear.orders.iter().all(|o| o.name != "delay") && self.delay.fixed() != 0 {
            return Err(bad(
                "--delay",
                format!("{}: this identifier has no dead-time option", entry.name),
            ));
        }
        combination.identifier(self.delay.fixed())?;
        Ok(combination)
    }
}

/// `--orders` text (positional `2,2` or named `na=2,nb=2`) as `NAME=value` pairs of `entry`.
pub fn parse_orders(
    entry: &IdentifierEntry,
    s: &str,
) -> Result<Vec<(String, f64)>, MonitoringError> {
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
                    bad(
                        "--orders",
                        format!(
                            "--orders {s:?}: {} takes at most {} positional orders ({})",
                            entry.name,
                            positional.len(),
                            positional.join(", ")
                        ),
                    )
                })?;
                (name.to_string(), item)
            }
        };
        let value: f64 = value.parse().map_err(|_| {
            bad(
                "--orders",
                format!("--orders: {name} = {value:?} is not a number"),
            )
        })?;
        out.push((name, value));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn settings_round_trip_and_refuse_what_cannot_work() {
        let s: SearchSettings =
            serde_json::from_str(r#"{"orders": "3,2", "delay": "auto", "step": 0.5}"#).unwrap();
        assert_eq!(s.delay, DelaySetting::Auto);
        let back: SearchSettings =
            serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(back, s);
        let c = s.combination("kano", "arx").unwrap();
        assert_eq!(
            c.orders,
            vec![("n".to_string(), 3.0), ("m".to_string(), 2.0)]
        );
        assert!(matches!(c.delay, Delay::Auto { .. }));
        assert!(serde_json::from_str::<SearchSettings>(r#"{"oders": "2"}"#).is_err());
        let bad_step = SearchSettings {
            step: Some(-1.0),
            ..Default::default()
        };
        assert!(bad_step.combination("kano", "arx").is_err());
        let bad_orders = SearchSettings {
            orders: Some("2,2,2,2,2".into()),
            ..Default::default()
        };
        let e = bad_orders
            .combination("kano", "arx")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--orders"), "{e}");
        let delay_ss = SearchSettings {
            delay: DelaySetting::Samples(2),
            ..Default::default()
        };
        assert!(delay_ss.combination("kano", "arx").is_ok());
    }
}
