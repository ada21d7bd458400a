//! The registry of linear identifiers, filled by `inventory::submit!` next to each identifier.

use crate::{IdError, LinearIdentifier, OrderKind, OrderValue};

/// One order / option of a registered identifier.
#[derive(Debug, Clone, Copy)]
pub struct OrderSpec {
    /// Name as used in JSON configs and `NAME=value` pairs.
    pub name: &'static str,
    /// Value when not given; its variant is the option's type ([`OrderSpec::kind`]).
    pub default: OrderValue,
    /// One-line meaning.
    pub meaning: &'static str,
}

impl OrderSpec {
    /// The option's type: the kind of its default.
    pub fn kind(&self) -> OrderKind {
        self.default.kind()
    }

    /// `value` as this option's type ([`OrderValue::to_kind`]), or
    /// [`IdError::InvalidOrder`] naming `identifier`.
    pub fn accept(
        &self,
        identifier: &'static str,
        value: OrderValue,
    ) -> Result<OrderValue, IdError> {
        value
            .to_kind(self.kind())
            .ok_or_else(|| IdError::InvalidOrder {
                identifier,
                name: self.name.to_string(),
                value,
                expected: self.kind().expected().into(),
            })
    }
}

/// Builds a checked identifier from `NAME=value` pairs.
pub type BuildFn = fn(&[(String, OrderValue)]) -> Result<Box<dyn LinearIdentifier>, IdError>;

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
    /// entry's orders: the values in the order of [`IdentifierEntry::orders`], each of its
    /// order's type ([`OrderSpec::accept`]), defaults filled in.
    pub fn resolve(&self, pairs: &[(String, OrderValue)]) -> Result<ResolvedOrders, IdError> {
        resolve(self.name, self.orders, pairs)
    }
}

/// See [`IdentifierEntry::resolve`]; usable from a `build` function.
pub fn resolve(
    identifier: &'static str,
    orders: &'static [OrderSpec],
    pairs: &[(String, OrderValue)],
) -> Result<ResolvedOrders, IdError> {
    let mut values: Vec<OrderValue> = orders.iter().map(|o| o.default).collect();
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
        values[idx] = orders[idx].accept(identifier, *value)?;
    }
    Ok(ResolvedOrders {
        identifier,
        specs: orders,
        values,
        next: 0,
    })
}

/// The values of [`resolve`]: one per order of the identifier, in the order of its specs, each
/// of its order's type. A `build` function takes them out in turn with [`ResolvedOrders::int`],
/// [`ResolvedOrders::bool`] and [`ResolvedOrders::real`].
///
/// ```
/// use linear_id::{resolve, OrderSpec, OrderValue};
/// const SPECS: [OrderSpec; 2] = [
///     OrderSpec { name: "n", default: OrderValue::Int(2), meaning: "order" },
///     OrderSpec { name: "center", default: OrderValue::Bool(true), meaning: "center first" },
/// ];
/// let mut v = resolve("mine", &SPECS, &[("center".into(), OrderValue::Int(0))])?;
/// assert_eq!((v.int()?, v.bool()?), (2, false));
/// # Ok::<(), linear_id::IdError>(())
/// ```
#[derive(Debug, Clone)]
pub struct ResolvedOrders {
    identifier: &'static str,
    specs: &'static [OrderSpec],
    values: Vec<OrderValue>,
    next: usize,
}

impl ResolvedOrders {
    /// Every value, in the order of the specs.
    pub fn values(&self) -> &[OrderValue] {
        &self.values
    }

    /// The next value as `kind`: an error when the build function asks for another type than
    /// its spec's, or for more values than there are specs.
    fn take(&mut self, kind: OrderKind) -> Result<OrderValue, IdError> {
        let i = self.next;
        self.next += 1;
        let name = self.specs.get(i).map_or("(none)", |s| s.name);
        let value = self.values.get(i).copied().unwrap_or(OrderValue::Int(0));
        value
            .to_kind(kind)
            .filter(|_| i < self.values.len())
            .ok_or_else(|| IdError::InvalidOrder {
                identifier: self.identifier,
                name: name.to_string(),
                value,
                expected: format!(
                    "{} (the build function reads order {i} as {kind})",
                    kind.expected()
                ),
            })
    }

    /// The next value, an integer.
    pub fn int(&mut self) -> Result<usize, IdError> {
        Ok(self.take(OrderKind::Integer)?.as_int().unwrap_or_default())
    }

    /// The next value, a switch.
    pub fn bool(&mut self) -> Result<bool, IdError> {
        Ok(self.take(OrderKind::Boolean)?.as_bool().unwrap_or_default())
    }

    /// The next value, a real number.
    pub fn real(&mut self) -> Result<f64, IdError> {
        Ok(self.take(OrderKind::Real)?.as_real().unwrap_or_default())
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
