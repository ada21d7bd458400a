//! The registry of linear identifiers, filled by `inventory::submit!` next to each identifier.

use crate::{IdError, LinearIdentifier};

/// One order / option of a registered identifier.
#[derive(Debug, Clone, Copy)]
pub struct OrderSpec {
    /// Name as used in JSON configs and `NAME=value` pairs.
    pub name: &'static str,
    /// Value when not given.
    pub default: f64,
    /// One-line meaning.
    pub meaning: &'static str,
}

/// Builds a checked identifier from `NAME=value` pairs.
pub type BuildFn = fn(&[(String, f64)]) -> Result<Box<dyn LinearIdentifier>, IdError>;

/// A registered identifier: what `stiction identifiers` lists and what a grid search builds.
#[derive(Debug)]
pub struct IdentifierEntry {
    /// Registered name, equal to the typetag tag.
    pub name: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// Orders and options, with defaults.
    pub orders: &'static [OrderSpec],
    /// Build a checked identifier from `NAME=value` pairs (missing ones take their default).
    pub build: BuildFn,
}

inventory::collect!(IdentifierEntry);

impl IdentifierEntry {
    /// Build with every order at its default.
    pub fn build_default(&self) -> Result<Box<dyn LinearIdentifier>, IdError> {
        (self.build)(&[])
    }

    /// Order names in order.
    pub fn order_names(&self) -> Vec<&'static str> {
        self.orders.iter().map(|o| o.name).collect()
    }

    /// Resolve `NAME=value` pairs (exact names first, then case-insensitive) against the
    /// entry's orders: the values in the order of [`IdentifierEntry::orders`], defaults filled in.
    pub fn resolve(&self, pairs: &[(String, f64)]) -> Result<Vec<f64>, IdError> {
        resolve(self.name, self.orders, pairs)
    }
}

/// See [`IdentifierEntry::resolve`]; usable from a `build` function.
pub fn resolve(
    identifier: &'static str,
    orders: &'static [OrderSpec],
    pairs: &[(String, f64)],
) -> Result<Vec<f64>, IdError> {
    let mut values: Vec<f64> = orders.iter().map(|o| o.default).collect();
    for (name, value) in pairs {
        let idx = orders
            .iter()
            .position(|o| o.name == name)
            .or_else(|| {
                orders
                    .iter()
                    .position(|o| o.name.eq_ignore_ascii_case(name))
            })
            .ok_or_else(|| IdError::UnknownOrder {
                identifier,
                name: name.clone(),
                known: orders.iter().map(|o| o.name).collect::<Vec<_>>().join(", "),
            })?;
        values[idx] = *value;
    }
    Ok(values)
}

/// Convert a registry value to a non-negative integer order.
pub fn as_order(identifier: &'static str, name: &str, value: f64) -> Result<usize, IdError> {
    if value.is_finite() && value >= 0.0 && value.fract() == 0.0 && value <= 1e6 {
        Ok(value as usize)
    } else {
        Err(IdError::InvalidOrder {
            identifier,
            name: name.to_string(),
            value,
            expected: "a non-negative integer".into(),
        })
    }
}

/// Every registered identifier, sorted by name.
pub fn registry() -> Vec<&'static IdentifierEntry> {
    let mut v: Vec<_> = inventory::iter::<IdentifierEntry>.into_iter().collect();
    v.sort_by_key(|e| e.name);
    v
}

/// The registered identifier called `name`, or an error listing the registered names.
pub fn find_identifier(name: &str) -> Result<&'static IdentifierEntry, IdError> {
    let all = registry();
    all.iter()
        .find(|e| e.name == name)
        .or_else(|| all.iter().find(|e| e.name.eq_ignore_ascii_case(name)))
        .copied()
        .ok_or_else(|| IdError::UnknownIdentifier {
            name: name.to_string(),
            known: all.iter().map(|e| e.name).collect::<Vec<_>>().join(", "),
        })
}

/// The registered `&'static` name equal to `kind`, or `"unknown"`.
pub(crate) fn static_name(kind: &str) -> &'static str {
    registry()
        .into_iter()
        .find(|e| e.name == kind)
        .map_or("unknown", |e| e.name)
}
