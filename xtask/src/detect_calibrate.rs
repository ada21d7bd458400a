//! `cargo xtask detect-calibrate`: fit the detection score's logistic coefficients on a
//! simulated training population and measure them on simulated populations never used for
//! fitting; the shared plant registrations are a test set, measured and printed last.
//!
//! The protocol (`docs/DETECTION.md`, "Calibration"):
//! * **Training population** (`datasets::simulate::population`, seed 1): flow, pressure and
//!   level loops, `Ts` 2-30 s, `N` 300-3000 samples, 960 loops; half sticky valves, half free.
//! * **Validation populations**, each with its own seeds, none used for fitting: the training
//!   ranges again (`in range`), and settings outside them: `N = 400`, `N = 4000`, `Ts = 1 s`,
//!   `Ts = 60 s` (the training families otherwise), the family left out of training
//!   (`composition`: slow second-order loops with long dead time, the training's `Ts` and `N`)
//!   the controller left out of training (`P-only`: the training ranges under
//!   proportional-only controllers) and long dead times (`dead time 10-60 s`: the training
//!   ranges with a transport delay of 10-60 s added to every process).
//! * **Figures**, per loop kind (self-regulating, integrating) and overall: the score's ROC AUC
//!   (sticky against free), the verdict right on the conclusive (a conclusive verdict on a loop
//!   whose OP barely moves counts as wrong: it cannot be judged), the share of sticky and free
//!   loops left inconclusive, and how many of the loops that cannot be judged got
//!   `inconclusive`.
//! * **The ceiling**: per population and loop kind, what an observer who knows everything of a
//!   loop but its noise and disturbances can see ([`known_model_lr`]): its AUC, its sticky
//!   loops that show nothing, and the score's AUC beside it ([`tables::ceiling`]).
//! * **Loop kind**: the training population is fitted with each loop's own kind (known, like
//!   its label); the validation populations are judged as `--integrating auto` judges a
//!   record (decided by [`detection::kind::evidence`], a level's tag letter `L` breaking a
//!   tie), and the accuracy of that decision is printed.
//! * **Models**: the one in `detection/src/score.rs` as it is (before a refit: the baseline),
//!   and the one fitted here on the training population (ridge-penalised logistic regression
//!   with non-negative weights, [`detection::logistic::fit_nonnegative`]), whose coefficients
//!   are printed for `score.rs`; with it, the training population's 5-fold cross-validated
//!   AUC, the figure on which a choice between score structures is made.
//! * **Test set**: the labelled plant registrations (`../shared/data/plant`), scored by both
//!   models and printed after everything else; nothing here is chosen by them.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use datasets::simulate::population::{known_model_lr, Family, Label, PopulationSpec};
use datasets::simulate::{Disturbance, PlantPreset, PlantSpec, Scenario};
use detection::hammerstein::{oracle_lr, oracle_lr_integrating, REGION_LR};
use detection::score::{
    detect_with, features, parts, settle, settle_on, Evidence, Model, FEATURES, HIDDEN_S,
    NO_STICTION_AT, STICTION_AT,
};
use detection::{combine, logistic, registry, run_all, Registration, TestOutcome, Verdict};
use rayon::prelude::*;
use stiction_models::Kano;

mod cv;
mod files;
mod tables;
use cv::{coefficients, print_cross_validated};
use files::{dump_cases, write_cases};
use tables::{ceiling, held_thresholds, kind_table, paper_benchmark, reasons, trace_and_oracle};

const USAGE: &str = "\
usage: cargo xtask detect-calibrate [--train N] [--train-seed N] [--valid N] [--ridge L] [--plant DIR] [--no-plant] [--integrating auto|truth] [--paper] [--dump DIR] [--cases FILE] [--hold K]

  --train N    loops in the training population (default 960)
  --train-seed N
               the training population's seed (default 1, the one score.rs is fitted on;
               another shows how much the fitted weights move with the draw)
  --valid N    loops in each validation population (default 80)
  --ridge L    ridge penalty of the logistic fit (default 0.1)
  --plant DIR  the labelled plant registrations, the test set (default ../shared/data/plant
               beside the repo); scored, never fitted on
  --no-plant   skip the plant test set
  --integrating auto|truth
               the loop kind the detector is given on the validation populations: decided
               from the record, the tag letter breaking a tie, as `--integrating auto` does
               (default), or the simulation's own (the training population always has its own)
  --paper      also score the reference paper's benchmark (`stiction simulate` loops)
  --dump DIR   also write the `in range` validation loops as CSV (t, SP, PV, OP) with an index.csv
  --cases FILE also write one CSV row per training and validation loop under the fitted model:
               population, description, label, score, verdict, reason and each test's
               statistic and verdict, the Hammerstein test's S, J, delay, region, one-step S
               and the stick-slip window, a sticky loop's oracle LR and PV's share on straight
               segments when the reader calls it compressed (to see which loops a change moves)
  --hold K     every loop's PV held over K samples (at each sample the value of the last
               multiple of K, as an analyser or a historian's step retrieval logs it), the
               training population too: how much a held PV costs the detector, and each
               verdict's share right on the training loops at stricter scores (where
               monitoring::detect::HELD_STICTION_AT and HELD_NO_STICTION_AT come from)";

