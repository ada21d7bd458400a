//! He et al. (2007): static friction band `fs` and kinetic friction `fd`.

use crate::{Constraint, Equivalent, FastPaths, InitialState, Runs, StictionError, ValveState};

crate::stiction_model! {
    /// He et al. (2007): the valve slips when the accumulated force `u_r + Δu` exceeds `fs`, and
    /// then lags OP by `fd`.
    ///
    /// | name | default | meaning | valid range |
    /// |------|---------|---------|-------------|
    /// | `fs` | 0 | static friction band | `0 <= fs <= span(OP)` |
    /// | `fd` | 0 | kinetic friction | `0 <= fd <= fs` |
    ///
    /// Equivalent Kano parameters (paper eq. 1): `S = fs + fd`, `J = fs - fd`. The two models agree
    /// at reversals and differ in slow unidirectional motion (specification §2.4).
    ///
    /// Initial state: the residual force is `u_r0 = d0 * fd` (the valve last moved in direction
    /// `d0`), and `MV(0) = OP(0) - u_r0` unless a position is given. The `stuck` flag and
    /// `stuck_at` of [`InitialState`] do not apply to this model.
    pub struct He("he") {
        /// Static friction band.
        fs: "fs", "static friction band (= (S+J)/2)", span 1.0;
        /// Kinetic friction.
        fd: "fd", "kinetic friction (= (S-J)/2)", span 0.5;
    }
    params HeParams;
    description "He et al. (2007): static friction fs and kinetic friction fd; S = fs+fd, J = fs-fd";
    constraints [Constraint::AtMost { param: "fd", bound: "fs" }];
    state start_state;
    impl {
        fn equivalent(&self) -> Equivalent {
            Equivalent {
                s: self.fs + self.fd,
                j: self.fs - self.fd,
            }
        }
        fn fast_paths(&self) -> Option<&dyn FastPaths> {
            Some(self)
        }
    }
}

impl He {
    /// He's model with the parameters equivalent to Kano's (S, J): `fs = (S+J)/2`, `fd = (S-J)/2`.
    pub fn from_sj(s: f64, j: f64) -> Result<He, StictionError> {
        crate::Kano::params().s(s).j(j).check()?;
        He::params().fs((s + j) / 2.0).fd((s - j) / 2.0).check()
    }
    fn start_state(&self, op0: f64, init: &InitialState) -> Result<HeState, StictionError> {
        init.validate_at(op0)?;
        let u_r = init.direction.sign() * self.fd;
        Ok(HeState {
            fs: self.fs,
            fd: self.fd,
            u_r,
            u_prev: op0,
            mv_prev: init.position.unwrap_or(op0 - u_r),
            stuck: true,
        })
    }
}

impl He {
    /// [`crate::kano::lockstep`] of four starts with the four states in the lanes of
    /// `[f64; 4]` arrays: each lane performs [`HeState::advance`]'s operations (both branches
    /// computed, one selected, which changes no value), so the same MV bit for bit, while the
    /// four dependent chains advance together instead of one after another (test
    /// `four_lanes_equal_lockstep`). After the merge, run 0 alone, as in `lockstep`.
    fn four_in_lanes(
        &self,
        op: &[f64],
        starts: &[InitialState; 4],
        out: &mut [Vec<f64>],
    ) -> Result<usize, StictionError> {
        crate::check_finite(op)?;
        let n = op.len();
        for o in out.iter_mut().take(4) {
            o.resize(n, 0.0);
        }
        let Some(&op0) = op.first() else {
            return Ok(0);
        };
        let mut states = [HeState::default(); 4];
        for (st, init) in states.iter_mut().zip(starts) {
            *st = self.start_state(op0, init)?;
        }
        for (o, st) in out.iter_mut().zip(&states) {
            o[0] = st.mv_prev;
        }
        let all_same = |s: &[HeState; 4]| s[1..].iter().all(|b| s[0].same(b));
        let (fs, fd) = (self.fs, self.fd);
        let mut u_r = states.map(|s| s.u_r);
        let mut mv_prev = states.map(|s| s.mv_prev);
        let mut u_prev = op0;
        let mut k = 1;
        let mut merge = if all_same(&states) { 1 } else { n };
        while k < n && merge == n {
            let u = op[k];
            let mut mv = [0.0; 4];
            for l in 0..4 {
                let cum = u_r[l] + (u - u_prev);
                let sign = if cum > 0.0 { 1.0 } else { -1.0 };
                let slip = cum.abs() > fs;
                u_r[l] = if slip { sign * fd } else { cum };
                mv[l] = if slip { u - sign * fd } else { mv_prev[l] };
            }
            mv_prev = mv;
            u_prev = u;
            for (o, &m) in out.iter_mut().zip(&mv) {
                o[k] = m;
            }
            k += 1;
            if (1..4).all(|l| u_r[l] == u_r[0] && mv_prev[l] == mv_prev[0]) {
                merge = k;
            }
        }
        let mut st = HeState {
            u_r: u_r[0],
            u_prev,
            mv_prev: mv_prev[0],
            ..states[0]
        };
        for (m, &u) in out[0][k..].iter_mut().zip(&op[k..]) {
            *m = st.advance(u);
        }
        Ok(merge)
    }
}

