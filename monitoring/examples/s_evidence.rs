//! Which S explains the verdict: the measurement behind `monitoring::answer::RULE`.
//!
//! On simulated populations (`datasets::simulate::population`, seeds of their own, never the
//! plant data), each loop is read as a historian record (PV, OP, SP, time; MV dropped), its
//! kind decided by `--integrating auto`'s rule, the detector run and `quantify`'s default
//! search (kano + arx) on the record as searched. For each rule of `answer::Rule` it prints:
//!
//! * contradictions: verdict `stiction` with S <= 0.2 %, or `no-stiction` with S >= 1.6 %;
//! * on sticky loops called `stiction`: the median |log2(S / true S)| and the share within a
//!   factor 2 of the truth; the share whose true S lies in the range reported;
//! * on healthy loops called `no-stiction`: the share with S >= 1.6 %;
//! * the maintenance call a single registration would get from `trend` (S reported at or above
//!   the 1.6 % threshold), by the detector's verdict: how many of those loops are sticky with a
//!   true S of 1.6 % or more, sticky with less, healthy, or cannot be judged.
//!
//! `cargo run --release -p monitoring --example s_evidence -- [LOOPS] [SEED]` (defaults 120
//! loops per population, seed 9_000_001).

use datasets::simulate::population::{Family, Label, PopulationSpec};
use detection::Verdict;
use monitoring::answer::{Answer, Rule};
use monitoring::{analyse, Integrating};
use rayon::prelude::*;

struct Case {
    index: usize,
    label: Label,
    family: Family,
    truth: f64,
    answers: Vec<Answer>,
}

const RULES: [(Rule, &str); 3] = [
    (Rule::OneStep, "one-step"),
    (Rule::OutputError, "output-error"),
    (Rule::Agreeing, "agreeing"),
];

fn case(spec: &PopulationSpec, i: usize) -> Option<Case> {
    let l = spec.generate(i).ok()?;
    let mut d = l.sim.to_loop_data();
    d.mv = None;
    d.source = format!("loop {i}");
    let a = analyse(&d, None, Integrating::Auto);
    let det = a.detect(&d).detected;
    let combination = run::Settings::default().combination("kano", "arx").ok()?;
    let q = run::problem(&a.searched)
        .ok()
        .and_then(|p| combination.run(p, None).ok());
    let q = q.as_ref().map(|f| &f.result);
    Some(Case {
        index: i,
        label: l.label,
        family: l.family,
        truth: l.s,
        answers: RULES
            .iter()
            .map(|&(r, _)| Answer::with_rule(&a, &det, q, r))
            .collect(),
    })
}

