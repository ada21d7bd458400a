//! `cargo xtask fuzz [--minutes N]`: mutate loop data and run the reader and the grid search
//! in process, with a time and memory budget per case.
//!
//! Seeds: loops simulated here (CSV and MATLAB v5 written by [`mat_bytes`]), the MAT fixtures
//! of `datasets/tests/fixtures`, and the plant registrations of `../shared/data/plant` when
//! present (never copied into the repository except as a crash's regression file, which the
//! user reviews before committing). Mutations: bytes (flips, inserts, cuts, BOM, CRLF,
//! delimiters), lines (drop, duplicate, swap, truncate, blank), cells (empty, NaN, inf, huge,
//! tiny, text, long), scales and degenerate columns (OP x 1e-3 ... 1e300, PV = OP, constant OP,
//! integer counts, alternating MODE, a second PV column) and the grid (the default plan or an
//! explicit step from 1e-6 to 1e6).
//!
//! Every case is written to `target/fuzz/current.*` before it runs; a case that aborts the
//! process (an allocation failure) is found there by the next run and saved as a regression.
//! A panic, a time-out (over `--case-seconds`) or a peak of live memory over `--memory-mb`
//! is saved to `datasets/tests/fuzz-regressions/` (with a `.txt` saying what happened) and
//! counted; the run fails when anything was found. Saved regressions are replayed first.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use datasets::simulate::Scenario;
use datasets::ReadOptions;
use grid_search::{quantify, GridPlan, Problem, SearchOptions};
use linear_id::Arx;
use stiction_models::{find_model, Kano};

/// A global allocator that counts live bytes and refuses (returns null for) any allocation
/// that would take the live total over [`LIMIT`]: a runaway allocation aborts the fuzzer with
/// the case on disk instead of taking the machine down.
pub struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static LIMIT: AtomicUsize = AtomicUsize::new(usize::MAX);

#[allow(unsafe_code)]
unsafe impl std::alloc::GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        let size = layout.size();
        let live = LIVE.fetch_add(size, Ordering::Relaxed) + size;
        if live > LIMIT.load(Ordering::Relaxed) {
            LIVE.fetch_sub(size, Ordering::Relaxed);
            return std::ptr::null_mut();
        }
        PEAK.fetch_max(live, Ordering::Relaxed);
        // SAFETY: forwarded to the system allocator with the caller's layout.
        unsafe { std::alloc::System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: `ptr` was allocated by `System` with this layout.
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }
}

/// splitmix64: small, seeded, good enough for mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }
}

#[derive(Clone, Copy, PartialEq, Debug)]
enum Kind {
    Csv,
    Mat,
}

impl Kind {
    fn ext(self) -> &'static str {
        match self {
            Kind::Csv => "csv",
            Kind::Mat => "mat",
        }
    }
}

/// One input and how the search is asked to run on it.
#[derive(Clone, Debug)]
struct Case {
    kind: Kind,
    bytes: Vec<u8>,
    /// `None`: the default plan for the OP span; `Some(step)`: an exhaustive grid.
    step: Option<f64>,
    /// Gap policy: 0 refuse, 1 fill (hold), 2 drop gaps.
    gaps: u8,
}

/// Cases the differential oracle compared (units and the reordered, renamed columns).
static ORACLE_RUNS: AtomicUsize = AtomicUsize::new(0);

/// The outcome of a case that went wrong.
#[derive(Debug)]
enum Finding {
    Panic(String),
    TimeOut(f64),
    Memory(usize),
    /// The differential oracle or the NaN check: an answer that changed under a
    /// meaning-preserving edit, or "NaN" in a sentence or a JSON string.
    Mismatch(String),
}

impl std::fmt::Display for Finding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Finding::Panic(m) => write!(f, "panic: {m}"),
            Finding::TimeOut(s) => write!(f, "time-out: over {s} s"),
            Finding::Memory(b) => write!(f, "memory: peak {} MiB over the budget", b >> 20),
            Finding::Mismatch(m) => write!(f, "mismatch: {m}"),
        }
    }
}

struct Options {
    minutes: f64,
    seed: u64,
    case_seconds: f64,
    memory_mb: usize,
    plant: Option<PathBuf>,
    regressions: PathBuf,
    work: PathBuf,
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace")
        .to_path_buf()
}

