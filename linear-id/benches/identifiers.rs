//! Each identifier at N = 3000 and N = 30000 with its default orders, plus ARX through the
//! prepared-output path and one-step prediction.
//!
//! Run: `CARGO_TARGET_DIR=/work/target-linear cargo bench -p linear-id --bench identifiers`

use divan::{black_box, Bencher};
use linear_id::{find_identifier, LinearIdentifier};

fn main() {
    divan::main();
}

#[path = "data.rs"]
mod workload;
use workload::data;

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

/// OP's dominant frequency as the detector asks for it (periods of 8 samples to a quarter of
/// the record) on a sine with noise: the Goertzel grid and the golden refinement
/// (`linear_id::dominant_frequency`; the lane count of its grid was chosen here).
#[divan::bench(consts = [1500, 3000])]
fn dominant_frequency<const N: usize>(bencher: Bencher) {
    let (u, _) = data(N);
    let x: Vec<f64> = u
        .iter()
        .enumerate()
        .map(|(t, v)| (t as f64 * 0.05).sin() + 0.1 * v)
        .collect();
    bencher.bench_local(|| {
        black_box(linear_id::dominant_frequency(
            black_box(&x),
            8.0,
            N as f64 / 4.0,
        ))
    });
}
