//! Event-driven valve runs: the Kano-type rule evaluated interval by interval.
//!
//! A Kano-type valve (Kano, asymmetric Kano) alternates between two kinds of interval:
//!
//! * **stuck**: MV is constant (the value held when the valve stopped); the interval ends at the
//!   first sample whose OP leaves the band `fl(OP - u_s) ∈ [lo, hi]` around the stop point
//!   `u_s` (`hi`, `lo` from the thresholds and the last direction);
//! * **moving**: `MV = OP - d · offset`; the interval ends at the first sample `k` whose OP
//!   increment changes sign, `fl(ΔOP_k · ΔOP_{k-1}) <= 0`, which depends on OP alone.
//!
//! [`OpIndex`] holds, once per record, what finds the next event without stepping every
//! sample: the next sign change of ΔOP (a precomputed array, exact including underflow of the
//! product) and a sparse table of running maxima and minima of OP for the band exit. The band
//! test is exact because `x ↦ fl(x - u_s)` is monotone: some sample of a range leaves the band
//! iff the range's maximum or minimum does. The result is the sample-by-sample rule bit for bit
//! (same MV at every sample, same `valid_from`, same In.2/In.3 averages): see the tests here
//! and `tests/events.rs`.
//!
//! Models that cannot describe themselves as such intervals (He's model accumulates its
//! residual force `u_r` as a running floating-point sum, so its threshold test cannot be
//! decided by a range query bit-exactly) return `None` from
//! [`crate::StictionModel::event_rule`] and keep the sample path.

use crate::{
    check_finite, run_valve_with, InitialState, Initialization, RunInfo, StictionError,
    StictionModel, ValveScratch,
};

/// The thresholds of a Kano-type valve (see `kano::KanoCore`): a moving valve lags OP by
/// `d · offset`; a stuck valve whose last motion was up (`d = +1`) reverses when OP falls
/// strictly more than `rev_from_up` below the stop point and restarts upward when it rises
/// strictly more than `j_up` above it (and symmetrically for `d = -1`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventRule {
    /// Lag of a moving valve behind OP.
    pub offset: f64,
    /// OP excursion needed to reverse after moving up.
    pub rev_from_up: f64,
    /// OP excursion needed to reverse after moving down.
    pub rev_from_dn: f64,
    /// OP excursion needed to restart upward after stopping while moving up.
    pub j_up: f64,
    /// OP excursion needed to restart downward after stopping while moving down.
    pub j_dn: f64,
}

/// Samples [`OpIndex::first_exit`] tests one by one before it gallops (a power of two; on the
/// paper loop's exhaustive kano × arx grid 16 was fastest of 4, 8, 16 and 32: 66 ms per search
/// against 74 ms galloping from the first sample, `examples/profile_exhaustive`).
const SCAN: usize = 16;

/// Longest block known to hold the exit that [`OpIndex::first_exit`] scans sample by sample
/// instead of lifting through the table.
const LINEAR_BLOCK: usize = 128;

/// A record's OP, indexed for event-driven valve runs (built once per record, shared by every
/// grid node and thread).
#[derive(Debug, Clone)]
pub struct OpIndex {
    op: Vec<f64>,
    /// `next_stop[k]`: the first `k' >= k` (`k' >= 2`) with `fl(ΔOP_k' · ΔOP_k'-1) <= 0`, or `n`.
    next_stop: Vec<u32>,
    /// Level `j`: `[max, min]` of `op[i .. i + 2^j]`.
    table: Vec<Vec<[f64; 2]>>,
}

impl OpIndex {
    /// Index `op` (finite; otherwise the first bad sample is the error).
    pub fn new(op: &[f64]) -> Result<OpIndex, StictionError> {
        check_finite(op)?;
        let n = op.len();
        let mut next_stop = vec![n as u32; n + 1];
        for k in (2..n).rev() {
            let du = op[k] - op[k - 1];
            let dp = op[k - 1] - op[k - 2];
            next_stop[k] = if du * dp <= 0.0 {
                k as u32
            } else {
                next_stop[k + 1]
            };
        }
        let mut table = vec![op.iter().map(|&v| [v, v]).collect::<Vec<_>>()];
        let mut len = 1;
        while 2 * len <= n {
            let prev = &table[table.len() - 1];
            let level: Vec<[f64; 2]> = (0..=n - 2 * len)
                .map(|i| {
                    let (a, b) = (prev[i], prev[i + len]);
                    [a[0].max(b[0]), a[1].min(b[1])]
                })
                .collect();
            table.push(level);
            len *= 2;
        }
        Ok(OpIndex {
            op: op.to_vec(),
            next_stop,
            table,
        })
    }

