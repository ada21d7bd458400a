//! Kano's two-parameter stiction model (S, J) and the shared Kano-type core that the
//! asymmetric variant reuses.

use crate::{
    Constraint, Direction, Equivalent, FastPaths, InitialState, Runs, StictionError, ValveState,
};

crate::stiction_model! {
    /// Kano et al. (2004): deadband plus stickband `S` and slip jump `J`, in OP units.
    ///
    /// | name | default | meaning | valid range |
    /// |------|---------|---------|-------------|
    /// | `S`  | 0 | deadband + stickband: OP excursion needed to reverse a stopped valve | `0 <= S <= span(OP)` |
    /// | `J`  | 0 | slip jump; also the OP excursion that restarts a stopped valve in the same direction | `0 <= J <= S` |
    ///
    /// The update rule is the one of the algorithm specification (§1.3): a moving valve lags OP by
    /// `d (S - J)/2`; it stops when OP reverses or stays flat, and restarts when OP has moved
    /// strictly more than `S` (reversal) or `J` (same direction) from where it stopped.
    pub struct Kano("kano") {
        /// Deadband plus stickband.
        s: "S", "deadband + stickband (OP excursion to reverse a stopped valve)", span 1.0;
        /// Slip jump.
        j: "J", "slip jump (also the OP excursion to restart in the same direction)", span 1.0;
    }
    params KanoParams;
    description "Kano et al. (2004): deadband+stickband S and slip jump J; the paper's default";
    constraints [Constraint::AtMost { param: "J", bound: "S" }];
    state start_state;
    impl {
        fn equivalent(&self) -> Equivalent {
            Equivalent {
                s: self.s,
                j: self.j,
            }
        }
        fn fast_paths(&self) -> Option<&dyn FastPaths> {
            Some(self)
        }
    }
}

/// The start state and the [`FastPaths`] of a model whose valve is the [`KanoCore`] of its
/// method `core()`.
macro_rules! kano_type_paths {
    ($model:ident) => {
        impl $model {
            fn start_state(
                &self,
                op0: f64,
                init: &InitialState,
            ) -> Result<$crate::kano::KanoState, StictionError> {
                self.core().start(op0, init)
            }
        }

        impl FastPaths for $model {
            fn simulate_starts(&self, runs: &mut $crate::Runs<'_>) -> Result<usize, StictionError> {
                self.core().simulate_starts(runs)
            }
            fn event_rule(&self) -> Option<crate::EventRule> {
                Some(self.core().into())
            }
        }
    };
}
pub(crate) use kano_type_paths;

kano_type_paths!(Kano);

impl Kano {
    /// The model of an `(S, J)` already checked against Kano's bounds (by a model that holds
    /// Kano's valve).
    pub(crate) fn from_checked(s: f64, j: f64) -> Kano {
        Kano { s, j }
    }
    pub(crate) fn core(&self) -> KanoCore {
        KanoCore::symmetric(self.s, self.j)
    }
}

/// The Kano-type update rule with per-direction thresholds.
///
/// The symmetric model has `rev_from_up = rev_from_dn = S`, `j_up = j_dn = J` and
/// `offset = (S - J)/2`; the asymmetric one has `offset = D/2`, `rev_from_up = D + J_dn`
/// (reversing into a downward motion), `rev_from_dn = D + J_up`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct KanoCore {
    /// Lag of a moving valve behind OP (`MV = u - d * offset`).
    pub offset: f64,
    /// OP excursion needed to reverse when the last motion was upward (`d = +1`).
    pub rev_from_up: f64,
    /// OP excursion needed to reverse when the last motion was downward (`d = -1`).
    pub rev_from_dn: f64,
    /// OP excursion needed to restart upward after stopping while moving up.
    pub j_up: f64,
    /// OP excursion needed to restart downward after stopping while moving down.
    pub j_dn: f64,
}

impl From<KanoCore> for crate::EventRule {
    fn from(c: KanoCore) -> Self {
        crate::EventRule {
            offset: c.offset,
            rev_from_up: c.rev_from_up,
            rev_from_dn: c.rev_from_dn,
            j_up: c.j_up,
            j_dn: c.j_dn,
        }
    }
}

impl KanoCore {
    pub(crate) fn symmetric(s: f64, j: f64) -> Self {
        KanoCore {
            offset: (s - j) / 2.0,
            rev_from_up: s,
            rev_from_dn: s,
            j_up: j,
            j_dn: j,
        }
    }

    pub(crate) fn start(&self, op0: f64, init: &InitialState) -> Result<KanoState, StictionError> {
        init.validate_at(op0)?;
        let (d, u_s, mv0) = init.kano_start(op0, self.offset);
        Ok(KanoState {
            core: *self,
            u_prev: op0,
            // A moving valve was following an OP moving in its direction; a stuck one has no
            // previous increment (the specification's KANO_INIT sets it to 0).
            du_prev: if init.stuck { 0.0 } else { d },
            u_s,
            stuck: init.stuck,
            d,
            mv_prev: mv0,
        })
    }
}

