//! The exhaustive kano × arx grid on the paper loop, fast path only, repeated: a target for
//! `perf record` (`cargo run --release -p grid-search --example profile_exhaustive -- 20`;
//! `BOTH=1` computes the free-run fits at every node, `SAMPLE=1` takes the sample path;
//! `MODEL=he` searches another stiction model; `LINEAR=ss` (any identifier) with `COARSE=1`
//! profiles the default coarse-to-fine grid of
//! `compare` for that identifier instead).

use datasets::simulate::Scenario;
use grid_search::{quantify_with, GridPlan, NodeFits, NodePath, Problem, SearchOptions};
use linear_id::find_identifier;
use stiction_models::{find_model, Kano};

fn main() {
    let repeat: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(10);
    let sim = Scenario {
        valve: Box::new(Kano::params().s(9.0).j(3.0).check().expect("valid")),
        ..Scenario::default()
    }
    .simulate()
    .expect("simulates");
    let kano =
        find_model(&std::env::var("MODEL").unwrap_or_else(|_| "kano".into())).expect("registered");
    let linear = std::env::var("LINEAR").unwrap_or_else(|_| "arx".into());
    let arx = (find_identifier(&linear).expect("registered").build)(&[]).expect("default orders");
    let span = sim.op.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b))
        - sim.op.iter().fold(f64::INFINITY, |a, &b| a.min(b));
    let opts = SearchOptions {
        grid: if std::env::var_os("COARSE").is_some() {
            GridPlan::for_span(span)
        } else {
            GridPlan::Exhaustive { step: 0.1 }
        },
        node_fits: if std::env::var_os("BOTH").is_some() {
            NodeFits::Both
        } else {
            NodeFits::Criterion
        },
        ..SearchOptions::default()
    };
    let t0 = std::time::Instant::now();
    for _ in 0..repeat {
        let q = quantify_with(
            kano,
            arx.as_ref(),
            Problem::new(&sim.op, &sim.pv),
            &opts,
            None,
            if std::env::var_os("SAMPLE").is_some() {
                NodePath::Sample
            } else {
                NodePath::Fast
            },
        )
        .expect("finds a node");
        std::hint::black_box(q);
    }
    println!(
        "{:.1} ms per search",
        t0.elapsed().as_secs_f64() * 1e3 / repeat as f64
    );
}
