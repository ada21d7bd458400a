//! Golden vectors of the specification (ALGORITHMS.md §8.1) and an independent, literal
//! re-implementation of the specification's pseudo-code (`KANO_INIT`/`KANO_STEP` §1.3-1.4,
//! `HE_STEP` §2.2, Kano-asym §3.2) compared with the crate on many generated inputs.
//!
//! The golden values are multiples of 0.5 and every operation that produces them is exact in
//! binary floating point, so they are compared with `assert_eq!`.

mod common;
use common::{he, kano, kano_asym};

use rand::{Rng as _, RngCore, SeedableRng};
use rand_xoshiro::SplitMix64;
use stiction_models::{Direction, He, InitialState, StictionError, StictionModel};

const GOLDEN_OP: [f64; 20] = [
    50.0, 50.5, 51.0, 52.0, 54.0, 56.0, 56.0, 56.5, 57.5, 58.0, 57.0, 55.0, 53.0, 52.0, 51.5, 52.0,
    53.0, 54.0, 55.0, 56.0,
];

const GOLDEN_KANO_UP: [f64; 20] = [
    48.5, 48.5, 48.5, 50.5, 52.5, 54.5, 54.5, 54.5, 56.0, 56.5, 56.5, 56.5, 54.5, 53.5, 53.0, 53.0,
    53.0, 53.0, 53.0, 54.5,
];

const GOLDEN_HE_UP: [f64; 20] = [
    48.5, 48.5, 48.5, 50.5, 52.5, 54.5, 54.5, 54.5, 56.0, 56.0, 56.0, 56.0, 54.5, 54.5, 53.0, 53.0,
    53.0, 53.0, 53.0, 54.5,
];

const GOLDEN_KANO_DOWN: [f64; 20] = [
    51.5, 51.5, 51.5, 51.5, 51.5, 54.5, 54.5, 54.5, 56.0, 56.5, 56.5, 56.5, 54.5, 53.5, 53.0, 53.0,
    53.0, 53.0, 53.0, 54.5,
];

// ---------------------------------------------------------------------------------------------
// §8.1 golden vectors
// ---------------------------------------------------------------------------------------------

#[test]
fn golden_kano_s4_j1_up_start() -> Result<(), StictionError> {
    let mv = kano(4.0, 1.0).simulate(&GOLDEN_OP, &InitialState::up())?;
    assert_eq!(mv, GOLDEN_KANO_UP.to_vec());
    Ok(())
}

#[test]
fn golden_kano_s4_j1_up_start_explicit_values() -> Result<(), StictionError> {
    // The spec states the start as d0 = +1, stp0 = 1, u_s0 = 50, mv0 = 48.5: give them all.
    let init = InitialState {
        direction: Direction::Up,
        stuck: true,
        stuck_at: Some(50.0),
        position: Some(48.5),
    };
    let mv = kano(4.0, 1.0).simulate(&GOLDEN_OP, &init)?;
    assert_eq!(mv, GOLDEN_KANO_UP.to_vec());
    Ok(())
}

#[test]
fn golden_kano_s4_j1_down_start_is_the_default() -> Result<(), StictionError> {
    // d0 = -1, mv0 = 51.5 = OP(0) + (S-J)/2: the crate's default initial state.
    assert_eq!(InitialState::default(), InitialState::down());
    let model = kano(4.0, 1.0);
    let mv = model.simulate(&GOLDEN_OP, &InitialState::default())?;
    assert_eq!(mv, GOLDEN_KANO_DOWN.to_vec());
    let explicit = InitialState {
        direction: Direction::Down,
        stuck: true,
        stuck_at: Some(50.0),
        position: Some(51.5),
    };
    assert_eq!(
        model.simulate(&GOLDEN_OP, &explicit)?,
        GOLDEN_KANO_DOWN.to_vec()
    );
    Ok(())
}

