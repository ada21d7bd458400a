//! Typed values of the identifiers' orders and options: an order is an integer, a switch a
//! boolean, a tuning constant a real number.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// The type of an order or option ([`crate::OrderSpec::kind`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[non_exhaustive]
pub enum OrderKind {
    /// A non-negative integer (an order, a horizon, a dead time in samples).
    Integer,
    /// A switch: `true` / `false` (also written `1` / `0`).
    Boolean,
    /// A real number (a tuning constant).
    Real,
}

impl OrderKind {
    /// What a value of this kind is, in words (for error messages).
    pub fn expected(self) -> &'static str {
        match self {
            OrderKind::Integer => "a non-negative integer",
            OrderKind::Boolean => "true or false (or 1 or 0)",
            OrderKind::Real => "a number",
        }
    }
}

impl fmt::Display for OrderKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            OrderKind::Integer => "integer",
            OrderKind::Boolean => "boolean",
            OrderKind::Real => "real",
        })
    }
}

/// The value of an order or option. Serialised as a bare JSON value (`2`, `true`, `0.8`);
/// displayed the same way (`n=2`, `center=true`, `lambda_beta=0.8`).
///
/// ```
/// use linear_id::{OrderKind, OrderValue};
/// let v: OrderValue = "1".parse()?;
/// assert_eq!(v, OrderValue::Int(1));
/// assert_eq!(v.to_kind(OrderKind::Boolean), Some(OrderValue::Bool(true)));
/// assert_eq!(v.to_kind(OrderKind::Real), Some(OrderValue::Real(1.0)));
/// assert_eq!("2.5".parse::<OrderValue>()?.to_kind(OrderKind::Integer), None);
/// assert_eq!(serde_json::to_string(&[OrderValue::Int(2), OrderValue::Bool(false)])?, "[2,false]");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
#[non_exhaustive]
pub enum OrderValue {
    /// A non-negative integer.
    Int(usize),
    /// A switch.
    Bool(bool),
    /// A real number.
    Real(f64),
}

impl OrderValue {
    /// The kind of this value as written.
    pub fn kind(self) -> OrderKind {
        match self {
            OrderValue::Int(_) => OrderKind::Integer,
            OrderValue::Bool(_) => OrderKind::Boolean,
            OrderValue::Real(_) => OrderKind::Real,
        }
    }

    /// This value as an option of kind `kind`, when it is one: an integer is also a real
    /// number, and `0` / `1` are also `false` / `true`; a real number is never an integer
    /// (`2.0` for an order is refused, not rounded).
    pub fn to_kind(self, kind: OrderKind) -> Option<OrderValue> {
        match (self, kind) {
            (OrderValue::Int(_), OrderKind::Integer)
            | (OrderValue::Bool(_), OrderKind::Boolean)
            | (OrderValue::Real(_), OrderKind::Real) => Some(self),
            (OrderValue::Int(0), OrderKind::Boolean) => Some(OrderValue::Bool(false)),
            (OrderValue::Int(1), OrderKind::Boolean) => Some(OrderValue::Bool(true)),
            (OrderValue::Int(n), OrderKind::Real) => Some(OrderValue::Real(n as f64)),
            _ => None,
        }
    }

    /// The integer, if this is one.
    pub fn as_int(self) -> Option<usize> {
        match self {
            OrderValue::Int(n) => Some(n),
            _ => None,
        }
    }

    /// The switch, if this is one (`0` / `1` count).
    pub fn as_bool(self) -> Option<bool> {
        match self.to_kind(OrderKind::Boolean) {
            Some(OrderValue::Bool(b)) => Some(b),
            _ => None,
        }
    }

    /// The number, if this is one (an integer counts).
    pub fn as_real(self) -> Option<f64> {
        match self.to_kind(OrderKind::Real) {
            Some(OrderValue::Real(x)) => Some(x),
            _ => None,
        }
    }
}

impl fmt::Display for OrderValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OrderValue::Int(n) => write!(f, "{n}"),
            OrderValue::Bool(b) => write!(f, "{b}"),
            OrderValue::Real(x) => write!(f, "{x}"),
        }
    }
}

/// Text that is not an order value ([`OrderValue`]'s `FromStr`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0:?} is not a number, true or false")]
pub struct OrderParseError(pub String);

impl FromStr for OrderValue {
    type Err = OrderParseError;

    /// A non-negative integer (`2`), `true` / `false` (any case), or a number (`0.8`, `-1`,
    /// `1e-3`; not NaN or infinite).
    fn from_str(s: &str) -> Result<OrderValue, OrderParseError> {
        let t = s.trim();
        if t.eq_ignore_ascii_case("true") {
            return Ok(OrderValue::Bool(true));
        }
        if t.eq_ignore_ascii_case("false") {
            return Ok(OrderValue::Bool(false));
        }
        if let Ok(n) = t.parse::<usize>() {
            return Ok(OrderValue::Int(n));
        }
        match t.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(OrderValue::Real(x)),
            _ => Err(OrderParseError(t.to_string())),
        }
    }
}

impl From<usize> for OrderValue {
    fn from(n: usize) -> Self {
        OrderValue::Int(n)
    }
}

impl From<bool> for OrderValue {
    fn from(b: bool) -> Self {
        OrderValue::Bool(b)
    }
}

impl From<f64> for OrderValue {
    fn from(x: f64) -> Self {
        OrderValue::Real(x)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn text_json_and_kinds() {
        for (text, v) in [
            ("3", OrderValue::Int(3)),
            (" true", OrderValue::Bool(true)),
            ("FALSE", OrderValue::Bool(false)),
            ("0.8", OrderValue::Real(0.8)),
            ("2.0", OrderValue::Real(2.0)),
            ("-1", OrderValue::Real(-1.0)),
        ] {
            assert_eq!(text.parse::<OrderValue>().unwrap(), v, "{text}");
        }
        for bad in ["x", "", "NaN", "inf", "1,2"] {
            assert!(bad.parse::<OrderValue>().is_err(), "{bad}");
        }
        let json = serde_json::to_string(&[
            OrderValue::Int(2),
            OrderValue::Bool(true),
            OrderValue::Real(0.1),
        ])
        .unwrap();
        assert_eq!(json, "[2,true,0.1]");
        let back: Vec<OrderValue> = serde_json::from_str("[2,true,0.1,2.0]").unwrap();
        assert_eq!(
            back,
            [
                OrderValue::Int(2),
                OrderValue::Bool(true),
                OrderValue::Real(0.1),
                OrderValue::Real(2.0)
            ]
        );
        assert_eq!(OrderValue::Int(2).to_kind(OrderKind::Boolean), None);
        assert_eq!(OrderValue::Bool(true).to_kind(OrderKind::Integer), None);
        assert_eq!(OrderValue::Real(1.0).to_kind(OrderKind::Boolean), None);
        assert_eq!(OrderValue::Int(0).as_bool(), Some(false));
        assert_eq!(OrderValue::Int(4).as_real(), Some(4.0));
        assert_eq!(
            format!(
                "{} {} {}",
                OrderValue::Int(2),
                OrderValue::Bool(false),
                OrderValue::Real(0.8)
            ),
            "2 false 0.8"
        );
    }
}
