//! Every registration in `../shared/data/plant` is diagnosed without error, or refused with a
//! clear one-line reason (the bad-data valve). Skips with a printed reason when the data is
//! absent.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use datasets::{read_csv_path, ReadOptions};
use discrepancy::{diagnose, Baseline, DiagnoseOptions};
use grid_search::Problem;

#[test]
fn plant_registrations_are_diagnosed_or_refused_clearly() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/plant");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!("skipped: {} not found", dir.display());
        return;
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().is_some_and(|x| x == "csv")
                && p.file_name().is_some_and(|n| n != "labels.csv")
        })
        .collect();
    files.sort();
    let limit: usize = std::env::var("STICTION_PLANT_LIMIT")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(usize::MAX);
    let (mut ok, mut refused) = (0, 0);
    // (valve, registration, diagnosis): the valve is the file name before its last '_'
    let mut diagnosed: Vec<(String, String, discrepancy::Diagnosis)> = Vec::new();
    for path in files.iter().take(limit) {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let data = match read_csv_path(path.clone(), &ReadOptions::default()) {
            Ok(d) => d,
            Err(e) => {
                let msg = e.to_string();
                assert!(!msg.contains('\n') && !msg.is_empty(), "{name}: {msg}");
                println!("{name}: refused by the reader: {msg}");
                refused += 1;
                continue;
            }
        };
        let pv = data.require_pv().unwrap();
        let span = data.op.iter().cloned().fold(f64::MIN, f64::max)
            - data.op.iter().cloned().fold(f64::MAX, f64::min);
        let problem = Problem {
            op: &data.op,
            pv,
            mv: data.mv.as_deref(),
        };
        match diagnose(
            problem,
            &Baseline::paper().unwrap(),
            &DiagnoseOptions::for_span(span),
        ) {
            Ok(d) => {
                ok += 1;
                let ext = d
                    .chosen
                    .and_then(|i| d.findings[i].extended.as_ref())
                    .map_or("-".to_string(), |x| format!("{:.2}", x.s));
                let open = d
                    .findings
                    .iter()
                    .find(|f| f.cause == discrepancy::UNEXPLAINED)
                    .map_or("not run".to_string(), |f| format!("{:.1}", f.lr));
                println!(
                    "{name}: causes {:?} | baseline S {:.2} J {:.2} F_PV val {:.2} | extended S {ext} | gain {:+.2} | open-set LR {open} | {:.1} s",
                    d.causes,
                    d.baseline.s,
                    d.baseline.j,
                    d.baseline.fit_pv_val,
                    d.gain_fit_pv_val,
                    d.elapsed_ms / 1e3
                );
                let stem = name.trim_end_matches(".csv").to_string();
                let valve = stem
                    .rsplit_once('_')
                    .map_or(stem.clone(), |(v, _)| v.to_string());
                diagnosed.push((valve, stem, d));
            }
            Err(e) => {
                let msg = e.to_string();
                assert!(!msg.contains('\n') && !msg.is_empty(), "{name}: {msg}");
                println!("{name}: refused: {msg}");
                refused += 1;
            }
        }
    }
    println!("{ok} diagnosed, {refused} refused");
    // per valve, the causes that hold on most of its registrations
    let mut valves: Vec<&str> = diagnosed.iter().map(|(v, _, _)| v.as_str()).collect();
    valves.dedup();
    for valve in valves {
        let regs: Vec<(&str, &discrepancy::Diagnosis)> = diagnosed
            .iter()
            .filter(|(v, _, _)| v == valve)
            .map(|(_, r, d)| (r.as_str(), d))
            .collect();
        let c = discrepancy::consensus(&regs);
        println!(
            "valve {valve} ({} registrations): causes on most {:?}; {} disagree",
            c.registrations,
            c.causes,
            c.disagreeing.len()
        );
        for d in &c.disagreeing {
            println!("   {} {:?}: {}", d.label, d.causes, d.why.join("; "));
        }
    }
    assert!(ok > 0);
}