#[test]
fn golden_he_fs25_fd15_up_start() -> Result<(), StictionError> {
    let model = he(2.5, 1.5);
    let mv = model.simulate(&GOLDEN_OP, &InitialState::up())?;
    assert_eq!(mv, GOLDEN_HE_UP.to_vec());
    // The same model through the (S, J) constructor.
    let from_sj = He::from_sj(4.0, 1.0)?;
    assert_eq!(from_sj, model);
    assert_eq!(
        from_sj.simulate(&GOLDEN_OP, &InitialState::up())?,
        GOLDEN_HE_UP.to_vec()
    );
    Ok(())
}

#[test]
fn golden_he_differs_from_kano_exactly_at_samples_9_to_13() {
    let differing: Vec<usize> = (0..GOLDEN_OP.len())
        .filter(|&k| GOLDEN_KANO_UP[k] != GOLDEN_HE_UP[k])
        .collect();
    assert_eq!(differing, vec![9, 10, 11, 13]);
    // Sample 12 coincides (both reverse down at OP = 53); the spec's "9-13" is the range.
}

#[test]
fn golden_kano_asym_with_equal_jumps_matches_kano_golden() -> Result<(), StictionError> {
    // A1: D = S - J = 3, J_up = J_dn = 1.
    let model = kano_asym(3.0, 1.0, 1.0);
    assert_eq!(
        model.simulate(&GOLDEN_OP, &InitialState::up())?,
        GOLDEN_KANO_UP.to_vec()
    );
    assert_eq!(
        model.simulate(&GOLDEN_OP, &InitialState::down())?,
        GOLDEN_KANO_DOWN.to_vec()
    );
    Ok(())
}

