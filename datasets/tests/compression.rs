//! Historian compression read back by linear interpolation is recognised (`compression`), a
//! measured (noisy) PV is not, and the reader says so in its notes.

use datasets::simulate::{swinging_door, Scenario};
use datasets::{compression, read_csv, NoteKind, ReadOptions};

/// A swinging-door archive of `x` read back by interpolation, optionally rounded to
/// `decimals`.
fn archive(x: &[f64], dev: f64, decimals: Option<i32>) -> (Vec<f64>, usize) {
    let (mut out, kept) = swinging_door(x, dev);
    if let Some(d) = decimals {
        let q = 10f64.powi(d);
        out.iter_mut().for_each(|v| *v = (*v * q).round() / q);
    }
    (out, kept)
}

fn paper_loop(noise: f64, seed: u64) -> Vec<f64> {
    Scenario {
        noise_sigma: noise,
        seed,
        ..Scenario::default()
    }
    .simulate()
    .expect("test data")
    .pv
}

#[test]
fn a_measured_pv_is_not_compressed() {
    for seed in 1..=5 {
        for noise in [0.02, 0.1, 0.5] {
            let pv = paper_loop(noise, seed);
            let c = compression(&pv).expect("test data");
            assert!(!c.detected(), "noise {noise} seed {seed}: {c:?}");
            // written with three decimals, as a historian exports it
            let rounded: Vec<f64> = pv.iter().map(|v| (v * 1e3).round() / 1e3).collect();
            let c = compression(&rounded).expect("test data");
            assert!(!c.detected(), "rounded, noise {noise} seed {seed}: {c:?}");
        }
    }
}

/// Every archive that keeps at most a third of the samples (the compression that changes what
/// a fit sees) is recognised.
#[test]
fn an_archive_read_back_is_compressed() {
    let mut checked = 0;
    for seed in 1..=5 {
        let pv = paper_loop(0.1, seed);
        let span = pv.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - pv.iter().cloned().fold(f64::INFINITY, f64::min);
        for frac in [0.01, 0.03, 0.1] {
            for decimals in [None, Some(3)] {
                let (x, kept) = archive(&pv, frac * span, decimals);
                let c = compression(&x).expect("test data");
                if 3 * kept > x.len() {
                    // a band within the noise keeps most samples: nothing to correct for
                    println!("deviation {frac}: {kept} kept points of {}: {c:?}", x.len());
                    continue;
                }
                assert!(
                    c.detected(),
                    "deviation {frac} of the span, {decimals:?} decimals, {kept} kept points, seed {seed}: {c:?}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 15, "only {checked} archives compress to a third");
}

#[test]
fn the_reader_notes_it() {
    let pv = paper_loop(0.1, 1);
    let op = Scenario::default().simulate().expect("test data").op;
    let span = 6.0;
    let (x, _) = archive(&pv, 0.03 * span, Some(3));
    let mut text = String::from("PV,OP\n");
    for (p, o) in x.iter().zip(&op) {
        text.push_str(&format!("{p},{o}\n"));
    }
    let d = read_csv(text.as_bytes(), "archive.csv", &ReadOptions::default()).expect("test data");
    let note = d
        .notes
        .iter()
        .find(|n| n.kind == NoteKind::Compression)
        .expect("a compression note");
    assert!(note.to_string().starts_with("column PV: "), "{note}");
    // the measured PV of the same loop gets no such note
    let mut text = String::from("PV,OP\n");
    for (p, o) in pv.iter().zip(&op) {
        text.push_str(&format!("{p},{o}\n"));
    }
    let d = read_csv(text.as_bytes(), "loop.csv", &ReadOptions::default()).expect("test data");
    assert!(d.notes.iter().all(|n| n.kind != NoteKind::Compression));
}

/// The shared plant registrations are measured values: none may be called compressed (the
/// share of straight samples is printed per file).
#[test]
fn plant_registrations() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/plant");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!("skipped: {} not found", dir.display());
        return;
    };
    let mut files: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv") && !p.ends_with("labels.csv"))
        .collect();
    files.sort();
    let mut flagged = 0;
    for f in &files {
        if let Ok(d) = datasets::read_csv_path(f, &ReadOptions::default()) {
            for n in d.notes.iter().filter(|n| n.kind == NoteKind::Compression) {
                flagged += 1;
                println!(
                    "{}: {n}",
                    f.file_name().expect("test data").to_string_lossy()
                );
            }
            for (name, x) in [("PV", d.pv.as_deref().unwrap_or(&[])), ("OP", &d.op[..])] {
                if let Some(c) = compression(x) {
                    println!(
                        "  {} {name}: {:.1} % straight, {} segments",
                        f.file_name().expect("test data").to_string_lossy(),
                        100.0 * c.share,
                        c.segments
                    );
                }
            }
        }
    }
    println!("{flagged} compression notes over {} files", files.len());
    assert_eq!(
        flagged, 0,
        "a measured plant registration was called compressed"
    );
}
