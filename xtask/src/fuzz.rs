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

mod mutate;
mod oracle;
use mutate::mutate;
use oracle::{detect_json, oracle};

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
/// for one accepted case in eight the differential oracle ([`oracle`](fn@oracle)): `(read, searched,
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
        (Ok(q), Some(det)) if h % 8 == 0 => oracle(&d, pv, (q.s, q.j), &q.interval, det, case.step),
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
