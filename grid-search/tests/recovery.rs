//! Recovery rate of the grid search on simulated loops (the project's must-hold): on the
//! paper's closed loop with no external disturbance, S is found within 0.25 of the truth in at
//! least 95 % of the loops over the paper's range S ∈ [1, 12], J ∈ [0.5, 4]; J within 0.5 in
//! most (the rate is printed; only a rate at or below one half fails).
//!
//! CI-sized: a few dozen loops drawn with a seeded generator, Kano × ARX (the paper's ARX(2, 2)
//! on the paper's plant, ARX(3, 3) on the third-order slow plant), the CLI's default coarse-to-fine grid, In.3, one-step prediction. The full-size
//! run (200 loops per setting) is `cargo xtask reproduce --only recovery`; its rates are in
//! `docs/REPRODUCTION.md`.
#![allow(clippy::unwrap_used)]

use datasets::simulate::{PlantPreset, PlantSpec, Scenario};
use grid_search::{quantify, Criterion, GridPlan, Problem, SearchOptions};
use linear_id::Arx;
use stiction_models::{find_model, Kano};

/// SplitMix64, to draw (S, J) reproducibly without another dependency.
struct SplitMix(u64);

impl SplitMix {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

struct Rates {
    loops: usize,
    s_hits: usize,
    j_hits: usize,
    misses: Vec<String>,
}

/// Quantify `loops` simulated loops with S ~ U[1, 12], J ~ U[0.5, min(4, S)].
fn recovery(plant: PlantPreset, order: usize, noise: f64, loops: usize, rng_seed: u64) -> Rates {
    let kano = find_model("kano").unwrap();
    let arx = Arx::params().n(order).m(order).delay(0).check().unwrap();
    let mut rng = SplitMix(rng_seed);
    let mut rates = Rates {
        loops,
        s_hits: 0,
        j_hits: 0,
        misses: Vec::new(),
    };
    for i in 0..loops {
        let s = 1.0 + 11.0 * rng.uniform();
        let j = 0.5 + (4.0f64.min(s) - 0.5) * rng.uniform();
        let seed = 100 + i as u64;
        let d = Scenario {
            plant: PlantSpec::Preset(plant),
            valve: Box::new(Kano::params().s(s).j(j).check().unwrap()),
            noise_sigma: noise,
            samples: 3000,
            warmup: 500,
            seed,
            ..Scenario::default()
        }
        .simulate()
        .unwrap();
        let span = d.op.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - d.op.iter().cloned().fold(f64::INFINITY, f64::min);
        let q = quantify(
            kano,
            &arx,
            Problem::new(&d.op, &d.pv),
            &SearchOptions {
                grid: GridPlan::for_span(span),
                criterion: Criterion::Prediction,
                ..SearchOptions::default()
            },
            None,
        )
        .unwrap();
        let s_ok = (q.s - s).abs() <= 0.25 + 1e-9;
        let j_ok = (q.j - j).abs() <= 0.5 + 1e-9;
        rates.s_hits += usize::from(s_ok);
        rates.j_hits += usize::from(j_ok);
        if !s_ok || !j_ok {
            rates.misses.push(format!(
                "seed {seed}: truth ({s:.2}, {j:.2}) → ({:.2}, {:.2}){}",
                q.s,
                q.j,
                if s_ok { "" } else { " S MISS" }
            ));
        }
    }
    println!(
        "{plant:?} plant, ARX({order},{order}), σ_e = {noise}: S within 0.25 in {}/{} loops ({:.0} %), J within 0.5 in {}/{} ({:.0} %)",
        rates.s_hits,
        loops,
        100.0 * rates.s_hits as f64 / loops as f64,
        rates.j_hits,
        loops,
        100.0 * rates.j_hits as f64 / loops as f64,
    );
    for m in &rates.misses {
        println!("  {m}");
    }
    rates
}

fn assert_s_rate(r: &Rates) {
    // At least 95 %: with 24 loops, at most one miss.
    let needed = (0.95 * r.loops as f64).ceil() as usize;
    assert!(
        r.s_hits >= needed,
        "S within 0.25 in only {}/{} loops (need {needed}); misses: {:#?}",
        r.s_hits,
        r.loops,
        r.misses
    );
    // "J within 0.5 in most": reported above; only a collapse is an error.
    assert!(
        2 * r.j_hits > r.loops,
        "J within 0.5 in only {}/{} loops; misses: {:#?}",
        r.j_hits,
        r.loops,
        r.misses
    );
}

/// The paper's plant (eq. 10), nominal PI, σ_e = 0.1, no disturbance, the paper's ARX(2, 2)
/// (its third pole is negligible: a3 = -0.0009).
#[test]
fn paper_plant_recovers_s_in_95_percent_of_loops() {
    let r = recovery(PlantPreset::Paper, 2, 0.1, 24, 0x5eed_0001);
    assert_s_rate(&r);
}

/// The slower plant of spec §6.3 and another noise level: the rate is not a property of one
/// plant. This plant is genuinely third order (poles 0.816, 0.4, 0.184), so it is identified
/// with ARX(3, 3), as in spec §5.9 G2. With the under-ordered ARX(2, 2) the rate drops (21/24
/// on these loops, 159/200 = 79.5 % in `docs/REPRODUCTION.md`): at σ_e = 0.05 the fit surface is
/// flat to 1e-3 % and the stiction parameters absorb the missing pole (typically J → 0 and S
/// low by about 1).
#[test]
fn slow_plant_recovers_s_in_95_percent_of_loops() {
    let r = recovery(PlantPreset::Slow, 3, 0.05, 24, 0x5eed_0002);
    assert_s_rate(&r);
}
