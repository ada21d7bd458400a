//! One declaration per identifier: [`linear_identifier!`](crate::linear_identifier).

/// Registers a linear identifier: its name (written once: the typetag tag, the registry entry
/// and [`LinearIdentifier::name`](crate::LinearIdentifier::name)), its orders and options
/// (name, type and default, meaning, and where the value sits in the parameter builder), and
/// the body of its [`LinearIdentifier`](crate::LinearIdentifier) implementation.
///
/// The macro writes `name`, `orders` and `box_clone`, the constant `ORDERS` and `params()`
/// (the builder's default) on the identifier, `TryFrom<Params>` through the builder's
/// `check()`, the build function (each order read in turn and given to the builder's setter
/// of the same name) and the [`IdentifierEntry`](crate::IdentifierEntry). The identifier is
/// `Copy`, its builder has a setter per order, `Default` and `check()`, and
/// `From<Identifier> for Params` gives the builder back (serde goes through the builder:
/// `#[serde(try_from = "Params", into = "Params")]`).
///
/// An order line is `name: Kind(default), "meaning", |p| value;` with `Kind` one of `Int`,
/// `Real`, `Bool` ([`OrderValue`](crate::OrderValue)) and `value` read from the builder `p`.
#[macro_export]
macro_rules! linear_identifier {
    (
        $model:ident($name:tt) from $params:ident;
        description $description:expr;
        orders {
            $($order:ident: $kind:ident($default:expr), $meaning:expr, |$p:ident| $get:expr;)+
        }
        impl { $($body:tt)* }
    ) => {
        impl $model {
            /// The orders and options, in the order of the registry entry.
            pub const ORDERS: &'static [$crate::OrderSpec] = &[$(
                $crate::OrderSpec {
                    name: stringify!($order),
                    default: $crate::OrderValue::$kind($default),
                    meaning: $meaning,
                },
            )+];
            /// Start a parameter builder at the defaults.
            pub fn params() -> $params {
                $params::default()
            }
        }

        impl TryFrom<$params> for $model {
            type Error = $crate::IdError;
            fn try_from(p: $params) -> Result<Self, $crate::IdError> {
                p.check()
            }
        }

        const _: () = {
            use $crate::typetag;

            #[typetag::serde(name = $name)]
            impl $crate::LinearIdentifier for $model {
                fn name(&self) -> &'static str {
                    $name
                }
                fn orders(&self) -> Vec<(&'static str, $crate::OrderValue)> {
                    let params = $params::from(*self);
                    vec![$(
                        (stringify!($order), $crate::OrderValue::$kind({
                            let $p = &params;
                            $get
                        })),
                    )+]
                }
                fn box_clone(&self) -> Box<dyn $crate::LinearIdentifier> {
                    Box::new(*self)
                }
                $($body)*
            }

            fn build(
                pairs: &[(String, $crate::OrderValue)],
            ) -> Result<Box<dyn $crate::LinearIdentifier>, $crate::IdError> {
                let mut v = $crate::resolve($name, $model::ORDERS, pairs)?;
                Ok(Box::new(
                    $model::params()$(.$order($crate::__take!(v, $kind)))+.check()?,
                ))
            }

            $crate::inventory::submit! {
                $crate::IdentifierEntry {
                    name: $name,
                    description: $description,
                    orders: $model::ORDERS,
                    build,
                }
            }
        };
    };
}

/// The next resolved order as `Kind` ([`linear_identifier!`](crate::linear_identifier)).
#[doc(hidden)]
#[macro_export]
macro_rules! __take {
    ($v:ident, Int) => {
        $v.int()?
    };
    ($v:ident, Real) => {
        $v.real()?
    };
    ($v:ident, Bool) => {
        $v.bool()?
    };
}
