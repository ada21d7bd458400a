//! Calibration tool for the open set (docs/DIAGNOSE.md, item 6): N loops of each effect of
//! the hidden-effect generator through `diagnose`, with the open-set check's likelihood ratio
//! (`unexplained`'s finding: the final model identified on the last third of its
//! identification window against the whole window, the valve from its best initial state)
//! and the sample `k₀` from which the final valve's In.3 estimate holds.
//! `cargo run --release -p discrepancy --example probe -- N` (`ONLY=ProcessChange` for one
//! effect).
#![allow(missing_docs, clippy::unwrap_used)]
#[path = "../tests/common/mod.rs"]
mod common;
use common::{case, Effect};

fn main() {
    let n: u64 = std::env::args().nth(1).map_or(4, |s| s.parse().unwrap());
    let only = std::env::var("ONLY").ok();
    for e in [
        Effect::Clean,
        Effect::Disturbance,
        Effect::Delay,
        Effect::Asymmetric,
        Effect::Characteristic,
        Effect::Oscillation,
        Effect::Order,
        Effect::ProcessChange,
    ] {
        if only.as_deref().is_some_and(|o| format!("{e:?}") != o) {
            continue;
        }
        let mut lrs = Vec::new();
        // the extra-lag generator draws loops that the PI loop cannot hold from seed 6 on
        let n = if e == Effect::Order { n.min(6) } else { n };
        for seed in 0..n {
            let c = case(seed, e, 3000);
            let d = c.diagnose(&[]);
            let f = d.final_fit().unwrap_or(&d.baseline_fit);
            let lr = d
                .findings
                .iter()
                .find(|f| f.cause == discrepancy::UNEXPLAINED)
                .map_or(f64::NAN, |f| f.lr);
            lrs.push(lr);
            println!(
                "{e:?} seed {seed}: causes {:?} final {} + {} | k0 {} | open-set LR {lr:.1} | {}",
                d.causes, f.stiction.name, f.linear, f.result.fits.valid_from, c.what
            );
        }
        lrs.sort_by(f64::total_cmp);
        let shown: Vec<String> = lrs.iter().map(|v| format!("{v:.0}")).collect();
        println!("{e:?}: open-set LR sorted: {}", shown.join(" "));
    }
}
