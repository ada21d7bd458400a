//! `cargo xtask detect-calibrate`: fit the detection score's logistic coefficients and
//! validate them, leaving one valve out.
//!
//! Data:
//! * simulated loops from `datasets::simulate` (half self-regulating, half integrating; half
//!   with a sticky Kano valve, S in [1, 8] %, J in [0, S]; half with a free valve), each with
//!   one of four situations: set-point moves only, an external sinusoid, aggressive tuning
//!   (closed-loop poles near the unit circle), or a slow drift with random load steps (the
//!   disturbances sized in % of the valve's travel through the plant's input gain; OP clipped
//!   to 0-100 % with conditional integration); plant
//!   dynamics, tuning, noise and disturbance sizes drawn per loop from a seeded generator. A
//!   training set (seeds from 1) and an independent validation set (seeds from 1 000 001);
//! * the shared plant registrations (`../shared/data/plant`, labels from its `labels.csv`,
//!   used only as the answer: the detector reads the time series alone). Integrating loops are
//!   the level loops by the ISA tag letter `L`, the rule of the CLI's `--integrating auto`.
//!
//! Fit: by default on the simulated training loops alone; the plant registrations only
//! validate, so every plant score is out of sample (leave one valve out holds trivially: no
//! registration of any valve is in the fit). Measured with this tool on the shared data:
//! fitted on the simulations and the other valves' registrations (`--with-plant`, the first
//! calibration), the leave-one-valve-out ROC AUC was 0.429 with 83 % inconclusive; fitted on
//! the simulations alone, 0.714 with 74.5 % inconclusive: two sticky valves (one with 23 of
//! the 26 sticky registrations) are too few to calibrate on, and fitting on them taught the
//! model the other valve's shape.
//!
//! Validation: for every plant valve (the tag before `_`), the model (with `--with-plant`:
//! fitted on the simulated training loops and the registrations of the *other* valves) scores
//! that valve's registrations (LOVO). The simulated validation loops are scored by the final
//! model, whose coefficients are printed for `detection/src/score.rs`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use datasets::simulate::{
    Controller, Disturbance, Plant, PlantPreset, PlantSpec, Scenario, Setpoint,
};
use detection::hammerstein::{oracle_lr, REGION_LR};
use detection::score::{features, Model, FEATURES, NO_STICTION_AT, STICTION_AT};
use detection::{combine, logistic, registry, run_all, Registration, TestOutcome, Verdict};
use rayon::prelude::*;
use stiction_models::{He, Kano, StictionModel};

const USAGE: &str = "\
usage: cargo xtask detect-calibrate [--sims N] [--plant DIR] [--ridge L] [--with-plant] [--dump DIR] [--valve kano|he] [--samples N]

  --sims N     simulated loops in the training set and again in the validation set (default 240)
  --plant DIR  the labelled plant registrations (default ../shared/data/plant beside the repo)
  --ridge L    ridge penalty of the logistic fit (default 0.1)
  --with-plant also fit on the plant registrations (of the other valves, for leave one valve
               out); by default they only validate: measured, fitting on them made the
               leave-one-valve-out AUC worse (0.429 against 0.714 from the simulations alone)
  --dump DIR   also write the simulated validation loops as CSV (t, SP, PV, OP) with an index.csv
  --valve M    the sticky valves of the validation loops: `kano` (default, as in training) or
               `he` (He et al.'s friction model at the same S and J: a check that the score
               holds for a valve model it was not fitted on)
  --samples N  samples per validation loop (default 751, as in training): the score's
               likelihood ratios grow with the record's length";

/// SplitMix64: a small seeded generator (the draw order is the code order below).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// One labelled registration.
struct Case {
    /// The valve (plant) or `sim` (simulated).
    group: String,
    /// What it is, for the tables.
    what: String,
    sticky: bool,
    sp: Option<Vec<f64>>,
    pv: Vec<f64>,
    op: Vec<f64>,
    ts: f64,
    integrating: bool,
    outcomes: Vec<TestOutcome>,
    x: Vec<f64>,
    /// Simulated loops: how much better the true valve position explains the valve's proxy
    /// than OP does ([`detection::hammerstein::oracle_lr`]).
    oracle: Option<f64>,
}