/// One labelled registration.
#[derive(Clone)]
struct Case {
    /// What it is, for the tables.
    what: String,
    /// The valve sticks (false for free valves and for loops that cannot be judged).
    sticky: bool,
    /// The valve sticks but leaves no trace in the record
    /// (`datasets::simulate::population::Label::NoTrace`; `sticky` is true too).
    no_trace: bool,
    /// Simulated sticky loops: the twin's log-likelihood gain
    /// (`datasets::simulate::population::Trace::lr`).
    trace_lr: Option<f64>,
    /// Whether the verdict must hold under both loop kinds (`--integrating auto` and the
    /// record does not decide the kind: `monitoring::detect::hold_across_kinds`).
    tie: bool,
    /// Score, verdict and reason under the model last judged with ([`judge_all`]).
    judged: Option<Judged>,
    /// The record can show whether the valve sticks (false: OP barely moves).
    judgeable: bool,
    /// The process integrates (the loop kind of the tables).
    kind_integrating: bool,
    sp: Option<Vec<f64>>,
    pv: Vec<f64>,
    op: Vec<f64>,
    ts: f64,
    /// Whether the detector treats the loop as integrating.
    integrating: bool,
    /// What the record alone says of its kind ([`detection::kind::evidence`]; `None`: a tie).
    kind_from_data: Option<bool>,
    outcomes: Vec<TestOutcome>,
    x: Vec<f64>,
    /// Simulated sticky loops: how much better the true valve position explains the valve's
    /// proxy than OP does ([`detection::hammerstein::oracle_lr`]).
    oracle: Option<f64>,
    /// Simulated loops: the log-likelihood ratio of the loop's own valve against a free one
    /// for an observer who knows the plant, the noise's colour and the valve
    /// ([`datasets::simulate::population::known_model_lr`]; 0 for a free valve).
    known_model: Option<f64>,
}

impl Case {
    fn registration(&self) -> Result<Registration<'_>> {
        let reg = Registration::new(&self.pv, &self.op, self.ts)?.integrating(self.integrating);
        Ok(match &self.sp {
            Some(sp) => reg.with_sp(sp)?,
            None => reg,
        })
    }
    fn judged(&self) -> Result<&Judged> {
        self.judged
            .as_ref()
            .with_context(|| format!("{}: not judged", self.what))
    }
    fn evaluate(mut self) -> Result<Case> {
        let outcomes = run_all(&self.registration()?);
        self.x = features(&outcomes);
        self.outcomes = outcomes;
        Ok(self)
    }
}

/// A named population.
struct Set {
    name: &'static str,
    spec: PopulationSpec,
}

/// Order of the AR model through which [`known_model_lr`] reads the disturbances: of 2, 8, 20,
/// 40 and 80, the one whose ceiling AUC over the validation populations (400 loops each) was
/// highest, overall and on the integrating loops (docs/decisions/2026-11-30-known-model-ceiling.md):
/// an oracle is read at its best.
const KNOWN_MODEL_ORDER: usize = 40;

const TRAIN_FAMILIES: [Family; 3] = [Family::Flow, Family::Pressure, Family::Level];
const TRAIN_TS: [f64; 2] = [2.0, 30.0];
const TRAIN_N: [usize; 2] = [300, 3000];

fn training_set(seed: u64) -> Set {
    Set {
        name: "training",
        spec: PopulationSpec {
            seed,
            families: TRAIN_FAMILIES.to_vec(),
            sample_time: TRAIN_TS,
            samples: TRAIN_N,
            ..PopulationSpec::default()
        },
    }
}

