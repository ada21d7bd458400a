//! Property tests of the invariants of ALGORITHMS.md: Kano K1-K10 (§1.7), He H1-H6 (§2.5),
//! kano-asym A1 (§3.2), the initialization strategies In.1-In.3 (§5.7), plus the plugin
//! plumbing (typetag JSON, registry, errors).
//!
//! Most properties run on *dyadic* inputs (multiples of 1/64 for OP, 1/16 for parameters):
//! every sum and difference the models compute is then exact, so threshold ties (`>` vs `>=`)
//! really occur and equivariance properties can be asserted with `==`. The number of cases
//! follows `PROPTEST_CASES` (default 256).

mod common;
use common::{he, kano, kano_asym};

use proptest::prelude::*;
use stiction_models::{
    find_model, registry, run_valve, Direction, He, InitialState, Initialization, Kano, KanoAsym,
    StictionError, StictionModel, ValveRun,
};

// ---------------------------------------------------------------------------------------------
// Helpers and strategies
// ---------------------------------------------------------------------------------------------

fn sim(model: &dyn StictionModel, op: &[f64], init: &InitialState) -> Vec<f64> {
    model.simulate(op, init).expect("finite OP and init")
}

/// `-v` for each value.
fn negated(v: &[f64]) -> Vec<f64> {
    v.iter().map(|x| -x).collect()
}

/// The start of the mirrored run (-OP): the other direction, every level negated.
fn mirrored(init: &InitialState) -> InitialState {
    InitialState {
        direction: flip(init.direction),
        stuck_at: init.stuck_at.map(|v| -v),
        position: init.position.map(|v| -v),
        ..*init
    }
}

/// `op[..=k0]`, then `op[k0]` held for `tail` more samples.
fn held_from(op: &[f64], k0: usize, tail: usize) -> Vec<f64> {
    let mut held = op[..=k0].to_vec();
    held.extend(std::iter::repeat_n(op[k0], tail));
    held
}

/// MV and the stuck flag after every sample, through the `ValveState` interface.
fn stepped(model: &dyn StictionModel, op: &[f64], init: &InitialState) -> (Vec<f64>, Vec<bool>) {
    let mut state = model.start(op[0], init).expect("finite start");
    let mut mv = vec![state.position()];
    let mut stuck = vec![state.is_stuck()];
    for &u in &op[1..] {
        mv.push(state.step(u));
        stuck.push(state.is_stuck());
    }
    (mv, stuck)
}

fn sign_of(d: Direction) -> f64 {
    match d {
        Direction::Up => 1.0,
        Direction::Down => -1.0,
    }
}

fn flip(d: Direction) -> Direction {
    match d {
        Direction::Up => Direction::Down,
        Direction::Down => Direction::Up,
    }
}

fn dyadic(lo: i32, hi: i32, denom: f64) -> impl Strategy<Value = f64> {
    (lo..=hi).prop_map(move |i| f64::from(i) / denom)
}

/// One OP increment on the 1/64 grid: flat, small, or large.
fn increment() -> impl Strategy<Value = f64> {
    prop_oneof![
        2 => Just(0.0),
        4 => dyadic(-64, 64, 64.0),
        2 => dyadic(-640, 640, 64.0),
    ]
}

fn cumulate(start: f64, steps: &[f64]) -> Vec<f64> {
    let mut x = start;
    let mut op = vec![start];
    for &s in steps {
        x += s;
        op.push(x);
    }
    op
}

/// Dyadic OP record, 1 to 300 samples.
fn op_dyadic() -> impl Strategy<Value = Vec<f64>> {
    (
        dyadic(-3200, 9600, 64.0),
        prop::collection::vec(increment(), 0..300),
    )
        .prop_map(|(start, steps)| cumulate(start, &steps))
}

/// OP with arbitrary (non-dyadic) values: a random walk plus a sinusoid, 1 to 400 samples.
fn op_float() -> impl Strategy<Value = Vec<f64>> {
    (
        -50.0..150.0f64,
        0.0..15.0f64,
        4.0..120.0f64,
        prop::collection::vec(-3.0..3.0f64, 0..400),
    )
        .prop_map(|(start, amp, period, steps)| {
            let walk = cumulate(start, &steps);
            walk.iter()
                .enumerate()
                .map(|(k, w)| w + amp * (std::f64::consts::TAU * k as f64 / period).sin())
                .collect()
        })
}

fn monotone_dyadic() -> impl Strategy<Value = Vec<f64>> {
    let inc = prop_oneof![2 => Just(0.0), 3 => dyadic(0, 64, 64.0), 1 => dyadic(0, 640, 64.0)];
    (
        dyadic(-3200, 9600, 64.0),
        prop::collection::vec(inc, 0..300),
    )
        .prop_map(|(start, steps)| cumulate(start, &steps))
}

/// (S, J) on the 1/16 grid with 0 <= J <= S, with the corners J = 0, J = S, S = J = 0.
fn sj() -> impl Strategy<Value = (f64, f64)> {
    prop_oneof![
        4 => (0u32..=192, 0u32..=192).prop_map(|(a, b)| {
            (f64::from(a.max(b)) / 16.0, f64::from(a.min(b)) / 16.0)
        }),
        1 => (0u32..=192).prop_map(|a| (f64::from(a) / 16.0, f64::from(a) / 16.0)),
        1 => (0u32..=192).prop_map(|a| (f64::from(a) / 16.0, 0.0)),
        1 => Just((0.0, 0.0)),
    ]
}

fn direction() -> impl Strategy<Value = Direction> {
    prop_oneof![Just(Direction::Up), Just(Direction::Down)]
}

/// One of the four `(stp, d)` combinations with consistent (implicit) values.
fn variant() -> impl Strategy<Value = InitialState> {
    (0usize..4).prop_map(|i| InitialState::four_variants()[i])
}

/// Any initial state: explicit `stuck_at`/`position` (dyadic offsets from OP(0)) or implicit.
fn any_init() -> impl Strategy<Value = (Direction, bool, Option<f64>, Option<f64>)> {
    (
        direction(),
        any::<bool>(),
        prop::option::of(dyadic(-640, 640, 64.0)),
        prop::option::of(dyadic(-640, 640, 64.0)),
    )
}

