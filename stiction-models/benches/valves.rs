//! Throughput of the stiction models on 10^5 samples (`cargo xtask bench`).
//!
//! The input is a noisy sinusoid (period 250 samples, amplitude 10 %, noise 0.3 %) so that the
//! valve sticks, slips and moves as in an oscillating loop. Divan reports the time per call;
//! divide by 10^5 for ns per sample (the "throughput" column gives items/s directly).

use stiction_models::{He, InitialState, Kano, KanoAsym, StictionModel};

const N: usize = 100_000;

fn op() -> Vec<f64> {
    // Deterministic pseudo-noise (xorshift) so the benchmark needs no RNG crate.
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..N)
        .map(|k| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let noise = (x as f64 / u64::MAX as f64 - 0.5) * 0.6;
            50.0 + 10.0 * (k as f64 * 2.0 * std::f64::consts::PI / 250.0).sin() + noise
        })
        .collect()
}

fn main() {
    divan::main();
}

fn run(model: &dyn StictionModel, bencher: divan::Bencher) {
    let op = op();
    let mut mv = vec![0.0; N];
    let init = InitialState::default();
    bencher
        .counter(divan::counter::ItemsCount::new(N))
        .bench_local(|| {
            model
                .simulate_into(divan::black_box(&op), &init, &mut mv)
                .expect("finite input");
            divan::black_box(&mv);
        });
}

#[divan::bench]
fn kano(bencher: divan::Bencher) {
    let m = Kano::params().s(4.0).j(1.0).check().expect("valid");
    run(&m, bencher);
}

#[divan::bench]
fn he(bencher: divan::Bencher) {
    let m = He::params().fs(2.5).fd(1.5).check().expect("valid");
    run(&m, bencher);
}

#[divan::bench]
fn kano_asym(bencher: divan::Bencher) {
    let m = KanoAsym::params()
        .d(3.0)
        .j_up(0.5)
        .j_dn(1.5)
        .check()
        .expect("valid");
    run(&m, bencher);
}

/// The same Kano model stepped sample by sample through the boxed `ValveState` (the path the
/// closed-loop simulator uses).
#[divan::bench]
fn kano_stepwise(bencher: divan::Bencher) {
    let m = Kano::params().s(4.0).j(1.0).check().expect("valid");
    let op = op();
    let init = InitialState::default();
    bencher
        .counter(divan::counter::ItemsCount::new(N))
        .bench_local(|| {
            let mut st = m.start(op[0], &init).expect("valid");
            let mut acc = 0.0;
            for &u in &op[1..] {
                acc += st.step(divan::black_box(u));
            }
            divan::black_box(acc);
        });
}