fn parse(rest: &[String]) -> Result<Options> {
    let root = root();
    let default_plant = root.join("../shared/data/plant");
    let mut o = Options {
        minutes: 1.0,
        seed: 1,
        case_seconds: 60.0,
        memory_mb: 2048,
        plant: default_plant.is_dir().then_some(default_plant),
        regressions: root.join("datasets/tests/fuzz-regressions"),
        work: root.join("target/fuzz"),
    };
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().with_context(|| format!("{name} needs a value"));
        match a.as_str() {
            "--minutes" => o.minutes = value("--minutes")?.parse().context("--minutes")?,
            "--seed" => o.seed = value("--seed")?.parse().context("--seed")?,
            "--case-seconds" => {
                o.case_seconds = value("--case-seconds")?.parse().context("--case-seconds")?
            }
            "--memory-mb" => o.memory_mb = value("--memory-mb")?.parse().context("--memory-mb")?,
            "--plant" => o.plant = Some(PathBuf::from(value("--plant")?)),
            "--no-plant" => o.plant = None,
            "--help" | "-h" => {
                println!(
                    "usage: cargo xtask fuzz [--minutes N] [--seed N] [--case-seconds S] [--memory-mb M] [--plant DIR | --no-plant]"
                );
                std::process::exit(0);
            }
            other => bail!("fuzz: unknown option {other:?} (see --help)"),
        }
    }
    Ok(o)
}

/// `cargo xtask fuzz`.
pub fn fuzz(rest: &[String]) -> Result<()> {
    let o = parse(rest)?;
    std::fs::create_dir_all(&o.work)?;
    std::fs::create_dir_all(&o.regressions)?;
    // The hard cap: twice the per-case budget (the budget is checked on the peak after each
    // case; the cap only stops a runaway allocation from taking the machine down).
    LIMIT.store(o.memory_mb.saturating_mul(2) << 20, Ordering::Relaxed);
    let mut found = 0usize;

    // A case left on disk by a run that aborted: a regression.
    for kind in [Kind::Csv, Kind::Mat] {
        let current = o.work.join(format!("current.{}", kind.ext()));
        if let Ok(bytes) = std::fs::read(&current) {
            let step = std::fs::read_to_string(o.work.join("current.step"))
                .ok()
                .and_then(|s| s.trim().parse().ok());
            let case = Case {
                kind,
                bytes,
                step,
                gaps: 0,
            };
            let path = save(&o, &case, "the previous fuzz run aborted on this case")?;
            eprintln!(
                "fuzz: the previous run aborted on a case: saved {}",
                path.display()
            );
            let _ = std::fs::remove_file(&current);
            found += 1;
        }
    }

    // Replay the saved regressions.
    let mut replayed = 0usize;
    let mut saved: Vec<PathBuf> = std::fs::read_dir(&o.regressions)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("csv" | "mat")))
        .collect();
    saved.sort();
    for path in saved {
        let kind = if path.extension().is_some_and(|e| e == "mat") {
            Kind::Mat
        } else {
            Kind::Csv
        };
        let step = std::fs::read_to_string(path.with_extension("step"))
            .ok()
            .and_then(|s| s.trim().parse().ok());
        let bytes = std::fs::read(&path)?;
        // Under every gap policy (the one that failed is in the `.txt`).
        for gaps in 0..3 {
            let case = Case {
                kind,
                bytes: bytes.clone(),
                step,
                gaps,
            };
            if let Some(f) = run_case(&o, &case)? {
                eprintln!("fuzz: regression {} still fails: {f}", path.display());
                found += 1;
            }
        }
        replayed += 1;
    }

    let seeds = seeds(&o)?;
    let mut rng = Rng(o.seed);
    let start = Instant::now();
    let deadline = Duration::from_secs_f64(o.minutes * 60.0);
    let (mut runs, mut read_ok, mut searched) = (0usize, 0usize, 0usize);
    let mut slowest = 0.0f64;
    let mut peak_max = 0usize;
    while start.elapsed() < deadline {
        let seed = rng.pick(&seeds).clone();
        let case = mutate(&mut rng, seed);
        let t0 = Instant::now();
        let outcome = run_case_counted(&o, &case)?;
        slowest = slowest.max(t0.elapsed().as_secs_f64());
        runs += 1;
        match outcome {
            Ok((read, search, peak)) => {
                read_ok += read as usize;
                searched += search as usize;
                peak_max = peak_max.max(peak);
            }
            Err(f) => {
                let path = save(&o, &case, &f.to_string())?;
                eprintln!("fuzz: {f}: saved {}", path.display());
                found += 1;
                if matches!(f, Finding::TimeOut(_)) {
                    // The timed-out case still runs on its thread: stop here.
                    break;
                }
            }
        }
        if runs % 200 == 0 {
            eprintln!(
                "fuzz: {runs} cases in {:.0} s ({read_ok} read, {searched} searched), {found} found",
                start.elapsed().as_secs_f64()
            );
        }
    }
    println!(
        "fuzz: {runs} cases in {:.1} min (seed {}): {read_ok} read, {searched} searched to the end; \
         {replayed} regressions replayed; slowest case {slowest:.1} s, peak live memory {} MiB; \
         {} cases through the differential oracle; \
         {found} panics/aborts/time-outs/memory overruns/mismatches",
        start.elapsed().as_secs_f64() / 60.0,
        o.seed,
        peak_max >> 20,
        ORACLE_RUNS.load(Ordering::Relaxed)
    );
    if found > 0 {
        bail!(
            "fuzz found {found} failing case(s), saved in {}",
            o.regressions.display()
        );
    }
    Ok(())
}

