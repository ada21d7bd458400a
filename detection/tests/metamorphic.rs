//! The same verdict however the record was exported: the first half of the rows, the second
//! half, every second row, the means of each two rows (an average retrieval at twice the
//! interval), the file renamed without its tag letters, PV and SP in other units
//! (scaled and offset), OP as a fraction of travel. Each variant is written as CSV and read as
//! `stiction detect` reads it (the reader's units detection included) and judged as
//! `stiction detect --integrating auto` judges it (`monitoring::detect_file`: the loop kind
//! from the record, a level's tag letter `L` breaking a tie, and then a verdict only when both
//! kinds give it); a variant may be `inconclusive` on less data, never the opposite verdict.
//! Run on a simulated population (seeds of its own, never fitted on) and on the shared plant
//! registrations (`../shared/data/plant`, skipped with a printed reason when absent).
#![allow(clippy::unwrap_used)]

use std::path::Path;

use datasets::simulate::population::{Family, PopulationSpec};
use datasets::ReadOptions;
use detection::Verdict;
use monitoring::Integrating;

/// One record as exported: time (s), SP, PV, OP (% of travel).
struct Record {
    name: String,
    t: Vec<f64>,
    sp: Option<Vec<f64>>,
    pv: Vec<f64>,
    op: Vec<f64>,
}

/// The variants of a record: name, rows kept, PV/SP `a·x + b`, OP scale, file name.
fn variants(r: &Record) -> Vec<(&'static str, Record)> {
    let n = r.pv.len();
    let pick = |rows: Vec<usize>, scale: (f64, f64), op_scale: f64, name: String| Record {
        name,
        t: rows.iter().map(|&k| r.t[k]).collect(),
        sp: r
            .sp
            .as_ref()
            .map(|sp| rows.iter().map(|&k| scale.0 * sp[k] + scale.1).collect()),
        pv: rows.iter().map(|&k| scale.0 * r.pv[k] + scale.1).collect(),
        op: rows.iter().map(|&k| op_scale * r.op[k]).collect(),
    };
    let all: Vec<usize> = (0..n).collect();
    let bare: String = r
        .name
        .chars()
        .filter(|c| !c.is_ascii_alphabetic())
        .collect();
    let means =
        |x: &[f64]| -> Vec<f64> { x.chunks_exact(2).map(|c| 0.5 * (c[0] + c[1])).collect() };
    let averaged = Record {
        name: r.name.clone(),
        // each mean stamped at the end of its interval, as a historian stamps an average
        t: r.t.chunks_exact(2).map(|c| c[1]).collect(),
        sp: r.sp.as_deref().map(means),
        pv: means(&r.pv),
        op: means(&r.op),
    };
    vec![
        (
            "first half",
            pick((0..n / 2).collect(), (1.0, 0.0), 1.0, r.name.clone()),
        ),
        (
            "second half",
            pick((n / 2..n).collect(), (1.0, 0.0), 1.0, r.name.clone()),
        ),
        (
            "every second row",
            pick((0..n).step_by(2).collect(), (1.0, 0.0), 1.0, r.name.clone()),
        ),
        ("the means of each two rows", averaged),
        (
            "renamed without tag letters",
            pick(all.clone(), (1.0, 0.0), 1.0, format!("record{bare}")),
        ),
        (
            "PV and SP in other units",
            pick(all.clone(), (0.37, 120.0), 1.0, r.name.clone()),
        ),
        (
            "OP as a fraction",
            pick(all, (1.0, 0.0), 0.01, r.name.clone()),
        ),
    ]
}

/// The verdict `stiction detect` gives the record written as CSV and read back.
fn verdict(r: &Record) -> Result<(Verdict, String), String> {
    let mut csv = String::from(if r.sp.is_some() {
        "t,SP,PV,OP\n"
    } else {
        "t,PV,OP\n"
    });
    for k in 0..r.pv.len() {
        match &r.sp {
            Some(sp) => csv.push_str(&format!("{},{},{},{}\n", r.t[k], sp[k], r.pv[k], r.op[k])),
            None => csv.push_str(&format!("{},{},{}\n", r.t[k], r.pv[k], r.op[k])),
        }
    }
    let opts = ReadOptions {
        accept_constant: true,
        ..ReadOptions::default()
    };
    let d = datasets::read_csv(csv.as_bytes(), &r.name, &opts).map_err(|e| e.to_string())?;
    let view = monitoring::detect_file(&d, Some(Path::new(&r.name)), Integrating::Auto);
    let det = view
        .detected
        .detection()
        .ok_or_else(|| view.detected.reason())?;
    Ok((
        det.verdict,
        format!("score {:.2}: {}", det.score, det.reason),
    ))
}

/// Flips (`stiction` ↔ `no-stiction`) and unread variants over `records`, printed: `(flips,
/// unread, runs)`.
fn flips(records: &[Record]) -> (usize, usize, usize) {
    let (mut flipped, mut unread, mut runs) = (0, 0, 0);
    for r in records {
        let Ok((base, why)) = verdict(r) else {
            continue;
        };
        for (what, v) in variants(r) {
            runs += 1;
            match verdict(&v) {
                Err(e) => {
                    unread += 1;
                    println!("{}, {what}: not read: {e}", r.name);
                }
                Ok((got, got_why)) => {
                    if matches!(
                        (base, got),
                        (Verdict::Stiction, Verdict::NoStiction)
                            | (Verdict::NoStiction, Verdict::Stiction)
                    ) {
                        flipped += 1;
                        println!("{}, {what}: {base} ({why}) -> {got} ({got_why})", r.name);
                    }
                }
            }
        }
    }
    println!("{runs} variant runs: {flipped} flips, {unread} not read");
    (flipped, unread, runs)
}

