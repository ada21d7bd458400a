//! Calibration tool for quantised OP and PV (docs/HOSTILE_INPUT.md, quantisation): suite loops
//! (clean and asymmetric valves) through `diagnose` with OP and PV as the simulator wrote them
//! and rounded as a DCS or a transmitter writes them, with the asymmetric cause's likelihood
//! ratio and fitted valve.
//! `cargo run --release -p discrepancy --example quantisation -- N` (`ONLY=Clean` for one
//! effect, `MODES=op14,pv001` for some roundings).
#![allow(missing_docs, clippy::unwrap_used)]
#[path = "../tests/common/mod.rs"]
mod common;
use common::{case, Effect};

/// Round `x` to the lattice `step` (a value as a DCS writes it, read back in % or PV units).
fn round_to(x: &[f64], step: f64) -> Vec<f64> {
    x.iter().map(|v| (v / step).round() * step).collect()
}

fn main() {
    let n: u64 = std::env::args().nth(1).map_or(4, |s| s.parse().unwrap());
    let first: u64 = std::env::args().nth(2).map_or(0, |s| s.parse().unwrap());
    let only = std::env::var("ONLY").ok();
    let modes = std::env::var("MODES").unwrap_or_else(|_| "raw,op14,op12,op01,pv001,pv12".into());
    for e in [
        Effect::Clean,
        Effect::Asymmetric,
        Effect::ProcessChange,
        Effect::Delay,
        Effect::Disturbance,
    ] {
        if only
            .as_deref()
            .is_some_and(|o| !o.split(',').any(|o| o == format!("{e:?}")))
        {
            continue;
        }
        for seed in first..first + n {
            let c = case(seed, e, 3000);
            for mode in modes.split(',') {
                let (op, pv) = match mode {
                    "raw" => (c.sim.op.clone(), c.sim.pv.clone()),
                    "op14" => (round_to(&c.sim.op, 100.0 / 16383.0), c.sim.pv.clone()),
                    "op12" => (round_to(&c.sim.op, 100.0 / 4095.0), c.sim.pv.clone()),
                    "op10" => (round_to(&c.sim.op, 100.0 / 1023.0), c.sim.pv.clone()),
                    "op01" => (round_to(&c.sim.op, 0.1), c.sim.pv.clone()),
                    "pv001" => (c.sim.op.clone(), round_to(&c.sim.pv, 0.01)),
                    "pv12" => (c.sim.op.clone(), round_to(&c.sim.pv, 100.0 / 4095.0)),
                    "pv01" => (c.sim.op.clone(), round_to(&c.sim.pv, 0.1)),
                    "both" => (
                        round_to(&c.sim.op, 100.0 / 16383.0),
                        round_to(&c.sim.pv, 0.01),
                    ),
                    m => panic!("unknown mode {m}"),
                };
                let problem = grid_search::Problem {
                    op: &op,
                    pv: &pv,
                    mv: None,
                };
                let span = op.iter().cloned().fold(f64::MIN, f64::max)
                    - op.iter().cloned().fold(f64::MAX, f64::min);
                let options = discrepancy::DiagnoseOptions::for_span(span);
                let baseline = discrepancy::Baseline::paper().unwrap();
                let d = match discrepancy::diagnose(problem, &baseline, &options) {
                    Ok(d) => d,
                    Err(err) => {
                        println!("{e:?} seed {seed} {mode}: error {err}");
                        continue;
                    }
                };
                let asym = d.findings.iter().find(|f| f.cause == "asymmetric-stiction");
                let (lr, params) = asym.map_or((f64::NAN, String::new()), |f| {
                    (
                        f.lr,
                        f.extended
                            .as_ref()
                            .map(|s| serde_json::to_string(&s.params).unwrap())
                            .unwrap_or_default(),
                    )
                });
                let others: Vec<String> = d
                    .findings
                    .iter()
                    .filter(|f| f.cause != "asymmetric-stiction" && f.lr.is_finite())
                    .map(|f| format!("{} {:.0}", f.cause, f.lr))
                    .collect();
                println!(
                    "{e:?} seed {seed} {mode}: causes {:?} | asym LR {lr:.1} {params} | {} | true S {:.2} J {:.2} {}",
                    d.causes,
                    others.join(", "),
                    c.s,
                    c.j,
                    c.what
                );
            }
        }
    }
}