/// The validation populations: the training ranges with fresh seeds, then settings outside
/// them.
fn validation_sets() -> Vec<Set> {
    let base = |seed: u64| PopulationSpec {
        seed,
        families: TRAIN_FAMILIES.to_vec(),
        sample_time: TRAIN_TS,
        samples: TRAIN_N,
        ..PopulationSpec::default()
    };
    // The training ranges but for every record's length, or every record's sampling time.
    let length = |name: &'static str, n: usize, seed: u64| Set {
        name,
        spec: PopulationSpec {
            samples: [n, n],
            ..base(seed)
        },
    };
    let sampling = |name: &'static str, ts: f64, seed: u64| Set {
        name,
        spec: PopulationSpec {
            sample_time: [ts, ts],
            ..base(seed)
        },
    };
    vec![
        Set {
            name: "in range",
            spec: base(1_000_001),
        },
        length("N = 400", 400, 2_000_001),
        length("N = 4000", 4000, 3_000_001),
        sampling("Ts = 1 s", 1.0, 4_000_001),
        sampling("Ts = 60 s", 60.0, 5_000_001),
        Set {
            name: "composition (left out)",
            spec: PopulationSpec {
                families: vec![Family::Composition],
                ..base(6_000_001)
            },
        },
        Set {
            name: "P-only (left out)",
            spec: PopulationSpec {
                proportional: 1.0,
                ..base(7_000_001)
            },
        },
        Set {
            name: "dead time 10-60 s (left out)",
            spec: PopulationSpec {
                transport_delay: [10.0, 60.0],
                ..base(8_000_001)
            },
        },
    ]
}

/// The first `n` loops of `set` that simulate (a loop whose tuning cannot be stabilised is
/// skipped and counted), evaluated; with `hold` above 1, PV held over `hold` samples first.
fn population(set: &Set, n: usize, auto: bool, hold: usize) -> Result<(Vec<Case>, usize)> {
    let got: Vec<Option<Case>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut l = match set.spec.generate(i) {
                Ok(l) => l,
                Err(_) => return Ok(None),
            };
            if hold > 1 {
                let live = l.sim.pv.clone();
                for (t, v) in l.sim.pv.iter_mut().enumerate() {
                    *v = live[t - t % hold];
                }
            }
            let oracle = if l.integrating {
                oracle_lr_integrating(&l.sim.pv, &l.sim.op, &l.sim.mv)
            } else {
                oracle_lr(&l.sim.pv, &l.sim.op, &l.sim.mv)
            };
            let (decided, _) = decide_kind(&l.sim.pv, &l.sim.op, l.family == Family::Level);
            let kind_from_data =
                detection::kind::evidence(&l.sim.pv, &l.sim.op).and_then(|e| e.integrating);
            Case {
                oracle,
                known_model: known_model_lr(&l.sim, KNOWN_MODEL_ORDER),
                what: format!("{} #{i}: {}", set.name, l.what),
                sticky: matches!(l.label, Label::Sticky | Label::NoTrace),
                no_trace: l.label == Label::NoTrace,
                trace_lr: l.trace.map(|t| t.lr()),
                tie: auto && kind_from_data.is_none(),
                judged: None,
                judgeable: l.label != Label::CannotJudge,
                kind_integrating: l.integrating,
                sp: Some(l.sim.sp),
                pv: l.sim.pv,
                op: l.sim.op,
                ts: l.sample_time,
                integrating: if auto { decided } else { l.integrating },
                kind_from_data,
                outcomes: Vec::new(),
                x: Vec::new(),
            }
            .evaluate()
            .map(Some)
        })
        .collect::<Result<_>>()?;
    let skipped = got.iter().filter(|c| c.is_none()).count();
    Ok((got.into_iter().flatten().collect(), skipped))
}

/// `--integrating auto` on a simulated loop whose tag would carry the letter `L` when
/// `level_tag`: the record decides, the tag breaks a tie (`(integrating, decided by the data)`).
fn decide_kind(pv: &[f64], op: &[f64], level_tag: bool) -> (bool, bool) {
    match detection::kind::evidence(pv, op).and_then(|e| e.integrating) {
        Some(yes) => (yes, true),
        None => (level_tag, false),
    }
}

