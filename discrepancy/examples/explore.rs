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
        Effect::Characteristic,
        Effect::DisturbanceDelay,
        Effect::DisturbanceAsymmetric,
        Effect::DelayAsymmetric,
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
            if std::env::var_os("TIMES").is_some() {
                for f in d.findings.iter() {
                    println!(
                        "  round 1 {} {:.0} ms",
                        f.cause,
                        f.fitted.as_ref().map_or(f64::NAN, |x| x.elapsed_ms)
                    );
                }
                for (k, st) in d.steps.iter().enumerate() {
                    for f in st {
                        println!(
                            "  step {} {} {:.0} ms",
                            k + 1,
                            f.cause,
                            f.fitted.as_ref().map_or(f64::NAN, |x| x.elapsed_ms)
                        );
                    }
                }
            }
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
                e, c.plant, c.s, c.j, d.causes.join("+"), d.baseline.s, f.join(" "), c.what, d.elapsed_ms / 1e3);
            if std::env::var_os("EXPLORE_STEPS").is_some() {
                let ms = |f: &discrepancy::Finding| {
                    let a = f
                        .fitted
                        .as_ref()
                        .filter(|x| x.stiction.name == "kano-char")
                        .map(|x| x.result.stiction.param_values()[2]);
                    let t = f.fitted.as_ref().map_or(0.0, |x| x.elapsed_ms);
                    match a {
                        Some(a) => format!(
                            "{t:.0} (a {a:+.2}, gain ratio {:.2})",
                            common::gain_ratio(a, &c.sim.op)
                        ),
                        None => format!("{t:.0}"),
                    }
                };
                let first: Vec<String> = d
                    .findings
                    .iter()
                    .map(|f| format!("{} {} ms", f.cause, ms(f)))
                    .collect();
                println!("    first round: {}", first.join(", "));
                for (k, step) in d.steps.iter().enumerate() {
                    let v: Vec<String> = step
                        .iter()
                        .map(|f| format!("{} LR {:.0} {} ms", f.cause, f.lr, ms(f)))
                        .collect();
                    println!("    step {k}: {}", v.join(", "));
                    for f in step {
                        if let Some(x) = &f.fitted {
                            println!(
                                "      {} -> {} + {} delay {} params {:?} fit {:.3}",
                                f.cause,
                                x.stiction.name,
                                x.linear,
                                x.delay,
                                x.result.stiction.param_values(),
                                x.fit_val()
                            );
                        }
                    }
                }
                println!(
                    "    final S {:.2}",
                    d.final_fit().map_or(d.baseline.s, |f| f.result.s)
                );
            }
        }
    }
}
