//! The repair estimate validated against the truth: each simulated loop has a healthy twin,
//! simulated with the same seed (the same set point and noise) and a free valve. The predicted
//! `reduction` (from the record alone: quantify kano × arx, then the identified loop replayed)
//! must come within 0.10 of the twin's true one on at least 90 % of the sticky loops, and
//! stay under 0.05 on the healthy ones.

#![allow(clippy::unwrap_used)]

use datasets::simulate::Scenario;
use run::Combination;

/// The twin population: two plants, a range of tunings and valves, several seeds.
fn population() -> Vec<(String, Scenario)> {
    let mut out = Vec::new();
    let valves = [(1.0, 0.0), (2.0, 0.5), (3.0, 1.0), (5.0, 2.0), (8.0, 3.0)];
    let mut seed = 100;
    for plant in ["paper", "slow"] {
        for (kc, ki) in [(0.5, 0.5), (0.3, 0.1), (0.2, 0.2)] {
            for (s, j) in valves.into_iter().chain(valves) {
                seed += 1;
                let json = format!(
                    r#"{{"plant": "{plant}", "controller": {{"kc": {kc}, "ki": {ki}}},
                        "valve": {{"kind": "kano", "S": {s}, "J": {j}}},
                        "samples": 1500, "warmup": 300, "seed": {seed}, "sample_time": 5}}"#
                );
                let Ok(sc) = Scenario::from_json(&json) else {
                    continue;
                };
                // a tuning the simulator refuses for this plant is not part of the population
                if sc.simulate().is_ok() {
                    out.push((
                        format!("{plant} kc={kc} ki={ki} S={s} J={j} seed={seed}"),
                        sc,
                    ));
                }
            }
        }
    }
    out
}

fn twin_of(sc: &Scenario) -> Scenario {
    let mut t = sc.clone();
    t.valve = Box::new(
        stiction_models::Kano::params()
            .s(0.0)
            .j(0.0)
            .check()
            .unwrap(),
    );
    t
}

/// (predicted, true) reduction of one loop, or the reason there is no prediction.
fn predicted_and_true(sc: &Scenario) -> Result<(f64, f64), String> {
    let sim = sc.simulate().map_err(|e| e.to_string())?;
    let twin = twin_of(sc).simulate().map_err(|e| e.to_string())?;
    let mut d = sim.to_loop_data();
    d.mv = None; // the valve position is not logged
    let fitted = Combination::paper()
        .unwrap()
        .run(run::problem(&d).unwrap(), None)
        .map_err(|e| e.to_string())?;
    let r = fitted.repair(&d, false).map_err(|e| e.to_string())?;
    let from = d.len() - r.samples;
    let truth = (1.0 - twin.error_std(from) / sim.error_std(from)).clamp(0.0, 1.0);
    Ok((r.reduction, truth))
}

#[test]
fn predicted_reduction_matches_the_healthy_twin() {
    let pop = population();
    assert!(pop.len() >= 20, "population of {}", pop.len());
    let (mut within, mut total) = (0, 0);
    let mut lines = Vec::new();
    for (name, sc) in &pop {
        total += 1;
        match predicted_and_true(sc) {
            Ok((p, t)) => {
                let ok = (p - t).abs() <= 0.10;
                within += usize::from(ok);
                lines.push(format!(
                    "{name}: predicted {p:.3}, twin {t:.3}{}",
                    if ok { "" } else { "  <-- off" }
                ));
            }
            Err(e) => lines.push(format!("{name}: no prediction: {e}")),
        }
    }
    println!("{}", lines.join("\n"));
    println!("sticky loops within 0.10 of the twin: {within} of {total}");
    assert!(
        within as f64 >= 0.9 * total as f64,
        "{within} of {total} within 0.10:\n{}",
        lines.join("\n")
    );
}

#[test]
fn a_healthy_loop_gets_no_reduction() {
    let (mut below, mut seen) = (0, 0);
    let mut lines = Vec::new();
    for (name, sc) in &population() {
        let sim = twin_of(sc).simulate().unwrap();
        let mut d = sim.to_loop_data();
        d.mv = None;
        let fitted = Combination::paper()
            .unwrap()
            .run(run::problem(&d).unwrap(), None)
            .unwrap();
        match fitted.repair(&d, false) {
            Ok(r) => {
                seen += 1;
                below += usize::from(r.reduction < 0.05);
                if r.reduction >= 0.05 {
                    lines.push(format!(
                        "{name} (healthy twin): reduction {:.3} at S = {:.2}",
                        r.reduction, fitted.result.s
                    ));
                }
            }
            Err(e) => lines.push(format!("{name} (healthy twin): no prediction: {e}")),
        }
    }
    println!("{}", lines.join("\n"));
    println!("healthy loops with a reduction under 0.05: {below} of {seen}");
    assert!(seen >= 50, "only {seen} healthy loops got a prediction");
    assert!(
        below as f64 >= 0.9 * seen as f64,
        "{below} of {seen}:\n{}",
        lines.join("\n")
    );
}

/// An integrating (level-like) loop: the model maps MV to ΔPV, the runs integrate it.
#[test]
fn an_integrating_loop_is_replayed_on_its_increments() {
    let (mut within, mut total) = (0, 0);
    let mut lines = Vec::new();
    for (k, (s, j)) in [
        (1.0, 0.3),
        (2.0, 0.5),
        (3.0, 1.0),
        (4.0, 1.0),
        (6.0, 2.0),
        (2.5, 0.0),
    ]
    .into_iter()
    .enumerate()
    {
        let json = format!(
            r#"{{"plant": {{"a": [1, -1.6, 0.6], "b": [0, 0.05, 0.03], "c": [1, 0.2], "delay": 0}},
                "controller": {{"kc": 0.8, "ki": 0.02}},
                "valve": {{"kind": "kano", "S": {s}, "J": {j}}},
                "samples": 2000, "warmup": 500, "seed": {}, "sample_time": 5}}"#,
            700 + k
        );
        let sc = Scenario::from_json(&json).unwrap();
        let sim = sc.simulate().unwrap();
        let twin = twin_of(&sc).simulate().unwrap();
        let mut d = sim.to_loop_data();
        d.mv = None;
        let used = monitoring::registration::increments(&d);
        let fitted = Combination::paper()
            .unwrap()
            .run(run::problem(&used).unwrap(), None)
            .unwrap();
        total += 1;
        match fitted.repair(&d, true) {
            Ok(r) => {
                let from = d.len() - r.samples;
                let truth = (1.0 - twin.error_std(from) / sim.error_std(from)).clamp(0.0, 1.0);
                let ok = (r.reduction - truth).abs() <= 0.10;
                within += usize::from(ok);
                lines.push(format!(
                    "S={s} J={j}: predicted {:.3}, twin {truth:.3} (fitted S {:.2})",
                    r.reduction, fitted.result.s
                ));
            }
            Err(e) => lines.push(format!("S={s} J={j}: no prediction: {e}")),
        }
    }
    println!("{}", lines.join("\n"));
    assert!(
        within + 1 >= total,
        "{within} of {total}:\n{}",
        lines.join("\n")
    );
}