fn make_init(
    op0: f64,
    (direction, stuck, stuck_off, pos_off): (Direction, bool, Option<f64>, Option<f64>),
) -> InitialState {
    InitialState {
        direction,
        stuck,
        stuck_at: stuck_off.map(|o| op0 + o),
        position: pos_off.map(|o| op0 + o),
    }
}

/// Same initial state with every implicit value made explicit for this model and OP(0).
fn explicit_kano_init(init: &InitialState, offset: f64, op0: f64) -> InitialState {
    let d = sign_of(init.direction);
    let u_s0 = init.stuck_at.unwrap_or(op0);
    let mv0 = init.position.unwrap_or(if init.stuck {
        u_s0 - d * offset
    } else {
        op0 - d * offset
    });
    InitialState {
        stuck_at: Some(u_s0),
        position: Some(mv0),
        ..*init
    }
}

/// OP whose increments respect §2.4's condition for He ≡ Kano: an increment with the same
/// sign as the previous one exceeds J in magnitude. `d0` plays the previous increment of a
/// moving start.
fn op_fast_segments(j: f64, d0: f64, start: f64, raw: &[(i8, u32)]) -> Vec<f64> {
    let mut op = vec![start];
    let mut prev = d0;
    let mut x = start;
    for &(dir, mag) in raw {
        let dir = f64::from(dir.signum());
        let small = f64::from(mag % 640) / 64.0;
        let du = if dir * prev > 0.0 {
            dir * (j + 1.0 / 64.0 + small)
        } else {
            dir * small
        };
        x += du;
        op.push(x);
        prev = du;
    }
    op
}

/// The state of a Kano-type valve that is stuck: which thresholds it obeys.
struct Thresholds {
    rev_from_up: f64,
    rev_from_dn: f64,
    j_up: f64,
    j_dn: f64,
    offset: f64,
}

/// K4 (and its asymmetric form A3): from rest at `u_s` with direction `d`, the valve stays
/// put exactly while `-d (u - u_s) <= S_rev` and `d (u - u_s) <= J_d`, and the first sample
/// that violates one of them is a breakaway in the corresponding direction.
fn check_breakaway(
    model: &dyn StictionModel,
    th: &Thresholds,
    op: &[f64],
    init: &InitialState,
) -> Result<(), TestCaseError> {
    prop_assert!(init.stuck);
    let d = sign_of(init.direction);
    let u_s = init.stuck_at.unwrap_or(op[0]);
    let (rev, same) = if d > 0.0 {
        (th.rev_from_up, th.j_up)
    } else {
        (th.rev_from_dn, th.j_dn)
    };
    let (mv, stuck) = stepped(model, op, init);
    for k in 1..op.len() {
        let exc = d * (op[k] - u_s);
        if -exc > rev {
            prop_assert!(!stuck[k], "k = {}: reversal not taken", k);
            prop_assert_eq!(mv[k], op[k] + d * th.offset, "k = {}", k);
            return Ok(());
        } else if exc > same {
            prop_assert!(!stuck[k], "k = {}: restart not taken", k);
            prop_assert_eq!(mv[k], op[k] - d * th.offset, "k = {}", k);
            return Ok(());
        }
        prop_assert!(
            stuck[k],
            "k = {}: moved with excursion {} inside the band",
            k,
            exc
        );
        prop_assert_eq!(mv[k], mv[0], "k = {}", k);
    }
    Ok(())
}

fn ceil_tenth(n: usize) -> usize {
    n.div_ceil(10)
}

fn four_sequences(model: &dyn StictionModel, op: &[f64]) -> Vec<Vec<f64>> {
    InitialState::four_variants()
        .iter()
        .map(|v| sim(model, op, v))
        .collect()
}

fn coincide_at(seqs: &[Vec<f64>], k: usize) -> bool {
    let first = seqs[0][k];
    seqs[1..]
        .iter()
        .all(|s| (s[k] - first).abs() <= 1e-12 * first.abs().max(1.0))
}

fn check_in3(model: &dyn StictionModel, op: &[f64]) -> Result<ValveRun, TestCaseError> {
    let run = run_valve(model, op, &Initialization::In3).expect("finite OP");
    let seqs = four_sequences(model, op);
    let n = op.len();
    prop_assert_eq!(run.mv.len(), n);
    if run.fell_back {
        prop_assert_eq!(run.valid_from, ceil_tenth(n));
        // Falling back means the four sequences never coincide up to the end.
        prop_assert!(!coincide_at(&seqs, n - 1));
    } else {
        prop_assert!(run.valid_from < n || n == 0);
        for k in run.valid_from..n {
            prop_assert!(
                coincide_at(&seqs, k),
                "k = {} >= valid_from {}",
                k,
                run.valid_from
            );
            prop_assert_eq!(run.mv[k], seqs[0][k]);
        }
        if run.valid_from > 0 {
            prop_assert!(!coincide_at(&seqs, run.valid_from - 1));
        }
    }
    // Where the four agree exactly the average is that value; elsewhere it is their mean.
    for k in 0..n {
        let all_same = seqs[1..].iter().all(|s| s[k] == seqs[0][k]);
        let want = if all_same {
            seqs[0][k]
        } else {
            seqs.iter().map(|s| s[k]).sum::<f64>() / 4.0
        };
        prop_assert_eq!(run.mv[k], want, "average at k = {}", k);
    }
    Ok(run)
}

// ---------------------------------------------------------------------------------------------
// Kano K1-K10
// ---------------------------------------------------------------------------------------------