fn save(o: &Options, case: &Case, what: &str) -> Result<PathBuf> {
    let hash = case.bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    });
    let path = o
        .regressions
        .join(format!("case-{hash:016x}.{}", case.kind.ext()));
    std::fs::write(&path, &case.bytes)?;
    if let Some(step) = case.step {
        std::fs::write(path.with_extension("step"), format!("{step:e}\n"))?;
    }
    std::fs::write(
        path.with_extension("txt"),
        format!(
            "{what}\ngap policy {} (0 refuse, 1 fill hold, 2 drop gaps)\n",
            case.gaps
        ),
    )?;
    Ok(path)
}

fn run_case(o: &Options, case: &Case) -> Result<Option<Finding>> {
    Ok(run_case_counted(o, case)?.err())
}

/// Run one case on its own thread with the time and memory budget; `Ok((read, searched,
/// peak bytes))` or the finding.
fn run_case_counted(o: &Options, case: &Case) -> Result<Result<(bool, bool, usize), Finding>> {
    let current = o.work.join(format!("current.{}", case.kind.ext()));
    std::fs::write(&current, &case.bytes)?;
    match case.step {
        Some(step) => std::fs::write(o.work.join("current.step"), format!("{step:e}"))?,
        None => {
            let _ = std::fs::remove_file(o.work.join("current.step"));
        }
    }
    let base = LIVE.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let (tx, rx) = std::sync::mpsc::channel();
    let c = case.clone();
    std::thread::spawn(move || {
        let r = std::panic::catch_unwind(|| exercise(&c));
        let _ = tx.send(r);
    });
    let outcome = match rx.recv_timeout(Duration::from_secs_f64(o.case_seconds)) {
        Ok(Ok((_, _, Some(m)))) => Err(Finding::Mismatch(m)),
        Ok(Ok((read, searched, None))) => {
            let peak = PEAK.load(Ordering::Relaxed).saturating_sub(base);
            if peak > o.memory_mb << 20 {
                Err(Finding::Memory(peak))
            } else {
                Ok((read, searched, peak))
            }
        }
        Ok(Err(p)) => Err(Finding::Panic(
            p.downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_default(),
        )),
        Err(_) => Err(Finding::TimeOut(o.case_seconds)),
    };
    if !matches!(outcome, Err(Finding::TimeOut(_))) {
        let _ = std::fs::remove_file(&current);
    }
    Ok(outcome)
}

