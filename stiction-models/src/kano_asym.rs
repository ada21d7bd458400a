//! Kano's model with direction-dependent slip jump (specification §3.2).

use serde::{Deserialize, Serialize};

use crate::kano::KanoCore;
use crate::{
    non_negative, Constraint, Equivalent, InitialState, ModelEntry, ParamSpec, StictionError,
    StictionModel, ValveState,
};

/// A valve whose friction differs by direction: common deadband `D`, slip jumps `J_up`
/// (opening) and `J_dn` (closing).
///
/// | name | default | meaning | valid range |
/// |------|---------|---------|-------------|
/// | `D` | 0 | deadband common to both directions; a moving valve lags OP by `D/2` | `0 <= D <= span(OP)` |
/// | `J_up` | 0 | slip jump when the valve moves up (opening) | `0 <= J_up <= span - D` |
/// | `J_dn` | 0 | slip jump when the valve moves down (closing) | `0 <= J_dn <= span - D` |
///
/// Reversing into the upward direction needs an OP excursion `S_up = D + J_up`, into the
/// downward one `S_dn = D + J_dn`; a same-direction restart needs `J` of that direction. Only
/// `(D, J_up, J_dn)` are identifiable from OP/PV data (specification §3.2). With
/// `J_up = J_dn = J` the model equals [`crate::Kano`] with `S = D + J` (invariant A1).
///
/// Its equivalent symmetric parameters are the averages `S = D + (J_up + J_dn)/2` and
/// `J = (J_up + J_dn)/2`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "KanoAsymParams", into = "KanoAsymParams")]
pub struct KanoAsym {
    d: f64,
    j_up: f64,
    j_dn: f64,
}

/// Unchecked parameters of [`KanoAsym`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KanoAsymParams {
    /// Common deadband.
    #[serde(rename = "D")]
    pub d: f64,
    /// Slip jump opening.
    #[serde(rename = "J_up")]
    pub j_up: f64,
    /// Slip jump closing.
    #[serde(rename = "J_dn")]
    pub j_dn: f64,
}

impl KanoAsymParams {
    /// Set `D`.
    pub fn d(mut self, d: f64) -> Self {
        self.d = d;
        self
    }
    /// Set `J_up`.
    pub fn j_up(mut self, j: f64) -> Self {
        self.j_up = j;
        self
    }
    /// Set `J_dn`.
    pub fn j_dn(mut self, j: f64) -> Self {
        self.j_dn = j;
        self
    }
    /// Validate (finite, non-negative) and build the model.
    pub fn check(self) -> Result<KanoAsym, StictionError> {
        non_negative("kano-asym", "D", self.d)?;
        non_negative("kano-asym", "J_up", self.j_up)?;
        non_negative("kano-asym", "J_dn", self.j_dn)?;
        Ok(KanoAsym {
            d: self.d,
            j_up: self.j_up,
            j_dn: self.j_dn,
        })
    }
}

impl TryFrom<KanoAsymParams> for KanoAsym {
    type Error = StictionError;
    fn try_from(p: KanoAsymParams) -> Result<Self, Self::Error> {
        p.check()
    }
}

impl From<KanoAsym> for KanoAsymParams {
    fn from(k: KanoAsym) -> Self {
        KanoAsymParams {
            d: k.d,
            j_up: k.j_up,
            j_dn: k.j_dn,
        }
    }
}

impl KanoAsym {
    /// Start a parameter builder.
    pub fn params() -> KanoAsymParams {
        KanoAsymParams::default()
    }
    /// Reversal threshold into the upward direction, `D + J_up`.
    pub fn s_up(&self) -> f64 {
        self.d + self.j_up
    }
    /// Reversal threshold into the downward direction, `D + J_dn`.
    pub fn s_dn(&self) -> f64 {
        self.d + self.j_dn
    }
    fn core(&self) -> KanoCore {
        KanoCore {
            offset: self.d / 2.0,
            rev_from_up: self.s_dn(),
            rev_from_dn: self.s_up(),
            j_up: self.j_up,
            j_dn: self.j_dn,
        }
    }
}

#[typetag::serde(name = "kano-asym")]
impl StictionModel for KanoAsym {
    fn name(&self) -> &'static str {
        "kano-asym"
    }
    fn param_values(&self) -> Vec<f64> {
        vec![self.d, self.j_up, self.j_dn]
    }
    fn derived_values(&self) -> Vec<(&'static str, f64)> {
        vec![("S_up", self.s_up()), ("S_dn", self.s_dn())]
    }
    fn equivalent(&self) -> Equivalent {
        let j = (self.j_up + self.j_dn) / 2.0;
        Equivalent { s: self.d + j, j }
    }
    fn start(&self, op0: f64, init: &InitialState) -> Result<Box<dyn ValveState>, StictionError> {
        Ok(Box::new(self.core().start(op0, init)?))
    }
    fn simulate_into(
        &self,
        op: &[f64],
        init: &InitialState,
        mv: &mut [f64],
    ) -> Result<(), StictionError> {
        self.core().simulate_into(op, init, mv)
    }
    fn simulate_starts(
        &self,
        op: &[f64],
        starts: &[InitialState],
        out: &mut [Vec<f64>],
    ) -> Result<usize, StictionError> {
        self.core().simulate_starts(op, starts, out)
    }
    fn event_rule(&self) -> Option<crate::EventRule> {
        Some(self.core().into())
    }
    fn box_clone(&self) -> Box<dyn StictionModel> {
        Box::new(*self)
    }
}

const KANO_ASYM_PARAMS: [ParamSpec; 3] = [
    ParamSpec {
        name: "D",
        meaning: "deadband common to both directions",
        default: 0.0,
        max_span_fraction: 1.0,
    },
    ParamSpec {
        name: "J_up",
        meaning: "slip jump when opening (S_up = D + J_up)",
        default: 0.0,
        max_span_fraction: 1.0,
    },
    ParamSpec {
        name: "J_dn",
        meaning: "slip jump when closing (S_dn = D + J_dn)",
        default: 0.0,
        max_span_fraction: 1.0,
    },
];

fn build_kano_asym(values: &[f64]) -> Result<Box<dyn StictionModel>, StictionError> {
    match values {
        [d, ju, jd] => Ok(Box::new(
            KanoAsym::params().d(*d).j_up(*ju).j_dn(*jd).check()?,
        )),
        _ => Err(StictionError::WrongParameterCount {
            model: "kano-asym",
            expected: 3,
            got: values.len(),
        }),
    }
}

inventory::submit! {
    ModelEntry {
        name: "kano-asym",
        description: "Kano with direction-dependent slip: deadband D, jumps J_up (opening) and J_dn (closing)",
        params: &KANO_ASYM_PARAMS,
        constraints: &[
            Constraint::SumAtMostSpan { params: &["D", "J_up"] },
            Constraint::SumAtMostSpan { params: &["D", "J_dn"] },
        ],
        build: build_kano_asym,
    }
}
