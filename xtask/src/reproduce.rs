//! `cargo xtask reproduce`: the reference paper's simulation study (§3, Tables 1-2, Figs 5-7)
//! run with this workspace's code, plus the criterion study (`docs/CRITERION.md`) and the
//! full-size recovery-rate check (`docs/REPRODUCTION.md`).
//!
//! Every Monte-Carlo run is one seed of the closed-loop simulator (`datasets::simulate`), i.e.
//! one realisation of the white noise and of the random-walk set point; run `r` uses seed
//! `seed0 + r` for every case (common random numbers across cases and linear models). Each run
//! is quantified with the CLI's default search: Kano, In.3, one-step prediction criterion,
//! coarse grid at span/40 refined at 0.1 within two coarse steps.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use datasets::simulate::{Controller, Disturbance, Plant, PlantPreset, PlantSpec, Scenario};
use grid_search::{Criterion, Problem, SearchOptions};
use rand::{Rng, SeedableRng};
use rand_xoshiro::SplitMix64;
use rayon::prelude::*;
use stiction_models::Kano;

/// Every linear model of the paper, in the paper's table order.
const MODELS: [&str; 5] = ["arx", "armax", "ss", "earx", "earmax"];

/// The (S, J) pairs of the Fig. 5/6 sweeps and of the criterion study: S ∈ [1, 12],
/// J ∈ [0.5, 4], J <= S.
const PAIRS: [(f64, f64); 7] = [
    (1.0, 0.5),
    (2.0, 1.0),
    (3.0, 1.0),
    (5.0, 2.0),
    (7.0, 2.5),
    (9.0, 3.0),
    (12.0, 4.0),
];

/// Paper Table 1 (aggressive, Kc = KI = 1.2): S̄, σ_S, J̄, σ_J, F̄_id, F̄_val.
const PAPER_TABLE1: [(&str, [f64; 6]); 5] = [
    ("arx", [9.00, 0.00, 2.97, 0.05, 99.73, 98.71]),
    ("armax", [9.00, 0.00, 2.90, 0.06, 98.77, 98.75]),
    ("ss", [9.00, 0.00, 2.88, 0.06, 98.78, 98.76]),
    ("earx", [9.00, 0.00, 2.89, 0.07, 98.98, 98.59]),
    ("earmax", [9.00, 0.00, 2.84, 0.09, 99.01, 98.99]),
];

/// Paper Table 2 (sluggish, Kc = KI = 0.2).
const PAPER_TABLE2: [(&str, [f64; 6]); 5] = [
    ("arx", [8.99, 0.01, 2.98, 0.15, 98.60, 98.61]),
    ("armax", [8.99, 0.03, 2.95, 0.15, 98.65, 98.65]),
    ("ss", [8.99, 0.03, 2.93, 0.16, 98.67, 98.66]),
    ("earx", [8.99, 0.01, 2.90, 0.27, 98.77, 98.40]),
    ("earmax", [9.00, 0.00, 2.88, 0.23, 98.88, 98.90]),
];

const USAGE: &str = "\
usage: cargo xtask reproduce [--runs N] [--out DIR] [--only WHAT[,WHAT...]] [--models M[,M...]]
                             [--loops N] [--seed S]

  --runs N      Monte-Carlo runs (simulator seeds) per case (default 10; the paper used 100)
  --out DIR     where the CSV files go (default target/reproduce)
  --only WHAT   table1, table2, fig5, fig6, fig7, criterion, recovery (default: all but recovery)
  --models M    linear models (default arx,armax,ss,earx,earmax)
  --loops N     loops per setting of the recovery study (default 200)
  --seed S      first simulator seed (default 1)