#[test]
fn golden_vectors_through_boxed_valve_state() -> Result<(), StictionError> {
    // The trait's stepping interface (`start` + `step`) gives the same numbers as `simulate`.
    let cases: [(Box<dyn StictionModel>, InitialState, &[f64; 20]); 3] = [
        (
            Box::new(kano(4.0, 1.0)),
            InitialState::up(),
            &GOLDEN_KANO_UP,
        ),
        (
            Box::new(kano(4.0, 1.0)),
            InitialState::down(),
            &GOLDEN_KANO_DOWN,
        ),
        (Box::new(he(2.5, 1.5)), InitialState::up(), &GOLDEN_HE_UP),
    ];
    for (model, init, expected) in cases {
        let mut state = model.start(GOLDEN_OP[0], &init)?;
        let mut mv = vec![state.position()];
        for &u in &GOLDEN_OP[1..] {
            mv.push(state.step(u));
        }
        assert_eq!(mv, expected.to_vec(), "{model:?}");
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Literal re-implementation of the specification's pseudo-code
// ---------------------------------------------------------------------------------------------

/// The variables Kano's pseudo-code carries from one sample to the next (§1.3; Kano-asym's
/// of §3.2 are the same): the previous input and its change, where the valve stuck, whether it
/// is stuck, the direction, the previous output.
struct KanoVars {
    u_prev: f64,
    du_prev: f64,
    u_s: f64,
    stp: u8,
    d: f64,
    mv_prev: f64,
}

impl KanoVars {
    /// (a) detect that the valve has just stopped: input reversed or stayed flat. Returns the
    /// input's change.
    fn detect_stop(&mut self, u: f64) -> f64 {
        let du = u - self.u_prev;
        if self.stp == 0 && du * self.du_prev <= 0.0 {
            self.u_s = self.u_prev;
            self.stp = 1;
        }
        du
    }

    /// The end of a step: keep the input, its change and the output for the next sample.
    fn keep(&mut self, u: f64, du: f64, mv: f64) -> f64 {
        self.du_prev = du;
        self.u_prev = u;
        self.mv_prev = mv;
        mv
    }
}

/// `KANO_STEP` of ALGORITHMS.md §1.3, written out literally (no clipping).
struct SpecKano {
    s: f64,
    j: f64,
    v: KanoVars,
}

impl SpecKano {
    fn step(&mut self, op_k: f64) -> f64 {
        let (s, j, v) = (self.s, self.j, &mut self.v);
        let u = op_k;
        let du = v.detect_stop(u);
        // (b) decide output
        let mv;
        if v.stp == 0 {
            mv = u - v.d * (s - j) / 2.0;
        } else if -v.d * (u - v.u_s) > s {
            v.d = -v.d;
            mv = u - v.d * (s - j) / 2.0;
            v.stp = 0;
        } else if v.d * (u - v.u_s) > j {
            mv = u - v.d * (s - j) / 2.0;
            v.stp = 0;
        } else {
            mv = v.mv_prev;
        }
        v.keep(u, du, mv)
    }
}

/// Kano-asym of §3.2: Kano's algorithm with moving offset `D/2`, reversal thresholds
/// `S_dn = D + J_dn` (from `d = +1`) and `S_up = D + J_up` (from `d = -1`), and the
/// same-direction restart threshold of the current direction.
struct SpecKanoAsym {
    dd: f64,
    j_up: f64,
    j_dn: f64,
    v: KanoVars,
}

impl SpecKanoAsym {
    // Transcribed branch by branch from the specification's pseudo-code, repeats included.
    #[allow(clippy::if_same_then_else)]
    fn step(&mut self, op_k: f64) -> f64 {
        let (dd, j_up, j_dn, v) = (self.dd, self.j_up, self.j_dn, &mut self.v);
        let u = op_k;
        let du = v.detect_stop(u);
        let s_up = dd + j_up;
        let s_dn = dd + j_dn;
        let mv;
        if v.stp == 0 {
            mv = u - v.d * dd / 2.0;
        } else if v.d == 1.0 && -(u - v.u_s) > s_dn {
            v.d = -1.0;
            mv = u - v.d * dd / 2.0;
            v.stp = 0;
        } else if v.d == -1.0 && (u - v.u_s) > s_up {
            v.d = 1.0;
            mv = u - v.d * dd / 2.0;
            v.stp = 0;
        } else if v.d == 1.0 && (u - v.u_s) > j_up {
            mv = u - v.d * dd / 2.0;
            v.stp = 0;
        } else if v.d == -1.0 && -(u - v.u_s) > j_dn {
            mv = u - v.d * dd / 2.0;
            v.stp = 0;
        } else {
            mv = v.mv_prev;
        }
        v.keep(u, du, mv)
    }
}

fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// `HE_STEP` of ALGORITHMS.md §2.2, written out literally (no clipping).
struct SpecHe {
    fs: f64,
    fd: f64,
    u_r: f64,
    u_prev: f64,
    mv_prev: f64,
}

impl SpecHe {
    fn step(&mut self, op_k: f64) -> f64 {
        let u = op_k;
        let cum = self.u_r + (u - self.u_prev);
        let mv;
        if cum.abs() > self.fs {
            mv = u - sign(cum) * self.fd;
            self.u_r = sign(cum) * self.fd;
        } else {
            mv = self.mv_prev;
            self.u_r = cum;
        }
        self.u_prev = u;
        self.mv_prev = mv;
        mv
    }
}

/// `KANO_INIT(OP_0; d0, stp0, u_s0, mv0)` of §1.4 with the crate's documented mapping of an
/// [`InitialState`] onto `d0`, `stp0`, `u_s0`, `mv0` (plus our moving-start extension
/// `du_prev = d0`); `offset` is the valve's lag behind a moving input.
fn kano_start(offset: f64, op_0: f64, init: &InitialState) -> KanoVars {
    let d0 = match init.direction {
        Direction::Up => 1.0,
        Direction::Down => -1.0,
    };
    let u_s0 = init.stuck_at.unwrap_or(op_0);
    let consistent = if init.stuck {
        u_s0 - d0 * offset
    } else {
        op_0 - d0 * offset
    };
    KanoVars {
        u_prev: op_0,
        du_prev: if init.stuck { 0.0 } else { d0 },
        u_s: u_s0,
        stp: if init.stuck { 1 } else { 0 },
        d: d0,
        mv_prev: init.position.unwrap_or(consistent),
    }
}

fn spec_kano(s: f64, j: f64, op: &[f64], init: &InitialState) -> Vec<f64> {
    let Some(&op_0) = op.first() else {
        return Vec::new();
    };
    let v = kano_start((s - j) / 2.0, op_0, init);
    let mut mv = vec![v.mv_prev];
    let mut valve = SpecKano { s, j, v };
    mv.extend(op[1..].iter().map(|&u| valve.step(u)));
    mv
}

fn spec_kano_asym(dd: f64, j_up: f64, j_dn: f64, op: &[f64], init: &InitialState) -> Vec<f64> {
    let Some(&op_0) = op.first() else {
        return Vec::new();
    };
    let v = kano_start(dd / 2.0, op_0, init);
    let mut mv = vec![v.mv_prev];
    let mut valve = SpecKanoAsym { dd, j_up, j_dn, v };
    mv.extend(op[1..].iter().map(|&u| valve.step(u)));
    mv
}

fn spec_he(fs: f64, fd: f64, op: &[f64], init: &InitialState) -> Vec<f64> {
    let Some(&op_0) = op.first() else {
        return Vec::new();
    };
    let d0 = match init.direction {
        Direction::Up => 1.0,
        Direction::Down => -1.0,
    };
    let u_r0 = d0 * fd;
    let mv0 = init.position.unwrap_or(op_0 - u_r0);
    let mut valve = SpecHe {
        fs,
        fd,
        u_r: u_r0,
        u_prev: op_0,
        mv_prev: mv0,
    };
    let mut mv = vec![mv0];
    mv.extend(op[1..].iter().map(|&u| valve.step(u)));
    mv
}

#[test]
fn literal_pseudo_code_reproduces_the_golden_vectors() {
    // Guards the reference implementation itself.
    assert_eq!(
        spec_kano(4.0, 1.0, &GOLDEN_OP, &InitialState::up()),
        GOLDEN_KANO_UP.to_vec()
    );
    assert_eq!(
        spec_kano(4.0, 1.0, &GOLDEN_OP, &InitialState::down()),
        GOLDEN_KANO_DOWN.to_vec()
    );
    assert_eq!(
        spec_he(2.5, 1.5, &GOLDEN_OP, &InitialState::up()),
        GOLDEN_HE_UP.to_vec()
    );
    assert_eq!(
        spec_kano_asym(3.0, 1.0, 1.0, &GOLDEN_OP, &InitialState::up()),
        GOLDEN_KANO_UP.to_vec()
    );
}

// ---------------------------------------------------------------------------------------------
// Generated inputs
// ---------------------------------------------------------------------------------------------

/// SplitMix64 with the draws the generators need.
struct Rng(SplitMix64);

impl Rng {
    fn seeded(seed: u64) -> Rng {
        Rng(SplitMix64::seed_from_u64(seed))
    }
    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64 {
        self.0.random()
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.0.next_u64() % n as u64) as usize
    }
    fn chance(&mut self, p: f64) -> bool {
        self.uniform() < p
    }
    /// Approximately standard normal (Irwin-Hall with 12 terms).
    fn normal(&mut self) -> f64 {
        (0..12).map(|_| self.uniform()).sum::<f64>() - 6.0
    }
}

/// A generated OP record of one of several shapes, optionally quantized.
fn generate_op(rng: &mut Rng) -> (String, Vec<f64>) {
    let n = match rng.below(10) {
        0 => 1 + rng.below(3),
        _ => 2 + rng.below(499),
    };
    let base = rng.range(-50.0, 150.0);
    let (kind, mut op): (&str, Vec<f64>) = match rng.below(6) {
        0 => {
            let sigma = [0.05, 0.3, 1.0, 3.0][rng.below(4)];
            let mut x = base;
            (
                "random walk",
                (0..n)
                    .map(|_| {
                        x += sigma * rng.normal();
                        x
                    })
                    .collect(),
            )
        }
        1 => {
            let amp = rng.range(0.5, 20.0);
            let period = rng.range(5.0, 200.0);
            let noise = [0.0, 0.05, 0.3, 1.0][rng.below(4)];
            let phase = rng.range(0.0, 6.3);
            let op = (0..n)
                .map(|k| {
                    base + amp * (std::f64::consts::TAU * k as f64 / period + phase).sin()
                        + noise * rng.normal()
                })
                .collect();
            ("sinusoid + noise", op)
        }
        2 => {
            let mut level = base;
            let op = (0..n)
                .map(|_| {
                    if rng.chance(0.05) {
                        level += rng.range(-10.0, 10.0);
                    }
                    level
                })
                .collect();
            ("steps", op)
        }
        3 => {
            let sigma = [0.1, 0.5, 2.0][rng.below(3)];
            let hold = rng.range(0.2, 0.8);
            let mut x = base;
            let op = (0..n)
                .map(|_| {
                    if !rng.chance(hold) {
                        x += sigma * rng.normal();
                    }
                    x
                })
                .collect();
            ("random walk with flat runs", op)
        }
        4 => {
            // Slow triangle: increments smaller or larger than J.
            let slope = [0.1, 0.3, 1.0, 2.5][rng.below(4)];
            let half = 3 + rng.below(60);
            let op = (0..n)
                .map(|k| {
                    let p = k % (2 * half);
                    let t = if p < half { p } else { 2 * half - p };
                    base + slope * t as f64
                })
                .collect();
            ("triangle", op)
        }
        _ => {
            // Mixture: noise around ramps and holds.
            let mut x = base;
            let mut drift = 0.0;
            let op = (0..n)
                .map(|_| {
                    if rng.chance(0.03) {
                        drift = rng.range(-1.0, 1.0);
                    }
                    if !rng.chance(0.3) {
                        x += drift + 0.2 * rng.normal();
                    }
                    x
                })
                .collect();
            ("mixture", op)
        }
    };
    let mut kind = kind.to_string();
    if rng.chance(0.4) {
        // Quantized OP: exact multiples of q hit the strict thresholds exactly.
        let q = [0.1, 0.25, 0.5, 1.0][rng.below(4)];
        for v in &mut op {
            *v = (*v / q).round() * q;
        }
        kind.push_str(&format!(", quantized to {q}"));
    }
    (kind, op)
}

/// (S, J) with 0 <= J <= S, including the corner cases S = J, J = 0, S = J = 0 and values on
/// the quantization grids (so that threshold ties occur).
fn generate_sj(rng: &mut Rng) -> (f64, f64) {
    let s = match rng.below(4) {
        0 => 0.0,
        1 => (rng.range(0.0, 12.0) * 4.0).round() / 4.0,
        _ => rng.range(0.0, 12.0),
    };
    let j = match rng.below(5) {
        0 => 0.0,
        1 => s,
        2 => (rng.range(0.0, s) * 4.0).floor() / 4.0,
        _ => rng.range(0.0, s),
    };
    (s, j)
}

fn generate_init(rng: &mut Rng, op_0: f64) -> InitialState {
    let direction = if rng.chance(0.5) {
        Direction::Up
    } else {
        Direction::Down
    };
    let stuck = rng.chance(0.6);
    let stuck_at = rng.chance(0.3).then(|| op_0 + rng.range(-5.0, 5.0));
    let position = rng.chance(0.3).then(|| op_0 + rng.range(-5.0, 5.0));
    InitialState {
        direction,
        stuck,
        stuck_at,
        position,
    }
}

fn all_inits(rng: &mut Rng, op_0: f64) -> Vec<InitialState> {
    let mut inits = InitialState::four_variants().to_vec();
    inits.push(generate_init(rng, op_0));
    inits.push(generate_init(rng, op_0));
    inits
}

fn assert_close(what: &str, got: &[f64], want: &[f64]) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    for (k, (&g, &w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= 1e-12 * w.abs().max(1.0),
            "{what}: sample {k}: crate {g} vs spec {w}"
        );
    }
}

