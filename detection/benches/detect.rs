//! `detect` on one registration of 751 samples (the plant data's length): every registered test
//! and the score; the Hammerstein test's output-error evidence on 3000 samples, the
//! detector's most expensive part; and `detect` on 3000 samples, the detector's share of
//! `quantify`'s path (`quantify` runs it once beside the grid, whose share is grid-search's
//! `kano_arx_exhaustive_step_0_1`) (`cargo xtask bench detect`; targets < 50 ms, <= 20 ms).

use datasets::simulate::{Controller, Plant, PlantSpec, Scenario, Setpoint};
use detection::{detect, find_test, Registration};
use stiction_models::Kano;

/// The CLI's allocator, so the figures are the command's (`cli/src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    divan::main();
}

/// A slow self-regulating plant under PI with a Kano valve S = 4, J = 1: a limit cycle.
fn registration(samples: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let sim = Scenario {
        plant: PlantSpec::Explicit(Plant::slow()),
        controller: Controller { kc: 0.3, ki: 0.1 },
        setpoint: Setpoint::constant(),
        valve: Box::new(Kano::params().s(4.0).j(1.0).check().expect("valid")),
        noise_sigma: 0.02,
        samples,
        sample_time: 10.0,
        ..Scenario::default()
    }
    .simulate()
    .expect("simulates");
    (sim.sp, sim.pv, sim.op)
}

/// `run` on a registration of `samples` samples (SP, PV, OP at 10 s) built anew each time, as a
/// command builds it from the file it read.
fn bench_on<T>(
    bencher: divan::Bencher,
    samples: usize,
    run: impl Fn(&Registration<'_>) -> T + Sync,
) {
    let (sp, pv, op) = registration(samples);
    bencher.bench(|| {
        let reg = Registration::new(&pv, &op, 10.0)
            .expect("same lengths")
            .with_sp(&sp)
            .expect("same lengths");
        run(divan::black_box(&reg))
    });
}

#[divan::bench]
fn detect_751_samples(bencher: divan::Bencher) {
    bench_on(bencher, 751, detect);
}

/// Every test, the score and the parts' check (its first half, its second half, every second
/// sample, the means of each two) on a 3000-sample registration: what `quantify` adds to its grid.
#[divan::bench]
fn detect_3000_samples(bencher: divan::Bencher) {
    bench_on(bencher, 3000, detect);
}

/// The Hammerstein test alone (its output-error and one-step fits over the valve grid) on a
/// 3000-sample registration.
#[divan::bench]
fn hammerstein_3000_samples(bencher: divan::Bencher) {
    let test = find_test("hammerstein").expect("registered").test;
    bench_on(bencher, 3000, |reg| test.run(reg));
}