`cargo xtask reproduce` re-runs itself in the release profile (the workspace crates are not
optimised in the dev profile). Progress goes to stderr, the tables (ours next to the paper's)
to stdout and DIR/report.md, one CSV of per-run results per experiment to DIR.";

struct Args {
    runs: usize,
    out: PathBuf,
    only: Vec<String>,
    models: Vec<String>,
    loops: usize,
    seed: u64,
}

fn parse_args(rest: &[String]) -> Result<Args> {
    let mut a = Args {
        runs: 10,
        out: PathBuf::from("target/reproduce"),
        only: Vec::new(),
        models: MODELS.iter().map(|s| s.to_string()).collect(),
        loops: 200,
        seed: 1,
    };
    let mut it = rest.iter();
    while let Some(flag) = it.next() {
        let mut value = |name: &str| -> Result<String> {
            it.next()
                .cloned()
                .with_context(|| format!("{name} needs a value\n{USAGE}"))
        };
        match flag.as_str() {
            "--runs" => {
                let v = value("--runs")?;
                a.runs = v
                    .parse()
                    .with_context(|| format!("--runs {v:?} is not a whole number"))?;
            }
            "--loops" => {
                let v = value("--loops")?;
                a.loops = v
                    .parse()
                    .with_context(|| format!("--loops {v:?} is not a whole number"))?;
            }
            "--seed" => {
                let v = value("--seed")?;
                a.seed = v
                    .parse()
                    .with_context(|| format!("--seed {v:?} is not a whole number"))?;
            }
            "--out" => a.out = PathBuf::from(value("--out")?),
            "--only" => a
                .only
                .extend(value("--only")?.split(',').map(|s| s.trim().to_lowercase())),
            "--models" => {
                a.models = value("--models")?
                    .split(',')
                    .map(|s| s.trim().to_lowercase())
                    .collect()
            }
            "-h" | "--help" => {
                println!("{USAGE}");
                std::process::exit(0);
            }
            other => bail!("unknown option {other:?}\n{USAGE}"),
        }
    }
    const KNOWN: [&str; 7] = [
        "table1",
        "table2",
        "fig5",
        "fig6",
        "fig7",
        "criterion",
        "recovery",
    ];
    for w in &a.only {
        if !KNOWN.contains(&w.as_str()) {
            bail!("--only {w:?}: expected one of {}", KNOWN.join(", "));
        }
    }
    if a.only.is_empty() {
        a.only = KNOWN[..6].iter().map(|s| s.to_string()).collect();
    }
    for m in &a.models {
        linear_id::find_identifier(m)?;
    }
    if a.runs == 0 {
        bail!("--runs must be at least 1");
    }
    Ok(a)
}

/// One simulated loop and how it is quantified.
#[derive(Debug, Clone)]
struct Job {
    plant: PlantPreset,
    kc: f64,
    ki: f64,
    s: f64,
    j: f64,
    a: f64,
    noise: f64,
    model: String,
    /// Orders of the linear model (`NAME=value` pairs); empty: the paper's (defaults).
    orders: Vec<(String, linear_id::OrderValue)>,
    seed: u64,
    criterion: Criterion,
}

impl Job {
    /// `arx`, or `arx(n=3,m=3)` when orders are given.
    fn model_label(&self) -> String {
        if self.orders.is_empty() {
            self.model.clone()
        } else {
            let o: Vec<String> = self
                .orders
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect();
            format!("{}({})", self.model, o.join(" "))
        }
    }
}

/// What came out of one job.
#[derive(Debug, Clone)]
struct Outcome {
    s_id: f64,
    j_id: f64,
    pred_id: f64,
    pred_val: f64,
    sim_id: f64,
    sim_val: f64,
    e_g: f64,
    fit_no_stiction: f64,
    nodes: usize,
    ms: f64,
}

/// Frequency response of the true process B/A of a plant.
fn true_response(plant: &Plant, w: &[f64]) -> Vec<(f64, f64)> {
    // Plant stores b = [b0, b1, ...] applied to u(k - delay - i); linear-id's convention is
    // q^-delay (b1 q^-1 + ...), so a leading b0 is one sample less of delay.
    if plant.b[0] == 0.0 {
        linear_id::polynomial_frequency_response(&plant.a, &plant.b[1..], plant.delay, w)
    } else {
        // delay >= 1 (validated by Plant::validate).
        linear_id::polynomial_frequency_response(&plant.a, &plant.b, plant.delay - 1, w)
    }
}

fn run_job(job: &Job) -> Result<Outcome> {
    let scenario = Scenario {
        plant: PlantSpec::Preset(job.plant),
        controller: Controller {
            kc: job.kc,
            ki: job.ki,
        },
        valve: Box::new(Kano::params().s(job.s).j(job.j).check()?),
        disturbances: if job.a > 0.0 {
            vec![Disturbance::Paper { a: job.a }]
        } else {
            Vec::new()
        },
        noise_sigma: job.noise,
        samples: 3000,
        warmup: 500,
        seed: job.seed,
        ..Scenario::default()
    };
    let sim = scenario.simulate()?;
    // The paper's combination: Kano × the job's identifier, default grid for the span.
    let combination = run::Combination {
        orders: job.orders.clone(),
        search: SearchOptions {
            criterion: job.criterion,
            ..SearchOptions::default()
        },
        ..run::Combination::named("kano", &job.model)?
    };
    let q = combination
        .run(
            Problem {
                op: &sim.op,
                pv: &sim.pv,
                mv: Some(&sim.mv),
            },
            None,
        )?
        .result;
    let w = linear_id::frequency_grid(linear_id::E_G_GRID_POINTS);
    let e_g = linear_id::e_g(
        &true_response(&job.plant.plant(), &w),
        &q.linear.frequency_response(&w),
    );
    Ok(Outcome {
        s_id: q.s,
        j_id: q.j,
        pred_id: q.fits.pred_id,
        pred_val: q.fits.pred_val,
        sim_id: q.fits.sim_id,
        sim_val: q.fits.sim_val,
        e_g,
        fit_no_stiction: q.fit_no_stiction.unwrap_or(f64::NAN),
        nodes: q.nodes_evaluated,
        ms: q.elapsed_ms,
    })
}

/// Run every job in parallel, with progress on stderr. Failed jobs are reported and kept as
/// `Err` (a failure is a result too).
fn run_all(label: &str, jobs: &[Job]) -> Vec<Result<Outcome, String>> {
    let start = Instant::now();
    let done = AtomicUsize::new(0);
    let total = jobs.len();
    eprintln!("[{label}] {total} quantifications");
    jobs.par_iter()
        .map(|job| {
            let r = run_job(job).map_err(|e| format!("{e:#}"));
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            let el = start.elapsed().as_secs_f64();
            let what = match &r {
                Ok(o) => format!("S_id {:.2} J_id {:.2}", o.s_id, o.j_id),
                Err(e) => format!("FAILED: {e}"),
            };
            eprintln!(
                "[{label}] {d}/{total} {:.0}s (eta {:.0}s): {} S={} J={} a={} Kc={} seed {} {}: {what}",
                el,
                el / d as f64 * (total - d) as f64,
                job.model_label(),
                job.s,
                job.j,
                job.a,
                job.kc,
                job.seed,
                job.criterion.label(),
            );
            r
        })
        .collect()
}

fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        f64::NAN
    } else {
        x.iter().sum::<f64>() / x.len() as f64
    }
}

