//! Hostile grids (issue 15): every grid is bounded by the node budget and defined relative to
//! the OP span; a request beyond the budget is an error naming it, never an allocation failure
//! or a panic; a step coarser than the span is refused, not answered with one node.
// Test helpers outside #[test] functions may unwrap too: a panic is how a test fails.
#![allow(clippy::unwrap_used)]

use datasets::simulate::Scenario;
use grid_search::{quantify, GridPlan, Problem, SearchError, SearchOptions};
use linear_id::Arx;
use stiction_models::{find_model, Kano};

fn paper_loop(scale: f64) -> (Vec<f64>, Vec<f64>) {
    let d = Scenario {
        valve: Box::new(Kano::params().s(4.0).j(1.0).check().unwrap()),
        samples: 900,
        ..Scenario::default()
    }
    .simulate()
    .unwrap();
    (d.op.iter().map(|v| v * scale).collect(), d.pv)
}

fn span(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    hi - lo
}

fn run(op: &[f64], pv: &[f64], grid: GridPlan) -> Result<grid_search::Quantification, SearchError> {
    let kano = find_model("kano").unwrap();
    let arx = Arx::params().check().unwrap();
    quantify(
        kano,
        &arx,
        Problem { op, pv, mv: None },
        &SearchOptions {
            grid,
            ..SearchOptions::default()
        },
        None,
    )
}

/// OP x 1e9 with the default plan used to ask for 3.5e10 bytes of nodes and abort; OP in
/// counts (x 163.83) took 370 k nodes. The plan is relative to the span now: the node count
/// is bounded whatever OP's scale (41²/2 coarse nodes plus a refinement box of at most 101²).
#[test]
fn default_plan_node_count_does_not_depend_on_op_scale() {
    let (op, pv) = paper_loop(1.0);
    let base = run(&op, &pv, GridPlan::for_span(span(&op))).unwrap();
    for scale in [1e-3, 163.83, 1e9] {
        let (op, pv) = paper_loop(scale);
        let q = run(&op, &pv, GridPlan::for_span(span(&op))).unwrap();
        assert!(
            q.nodes_evaluated <= 12_000,
            "scale {scale}: {} nodes (base {})",
            q.nodes_evaluated,
            base.nodes_evaluated
        );
        assert!(
            (q.s / scale - base.s).abs() <= 0.5,
            "{} vs {}",
            q.s / scale,
            base.s
        );
    }
}

/// `--step 5e-324` panicked (capacity overflow in `grid::axis`); `--step 1e-4` aborted at
/// 4.7 GB. Both are a budget error naming the budget now.
#[test]
fn tiny_steps_are_a_budget_error() {
    let (op, pv) = paper_loop(1.0);
    for step in [5e-324, 1e-4, 1e-3] {
        match run(&op, &pv, GridPlan::Exhaustive { step }) {
            Err(e @ SearchError::Budget { .. }) => {
                let msg = e.to_string();
                assert!(msg.contains("node budget of 200000"), "{msg}");
                assert!(msg.contains("--max-nodes"), "{msg}");
            }
            other => panic!("step {step}: {other:?}"),
        }
    }
}

/// `--step 1e9` (larger than the OP span) gave one node and "no evidence of stiction".
#[test]
fn a_step_over_the_span_is_refused() {
    let (op, pv) = paper_loop(1.0);
    let sp = span(&op);
    for step in [1e9, sp, sp / 3.0] {
        match run(&op, &pv, GridPlan::Exhaustive { step }) {
            Err(SearchError::InvalidOption { name: "step", .. }) => {}
            other => panic!("step {step}: {other:?}"),
        }
    }
    assert!(run(&op, &pv, GridPlan::Exhaustive { step: sp / 5.0 }).is_ok());
}

/// The budget is an option: a smaller one refuses a grid the default accepts.
#[test]
fn the_budget_is_configurable() {
    let (op, pv) = paper_loop(1.0);
    let kano = find_model("kano").unwrap();
    let arx = Arx::params().check().unwrap();
    let r = quantify(
        kano,
        &arx,
        Problem::new(&op, &pv),
        &SearchOptions {
            grid: GridPlan::Exhaustive { step: 0.1 },
            max_nodes: 100,
            ..SearchOptions::default()
        },
        None,
    );
    assert!(
        matches!(r, Err(SearchError::Budget { budget: 100, .. })),
        "{r:?}"
    );
}
