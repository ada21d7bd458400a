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

/// A builder setter per field: `fn field(mut self, value: T) -> Self` (in an `impl` block of
/// a parameter builder).
macro_rules! setters {
    ($($field:ident: $ty:ty),+ $(,)?) => {
        $(
            #[doc = concat!("Set `", stringify!($field), "`.")]
            pub fn $field(mut self, value: $ty) -> Self {
                self.$field = value;
                self
            }
        )+
    };
}
pub(crate) use setters;

/// A built-in identifier that holds exactly the fields of its parameter builder, from one
/// list of fields: the `Copy` identifier, its builder (public fields, defaults, a setter per
/// field, `check()`: the given checks on `p`, then the identifier), `From<Identifier>` for
/// the builder, and serde through the builder (a read identifier is checked).
macro_rules! identifier_params {
    (
        $(#[$meta:meta])*
        pub struct $model:ident;
        $(#[$pmeta:meta])*
        pub struct $params:ident {
            $($(#[$fmeta:meta])* $field:ident: $ty:ty = $default:expr,)+
        }
        check |$p:ident| $check:block
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $model {
            $($field: $ty,)+
        }

        $(#[$pmeta])*
        #[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
        #[serde(deny_unknown_fields, default)]
        pub struct $params {
            $($(#[$fmeta])* pub $field: $ty,)+
        }

        impl Default for $params {
            fn default() -> Self {
                $params {
                    $($field: $default,)+
                }
            }
        }

        impl $params {
            $crate::declare::setters!($($field: $ty),+);
            /// Validate and build.
            pub fn check(self) -> Result<$model, $crate::IdError> {
                let $p = &self;
                $check
                Ok($model {
                    $($field: self.$field,)+
                })
            }
        }

        impl From<$model> for $params {
            fn from(m: $model) -> Self {
                $params {
                    $($field: m.$field,)+
                }
            }
        }

        impl serde::Serialize for $model {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                serde::Serialize::serialize(&$params::from(*self), s)
            }
        }

        impl<'de> serde::Deserialize<'de> for $model {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let p = <$params as serde::Deserialize>::deserialize(d)?;
                p.check().map_err(<D::Error as serde::de::Error>::custom)
            }
        }
    };
}
pub(crate) use identifier_params;

/// `identify` and `identify_predict_many` of an identifier whose fit comes out of the method
/// `$fit_bare` without its diagnostics (in the `impl` block of
/// [`linear_identifier!`](crate::linear_identifier)): `identify` adds them from a prediction,
/// `identify_predict_many` from the prediction's identification window
/// ([`predict_many_from_bare`](crate::predict_many_from_bare)).
/// With `many |this, batch| { .. }`, that block is `identify_predict_many`.
macro_rules! identify_from_bare {
    ($fit_bare:ident) => {
        $crate::declare::identify_from_bare!(
            $fit_bare,
            many | this,
            batch | { $crate::predict_many_from_bare(batch, |u, y| this.$fit_bare(u, y)) }
        );
    };
    ($fit_bare:ident, many |$this:ident, $batch:ident| $many:block) => {
        fn identify(&self, u: &[f64], y: &[f64]) -> Result<$crate::LinearFit, $crate::IdError> {
            let mut fit = self.$fit_bare(u, y)?;
            fit.refresh_info(u, y)?;
            Ok(fit)
        }
        fn identify_predict_many(
            &self,
            $batch: $crate::Batch<'_>,
        ) -> Vec<Result<$crate::Identified, $crate::IdError>> {
            let $this = self;
            $many
        }
    };
}
pub(crate) use identify_from_bare;