/// Steps a model through the boxed `ValveState` interface.
fn stepped(model: &dyn StictionModel, op: &[f64], init: &InitialState) -> Vec<f64> {
    let Some(&op_0) = op.first() else {
        return Vec::new();
    };
    let mut state = model.start(op_0, init).expect("finite start");
    let mut mv = vec![state.position()];
    mv.extend(op[1..].iter().map(|&u| state.step(u)));
    mv
}

const CASES: u64 = 3000;

/// The spec's MV for an OP record and a start.
type Spec = Box<dyn Fn(&[f64], &InitialState) -> Vec<f64>>;

/// Every generated case (`CASES` OPs from `seed`, each from every start): `draw` gives the
/// parameters (as text), the model and the spec's rule; the model's whole-record and stepped
/// runs must equal the spec.
fn equals_the_spec_on_generated_inputs(
    seed: u64,
    mut draw: impl FnMut(&mut Rng) -> (String, Box<dyn StictionModel>, Spec),
) -> Result<(), StictionError> {
    let mut rng = Rng::seeded(seed);
    for case in 0..CASES {
        let (kind, op) = generate_op(&mut rng);
        let (params, model, spec) = draw(&mut rng);
        for init in all_inits(&mut rng, op[0]) {
            let what = format!("case {case} ({kind}, N = {}), {params}, {init:?}", op.len());
            let want = spec(&op, &init);
            assert_close(&what, &model.simulate(&op, &init)?, &want);
            assert_close(
                &format!("{what}, stepped"),
                &stepped(model.as_ref(), &op, &init),
                &want,
            );
        }
    }
    Ok(())
}

