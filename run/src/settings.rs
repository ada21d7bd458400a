//! What a run searches, as one serialisable value: the identifier's orders as the user gave
//! them, the dead time, the grid and the search options. [`Settings::combination`] turns them
//! into a [`Combination`] for one stiction model × one identifier, so that one set of settings
//! serves every combination of a `compare`, a `trend` or a `batch`.

use grid_search::{GridPlan, SearchOptions};
use linear_id::{find_identifier, IdentifierEntry, LinearIdentifier, OrderSpec, OrderValue};
use serde::{Deserialize, Serialize};
use stiction_models::find_model;

use crate::{Combination, Delay, RunError};

/// The orders of a linear identifier as given: each value by its name (`n=3`) or by its
/// position among the identifier's orders without the dead time (`3,2` is `n=3, m=2` for arx,
/// `n=3, m=2` for armax too). Resolved per identifier by [`Orders::resolve`], so one list
/// serves several identifiers; each value is as written (`3` an integer, `true` a switch, `0.7`
/// a number) and takes its order's type there. Empty: every order at the identifier's default.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Orders(pub Vec<(Option<String>, OrderValue)>);

impl Orders {
    /// Named orders.
    pub fn named<'a>(pairs: impl IntoIterator<Item = (&'a str, OrderValue)>) -> Orders {
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
    /// orders (without `delay`) in turn, each value its order's type (an error when it is not
    /// one, [`linear_id::OrderSpec::accept`]); a given `delay` is left out (the dead time is the
    /// combination's [`Delay`]); a name the identifier does not know is kept (the identifier
    /// refuses it when built).
    pub fn resolve(&self, entry: &IdentifierEntry) -> Result<Vec<(String, OrderValue)>, RunError> {
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
                    .ok_or_else(|| RunError::TooManyOrders {
                        identifier: entry.name,
                        positional: positional.clone(),
                    })?
                    .to_string(),
            };
            match spec(entry, &name) {
                Some(spec) if spec.name == "delay" => {}
                Some(spec) => out.push((spec.name.to_string(), spec.accept(entry.name, *value)?)),
                None => out.push((name, *value)),
            }
        }
        Ok(out)
    }
}

/// The settings of a search shared by every combination of a run.
///
/// ```
/// use linear_id::OrderValue::Int;
/// use run::{Delay, Orders, Settings};
/// let settings = Settings {
///     orders: Orders::named([("n", Int(3)), ("m", Int(2))]),
///     delay: Delay::Fixed(1),
///     ..Settings::default()
/// };
/// let c = settings.combination("kano", "arx")?;
/// assert_eq!(c.identifier(1)?.orders(), vec![("n", Int(3)), ("m", Int(2)), ("delay", Int(1))]);
/// # Ok::<(), run::RunError>(())
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
    pub fn combination(&self, stiction: &str, linear: &str) -> Result<Combination, RunError> {
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

/// The dead time as the CLI's `--delay` and Python's `delay=` spell it: a number of samples or
/// `"auto"` (scan `0..=MAX_AUTO_DELAY`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DelayArg {
    /// A fixed number of samples.
    Samples(usize),
    /// Estimated.
    Auto,
}

impl Default for DelayArg {
    fn default() -> Self {
        DelayArg::Samples(0)
    }
}

impl DelayArg {
    /// `N` or `auto`.
    pub fn parse(s: &str) -> Result<DelayArg, String> {
        if s.trim().eq_ignore_ascii_case("auto") {
            return Ok(DelayArg::Auto);
        }
        s.trim()
            .parse::<usize>()
            .map(DelayArg::Samples)
            .map_err(|_| format!("expected a number of samples or `auto`, got {s:?}"))
    }

    /// The fixed dead time (0 for `Auto`).
    pub fn fixed(self) -> usize {
        match self {
            DelayArg::Auto => 0,
            DelayArg::Samples(n) => n,
        }
    }