/// Sample standard deviation (n - 1); 0 for a single value.
fn std(x: &[f64]) -> f64 {
    if x.len() < 2 {
        return 0.0;
    }
    let m = mean(x);
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

/// Per-run CSV.
fn write_runs(path: &Path, jobs: &[Job], res: &[Result<Outcome, String>]) -> Result<()> {
    let mut s = String::from(
        "plant,kc,ki,S,J,a,noise,model,criterion,seed,S_id,J_id,F_pred_id,F_pred_val,F_sim_id,F_sim_val,E_G,F_no_stiction,nodes,ms,error\n",
    );
    for (j, r) in jobs.iter().zip(res) {
        let _ = write!(
            s,
            "{:?},{},{},{},{},{},{},{},{},{},",
            j.plant,
            j.kc,
            j.ki,
            j.s,
            j.j,
            j.a,
            j.noise,
            j.model_label(),
            j.criterion.label(),
            j.seed
        );
        match r {
            Ok(o) => {
                let _ = writeln!(
                    s,
                    "{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{:.0},",
                    o.s_id,
                    o.j_id,
                    o.pred_id,
                    o.pred_val,
                    o.sim_id,
                    o.sim_val,
                    o.e_g,
                    o.fit_no_stiction,
                    o.nodes,
                    o.ms
                );
            }
            Err(e) => {
                let _ = writeln!(s, ",,,,,,,,,,\"{}\"", e.replace('"', "'"));
            }
        }
    }
    std::fs::write(path, s).with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

/// Summary of a group of runs of the same case.
#[derive(Debug, Clone, Default)]
struct Summary {
    n: usize,
    failed: usize,
    s: (f64, f64),
    j: (f64, f64),
    pred_id: f64,
    pred_val: f64,
    sim_val: f64,
    e_g: f64,
    hit_s: usize,
    hit_j: usize,
    err_s: f64,
    err_j: f64,
}

impl Summary {
    /// The cells `S hit | J hit`: hits out of the runs that did not fail.
    fn hit_cells(&self) -> String {
        format!("{}/{} | {}/{}", self.hit_s, self.n, self.hit_j, self.n)
    }

    /// The recovery table's cells `loops | S hit | J hit | mean abs err S | mean abs err J |
    /// failed`, the hit shares with `pct` decimals and the errors with `err`.
    fn recovery_cells(&self, pct: usize, err: usize) -> String {
        let share = |hits: usize| {
            let p = 100.0 * hits as f64 / self.n.max(1) as f64;
            format!("{hits}/{} ({p:.pct$} %)", self.n)
        };
        format!(
            "{} | {} | {} | {:.err$} | {:.err$} | {}",
            self.n + self.failed,
            share(self.hit_s),
            share(self.hit_j),
            self.err_s,
            self.err_j,
            self.failed
        )
    }
}

fn summarise(jobs: &[&Job], res: &[&Result<Outcome, String>]) -> Summary {
    let ok: Vec<(&Job, &Outcome)> = jobs
        .iter()
        .zip(res)
        .filter_map(|(j, r)| r.as_ref().ok().map(|o| (*j, o)))
        .collect();
    let col = |f: &dyn Fn(&Outcome) -> f64| ok.iter().map(|(_, o)| f(o)).collect::<Vec<f64>>();
    let s = col(&|o| o.s_id);
    let j = col(&|o| o.j_id);
    Summary {
        n: ok.len(),
        failed: res.len() - ok.len(),
        s: (mean(&s), std(&s)),
        j: (mean(&j), std(&j)),
        pred_id: mean(&col(&|o| o.pred_id)),
        pred_val: mean(&col(&|o| o.pred_val)),
        sim_val: mean(&col(&|o| o.sim_val)),
        e_g: mean(&col(&|o| o.e_g)),
        hit_s: ok
            .iter()
            .filter(|(jb, o)| (o.s_id - jb.s).abs() <= 0.25 + 1e-9)
            .count(),
        hit_j: ok
            .iter()
            .filter(|(jb, o)| (o.j_id - jb.j).abs() <= 0.5 + 1e-9)
            .count(),
        err_s: mean(
            &ok.iter()
                .map(|(jb, o)| (o.s_id - jb.s).abs())
                .collect::<Vec<_>>(),
        ),
        err_j: mean(
            &ok.iter()
                .map(|(jb, o)| (o.j_id - jb.j).abs())
                .collect::<Vec<_>>(),
        ),
    }
}

/// Group runs by a key (keeps first-appearance order) and summarise each group.
fn group<K: Ord + Clone>(
    jobs: &[Job],
    res: &[Result<Outcome, String>],
    key: impl Fn(&Job) -> K,
) -> Vec<(K, Summary)> {
    let mut order: Vec<K> = Vec::new();
    type Members<'a> = (Vec<&'a Job>, Vec<&'a Result<Outcome, String>>);
    let mut groups: BTreeMap<K, Members<'_>> = BTreeMap::new();
    for (j, r) in jobs.iter().zip(res) {
        let k = key(j);
        let g = groups.entry(k.clone()).or_insert_with(|| {
            order.push(k.clone());
            (Vec::new(), Vec::new())
        });
        g.0.push(j);
        g.1.push(r);
    }
    order
        .into_iter()
        .map(|k| {
            let (j, r) = &groups[&k];
            let s = summarise(j, r);
            (k, s)
        })
        .collect()
}

fn seeds(a: &Args) -> impl Iterator<Item = u64> + '_ {
    (0..a.runs as u64).map(move |r| a.seed + r)
}

fn nominal(model: &str, s: f64, j: f64, a: f64, seed: u64, criterion: Criterion) -> Job {
    Job {
        plant: PlantPreset::Paper,
        kc: 0.5,
        ki: 0.5,
        s,
        j,
        a,
        noise: 0.1,
        model: model.to_string(),
        orders: Vec::new(),
        seed,
        criterion,
    }
}

fn f2(x: f64) -> String {
    format!("{x:.2}")
}

fn table(args: &Args, name: &str, kc: f64, paper: &[(&str, [f64; 6]); 5]) -> Result<String> {
    let mut jobs = Vec::new();
    for m in &args.models {
        for seed in seeds(args) {
            jobs.push(Job {
                kc,
                ki: kc,
                ..nominal(m, 9.0, 3.0, 0.0, seed, Criterion::Prediction)
            });
        }
    }
    let res = run_all(name, &jobs);
    write_runs(&args.out.join(format!("{name}.csv")), &jobs, &res)?;
    let mut md = format!(
        "### {name}: Kano S = 9, J = 3, a = 0, Kc = KI = {kc}, {} runs\n\n\
         | model | S̄ ours | S̄ paper | σ_S ours | σ_S paper | J̄ ours | J̄ paper | σ_J ours | σ_J paper | F_id ours | F_id paper | F_val ours | F_val paper | E_G ours | failed |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        args.runs
    );
    for (m, s) in group(&jobs, &res, |j| j.model.clone()) {
        let p = paper
            .iter()
            .find(|(n, _)| *n == m)
            .map(|(_, v)| *v)
            .unwrap_or([f64::NAN; 6]);
        let _ = writeln!(
            md,
            "| {m} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1} | {} |",
            f2(s.s.0),
            f2(p[0]),
            f2(s.s.1),
            f2(p[1]),
            f2(s.j.0),
            f2(p[2]),
            f2(s.j.1),
            f2(p[3]),
            f2(s.pred_id),
            f2(p[4]),
            f2(s.pred_val),
            f2(p[5]),
            s.e_g,
            s.failed
        );
    }
    Ok(md)
}

fn sweep_md(title: &str, jobs: &[Job], res: &[Result<Outcome, String>], by_a: bool) -> String {
    let mut md = format!(
        "### {title}\n\n| model | {} | S̄_id | σ_S | J̄_id | σ_J | E_G | F_val | S hit | J hit | failed |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
        if by_a { "a" } else { "S, J" }
    );
    let rows = group(jobs, res, |j| {
        (
            j.model.clone(),
            (j.a * 1000.0).round() as i64,
            (j.s * 1000.0).round() as i64,
            (j.j * 1000.0).round() as i64,
        )
    });
    // Order: model (args order) then case.
    let mut rows = rows;
    let order: Vec<String> = jobs
        .iter()
        .map(|j| j.model.clone())
        .fold(Vec::new(), |mut v, m| {
            if !v.contains(&m) {
                v.push(m);
            }
            v
        });
    rows.sort_by_key(|((m, a, s, j), _)| (order.iter().position(|x| x == m), *a, *s, *j));
    for ((m, a, s, j), su) in rows {
        let case = if by_a {
            format!("{:.1}", a as f64 / 1000.0)
        } else {
            format!("({}, {})", s as f64 / 1000.0, j as f64 / 1000.0)
        };
        let _ = writeln!(
            md,
            "| {m} | {case} | {} | {} | {} | {} | {:.1} | {:.2} | {} | {} |",
            f2(su.s.0),
            f2(su.s.1),
            f2(su.j.0),
            f2(su.j.1),
            su.e_g,
            su.pred_val,
            su.hit_cells(),
            su.failed
        );
    }
    md
}

fn fig(args: &Args, name: &str, a: f64) -> Result<String> {
    let mut jobs = Vec::new();
    for m in &args.models {
        for &(s, j) in &PAIRS {
            for seed in seeds(args) {
                jobs.push(nominal(m, s, j, a, seed, Criterion::Prediction));
            }
        }
    }
    let res = run_all(name, &jobs);
    write_runs(&args.out.join(format!("{name}.csv")), &jobs, &res)?;
    Ok(sweep_md(
        &format!(
            "{name}: a = {a}, Kc = KI = 0.5, {} runs per case (S hit: |S_id - S| <= 0.25, J hit: |J_id - J| <= 0.5)",
            args.runs
        ),
        &jobs,
        &res,
        false,
    ))
}

fn fig7(args: &Args) -> Result<String> {
    let mut jobs = Vec::new();
    for m in &args.models {
        for i in 0..=10 {
            let a = i as f64 / 10.0;
            for seed in seeds(args) {
                jobs.push(nominal(m, 5.0, 2.0, a, seed, Criterion::Prediction));
            }
        }
    }
    let res = run_all("fig7", &jobs);
    write_runs(&args.out.join("fig7.csv"), &jobs, &res)?;
    Ok(sweep_md(
        &format!(
            "fig7: S = 5, J = 2, a = 0 … 1, Kc = KI = 0.5, {} runs per case",
            args.runs
        ),
        &jobs,
        &res,
        true,
    ))
}

fn criterion(args: &Args) -> Result<String> {
    // The paper's benchmark (plant eq. 10, σ_e = 0.1), then the slower plant of spec §6.3 on
    // which spec §5.5 observed the free-run criterion picking S = J = 0, at two noise levels.
    let settings = [
        (PlantPreset::Paper, 0.1),
        (PlantPreset::Slow, 0.1),
        (PlantPreset::Slow, 0.02),
    ];
    let mut jobs = Vec::new();
    for (plant, noise) in settings {
        for c in [Criterion::Prediction, Criterion::Simulation] {
            for &(s, j) in &PAIRS {
                for seed in seeds(args) {
                    jobs.push(Job {
                        plant,
                        noise,
                        ..nominal("arx", s, j, 0.0, seed, c)
                    });
                }
            }
        }
    }
    let res = run_all("criterion", &jobs);
    write_runs(&args.out.join("criterion.csv"), &jobs, &res)?;
    let mut md = format!(
        "### criterion: Kano × ARX(2,2), a = 0, Kc = KI = 0.5, default grid, {} seeds per pair\n\n\
         | plant | σ_e | criterion | S, J | S̄_id | J̄_id | S hit (±0.25) | J hit (±0.5) | mean abs err S | mean abs err J | F_pred_val | F_sim_val |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
        args.runs
    );
    let rows = group(&jobs, &res, |j| {
        (
            j.plant == PlantPreset::Slow,
            -((j.noise * 1000.0).round() as i64),
            j.criterion != Criterion::Prediction,
            (j.s * 1000.0).round() as i64,
            (j.j * 1000.0).round() as i64,
        )
    });
    for ((slow, noise, c, s, j), su) in &rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | ({}, {}) | {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} |",
            if *slow { "slow" } else { "paper" },
            -*noise as f64 / 1000.0,
            if *c { "simulation" } else { "prediction" },
            *s as f64 / 1000.0,
            *j as f64 / 1000.0,
            f2(su.s.0),
            f2(su.j.0),
            su.hit_cells(),
            su.err_s,
            su.err_j,
            su.pred_val,
            su.sim_val
        );
    }
    md.push_str("\n| plant | σ_e | criterion | loops | S hit | J hit | mean abs err S | mean abs err J | failed |\n|---|---|---|---|---|---|---|---|---|\n");
    for ((slow, noise, c), su) in group(&jobs, &res, |j| {
        (
            j.plant == PlantPreset::Slow,
            -((j.noise * 1000.0).round() as i64),
            j.criterion != Criterion::Prediction,
        )
    }) {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} |",
            if slow { "slow" } else { "paper" },
            -noise as f64 / 1000.0,
            if c { "simulation" } else { "prediction" },
            su.recovery_cells(0, 2)
        );
    }
    Ok(md)
}

