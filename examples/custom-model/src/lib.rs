//! Example of a third-party stiction model living in its own crate.
//!
//! `backlash` is a pure deadband (mechanical play) of width `B`: the valve follows OP with a
//! lag of `B/2` and does not move until OP has crossed the whole band after a reversal. It has
//! no slip jump. Two things make it a first-class model:
//! 1. one [`stiction_model!`] declaration: the name, the parameters (name, meaning, span
//!    fraction, bound), the constraints and the simulation; the macro writes the parameter
//!    builder and its checks, serde, the typetag name and the registry entry;
//! 2. reference this crate from the binary (`use custom_model as _;`) so the linker keeps it.
//!
//! `cargo run -p custom-model -- models` then lists it next to the built-ins, and every
//! command (`valve`, `simulate`, ...) accepts `--model backlash` / `--valve backlash`.

use stiction_models::{stiction_model, Equivalent, InitialState, StictionError, ValveState};

stiction_model! {
    /// Pure backlash of width `B` (OP units).
    pub struct Backlash("backlash") {
        /// Band width.
        b: "B", "backlash (deadband) width", span 1.0;
    }
    params BacklashParams;
    description "example plugin: pure backlash of width B (no slip jump)";
    constraints [];
    impl {
        fn equivalent(&self) -> Equivalent {
            Equivalent { s: self.b, j: 0.0 }
        }
        fn start(
            &self,
            op0: f64,
            init: &InitialState,
        ) -> Result<Box<dyn ValveState>, StictionError> {
            init.validate()?;
            let half = self.b / 2.0;
            let mv = init.position.unwrap_or(op0 - init.direction.sign() * half);
            Ok(Box::new(BacklashState { half, mv }))
        }
    }
}

impl Backlash {
    /// A checked model of width `b`.
    pub fn new(b: f64) -> Result<Self, StictionError> {
        Backlash::params().b(b).check()
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
