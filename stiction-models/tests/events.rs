//! The event-driven valve run (`run_valve_indexed`) against the sample path (`run_valve_with`):
//! the same MV at every sample, bit for bit, the same `valid_from` and In.3 fallback, for Kano
//! and kano-asym under In.1 (every preset, custom stop points and positions), In.2 and In.3.
//! He's model has no event rule and must take the sample path unchanged.
//!
//! OP mixes dyadic steps (exact sums, so threshold ties `>` vs `>=` really occur, and flat
//! stretches so `ΔOP = 0` stops occur) with arbitrary reals. `PROPTEST_CASES` scales it.

mod common;
use common::{he, kano, kano_asym};

use proptest::prelude::*;
use stiction_models::{
    run_valve_indexed, run_valve_with, Direction, FastPaths, InitialState, Initialization, OpIndex,
    StictionModel, ValveScratch,
};

fn op_series() -> impl Strategy<Value = Vec<f64>> {
    let step = prop_oneof![
        3 => Just(0.0),
        4 => (-16i32..=16).prop_map(|i| f64::from(i) / 64.0),
        2 => (-200i32..=200).prop_map(|i| f64::from(i) / 64.0),
        3 => -3.0f64..3.0,
    ];
    (
        -50.0f64..50.0,
        prop::collection::vec(step, 1..400),
        prop::bool::ANY,
    )
        .prop_map(|(start, steps, dyadic_start)| {
            let mut v = if dyadic_start { start.round() } else { start };
            let mut out = vec![v];
            for s in steps {
                v += s;
                out.push(v);
            }
            out
        })
}

fn param() -> impl Strategy<Value = f64> {
    prop_oneof![
        2 => (0i32..=64).prop_map(|i| f64::from(i) / 16.0),
        1 => 0.0f64..6.0,
    ]
}

fn inits() -> Vec<Initialization> {
    let mut v = vec![
        Initialization::In3,
        Initialization::In2 {
            stationary_fraction: 0.1,
        },
    ];
    for s in InitialState::four_variants() {
        v.push(Initialization::In1(s));
    }
    v.push(Initialization::In1(InitialState {
        direction: Direction::Up,
        stuck: true,
        stuck_at: Some(1.25),
        position: Some(-3.0),
    }));
    v.push(Initialization::In1(InitialState {
        direction: Direction::Down,
        stuck: false,
        stuck_at: None,
        position: Some(7.5),
    }));
    v
}

fn same_run(model: &dyn StictionModel, op: &[f64]) -> Result<(), TestCaseError> {
    let index = OpIndex::new(op).expect("finite");
    let (mut a, mut b) = (ValveScratch::default(), ValveScratch::default());
    for init in inits() {
        let ra = run_valve_with(model, op, &init, &mut a).expect("runs");
        // twice through the same scratch: buffers from the previous run must not leak
        for _ in 0..2 {
            let rb = run_valve_indexed(model, &index, &init, &mut b).expect("runs");
            prop_assert_eq!(ra, rb, "{:?} {:?}", model, init);
            let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            prop_assert_eq!(bits(&a.mv), bits(&b.mv), "{:?} {:?}", model, init);
        }
    }
    Ok(())
}

proptest! {
    #[test]
    fn kano_events_equal_the_sample_path(op in op_series(), s in param(), j in param()) {
        let (s, j) = if j <= s { (s, j) } else { (j, s) };
        same_run(&kano(s, j), &op)?;
    }

    #[test]
    fn kano_asym_events_equal_the_sample_path(
        op in op_series(), d in param(), ju in param(), jd in param()
    ) {
        same_run(&kano_asym(d, ju, jd), &op)?;
    }

    #[test]
    fn he_keeps_the_sample_path(op in op_series(), fs in param(), fd in param()) {
        let (fs, fd) = if fd <= fs { (fs, fd) } else { (fd, fs) };
        let m = he(fs, fd);
        prop_assert!(m.event_rule().is_none());
        same_run(&m, &op)?;
    }
}

#[test]
fn long_stuck_intervals_use_the_range_table() {
    // a slow sine with small noise: stuck intervals far longer than the linear look-ahead
    let op: Vec<f64> = (0..5000)
        .map(|k| 10.0 * (k as f64 / 300.0).sin() + 0.01 * ((k * 7919 % 13) as f64 - 6.0))
        .collect();
    for (s, j) in [(0.0, 0.0), (0.5, 0.1), (3.0, 1.0), (9.0, 3.0), (25.0, 25.0)] {
        same_run(&kano(s, j), &op).expect("equal");
    }
}