    /// The indexed record.
    pub fn op(&self) -> &[f64] {
        &self.op
    }

    /// First `k >= from` with `fl(op[k] - u_s) > hi` or `< lo`, or `n`.
    #[inline]
    fn first_exit(&self, from: usize, u_s: f64, hi: f64, lo: f64) -> usize {
        let op = &self.op;
        let n = op.len();
        let exits = |mx: f64, mn: f64| mx - u_s > hi || mn - u_s < lo;
        let mut p = from;
        // the next samples one by one from OP itself (short stuck intervals, the common case,
        // end here without touching the table, whose levels lie apart in memory)
        let scan_end = (p + SCAN).min(n);
        while p < scan_end {
            if exits(op[p], op[p]) {
                return p;
            }
            p += 1;
        }
        if p >= n {
            return n;
        }
        // gallop: blocks of SCAN, 2 SCAN, 4 SCAN, ... samples without an exit, then the last
        // block sample by sample when it is short, else by binary lifting
        let top = self.table.len();
        let mut j = SCAN.trailing_zeros() as usize;
        while j < top && p + (1 << j) <= n {
            let [mx, mn] = self.table[j][p];
            if exits(mx, mn) {
                break;
            }
            p += 1 << j;
            j += 1;
        }
        if j < top && p + (1 << j) <= n && (1 << j) <= LINEAR_BLOCK {
            // the exit lies in the block [p, p + 2^j): a short one is scanned sample by
            // sample (contiguous) rather than lifted through the table's levels (one read
            // per level, each in a level of its own far apart in memory)
            let block = &op[p..p + (1 << j)];
            if let Some(i) = block.iter().position(|&v| exits(v, v)) {
                return p + i;
            }
        }
        for jj in (0..j.min(top)).rev() {
            let len = 1usize << jj;
            if p + len <= n {
                let [mx, mn] = self.table[jj][p];
                if !exits(mx, mn) {
                    p += len;
                }
            }
        }
        if j >= top || p + (1 << j.min(top - 1)) > n {
            // ran out of levels or of record: finish by lifting from the top
            for jj in (0..top).rev() {
                let len = 1usize << jj;
                if p + len <= n {
                    let [mx, mn] = self.table[jj][p];
                    if !exits(mx, mn) {
                        p += len;
                    }
                }
            }
        }
        p
    }
}

/// The valve's state after a sample.
#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    /// Moving in direction `d` (MV = OP - d · offset).
    Moving { d: f64 },
    /// At rest at `mv` since OP was `u_s`, last motion `d`.
    Stuck { d: f64, u_s: f64, mv: f64 },
}

impl State {
    /// Same future for any input (the sample path's `KanoState::same` at a sample `k >= 1`,
    /// where `u_prev` and `du_prev` are OP's).
    fn same(&self, other: &State) -> bool {
        match (self, other) {
            (State::Moving { d: a }, State::Moving { d: b }) => a == b,
            (
                State::Stuck { d, u_s, mv },
                State::Stuck {
                    d: d2,
                    u_s: u2,
                    mv: m2,
                },
            ) => d == d2 && u_s == u2 && mv == m2,
            _ => false,
        }
    }
}

/// One interval `[start, next start)` of constant state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Seg {
    start: usize,
    state: State,
}

/// Generates a run's intervals one by one.
struct Runner<'a> {
    rule: EventRule,
    index: &'a OpIndex,
    /// State from sample `k` on (until the next event).
    state: State,
    /// Current interval start (`n` when done).
    k: usize,
    /// `du_prev` of the initial state (used only for the stop test at sample 1).
    du0: f64,
    /// MV at sample 0.
    mv0: f64,
}

impl<'a> Runner<'a> {
    fn new(rule: EventRule, index: &'a OpIndex, init: &InitialState) -> Option<Self> {
        let op0 = *index.op.first()?;
        let (d, u_s, mv0) = init.kano_start(op0, rule.offset);
        let state = if init.stuck {
            State::Stuck { d, u_s, mv: mv0 }
        } else {
            State::Moving { d }
        };
        Some(Runner {
            rule,
            index,
            state,
            k: 0,
            du0: if init.stuck { 0.0 } else { d },
            mv0,
        })
    }