proptest! {
    /// K1: S = J = 0 ⇒ MV(k) = OP(k) for k >= 1 (any start without an explicit position).
    #[test]
    fn k1_no_stiction_is_identity(op in op_float(), init in any_init()) {
        let init = InitialState { position: None, ..make_init(op[0], init) };
        let mv = sim(&kano(0.0, 0.0), &op, &init);
        prop_assert_eq!(&mv[1..], &op[1..]);
    }

    /// K2: while the valve is stuck MV is constant.
    #[test]
    fn k2_stuck_valve_holds_mv(op in op_dyadic(), (s, j) in sj(), init in any_init()) {
        let init = make_init(op[0], init);
        let (mv, stuck) = stepped(&kano(s, j), &op, &init);
        for k in 1..op.len() {
            if stuck[k] {
                prop_assert_eq!(mv[k], mv[k - 1], "k = {}", k);
            }
        }
    }

    /// K3: with a consistent start |u - MV| <= (S+J)/2 for every k, and a moving valve lags
    /// OP by exactly (S-J)/2 in its direction of motion.
    #[test]
    fn k3_bounded_lag_and_exact_offset(op in op_dyadic(), (s, j) in sj(), init in variant()) {
        let (mv, stuck) = stepped(&kano(s, j), &op, &init);
        for k in 0..op.len() {
            prop_assert!((op[k] - mv[k]).abs() <= (s + j) / 2.0, "k = {}", k);
            if !stuck[k] {
                prop_assert_eq!((op[k] - mv[k]).abs(), (s - j) / 2.0, "k = {}", k);
            }
        }
    }

    /// K3 after the first breakaway, for any (also inconsistent, explicit) start.
    #[test]
    fn k3_after_first_breakaway_any_start(op in op_dyadic(), (s, j) in sj(), init in any_init()) {
        let init = make_init(op[0], init);
        let (mv, stuck) = stepped(&kano(s, j), &op, &init);
        if let Some(first) = (1..op.len()).find(|&k| !stuck[k]) {
            for k in first..op.len() {
                prop_assert!((op[k] - mv[k]).abs() <= (s + j) / 2.0, "k = {}", k);
            }
        }
    }

    /// K4: from rest, a reversal needs an excursion from u_s strictly greater than S and a
    /// same-direction restart strictly more than J (exact ties are generated).
    #[test]
    fn k4_breakaway_thresholds_are_strict(
        op in op_dyadic(),
        (s, j) in sj(),
        dir in direction(),
        stuck_off in prop::option::of(dyadic(-640, 640, 64.0)),
    ) {
        let init = InitialState {
            direction: dir,
            stuck: true,
            stuck_at: stuck_off.map(|o| op[0] + o),
            position: None,
        };
        let th = Thresholds { rev_from_up: s, rev_from_dn: s, j_up: j, j_dn: j, offset: (s - j) / 2.0 };
        check_breakaway(&kano(s, j), &th, &op, &init)?;
    }

    /// K4 at the exact thresholds: OP moving by exactly S (reversal) or J (same direction)
    /// does not move the valve; 1/64 more does.
    #[test]
    fn k4_exact_ties(op0 in dyadic(-3200, 9600, 64.0), (s, j) in sj(), dir in direction()) {
        let model = kano(s, j);
        let d = sign_of(dir);
        let init = InitialState { direction: dir, ..InitialState::default() };
        let held = op0 - d * (s - j) / 2.0;
        let eps = 1.0 / 64.0;
        prop_assert_eq!(sim(&model, &[op0, op0 - d * s], &init), vec![held, held]);
        prop_assert_eq!(sim(&model, &[op0, op0 + d * j], &init), vec![held, held]);
        let rev = op0 - d * (s + eps);
        prop_assert_eq!(sim(&model, &[op0, rev], &init), vec![held, rev + d * (s - j) / 2.0]);
        let same = op0 + d * (j + eps);
        prop_assert_eq!(sim(&model, &[op0, same], &init), vec![held, same - d * (s - j) / 2.0]);
    }

    /// K5: monotone OP with a consistent start ⇒ monotone MV (both directions).
    #[test]
    fn k5_monotone_op_gives_monotone_mv(op in monotone_dyadic(), (s, j) in sj(), init in variant()) {
        let model = kano(s, j);
        let mv = sim(&model, &op, &init);
        for k in 1..op.len() {
            prop_assert!(mv[k] >= mv[k - 1], "rising: k = {}: {} < {}", k, mv[k], mv[k - 1]);
        }
        let mv = sim(&model, &negated(&op), &init);
        for k in 1..op.len() {
            prop_assert!(mv[k] <= mv[k - 1], "falling: k = {}: {} > {}", k, mv[k], mv[k - 1]);
        }
    }

    /// K6: OP + c with u_s0 + c and mv0 + c ⇒ MV + c (exact on dyadic data).
    #[test]
    fn k6_translation(
        op in op_dyadic(),
        (s, j) in sj(),
        init in any_init(),
        c in dyadic(-6400, 6400, 64.0),
    ) {
        let model = kano(s, j);
        let init = explicit_kano_init(&make_init(op[0], init), (s - j) / 2.0, op[0]);
        let shifted_init = InitialState {
            stuck_at: init.stuck_at.map(|v| v + c),
            position: init.position.map(|v| v + c),
            ..init
        };
        let shifted: Vec<f64> = op.iter().map(|v| v + c).collect();
        let want: Vec<f64> = sim(&model, &op, &init).iter().map(|v| v + c).collect();
        prop_assert_eq!(sim(&model, &shifted, &shifted_init), want.clone());
        // The implicit defaults (u_s0 = OP(0), consistent MV(0)) translate with OP.
        let implicit = InitialState { stuck_at: None, position: None, ..init };
        let want: Vec<f64> = sim(&model, &op, &implicit).iter().map(|v| v + c).collect();
        prop_assert_eq!(sim(&model, &shifted, &implicit), want);
    }

    /// K7: -OP with -d0, -u_s0, -mv0 ⇒ -MV (exact for any floats: negation is exact).
    #[test]
    fn k7_sign_symmetry(op in op_float(), (s, j) in sj(), init in any_init()) {
        let model = kano(s, j);
        let init = make_init(op[0], init);
        let want = negated(&sim(&model, &op, &init));
        prop_assert_eq!(sim(&model, &negated(&op), &mirrored(&init)), want);
    }

    /// K8: OP constant from k0 >= 1 on ⇒ MV constant from k0 on (any start); from k0 = 0
    /// when the valve starts stuck at OP(0).
    #[test]
    fn k8_constant_op_gives_constant_mv(
        op in op_dyadic(),
        (s, j) in sj(),
        init in any_init(),
        k0 in 0usize..300,
        tail in 1usize..50,
    ) {
        let model = kano(s, j);
        let mut init = make_init(op[0], init);
        let k0 = k0 % op.len();
        if k0 == 0 {
            init.stuck_at = None;
        }
        let mv = sim(&model, &held_from(&op, k0, tail), &init);
        for k in k0..mv.len() {
            prop_assert_eq!(mv[k], mv[k0], "k = {}", k);
        }
    }

    /// K9: two runs from different consistent starts agree from the first sample at which
    /// both are moving in the same direction.
    #[test]
    fn k9_coupling_after_first_common_motion(
        op in op_dyadic(),
        (s, j) in sj(),
        a in any_init(),
        b in any_init(),
    ) {
        let model = kano(s, j);
        // Consistent starts: no explicit position, and OP(0) inside the stuck band of u_s0
        // (otherwise the valve can break away at k = 1 against the OP increment, e.g. stuck
        // "up" at u_s0 < OP(0) - J with OP falling: it restarts with d = +1 while MV falls).
        let consistent = |init| {
            let init = InitialState { position: None, ..make_init(op[0], init) };
            let (lo, hi) = match init.direction {
                Direction::Up => (-j, s),
                Direction::Down => (-s, j),
            };
            InitialState { stuck_at: init.stuck_at.map(|u| op[0] + (u - op[0]).clamp(lo, hi)), ..init }
        };
        let (a, b) = (consistent(a), consistent(b));
        let (mv_a, st_a) = stepped(&model, &op, &a);
        let (mv_b, st_b) = stepped(&model, &op, &b);
        let dir = |mv: &[f64], k: usize| (mv[k] - mv[k - 1]).signum();
        if let Some(k) = (1..op.len()).find(|&k| {
            !st_a[k] && !st_b[k] && dir(&mv_a, k) == dir(&mv_b, k)
        }) {
            prop_assert_eq!(&mv_a[k..], &mv_b[k..], "common motion at k = {}", k);
        }
    }

    /// K9 liveness: for a sinusoid whose peak-to-peak exceeds S + J the four (stp, d) starts
    /// coincide within two periods, and In.3 finds that.
    #[test]
    fn k9_four_starts_couple_within_two_periods(
        (s, j) in sj(),
        extra in 0.0..10.0f64,
        period in 20usize..100,
        phase in 0.0..std::f64::consts::TAU,
        base in 20.0..80.0f64,
    ) {
        let amp = (s + j) / 2.0 + 1.0 + extra;
        let n = 3 * period;
        let op: Vec<f64> = (0..n)
            .map(|k| base + amp * (std::f64::consts::TAU * k as f64 / period as f64 + phase).sin())
            .collect();
        let model = kano(s, j);
        let run = check_in3(&model, &op)?;
        prop_assert!(!run.fell_back);
        prop_assert!(run.valid_from <= 2 * period + 2, "valid_from {} period {}", run.valid_from, period);
    }

    /// K10 (= H3): J = 0 ⇒ Kano(S, 0) equals He(fs = fd = S/2) for any input and each of the
    /// four starts.
    #[test]
    fn k10_kano_j0_equals_he(op in op_dyadic(), s16 in 0u32..=192, init in variant()) {
        let s = f64::from(s16) / 16.0;
        prop_assert_eq!(sim(&kano(s, 0.0), &op, &init), sim(&he(s / 2.0, s / 2.0), &op, &init));
    }
}