/// Figures of one group of loops under one model.
struct Figures {
    n: usize,
    auc: Option<f64>,
    right: f64,
    conclusive: usize,
    inconclusive: f64,
    cannot: usize,
    cannot_inconclusive: usize,
    /// The verdicts on the sticky loops that leave no trace: stiction, no-stiction,
    /// inconclusive.
    no_trace: [usize; 3],
}

/// A sticky loop whose true valve position explains the valve's proxy no better than OP
/// (oracle LR below the likelihood region's χ²₁ bound): its stiction never showed in the record.
fn hidden(c: &Case) -> bool {
    c.sticky && c.oracle.is_some_and(|o| o < REGION_LR)
}

fn figures_of(cases: &[&Case]) -> Result<Figures> {
    let mut scores = Vec::new();
    let (mut conclusive, mut right, mut judged, mut undecided) = (0, 0, 0, 0);
    let (mut cannot, mut cannot_inc) = (0, 0);
    let mut no_trace = [0usize; 3];
    let leave_out = LEAVE_OUT.get();
    for c in cases {
        let (s, d) = c.judged().map(|j| (j.score, j.verdict))?;
        if c.no_trace {
            no_trace[match d {
                Verdict::Stiction => 0,
                Verdict::NoStiction => 1,
                Verdict::Inconclusive => 2,
            }] += 1;
        }
        let left_out = match leave_out {
            LeaveOut::Nothing => false,
            LeaveOut::NoTrace => c.no_trace,
            LeaveOut::Hidden => hidden(c),
        };
        if left_out && leave_out == LeaveOut::NoTrace {
            // neither verdict is wrong about the record: counted in their own column only
            continue;
        }
        if c.judgeable && !left_out {
            scores.push((s, c.sticky));
            judged += 1;
            if d == Verdict::Inconclusive {
                undecided += 1;
            }
        } else if !c.judgeable {
            cannot += 1;
            if d == Verdict::Inconclusive {
                cannot_inc += 1;
            }
        }
        if d != Verdict::Inconclusive {
            conclusive += 1;
            if c.judgeable && (d == Verdict::Stiction) == c.sticky {
                right += 1;
            }
        }
    }
    Ok(Figures {
        n: cases.len(),
        auc: auc(&scores),
        right: 100.0 * right as f64 / conclusive.max(1) as f64,
        conclusive,
        inconclusive: 100.0 * undecided as f64 / judged.max(1) as f64,
        cannot,
        cannot_inconclusive: cannot_inc,
        no_trace,
    })
}

/// Whether `f` meets the targets (AUC >= 0.95, >= 95 % right on the conclusive, <= 20 %
/// inconclusive).
fn meets(f: &Figures) -> bool {
    f.auc.is_some_and(|a| a >= 0.95) && f.right >= 95.0 && f.inconclusive <= 20.0
}

fn print_header() {
    println!(
        "  {:24} {:16} {:>4}  {:>6}  {:>16}  {:>12}  {:>14}  {:>15}  targets",
        "population",
        "loops",
        "n",
        "AUC",
        "right/conclusive",
        "inconclusive",
        "cannot judge",
        "no trace s/n/i"
    );
}

fn print_row(set: &str, kind: &str, f: &Figures) {
    let [s, n, i] = f.no_trace;
    println!(
        "  {set:24} {kind:16} {:>4}  {:>6}  {:>9.1} % of {:>3}  {:>10.1} %  {:>6} of {:>3}  {:>15}  {}",
        f.n,
        fmt_auc(f.auc),
        f.right,
        f.conclusive,
        f.inconclusive,
        f.cannot_inconclusive,
        f.cannot,
        format!("{s}/{n}/{i}"),
        if meets(f) { "met" } else { "NOT met" }
    );
}

/// Which sticky loops [`figures_of`] leaves out.
#[derive(Clone, Copy, PartialEq, Eq)]
enum LeaveOut {
    /// None: every sticky loop is sticky (the figures as before the no-trace label).
    Nothing,
    /// The loops that leave no trace, out of everything but their own column (the judgeable
    /// figures).
    NoTrace,
    /// The loops whose stiction the oracle does not see, out of the AUC and the inconclusive
    /// share (their conclusive verdicts still count).
    Hidden,
}

thread_local! {
    /// What [`figures_of`] leaves out.
    static LEAVE_OUT: std::cell::Cell<LeaveOut> = const { std::cell::Cell::new(LeaveOut::Nothing) };
}

/// Which loops of a population a table row keeps.
type KindFilter = fn(&Case) -> bool;

