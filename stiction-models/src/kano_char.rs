//! Kano's valve followed by an installed flow characteristic (a Hammerstein chain: stiction,
//! characteristic, then the linear model).

use crate::kano::{KanoCore, KanoState};
use crate::{
    Bound, Constraint, Equivalent, FastPaths, InitialState, Kano, Runs, StictionError, ValveState,
};

/// Largest |a| accepted: `e^20` is a gain ratio of 5·10⁸ over the span, far beyond any valve.
pub const MAX_SHAPE: f64 = 20.0;

/// The installed characteristic of shape `a`, in % of span: `f(x) = 100 (e^(a x/100) − 1) /
/// (e^a − 1)`, exactly `x` for `a = 0`.
///
/// `a > 0` is equal-percentage-like (the local gain grows with the opening: an
/// equal-percentage valve of rangeability `R` is `a = ln R` up to an offset and a scale, which
/// a linear model with an intercept absorbs), `a < 0` quick-opening-like (its mirror image,
/// `f_{−a}(x) = 100 − f_a(100 − x)`). The local gain changes by the factor `e^(a Δ/100)` over
/// an opening range of `Δ` % of span. Only `a` matters to a Hammerstein model with a linear
/// part and an intercept: the family is closed under shifts of `x` up to gain and offset.
pub fn characteristic(a: f64, x: f64) -> f64 {
    if a == 0.0 {
        x
    } else {
        100.0 * (a * x / 100.0).exp_m1() / a.exp_m1()
    }
}

crate::stiction_model! {
    /// A Kano valve (S, J) seen through the installed characteristic of shape `a`
    /// ([`characteristic`]): MV is `f_a` of Kano's valve position, so the linear model after it
    /// sees the flow, not the stem position. All three in OP units (% of span) except `a`,
    /// which is dimensionless.
    ///
    /// | name | default | meaning | valid range |
    /// |------|---------|---------|-------------|
    /// | `S`  | 0 | Kano's deadband + stickband | `0 <= S <= span(OP)` |
    /// | `J`  | 0 | Kano's slip jump | `0 <= J <= S` |
    /// | `a`  | 0 | shape: > 0 equal-percentage-like, < 0 quick-opening-like, 0 linear (then exactly [`crate::Kano`]) | `|a| <= 20` |
    ///
    /// OP must be the absolute opening in % of span for `a` to mean what it says (the readers
    /// rescale OP to % of its span). The registry's grid does not search `a` (its
    /// `max_span_fraction` is 0, so a grid fixes `a = 0`); `stiction diagnose` fits it by a local
    /// search (cause `valve-characteristic`). The equivalent (S, J) are Kano's.
    pub struct KanoChar("kano-char") {
        /// Deadband plus stickband.
        s: "S", "Kano's deadband + stickband", span 1.0;
        /// Slip jump.
        j: "J", "Kano's slip jump", span 1.0;
        /// Shape of the characteristic.
        #[serde(default)]
        a: "a",
            "shape of the installed characteristic f(x) = 100 (e^(a x/100) - 1)/(e^a - 1): > 0 equal-percentage, < 0 quick-opening, 0 linear (not gridded: a grid fixes a = 0)",
            span 0.0, Bound::AbsAtMost(MAX_SHAPE);
    }
    params KanoCharParams;
    description "Kano (S, J) then an installed flow characteristic of shape a (equal-percentage a > 0, quick-opening a < 0)";
    constraints [Constraint::AtMost { param: "J", bound: "S" }];
    state start_state;
    impl {
        fn equivalent(&self) -> Equivalent {
            self.kano().equivalent()
        }
        fn fast_paths(&self) -> Option<&dyn FastPaths> {
            Some(self)
        }
    }
}

impl KanoChar {
    /// The shape `a`.
    pub fn shape(&self) -> f64 {
        self.a
    }
    /// Kano's valve of the same (S, J), before the characteristic.
    fn kano(&self) -> Kano {
        Kano::from_checked(self.s, self.j)
    }
    fn core(&self) -> KanoCore {
        self.kano().core()
    }
    fn start_state(&self, op0: f64, init: &InitialState) -> Result<CharState, StictionError> {
        Ok(CharState {
            inner: self.core().start(op0, init)?,
            flow: Flow {
                a: self.a,
                last: None,
            },
        })
    }
    fn map(&self, mv: &mut [f64]) {
        if self.a != 0.0 {
            let mut flow = Flow {
                a: self.a,
                last: None,
            };
            for m in mv {
                *m = flow.of(*m);
            }
        }
    }
}

