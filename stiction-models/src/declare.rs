//! One declaration per stiction model: [`stiction_model!`](crate::stiction_model).
//!
//! The macro takes the model's name, its parameters (names, meanings, bounds, span
//! fractions), its constraints and the body of its [`StictionModel`](crate::StictionModel)
//! implementation, and writes the rest: the checked model struct, its unchecked parameter
//! builder, serde through the builder (so a config is checked when it is read), the typetag
//! registration and the [`ModelEntry`](crate::ModelEntry) in the registry. The name is
//! written once.

use crate::{Constraint, ParamSpec, StictionError};

/// The valid values of one parameter, checked by the generated `check()`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    /// Finite and `>= 0` (a width or a jump in OP units).
    NonNegative,
    /// Finite with `|value| <= limit` (a dimensionless shape).
    AbsAtMost(f64),
}

impl Bound {
    fn holds(self, value: f64) -> bool {
        match self {
            Bound::NonNegative => value.is_finite() && value >= 0.0,
            Bound::AbsAtMost(limit) => value.is_finite() && value.abs() <= limit,
        }
    }

    fn expected(self) -> String {
        match self {
            Bound::NonNegative => "a finite number >= 0 (OP units)".to_string(),
            Bound::AbsAtMost(limit) => format!("a finite number with |a| <= {limit}"),
        }
    }
}

/// Check a parameter vector (in the order of `params`): the non-negative parameters first,
/// then every `AtMost` constraint (`J <= S`), then the other bounds. The first violation is
/// the error. `SumAtMostSpan` constraints need the OP span and are left to the grid
/// ([`crate::ModelEntry::admissible`]).
pub fn check_params(
    model: &'static str,
    params: &[ParamSpec],
    constraints: &[Constraint],
    values: &[f64],
) -> Result<(), StictionError> {
    let invalid = |name: &str, value: f64, expected: String| StictionError::InvalidParameter {
        model,
        name: name.to_string(),
        value,
        expected,
    };
    let bound_first = |first: bool| {
        params
            .iter()
            .zip(values)
            .filter(move |(p, _)| (p.bound == Bound::NonNegative) == first)
            .find(|(p, &v)| !p.bound.holds(v))
            .map(|(p, &v)| invalid(p.name, v, p.bound.expected()))
    };
    if let Some(e) = bound_first(true) {
        return Err(e);
    }
    let value_of = |name: &str| {
        params
            .iter()
            .position(|p| p.name == name)
            .and_then(|i| values.get(i).copied())
    };
    for c in constraints {
        if let Constraint::AtMost { param, bound } = c {
            if let (Some(v), Some(b)) = (value_of(param), value_of(bound)) {
                if v > b {
                    return Err(invalid(
                        param,
                        v,
                        format!("0 <= {param} <= {bound} (= {b})"),
                    ));
                }
            }
        }
    }
    bound_first(false).map_or(Ok(()), Err)
}