    /// The combination's [`Delay`].
    pub fn delay(self) -> Delay {
        match self {
            DelayArg::Auto => Delay::Auto {
                max: crate::MAX_AUTO_DELAY,
            },
            DelayArg::Samples(n) => Delay::Fixed(n),
        }
    }
}

impl Serialize for DelayArg {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            DelayArg::Auto => s.serialize_str("auto"),
            DelayArg::Samples(n) => s.serialize_u64(*n as u64),
        }
    }
}

impl<'de> Deserialize<'de> for DelayArg {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            N(u64),
            S(String),
        }
        match Raw::deserialize(d)? {
            Raw::N(n) => Ok(DelayArg::Samples(n as usize)),
            Raw::S(s) => DelayArg::parse(&s).map_err(serde::de::Error::custom),
        }
    }
}

/// The search settings as the CLI's flags (`--orders`, `--delay`, `--step`, `--init`,
/// `--criterion`, `--split`, `--max-nodes`) and the Python package's keywords spell them: text
/// and numbers, with the CLI's defaults. [`SearchArgs::settings`] checks them once, with
/// messages naming the flag, and gives the [`Settings`]; the CLI and the Python binding both go
/// through it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SearchArgs {
    /// Orders: positional (`2,2`) or named (`n=2,m=2`); `None` = the identifier's defaults.
    pub orders: Option<String>,
    /// Dead time.
    pub delay: DelayArg,
    /// Exhaustive grid step in OP units; `None` = the coarse-to-fine plan for the OP span.
    pub step: Option<f64>,
    /// `In.1`, `In.2` or `In.3`.
    pub init: String,
    /// `prediction` or `simulation`.
    pub criterion: String,
    /// Identification fraction, strictly between 0 and 1.
    pub split: f64,
    /// Node budget of one grid stage.
    pub max_nodes: usize,
    /// Work budget of one grid stage (nodes × samples × cost per sample).
    pub max_work: f64,
}

impl Default for SearchArgs {
    fn default() -> Self {
        SearchArgs {
            orders: None,
            delay: DelayArg::default(),
            step: None,
            init: "In.3".into(),
            criterion: "prediction".into(),
            split: 2.0 / 3.0,
            max_nodes: grid_search::budget::DEFAULT_MAX_NODES,
            max_work: grid_search::budget::DEFAULT_MAX_WORK,
        }
    }
}

fn setting(flag: &'static str, message: String) -> RunError {
    RunError::Setting { flag, message }
}

/// The items of `--orders` text: `(name, value text)`, name `None` for a positional value.
fn order_items(s: &str) -> impl Iterator<Item = (Option<&str>, &str)> {
    s.split(',')
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .map(|item| match item.split_once('=') {
            Some((k, v)) => (Some(k.trim()), v.trim()),
            None => (None, item),
        })
}

/// The order of `entry` called `name` (exact name first, then case-insensitive).
fn spec<'a>(entry: &'a IdentifierEntry, name: &str) -> Option<&'a OrderSpec> {
    let orders = entry.orders.iter();
    orders
        .clone()
        .find(|o| o.name == name)
        .or_else(|| orders.clone().find(|o| o.name.eq_ignore_ascii_case(name)))
}