impl Case {
    fn registration(&self) -> Result<Registration<'_>> {
        let reg = Registration::new(&self.pv, &self.op, self.ts)?.integrating(self.integrating);
        Ok(match &self.sp {
            Some(sp) => reg.with_sp(sp)?,
            None => reg,
        })
    }
    fn evaluate(mut self) -> Result<Case> {
        let outcomes = run_all(&self.registration()?);
        self.x = features(&outcomes);
        self.outcomes = outcomes;
        Ok(self)
    }
}

const SITUATIONS: [&str; 4] = [
    "set-point moves",
    "external sine",
    "aggressive tuning",
    "drift + load steps",
];

/// Simulated loop `index` of the set starting at `seed0`.
fn simulated(seed0: u64, index: usize, he: bool, samples: usize) -> Result<Case> {
    let seed = seed0 + index as u64;
    let mut rng = Rng(seed.wrapping_mul(0xD1B5_4A32_D192_ED03));
    let integrating = index % 2 == 1;
    let sticky = (index / 2).is_multiple_of(2);
    let situation = (index / 4) % SITUATIONS.len();
    // Plant.
    let delay = (rng.next() * 3.0) as usize;
    let pole = rng.range(0.0, 0.95);
    let gain = rng.range(0.5, 2.0);
    let plant = if integrating {
        let g = rng.range(0.02, 0.2);
        if rng.next() < 0.5 {
            Plant {
                a: vec![1.0, -1.0],
                b: vec![0.0, g],
                c: vec![1.0],
                delay,
            }
        } else {
            let p = rng.range(0.3, 0.8);
            Plant {
                a: vec![1.0, -(1.0 + p), p],
                b: vec![0.0, g * (1.0 - p)],
                c: vec![1.0],
                delay,
            }
        }
    } else {
        Plant {
            a: vec![1.0, -pole],
            b: vec![0.0, gain * (1.0 - pole)],
            c: vec![1.0],
            delay,
        }
    };
    // Tuning: a draw, scaled down until stable; for the aggressive situation scaled up until
    // the closed loop's slowest pole is near the unit circle.
    let (mut kc, mut ki) = if integrating {
        let g = plant.b.iter().sum::<f64>();
        (
            rng.range(0.3, 1.5) / (g * 10.0),
            rng.range(0.01, 0.05) / (g * 10.0),
        )
    } else {
        (rng.range(0.1, 0.8) / gain, rng.range(0.05, 0.3) / gain)
    };
    for _ in 0..60 {
        if plant.check_stability(kc, ki).is_ok() {
            break;
        }
        kc *= 0.8;
        ki *= 0.8;
    }
    if situation == 2 {
        for _ in 0..200 {
            let (nk, ni) = (kc * 1.05, ki * 1.05);
            match plant.check_stability(nk, ni) {
                Ok(m) if m < 0.97 => (kc, ki) = (nk, ni),
                _ => break,
            }
        }
    }
    let s = rng.range(1.0, 8.0);
    let j = rng.range(0.0, 1.0) * s;
    let valve: Box<dyn StictionModel> = match (sticky, he) {
        (true, false) => Box::new(Kano::params().s(s).j(j).check()?),
        (true, true) => Box::new(He::from_sj(s, j)?),
        (false, _) => Box::new(Kano::params().check()?),
    };
    let noise = rng.range(0.01, 0.2);
    // Disturbances enter the plant's difference equation; they are sized in % of the valve's
    // travel (scaled by B(1), the plant's input gain), so that the controller compensates them
    // with OP moves a real valve can make — a load drift on a level otherwise asks OP for
    // hundreds of %.
    let input_gain = plant.b.iter().sum::<f64>();
    let amplitude = rng.range(0.3, 2.0);
    let period = rng.range(20.0, 200.0);
    let slope = rng.range(-0.004, 0.004);
    let disturbances = match situation {
        1 => vec![Disturbance::Sine {
            amplitude: amplitude * input_gain,
            frequency: 2.0 * std::f64::consts::PI / period,
            phase: 0.0,
        }],
        3 => vec![
            Disturbance::Drift {
                slope: slope * input_gain,
            },
            Disturbance::RandomSteps {
                probability: 0.005,
                sigma: amplitude * input_gain,
            },
        ],
        _ => Vec::new(),
    };
    let setpoint = if situation == 0 {
        Setpoint::default()
    } else {
        Setpoint::constant()
    };
    let sim = Scenario {
        plant: PlantSpec::Explicit(plant),
        controller: Controller { kc, ki },
        setpoint,
        valve,
        disturbances,
        noise_sigma: noise,
        samples,
        warmup: 500,
        seed,
        sample_time: 10.0,
        // A valve's travel is 0-100 %: OP saturates (with conditional integration), as a real
        // controller's output does.
        op_limits: Some([0.0, 100.0]),
        ..Scenario::default()
    }
    .simulate()
    .with_context(|| format!("simulated loop {index} (seed {seed})"))?;
    let oracle = if integrating {
        let dpv: Vec<f64> = sim.pv.windows(2).map(|w| w[1] - w[0]).collect();
        oracle_lr(&dpv, &sim.op[1..], &sim.mv[1..])
    } else {
        oracle_lr(&sim.pv, &sim.op, &sim.mv)
    };
    Case {
        group: "sim".into(),
        what: format!(
            "{} {} {}",
            if integrating {
                "integrating"
            } else {
                "self-regulating"
            },
            if sticky {
                format!("{} S={s:.1} J={j:.1}", if he { "he" } else { "kano" })
            } else {
                "free valve".into()
            },
            SITUATIONS[situation]
        ),
        sticky,
        oracle,
        sp: Some(sim.sp),
        pv: sim.pv,
        op: sim.op,
        ts: 10.0,
        integrating,
        outcomes: Vec::new(),
        x: Vec::new(),
    }
    .evaluate()
}