    /// `(hi, lo)` of the band `fl(OP - u_s) ∈ [lo, hi]` of a valve stuck after moving in
    /// direction `d`, and the reversal threshold.
    #[inline]
    fn band(&self, d: f64) -> (f64, f64, f64) {
        let r = &self.rule;
        let (rev, same) = if d > 0.0 {
            (r.rev_from_up, r.j_up)
        } else {
            (r.rev_from_dn, r.j_dn)
        };
        // excursion = d (u - u_s): reverse when -excursion > rev, restart when excursion > same
        if d > 0.0 {
            (same, -rev, rev)
        } else {
            (rev, -same, rev)
        }
    }

    /// The state after a band exit at sample `k` of a valve stuck at `u_s` after moving in
    /// direction `d` (the sample path's reversal test first).
    #[inline]
    fn exit_state(&self, k: usize, d: f64, u_s: f64, rev: f64) -> State {
        let excursion = d * (self.index.op[k] - u_s);
        State::Moving {
            d: if -excursion > rev { -d } else { d },
        }
    }

    /// The current interval; afterwards `self.k` is the start of the next one (`n` at the end).
    fn next(&mut self) -> Option<Seg> {
        let op = &self.index.op;
        let n = op.len();
        if self.k >= n {
            return None;
        }
        let seg = Seg {
            start: self.k,
            state: self.state,
        };
        match self.state {
            State::Moving { d } => {
                // (a) the valve stops where the OP increment changes sign (depends on OP only)
                let stop = if self.k == 0 {
                    if n > 1 && (op[1] - op[0]) * self.du0 <= 0.0 {
                        1
                    } else {
                        self.index.next_stop[2.min(n)] as usize
                    }
                } else {
                    self.index.next_stop[(self.k + 1).min(n)] as usize
                };
                if stop >= n {
                    self.k = n;
                    return Some(seg);
                }
                let u_s = op[stop - 1];
                let held = if stop == 1 {
                    self.mv0
                } else {
                    op[stop - 1] - d * self.rule.offset
                };
                // (b) a stopping valve is tested against its band at the stop sample
                let (hi, lo, rev) = self.band(d);
                let x = op[stop] - u_s;
                self.state = if x > hi || x < lo {
                    self.exit_state(stop, d, u_s, rev)
                } else {
                    State::Stuck { d, u_s, mv: held }
                };
                self.k = stop;
            }
            State::Stuck { d, u_s, .. } => {
                let (hi, lo, rev) = self.band(d);
                let exit = self.index.first_exit(self.k + 1, u_s, hi, lo);
                if exit >= n {
                    self.k = n;
                    return Some(seg);
                }
                self.state = self.exit_state(exit, d, u_s, rev);
                self.k = exit;
            }
        }
        Some(seg)
    }
}

/// Write MV over `[segs[0].start, to)` for the intervals `segs` (sorted).
fn fill(rule: &EventRule, op: &[f64], segs: &[Seg], mv0: f64, mv: &mut [f64], to: usize) {
    fill_from(rule, op, segs, mv0, mv, 0, to);
}

/// Write MV over `[from, to)` for the intervals `segs` (sorted, covering it).
fn fill_from(
    rule: &EventRule,
    op: &[f64],
    segs: &[Seg],
    mv0: f64,
    mv: &mut [f64],
    from: usize,
    to: usize,
) {
    let first = segs.partition_point(|s| s.start <= from).saturating_sub(1);
    for (i, s) in segs.iter().enumerate().skip(first) {
        let start = s.start.max(from);
        let end = segs.get(i + 1).map_or(to, |t| t.start).min(to);
        if start >= end {
            if start >= to {
                break;
            }
            continue;
        }
        match s.state {
            State::Stuck { mv: v, .. } => mv[start..end].iter_mut().for_each(|m| *m = v),
            State::Moving { d } => {
                let dof = d * rule.offset;
                for (m, &u) in mv[start..end].iter_mut().zip(&op[start..end]) {
                    *m = u - dof;
                }
            }
        }
    }
    if from == 0 && segs.first().is_some_and(|s| s.start == 0) && to > 0 {
        mv[0] = mv0;
    }
}

