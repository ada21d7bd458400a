//! Grid-search benchmarks (`cargo xtask bench grid`).
//!
//! Data: the paper's benchmark loop (eq. 10, PI 0.5/0.5, σ_e = 0.1) with a Kano valve S = 9,
//! J = 3, 3000 samples, seed 1 (OP span ≈ 22.6 %).
//! - `kano_arx_exhaustive_step_0_1`: every node of the triangle at step 0.1 (25 878 nodes), on
//!   the fast path (with and without the free run at every node) and the sample path.
//! - `combination/<stiction>/<linear>`: one `compare` cell at the default grid (coarse span/40,
//!   refined at 0.1 within two coarse steps), the paper's orders.
//! - `compare_paper/<path>`: all ten cells of `stiction compare --example paper` in a row, on
//!   the fast and on the sample node path in the same run.
//! - `fleet`: generated loops (3000 samples each, seeds 1.., Kano valves with S, J drawn per
//!   loop) x the ten combinations, fast path, loops side by side (as `stiction batch` runs
//!   registrations), progress on stderr. `STICTION_FLEET_LOOPS` sets
//!   the number of loops (default 20; the fleet is 1000).

use std::sync::atomic::{AtomicUsize, Ordering};

use datasets::simulate::Scenario;
use grid_search::{quantify, quantify_with, GridPlan, NodeFits, NodePath, Problem, SearchOptions};
use linear_id::find_identifier;
use rayon::prelude::*;
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
/// `fast`: the default (the free run only at the best node, `NodeFits::Criterion`);
/// `fast-all-fits`: both criteria's fits at every node (`NodeFits::Both`, as for `--surface`).
#[divan::bench(sample_count = 5, args = ["fast", "fast-all-fits", "sample"])]
fn kano_arx_exhaustive_step_0_1(bencher: divan::Bencher, path: &str) {
    let (op, pv) = data();
    let kano = find_model("kano").expect("registered");
    let arx = (find_identifier("arx").expect("registered").build)(&[]).expect("default orders");
    let opts = SearchOptions {
        grid: GridPlan::Exhaustive { step: 0.1 },
        node_fits: if path == "fast-all-fits" {
            NodeFits::Both
        } else {
            NodeFits::Criterion
        },
        ..SearchOptions::default()
    };
    let path = if path == "sample" {
        NodePath::Sample
    } else {
        NodePath::Fast
    };
    bencher.bench(|| {
        quantify_with(
            kano,
            arx.as_ref(),
            Problem::new(&op, &pv),
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
    bencher.bench(|| quantify(model, id.as_ref(), Problem::new(&op, &pv), &opts, None));
}

/// The ten `compare` cells on one loop, through `path`.
fn compare_cells(op: &[f64], pv: &[f64], path: NodePath) -> usize {
    let opts = SearchOptions {
        grid: GridPlan::for_op(op),
        ..SearchOptions::default()
    };
    let mut found = 0;
    for (s, l) in combinations() {
        let model = find_model(s).expect("registered");
        let Ok(entry) = find_identifier(l) else {
            continue;
        };
        let id = (entry.build)(&[]).expect("default orders");
        let q = quantify_with(
            model,
            id.as_ref(),
            Problem { op, pv, mv: None },
            &opts,
            None,
            path,
        );
        found += usize::from(q.is_ok());
    }
    found
}

#[divan::bench(sample_count = 3, args = ["fast", "sample"])]
fn compare_paper(bencher: divan::Bencher, path: &str) {
    let (op, pv) = data();
    let path = if path == "fast" {
        NodePath::Fast
    } else {
        NodePath::Sample
    };
    bencher.bench(|| compare_cells(&op, &pv, path));
}

#[divan::bench(sample_count = 1)]
fn fleet(bencher: divan::Bencher) {
    let loops: u64 = std::env::var("STICTION_FLEET_LOOPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20);
    let data: Vec<(Vec<f64>, Vec<f64>)> = (1..=loops)
        .map(|seed| {
            let sim = Scenario::fleet(seed).simulate().expect("simulates");
            (sim.op, sim.pv)
        })
        .collect();
    bencher.bench(|| {
        let start = std::time::Instant::now();
        let done = AtomicUsize::new(0);
        // loops side by side, as `stiction batch` runs registrations (each search is itself
        // parallel over its nodes; rayon shares the cores between both levels)
        data.par_iter()
            .map(|(op, pv)| {
                let found = compare_cells(op, pv, NodePath::Fast);
                let i = done.fetch_add(1, Ordering::Relaxed) + 1;
                if i.is_multiple_of(10) || i == data.len() {
                    eprintln!(
                        "fleet: {i}/{} loops, {:.1} s",
                        data.len(),
                        start.elapsed().as_secs_f64()
                    );
                }
                found
            })
            .sum::<usize>()
    });
}

fn combinations() -> Vec<(&'static str, &'static str)> {
    STICTION
        .iter()
        .flat_map(|s| LINEAR.iter().map(move |l| (*s, *l)))
        .collect()
}