/// The table of `sets` as last judged ([`judge_all`]): every set by loop kind and overall, then
/// all of them.
fn table(sets: &[(&str, Vec<Case>)]) -> Result<()> {
    print_header();
    let kinds: [(&str, KindFilter); 3] = [
        ("self-regulating", |c| !c.kind_integrating),
        ("integrating", |c| c.kind_integrating),
        ("all", |_| true),
    ];
    for (name, cases) in sets {
        for (kind, keep) in &kinds {
            let sub: Vec<&Case> = cases.iter().filter(|c| keep(c)).collect();
            if sub.is_empty() {
                continue;
            }
            print_row(name, kind, &figures_of(&sub)?);
        }
    }
    if sets.len() > 1 {
        for (kind, keep) in &kinds {
            let sub: Vec<&Case> = sets
                .iter()
                .flat_map(|(_, c)| c.iter())
                .filter(|c| keep(c))
                .collect();
            print_row("every validation loop", kind, &figures_of(&sub)?);
        }
    }
    Ok(())
}

fn print_model(model: &Model) {
    println!(
        "pub const NO_STICTION_AT: f64 = {};\npub const STICTION_AT: f64 = {};\npub const HIDDEN_S: f64 = {};",
        model.no_stiction_at, model.stiction_at, model.hidden_s
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
}

/// The labelled plant registrations, read as `stiction detect` reads them, and the files the
/// reader still refuses.
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
        // Read as `stiction detect` reads: a PV or OP constant or flat over most rows is
        // evidence the detector answers (FIC10112's frozen PV), not a refusal.
        let read = datasets::ReadOptions {
            accept_constant: true,
            ..datasets::ReadOptions::default()
        };
        let d = match datasets::read_path(dir.join(file), &read) {
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
            what: file.to_string(),
            sticky,
            judgeable: true,
            kind_integrating: integrating,
            sp: d.sp.clone(),
            pv: d.require_pv()?.to_vec(),
            op: d.op.clone(),
            ts,
            integrating,
            outcomes: Vec::new(),
            x: Vec::new(),
            oracle: None,
            known_model: None,
            kind_from_data: None,
            no_trace: false,
            trace_lr: None,
            tie: false,
            judged: None,
        });
    }
    let cases = cases
        .into_iter()
        .map(Case::evaluate)
        .collect::<Result<Vec<_>>>()?;
    Ok((cases, refused))
}

/// The logistic fit on the loops that can be judged.
fn fit(cases: &[&Case], ridge: f64) -> Result<Model> {
    let cases: Vec<&&Case> = cases.iter().filter(|c| c.judgeable).collect();
    let x: Vec<Vec<f64>> = cases.iter().map(|c| c.x.clone()).collect();
    let y: Vec<bool> = cases.iter().map(|c| c.sticky).collect();
    let f = coefficients(&x, &y, ridge)?;
    let mut model = Model {
        intercept: f.intercept,
        weights: f.weights,
        stiction_at: STICTION_AT,
        no_stiction_at: NO_STICTION_AT,
        hidden_s: HIDDEN_S,
    };
    (model.no_stiction_at, model.stiction_at, model.hidden_s) = thresholds(&cases, &model)?;
    Ok(model)
}

/// The least share of the training loops a threshold pair must decide beyond 0.5/0.5 to
/// replace it: the best of the grid's hundred pairs, chosen in sample, gains a few loops by
/// chance alone.
const MIN_GAIN: f64 = 0.02;

