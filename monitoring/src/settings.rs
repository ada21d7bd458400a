//! What a run searches, as one serialisable value: the identifier's orders as the user gave
//! them, the dead time, the grid and the search options. [`Settings::combination`] turns them
//! into a [`Combination`] for one stiction model × one identifier, so that one set of settings
//! serves every combination of a `compare`, a `trend` or a `batch`.

use grid_search::{GridPlan, SearchOptions};
use linear_id::{find_identifier, IdentifierEntry};
use serde::{Deserialize, Serialize};
use stiction_models::find_model;

use crate::{Combination, Delay, MonitoringError};

/// The orders of a linear identifier as given: each value by its name (`n=3`) or by its
/// position among the identifier's orders without the dead time (`3,2` is `n=3, m=2` for arx,
/// `n=3, m=2` for armax too). Resolved per identifier by [`Orders::resolve`], so one list
/// serves several identifiers. Empty: every order at the identifier's default.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Orders(pub Vec<(Option<String>, f64)>);

impl Orders {
    /// Named orders.
    pub fn named<'a>(pairs: impl IntoIterator<Item = (&'a str, f64)>) -> Orders {
        Orders(
            pairs
                .into_iter()
                .map(|(k, v)| (Some(k.to_string()), v))
                .collect(),
        )
    }

    /// Whether no order is given.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// `NAME=value` pairs for `entry`: positional values take the names of the identifier's
    /// orders (without `delay`) in turn; a given `delay` is left out (the dead time is the
    /// combination's [`Delay`]).
    pub fn resolve(&self, entry: &IdentifierEntry) -> Result<Vec<(String, f64)>, MonitoringError> {
        let positional: Vec<&'static str> = entry
            .orders
            .iter()
            .map(|o| o.name)
            .filter(|n| *n != "delay")
            .collect();
        let mut out = Vec::new();
        for (i, (name, value)) in self.0.iter().enumerate() {
            let name = match name {
                Some(n) => n.clone(),
                None => positional
                    .get(i)
                    .ok_or_else(|| MonitoringError::TooManyOrders {
                        identifier: entry.name,
                        positional: positional.clone(),
                    })?
                    .to_string(),
            };
            if name != "delay" {
                out.push((name, *value));
            }
        }
        Ok(out)
    }
}

/// The settings of a search shared by every combination of a run.
///
/// ```
/// use monitoring::{Delay, Orders, Settings};
/// let settings = Settings {
///     orders: Orders::named([("n", 3.0), ("m", 2.0)]),
///     delay: Delay::Fixed(1),
///     ..Settings::default()
/// };
/// let c = settings.combination("kano", "arx")?;
/// assert_eq!(c.identifier(1)?.orders(), vec![("n", 3.0), ("m", 2.0), ("delay", 1.0)]);
/// # Ok::<(), monitoring::MonitoringError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Settings {
    /// Orders of the linear identifier.
    pub orders: Orders,
    /// Dead time.
    pub delay: Delay,
    /// Grid plan; `None`: the default grid for each record's OP span
    /// ([`GridPlan::for_span`]).
    pub grid: Option<GridPlan>,
    /// Initialization, split, criterion, confidence and node budget (its `grid` is unused:
    /// the plan above decides).
    pub search: SearchOptions,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            orders: Orders::default(),
            delay: Delay::Fixed(0),
            grid: None,
            search: SearchOptions::default(),
        }
    }
}

impl Settings {
    /// The combination of the registered stiction model `stiction` and identifier `linear`
    /// with these settings. Checks the names, the orders and that the identifier can take the
    /// fixed dead time.
    pub fn combination(
        &self,
        stiction: &str,
        linear: &str,
    ) -> Result<Combination, MonitoringError> {
        let stiction = find_model(stiction)?;
        let linear = find_identifier(linear)?;
        let combination = Combination {
            stiction,
            linear,
            orders: self.orders.resolve(linear)?,
            delay: self.delay,
            grid: self.grid,
            search: self.search,
        };
        combination.identifier(combination.fixed_delay())?;
        Ok(combination)
    }

    /// The search options for a record whose OP spans `span`.
    pub fn options(&self, span: f64) -> SearchOptions {
        SearchOptions {
            grid: self.grid.unwrap_or_else(|| GridPlan::for_span(span)),
            ..self.search
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positional_orders_follow_each_identifier() -> Result<(), MonitoringError> {
        let orders = Orders(vec![(None, 3.0), (None, 2.0), (Some("delay".into()), 4.0)]);
        let arx = orders.resolve(find_identifier("arx")?)?;
        assert_eq!(arx, vec![("n".to_string(), 3.0), ("m".to_string(), 2.0)]);
        let ss = orders.resolve(find_identifier("ss")?)?;
        assert_eq!(ss[0].0, "n");
        let too_many = Orders(vec![(None, 1.0); 3]).resolve(find_identifier("arx")?);
        assert!(
            matches!(too_many, Err(MonitoringError::TooManyOrders { .. })),
            "{too_many:?}"
        );
        Ok(())
    }
}