/// Declares a stiction model once: its struct, parameter builder, checks, serde, typetag
/// name and registry entry.
///
/// ```
/// use stiction_models::{stiction_model, Equivalent, InitialState, StictionError, ValveState};
///
/// stiction_model! {
///     /// A valve that follows OP exactly, offset by `c`.
///     pub struct Offset("offset") {
///         /// Offset.
///         c: "c", "constant offset of MV below OP", span 0.5;
///     }
///     params OffsetParams;
///     description "example: MV = OP - c";
///     constraints [];
///     impl {
///         fn equivalent(&self) -> Equivalent {
///             Equivalent { s: 0.0, j: 0.0 }
///         }
///         fn start(&self, op0: f64, init: &InitialState)
///             -> Result<Box<dyn ValveState>, StictionError> {
///             init.validate()?;
///             Ok(Box::new(Follow { c: self.c, mv: op0 - self.c }))
///         }
///     }
/// }
///
/// struct Follow { c: f64, mv: f64 }
/// impl ValveState for Follow {
///     fn step(&mut self, op: f64) -> f64 { self.mv = op - self.c; self.mv }
///     fn position(&self) -> f64 { self.mv }
///     fn is_stuck(&self) -> bool { false }
/// }
///
/// let m = Offset::params().c(1.0).check()?;
/// assert_eq!(m.c(), 1.0);
/// assert!(Offset::params().c(-1.0).check().is_err());
/// let entry = stiction_models::find_model("offset")?;
/// assert_eq!(entry.param_names(), ["c"]);
/// # Ok::<(), StictionError>(())
/// ```
///
/// Each parameter line is `field: "NAME" [= default], "meaning", span FRACTION [, bound];`:
/// * `NAME` is the parameter's name in `--param NAME=V`, in JSON and in the registry;
/// * `default` (0 when left out) is its value when a `NAME=V` list does not give it;
/// * `span FRACTION` is the upper end of the range a grid search scans, as a fraction of the
///   OP span (`max_span_fraction`: 1 for a width that can reach the whole span, 0.5 for one
///   that cannot exceed half of it, 0 for a parameter the grid does not scan, which then
///   stays at its default);
/// * `bound` ([`Bound`], `NonNegative` when left out) is checked by the builder's `check()`,
///   and so whenever a model is built or read from JSON, with the `AtMost` constraints.
///
/// Attributes before a parameter (its doc, `#[serde(default)]`) go to the builder's field.
/// The `impl` block holds the [`StictionModel`](crate::StictionModel) methods other than
/// `name`, `param_values` and `box_clone`, which are generated. With `state start_state;`
/// (before `impl`) the model's method `start_state(&self, op0, &InitialState) ->
/// Result<S, StictionError>` of a concrete [`ValveState`](crate::ValveState) `S` gives
/// `start` (the state boxed) and `simulate_into` (the state stepped without a box,
/// [`simulate_states`](crate::simulate_states)), which the `impl` block then leaves out. The model struct is `Copy`
/// with one private `f64` field per parameter and a getter of the field's name; the builder
/// (`params` type) has public fields and setters, and `check()` builds the model.
#[macro_export]
macro_rules! stiction_model {
    (
        $(#[$meta:meta])*
        $vis:vis struct $model:ident($name:tt) {
            $(
                $(#[$fmeta:meta])*
                $field:ident : $pname:tt $(= $default:expr)?, $meaning:expr, span $frac:expr
                    $(, $bound:expr)?;
            )+
        }
        params $params:ident;
        description $description:expr;
        constraints [$($constraint:expr),* $(,)?];
        $(state $start:ident;)?
        impl { $($body:tt)* }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        $vis struct $model {
            $($field: f64,)+
        }

        #[doc = concat!("Unchecked parameters of [`", stringify!($model), "`]; [`",
            stringify!($params), "::check`] builds the model.")]
        #[derive(Debug, Clone, Copy, PartialEq, Default,
            $crate::serde::Serialize, $crate::serde::Deserialize)]
        #[serde(crate = "stiction_models::serde", deny_unknown_fields)]
        $vis struct $params {
            $(
                $(#[$fmeta])*
                #[serde(rename = $pname)]
                pub $field: f64,
            )+
        }

        impl $params {
            $(
                #[doc = concat!("Set `", $pname, "`.")]
                pub fn $field(mut self, value: f64) -> Self {
                    self.$field = value;
                    self
                }
            )+
            /// Check every parameter against its bound and the constraints, and build the model.
            pub fn check(self) -> Result<$model, $crate::StictionError> {
                $crate::declare::check_params(
                    $name,
                    $model::PARAMS,
                    $model::CONSTRAINTS,
                    &[$(self.$field),+],
                )?;
                Ok($model { $($field: self.$field),+ })
            }
        }

        impl $model {
            /// The parameters, in the order of the registry entry.
            pub const PARAMS: &'static [$crate::ParamSpec] = &[$(
                $crate::ParamSpec {
                    name: $pname,
                    meaning: $meaning,
                    default: $crate::__or!(0.0 $(, $default)?),
                    max_span_fraction: $frac,
                    bound: $crate::__or!($crate::Bound::NonNegative $(, $bound)?),
                },
            )+];
            /// The constraints between parameters.
            pub const CONSTRAINTS: &'static [$crate::Constraint] = &[$($constraint),*];
            /// Start a parameter builder, every parameter at 0.
            pub fn params() -> $params {
                $params::default()
            }
            $(
                #[doc = concat!("The parameter `", $pname, "`.")]
                pub fn $field(&self) -> f64 {
                    self.$field
                }
            )+
        }

        impl TryFrom<$params> for $model {
            type Error = $crate::StictionError;
            fn try_from(p: $params) -> Result<Self, Self::Error> {
                p.check()
            }
        }

        impl From<$model> for $params {
            fn from(m: $model) -> Self {
                $params { $($field: m.$field),+ }
            }
        }

        impl $crate::serde::Serialize for $model {
            fn serialize<S: $crate::serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                $crate::serde::Serialize::serialize(&$params::from(*self), s)
            }
        }

        impl<'de> $crate::serde::Deserialize<'de> for $model {
            fn deserialize<D: $crate::serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let p = <$params as $crate::serde::Deserialize>::deserialize(d)?;
                p.check().map_err(<D::Error as $crate::serde::de::Error>::custom)
            }
        }

        const _: () = {
            use $crate::typetag;

            #[typetag::serde(name = $name)]
            impl $crate::StictionModel for $model {
                fn name(&self) -> &'static str {
                    $name
                }
                fn param_values(&self) -> Vec<f64> {
                    vec![$(self.$field),+]
                }
                fn box_clone(&self) -> Box<dyn $crate::StictionModel> {
                    Box::new(*self)
                }
                $(
                    fn start(
                        &self,
                        op0: f64,
                        init: &$crate::InitialState,
                    ) -> Result<Box<dyn $crate::ValveState>, $crate::StictionError> {
                        Ok(Box::new(self.$start(op0, init)?))
                    }
                    fn simulate_into(
                        &self,
                        op: &[f64],
                        init: &$crate::InitialState,
                        mv: &mut [f64],
                    ) -> Result<(), $crate::StictionError> {
                        $crate::simulate_states(op, mv, |op0| self.$start(op0, init))
                    }
                )?
                $($body)*
            }

            fn build(
                values: &[f64],
            ) -> Result<Box<dyn $crate::StictionModel>, $crate::StictionError> {
                let &[$($field),+] = values else {
                    return Err($crate::StictionError::WrongParameterCount {
                        model: $name,
                        expected: $model::PARAMS.len(),
                        got: values.len(),
                    });
                };
                Ok(Box::new($params { $($field),+ }.check()?))
            }

            $crate::inventory::submit! {
                $crate::ModelEntry {
                    name: $name,
                    description: $description,
                    params: $model::PARAMS,
                    constraints: $model::CONSTRAINTS,
                    build,
                }
            }
        };
    };
}

/// The second expression when given, else the first (optional parts of
/// [`stiction_model!`](crate::stiction_model)).
#[doc(hidden)]
#[macro_export]
macro_rules! __or {
    ($fallback:expr) => {
        $fallback
    };
    ($fallback:expr, $given:expr) => {
        $given
    };
}