/// The reader, then (when it accepts the data) the search as the CLI runs it, the detector, and
/// for one accepted case in eight the differential oracle ([`oracle`]): `(read, searched,
/// mismatch)`.
fn exercise(case: &Case) -> (bool, bool, Option<String>) {
    let opts = ReadOptions {
        min_rows: 30,
        gaps: match case.gaps {
            1 => datasets::GapPolicy::FillHold,
            2 => datasets::GapPolicy::DropGaps,
            _ => datasets::GapPolicy::Refuse,
        },
        ..ReadOptions::default()
    };
    let data = match case.kind {
        Kind::Csv => datasets::read_csv(case.bytes.as_slice(), "fuzz.csv", &opts),
        Kind::Mat => datasets::read_mat(case.bytes.as_slice(), "fuzz.mat", &opts),
    };
    let Ok(d) = data else {
        return (false, false, None);
    };
    let Some(pv) = d.pv.as_deref() else {
        return (true, false, None);
    };
    let nan_in_notes = d.notes.iter().find(|n| has_nan_word(&n.text));
    if let Some(n) = nan_in_notes {
        return (
            true,
            false,
            Some(format!("NaN in a reader note: {}", n.text)),
        );
    }
    let (lo, hi) =
        d.op.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
    let span = hi - lo;
    let grid = match case.step {
        Some(step) => GridPlan::Exhaustive { step },
        None => GridPlan::for_span(span),
    };
    let kano = find_model("kano").expect("kano is registered");
    let arx = Arx::params().check().expect("default ARX orders");
    let r = quantify(
        kano,
        &arx,
        Problem {
            op: &d.op,
            pv,
            mv: d.mv.as_deref(),
        },
        &SearchOptions {
            grid,
            ..SearchOptions::default()
        },
        None,
    );
    let det = detect_json(&d.op, pv, d.sp.as_deref());
    if let Some(m) = det.as_ref().and_then(|(j, _, _)| nan_in_json(j)) {
        return (
            true,
            r.is_ok(),
            Some(format!("NaN in the detector's JSON: {m}")),
        );
    }
    if let Err(e) = &r {
        if has_nan_word(&e.to_string()) {
            return (true, false, Some(format!("NaN in a search error: {e}")));
        }
    }
    // The oracle on one accepted case in eight (it runs the search and the detector again).
    let h = case
        .bytes
        .iter()
        .fold(0u64, |h, &b| h.wrapping_mul(31).wrapping_add(b as u64));
    let mismatch = match (&r, &det) {
        (Ok(q), Some(det)) if h % 8 == 0 => oracle(&d, pv, (q.s, q.j), det, case.step),
        _ => None,
    };
    (true, r.is_ok(), mismatch)
}

/// Whether `text` has the word `NaN` or `inf` (Rust's formatting of non-finite numbers) as a
/// number: "empty or NaN cells" names the cells' text, not a computed value.
fn has_nan_word(text: &str) -> bool {
    let words: Vec<&str> = text
        .split(|c: char| !c.is_alphanumeric())
        .filter(|w| !w.is_empty())
        .collect();
    words.iter().enumerate().any(|(i, w)| {
        (*w == "NaN" || *w == "inf") && !matches!(words.get(i + 1), Some(&"cells") | Some(&"cell"))
    })
}

/// A JSON string of `doc` that contains "NaN" (numbers that are not finite are `null`).
fn nan_in_json(doc: &serde_json::Value) -> Option<String> {
    match doc {
        serde_json::Value::String(s) if has_nan_word(s) => Some(s.clone()),
        serde_json::Value::Array(v) => v.iter().find_map(nan_in_json),
        serde_json::Value::Object(m) => m.values().find_map(nan_in_json),
        _ => None,
    }
}

/// The detector on the record: its JSON, verdict and score.
fn detect_json(
    op: &[f64],
    pv: &[f64],
    sp: Option<&[f64]>,
) -> Option<(serde_json::Value, detection::Verdict, f64)> {
    let mut reg = detection::Registration::new(pv, op, 1.0).ok()?;
    if let Some(sp) = sp {
        reg = reg.with_sp(sp).ok()?;
    }
    let d = detection::detect(&reg);
    Some((serde_json::to_value(&d).ok()?, d.verdict, d.score))
}

