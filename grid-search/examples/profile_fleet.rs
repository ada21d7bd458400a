//! The fleet bench's work, loop after loop, with the time per combination: a target for
//! `perf record` and a table of where a fleet's time goes
//! (`RAYON_NUM_THREADS=1 cargo run --release -p grid-search --example profile_fleet -- 20`;
//! the argument is the number of generated loops, seeds 1.., drawn as in the `fleet` bench;
//! `ONLY=he/ss` keeps one combination).

use std::time::{Duration, Instant};

use datasets::simulate::Scenario;
use grid_search::{quantify_with, GridPlan, NodePath, Problem, SearchOptions};
use linear_id::find_identifier;
use stiction_models::find_model;

const STICTION: [&str; 2] = ["kano", "he"];
const LINEAR: [&str; 5] = ["arx", "armax", "ss", "earx", "earmax"];

fn main() {
    let loops: u64 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20);
    let only = std::env::var("ONLY").ok();
    let mut spent: Vec<((&str, &str), Duration, usize)> = Vec::new();
    for s in STICTION {
        for l in LINEAR {
            if only.as_deref().is_none_or(|o| o == format!("{s}/{l}")) {
                spent.push(((s, l), Duration::ZERO, 0));
            }
        }
    }
    for seed in 1..=loops {
        let sim = Scenario::fleet(seed).simulate().expect("simulates");
        let opts = SearchOptions {
            grid: GridPlan::for_op(&sim.op),
            ..SearchOptions::default()
        };
        for ((model, linear), time, nodes) in &mut spent {
            let m = find_model(model).expect("registered");
            let id = (find_identifier(linear).expect("registered").build)(&[]).expect("orders");
            let start = Instant::now();
            let q = quantify_with(
                m,
                id.as_ref(),
                Problem::new(&sim.op, &sim.pv),
                &opts,
                None,
                NodePath::Fast,
            );
            *time += start.elapsed();
            *nodes += q.map_or(0, |q| q.nodes_evaluated);
        }
    }
    let total: Duration = spent.iter().map(|(_, t, _)| *t).sum();
    println!("{loops} loops, {:.2} s in all", total.as_secs_f64());
    for ((model, linear), time, nodes) in &spent {
        println!(
            "{model:>5} x {linear:<7} {:>8.1} ms/loop {:>5.1} %  {:>7.1} nodes/loop  {:>6.1} µs/node",
            time.as_secs_f64() * 1e3 / loops as f64,
            100.0 * time.as_secs_f64() / total.as_secs_f64(),
            *nodes as f64 / loops as f64,
            time.as_secs_f64() * 1e6 / (*nodes).max(1) as f64,
        );
    }
}