/// Simulation state of He's model.
#[derive(Debug, Clone, Copy, Default)]
struct HeState {
    fs: f64,
    fd: f64,
    u_r: f64,
    u_prev: f64,
    mv_prev: f64,
    stuck: bool,
}

impl HeState {
    #[inline(always)]
    fn advance(&mut self, u: f64) -> f64 {
        let cum = self.u_r + (u - self.u_prev);
        let mv = if cum.abs() > self.fs {
            let sign = if cum > 0.0 { 1.0 } else { -1.0 };
            self.u_r = sign * self.fd;
            self.stuck = false;
            u - sign * self.fd
        } else {
            self.u_r = cum;
            self.stuck = true;
            self.mv_prev
        };
        self.u_prev = u;
        self.mv_prev = mv;
        mv
    }
}

impl HeState {
    /// Same future for any input (what [`crate::kano::lockstep`] merges on).
    fn same(&self, other: &HeState) -> bool {
        self.u_r == other.u_r && self.u_prev == other.u_prev && self.mv_prev == other.mv_prev
    }
}

crate::kano::advancing_state!(HeState);

impl FastPaths for He {
    /// Four starts (In.2/In.3) run side by side, one per SIMD lane (`He::four_in_lanes`);
    /// other counts by `kano::lockstep`. The same MV and merge sample either way.
    fn simulate_starts(&self, runs: &mut Runs<'_>) -> Result<usize, StictionError> {
        let four = <&[InitialState; 4]>::try_from(runs.starts);
        if let (Ok(four), true) = (four, runs.out.len() >= 4) {
            return self.four_in_lanes(runs.op, four, runs.out);
        }
        crate::kano::lockstep(
            runs,
            |op0, s| self.start_state(op0, s),
            HeState::advance,
            HeState::same,
        )
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::Direction;

    /// The four lanes against the generic lockstep, bit for bit: random-walk OP, several
    /// frictions, the In.2/In.3 starts and starts with given positions.
    #[test]
    fn four_lanes_equal_lockstep() {
        let mut state = 11u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let given = |direction, stuck, position| InitialState {
            direction,
            stuck,
            stuck_at: None,
            position: Some(position),
        };
        for (s, j) in [(0.5, 0.0), (3.0, 1.0), (9.0, 3.0), (2.0, 2.0)] {
            let he = He::from_sj(s, j).unwrap();
            for len in [0, 1, 2, 50, 700] {
                let mut level = 50.0;
                let op: Vec<f64> = (0..len)
                    .map(|_| {
                        level += 2.0 * next();
                        level
                    })
                    .collect();
                let mixed = [
                    given(Direction::Up, true, 48.0),
                    given(Direction::Down, false, 51.0),
                    given(Direction::Up, false, 50.0),
                    given(Direction::Down, true, 49.5),
                ];
                for starts in [InitialState::four_variants(), mixed] {
                    let mut lanes = vec![Vec::new(); 4];
                    let mut generic = vec![Vec::new(); 4];
                    let m1 = he.four_in_lanes(&op, &starts, &mut lanes).unwrap();
                    let mut runs = Runs {
                        op: &op,
                        starts: &starts,
                        out: &mut generic,
                    };
                    let m2 = crate::kano::lockstep(
                        &mut runs,
                        |op0, s| he.start_state(op0, s),
                        HeState::advance,
                        HeState::same,
                    )
                    .unwrap();
                    assert_eq!(m1, m2, "merge, S {s} J {j} len {len}");
                    for (a, b) in lanes.iter().zip(&generic) {
                        let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                        assert_eq!(bits(&a[..m1]), bits(&b[..m1]), "S {s} J {j} len {len}");
                    }
                    assert_eq!(lanes[0], generic[0]);
                }
            }
        }
    }
}
