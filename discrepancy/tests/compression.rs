//! Historian compression hidden in generated loops: PV logged through a swinging-door archive
//! and read back by linear interpolation (`Scenario::pv_compression`). The diagnosis must name
//! `compression` first and nothing else (the other causes' tests are not run on such data;
//! run plainly they named a spurious `time-delay`), and says what the baseline estimates.
//!
//! CI size: 6 loops (`STICTION_SUITE_SIZE=N` runs N). Loops: the paper's or the slow plant,
//! Kano valve S in [2, 8] %, J in [0.3, S/2], noise σ in [0.05, 0.15], PI gains in [0.25, 0.6],
//! swinging-door deviation in [0.3, 0.8] (PV units), 3000 samples. Acceptance: the causes are
//! exactly `[compression]` in every loop, and S does not collapse: at least half the truth in
//! every loop (the refit at the archive's lag, `linear_id::Larx`; with the paper's ARX kept,
//! seed 4 gave S = 1.10 for a true 5.15 and the test fails). S within max(0.5, 10 %) of the
//! truth is printed, not asserted (4 of 6 at CI size, 14 of 24 at size 24 against 12 of 24
//! with the paper's ARX; 5 of 6 for the same loops uncompressed: `DBG=1` prints those;
//! docs/DIAGNOSE.md). With the cause disabled (`disabled = ["compression"]`) the causes'
//! assertion fails in every loop.
#![allow(clippy::unwrap_used)]

use datasets::simulate::{Controller, Plant, PlantSpec, Scenario};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stiction_models::Kano;

struct Compressed {
    s: f64,
    what: String,
    op: Vec<f64>,
    pv: Vec<f64>,
}

fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

fn compressed_loop(seed: u64) -> Compressed {
    compressed_loop_with(seed, true)
}

fn compressed_loop_with(seed: u64, compress: bool) -> Compressed {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xC0_4D_E5);
    let slow = rng.random::<f64>() < 0.5;
    let plant = if slow { Plant::slow() } else { Plant::paper() };
    let noise = uniform(&mut rng, 0.05, 0.15);
    let gain = uniform(&mut rng, 0.25, 0.6);
    let s = uniform(&mut rng, 2.0, 8.0);
    let j = uniform(&mut rng, 0.3, 0.5 * s);
    let deviation = uniform(&mut rng, 0.3, 0.8);
    let sim = Scenario {
        plant: PlantSpec::Explicit(plant),
        valve: Box::new(Kano::params().s(s).j(j).check().unwrap()),
        noise_sigma: noise,
        controller: Controller { kc: gain, ki: gain },
        samples: 3000,
        seed: rng.random::<u64>() % 1_000_000,
        pv_compression: compress.then_some(deviation),
        ..Scenario::default()
    }
    .simulate()
    .unwrap();
    Compressed {
        s,
        what: format!(
            "{} plant, S {s:.2} J {j:.2}, noise {noise:.3}, gain {gain:.2}, door {deviation:.2}",
            if slow { "slow" } else { "paper" }
        ),
        op: sim.op,
        pv: sim.pv,
    }
}

fn diagnose(c: &Compressed, disabled: &[String]) -> discrepancy::Diagnosis {
    let problem = grid_search::Problem {
        op: &c.op,
        pv: &c.pv,
        mv: None,
    };
    let span = c.op.iter().cloned().fold(f64::MIN, f64::max)
        - c.op.iter().cloned().fold(f64::MAX, f64::min);
    let mut options = discrepancy::DiagnoseOptions::for_span(span);
    options.disabled = disabled.to_vec();
    let baseline = discrepancy::Baseline::paper().unwrap();
    discrepancy::diagnose(problem, &baseline, &options).unwrap()
}

fn size() -> u64 {
    std::env::var("STICTION_SUITE_SIZE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(6)
}

#[test]
fn compression_is_named_alone() {
    let n = size();
    let (mut named, mut s_right, mut collapsed) = (0, 0, Vec::new());
    for seed in 1..=n {
        let c = compressed_loop(seed);
        let d = diagnose(&c, &[]);
        let s = d.final_fit().map_or(d.baseline.s, |f| f.result.s);
        let tol = (0.1 * c.s).max(0.5);
        if std::env::var_os("DBG").is_some() {
            let u = compressed_loop_with(seed, false);
            let du = diagnose(&u, &[]);
            println!(
                "   uncompressed: causes {:?} S {:.2}",
                du.causes,
                du.final_fit().map_or(du.baseline.s, |f| f.result.s)
            );
        }
        named += usize::from(d.cause == "compression" && d.causes == ["compression"]);
        s_right += usize::from((s - c.s).abs() <= tol);
        if s < 0.5 * c.s {
            collapsed.push(format!("seed {seed}: S {s:.2} for a true {:.2}", c.s));
        }
        println!(
            "seed {seed} ({}): causes {:?}, S {s:.2}, true {:.2}",
            c.what, d.causes, c.s
        );
    }
    println!("causes [compression] {named}/{n}; S within max(0.5, 10 %) {s_right}/{n}");
    assert_eq!(
        named as u64, n,
        "the causes must be [compression] in every loop"
    );
    assert!(
        collapsed.is_empty(),
        "S collapsed towards 0 on compressed PV: {collapsed:?}"
    );
}

#[test]
fn an_uncompressed_loop_is_not_called_compressed() {
    let c = compressed_loop(1);
    let sim = Scenario {
        valve: Box::new(Kano::params().s(c.s).j(1.0).check().unwrap()),
        ..Scenario::default()
    }
    .simulate()
    .unwrap();
    let d = diagnose(
        &Compressed {
            s: c.s,
            what: String::new(),
            op: sim.op,
            pv: sim.pv,
        },
        &[],
    );
    assert!(
        !d.causes.iter().any(|c| c == "compression"),
        "{:?}",
        d.causes
    );
}
