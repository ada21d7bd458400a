//! How often the fast path's ARX falls back from the normal equations to the QR
//! (`linear_id::GRAM_PIVOT_TOL`), and how far the fast surface is from the sample path's:
//! on the paper's loop (exhaustive grid, step 0.1) and on every plant CSV of a directory.
//!
//! `cargo run --release -p grid-search --example fallbacks [-- DIR]`
#![allow(clippy::unwrap_used, clippy::print_stdout)]

use datasets::simulate::Scenario;
use datasets::{read_csv_path, ReadOptions};
use grid_search::{quantify_with, GridPlan, NodePath, Problem, Quantification, SearchOptions};
use linear_id::find_identifier;
use stiction_models::{find_model, Kano};

fn max_rel_diff(a: &Quantification, b: &Quantification) -> f64 {
    let mut worst = 0.0f64;
    for (x, y) in a.surface.iter().zip(&b.surface) {
        if let (Ok(f), Ok(g)) = (&x.outcome, &y.outcome) {
            for (p, q) in [
                (f.pred_id, g.pred_id),
                (f.pred_val, g.pred_val),
                (f.sim_id, g.sim_id),
                (f.sim_val, g.sim_val),
            ] {
                if p != q {
                    worst = worst.max((p - q).abs() / p.abs().max(1.0));
                }
            }
        }
    }
    worst
}

fn run(name: &str, op: &[f64], pv: &[f64], plan: GridPlan) {
    let arx = (find_identifier("arx").unwrap().build)(&[]).unwrap();
    let opts = SearchOptions {
        grid: plan,
        ..SearchOptions::default()
    };
    let problem = Problem { op, pv, mv: None };
    for model in ["kano", "he"] {
        let entry = find_model(model).unwrap();
        let fast = quantify_with(entry, arx.as_ref(), problem, &opts, None, NodePath::Fast);
        let slow = quantify_with(entry, arx.as_ref(), problem, &opts, None, NodePath::Sample);
        match (fast, slow) {
            (Ok(f), Ok(s)) => println!(
                "{name} {model}: {} nodes, ARX from sums {}, QR fallback {} ({:.2} %), best same: {}, max rel. fit diff {:.1e}, {:.0} ms vs {:.0} ms",
                f.surface.len(),
                f.arx_from_sums[0],
                f.arx_from_sums[1],
                100.0 * f.arx_from_sums[1] as f64
                    / (f.arx_from_sums[0] + f.arx_from_sums[1]).max(1) as f64,
                f.stiction.param_values() == s.stiction.param_values() && f.fits == s.fits,
                max_rel_diff(&f, &s),
                f.elapsed_ms,
                s.elapsed_ms,
            ),
            (f, s) => println!(
                "{name} {model}: fast {:?} / sample {:?}",
                f.err().map(|e| e.to_string()),
                s.err().map(|e| e.to_string())
            ),
        }
    }
}

fn main() {
    let sim = Scenario {
        valve: Box::new(Kano::params().s(9.0).j(3.0).check().unwrap()),
        ..Scenario::default()
    }
    .simulate()
    .unwrap();
    run(
        "paper",
        &sim.op,
        &sim.pv,
        GridPlan::Exhaustive { step: 0.1 },
    );
    let dir = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "/work/shared/data/plant".into());
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!("no plant data in {dir}");
        return;
    };
    let mut files: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    files.sort();
    for f in files {
        let Ok(d) = read_csv_path(&f, &ReadOptions::default()) else {
            continue;
        };
        let Some(pv) = d.pv else { continue };
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        run(&name, &d.op, &pv, GridPlan::for_op(&d.op));
    }
}
