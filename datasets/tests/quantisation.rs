//! The reader notes PV and OP written on a lattice coarse relative to their motion
//! (`datasets::quantisation`), and nothing for values as the simulator computes them.
#![allow(clippy::unwrap_used)]

use datasets::simulate::Scenario;
use datasets::{quantisation, read_csv, NoteKind, ReadOptions};

fn read(pv: &[String], op: &[String]) -> datasets::LoopData {
    let mut text = String::from("PV,OP\n");
    for (p, o) in pv.iter().zip(op) {
        text.push_str(&format!("{p},{o}\n"));
    }
    read_csv(text.as_bytes(), "loop.csv", &ReadOptions::default()).unwrap()
}

#[test]
fn op_in_counts_and_pv_to_decimals_are_noted() {
    let sim = Scenario::default().simulate().unwrap();
    let plain = |x: &[f64]| x.iter().map(|v| format!("{v}")).collect::<Vec<_>>();
    let d = read(&plain(&sim.pv), &plain(&sim.op));
    assert!(
        d.notes.iter().all(|n| n.kind != NoteKind::Quantised),
        "{:?}",
        d.notes
    );
    assert_eq!(quantisation::step(&d.op), None);
    // OP as 12-bit counts (read back in % of 0-4095), PV to one decimal
    let counts: Vec<String> = sim
        .op
        .iter()
        .map(|v| format!("{}", (v / 100.0 * 4095.0).round()))
        .collect();
    let tenths: Vec<String> = sim.pv.iter().map(|v| format!("{v:.1}")).collect();
    let d = read(&tenths, &counts);
    let noted: Vec<String> = d
        .notes
        .iter()
        .filter(|n| n.kind == NoteKind::Quantised)
        .map(|n| n.to_string())
        .collect();
    assert_eq!(noted.len(), 2, "{noted:?}");
    assert!(
        noted[0].starts_with("column PV: values on a lattice of step 0.1 ("),
        "{noted:?}"
    );
    assert!(
        noted[1].starts_with("column OP: values on a lattice of step 1 ("),
        "{noted:?}"
    );
    // the step after the reader's rescaling of the counts to %
    let q = quantisation::step(&d.op).unwrap();
    assert!((q / (100.0 / 4095.0) - 1.0).abs() < 1e-9, "{q}");
}
