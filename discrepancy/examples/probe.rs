//! Calibration tool for the open set (docs/DIAGNOSE.md, item 6): the likelihood ratios of
//! generic probes on the final model of `diagnose`, N loops of each effect of the hidden-effect
//! generator: ARX orders +2 each ("dynamics"), and the final model identified again on the last
//! half / third of its identification window ("recent"; `open_set` uses the third).
//! `cargo run --release -p discrepancy --example probe -- N`
#![allow(missing_docs, clippy::unwrap_used)]
#[path = "../tests/common/mod.rs"]
mod common;
use common::{case, Effect};
use linear_id::{find_identifier, OrderValue};

fn sse(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

fn main() {
    let n: u64 = std::env::args().nth(1).map_or(4, |s| s.parse().unwrap());
    for e in [
        Effect::Clean,
        Effect::Disturbance,
        Effect::Delay,
        Effect::Asymmetric,
        Effect::Characteristic,
        Effect::Order,
        Effect::ProcessChange,
    ] {
        for seed in 0..n {
            let c = case(seed, e, 3000);
            let d = c.diagnose(&[]);
            let probes = |f: &discrepancy::Fitted| -> (f64, f64, f64) {
                let q = &f.result;
                let (pv, mv) = (&c.sim.pv, &q.mv_est);
                let (k0, ni, len) = (q.fits.valid_from, q.split_index, pv.len());
                let nval = (len - ni) as f64;
                let base_sse = sse(&q.pv_pred[ni..], &pv[ni..]);
                let entry = find_identifier(f.linear).unwrap();
                let orders: Vec<(String, OrderValue)> = f
                    .identifier
                    .orders()
                    .into_iter()
                    .map(|(k, v)| (k.to_string(), v))
                    .collect();
                let bumped: Vec<(String, OrderValue)> = orders
                    .iter()
                    .map(|(k, v)| match (k.as_str(), v) {
                        ("n" | "m" | "p", OrderValue::Int(i)) => {
                            (k.clone(), OrderValue::Int(i + 2))
                        }
                        _ => (k.clone(), *v),
                    })
                    .collect();
                let probe = |ords: &[(String, OrderValue)], from: usize| -> f64 {
                    let id = monitoring::build_identifier(entry, ords, f.delay).unwrap();
                    match id.identify(&mv[from..ni], &pv[from..ni]) {
                        Ok(fit) => {
                            let pred = fit.predict_one_step(&mv[from..], &pv[from..]).unwrap();
                            let s = sse(&pred[ni - from..], &pv[ni..]);
                            nval * (base_sse / s).ln()
                        }
                        Err(_) => f64::NAN,
                    }
                };
                let lr_dyn = probe(&bumped, k0);
                let lr_recent = probe(&orders, (k0 + ni) / 2);
                let lr_third = probe(&orders, k0 + 2 * (ni - k0) / 3);
                (lr_dyn, lr_recent, lr_third)
            };
            let f = d.final_fit().unwrap_or(&d.baseline_fit);
            let (lr_dyn, lr_recent, lr_third) = probes(f);
            println!(
                "{e:?} seed {seed}: causes {:?} final {} + {} | LR dynamics(+2) {lr_dyn:.1} | LR recent half {lr_recent:.1} | LR recent third {lr_third:.1} | LB Q {:.0}",
                d.causes, f.stiction.name, f.linear, d.residuals.ljung_box_q
            );
        }
    }
}