/// [`crate::run_valve_with`] through `index`: event-driven when the model has an
/// [`EventRule`], the sample path otherwise. Same MV (bit for bit), `valid_from` and fallback.
pub fn run_valve_indexed(
    model: &dyn StictionModel,
    index: &OpIndex,
    init: &Initialization,
    scratch: &mut ValveScratch,
) -> Result<RunInfo, StictionError> {
    let Some(rule) = model.event_rule() else {
        return run_valve_with(model, &index.op, init, scratch);
    };
    let op = &index.op;
    let n = op.len();
    scratch.mv.resize(n, 0.0);
    match init {
        Initialization::In1(state) => {
            state.validate()?;
            let mut segs = std::mem::take(&mut scratch.segs[0]);
            segs.clear();
            if let Some(mut runner) = Runner::new(rule, index, state) {
                while let Some(s) = runner.next() {
                    segs.push(s);
                }
                fill(&rule, op, &segs, runner.mv0, &mut scratch.mv, n);
            }
            scratch.segs[0] = segs;
            Ok(RunInfo::without_fallback(0))
        }
        Initialization::In2 {
            stationary_fraction,
        } => {
            let info =
                RunInfo::without_fallback(crate::init::in2_valid_from(*stationary_fraction, n)?);
            four_starts(rule, index, scratch);
            Ok(info)
        }
        // the sample after the last one where the four runs differ by more than the tolerance
        // (`in3_valid_from`), and the In.2 fallback when they never coincide
        Initialization::In3 => Ok(RunInfo::in3(four_starts(rule, index, scratch), n)),
    }
}

/// The four In.2/In.3 starts, as `simulate_starts` + `average_into` + `in3_valid_from` do it
/// sample by sample: run 0 over the whole record, each other run until its state equals that
/// of an earlier run (after which its MV is that run's, bit for bit). MV goes to `scratch.mv`:
/// before the common merge (every run equal to run 0) the average of the four runs where they
/// differ, run 0's value elsewhere, assembled piece by piece over the union of the runs'
/// intervals (constant pieces where all four are stuck, per sample elsewhere). Returns the
/// In.3 stationary time before the fallback: one after the last sample where the runs differ
/// by more than `1e-12 · max(1, |MV_0|)` (0 if none).
///
/// A run stops at the first earlier run it meets, not only at run 0: on a record where run 0
/// never meets the others (a valve held where it started), runs 2 and 3 usually meet run 1
/// early, and then read run 1's intervals instead of generating the same ones again.
fn four_starts(rule: EventRule, index: &OpIndex, scratch: &mut ValveScratch) -> usize {
    let op = &index.op;
    let n = op.len();
    scratch.mv.resize(n, 0.0);
    if n == 0 {
        return 0;
    }
    let starts = InitialState::four_variants();
    let mut segs = std::mem::take(&mut scratch.segs);
    let mut mv0 = [0.0; 4];
    // run i equals run `joins[i].1` from sample `joins[i].0` on (`n`: never)
    let mut joins = [(n, 0usize); 4];
    for s in segs.iter_mut() {
        s.clear();
    }
    let Some(mut runner0) = Runner::new(rule, index, &starts[0]) else {
        return 0;
    };
    while let Some(s) = runner0.next() {
        segs[0].push(s);
    }
    mv0[0] = runner0.mv0;
    joins[0] = (usize::MAX, 0);
    for i in 1..4 {
        let (head, tail) = segs.split_at_mut(i);
        let own = &mut tail[0];
        if let Some(mut runner) = Runner::new(rule, index, &starts[i]) {
            mv0[i] = runner.mv0;
            // equality with an earlier run can only begin at an interval start of either run,
            // and persists once reached; an earlier run's own intervals hold until it joined
            // another (from there that one's list describes it)
            let mut cursors = [0usize; 4];
            'run: while let Some(seg) = runner.next() {
                own.push(seg);
                let mut found: Option<(usize, usize)> = None;
                for (q, list) in head.iter().enumerate() {
                    let end = runner.k.min(joins[q].0);
                    if seg.start >= end {
                        continue;
                    }
                    if let Some(k) = first_same(list, &mut cursors[q], &seg, end) {
                        if found.is_none_or(|(f, _)| k < f) {
                            found = Some((k, q));
                        }
                    }
                }
                if let Some(j) = found {
                    joins[i] = j;
                    break 'run;
                }
            }
        }
    }
    // the first sample from which each run equals run 0
    let mut merges = [n; 4];
    merges[0] = 1;
    for i in 1..4 {
        let (k, q) = joins[i];
        merges[i] = if k >= n {
            n
        } else if q == 0 {
            k
        } else {
            k.max(merges[q])
        };
    }
    let merge = merges.iter().copied().max().unwrap_or(n).min(n);
    // run 0 from the merge on
    fill_from(&rule, op, &segs[0], mv0[0], &mut scratch.mv, merge, n);
    let last = assemble(&rule, op, &segs, &mv0, &joins, merge, &mut scratch.mv);
    scratch.segs = segs;
    last.map_or(0, |k| k + 1)
}