/// `n` loops: S ~ U[1, 12], J ~ U[0.5, min(4, S)] drawn by SplitMix64 from `rng_seed`, seeds
/// seed0.. (same draw as the test `grid-search/tests/recovery.rs`, with a different generator
/// seed).
fn recovery_loops(n: usize, rng_seed: u64, seed0: u64) -> Vec<(f64, f64, u64)> {
    let mut rng = SplitMix64::seed_from_u64(rng_seed);
    (0..n)
        .map(|i| {
            let s = 1.0 + 11.0 * rng.random::<f64>();
            let j = 0.5 + (4.0f64.min(s) - 0.5) * rng.random::<f64>();
            (s, j, seed0 + i as u64)
        })
        .collect()
}

fn recovery(args: &Args) -> Result<String> {
    let mut md = format!(
        "### recovery: Kano × ARX, default coarse-to-fine grid, In.3, prediction; {} loops per setting, S ~ U[1, 12], J ~ U[0.5, min(4, S)], a = 0, Kc = KI = 0.5\n\n\
         | plant | linear model | σ_e | loops | S within 0.25 | J within 0.5 | mean abs err S | mean abs err J | failed |\n|---|---|---|---|---|---|---|---|---|\n",
        args.loops
    );
    // The paper's plant with the paper's ARX(2,2); the slower third-order plant of spec §6.3
    // with the paper's ARX(2,2) (order mismatch) and with ARX(3,3) (the true order).
    let settings: [(PlantPreset, f64, usize); 3] = [
        (PlantPreset::Paper, 0.1, 2),
        (PlantPreset::Slow, 0.05, 2),
        (PlantPreset::Slow, 0.05, 3),
    ];
    let mut all_jobs = Vec::new();
    for (plant, noise, order) in settings {
        for (s, j, seed) in recovery_loops(args.loops, 2024, args.seed + 1000) {
            all_jobs.push(Job {
                plant,
                noise,
                orders: if order == 2 {
                    Vec::new()
                } else {
                    let order = linear_id::OrderValue::Int(order);
                    vec![("n".into(), order), ("m".into(), order)]
                },
                ..nominal("arx", s, j, 0.0, seed, Criterion::Prediction)
            });
        }
    }
    let res = run_all("recovery", &all_jobs);
    write_runs(&args.out.join("recovery.csv"), &all_jobs, &res)?;
    for ((p, m, n), su) in group(&all_jobs, &res, |j| {
        (
            format!("{:?}", j.plant),
            j.model_label(),
            (j.noise * 1000.0) as i64,
        )
    }) {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} |",
            p.to_lowercase(),
            m,
            n as f64 / 1000.0,
            su.recovery_cells(1, 3)
        );
    }
    // The misses, for the record.
    let misses: Vec<String> = all_jobs
        .iter()
        .zip(&res)
        .filter_map(|(j, r)| match r {
            Ok(o) if (o.s_id - j.s).abs() > 0.25 + 1e-9 => Some(format!(
                "{:?} {} σ={} seed {}: S = {:.2}, J = {:.2} → S_id = {:.2}, J_id = {:.2}",
                j.plant,
                j.model_label(),
                j.noise,
                j.seed,
                j.s,
                j.j,
                o.s_id,
                o.j_id
            )),
            Err(e) => Some(format!(
                "{:?} {} σ={} seed {}: S = {:.2}, J = {:.2} → failed: {e}",
                j.plant,
                j.model_label(),
                j.noise,
                j.seed,
                j.s,
                j.j
            )),
            _ => None,
        })
        .collect();
    if !misses.is_empty() {
        md.push_str("\nS misses:\n\n");
        for m in misses {
            let _ = writeln!(md, "- {m}");
        }
    }
    Ok(md)
}