// ---------------------------------------------------------------------------------------------
// He H1-H6
// ---------------------------------------------------------------------------------------------

proptest! {
    /// H1: fs = fd = 0 ⇒ MV(k) = OP(k) for k >= 1.
    #[test]
    fn h1_no_stiction_is_identity(op in op_float(), dir in direction(), stuck in any::<bool>()) {
        let init = InitialState { direction: dir, stuck, ..InitialState::default() };
        let mv = sim(&he(0.0, 0.0), &op, &init);
        prop_assert_eq!(&mv[1..], &op[1..]);
    }

    /// H2: |u - MV| <= fs with a consistent start, and exactly fd while slipping.
    #[test]
    fn h2_bounded_lag(op in op_dyadic(), (s, j) in sj(), init in variant()) {
        let (fs, fd) = ((s + j) / 2.0, (s - j) / 2.0);
        let (mv, stuck) = stepped(&he(fs, fd), &op, &init);
        for k in 0..op.len() {
            prop_assert!((op[k] - mv[k]).abs() <= fs, "k = {}", k);
            if !stuck[k] {
                prop_assert_eq!((op[k] - mv[k]).abs(), fd, "k = {}", k);
            }
        }
    }

    /// H4: He(fs, fd) ≡ Kano(S, J) when every same-direction increment exceeds J (§2.4),
    /// for the four starts (a moving start counts as a previous increment of sign d0).
    #[test]
    fn h4_he_equals_kano_under_increment_condition(
        (s, j) in sj(),
        start in dyadic(-3200, 9600, 64.0),
        raw in prop::collection::vec((-1i8..=1, any::<u32>()), 0..300),
        init in variant(),
    ) {
        let op = op_fast_segments(j, sign_of(init.direction), start, &raw);
        let kano_mv = sim(&kano(s, j), &op, &init);
        let he_mv = sim(&He::from_sj(s, j).expect("valid"), &op, &init);
        prop_assert_eq!(kano_mv, he_mv);
    }

    /// H5: MV held while stuck; monotone OP ⇒ monotone MV.
    #[test]
    fn h5_piecewise_constant_and_monotone(
        op in op_dyadic(),
        mono in monotone_dyadic(),
        (s, j) in sj(),
        init in variant(),
    ) {
        let model = He::from_sj(s, j).expect("valid");
        let (mv, stuck) = stepped(&model, &op, &init);
        for k in 1..op.len() {
            if stuck[k] {
                prop_assert_eq!(mv[k], mv[k - 1], "k = {}", k);
            }
        }
        let mv = sim(&model, &mono, &init);
        for k in 1..mono.len() {
            prop_assert!(mv[k] >= mv[k - 1], "k = {}", k);
        }
    }

    /// H6: translation (OP + c, mv0 + c ⇒ MV + c) and sign symmetry (-OP, -d0, -mv0 ⇒ -MV).
    #[test]
    fn h6_translation_and_sign_symmetry(
        op in op_dyadic(),
        (s, j) in sj(),
        dir in direction(),
        pos in prop::option::of(dyadic(-640, 640, 64.0)),
        c in dyadic(-6400, 6400, 64.0),
    ) {
        let (fs, fd) = ((s + j) / 2.0, (s - j) / 2.0);
        let model = he(fs, fd);
        let mv0 = op[0] + pos.unwrap_or(-sign_of(dir) * fd);
        let init = InitialState { direction: dir, position: Some(mv0), ..InitialState::default() };
        let mv = sim(&model, &op, &init);

        let shifted: Vec<f64> = op.iter().map(|v| v + c).collect();
        let shifted_init = InitialState { position: Some(mv0 + c), ..init };
        let want: Vec<f64> = mv.iter().map(|v| v + c).collect();
        prop_assert_eq!(sim(&model, &shifted, &shifted_init), want);

        let neg_init = InitialState { direction: flip(dir), position: Some(-mv0), ..init };
        prop_assert_eq!(sim(&model, &negated(&op), &neg_init), negated(&mv));
    }

    /// H6 sign symmetry on arbitrary floats (negation is exact, so the mirror is too).
    #[test]
    fn h6_float_inputs(op in op_float(), fs in 0.0..10.0f64, frac in 0.0..=1.0f64, dir in direction()) {
        let model = he(fs, fs * frac);
        let init = InitialState { direction: dir, ..InitialState::default() };
        let neg_init = InitialState { direction: flip(dir), ..init };
        let want = negated(&sim(&model, &op, &init));
        prop_assert_eq!(sim(&model, &negated(&op), &neg_init), want);
    }

    /// He's K8 analogue: constant OP from k0 on ⇒ constant MV from k0 on (any start).
    #[test]
    fn h_constant_op_gives_constant_mv(
        op in op_dyadic(),
        (s, j) in sj(),
        init in any_init(),
        k0 in 0usize..300,
        tail in 1usize..50,
    ) {
        let model = He::from_sj(s, j).expect("valid");
        let init = make_init(op[0], init);
        let k0 = k0 % op.len();
        let mv = sim(&model, &held_from(&op, k0, tail), &init);
        for k in k0..mv.len() {
            prop_assert_eq!(mv[k], mv[k0], "k = {}", k);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// kano-asym
// ---------------------------------------------------------------------------------------------

proptest! {
    /// A1: J_up = J_dn = J ⇒ kano-asym(D, J, J) equals Kano(S = D + J, J), any input and start.
    #[test]
    fn a1_symmetric_asym_equals_kano(
        op in op_float(),
        d in 0.0..10.0f64,
        j in 0.0..5.0f64,
        init in any_init(),
    ) {
        let init = make_init(op[0], init);
        let asym = sim(&kano_asym(d, j, j), &op, &init);
        let sym = sim(&kano(d + j, j), &op, &init);
        for (k, (a, b)) in asym.iter().zip(&sym).enumerate() {
            prop_assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "k = {}: {} vs {}", k, a, b);
        }
    }

    /// A1 on dyadic data (including threshold ties) is exact.
    #[test]
    fn a1_exact_on_dyadic_data(op in op_dyadic(), d16 in 0u32..=128, j16 in 0u32..=64, init in any_init()) {
        let (d, j) = (f64::from(d16) / 16.0, f64::from(j16) / 16.0);
        let init = make_init(op[0], init);
        prop_assert_eq!(sim(&kano_asym(d, j, j), &op, &init), sim(&kano(d + j, j), &op, &init));
    }

    /// A3 (thresholds): from rest after moving up the valve reverses only beyond
    /// S_dn = D + J_dn and restarts beyond J_up; after moving down, S_up = D + J_up and J_dn.
    #[test]
    fn a3_asym_breakaway_thresholds(
        op in op_dyadic(),
        d16 in 0u32..=128,
        ju16 in 0u32..=64,
        jd16 in 0u32..=64,
        dir in direction(),
        stuck_off in prop::option::of(dyadic(-640, 640, 64.0)),
    ) {
        let (d, j_up, j_dn) = (f64::from(d16) / 16.0, f64::from(ju16) / 16.0, f64::from(jd16) / 16.0);
        let model = kano_asym(d, j_up, j_dn);
        let init = InitialState {
            direction: dir,
            stuck: true,
            stuck_at: stuck_off.map(|o| op[0] + o),
            position: None,
        };
        let th = Thresholds { rev_from_up: d + j_dn, rev_from_dn: d + j_up, j_up, j_dn, offset: d / 2.0 };
        check_breakaway(&model, &th, &op, &init)?;
        prop_assert_eq!(model.s_up(), d + j_up);
        prop_assert_eq!(model.s_dn(), d + j_dn);
    }

    /// Mirror symmetry of kano-asym: -OP with the opposite start and J_up, J_dn swapped ⇒ -MV.
    #[test]
    fn asym_mirror_swaps_jumps(
        op in op_float(),
        d in 0.0..10.0f64,
        j_up in 0.0..5.0f64,
        j_dn in 0.0..5.0f64,
        init in any_init(),
    ) {
        let init = make_init(op[0], init);
        let want = negated(&sim(&kano_asym(d, j_up, j_dn), &op, &init));
        prop_assert_eq!(sim(&kano_asym(d, j_dn, j_up), &negated(&op), &mirrored(&init)), want);
    }

    /// Asym monotonicity: monotone OP with a consistent start ⇒ monotone MV.
    #[test]
    fn asym_monotone(op in monotone_dyadic(), d16 in 0u32..=128, ju16 in 0u32..=64, jd16 in 0u32..=64, init in variant()) {
        let model = kano_asym(f64::from(d16) / 16.0, f64::from(ju16) / 16.0, f64::from(jd16) / 16.0);
        let mv = sim(&model, &op, &init);
        for k in 1..op.len() {
            prop_assert!(mv[k] >= mv[k - 1], "k = {}", k);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Initialization strategies In.1 / In.2 / In.3
// ---------------------------------------------------------------------------------------------

proptest! {
    /// In.3: after valid_from the four sequences coincide and MV is their common value; at
    /// valid_from - 1 they still differ; on fallback valid_from = ceil(N/10).
    #[test]
    fn in3_sequences_coincide_after_valid_from(op in op_dyadic(), (s, j) in sj()) {
        check_in3(&kano(s, j), &op)?;
        check_in3(&He::from_sj(s, j).expect("valid"), &op)?;
    }

    /// In.3 on arbitrary float records.
    #[test]
    fn in3_on_float_records(op in op_float(), (s, j) in sj()) {
        check_in3(&kano(s, j), &op)?;
    }

    /// In.3 falls back to In.2 when the sequences can never coincide: S - J larger than the
    /// OP span keeps the "up" and "down" starts offset by S - J forever.
    #[test]
    fn in3_falls_back_when_s_exceeds_the_span(op in op_dyadic(), j in 0.0..5.0f64, margin in 0.01..5.0f64) {
        let lo = op.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = op.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let s = (hi - lo) + j + margin;
        let run = run_valve(&kano(s, j), &op, &Initialization::In3).expect("finite OP");
        prop_assert!(run.fell_back);
        prop_assert_eq!(run.valid_from, ceil_tenth(op.len()));
        let in2 = run_valve(
            &kano(s, j),
            &op,
            &Initialization::In2 { stationary_fraction: Initialization::IN2_DEFAULT_FRACTION },
        ).expect("finite OP");
        prop_assert_eq!(run.mv, in2.mv);
    }

    /// In.2: valid_from = ceil(N/10) with the default fraction (ceil(f N) in general) and MV is
    /// the average of the four sequences.
    #[test]
    fn in2_valid_from_and_average(op in op_dyadic(), (s, j) in sj(), frac in 0.0..1.0f64) {
        let model = kano(s, j);
        let n = op.len();
        let run = run_valve(&model, &op, &Initialization::parse("In.2").expect("label")).expect("finite");
        prop_assert_eq!(run.valid_from, ceil_tenth(n));
        prop_assert!(!run.fell_back);
        let seqs = four_sequences(&model, &op);
        for k in 0..n {
            let mean = seqs.iter().map(|s| s[k]).sum::<f64>() / 4.0;
            prop_assert!((run.mv[k] - mean).abs() <= 1e-12 * mean.abs().max(1.0), "k = {}", k);
        }
        let run = run_valve(&model, &op, &Initialization::In2 { stationary_fraction: frac }).expect("finite");
        prop_assert_eq!(run.valid_from, (frac * n as f64).ceil() as usize);
    }

    /// In.1 is a plain simulation from the given start.
    #[test]
    fn in1_is_plain_simulation(op in op_dyadic(), (s, j) in sj(), init in any_init()) {
        let model = kano(s, j);
        let init = make_init(op[0], init);
        let run = run_valve(&model, &op, &Initialization::In1(init)).expect("finite");
        prop_assert_eq!(run, ValveRun { mv: sim(&model, &op, &init), valid_from: 0, fell_back: false });
    }
}

// ---------------------------------------------------------------------------------------------
// Plumbing: typetag JSON, registry, errors
// ---------------------------------------------------------------------------------------------

proptest! {
    /// Every registered model survives a typetag JSON round trip with identical output.
    /// Parameters are multiples of 1/1024, which serde_json (without `float_roundtrip`)
    /// parses exactly.
    #[test]
    fn typetag_json_round_trip_every_registered_model(
        raw in prop::collection::vec(0u32..=10 * 1024, 3),
        op in op_float(),
        init in variant(),
    ) {
        for entry in registry() {
            let mut values: Vec<f64> = raw[..entry.params.len()].iter().map(|&v| f64::from(v) / 1024.0).collect();
            // Satisfy "A <= B" constraints generically by sorting descending (J <= S,
            // fd <= fs: the bound comes first in every built-in).
            if !entry.admissible(&values, 100.0) {
                values.sort_by(|a, b| b.total_cmp(a));
            }
            let model = (entry.build)(&values).expect("admissible values build");
            prop_assert_eq!(model.name(), entry.name);
            let json = serde_json::to_string(&model).expect("serialize");
            let value: serde_json::Value = serde_json::from_str(&json).expect("valid JSON");
            prop_assert_eq!(value["kind"].as_str(), Some(entry.name));
            let back: Box<dyn StictionModel> = serde_json::from_str(&json).expect("deserialize");
            prop_assert_eq!(back.name(), entry.name);
            prop_assert_eq!(back.param_values(), model.param_values());
            prop_assert_eq!(sim(back.as_ref(), &op, &init), sim(model.as_ref(), &op, &init));
            let cloned = model.clone();
            prop_assert_eq!(sim(cloned.as_ref(), &op, &init), sim(model.as_ref(), &op, &init));
        }
    }

    /// A non-finite OP sample is rejected with the index of the first bad sample, by every
    /// model and every initialization strategy.
    #[test]
    fn non_finite_op_names_the_first_index(
        op in op_float(),
        bad in prop::collection::vec((0usize..400, 0usize..3), 1..4),
    ) {
        let mut op = op;
        let specials = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
        for &(i, v) in &bad {
            let i = i % op.len();
            op[i] = specials[v];
        }
        let index = op.iter().position(|v| !v.is_finite()).expect("one inserted");
        let check = |err: StictionError| -> Result<(), TestCaseError> {
            match err {
                StictionError::NonFiniteInput { index: i, value } => {
                    prop_assert_eq!(i, index);
                    prop_assert_eq!(value.to_bits(), op[index].to_bits());
                    Ok(())
                }
                other => Err(TestCaseError::fail(format!("wrong error {other:?}"))),
            }
        };
        for entry in registry() {
            let model = (entry.build)(&vec![1.0; entry.params.len()]).expect("valid");
            check(model.simulate(&op, &InitialState::default()).expect_err("rejected"))?;
            for init in [
                Initialization::In1(InitialState::up()),
                Initialization::parse("In.2").expect("label"),
                Initialization::In3,
            ] {
                check(run_valve(model.as_ref(), &op, &init).expect_err("rejected"))?;
            }
        }
    }
}

#[test]
fn kano_json_shape_and_j_greater_than_s_rejected() {
    let model: Box<dyn StictionModel> = Box::new(kano(4.0, 1.0));
    assert_eq!(
        serde_json::to_value(&model).expect("serialize"),
        serde_json::json!({"kind": "kano", "S": 4.0, "J": 1.0})
    );
    let err = serde_json::from_str::<Box<dyn StictionModel>>(r#"{"kind":"kano","S":1,"J":2}"#)
        .expect_err("J > S");
    let msg = err.to_string();
    assert!(
        msg.starts_with("kano: parameter J = 2 is out of range: expected 0 <= J <= S (= 1)"),
        "{msg}"
    );
    // The same error from the builder, as a value.
    assert_eq!(
        Kano::params().s(1.0).j(2.0).check(),
        Err(StictionError::InvalidParameter {
            model: "kano",
            name: "J".into(),
            value: 2.0,
            expected: "0 <= J <= S (= 1)".into(),
        })
    );
}

#[test]
fn invalid_parameters_are_rejected_with_exact_errors() {
    let finite = "a finite number >= 0 (OP units)".to_string();
    assert_eq!(
        Kano::params().s(-1.0).j(0.0).check(),
        Err(StictionError::InvalidParameter {
            model: "kano",
            name: "S".into(),
            value: -1.0,
            expected: finite.clone(),
        })
    );
    assert_eq!(
        Kano::params().s(f64::INFINITY).check(),
        Err(StictionError::InvalidParameter {
            model: "kano",
            name: "S".into(),
            value: f64::INFINITY,
            expected: finite.clone(),
        })
    );
    assert_eq!(
        He::params().fs(2.0).fd(3.0).check(),
        Err(StictionError::InvalidParameter {
            model: "he",
            name: "fd".into(),
            value: 3.0,
            expected: "0 <= fd <= fs (= 2)".into(),
        })
    );
    assert_eq!(
        KanoAsym::params().d(1.0).j_up(-0.5).check(),
        Err(StictionError::InvalidParameter {
            model: "kano-asym",
            name: "J_up".into(),
            value: -0.5,
            expected: finite.clone(),
        })
    );
    let nan = Kano::params()
        .s(1.0)
        .j(f64::NAN)
        .check()
        .expect_err("NaN J");
    assert_eq!(
        nan.to_string(),
        "kano: parameter J = NaN is out of range: expected a finite number >= 0 (OP units)"
    );
    let err = serde_json::from_str::<Box<dyn StictionModel>>(r#"{"kind":"he","fs":2,"fd":3}"#)
        .expect_err("fd > fs");
    assert!(
        err.to_string()
            .starts_with("he: parameter fd = 3 is out of range: expected 0 <= fd <= fs (= 2)"),
        "{err}"
    );
    let err = serde_json::from_str::<Box<dyn StictionModel>>(
        r#"{"kind":"kano-asym","D":-1,"J_up":0,"J_dn":0}"#,
    )
    .expect_err("D < 0");
    assert!(
        err.to_string()
            .starts_with("kano-asym: parameter D = -1 is out of range"),
        "{err}"
    );
}

#[test]
fn json_rejects_unknown_fields_and_unknown_kinds() {
    let err =
        serde_json::from_str::<Box<dyn StictionModel>>(r#"{"kind":"kano","S":4,"J":1,"X":0}"#)
            .expect_err("unknown field");
    assert!(err.to_string().contains("unknown field `X`"), "{err}");
    let err = serde_json::from_str::<Box<dyn StictionModel>>(r#"{"kind":"nope","S":4}"#)
        .expect_err("unknown kind");
    assert!(err.to_string().contains("nope"), "{err}");
    // Missing parameters take no silent default in JSON.
    let err = serde_json::from_str::<Box<dyn StictionModel>>(r#"{"kind":"kano","S":4}"#)
        .expect_err("missing J");
    assert!(err.to_string().contains("missing field `J`"), "{err}");
}

#[test]
fn registry_lists_the_built_in_models_with_their_parameters() {
    let listed: Vec<(&str, Vec<&str>, Vec<String>)> = registry()
        .iter()
        .map(|e| {
            (
                e.name,
                e.param_names(),
                e.constraints.iter().map(|c| c.describe()).collect(),
            )
        })
        .collect();
    assert_eq!(
        listed,
        vec![
            ("he", vec!["fs", "fd"], vec!["fd <= fs".to_string()]),
            ("kano", vec!["S", "J"], vec!["J <= S".to_string()]),
            (
                "kano-asym",
                vec!["D", "J_up", "J_dn"],
                vec![
                    "D + J_up <= span".to_string(),
                    "D + J_dn <= span".to_string()
                ]
            ),
            ("kano-char", vec!["S", "J", "a"], vec!["J <= S".to_string()]),
        ]
    );
    for entry in registry() {
        assert!(!entry.description.is_empty());
        let defaults: Vec<f64> = entry.params.iter().map(|p| p.default).collect();
        let model = (entry.build)(&defaults).expect("defaults are valid");
        assert_eq!(model.name(), entry.name);
        assert_eq!(model.param_values(), defaults);
        assert!(entry.admissible(&defaults, 100.0));
    }
}

#[test]
fn find_model_and_build_named() {
    assert_eq!(find_model("kano").expect("registered").name, "kano");
    assert_eq!(
        find_model("KANO-ASYM").expect("case-insensitive").name,
        "kano-asym"
    );
    assert_eq!(
        find_model("choudhury").map(|e| e.name),
        Err(StictionError::UnknownModel {
            name: "choudhury".into(),
            known: "he, kano, kano-asym, kano-char".into(),
        })
    );
    let entry = find_model("kano").expect("registered");
    let err = entry
        .build_named(&[("S".into(), 4.0), ("X".into(), 1.0)])
        .expect_err("unknown");
    assert_eq!(
        err,
        StictionError::UnknownParameter {
            model: "kano",
            name: "X".into(),
            known: "S, J".into(),
        }
    );
    assert_eq!(
        err.to_string(),
        "kano: unknown parameter \"X\"; the model's parameters are S, J"
    );
    // Case-insensitive names, missing ones default to 0.
    let model = entry.build_named(&[("s".into(), 4.0)]).expect("valid");
    assert_eq!(model.param_values(), vec![4.0, 0.0]);
    let err = entry
        .build_named(&[("J".into(), 1.0)])
        .expect_err("J > S = 0");
    assert_eq!(
        err,
        StictionError::InvalidParameter {
            model: "kano",
            name: "J".into(),
            value: 1.0,
            expected: "0 <= J <= S (= 0)".into(),
        }
    );
    let asym = find_model("kano-asym").expect("registered");
    let model = asym
        .build_named(&[("d".into(), 2.0), ("j_dn".into(), 0.5)])
        .expect("valid");
    assert_eq!(model.param_values(), vec![2.0, 0.0, 0.5]);
    assert_eq!(model.derived_values(), vec![("S_up", 2.0), ("S_dn", 2.5)]);
    assert_eq!(
        (asym.build)(&[1.0, 2.0]).map(|m| m.name()),
        Err(StictionError::WrongParameterCount {
            model: "kano-asym",
            expected: 3,
            got: 2,
        })
    );
    assert!(!asym.admissible(&[60.0, 50.0, 0.0], 100.0));
    assert!(asym.admissible(&[60.0, 40.0, 0.0], 100.0));
    assert!(!find_model("kano")
        .expect("registered")
        .admissible(&[1.0, 2.0], 100.0));
}

#[test]
fn equivalent_parameters() {
    assert_eq!(kano(4.0, 1.0).equivalent().s, 4.0);
    let he = he(2.5, 1.5).equivalent();
    assert_eq!((he.s, he.j), (4.0, 1.0));
    let asym = kano_asym(3.0, 1.0, 2.0).equivalent();
    assert_eq!((asym.s, asym.j), (4.5, 1.5));
}

#[test]
fn non_finite_op_error_text_and_edge_lengths() {
    let model = kano(4.0, 1.0);
    let err = model
        .simulate(&[1.0, 2.0, 3.0, f64::NAN], &InitialState::default())
        .expect_err("NaN");
    assert_eq!(err.to_string(), "OP sample 3 is not finite (NaN)");
    assert_eq!(
        model.simulate(&[f64::INFINITY, 1.0], &InitialState::default()),
        Err(StictionError::NonFiniteInput {
            index: 0,
            value: f64::INFINITY
        })
    );
    let err = model
        .start(f64::NEG_INFINITY, &InitialState::default())
        .map(|s| s.position());
    assert_eq!(
        err,
        Err(StictionError::NonFiniteInput {
            index: 0,
            value: f64::NEG_INFINITY
        })
    );
    // Empty and one-sample records.
    assert_eq!(model.simulate(&[], &InitialState::default()), Ok(vec![]));
    assert_eq!(
        model.simulate(&[50.0], &InitialState::default()),
        Ok(vec![51.5])
    );
    let run = run_valve(&model, &[], &Initialization::In3).expect("empty is fine");
    assert_eq!(
        run,
        ValveRun {
            mv: vec![],
            valid_from: 0,
            fell_back: false
        }
    );
    // Length mismatch of the output buffer.
    let mut out = [0.0; 2];
    assert_eq!(
        model.simulate_into(&[1.0, 2.0, 3.0], &InitialState::default(), &mut out),
        Err(StictionError::LengthMismatch { op: 3, out: 2 })
    );
}

#[test]
fn invalid_initialization_is_rejected() {
    let model = kano(4.0, 1.0);
    let bad = InitialState {
        position: Some(f64::NAN),
        ..InitialState::default()
    };
    assert_eq!(
        model.simulate(&[1.0, 2.0], &bad),
        Err(StictionError::InvalidInit(
            "position = NaN must be a finite number".into()
        ))
    );
    let bad = InitialState {
        stuck_at: Some(f64::INFINITY),
        ..InitialState::default()
    };
    // He does not use stuck_at but still rejects a non-finite one.
    assert_eq!(
        He::from_sj(4.0, 1.0).expect("valid").simulate(&[1.0], &bad),
        Err(StictionError::InvalidInit(
            "stuck_at = inf must be a finite number".into()
        ))
    );
    assert_eq!(
        model.simulate(&[1.0], &bad),
        Err(StictionError::InvalidInit(
            "stuck_at = inf must be a finite number".into()
        ))
    );
    for frac in [1.0, -0.1, f64::NAN] {
        assert_eq!(
            run_valve(
                &model,
                &[1.0, 2.0],
                &Initialization::In2 {
                    stationary_fraction: frac
                }
            ),
            Err(StictionError::InvalidInit(format!(
                "In.2 stationary fraction {frac} must be in [0, 1)"
            )))
        );
    }
}

#[test]
fn initialization_labels_parse_and_serde() {
    for (text, label) in [
        ("In.1", "In.1"),
        ("in2", "In.2"),
        ("IN.3", "In.3"),
        ("in.3", "In.3"),
    ] {
        assert_eq!(
            Initialization::parse(text).map(|i| i.label()),
            Some(label),
            "{text}"
        );
    }
    assert_eq!(Initialization::parse("In.4"), None);
    assert_eq!(Initialization::default(), Initialization::In3);
    assert_eq!(
        Initialization::parse("in1"),
        Some(Initialization::In1(InitialState::default()))
    );
    let json = serde_json::to_value(Initialization::In3).expect("serialize");
    assert_eq!(json, serde_json::json!({"strategy": "In.3"}));
    let back: Initialization =
        serde_json::from_str(r#"{"strategy":"In.2","stationary_fraction":0.25}"#).expect("parse");
    assert_eq!(
        back,
        Initialization::In2 {
            stationary_fraction: 0.25
        }
    );
    let init: InitialState = serde_json::from_str(r#"{"direction":"up"}"#).expect("parse");
    assert_eq!(init, InitialState::up());
}
