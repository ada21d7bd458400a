//! Kano's valve followed by an installed flow characteristic (a Hammerstein chain: stiction,
//! characteristic, then the linear model).

use serde::{Deserialize, Serialize};

use crate::kano::KanoCore;
use crate::{
    non_negative, Constraint, Equivalent, InitialState, ModelEntry, ParamSpec, StictionError,
    StictionModel, ValveState,
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
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "KanoCharParams", into = "KanoCharParams")]
pub struct KanoChar {
    s: f64,
    j: f64,
    a: f64,
}

/// Unchecked parameters of [`KanoChar`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KanoCharParams {
    /// Deadband plus stickband.
    #[serde(rename = "S")]
    pub s: f64,
    /// Slip jump.
    #[serde(rename = "J")]
    pub j: f64,
    /// Shape of the characteristic.
    #[serde(default)]
    pub a: f64,
}

impl KanoCharParams {
    /// Set `S`.
    pub fn s(mut self, s: f64) -> Self {
        self.s = s;
        self
    }
    /// Set `J`.
    pub fn j(mut self, j: f64) -> Self {
        self.j = j;
        self
    }
    /// Set `a`.
    pub fn a(mut self, a: f64) -> Self {
        self.a = a;
        self
    }
    /// Validate (S, J as [`crate::Kano`]; `|a| <= 20`) and build the model.
    pub fn check(self) -> Result<KanoChar, StictionError> {
        non_negative("kano-char", "S", self.s)?;
        non_negative("kano-char", "J", self.j)?;
        if self.j > self.s {
            return Err(StictionError::InvalidParameter {
                model: "kano-char",
                name: "J".into(),
                value: self.j,
                expected: format!("0 <= J <= S (= {})", self.s),
            });
        }
        if !(self.a.is_finite() && self.a.abs() <= MAX_SHAPE) {
            return Err(StictionError::InvalidParameter {
                model: "kano-char",
                name: "a".into(),
                value: self.a,
                expected: format!("a finite number with |a| <= {MAX_SHAPE}"),
            });
        }
        Ok(KanoChar {
            s: self.s,
            j: self.j,
            a: self.a,
        })
    }
}

impl TryFrom<KanoCharParams> for KanoChar {
    type Error = StictionError;
    fn try_from(p: KanoCharParams) -> Result<Self, Self::Error> {
        p.check()
    }
}

impl From<KanoChar> for KanoCharParams {
    fn from(k: KanoChar) -> Self {
        KanoCharParams {
            s: k.s,
            j: k.j,
            a: k.a,
        }
    }
}

impl KanoChar {
    /// Start a parameter builder.
    pub fn params() -> KanoCharParams {
        KanoCharParams::default()
    }
    /// The shape `a`.
    pub fn shape(&self) -> f64 {
        self.a
    }
    fn core(&self) -> KanoCore {
        KanoCore::symmetric(self.s, self.j)
    }
    fn map(&self, mv: &mut [f64]) {
        if self.a != 0.0 {
            // a sticky valve holds its position for many samples: the characteristic of a
            // repeated position is the previous sample's (the same bits)
            let mut last: Option<(f64, f64)> = None;
            for m in mv {
                let x = *m;
                let y = match last {
                    Some((px, py)) if px.to_bits() == x.to_bits() => py,
                    _ => characteristic(self.a, x),
                };
                last = Some((x, y));
                *m = y;
            }
        }
    }
}

/// Kano's state with the characteristic applied to its position.
struct CharState {
    inner: Box<dyn ValveState>,
    a: f64,
}

impl ValveState for CharState {
    fn step(&mut self, op: f64) -> f64 {
        characteristic(self.a, self.inner.step(op))
    }
    fn position(&self) -> f64 {
        characteristic(self.a, self.inner.position())
    }
    fn is_stuck(&self) -> bool {
        self.inner.is_stuck()
    }
}

#[typetag::serde(name = "kano-char")]
impl StictionModel for KanoChar {
    fn name(&self) -> &'static str {
        "kano-char"
    }
    fn param_values(&self) -> Vec<f64> {
        vec![self.s, self.j, self.a]
    }
    fn equivalent(&self) -> Equivalent {
        Equivalent {
            s: self.s,
            j: self.j,
        }
    }
    fn start(&self, op0: f64, init: &InitialState) -> Result<Box<dyn ValveState>, StictionError> {
        Ok(Box::new(CharState {
            inner: Box::new(self.core().start(op0, init)?),
            a: self.a,
        }))
    }
    fn simulate_into(
        &self,
        op: &[f64],
        init: &InitialState,
        mv: &mut [f64],
    ) -> Result<(), StictionError> {
        self.core().simulate_into(op, init, mv)?;
        self.map(mv);
        Ok(())
    }
    fn simulate_starts(
        &self,
        op: &[f64],
        starts: &[InitialState],
        out: &mut [Vec<f64>],
    ) -> Result<usize, StictionError> {
        let merge = self.core().simulate_starts(op, starts, out)?;
        // Run 0 is complete; the others up to the merge (equal states map to equal outputs).
        for (i, o) in out.iter_mut().enumerate().take(starts.len()) {
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
    fn box_clone(&self) -> Box<dyn StictionModel> {
        Box::new(*self)
    }
}

const KANO_CHAR_PARAMS: [ParamSpec; 3] = [
    ParamSpec {
        name: "S",
        meaning: "Kano's deadband + stickband",
        default: 0.0,
        max_span_fraction: 1.0,
    },
    ParamSpec {
        name: "J",
        meaning: "Kano's slip jump",
        default: 0.0,
        max_span_fraction: 1.0,
    },
    ParamSpec {
        name: "a",
        meaning: "shape of the installed characteristic f(x) = 100 (e^(a x/100) - 1)/(e^a - 1): > 0 equal-percentage, < 0 quick-opening, 0 linear (not gridded: a grid fixes a = 0)",
        default: 0.0,
        max_span_fraction: 0.0,
    },
];

fn build_kano_char(values: &[f64]) -> Result<Box<dyn StictionModel>, StictionError> {
    match values {
        [s, j, a] => Ok(Box::new(KanoChar::params().s(*s).j(*j).a(*a).check()?)),
        _ => Err(StictionError::WrongParameterCount {
            model: "kano-char",
            expected: 3,
            got: values.len(),
        }),
    }
}

inventory::submit! {
    ModelEntry {
        name: "kano-char",
        description: "Kano (S, J) then an installed flow characteristic of shape a (equal-percentage a > 0, quick-opening a < 0)",
        params: &KANO_CHAR_PARAMS,
        constraints: &[Constraint::AtMost { param: "J", bound: "S" }],
        build: build_kano_char,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Kano;

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