/// The differential oracle: edits that keep the record's meaning must keep the answer.
/// * PV and SP in other units (`a·x + b`, a from 1e-6 to 1e12, b up to 10 × a × PV's range):
///   the detector's verdict and score (within 1e-3);
/// * the columns in another order and renamed in other case, written back as CSV and read
///   again: the same S, J, verdict and score;
/// * OP (in % of span as read) written as a fraction of span, which the reader takes back to
///   %: the same verdict, the score within 1e-6, S and J within two grid steps (OP / 100 × 100
///   may differ from OP in its last bit, which can move a tie between two nodes).
fn oracle(
    d: &datasets::LoopData,
    pv: &[f64],
    (s, j): (f64, f64),
    (_, verdict, score): &(serde_json::Value, detection::Verdict, f64),
    grid_step: Option<f64>,
) -> Option<String> {
    let op = &d.op;
    let sp = d.sp.as_deref();
    let n = op.len();
    ORACLE_RUNS.fetch_add(1, Ordering::Relaxed);
    // PV and SP units.
    let h = pv.len() as f64 + pv.first().copied().unwrap_or(0.0).abs();
    let a = 10f64.powi((h as i64 % 19) as i32 - 6);
    // An offset that keeps PV's variation representable (1e7 added to PV of spread 1e-76
    // rounds it away: information lost, not a change of units).
    let (lo, hi) = pv
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let b = if h as i64 % 2 == 0 {
        0.0
    } else {
        10.0 * a * (hi - lo)
    };
    let pv2: Vec<f64> = pv.iter().map(|v| a * v + b).collect();
    let sp2: Option<Vec<f64>> = sp.map(|x| x.iter().map(|v| a * v + b).collect());
    if pv2
        .iter()
        .chain(sp2.iter().flatten())
        .all(|v| v.abs() < 1e50)
    {
        if let Some((_, v2, s2)) = detect_json(op, &pv2, sp2.as_deref()) {
            // the score within 1e-3: rounding in the tests' sums moves it by up to 1e-5 on
            // plant records with PV near 1e-76 (measured, seed 33)
            if v2 != *verdict || (s2 - score).abs() > 1e-3 {
                return Some(format!(
                    "PV and SP x {a:e} + {b:e}: detect {v2} ({s2:.6}) against {verdict} ({score:.6})"
                ));
            }
        }
    }
    // Columns reordered and renamed, through the reader again.
    let col = |x: &[f64]| x.iter().map(|v| format!("{v:?}")).collect::<Vec<_>>();
    let (opc, pvc) = (col(op), col(pv));
    let spc = sp.map(col);
    let mut text = String::from(if spc.is_some() { "op,Sp,pV" } else { "op,pV" });
    text.push('\n');
    for i in 0..n {
        match &spc {
            Some(spc) => text.push_str(&format!("{},{},{}\n", opc[i], spc[i], pvc[i])),
            None => text.push_str(&format!("{},{}\n", opc[i], pvc[i])),
        }
    }
    let keep = ReadOptions {
        min_rows: 30,
        op_range: datasets::OpRange::Keep,
        ..ReadOptions::default()
    };
    let detect_units = ReadOptions {
        op_range: datasets::OpRange::Detect,
        ..keep.clone()
    };
    let again = |text: &str, opts: &ReadOptions| -> Option<(f64, f64, detection::Verdict, f64)> {
        let d2 = datasets::read_csv(text.as_bytes(), "oracle.csv", opts).ok()?;
        let pv2 = d2.pv.as_deref()?;
        let (lo, hi) = d2
            .op
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        let grid = match grid_step {
            Some(step) => GridPlan::Exhaustive { step },
            None => GridPlan::for_span(hi - lo),
        };
        let kano = find_model("kano").ok()?;
        let arx = Arx::params().check().ok()?;
        let q = quantify(
            kano,
            &arx,
            Problem {
                op: &d2.op,
                pv: pv2,
                mv: None,
            },
            &SearchOptions {
                grid,
                ..SearchOptions::default()
            },
            None,
        )
        .ok()?;
        let (_, v, sc) = detect_json(&d2.op, pv2, d2.sp.as_deref())?;
        Some((q.s, q.j, v, sc))
    };
    // Only records the reader keeps as they are (no notes that change samples) compare.
    if d.mv.is_some() || d.notes.iter().any(|n| n.kind.changes_samples()) {
        return None;
    }
    if let Some((s2, j2, v2, sc2)) = again(&text, &keep) {
        if (s2 - s).abs() > 1e-9
            || (j2 - j).abs() > 1e-9
            || v2 != *verdict
            || (sc2 - score).abs() > 1e-9
        {
            return Some(format!(
                "columns reordered and renamed: S {s2}, J {j2}, {v2} ({sc2:.6}) against S {s}, J {j}, {verdict} ({score:.6})"
            ));
        }
    }
    // OP as a fraction of span (when it is within the fraction rule's range once divided).
    if op.iter().all(|v| (-5.0..=105.0).contains(v)) {
        let mut text = String::from(if spc.is_some() { "OP,SP,PV" } else { "OP,PV" });
        text.push('\n');
        for i in 0..n {
            let f = format!("{:?}", op[i] / 100.0);
            match &spc {
                Some(spc) => text.push_str(&format!("{f},{},{}\n", spc[i], pvc[i])),
                None => text.push_str(&format!("{f},{}\n", pvc[i])),
            }
        }
        if let Some((s2, j2, v2, sc2)) = again(&text, &detect_units) {
            let (lo, hi) = op
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                    (l.min(v), h.max(v))
                });
            let step = match grid_step {
                Some(step) => step,
                None => match GridPlan::for_span(hi - lo) {
                    GridPlan::CoarseToFine { fine, .. } => fine,
                    GridPlan::Exhaustive { step } => step,
                },
            };
            let tol = 1e-6 + 2.0 * step;
            if (s2 - s).abs() > tol
                || (j2 - j).abs() > tol
                || v2 != *verdict
                || (sc2 - score).abs() > 1e-6
            {
                return Some(format!(
                    "OP as a fraction of span: S {s2}, J {j2}, {v2} ({sc2:.6}) against S {s}, J {j}, {verdict} ({score:.6})"
                ));
            }
        }
    }
    None
}

