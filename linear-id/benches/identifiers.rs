//! Each identifier at N = 3000 and N = 30000 with its default orders, plus ARX through the
//! prepared-output path and one-step prediction.
//!
//! Run: `CARGO_TARGET_DIR=/work/target-linear cargo bench -p linear-id --bench identifiers`

use divan::{black_box, Bencher};
use linear_id::{find_identifier, LinearIdentifier};

fn main() {
    divan::main();
}

/// Deterministic closed-loop-like data: an ARMAX(3,3,3) plant driven by a pseudo-random
/// square wave plus a small LCG noise.
fn data(len: usize) -> (Vec<f64>, Vec<f64>) {
    let mut state: u64 = 12345;
    let mut rnd = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let a = [1.0, -0.5215, 0.0590, -0.0009];
    let b = [0.2836, 0.2442, 0.0088];
    let mut u = vec![0.0; len];
    let mut y = vec![0.0; len];
    let mut level = 1.0;
    for k in 0..len {
        if rnd() > 0.45 {
            level = -level;
        }
        u[k] = 50.0 + level + 0.1 * rnd();
        let mut v = 0.2 * rnd();
        for i in 1..4 {
            if k >= i {
                v += -a[i] * y[k - i] + b[i - 1] * u[k - i];
            }
        }
        y[k] = v;
    }
    (u, y)
}

const NAMES: &[&str] = &["arx", "armax", "earx", "earmax", "ss"];
const LENS: &[usize] = &[3000, 30000];

#[divan::bench(args = NAMES, consts = [3000, 30000])]
fn identify<const N: usize>(bencher: Bencher, name: &str) {
    let _ = LENS;
    let id: Box<dyn LinearIdentifier> = find_identifier(name)
        .expect("registered")
        .build_default()
        .expect("defaults");
    let (u, y) = data(N);
    bencher.bench_local(|| black_box(id.identify(black_box(&u), black_box(&y)).expect("fit")));
}

#[divan::bench(consts = [3000, 30000])]
fn arx_prepared<const N: usize>(bencher: Bencher) {
    let id = find_identifier("arx")
        .expect("arx")
        .build_default()
        .expect("defaults");
    let (u, y) = data(N);
    let prepared = id.prepare(&y).expect("prepare");
    bencher.bench_local(|| black_box(id.identify_prepared(&prepared, black_box(&u)).expect("fit")));
}

#[divan::bench(args = NAMES, consts = [3000])]
fn predict_one_step<const N: usize>(bencher: Bencher, name: &str) {
    let id = find_identifier(name)
        .expect("registered")
        .build_default()
        .expect("defaults");
    let (u, y) = data(N);
    let fit = id.identify(&u, &y).expect("fit");
    let mut out = vec![0.0; N];
    bencher.bench_local(|| {
        fit.predict_one_step_into(black_box(&u), black_box(&y), &mut out)
            .expect("predict")
    });
}
