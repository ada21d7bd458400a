//! Calibration tool for the hidden-effect suite: runs `diagnose` on generated loops and prints
//! one line per loop (truth, cause found, LR of every finding, S estimates).
//! `cargo run --release -p discrepancy --example explore -- N [effect-prefix] [first-seed]`
#![allow(missing_docs, clippy::unwrap_used)]
#[path = "../tests/common/mod.rs"]
mod common;
use common::{case, Effect};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: u64 = args.get(1).map_or(4, |s| s.parse().unwrap());
    let all = [
        Effect::Clean,
        Effect::Disturbance,
        Effect::Asymmetric,
        Effect::Delay,
        Effect::Oscillation,
    ];
    let effects: Vec<Effect> = match args.get(2) {
        Some(w) if w != "all" => all
            .iter()
            .copied()
            .filter(|e| format!("{e:?}").to_lowercase().starts_with(w.as_str()))
            .collect(),
        _ => all.to_vec(),
    };
    let first: u64 = args.get(3).map_or(0, |s| s.parse().unwrap());
    for &e in &effects {
        for seed in first..first + n {
            let c = case(seed, e, 3000);
            let disabled: Vec<String> = std::env::var("STICTION_SUITE_DISABLE")
                .ok()
                .map(|s| s.split(',').map(str::to_string).collect())
                .unwrap_or_default();
            let d = c.diagnose(&disabled);
            let ok = if d.cause == e.cause() { "OK " } else { "BAD" };
            let f: Vec<String> = d
                .findings
                .iter()
                .map(|f| {
                    format!(
                        "{}:{:.0}/{:.0}(st {:.1}, S {:.2})",
                        f.cause,
                        f.lr,
                        f.threshold,
                        f.statistic,
                        f.extended.as_ref().map_or(f64::NAN, |x| x.s)
                    )
                })
                .collect();
            println!("{ok} {:?} {seed} {} true S {:.2} J {:.2} | found {} | base S {:.2} | {} | {} | {:.1}s",
                e, c.plant, c.s, c.j, d.cause, d.baseline.s, f.join(" "), c.what, d.elapsed_ms / 1e3);
        }
    }
}