/// The seed inputs.
fn seeds(o: &Options) -> Result<Vec<Case>> {
    let mut out = Vec::new();
    for (k, (s, j, n)) in [
        (4.0, 1.0, 751),
        (0.0, 0.0, 600),
        (9.0, 3.0, 1500),
        (2.0, 2.0, 300),
    ]
    .into_iter()
    .enumerate()
    {
        let sim = Scenario {
            valve: Box::new(Kano::params().s(s).j(j).check()?),
            samples: n,
            seed: 100 + k as u64,
            ..Scenario::default()
        }
        .simulate()?;
        let mut csv = String::from("t,SP,PV,OP,MODE\n");
        for i in 0..sim.len() {
            csv.push_str(&format!(
                "{},{},{},{},1\n",
                sim.t[i], sim.sp[i], sim.pv[i], sim.op[i]
            ));
        }
        out.push(Case {
            kind: Kind::Csv,
            bytes: csv.into_bytes(),
            step: None,
            gaps: 0,
        });
        out.push(Case {
            kind: Kind::Mat,
            bytes: mat_bytes(&[
                ("t", &sim.t),
                ("SP", &sim.sp),
                ("PV", &sim.pv),
                ("OP", &sim.op),
            ]),
            step: None,
            gaps: 0,
        });
    }
    let fixtures = root().join("datasets/tests/fixtures");
    for entry in std::fs::read_dir(&fixtures)
        .with_context(|| format!("{}", fixtures.display()))?
        .flatten()
    {
        if entry.path().extension().is_some_and(|e| e == "mat") {
            out.push(Case {
                kind: Kind::Mat,
                bytes: std::fs::read(entry.path())?,
                step: None,
                gaps: 0,
            });
        }
    }
    if let Some(dir) = &o.plant {
        let mut n = 0;
        for entry in std::fs::read_dir(dir)?.flatten() {
            let p = entry.path();
            if p.extension().is_some_and(|e| e == "csv") && !p.ends_with("labels.csv") {
                out.push(Case {
                    kind: Kind::Csv,
                    bytes: std::fs::read(&p)?,
                    step: None,
                    gaps: 0,
                });
                n += 1;
            }
        }
        eprintln!(
            "fuzz: {n} plant registrations from {} as seeds",
            dir.display()
        );
    } else {
        eprintln!("fuzz: no plant data (../shared/data/plant absent): generated seeds only");
    }
    Ok(out)
}

/// A little-endian MATLAB v5 file of double column vectors.
pub fn mat_bytes(vars: &[(&str, &[f64])]) -> Vec<u8> {
    let mut out = b"MATLAB 5.0 MAT-file, written by cargo xtask fuzz".to_vec();
    out.resize(116, b' ');
    out.extend([0u8; 8]);
    out.extend([0u8, 1]);
    out.extend(b"IM");
    let element = |kind: u32, data: &[u8]| {
        let mut v = kind.to_le_bytes().to_vec();
        v.extend((data.len() as u32).to_le_bytes());
        v.extend(data);
        v.resize(v.len().div_ceil(8) * 8, 0);
        v
    };
    for (name, xs) in vars {
        let mut body = element(6, &[6u32.to_le_bytes(), [0; 4]].concat());
        body.extend(element(
            5,
            &[(xs.len() as u32).to_le_bytes(), 1u32.to_le_bytes()].concat(),
        ));
        body.extend(element(1, name.as_bytes()));
        let bytes: Vec<u8> = xs.iter().flat_map(|x| x.to_le_bytes()).collect();
        body.extend(element(9, &bytes));
        out.extend(element(14, &body));
    }
    out
}

