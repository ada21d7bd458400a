//! The detector on the shared plant registrations (`../shared/data/plant`, skipped with a
//! printed reason when absent): a test set, measured and printed, never a target. The test
//! checks that every registration is read as `stiction detect` reads it and gets a score and
//! a verdict; it holds no
//! threshold on the figures (choosing the detector by them would fit it to two sticky valves).
//!
//! The labels are used only as the answer; the detector reads the time series (and, as the
//! CLI's `--integrating auto`, decides the loop kind from the record, the tag letter `L`
//! breaking a tie).
#![allow(clippy::unwrap_used)]

mod common;
use common::{auc, detect_read};

use std::path::Path;

use detection::Verdict;

#[test]
fn every_plant_registration_is_scored_and_its_figures_printed() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/plant");
    let Ok(labels) = std::fs::read_to_string(dir.join("labels.csv")) else {
        println!("skipped: {} not found", dir.join("labels.csv").display());
        return;
    };
    let mut scored: Vec<(f64, bool)> = Vec::new();
    let (mut right, mut conclusive, mut inconclusive) = (0usize, 0usize, 0usize);
    for line in labels.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        let (file, label) = (cols[0], cols[6]);
        let sticky = label == "stiction";
        // Read as `stiction detect` reads: a constant or mostly flat PV or OP (FIC10112's
        // frozen PV) is evidence the detector answers, and every registration is answered.
        let read = datasets::ReadOptions {
            accept_constant: true,
            ..datasets::ReadOptions::default()
        };
        let d = datasets::read_path(dir.join(file), &read)
            .unwrap_or_else(|e| panic!("{file}: not read as `stiction detect` reads it: {e}"));
        let det = detect_read(&d, file);
        assert!(
            (0.0..=1.0).contains(&det.score),
            "{file}: score {}",
            det.score
        );
        println!("{file}: {label}, score {:.2}, {}", det.score, det.verdict);
        scored.push((det.score, sticky));
        match det.verdict {
            Verdict::Inconclusive => inconclusive += 1,
            v => {
                conclusive += 1;
                if (v == Verdict::Stiction) == sticky {
                    right += 1;
                }
            }
        }
    }
    let n = scored.len();
    let a = auc(&scored);
    let right_share = right as f64 / conclusive as f64;
    let inconclusive_share = inconclusive as f64 / n as f64;
    println!(
        "{n} registrations: ROC AUC {a:.3}, right on {:.1} % of the {conclusive} conclusive, {:.1} % inconclusive",
        100.0 * right_share,
        100.0 * inconclusive_share
    );
    assert_eq!(n, 49, "every one of the 49 registrations is answered");
}