/// The population of the simulated checks: seeds of its own, `Ts` 1-60 s, 400-2000 rows.
fn population() -> PopulationSpec {
    PopulationSpec {
        seed: 9_100_003,
        families: vec![
            Family::Flow,
            Family::Pressure,
            Family::Level,
            Family::Composition,
        ],
        sample_time: [1.0, 60.0],
        samples: [400, 2000],
        ..PopulationSpec::default()
    }
}

/// The stick-slip test's first window (before any doubling) in seconds, with the record's
/// rows and whether the loop oscillates regularly.
fn stick_slip_window(
    l: &datasets::simulate::population::PopulationLoop,
    every: usize,
) -> Option<(f64, usize, bool)> {
    let thin = |x: &[f64]| -> Vec<f64> { x.iter().step_by(every).copied().collect() };
    let (sp, pv, op) = (thin(&l.sim.sp), thin(&l.sim.pv), thin(&l.sim.op));
    let ts = l.sample_time * every as f64;
    let reg = detection::Registration::new(&pv, &op, ts)
        .ok()?
        .integrating(l.integrating)
        .with_sp(&sp)
        .ok()?;
    let regular = reg.oscillation().ok()?.is_regular();
    let t = detection::run_all(&reg)
        .into_iter()
        .find(|t| t.name == "stick-slip")?;
    Some((t.value("first_window")? * ts, pv.len(), regular))
}

/// The stick-slip test's windows are in the loop's own time: a simulated loop and its every
/// second row (the same loop logged at twice the sampling time) get first windows of the same
/// duration (three in four within one sample of the thinned record, none more than a fifth
/// apart), wherever neither window sits on a bound
/// of what its record resolves (5 samples, a twentieth of the rows) and both records agree on
/// whether the loop oscillates regularly (an eighth of the period then, a share of OP's
/// correlation time otherwise). A window counted in samples (10 samples whatever the
/// sampling) fails it: the thinned record's window is twice as long in time.
#[test]
fn the_stick_slip_window_is_the_same_time_at_half_the_sampling() {
    let spec = population();
    let (mut compared, mut within, mut worst) = (0, 0, 0.0_f64);
    for i in 0..48 {
        let l = spec.generate(i).unwrap();
        let (Some((fine, n, r1)), Some((coarse, n2, r2))) =
            (stick_slip_window(&l, 1), stick_slip_window(&l, 2))
        else {
            continue;
        };
        let ts2 = 2.0 * l.sample_time;
        let bound = |w: f64, rows: usize, ts: f64| {
            let samples = (w / ts).round() as usize;
            samples <= 5 || samples >= rows / 20
        };
        if r1 != r2 || bound(fine, n, l.sample_time) || bound(coarse, n2, ts2) {
            continue;
        }
        compared += 1;
        let gap = (fine - coarse).abs();
        let ok = gap <= ts2 + 1e-9;
        within += usize::from(ok);
        worst = worst.max(gap / fine.max(coarse));
        println!(
            "loop {i}: {fine:.1} s at {:.1} s, {coarse:.1} s at {ts2:.1} s{}",
            l.sample_time,
            if ok {
                ""
            } else {
                "  <- more than a sample apart"
            }
        );
    }
    println!(
        "{within} of {compared} loops within one sample of the thinned record; the largest gap {:.0} % of the window",
        100.0 * worst
    );
    assert!(compared >= 8, "only {compared} loops to compare");
    // Most within one sample; the correlation time is an estimate, and a component of OP
    // correlated over a sample or two of the finer record counts as the loop's own at the
    // finer sampling and as noise at the coarser: no window more than a fifth apart (a window
    // counted in samples is twice as long in time on the thinned record, 50 % apart).
    assert!(4 * within >= 3 * compared, "{within} of {compared}");
    assert!(worst <= 0.2, "{worst}");
}

#[test]
fn the_verdict_does_not_flip_with_the_export_on_simulated_loops() {
    let spec = population();
    let records: Vec<Record> = (0..24)
        .map(|i| {
            let l = spec.generate(i).unwrap();
            let tag = if l.integrating { "LIC" } else { "FIC" };
            Record {
                name: format!("{i:02}{tag}{i:03}.csv"),
                t: (0..l.sim.len()).map(|k| k as f64 * l.sample_time).collect(),
                sp: Some(l.sim.sp),
                pv: l.sim.pv,
                op: l.sim.op,
            }
        })
        .collect();
    let (flipped, unread, runs) = flips(&records);
    assert_eq!(runs, 24 * 7);
    assert_eq!(unread, 0);
    assert_eq!(flipped, 0);
}

#[test]
fn the_verdict_does_not_flip_with_the_export_on_the_plant_data() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/plant");
    let Ok(labels) = std::fs::read_to_string(dir.join("labels.csv")) else {
        println!("skipped: {} not found", dir.join("labels.csv").display());
        return;
    };
    let mut records = Vec::new();
    for line in labels.lines().skip(1) {
        let file = line.split(',').next().unwrap();
        let Ok(d) = datasets::read_path(dir.join(file), &ReadOptions::default()) else {
            continue;
        };
        records.push(Record {
            name: file.to_string(),
            t: d.t.clone().unwrap(),
            sp: d.sp.clone(),
            pv: d.require_pv().unwrap().to_vec(),
            op: d.op.clone(),
        });
    }
    let (flipped, unread, runs) = flips(&records);
    assert_eq!(runs, records.len() * 7);
    assert_eq!(unread, 0);
    assert_eq!(flipped, 0);
}