fn table(name: &str, cases: &[&Case]) {
    println!("{name}: {} loops", cases.len());
    println!(
        "  {:13} {:>14} {:>10} {:>14} {:>14} {:>14}",
        "rule", "contradictions", "med|log2|", "within x2", "in range", "healthy >=1.6"
    );
    let (mut n, mut os, mut oe) = (0, 0, 0);
    let inside = |r: [f64; 2], t: f64| r[0] <= t && t <= r[1];
    for c in cases {
        let a = &c.answers[0];
        if c.label == Label::Sticky && a.verdict == Verdict::Stiction {
            n += 1;
            os += usize::from(a.one_step.is_some_and(|e| inside(e.range, c.truth)));
            oe += usize::from(a.output_error.is_some_and(|e| inside(e.range, c.truth)));
        }
    }
    println!("  true S inside one structure's region, sticky loops called stiction: one-step {os}/{n}, output-error {oe}/{n}");
    for (k, (_, rule)) in RULES.iter().enumerate() {
        let mut contradictions = 0;
        let (mut errs, mut covered, mut sticky) = (Vec::new(), 0, 0);
        let (mut high, mut healthy) = (0, 0);
        for c in cases {
            let a = &c.answers[k];
            let Some(s) = a.s else { continue };
            match a.verdict {
                Verdict::Stiction if s <= 0.2 => contradictions += 1,
                Verdict::NoStiction if s >= 1.6 => contradictions += 1,
                _ => {}
            }
            if c.label == Label::Sticky && a.verdict == Verdict::Stiction {
                sticky += 1;
                errs.push((s.max(0.01) / c.truth).log2().abs());
                if let Some(r) = a.s_range {
                    if r[0] <= c.truth && c.truth <= r[1] {
                        covered += 1;
                    }
                }
            }
            if c.label == Label::Healthy && a.verdict == Verdict::NoStiction {
                healthy += 1;
                if s >= 1.6 {
                    high += 1;
                }
            }
        }
        errs.sort_by(f64::total_cmp);
        let median = errs.get(errs.len() / 2).copied().unwrap_or(f64::NAN);
        let within = errs.iter().filter(|&&e| e <= 1.0).count();
        let pct = |a: usize, b: usize| {
            if b == 0 {
                "-".to_string()
            } else {
                format!("{:.0} % ({a}/{b})", 100.0 * a as f64 / b as f64)
            }
        };
        println!(
            "  {:13} {:>14} {:>10.2} {:>14} {:>14} {:>14}",
            rule,
            contradictions,
            median,
            pct(within, sticky),
            pct(covered, sticky),
            pct(high, healthy)
        );
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(120);
    let seed: u64 = args
        .next()
        .and_then(|a| a.parse().ok())
        .unwrap_or(9_000_001);
    let spec = PopulationSpec::wide(seed);
    let cases: Vec<Case> = (0..n)
        .into_par_iter()
        .filter_map(|i| case(&spec, i))
        .collect();
    let all: Vec<&Case> = cases.iter().collect();
    let contradicting: Vec<String> = cases
        .iter()
        .filter(|c| {
            let a = &c.answers[0];
            a.s.is_some_and(|s| !monitoring::answer::agrees(a.verdict, s))
        })
        .map(|c| c.index.to_string())
        .collect();
    println!(
        "loops whose one-step S contradicts the verdict: {}",
        contradicting.join(" ")
    );
    println!("population wide({seed}): Ts 1-60 s, N 200-5000, every family");
    table("all", &all);
    let selfreg: Vec<&Case> = cases.iter().filter(|c| c.family != Family::Level).collect();
    table("self-regulating", &selfreg);
    let level: Vec<&Case> = cases.iter().filter(|c| c.family == Family::Level).collect();
    table("integrating", &level);
    maintenance(&all);
}

/// Loops whose reported S (the kept rule) reaches the maintenance threshold, by verdict: what
/// they truly are.
fn maintenance(cases: &[&Case]) {
    const THRESHOLD: f64 = grid_search::MAINTENANCE_S;
    println!("reported S >= {THRESHOLD} % (the kept rule), by verdict: sticky S >= {THRESHOLD} / sticky S < {THRESHOLD} / healthy / cannot judge");
    for v in [
        Verdict::Stiction,
        Verdict::Inconclusive,
        Verdict::NoStiction,
    ] {
        let mut n = [0usize; 4];
        let mut all = 0;
        for c in cases {
            let a = &c.answers[2];
            if a.verdict != v {
                continue;
            }
            all += 1;
            if !a.s.is_some_and(|s| s >= THRESHOLD) {
                continue;
            }
            n[match c.label {
                Label::Sticky | Label::NoTrace if c.truth >= THRESHOLD => 0,
                Label::Sticky | Label::NoTrace => 1,
                Label::Healthy => 2,
                Label::CannotJudge => 3,
            }] += 1;
        }
        println!(
            "  {:13} {:>4} of {:>4} loops: {} / {} / {} / {}",
            v.as_str(),
            n.iter().sum::<usize>(),
            all,
            n[0],
            n[1],
            n[2],
            n[3]
        );
    }
}