/// `--orders` text for the identifier `entry` (`None`: names and types not checked against
/// one), with the CLI's messages. A value is read as written (`2` an integer, `true` a switch,
/// `0.8` a number); with `entry`, an order of it must be of its type: an integer for an order,
/// `0`, `1`, `true` or `false` for a switch, a number for a real option.
///
/// ```
/// let ss = linear_id::find_identifier("ss")?;
/// assert!(run::parse_orders("n=3,center=0", Some(ss)).is_ok());
/// let e = run::parse_orders("n=2.5", Some(ss)).unwrap_err();
/// assert_eq!(e.to_string(), r#"--orders: n = "2.5" is not a non-negative integer"#);
/// # Ok::<(), linear_id::IdError>(())
/// ```
pub fn parse_orders(text: &str, entry: Option<&IdentifierEntry>) -> Result<Orders, RunError> {
    let positional: Vec<&OrderSpec> = entry
        .map(|e| e.orders.iter().filter(|o| o.name != "delay").collect())
        .unwrap_or_default();
    let mut parsed = Vec::new();
    for (i, (key, value)) in order_items(text).enumerate() {
        let order = match (key, entry) {
            (Some(k), Some(e)) => spec(e, k),
            (Some(_), None) | (None, None) => None,
            (None, Some(e)) => Some(*positional.get(i).ok_or_else(|| {
                let names: Vec<&str> = positional.iter().map(|o| o.name).collect();
                setting(
                    "--orders",
                    format!(
                        "--orders {text:?}: {} takes at most {} positional orders ({})",
                        e.name,
                        names.len(),
                        names.join(", ")
                    ),
                )
            })?),
        };
        let shown = key.or(order.map(|o| o.name)).unwrap_or("order");
        let expected = order.map_or("a number, true or false", |o| o.kind().expected());
        let typed = value
            .parse::<OrderValue>()
            .ok()
            .filter(|v| order.is_none_or(|o| v.to_kind(o.kind()).is_some()))
            .ok_or_else(|| {
                setting(
                    "--orders",
                    format!("--orders: {shown} = {value:?} is not {expected}"),
                )
            })?;
        parsed.push((key.map(str::to_string), typed));
    }
    Ok(Orders(parsed))
}

/// The registered identifier `linear` with the `--orders` text `orders` and the fixed dead time
/// `delay`, checked with the flags' messages ([`parse_orders`]; `--delay` when the identifier
/// has no dead-time option), and the orders as given.
///
/// ```
/// let (arx, _) = run::identifier_for("arx", "3,2", 1)?;
/// assert_eq!(arx.orders()[0], ("n", linear_id::OrderValue::Int(3)));
/// assert!(run::identifier_for("ss", "", 1).is_err());
/// # Ok::<(), run::RunError>(())
/// ```
pub fn identifier_for(
    linear: &str,
    orders: &str,
    delay: usize,
) -> Result<(Box<dyn LinearIdentifier>, Orders), RunError> {
    let entry = find_identifier(linear)?;
    let orders = parse_orders(orders, Some(entry))?;
    if delay != 0 && !entry.orders.iter().any(|o| o.name == "delay") {
        return Err(setting(
            "--delay",
            format!("{}: this identifier has no dead-time option", entry.name),
        ));
    }
    let named = orders.resolve(entry)?;
    let identifier = crate::build_identifier(entry, &named, delay)?;
    Ok((identifier, orders))
}