/// MV over `[0, merge)` from the four runs' intervals (see [`four_starts`]; run `r` reads its
/// own list before `joins[r].0`, then the list of the run it joined); returns the last sample
/// where a run differs from run 0 by more than the In.3 tolerance.
fn assemble(
    rule: &EventRule,
    op: &[f64],
    segs: &[Vec<Seg>; 4],
    mv0: &[f64; 4],
    joins: &[(usize, usize); 4],
    merge: usize,
    mv: &mut [f64],
) -> Option<usize> {
    let tol = |v: f64| 1e-12 * v.abs().max(1.0);
    let mut last = None;
    let select = |v: [f64; 4]| -> f64 {
        if v[1] != v[0] || v[2] != v[0] || v[3] != v[0] {
            v.iter().sum::<f64>() / 4.0
        } else {
            v[0]
        }
    };
    let differs = |v: &[f64; 4]| {
        let t = tol(v[0]);
        v[1..].iter().any(|x| (x - v[0]).abs() > t)
    };
    if merge == 0 {
        return None;
    }
    // sample 0: the initial positions
    mv[0] = select(*mv0);
    if differs(mv0) {
        last = Some(0);
    }
    // cursors: [interval index per list]; a run at or past its join reads the list of the run
    // it joined (run 0's list covers the record)
    let mut cur = [0usize; 4];
    let mut k = 1;
    while k < merge {
        let mut st = [State::Moving { d: 0.0 }; 4];
        let mut end = merge;
        for (r, state) in st.iter_mut().enumerate() {
            let mut list = r;
            while k >= joins[list].0 {
                list = joins[list].1;
            }
            let sl = &segs[list];
            let c = &mut cur[list];
            while *c + 1 < sl.len() && sl[*c + 1].start <= k {
                *c += 1;
            }
            *state = sl[*c].state;
            if let Some(next) = sl.get(*c + 1) {
                end = end.min(next.start);
            }
            end = end.min(joins[list].0);
        }
        let all_stuck = st.iter().all(|s| matches!(s, State::Stuck { .. }));
        if all_stuck {
            let v = st.map(|s| match s {
                State::Stuck { mv, .. } => mv,
                State::Moving { .. } => 0.0,
            });
            let m = select(v);
            mv[k..end].iter_mut().for_each(|x| *x = m);
            if differs(&v) {
                last = Some(end - 1);
            }
        } else {
            // per sample: stuck runs hold their value, moving ones follow OP
            let shift = st.map(|s| match s {
                State::Stuck { mv, .. } => (0.0, mv),
                State::Moving { d } => (1.0, d * rule.offset),
            });
            for t in k..end {
                let u = op[t];
                let v = shift.map(|(moving, c)| if moving == 1.0 { u - c } else { c });
                mv[t] = select(v);
                if differs(&v) {
                    last = Some(t);
                }
            }
        }
        k = end;
    }
    last
}

/// Run i is in `seg.state` over `[seg.start, end)`: the first sample `k >= 1` there at which
/// run 0's state is the same.
fn first_same(segs0: &[Seg], p0: &mut usize, seg: &Seg, end: usize) -> Option<usize> {
    while let Some(s0) = segs0.get(*p0) {
        let e0 = segs0.get(*p0 + 1).map_or(usize::MAX, |t| t.start);
        if e0 <= seg.start {
            *p0 += 1;
            continue;
        }
        if s0.start >= end {
            return None;
        }
        let from = s0.start.max(seg.start).max(1);
        if from < end.min(e0) && s0.state.same(&seg.state) {
            return Some(from);
        }
        if e0 <= end {
            *p0 += 1;
        } else {
            return None;
        }
    }
    None
}