fn mutate(rng: &mut Rng, mut case: Case) -> Case {
    let rounds = 1 + rng.below(3);
    for _ in 0..rounds {
        match (case.kind, rng.below(10)) {
            (Kind::Csv, 0..=2) => case.bytes = mutate_cells(rng, &case.bytes),
            (Kind::Csv, 3..=4) => case.bytes = mutate_columns(rng, &case.bytes),
            (Kind::Csv, 5..=6) => case.bytes = mutate_lines(rng, &case.bytes),
            (Kind::Mat, 0..=3) => case.bytes = mutate_mat(rng, &case.bytes),
            _ => mutate_bytes(rng, &mut case.bytes),
        }
    }
    if rng.below(5) == 0 {
        case.step = Some(10f64.powf(-6.0 + 12.0 * rng.unit()));
    }
    case.gaps = rng.below(3) as u8;
    case
}

fn mutate_bytes(rng: &mut Rng, b: &mut Vec<u8>) {
    match rng.below(7) {
        0 => {
            for _ in 0..1 + rng.below(8) {
                if !b.is_empty() {
                    let i = rng.below(b.len());
                    b[i] ^= 1 << rng.below(8);
                }
            }
        }
        1 => {
            let i = rng.below(b.len() + 1);
            let junk: Vec<u8> = (0..1 + rng.below(16)).map(|_| rng.next() as u8).collect();
            b.splice(i..i, junk);
        }
        2 => {
            let cut = rng.below(b.len() + 1);
            b.truncate(cut);
        }
        3 => b.splice(0..0, [0xEF, 0xBB, 0xBF]).for_each(drop),
        4 => {
            let text = String::from_utf8_lossy(b).replace('\n', "\r\n");
            *b = text.into_bytes();
        }
        5 => {
            let d = *rng.pick(b";\t |");
            for x in b.iter_mut() {
                if *x == b',' {
                    *x = d;
                }
            }
        }
        _ => {
            if !b.is_empty() {
                let i = rng.below(b.len());
                let n = rng.below(b.len() - i + 1);
                b.drain(i..i + n);
            }
        }
    }
}