/// The verdict's thresholds `(no-stiction at or below, stiction at or above)` on a grid of
/// 0.05, judged on the training population with the parts' rule ([`settle_on`]) and the
/// band a `no-stiction` verdict must exclude ([`detection::score::HIDDEN_S`], a requirement,
/// not tuned here) in place. Kept: the pair with the fewest inconclusive among those right on
/// at least as large a share of the conclusive as the pair 0.5/0.5 (ties: more loops right)
/// and leaving at least [`MIN_GAIN`] of the loops fewer inconclusive; 0.5/0.5 when none is.
fn thresholds(cases: &[&&Case], model: &Model) -> Result<(f64, f64, f64)> {
    // What the rule judges, computed once per loop: the whole record's evidence and its parts'.
    type Cached = (Evidence, [(&'static str, Option<Evidence>); 4], bool);
    let cached: Vec<Cached> = cases
        .par_iter()
        .map(|c| {
            let reg = c.registration()?;
            Ok((
                Evidence::of(&reg, c.outcomes.clone()),
                parts(&reg),
                c.sticky,
            ))
        })
        .collect::<Result<_>>()?;
    let rate = |m: &Model| -> (usize, usize) {
        let (mut right, mut conclusive) = (0usize, 0usize);
        for (whole, parts, sticky) in &cached {
            let d = settle_on(whole.judge(m), parts, m).verdict;
            if d != Verdict::Inconclusive {
                conclusive += 1;
                right += usize::from((d == Verdict::Stiction) == *sticky);
            }
        }
        (right, conclusive)
    };
    let n = cached.len().max(1) as f64;
    let now = Model {
        no_stiction_at: 0.5,
        stiction_at: 0.5,
        ..model.clone()
    };
    let (right0, conclusive0) = rate(&now);
    let share0 = right0 as f64 / conclusive0.max(1) as f64;
    println!(
        "the verdict's thresholds on the training population, the parts' rule in place ({} loops that can be judged); {}/{} (HIDDEN_S {} %): right {:.1} % of {conclusive0}, {:.1} % inconclusive",
        cached.len(),
        now.no_stiction_at,
        now.stiction_at,
        now.hidden_s,
        100.0 * share0,
        100.0 * (1.0 - conclusive0 as f64 / n)
    );
    println!("  no-stiction at  stiction at  HIDDEN_S  right of conclusive  inconclusive   (every pair at least as right with fewer inconclusive)");
    let mut best: Option<(f64, f64, f64, usize, usize)> = None;
    for hidden_s in [model.hidden_s] {
        let mut of_this: Vec<(f64, f64, usize, usize)> = Vec::new();
        for lo in 1..=10 {
            for hi in 10..=19 {
                let m = Model {
                    no_stiction_at: f64::from(lo) / 20.0,
                    stiction_at: f64::from(hi) / 20.0,
                    hidden_s,
                    ..model.clone()
                };
                let (right, conclusive) = rate(&m);
                of_this.push((m.no_stiction_at, m.stiction_at, right, conclusive));
            }
        }
        for &(lo, hi, right, conclusive) in &of_this {
            let share = right as f64 / conclusive.max(1) as f64;
            if share + 1e-12 < share0 || conclusive <= conclusive0 {
                continue;
            }
            println!(
                "  {lo:>14.2}  {hi:>11.2}  {hidden_s:>8}  {:>9.1} % of {conclusive:>3}  {:>10.1} %",
                100.0 * share,
                100.0 * (1.0 - conclusive as f64 / n)
            );
            let enough = (conclusive - conclusive0) as f64 >= MIN_GAIN * n;
            let better = enough
                && best.is_none_or(|b| conclusive > b.4 || (conclusive == b.4 && right > b.3));
            if better {
                best = Some((lo, hi, hidden_s, right, conclusive));
            }
        }
    }
    Ok(
        best.map_or((now.no_stiction_at, now.stiction_at, now.hidden_s), |b| {
            (b.0, b.1, b.2)
        }),
    )
}

/// A case's score, verdict and reason under one model.
#[derive(Clone)]
struct Judged {
    score: f64,
    verdict: Verdict,
    reason: String,
    /// The verdict before the rule for a PV held between updates
    /// (`monitoring::detect::hold_on_held_pv`).
    live: Verdict,
}

/// Score, verdict and reason of `case` under `model`, as the product gives them: the parts'
/// rule ([`settle`]) and, when the record does not decide the loop kind on a validation loop
/// judged as `--integrating auto` judges it, the kind rule of
/// `monitoring::detect::hold_across_kinds` (a conclusive verdict stands unless the other
/// kind's reading gives the opposite one), then the rule for a PV held between updates
/// (`monitoring::detect::hold_on_held_pv`).
fn judge(case: &Case, model: &Model) -> Result<Judged> {
    let reg = case.registration()?;
    let mut d = settle(&reg, model, combine(&reg, case.outcomes.clone(), model));
    let opposite = match d.verdict {
        Verdict::Stiction => Some(Verdict::NoStiction),
        Verdict::NoStiction => Some(Verdict::Stiction),
        Verdict::Inconclusive => None,
    };
    if let Some(opposite) = opposite.filter(|_| case.tie) {
        let mut other = case.registration()?.integrating(!case.integrating);
        if let Some(sp) = &case.sp {
            other = other.with_sp(sp)?;
        }
        if detect_with(&other, model).verdict == opposite {
            d.reason = format!(
                "the record does not decide whether the loop is integrating, and the two readings disagree ({})",
                d.reason
            );
            d.verdict = Verdict::Inconclusive;
        }
    }
    let live = d.verdict;
    let d = monitoring::detect::hold_on_held_pv(Some(&case.pv), d);
    Ok(Judged {
        score: d.score,
        verdict: d.verdict,
        reason: d.reason,
        live,
    })
}

/// Judge every case of `sets` under `model` (kept in each case for the tables).
fn judge_all(sets: &mut [(&str, Vec<Case>)], model: &Model) -> Result<()> {
    sets.iter_mut()
        .flat_map(|(_, c)| c.iter_mut())
        .collect::<Vec<_>>()
        .into_par_iter()
        .try_for_each(|c| {
            c.judged = Some(judge(c, model)?);
            Ok(())
        })
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
    let mut n_train = 960usize;
    let mut train_seed = 1u64;
    let mut n_valid = 80usize;
    let mut plant_dir: Option<PathBuf> = Some(root.join("../shared/data/plant"));
    let mut ridge = 0.1;
    let mut paper = false;
    let mut dump: Option<PathBuf> = None;
    let mut cases_out: Option<PathBuf> = None;
    let mut auto = true;
    let mut hold = 1usize;
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| {
            it.next()
                .with_context(|| format!("{name} needs a value\n{USAGE}"))
        };
        let whole = |v: &String, name: &str| -> Result<usize> {
            v.parse().with_context(|| format!("{name}: a whole number"))
        };
        match a.as_str() {
            "--train-seed" => train_seed = whole(value(a)?, a)? as u64,
            "--train" => n_train = whole(value(a)?, a)?,
            "--valid" => n_valid = whole(value(a)?, a)?,
            "--plant" => plant_dir = Some(PathBuf::from(value("--plant")?)),
            "--no-plant" => plant_dir = None,
            "--ridge" => ridge = value("--ridge")?.parse().context("--ridge: a number")?,
            "--paper" => paper = true,
            "--integrating" => {
                auto = match value("--integrating")?.as_str() {
                    "auto" => true,
                    "truth" => false,
                    other => bail!("--integrating: `auto` or `truth`, not {other:?}"),
                }
            }
            "--dump" => dump = Some(PathBuf::from(value("--dump")?)),
            "--cases" => cases_out = Some(PathBuf::from(value("--cases")?)),
            "--hold" => hold = whole(value(a)?, a)?,
            "--help" | "-h" => {
                println!("{USAGE}");
                return Ok(());
            }
            other => bail!("unknown option {other:?}\n{USAGE}"),
        }
    }
    let started = std::time::Instant::now();
    let train_set = training_set(train_seed);
    let (train, skipped) = population(&train_set, n_train, false, hold)?;
    println!(
        "training population: {} loops ({skipped} skipped: no stabilising tuning) [{:.1} s]",
        train.len(),
        started.elapsed().as_secs_f64()
    );
    let mut valid: Vec<(&str, Vec<Case>)> = Vec::new();
    for set in validation_sets() {
        let (cases, skipped) = population(&set, n_valid, auto, hold)?;
        println!(
            "validation population {:24} {} loops ({skipped} skipped) [{:.1} s]",
            set.name,
            cases.len(),
            started.elapsed().as_secs_f64()
        );
        valid.push((set.name, cases));
    }
    if let Some(dir) = &dump {
        dump_cases(dir, &valid[0].1)?;
        println!("wrote the `in range` validation loops to {}", dir.display());
    }

    println!(
        "\nloop kind from the record (detection::kind; the tag's letter `L` only breaks a tie; the detector treats loops as {}):",
        if auto { "this decides (`--integrating auto`)" } else { "they are (`--integrating truth`)" }
    );
    kind_table(&valid);

    let today = Model::calibrated();
    judge_all(&mut valid, &today)?;
    println!("\nthe model in detection/src/score.rs, as it is:");
    table(&valid)?;

    let mut train = vec![("training", train)];
    if hold > 1 {
        judge_all(&mut train, &today)?;
        println!("\nthe training loops with PV held over {hold} samples, the model as it is: each verdict's share right at a stricter score (monitoring::detect::HELD_STICTION_AT, HELD_NO_STICTION_AT):");
        held_thresholds(&train[0].1)?;
    }
    let refs: Vec<&Case> = train[0].1.iter().collect();
    let model = fit(&refs, ridge)?;
    println!(
        "\nfitted on the training population ({} loops, ridge {ridge}):",
        refs.len()
    );
    print_model(&model);
    print_cross_validated(&refs, ridge)?;
    judge_all(&mut train, &model)?;
    judge_all(&mut valid, &model)?;
    for (what, leave_out) in [
        ("every sticky loop sticky", LeaveOut::Nothing),
        (
            "the sticky loops that leave no trace out of the figures (their verdicts in their own column)",
            LeaveOut::NoTrace,
        ),
    ] {
        LEAVE_OUT.set(leave_out);
        println!("\n{what}:\ntraining population (in sample):");
        table(&train)?;
        println!("validation populations (never fitted on):");
        table(&valid)?;
    }
    if let Some(path) = &cases_out {
        write_cases(path, &train, &valid)?;
        println!("\nwrote one row per loop to {}", path.display());
    }
    LEAVE_OUT.set(LeaveOut::Hidden);
    println!("\nthe sticky loops whose stiction never showed to the true valve position (oracle LR < {REGION_LR}) left out of the AUC and the inconclusive share:");
    table(&valid)?;
    LEAVE_OUT.set(LeaveOut::Nothing);
    for (what, sets) in [("training", &train), ("validation", &valid)] {
        println!("\nwhy the {what} loops that can be judged are inconclusive:");
        reasons(sets)?;
    }
    trace_and_oracle(&valid);
    ceiling(&valid)?;

    oracle_and_tests(&valid)?;
    if paper {
        paper_benchmark(&model)?;
    }
    if let Some(dir) = plant_dir.filter(|d| d.join("labels.csv").exists()) {
        let (plant, refused) = plant_cases(&dir)?;
        println!(
            "\ntest set: {} plant registrations of {} ({} refused by the reader), never fitted on:",
            plant.len(),
            dir.display(),
            refused.len()
        );
        for r in &refused {
            println!("  refused: {r}");
        }
        let mut plant = vec![("plant", plant)];
        for (what, m) in [("score.rs as it is", &today), ("fitted here", &model)] {
            println!("model {what}:");
            judge_all(&mut plant, m)?;
            table(&plant)?;
        }
    }
    println!("\n[{:.1} s]", started.elapsed().as_secs_f64());
    Ok(())
}

/// The sticky validation loops whose stiction never showed (by the oracle), the oracle's own
/// AUC, each test's own AUC, and the first wrong verdicts of `model`.
fn oracle_and_tests(valid: &[(&str, Vec<Case>)]) -> Result<()> {
    let hidden: Vec<&Case> = valid
        .iter()
        .flat_map(|(_, c)| c.iter())
        .filter(|c| c.sticky && c.oracle.is_none_or(|o| o < REGION_LR))
        .collect();
    let sticky = valid
        .iter()
        .flat_map(|(_, c)| c.iter())
        .filter(|c| c.sticky)
        .count();
    let oracle_scores: Vec<(f64, bool)> = valid
        .iter()
        .flat_map(|(_, c)| c.iter())
        .filter(|c| c.judgeable)
        .map(|c| (c.oracle.unwrap_or(0.0), c.sticky))
        .collect();
    println!(
        "\nsticky validation loops whose true valve position explains the valve's proxy no better than OP (oracle LR < {REGION_LR}): {} of {sticky}; the oracle LR's own AUC (the true valve position known): {}",
        hidden.len(),
        fmt_auc(auc(&oracle_scores))
    );
    println!("\neach test's own statistic on every validation loop that can be judged (AUC; not fitted):");
    let all: Vec<&Case> = valid
        .iter()
        .flat_map(|(_, c)| c.iter())
        .filter(|c| c.judgeable)
        .collect();
    for (name, a, n) in test_aucs(&all) {
        println!("  {name:18} AUC {} over {n:>3}", fmt_auc(a));
    }
    let mut wrong = 0;
    for c in &all {
        let (s, d) = c.judged().map(|j| (j.score, j.verdict))?;
        if d != Verdict::Inconclusive
            && (d == Verdict::Stiction) != c.sticky
            && !c.no_trace
            && wrong < 16
        {
            wrong += 1;
            println!("  wrong: {} -> {d} (score {s:.2})", c.what);
        }
    }
    Ok(())
}