#[test]
fn kano_equals_the_literal_spec_pseudo_code_on_generated_inputs() -> Result<(), StictionError> {
    equals_the_spec_on_generated_inputs(0x5EED_CA40, |rng| {
        let (s, j) = generate_sj(rng);
        let spec: Spec = Box::new(move |op, init| spec_kano(s, j, op, init));
        (format!("S = {s}, J = {j}"), Box::new(kano(s, j)), spec)
    })
}

#[test]
fn kano_asym_equals_the_spec_rule_on_generated_inputs() -> Result<(), StictionError> {
    equals_the_spec_on_generated_inputs(0xA5_7A5, |rng| {
        let dd = if rng.chance(0.2) {
            0.0
        } else {
            rng.range(0.0, 8.0)
        };
        let j_up = if rng.chance(0.2) {
            0.0
        } else {
            rng.range(0.0, 5.0)
        };
        let j_dn = match rng.below(4) {
            0 => 0.0,
            1 => j_up,
            _ => rng.range(0.0, 5.0),
        };
        let spec: Spec = Box::new(move |op, init| spec_kano_asym(dd, j_up, j_dn, op, init));
        let params = format!("D = {dd}, J_up = {j_up}, J_dn = {j_dn}");
        (params, Box::new(kano_asym(dd, j_up, j_dn)), spec)
    })
}

