//! Kano's model with direction-dependent slip jump (specification §3.2).

use crate::kano::KanoCore;
use crate::{Constraint, Equivalent, FastPaths, InitialState, StictionError};

crate::stiction_model! {
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
    pub struct KanoAsym("kano-asym") {
        /// Common deadband.
        d: "D", "deadband common to both directions", span 1.0;
        /// Slip jump opening.
        j_up: "J_up", "slip jump when opening (S_up = D + J_up)", span 1.0;
        /// Slip jump closing.
        j_dn: "J_dn", "slip jump when closing (S_dn = D + J_dn)", span 1.0;
    }
    params KanoAsymParams;
    description "Kano with direction-dependent slip: deadband D, jumps J_up (opening) and J_dn (closing)";
    constraints [
        Constraint::SumAtMostSpan { params: &["D", "J_up"] },
        Constraint::SumAtMostSpan { params: &["D", "J_dn"] },
    ];
    state start_state;
    impl {
        fn derived_values(&self) -> Vec<(&'static str, f64)> {
            vec![("S_up", self.s_up()), ("S_dn", self.s_dn())]
        }
        fn equivalent(&self) -> Equivalent {
            let j = (self.j_up + self.j_dn) / 2.0;
            Equivalent { s: self.d + j, j }
        }
        fn fast_paths(&self) -> Option<&dyn FastPaths> {
            Some(self)
        }
    }
}

impl KanoAsym {
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

crate::kano::kano_type_paths!(KanoAsym);