impl KanoCore {
    /// Lockstep simulation from several starts (see [`FastPaths::simulate_starts`]).
    pub(crate) fn simulate_starts(&self, runs: &mut Runs<'_>) -> Result<usize, StictionError> {
        lockstep(
            runs,
            |op0, s| self.start(op0, s),
            KanoState::advance,
            KanoState::same,
        )
    }
}

/// Step several valve states in lockstep until they all equal the first, then only the first
/// (see [`FastPaths::simulate_starts`]). `same` must be true only for states that produce
/// identical futures for any input.
pub(crate) fn lockstep<S: ValveState>(
    runs: &mut Runs<'_>,
    start: impl Fn(f64, &InitialState) -> Result<S, StictionError>,
    advance: impl Fn(&mut S, f64) -> f64,
    same: impl Fn(&S, &S) -> bool,
) -> Result<usize, StictionError> {
    let (op, starts, out) = (runs.op, runs.starts, &mut *runs.out);
    crate::check_finite(op)?;
    let n = op.len();
    if out.len() < starts.len() || starts.is_empty() {
        return Err(StictionError::InvalidInit(format!(
            "{} starts need as many output buffers (got {})",
            starts.len(),
            out.len()
        )));
    }
    for o in out.iter_mut().take(starts.len()) {
        o.resize(n, 0.0);
    }
    let Some(&op0) = op.first() else {
        return Ok(0);
    };
    let mut states = starts
        .iter()
        .map(|s| start(op0, s))
        .collect::<Result<Vec<S>, _>>()?;
    for (o, st) in out.iter_mut().zip(&states) {
        o[0] = st.position();
    }
    let all_same = |states: &[S]| states[1..].iter().all(|s| same(&states[0], s));
    let mut k = 1;
    let mut merge = if all_same(&states) { 1 } else { n };
    while k < n && merge == n {
        let u = op[k];
        for (o, st) in out.iter_mut().zip(states.iter_mut()) {
            o[k] = advance(st, u);
        }
        k += 1;
        if all_same(&states) {
            merge = k;
        }
    }
    let st = &mut states[0];
    for (m, &u) in out[0][k..].iter_mut().zip(&op[k..]) {
        *m = advance(st, u);
    }
    Ok(merge)
}

/// Simulation state of a Kano-type valve: `u_prev`, `du_prev`, `u_s`, `stp`, `d`, `mv_prev`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct KanoState {
    core: KanoCore,
    u_prev: f64,
    du_prev: f64,
    u_s: f64,
    stuck: bool,
    d: f64,
    mv_prev: f64,
}

impl KanoState {
    /// Same future for any input: equal in every variable that the update reads (`u_s` only
    /// matters while stuck; it is reset at the next stop).
    fn same(a: &KanoState, b: &KanoState) -> bool {
        a.u_prev == b.u_prev
            && a.du_prev == b.du_prev
            && a.stuck == b.stuck
            && a.d == b.d
            && a.mv_prev == b.mv_prev
            && (!a.stuck || a.u_s == b.u_s)
    }

    #[inline(always)]
    fn advance(&mut self, u: f64) -> f64 {
        let c = &self.core;
        let du = u - self.u_prev;
        // (a) the valve stops when the input reverses or stays flat.
        if !self.stuck && du * self.du_prev <= 0.0 {
            self.u_s = self.u_prev;
            self.stuck = true;
        }
        // (b) output.
        let mv = if !self.stuck {
            u - self.d * c.offset
        } else {
            let (rev, same) = if self.d > 0.0 {
                (c.rev_from_up, c.j_up)
            } else {
                (c.rev_from_dn, c.j_dn)
            };
            let excursion = self.d * (u - self.u_s);
            if -excursion > rev {
                self.d = -self.d;
                self.stuck = false;
                u - self.d * c.offset
            } else if excursion > same {
                self.stuck = false;
                u - self.d * c.offset
            } else {
                self.mv_prev
            }
        };
        self.du_prev = du;
        self.u_prev = u;
        self.mv_prev = mv;
        mv
    }
}

/// The [`ValveState`] of a state with the method `advance(&mut self, op) -> MV` and the fields
/// `mv_prev` (the position) and `stuck`.
macro_rules! advancing_state {
    ($state:ident) => {
        impl ValveState for $state {
            fn step(&mut self, op: f64) -> f64 {
                self.advance(op)
            }
            fn position(&self) -> f64 {
                self.mv_prev
            }
            fn is_stuck(&self) -> bool {
                self.stuck
            }
        }
    };
}
pub(crate) use advancing_state;

advancing_state!(KanoState);

impl Direction {
    /// `+1.0` for up, `-1.0` for down.
    pub fn sign(self) -> f64 {
        match self {
            Direction::Up => 1.0,
            Direction::Down => -1.0,
        }
    }
}