/// Write each case as `sim-<index>.csv` (t, SP, PV, OP) under `dir`, with `index.csv` naming
/// what each is (with the oracle likelihood ratio of the true valve position, empty where
/// there is none).
fn dump_cases(dir: &Path, cases: &[Case]) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut index = String::from("file,what,sticky,integrating,oracle_lr\n");
    for (i, c) in cases.iter().enumerate() {
        let name = format!("sim-{i:03}.csv");
        let mut text = String::from("t,SP,PV,OP\n");
        for k in 0..c.pv.len() {
            let sp = c.sp.as_ref().map_or(f64::NAN, |s| s[k]);
            text.push_str(&format!(
                "{},{sp},{},{}\n",
                k as f64 * c.ts,
                c.pv[k],
                c.op[k]
            ));
        }
        std::fs::write(dir.join(&name), text).with_context(|| format!("writing {name}"))?;
        let oracle = c.oracle.map_or(String::new(), |v| format!("{v:.2}"));
        index.push_str(&format!(
            "{name},{},{},{},{oracle}\n",
            c.what, c.sticky, c.integrating
        ));
    }
    std::fs::write(dir.join("index.csv"), index).context("writing index.csv")
}

/// The labelled plant registrations the reader accepts, and the files it refuses.
fn plant_cases(dir: &Path) -> Result<(Vec<Case>, Vec<String>)> {
    let labels = std::fs::read_to_string(dir.join("labels.csv"))
        .with_context(|| format!("reading {}", dir.join("labels.csv").display()))?;
    let mut cases = Vec::new();
    let mut refused = Vec::new();
    for line in labels.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        let (Some(file), Some(label)) = (cols.first(), cols.get(6)) else {
            continue;
        };
        let valve = file.split('_').next().unwrap_or(file).to_string();
        let sticky = match *label {
            "stiction" => true,
            "no-stiction" => false,
            other => bail!("{file}: unknown label {other:?}"),
        };
        let d = match datasets::read_path(dir.join(file), &datasets::ReadOptions::default()) {
            Ok(d) => d,
            Err(e) => {
                refused.push(format!("{file}: {e}"));
                continue;
            }
        };
        let ts =
            d.t.as_ref()
                .and_then(|t| {
                    let dts: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
                    (!dts.is_empty()).then(|| monitoring::median(&dts))
                })
                .filter(|v| v.is_finite() && *v > 0.0)
                .unwrap_or(1.0);
        let integrating = valve
            .chars()
            .find(|c| c.is_ascii_alphabetic())
            .is_some_and(|c| c.eq_ignore_ascii_case(&'l'));
        cases.push(Case {
            group: valve,
            what: file.to_string(),
            sticky,
            sp: d.sp.clone(),
            pv: d.require_pv()?.to_vec(),
            op: d.op.clone(),
            ts,
            integrating,
            outcomes: Vec::new(),
            x: Vec::new(),
            oracle: None,
        });
    }
    let cases = cases
        .into_iter()
        .map(Case::evaluate)
        .collect::<Result<Vec<_>>>()?;
    Ok((cases, refused))
}