/// The characteristic of shape `a`, remembering the last position: a sticky valve holds its
/// position for many samples, and the characteristic of a repeated position is the previous
/// sample's (the same bits).
struct Flow {
    a: f64,
    /// The last position and its characteristic.
    last: Option<(f64, f64)>,
}

impl Flow {
    fn of(&mut self, x: f64) -> f64 {
        match self.last {
            Some((px, py)) if px.to_bits() == x.to_bits() => py,
            _ => {
                let y = characteristic(self.a, x);
                self.last = Some((x, y));
                y
            }
        }
    }
}

/// Kano's state with the characteristic applied to its position.
struct CharState {
    inner: KanoState,
    flow: Flow,
}

impl ValveState for CharState {
    fn step(&mut self, op: f64) -> f64 {
        let x = self.inner.step(op);
        self.flow.of(x)
    }
    fn position(&self) -> f64 {
        characteristic(self.flow.a, self.inner.position())
    }
    fn is_stuck(&self) -> bool {
        self.inner.is_stuck()
    }
}

impl FastPaths for KanoChar {
    fn simulate_starts(&self, runs: &mut Runs<'_>) -> Result<usize, StictionError> {
        let merge = self.core().simulate_starts(runs)?;
        // Run 0 is complete; the others up to the merge (equal states map to equal outputs).
        for (i, o) in runs.out.iter_mut().enumerate().take(runs.starts.len()) {
            let end = if i == 0 { o.len() } else { merge.min(o.len()) };
            self.map(&mut o[..end]);
        }
        Ok(merge)
    }
    /// Kano's rule when `a = 0` (then MV is Kano's bit for bit); otherwise none (MV is not
    /// `OP - d offset` while moving), so the sample path is used.
    fn event_rule(&self) -> Option<crate::EventRule> {
        (self.a == 0.0).then(|| self.core().into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::StictionModel;

    #[test]
    fn a_zero_is_kano_bit_for_bit() {
        let op: Vec<f64> = (0..200)
            .map(|k| 50.0 + 8.0 * (k as f64 * 0.1).sin())
            .collect();
        let init = InitialState::default();
        let k = Kano::params().s(4.0).j(1.0).check().unwrap();
        let c = KanoChar::params().s(4.0).j(1.0).check().unwrap();
        assert_eq!(
            k.simulate(&op, &init).unwrap(),
            c.simulate(&op, &init).unwrap()
        );
    }

    #[test]
    fn characteristic_is_monotone_fixes_the_ends_and_mirrors() {
        for a in [-4.0, -1.0, 0.5, 3.9] {
            assert!((characteristic(a, 0.0)).abs() < 1e-12);
            assert!((characteristic(a, 100.0) - 100.0).abs() < 1e-9);
            let mut prev = f64::NEG_INFINITY;
            for i in 0..=100 {
                let y = characteristic(a, i as f64);
                assert!(y > prev);
                prev = y;
                let mirror = 100.0 - characteristic(-a, 100.0 - i as f64);
                assert!((y - mirror).abs() < 1e-9, "a {a} x {i}");
            }
        }
    }

    #[test]
    fn stepped_equals_simulated_and_a_is_checked() {
        let op: Vec<f64> = (0..300)
            .map(|k| 50.0 + 8.0 * (k as f64 * 0.07).sin())
            .collect();
        let init = InitialState::default();
        let c = KanoChar::params().s(3.0).j(1.0).a(3.0).check().unwrap();
        let sim = c.simulate(&op, &init).unwrap();
        let mut st = c.start(op[0], &init).unwrap();
        let mut stepped = vec![st.position()];
        stepped.extend(op[1..].iter().map(|&u| st.step(u)));
        assert_eq!(sim, stepped);
        assert!(KanoChar::params().a(25.0).check().is_err());
        assert!(KanoChar::params().s(1.0).j(2.0).check().is_err());
    }
}