fn split_csv(b: &[u8]) -> Vec<Vec<String>> {
    String::from_utf8_lossy(b)
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

fn join_csv(rows: &[Vec<String>]) -> Vec<u8> {
    let mut s = String::new();
    for r in rows {
        s.push_str(&r.join(","));
        s.push('\n');
    }
    s.into_bytes()
}

const CELLS: [&str; 20] = [
    "",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-320",
    "abc",
    "\"1,5\"",
    "0x10",
    "1,5",
    "--1",
    "1e",
    "\u{663}",
    "\"",
    "AUTO",
    "MAN",
    "2024-13-45T25:61:00",
    "9999999999999999999999999",
];

fn mutate_cells(rng: &mut Rng, b: &[u8]) -> Vec<u8> {
    let mut rows = split_csv(b);
    if rows.len() < 2 {
        return b.to_vec();
    }
    for _ in 0..1 + rng.below(5) {
        let r = 1 + rng.below(rows.len() - 1);
        let width = rows[r].len();
        if width == 0 {
            continue;
        }
        let c = rng.below(width);
        rows[r][c] = if rng.below(10) == 0 {
            "7".repeat(1 + rng.below(200_000))
        } else {
            rng.pick(&CELLS).to_string()
        };
    }
    join_csv(&rows)
}

fn mutate_columns(rng: &mut Rng, b: &[u8]) -> Vec<u8> {
    let mut rows = split_csv(b);
    if rows.len() < 2 {
        return b.to_vec();
    }
    let header = rows[0].clone();
    let find = |name: &str| header.iter().position(|h| h.eq_ignore_ascii_case(name));
    let (op, pv) = (find("OP"), find("PV"));
    let scale = |rows: &mut Vec<Vec<String>>, col: usize, f: &dyn Fn(f64) -> f64| {
        for r in rows.iter_mut().skip(1) {
            if let Some(cell) = r.get_mut(col) {
                if let Ok(v) = cell.parse::<f64>() {
                    *cell = format!("{}", f(v));
                }
            }
        }
    };
    match rng.below(9) {
        0 | 1 => {
            if let Some(c) = if rng.below(2) == 0 { op } else { pv } {
                let k = *rng.pick(&[1e-9, 1e-3, 0.01, -1.0, 163.83, 1e6, 1e9, 1e300]);
                scale(&mut rows, c, &|v| v * k);
            }
        }
        2 => {
            if let Some(c) = op {
                scale(&mut rows, c, &|v| (v * 163.83).round());
            }
        }
        3 => {
            if let (Some(o), Some(p)) = (op, pv) {
                for r in rows.iter_mut().skip(1) {
                    if r.len() > o.max(p) {
                        r[p] = r[o].clone();
                    }
                }
            }
        }
        4 => {
            if let Some(c) = op {
                scale(&mut rows, c, &|_| 42.0);
            }
        }
        5 => {
            let alternating = rng.below(2) == 0;
            rows[0].push("MODE".into());
            for (i, r) in rows.iter_mut().enumerate().skip(1) {
                r.push(
                    if alternating && i % 2 == 0 {
                        "MAN"
                    } else {
                        "AUTO"
                    }
                    .into(),
                );
            }
        }
        6 => {
            if let Some(p) = pv {
                for (i, r) in rows.iter_mut().enumerate() {
                    let extra = if i == 0 {
                        "pv".to_string()
                    } else {
                        r.get(p).cloned().unwrap_or_default()
                    };
                    r.push(extra);
                }
            }
        }
        7 => {
            // Reorder the columns.
            let n = rows[0].len();
            if n > 1 {
                let (a, b2) = (rng.below(n), rng.below(n));
                for r in rows.iter_mut() {
                    if r.len() == n {
                        r.swap(a, b2);
                    }
                }
            }
        }
        _ => {
            if let Some(c) = pv {
                let k = 10f64.powi(rng.below(40) as i32 * 10 - 200);
                scale(&mut rows, c, &|v| v * k);
            }
        }
    }
    join_csv(&rows)
}

fn mutate_lines(rng: &mut Rng, b: &[u8]) -> Vec<u8> {
    let text = String::from_utf8_lossy(b);
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        return b.to_vec();
    }
    let n = lines.len();
    match rng.below(6) {
        0 => {
            let i = rng.below(n);
            let k = rng.below(n - i + 1);
            lines.drain(i..i + k);
        }
        1 => {
            let i = rng.below(n);
            let l = lines[i].clone();
            for _ in 0..1 + rng.below(50) {
                lines.insert(i, l.clone());
            }
        }
        2 => {
            let (a, c) = (rng.below(n), rng.below(n));
            lines.swap(a, c);
        }
        3 => {
            let i = rng.below(n);
            lines.insert(i, String::new());
        }
        4 => {
            let i = rng.below(n);
            let h = lines[0].clone();
            lines.insert(i, h);
        }
        _ => {
            let i = rng.below(n);
            let l = &mut lines[i];
            let cut = rng.below(l.len() + 1);
            let mut cut_at = cut;
            while !l.is_char_boundary(cut_at) {
                cut_at -= 1;
            }
            l.truncate(cut_at);
        }
    }
    let mut s = lines.join("\n");
    s.push('\n');
    s.into_bytes()
}

/// MAT-specific damage: element sizes and types overwritten with extreme values.
fn mutate_mat(rng: &mut Rng, b: &[u8]) -> Vec<u8> {
    let mut b = b.to_vec();
    if b.len() < 136 {
        mutate_bytes(rng, &mut b);
        return b;
    }
    let words = (b.len() - 128) / 4;
    for _ in 0..1 + rng.below(3) {
        let i = 128 + 4 * rng.below(words);
        let v: u32 = *rng.pick(&[0, 1, 7, 8, 0xFFFF, 0x7FFF_FFFF, 0xFFFF_FFFF, 14, 15, 9, 6]);
        b[i..i + 4].copy_from_slice(&v.to_le_bytes());
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_mat_files_read_back() {
        let op = [1.0, 2.0, 3.0, 2.0];
        let pv = [0.5, 0.7, 0.2, 0.9];
        let b = mat_bytes(&[("OP", &op), ("PV", &pv)]);
        let d = datasets::read_mat(
            b.as_slice(),
            "x.mat",
            &ReadOptions {
                op_range: datasets::OpRange::Keep,
                ..ReadOptions::default()
            },
        )
        .unwrap();
        assert_eq!(d.op, op);
        assert_eq!(d.pv.unwrap(), pv);
    }
}