fn fit(cases: &[&Case], ridge: f64) -> Result<Model> {
    let x: Vec<Vec<f64>> = cases.iter().map(|c| c.x.clone()).collect();
    let y: Vec<bool> = cases.iter().map(|c| c.sticky).collect();
    let w = vec![1.0; x.len()];
    let f = logistic::fit(&x, &y, &w, ridge).context("the logistic fit failed (singular)")?;
    Ok(Model {
        intercept: f.intercept,
        weights: f.weights,
    })
}

/// Score and verdict of `case` under `model`.
fn judge(case: &Case, model: &Model) -> Result<(f64, Verdict)> {
    let d = combine(&case.registration()?, case.outcomes.clone(), model);
    Ok((d.score, d.verdict))
}

/// The threshold on the score (midway between two scores) that decides the most of `v`
/// right, stiction above it.
fn best_threshold(v: &[(f64, bool)]) -> f64 {
    let mut by_score = v.to_vec();
    by_score.sort_by(|a, b| a.0.total_cmp(&b.0));
    let sticky_total = by_score.iter().filter(|(_, l)| *l).count();
    let mut best = (sticky_total, by_score.first().map_or(0.5, |x| x.0 - 1e-9));
    let mut free_below = 0;
    let mut sticky_below = 0;
    for (i, (s, l)) in by_score.iter().enumerate() {
        if *l {
            sticky_below += 1;
        } else {
            free_below += 1;
        }
        let Some(next) = by_score.get(i + 1).map(|x| x.0) else {
            break;
        };
        if next == *s {
            continue;
        }
        let right = free_below + sticky_total - sticky_below;
        if right > best.0 {
            best = (right, 0.5 * (s + next));
        }
    }
    best.1
}

/// AUC (ties one half) of `(score, label)`, `None` without both classes.
fn auc(v: &[(f64, bool)]) -> Option<f64> {
    monitoring::roc(v).map(|r| r.auc)
}

/// `% right of conclusive`, `% inconclusive`, `% right of all`.
fn rates(v: &[(Verdict, bool)]) -> (f64, f64, f64) {
    let n = v.len().max(1) as f64;
    let conclusive: Vec<&(Verdict, bool)> = v
        .iter()
        .filter(|(d, _)| *d != Verdict::Inconclusive)
        .collect();
    let right = conclusive
        .iter()
        .filter(|(d, l)| (*d == Verdict::Stiction) == *l)
        .count() as f64;
    (
        100.0 * right / conclusive.len().max(1) as f64,
        100.0 * (v.len() - conclusive.len()) as f64 / n,
        100.0 * right / n,
    )
}

fn fmt_auc(a: Option<f64>) -> String {
    a.map_or("  -  ".into(), |a| format!("{a:.3}"))
}

/// Per-test AUC of its statistic (higher = stiction) over the cases where it has one.
fn test_aucs(cases: &[&Case]) -> Vec<(String, Option<f64>, usize)> {
    registry()
        .iter()
        .map(|e| {
            let v: Vec<(f64, bool)> = cases
                .iter()
                .filter_map(|c| {
                    c.outcomes
                        .iter()
                        .find(|o| o.name == e.name)
                        .and_then(|o| o.statistic)
                        .filter(|s| s.is_finite())
                        .map(|s| (s, c.sticky))
                })
                .collect();
            (e.name.to_string(), auc(&v), v.len())
        })
        .collect()
}

