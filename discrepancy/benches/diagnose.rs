//! Wall time of one diagnosis of a 3000-sample loop: the paper's loop (Kano S = 9, J = 3), two
//! loops with two hidden causes at once (disturbance and dead time; disturbance and an
//! asymmetric valve), and a loop with an installed equal-percentage valve.
#![allow(missing_docs, clippy::unwrap_used)]

use datasets::simulate::{
    Characteristic, Controller, Disturbance, Plant, PlantSpec, Scenario, Setpoint,
};
use discrepancy::{diagnose, Baseline, DiagnoseOptions, Diagnosis};
use grid_search::Problem;
use stiction_models::Kano;

/// The CLI's allocator, so the figures are the command's (`cli/src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    divan::main();
}

/// Simulate `scenario`, then time its diagnosis from the paper's baseline; `show` prints the
/// causes found once, before the timing.
fn bench_diagnosis(bencher: divan::Bencher, scenario: Scenario, show: fn(&Diagnosis)) {
    let sim = scenario.simulate().unwrap();
    let span = sim.op.iter().cloned().fold(f64::MIN, f64::max)
        - sim.op.iter().cloned().fold(f64::MAX, f64::min);
    let options = DiagnoseOptions::for_span(span);
    let baseline = Baseline::paper().unwrap();
    let p = Problem {
        op: &sim.op,
        pv: &sim.pv,
        mv: None,
    };
    show(&diagnose(p, &baseline, &options).unwrap());
    bencher.bench(|| diagnose(p, &baseline, &options).unwrap().causes.join("+"));
}

#[divan::bench(sample_count = 3, sample_size = 1)]
fn diagnose_paper_loop_3000(bencher: divan::Bencher) {
    let scenario = Scenario {
        valve: Box::new(Kano::params().s(9.0).j(3.0).check().unwrap()),
        ..Scenario::default()
    };
    bench_diagnosis(bencher, scenario, |_| {});
}

/// Two hidden causes at once (the paper's disturbance shape, a = 0.8, and 4 samples of extra
/// dead time): the forward selection's second step, and its second start when the first
/// round's runner-up is significant too.
#[divan::bench(sample_count = 3, sample_size = 1)]
fn diagnose_disturbance_and_delay_3000(bencher: divan::Bencher) {
    let mut plant = Plant::paper();
    plant.delay = 4;
    let scenario = Scenario {
        plant: PlantSpec::Explicit(plant),
        valve: Box::new(Kano::params().s(7.0).j(2.0).check().unwrap()),
        disturbances: vec![Disturbance::Paper { a: 0.8 }],
        controller: Controller { kc: 0.3, ki: 0.3 },
        ..Scenario::default()
    };
    bench_diagnosis(bencher, scenario, |d| {
        eprintln!("two causes hidden; diagnose finds {:?}", d.causes)
    });
}

/// An installed equal-percentage valve (rangeability 40) after a Kano valve (S = 6, J = 2),
/// the set point wandering as in the suite's characteristic loops (random-walk step 5).
#[divan::bench(sample_count = 3, sample_size = 1)]
fn diagnose_equal_percentage_3000(bencher: divan::Bencher) {
    let scenario = Scenario {
        valve: Box::new(Kano::params().s(6.0).j(2.0).check().unwrap()),
        characteristic: Some(Characteristic::EqualPercentage { rangeability: 40.0 }),
        setpoint: Setpoint {
            step: 5.0,
            ..Setpoint::default()
        },
        controller: Controller { kc: 0.3, ki: 0.3 },
        ..Scenario::default()
    };
    bench_diagnosis(bencher, scenario, |d| {
        eprintln!("equal-percentage valve; diagnose finds {:?}", d.causes)
    });
}

/// A disturbance (the paper's shape, a = 0.8) and an asymmetric valve (kano-asym D = 3,
/// J_up = 3, J_dn = 0.5) at once: the forward selection re-tests every cause on the extended
/// model, including the asymmetric valve's local search on EARX and the dead time and
/// disturbance on a three-parameter valve.
#[divan::bench(sample_count = 3, sample_size = 1)]
fn diagnose_disturbance_and_asymmetric_3000(bencher: divan::Bencher) {
    let valve = stiction_models::KanoAsym::params()
        .d(3.0)
        .j_up(3.0)
        .j_dn(0.5)
        .check()
        .unwrap();
    let scenario = Scenario {
        valve: Box::new(valve),
        disturbances: vec![Disturbance::Paper { a: 0.8 }],
        controller: Controller { kc: 0.3, ki: 0.3 },
        ..Scenario::default()
    };
    bench_diagnosis(bencher, scenario, |d| {
        eprintln!(
            "disturbance and asymmetric valve; diagnose finds {:?}",
            d.causes
        )
    });
}