#[test]
fn he_equals_the_literal_spec_pseudo_code_on_generated_inputs() -> Result<(), StictionError> {
    equals_the_spec_on_generated_inputs(0x4E_57E9, |rng| {
        let (s, j) = generate_sj(rng);
        let (fs, fd) = ((s + j) / 2.0, (s - j) / 2.0);
        let spec: Spec = Box::new(move |op, init| spec_he(fs, fd, op, init));
        (format!("fs = {fs}, fd = {fd}"), Box::new(he(fs, fd)), spec)
    })
}

#[test]
fn moving_start_keeps_moving_while_op_continues_and_stops_otherwise() -> Result<(), StictionError> {
    // Our extension (du_prev = d0 for a moving start), checked on hand-computed values:
    // S = 4, J = 1, offset 1.5.
    let model = kano(4.0, 1.0);
    let moving_up = InitialState {
        direction: Direction::Up,
        stuck: false,
        stuck_at: None,
        position: None,
    };
    // OP keeps rising by tiny steps: the valve follows with lag 1.5.
    assert_eq!(
        model.simulate(&[50.0, 50.25, 50.5], &moving_up)?,
        vec![48.5, 48.75, 49.0]
    );
    // OP flat at sample 1: it stops at u_s = 50 and holds 48.5 until OP exceeds 51 (> J).
    assert_eq!(
        model.simulate(&[50.0, 50.0, 51.0, 51.25], &moving_up)?,
        vec![48.5, 48.5, 48.5, 49.75]
    );
    // Moving down, OP reverses upward: stops at 50, needs > 54 to reverse.
    let moving_down = InitialState {
        direction: Direction::Down,
        ..moving_up
    };
    assert_eq!(
        model.simulate(&[50.0, 52.0, 54.0, 54.5], &moving_down)?,
        vec![51.5, 51.5, 51.5, 53.0]
    );
    Ok(())
}