impl SearchArgs {
    /// The settings for a run over the identifiers `linear` (each is checked: its name, the
    /// orders for it, the dead time it can take).
    pub fn settings(&self, linear: &[&str]) -> Result<Settings, RunError> {
        let text = self.orders.as_deref().unwrap_or("");
        let mut orders = None;
        for name in linear {
            orders = Some(identifier_for(name, text, self.delay.fixed())?.1);
        }
        let orders = match orders {
            Some(orders) => orders,
            None => parse_orders(text, None)?,
        };
        let grid = match self.step {
            Some(step) if step.is_finite() && step > 0.0 => Some(GridPlan::Exhaustive { step }),
            Some(step) => {
                return Err(setting(
                    "--step",
                    format!("--step {step}: expected a positive step in OP units"),
                ))
            }
            None => None,
        };
        if !(self.split.is_finite() && self.split > 0.0 && self.split < 1.0) {
            return Err(setting(
                "--split",
                format!(
                    "--split {}: expected a fraction strictly between 0 and 1",
                    self.split
                ),
            ));
        }
        let init = stiction_models::Initialization::parse(&self.init).ok_or_else(|| {
            setting(
                "--init",
                format!("--init: expected In.1, In.2 or In.3, got {:?}", self.init),
            )
        })?;
        let criterion = match self.criterion.to_ascii_lowercase().as_str() {
            "prediction" => grid_search::Criterion::Prediction,
            "simulation" => grid_search::Criterion::Simulation,
            other => {
                return Err(setting(
                    "--criterion",
                    format!("--criterion: expected prediction or simulation, got {other:?}"),
                ))
            }
        };
        Ok(Settings {
            orders,
            delay: self.delay.delay(),
            grid,
            search: SearchOptions {
                init,
                split: self.split,
                criterion,
                max_nodes: self.max_nodes,
                max_work: self.max_work,
                ..SearchOptions::default()
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positional_orders_follow_each_identifier() -> Result<(), RunError> {
        use OrderValue::{Bool, Int, Real};
        let orders = Orders(vec![
            (None, Int(3)),
            (None, Int(2)),
            (Some("delay".into()), Int(4)),
        ]);
        let arx = orders.resolve(find_identifier("arx")?)?;
        assert_eq!(
            arx,
            vec![("n".to_string(), Int(3)), ("m".to_string(), Int(2))]
        );
        let ss = orders.resolve(find_identifier("ss")?)?;
        assert_eq!(ss[0].0, "n");
        // each value takes its order's type; names are the identifier's
        let given = Orders::named([("N", Int(1)), ("center", Int(0)), ("threshold", Int(0))]);
        assert_eq!(
            given.resolve(find_identifier("ss")?)?,
            vec![
                ("n".to_string(), Int(1)),
                ("center".to_string(), Bool(false)),
                ("threshold".to_string(), Real(0.0))
            ]
        );
        let wrong = Orders::named([("n", Real(2.0))]).resolve(find_identifier("arx")?);
        assert!(
            matches!(wrong, Err(RunError::Identification(_))),
            "{wrong:?}"
        );
        let too_many = Orders(vec![(None, Int(1)); 3]).resolve(find_identifier("arx")?);
        assert!(
            matches!(too_many, Err(RunError::TooManyOrders { .. })),
            "{too_many:?}"
        );
        Ok(())
    }

    #[test]
    fn search_args_give_the_settings_or_the_flag_s_message() -> Result<(), RunError> {
        let args: SearchArgs = serde_json::from_str(
            r#"{"orders": "3,2", "delay": "auto", "step": 0.5}"#,
        )
        .map_err(|e| RunError::Setting {
            flag: "json",
            message: e.to_string(),
        })?;
        let s = args.settings(&["arx"])?;
        assert!(matches!(s.delay, Delay::Auto { .. }));
        assert_eq!(s.grid, Some(GridPlan::Exhaustive { step: 0.5 }));
        assert_eq!(
            s.orders.resolve(find_identifier("arx")?)?,
            vec![
                ("n".to_string(), OrderValue::Int(3)),
                ("m".to_string(), OrderValue::Int(2))
            ]
        );
        assert!(serde_json::from_str::<SearchArgs>(r#"{"oders": "2"}"#).is_err());
        let cases = [
            (
                SearchArgs {
                    step: Some(-1.0),
                    ..SearchArgs::default()
                },
                "--step",
            ),
            (
                SearchArgs {
                    orders: Some("2,2,2,2,2".into()),
                    ..SearchArgs::default()
                },
                "--orders",
            ),
            (
                SearchArgs {
                    orders: Some("n=x".into()),
                    ..SearchArgs::default()
                },
                "--orders",
            ),
            (
                SearchArgs {
                    orders: Some("2.5".into()),
                    ..SearchArgs::default()
                },
                "--orders",
            ),
            (
                SearchArgs {
                    split: 1.5,
                    ..SearchArgs::default()
                },
                "--split",
            ),
            (
                SearchArgs {
                    init: "In.4".into(),
                    ..SearchArgs::default()
                },
                "--init",
            ),
            (
                SearchArgs {
                    criterion: "best".into(),
                    ..SearchArgs::default()
                },
                "--criterion",
            ),
        ];
        for (args, flag) in cases {
            let e = args
                .settings(&["arx"])
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(e.starts_with(flag), "{flag}: {e}");
        }
        Ok(())
    }
}