/// `cargo xtask detect-calibrate`.
pub fn detect_calibrate(rest: &[String]) -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut sims = 240usize;
    let mut plant_dir: PathBuf = root.join("../shared/data/plant");
    let mut ridge = 0.1;
    let mut with_plant = false;
    let mut dump: Option<PathBuf> = None;
    let mut he = false;
    let mut samples = 751;
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| {
            it.next()
                .with_context(|| format!("{name} needs a value\n{USAGE}"))
        };
        match a.as_str() {
            "--sims" => sims = value("--sims")?.parse().context("--sims: a whole number")?,
            "--plant" => plant_dir = PathBuf::from(value("--plant")?),
            "--ridge" => ridge = value("--ridge")?.parse().context("--ridge: a number")?,
            "--with-plant" => with_plant = true,
            "--dump" => dump = Some(PathBuf::from(value("--dump")?)),
            "--samples" => {
                samples = value("--samples")?
                    .parse()
                    .context("--samples: a whole number")?;
                if samples < detection::MIN_SAMPLES {
                    bail!(
                        "--samples: at least {} (a shorter registration is not judged)",
                        detection::MIN_SAMPLES
                    );
                }
            }
            "--valve" => {
                he = match value("--valve")?.as_str() {
                    "kano" => false,
                    "he" => true,
                    other => bail!("--valve: `kano` or `he`, not {other:?}"),
                }
            }
            "--help" | "-h" => {
                println!("{USAGE}");
                return Ok(());
            }
            other => bail!("unknown option {other:?}\n{USAGE}"),
        }
    }
    let started = std::time::Instant::now();
    let train: Vec<Case> = (0..sims)
        .into_par_iter()
        .map(|i| simulated(1, i, false, 751))
        .collect::<Result<_>>()?;
    let valid: Vec<Case> = (0..sims)
        .into_par_iter()
        .map(|i| simulated(1_000_001, i, he, samples))
        .collect::<Result<_>>()?;
    if let Some(dir) = &dump {
        dump_cases(dir, &valid)?;
        println!(
            "wrote the {} validation loops to {}",
            valid.len(),
            dir.display()
        );
    }
    let (plant, refused) = if plant_dir.join("labels.csv").exists() {
        plant_cases(&plant_dir)?
    } else {
        println!(
            "note: {} not found: calibrating on simulated loops only",
            plant_dir.display()
        );
        (Vec::new(), Vec::new())
    };
    println!(
        "data: {} simulated training loops, {} simulated validation loops, {} plant registrations ({} refused by the reader) [{:.1} s]",
        train.len(),
        valid.len(),
        plant.len(),
        refused.len(),
        started.elapsed().as_secs_f64()
    );
    for r in &refused {
        println!("  refused: {r}");
    }

    // Leave one valve out.
    let valves: Vec<String> = {
        let mut v: Vec<String> = plant.iter().map(|c| c.group.clone()).collect();
        v.dedup();
        v.sort();
        v.dedup();
        v
    };
    let mut lovo: Vec<(f64, Verdict, bool)> = Vec::new();
    let mut per_valve: BTreeMap<String, (bool, usize, f64, [usize; 3])> = BTreeMap::new();
    for v in &valves {
        let fit_on: Vec<&Case> = train
            .iter()
            .chain(plant.iter().filter(|c| with_plant && &c.group != v))
            .collect();
        let model = fit(&fit_on, ridge)?;
        for c in plant.iter().filter(|c| &c.group == v) {
            let (s, d) = judge(c, &model)?;
            lovo.push((s, d, c.sticky));
            let e = per_valve
                .entry(v.clone())
                .or_insert((c.sticky, 0, 0.0, [0; 3]));
            e.1 += 1;
            e.2 += s;
            e.3[match d {
                Verdict::Stiction => 0,
                Verdict::NoStiction => 1,
                _ => 2,
            }] += 1;
        }
    }
    // Final model and the simulated validation set.
    let all: Vec<&Case> = train
        .iter()
        .chain(plant.iter().filter(|_| with_plant))
        .collect();
    let model = fit(&all, ridge)?;
    let sim_judged: Vec<(f64, Verdict, bool, &Case)> = valid
        .iter()
        .map(|c| judge(c, &model).map(|(s, d)| (s, d, c.sticky, c)))
        .collect::<Result<_>>()?;

    println!(
        "\nfinal model (simulated training loops{}, ridge {ridge}):",
        if with_plant {
            " + all plant registrations"
        } else {
            " only; the plant registrations validate"
        }
    );
    println!("pub const INTERCEPT: f64 = {:.4};", model.intercept);
    println!(
        "pub const WEIGHTS: [f64; {}] = [{}];",
        model.weights.len(),
        model
            .weights
            .iter()
            .map(|w| format!("{w:.4}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for (f, w) in FEATURES.iter().zip(&model.weights) {
        println!("  {:16} {:>8.3}   ({}: {})", f.name, w, f.test, f.meaning);
    }

    if !plant.is_empty() {
        println!("\nplant registrations, leave one valve out:");
        println!(
            "valve            label        n  mean score  stiction  no-stiction  inconclusive"
        );
        for (v, (sticky, n, sum, c)) in &per_valve {
            println!(
                "{v:16} {:12} {n:>2}  {:>10.2}  {:>8}  {:>11}  {:>12}",
                if *sticky { "stiction" } else { "no-stiction" },
                sum / *n as f64,
                c[0],
                c[1],
                c[2]
            );
        }
        let sv: Vec<(f64, bool)> = lovo.iter().map(|(s, _, l)| (*s, *l)).collect();
        let dv: Vec<(Verdict, bool)> = lovo.iter().map(|(_, d, l)| (*d, *l)).collect();
        let (right, inconclusive, _) = rates(&dv);
        println!(
            "score: LOVO ROC AUC {}, verdict right on {right:.1} % of the conclusive, {inconclusive:.1} % inconclusive ({} registrations)",
            fmt_auc(auc(&sv)),
            lovo.len()
        );
        println!("\neach test's own statistic on the plant registrations (AUC where it has one; not fitted):");
        let refs: Vec<&Case> = plant.iter().collect();
        for (name, a, n) in test_aucs(&refs) {
            let verdicts: Vec<(Verdict, bool)> = plant
                .iter()
                .filter_map(|c| {
                    c.outcomes
                        .iter()
                        .find(|o| o.name == name)
                        .map(|o| (o.verdict, c.sticky))
                })
                .collect();
            let (right, inc, _) = rates(&verdicts);
            println!(
                "  {name:18} AUC {} over {n:>2}; own verdict right on {right:5.1} % of its conclusive, {inc:5.1} % inconclusive",
                fmt_auc(a)
            );
        }
    }

    println!("\nsimulated validation loops (fresh seeds), final model:");
    let sv: Vec<(f64, bool)> = sim_judged.iter().map(|(s, _, l, _)| (*s, *l)).collect();
    let dv: Vec<(Verdict, bool)> = sim_judged.iter().map(|(_, d, l, _)| (*d, *l)).collect();
    let (right, inconclusive, right_all) = rates(&dv);
    println!(
        "score ROC AUC {}; verdict right on {right_all:.1} % of all loops ({right:.1} % of the conclusive, {inconclusive:.1} % inconclusive)",
        fmt_auc(auc(&sv))
    );
    for integrating in [false, true] {
        for (k, situation) in SITUATIONS.iter().enumerate() {
            let sub: Vec<(Verdict, bool)> = sim_judged
                .iter()
                .enumerate()
                .filter(|(i, (_, _, _, c))| {
                    c.integrating == integrating && (i / 4) % SITUATIONS.len() == k
                })
                .map(|(_, (_, d, l, _))| (*d, *l))
                .collect();
            let (r, inc, all) = rates(&sub);
            println!(
                "  {:16} {situation:20} n {:>3}: right {all:5.1} % of all ({r:5.1} % of conclusive, {inc:5.1} % inconclusive)",
                if integrating { "integrating" } else { "self-regulating" },
                sub.len()
            );
        }
    }
    // What the data can show at best: a sticky valve whose true position explains PV no better
    // than OP does never stuck visibly in the record.
    let hidden = |c: &Case| c.sticky && c.oracle.is_none_or(|lr| lr < REGION_LR);
    let (seen, unseen): (Vec<_>, Vec<_>) = sim_judged.iter().partition(|(.., c)| !hidden(c));
    let of = |v: &[&(f64, Verdict, bool, &Case)]| {
        rates(&v.iter().map(|(_, d, l, _)| (*d, *l)).collect::<Vec<_>>())
    };
    let (r, inc, all) = of(&seen);
    println!(
        "  without the {} sticky loops whose true valve position explains the valve's proxy no better than OP (oracle LR < {REGION_LR}): right {all:.1} % of all {} ({r:.1} % of conclusive, {inc:.1} % inconclusive)",
        unseen.len(),
        seen.len()
    );
    let count = |v: Verdict| unseen.iter().filter(|(_, d, ..)| *d == v).count();
    println!(
        "    those {}: stiction {}, no-stiction {}, inconclusive {}",
        unseen.len(),
        count(Verdict::Stiction),
        count(Verdict::NoStiction),
        count(Verdict::Inconclusive)
    );
    // Why the undecided loops are undecided, in the order of `combine`'s rule.
    let mut why = [[0usize; 2]; 4];
    for (s, d, l, c) in &sim_judged {
        if *d == Verdict::Inconclusive {
            let k = if c.registration()?.check().is_err() {
                0
            } else if *s >= STICTION_AT {
                1
            } else if *s <= NO_STICTION_AT {
                2
            } else {
                3
            };
            why[k][usize::from(*l)] += 1;
        }
    }
    for (k, what) in [
        "the record cannot be judged (too short, flat, OP or PV without motion)",
        "score high, but no oscillation, no stick-slip, no sticky valve explaining PV",
        "score low, but the likelihood region keeps a band of 2 % or more (HIDDEN_S)",
        "score between the two thresholds",
    ]
    .iter()
    .enumerate()
    {
        println!(
            "  inconclusive: {what}: {} free, {} sticky",
            why[k][0], why[k][1]
        );
    }
    // The score alone with every loop decided at one threshold: chosen on the training loops
    // (fair), and chosen on these validation loops (the ceiling of the score, optimistic).
    let train_scores: Vec<(f64, bool)> = train
        .iter()
        .map(|c| judge(c, &model).map(|(s, _)| (s, c.sticky)))
        .collect::<Result<_>>()?;
    let right_at = |v: &[(f64, bool)], t: f64| v.iter().filter(|(s, l)| (*s > t) == *l).count();
    let visible: Vec<(f64, bool)> = sim_judged
        .iter()
        .filter(|(.., c)| !hidden(c))
        .map(|(s, _, l, _)| (*s, *l))
        .collect();
    for (how, t) in [
        (
            "chosen on the training loops",
            best_threshold(&train_scores),
        ),
        ("chosen on these loops (optimistic)", best_threshold(&sv)),
    ] {
        println!(
            "  the score alone at one threshold {t:.2}, {how}, every loop decided: right on {:.1} % of all ({:.1} % of the {} without the hidden sticky loops)",
            100.0 * right_at(&sv, t) as f64 / sv.len().max(1) as f64,
            100.0 * right_at(&visible, t) as f64 / visible.len().max(1) as f64,
            visible.len()
        );
    }
    let wrong: Vec<&(f64, Verdict, bool, &Case)> = sim_judged
        .iter()
        .filter(|(_, d, l, _)| *d != Verdict::Inconclusive && (*d == Verdict::Stiction) != *l)
        .collect();
    for (s, d, _, c) in wrong.iter().take(12) {
        println!(
            "  wrong: {} -> {d} (score {s:.2}; oracle LR {})",
            c.what,
            c.oracle.map_or("-".into(), |v| format!("{v:.1}"))
        );
    }
    println!("\neach test's own statistic on the simulated validation loops:");
    let refs: Vec<&Case> = valid.iter().collect();
    for (name, a, n) in test_aucs(&refs) {
        println!("  {name:18} AUC {} over {n:>3}", fmt_auc(a));
    }
    paper_benchmark(&model)?;
    println!("\n[{:.1} s]", started.elapsed().as_secs_f64());
    Ok(())
}

/// The valves of [`paper_benchmark`]: `(S, J)`.
const PAPER_VALVES: [(f64, f64); 4] = [(0.0, 0.0), (1.0, 0.5), (3.0, 1.0), (9.0, 3.0)];
/// Seeds per cell of [`paper_benchmark`].
const PAPER_SEEDS: u64 = 6;

/// One loop of the reference paper's benchmark (`stiction simulate` with these settings):
/// its third-order ARMAX plant (or the slower preset), PI 0.5/0.5, random-walk set point,
/// the paper's two-sine disturbance of amplitude `a`, 1 500 samples.
fn paper_case(preset: PlantPreset, a: f64, s: f64, j: f64, seed: u64) -> Result<Case> {
    let sim = Scenario {
        plant: PlantSpec::Preset(preset),
        valve: Box::new(Kano::params().s(s).j(j).check()?),
        disturbances: if a > 0.0 {
            vec![Disturbance::Paper { a }]
        } else {
            Vec::new()
        },
        samples: 1500,
        seed,
        ..Scenario::default()
    }
    .simulate()
    .with_context(|| format!("paper benchmark {preset:?} a = {a} S = {s} seed {seed}"))?;
    Case {
        group: "paper".into(),
        what: format!("{preset:?} a={a} S={s} J={j} seed {seed}"),
        sticky: s > 0.0,
        oracle: None,
        sp: Some(sim.sp),
        pv: sim.pv,
        op: sim.op,
        ts: 1.0,
        integrating: false,
        outcomes: Vec::new(),
        x: Vec::new(),
    }
    .evaluate()
}

/// The final model on loops of another generator: the reference paper's benchmark, whose
/// plants (third order, coloured noise) and disturbance are not those of the training loops.
fn paper_benchmark(model: &Model) -> Result<()> {
    let mut cells = Vec::new();
    for preset in [PlantPreset::Paper, PlantPreset::Slow] {
        for a in [0.0, 0.25, 1.0] {
            for (s, j) in PAPER_VALVES {
                cells.push((preset, a, s, j));
            }
        }
    }
    let judged: Vec<Vec<(Verdict, bool)>> = cells
        .par_iter()
        .map(|&(preset, a, s, j)| {
            (1..=PAPER_SEEDS)
                .map(|seed| {
                    let c = paper_case(preset, a, s, j, seed)?;
                    Ok((judge(&c, model)?.1, c.sticky))
                })
                .collect::<Result<Vec<_>>>()
        })
        .collect::<Result<_>>()?;
    println!(
        "\nthe reference paper's benchmark (`stiction simulate`: plant preset, disturbance a, Kano S/J; {PAPER_SEEDS} seeds, 1 500 samples), final model:"
    );
    println!("plant  a     S    J    stiction  no-stiction  inconclusive");
    for ((preset, a, s, j), v) in cells.iter().zip(&judged) {
        let count = |d: Verdict| v.iter().filter(|(x, _)| *x == d).count();
        println!(
            "{:6} {a:<5} {s:<4} {j:<4} {:>8}  {:>11}  {:>12}",
            format!("{preset:?}").to_lowercase(),
            count(Verdict::Stiction),
            count(Verdict::NoStiction),
            count(Verdict::Inconclusive)
        );
    }
    let all: Vec<(Verdict, bool)> = judged.into_iter().flatten().collect();
    let (right, inc, right_all) = rates(&all);
    println!(
        "verdict right on {right_all:.1} % of all {} ({right:.1} % of the conclusive, {inc:.1} % inconclusive)",
        all.len()
    );
    Ok(())
}
