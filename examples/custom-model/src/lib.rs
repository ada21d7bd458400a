//! Example of a third-party stiction model living in its own crate.
//!
//! `backlash` is a pure deadband (mechanical play) of width `B`: the valve follows OP with a
//! lag of `B/2` and does not move until OP has crossed the whole band after a reversal. It has
//! no slip jump. Three things make it a first-class model:
//! 1. implement [`StictionModel`] with `#[typetag::serde(name = "backlash")]`;
//! 2. submit a [`ModelEntry`] with the same name through `inventory`;
//! 3. reference this crate from the binary (`use custom_model as _;`) so the linker keeps it.
//!
//! `cargo run -p custom-model -- models` then lists it next to the built-ins, and every
//! command (`valve`, `simulate`, ...) accepts `--model backlash` / `--valve backlash`.

use serde::{Deserialize, Serialize};
use stiction_models::{
    inventory, typetag, Constraint, Equivalent, InitialState, ModelEntry, ParamSpec, StictionError,
    StictionModel, ValveState,
};

/// Pure backlash of width `B` (OP units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "BacklashParams", into = "BacklashParams")]
pub struct Backlash {
    b: f64,
}

/// Unchecked parameters of [`Backlash`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BacklashParams {
    /// Band width.
    #[serde(rename = "B")]
    pub b: f64,
}

impl TryFrom<BacklashParams> for Backlash {
    type Error = StictionError;
    fn try_from(p: BacklashParams) -> Result<Self, Self::Error> {
        if p.b.is_finite() && p.b >= 0.0 {
            Ok(Backlash { b: p.b })
        } else {
            Err(StictionError::InvalidParameter {
                model: "backlash",
                name: "B".into(),
                value: p.b,
                expected: "a finite number >= 0".into(),
            })
        }
    }
}

impl From<Backlash> for BacklashParams {
    fn from(m: Backlash) -> Self {
        BacklashParams { b: m.b }
    }
}

impl Backlash {
    /// A checked model of width `b`.
    pub fn new(b: f64) -> Result<Self, StictionError> {
        BacklashParams { b }.try_into()
    }
}

struct BacklashState {
    half: f64,
    mv: f64,
}

impl ValveState for BacklashState {
    fn step(&mut self, op: f64) -> f64 {
        if op - self.mv > self.half {
            self.mv = op - self.half;
        } else if self.mv - op > self.half {
            self.mv = op + self.half;
        }
        self.mv
    }
    fn position(&self) -> f64 {
        self.mv
    }
    fn is_stuck(&self) -> bool {
        false
    }
}

#[typetag::serde(name = "backlash")]
impl StictionModel for Backlash {
    fn name(&self) -> &'static str {
        "backlash"
    }
    fn param_values(&self) -> Vec<f64> {
        vec![self.b]
    }
    fn equivalent(&self) -> Equivalent {
        Equivalent { s: self.b, j: 0.0 }
    }
    fn start(&self, op0: f64, init: &InitialState) -> Result<Box<dyn ValveState>, StictionError> {
        init.validate()?;
        let half = self.b / 2.0;
        let mv = init.position.unwrap_or(op0 - init.direction.sign() * half);
        Ok(Box::new(BacklashState { half, mv }))
    }
    fn box_clone(&self) -> Box<dyn StictionModel> {
        Box::new(*self)
    }
}

fn build(values: &[f64]) -> Result<Box<dyn StictionModel>, StictionError> {
    match values {
        [b] => Ok(Box::new(Backlash::new(*b)?)),
        _ => Err(StictionError::WrongParameterCount {
            model: "backlash",
            expected: 1,
            got: values.len(),
        }),
    }
}

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "B",
    meaning: "backlash (deadband) width",
    default: 0.0,
    max_span_fraction: 1.0,
}];

inventory::submit! {
    ModelEntry {
        name: "backlash",
        description: "example plugin: pure backlash of width B (no slip jump)",
        params: &PARAMS,
        constraints: &[] as &[Constraint],
        build,
    }
}
