//! What holding the verdict across both loop kinds costs when the record does not decide the
//! kind (`monitoring::detect::hold_across_kinds`), measured on simulated populations: the
//! training population of `cargo xtask detect-calibrate` (seed 1, where a choice between rules
//! is made) and its six validation populations (the same specs and seeds, never fitted on). Each
//! loop is read as a historian record (PV, OP, SP, time; MV dropped) under a tag whose letter
//! says what the simulated family is (`LIC` for levels, `FIC` else, as the calibration's
//! tie-break), its kind decided by `--integrating auto`'s rule, and the detector run under the
//! kind decided and, when the record does not decide, under the other kind. Three rules:
//! `once` (the kind decided alone, the rule before), `agree` (a conclusive verdict stands only
//! when the other kind gives the same) and `not-opposite` (it stands unless the other kind
//! gives the opposite one). Per loop kind and overall: the verdict right on the conclusive (a
//! conclusive verdict on a loop that cannot be judged is wrong) and the share of sticky and
//! free loops left `inconclusive`. A sticky valve that leaves no trace in its record
//! (`Label::NoTrace`) counts as sticky, as in the calibration's first figure set.
//!
//! `cargo run --release -p monitoring --example kind_tie -- [LOOPS]` (default 80 per
//! population, as the calibration).

use datasets::simulate::population::{Family, Label, PopulationSpec};
use detection::Verdict;
use monitoring::detect::detect_loop;
use monitoring::Integrating;
use rayon::prelude::*;

struct Case {
    set: &'static str,
    integrating: bool,
    label: Label,
    undecided: bool,
    /// The verdict under each rule: once, agree, not-opposite.
    verdicts: [Verdict; 3],
}

/// Which loops a table row counts.
type Keep = fn(&Case) -> bool;

const RULES: [&str; 3] = ["once", "agree", "not-opposite"];

fn case(set: &'static str, spec: &PopulationSpec, i: usize) -> Option<Case> {
    let l = spec.generate(i).ok()?;
    let mut d = l.sim.to_loop_data();
    d.mv = None;
    let tag = if l.family == Family::Level {
        "LIC1"
    } else {
        "FIC1"
    };
    let kind = Integrating::Auto.decide(tag, Some(&d));
    let once = detect_loop(&d, kind.integrating).verdict();
    let other = if kind.undecided() && once != Verdict::Inconclusive {
        detect_loop(&d, !kind.integrating).verdict()
    } else {
        once
    };
    let opposite = matches!(
        (once, other),
        (Verdict::Stiction, Verdict::NoStiction) | (Verdict::NoStiction, Verdict::Stiction)
    );
    let pick = |stands: bool| if stands { once } else { Verdict::Inconclusive };
    Some(Case {
        set,
        integrating: l.integrating,
        label: l.label,
        undecided: kind.undecided(),
        verdicts: [once, pick(other == once), pick(!opposite)],
    })
}

/// `(% right of conclusive, conclusive, % inconclusive of sticky and free)`.
fn figures(cases: &[&Case], verdict: impl Fn(&Case) -> Verdict) -> (f64, usize, f64) {
    let conclusive: Vec<&&Case> = cases
        .iter()
        .filter(|c| verdict(c) != Verdict::Inconclusive)
        .collect();
    let right = conclusive
        .iter()
        .filter(|c| {
            matches!(
                (c.label, verdict(c)),
                (Label::Sticky | Label::NoTrace, Verdict::Stiction)
                    | (Label::Healthy, Verdict::NoStiction)
            )
        })
        .count();
    let judgeable: Vec<&&Case> = cases
        .iter()
        .filter(|c| c.label != Label::CannotJudge)
        .collect();
    let open = judgeable
        .iter()
        .filter(|c| verdict(c) == Verdict::Inconclusive)
        .count();
    (
        100.0 * right as f64 / conclusive.len().max(1) as f64,
        conclusive.len(),
        100.0 * open as f64 / judgeable.len().max(1) as f64,
    )
}

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(80);
    let families = vec![Family::Flow, Family::Pressure, Family::Level];
    let base = |seed: u64| PopulationSpec {
        seed,
        families: families.clone(),
        sample_time: [2.0, 30.0],
        samples: [300, 3000],
        ..PopulationSpec::default()
    };
    let sets = [
        ("training", base(1)),
        ("in range", base(1_000_001)),
        (
            "N = 400",
            PopulationSpec {
                samples: [400, 400],
                ..base(2_000_001)
            },
        ),
        (
            "N = 4000",
            PopulationSpec {
                samples: [4000, 4000],
                ..base(3_000_001)
            },
        ),
        (
            "Ts = 1 s",
            PopulationSpec {
                sample_time: [1.0, 1.0],
                ..base(4_000_001)
            },
        ),
        (
            "Ts = 60 s",
            PopulationSpec {
                sample_time: [60.0, 60.0],
                ..base(5_000_001)
            },
        ),
        (
            "composition",
            PopulationSpec {
                families: vec![Family::Composition],
                ..base(6_000_001)
            },
        ),
    ];
    let cases: Vec<Case> = sets
        .iter()
        .flat_map(|&(name, ref spec)| (0..n).map(move |i| (name, spec, i)))
        .collect::<Vec<_>>()
        .into_par_iter()
        .filter_map(|(name, spec, i)| case(name, spec, i))
        .collect();
    for (what, training) in [
        ("training population", true),
        ("validation populations", false),
    ] {
        let of: Vec<&Case> = cases
            .iter()
            .filter(|c| (c.set == "training") == training)
            .collect();
        let undecided = of.iter().filter(|c| c.undecided).count();
        println!(
            "\n{what}: {} loops ({n} per population), the kind undecided by the record on {undecided}",
            of.len()
        );
        println!("kind              loops  rule           right of conclusive (n)  inconclusive");
        let kinds: [(&str, Keep); 3] = [
            ("self-regulating", |c| !c.integrating),
            ("integrating", |c| c.integrating),
            ("all", |_| true),
        ];
        for (name, keep) in kinds {
            let sel: Vec<&Case> = of.iter().copied().filter(|c| keep(c)).collect();
            for (r, rule) in RULES.iter().enumerate() {
                let (right, conclusive, open) = figures(&sel, |c| c.verdicts[r]);
                println!(
                    "{name:17} {:5}  {rule:13}  {right:5.1} % ({conclusive:3})          {open:5.1} %",
                    sel.len()
                );
            }
        }
    }
}