/// `cargo xtask reproduce ...`.
pub fn reproduce(rest: &[String]) -> Result<()> {
    let args = parse_args(rest)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let start = Instant::now();
    let mut report = format!(
        "# cargo xtask reproduce --runs {} --only {} --models {}\n\n",
        args.runs,
        args.only.join(","),
        args.models.join(",")
    );
    for what in args.only.clone() {
        let t = Instant::now();
        let md = match what.as_str() {
            "table1" => table(&args, "table1", 1.2, &PAPER_TABLE1)?,
            "table2" => table(&args, "table2", 0.2, &PAPER_TABLE2)?,
            "fig5" => fig(&args, "fig5", 0.0)?,
            "fig6" => fig(&args, "fig6", 0.25)?,
            "fig7" => fig7(&args)?,
            "criterion" => criterion(&args)?,
            "recovery" => recovery(&args)?,
            _ => unreachable!("checked in parse_args"),
        };
        let md = format!("{md}\n(wall time {:.0} s)\n\n", t.elapsed().as_secs_f64());
        print!("{md}");
        report.push_str(&md);
    }
    let _ = writeln!(
        report,
        "total wall time {:.0} s, {} threads",
        start.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    let path = args.out.join("report.md");
    std::fs::write(&path, &report).with_context(|| format!("writing {}", path.display()))?;
    let json = serde_json::json!({
        "runs": args.runs,
        "only": args.only,
        "models": args.models,
        "wall_time_s": start.elapsed().as_secs_f64(),
    });
    std::fs::write(
        args.out.join("meta.json"),
        serde_json::to_string_pretty(&json)?,
    )?;
    eprintln!(
        "wrote {} (total {:.0} s)",
        path.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
