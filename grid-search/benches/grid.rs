//! Grid-search benchmarks (`cargo xtask bench grid`).
//!
//! Data: the paper's benchmark loop (eq. 10, PI 0.5/0.5, σ_e = 0.1) with a Kano valve S = 9,
//! J = 3, 3000 samples, seed 1 (OP span ≈ 22.6 %).
//! - `kano_arx_exhaustive_step_0_1`: every node of the triangle at step 0.1 (25 878 nodes).
//! - `combination/<stiction>/<linear>`: one `compare` cell at the default grid (coarse span/40,
//!   refined at 0.1 within two coarse steps), the paper's orders.

use datasets::simulate::Scenario;
use grid_search::{quantify, quantify_with, GridPlan, NodePath, Problem, SearchOptions};
use linear_id::find_identifier;
use stiction_models::{find_model, Kano};

fn main() {
    divan::main();
}

fn data() -> (Vec<f64>, Vec<f64>) {
    let sim = Scenario {
        valve: Box::new(Kano::params().s(9.0).j(3.0).check().expect("valid")),
        ..Scenario::default()
    }
    .simulate()
    .expect("simulates");
    (sim.op, sim.pv)
}

/// The same exhaustive grid through both node paths, in one run (the ratio is the speed-up).
#[divan::bench(sample_count = 5, args = ["fast", "sample"])]
fn kano_arx_exhaustive_step_0_1(bencher: divan::Bencher, path: &str) {
    let (op, pv) = data();
    let kano = find_model("kano").expect("registered");
    let arx = (find_identifier("arx").expect("registered").build)(&[]).expect("default orders");
    let opts = SearchOptions {
        grid: GridPlan::Exhaustive { step: 0.1 },
        ..SearchOptions::default()
    };
    let path = if path == "fast" {
        NodePath::Fast
    } else {
        NodePath::Sample
    };
    bencher.bench(|| {
        quantify_with(
            kano,
            arx.as_ref(),
            Problem {
                op: &op,
                pv: &pv,
                mv: None,
            },
            &opts,
            None,
            path,
        )
        .expect("finds a node")
    });
}

const STICTION: [&str; 2] = ["kano", "he"];
const LINEAR: [&str; 5] = ["arx", "armax", "ss", "earx", "earmax"];

#[divan::bench(sample_count = 3, args = combinations())]
fn combination(bencher: divan::Bencher, combo: &(&str, &str)) {
    let (op, pv) = data();
    let (lo, hi) = op
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let coarse = (hi - lo) / 40.0;
    let opts = SearchOptions {
        grid: GridPlan::CoarseToFine {
            coarse,
            fine: 0.1f64.min(coarse / 5.0),
            radius: 2.0,
        },
        ..SearchOptions::default()
    };
    let model = find_model(combo.0).expect("registered");
    let Ok(entry) = find_identifier(combo.1) else {
        return;
    };
    let id = (entry.build)(&[]).expect("default orders");
    bencher.bench(|| {
        quantify(
            model,
            id.as_ref(),
            Problem {
                op: &op,
                pv: &pv,
                mv: None,
            },
            &opts,
            None,
        )
    });
}

fn combinations() -> Vec<(&'static str, &'static str)> {
    STICTION
        .iter()
        .flat_map(|s| LINEAR.iter().map(move |l| (*s, *l)))
        .collect()
}
