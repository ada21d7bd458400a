//! The tables of `cargo xtask detect-calibrate` beyond the figures: why verdicts are
//! `inconclusive`, the no-trace label against the oracle, and the reference paper's benchmark.

use super::*;

/// Why a verdict is `inconclusive`, from its reason (the first rule of [`judge`] that made it so).
fn why_inconclusive(reason: &str) -> String {
    const RULES: [(&str, &str); 9] = [
        (
            "the two readings disagree",
            "kind tie (the other loop kind's reading says the opposite)",
        ),
        (
            "cannot rule out a stuck valve",
            "a valve that moves little or not at all fits as well as a free valve",
        ),
        (
            "cannot rule out a stiction band",
            "HIDDEN_S (a band of 2 % or more fits as well as a free valve)",
        ),
        (
            "the shape tests alone",
            "oscillation gate (score high, no limit cycle, stick-slip or sticky valve)",
        ),
        ("barely asked to move", "OP barely moves"),
        ("frozen transmitter", "PV frozen"),
        (" between ", "score between the thresholds"),
        ("no test could judge", "no test could judge"),
        ("the data cannot be judged", "other degenerate record"),
    ];
    if !reason.contains("the two readings disagree") {
        if let Some(at) = reason.find(" alone says ") {
            let head = &reason[..at];
            let part = [
                "its first half",
                "its second half",
                "every second sample",
                "the means of each two samples",
            ]
            .into_iter()
            .find(|p| head.ends_with(p))
            .unwrap_or("a part");
            let says = reason[at + " alone says ".len()..]
                .split(':')
                .next()
                .unwrap_or("");
            return format!("part: {part} says {says}");
        }
    }
    RULES
        .iter()
        .find(|(key, _)| reason.contains(key))
        .map_or_else(|| format!("other: {reason}"), |(_, name)| name.to_string())
}

/// The inconclusive verdicts of `sets` counted by reason and by label (sticky with a trace,
/// sticky without, free, cannot be judged), and how many of them had the Hammerstein optimum
/// on the grid's edge.
pub(super) fn reasons(sets: &[(&str, Vec<Case>)]) -> Result<()> {
    let mut counts: std::collections::BTreeMap<String, [usize; 4]> = Default::default();
    let (mut edge, mut total) = (0usize, 0usize);
    for c in sets.iter().flat_map(|(_, c)| c.iter()) {
        let j = c.judged()?;
        if j.verdict != Verdict::Inconclusive {
            continue;
        }
        total += 1;
        let col = match (c.judgeable, c.sticky, c.no_trace) {
            (false, _, _) => 3,
            (true, true, false) => 0,
            (true, true, true) => 1,
            (true, false, _) => 2,
        };
        counts.entry(why_inconclusive(&j.reason)).or_default()[col] += 1;
        edge += usize::from(
            c.outcomes
                .iter()
                .any(|o| o.name == "hammerstein" && o.evidence.contains("grid's edge")),
        );
    }
    println!(
        "  {:78} {:>6} {:>8} {:>5} {:>7}",
        "reason", "sticky", "no trace", "free", "cannot"
    );
    let mut rows: Vec<_> = counts.into_iter().collect();
    rows.sort_by_key(|(_, c)| std::cmp::Reverse(c.iter().sum::<usize>()));
    for (why, [a, b, c, d]) in rows {
        println!("  {why:78} {a:>6} {b:>8} {c:>5} {d:>7}");
    }
    println!(
        "  {total} inconclusive; of them the Hammerstein test's best sticky valve on the grid's edge: {edge}"
    );
    Ok(())
}

/// How often each verdict is right, at the product's thresholds, when it must also reach a
/// stricter score: `stiction` at a score of `t` or more, `no-stiction` at `t` or less, over the
/// loops of `cases` that can be judged (the verdicts before the rule for a PV held between
/// updates). With `--hold K` it shows where `monitoring::detect::HELD_STICTION_AT` and
/// `HELD_NO_STICTION_AT` come from (the loosest score on the grid at which the verdict is right
/// at least as often as on the live training loops, over the training loops held over 5 and
/// over 10 samples pooled).
pub(super) fn held_thresholds(cases: &[Case]) -> Result<()> {
    let mut judged = Vec::new();
    for c in cases.iter().filter(|c| c.judgeable) {
        let j = c.judged()?;
        judged.push((j.live, j.score, c.sticky));
    }
    let row = |verdict: Verdict, keep: &dyn Fn(f64) -> bool| {
        let kept: Vec<bool> = judged
            .iter()
            .filter(|(v, s, _)| *v == verdict && keep(*s))
            .map(|(_, _, sticky)| *sticky == (verdict == Verdict::Stiction))
            .collect();
        let right = kept.iter().filter(|r| **r).count();
        (right, kept.len())
    };
    println!("  stiction at or above   right            no-stiction at or below   right");
    for k in 0..10 {
        let (hi, lo) = (0.5 + 0.05 * k as f64, 0.5 - 0.05 * k as f64);
        let (r1, n1) = row(Verdict::Stiction, &|s| s >= hi - 1e-9);
        let (r2, n2) = row(Verdict::NoStiction, &|s| s <= lo + 1e-9);
        let share = |r: usize, n: usize| {
            if n == 0 {
                "-".to_string()
            } else {
                format!("{:.1} %", 100.0 * r as f64 / n as f64)
            }
        };
        println!(
            "  {hi:>20.2}   {:>7} of {n1:>4}   {lo:>23.2}   {:>7} of {n2:>4}",
            share(r1, n1),
            share(r2, n2)
        );
    }
    Ok(())
}

/// The no-trace label (from the free twin) against the oracle (the true valve position
/// against OP through the Hammerstein model): how many sticky validation loops each flags and
/// how they overlap.
pub(super) fn trace_and_oracle(valid: &[(&str, Vec<Case>)]) {
    let sticky: Vec<&Case> = valid
        .iter()
        .flat_map(|(_, c)| c.iter())
        .filter(|c| c.sticky && c.judgeable)
        .collect();
    let oracle_hidden = |c: &&Case| c.oracle.is_none_or(|o| o < REGION_LR);
    let both = sticky
        .iter()
        .filter(|c| c.no_trace && oracle_hidden(c))
        .count();
    let trace_only = sticky
        .iter()
        .filter(|c| c.no_trace && !oracle_hidden(c))
        .count();
    let oracle_only = sticky
        .iter()
        .filter(|c| !c.no_trace && oracle_hidden(c))
        .count();
    println!(
        "\nsticky validation loops that can be judged: {}; no trace by the twin (LR < {}): {}; hidden to the oracle (oracle LR < {REGION_LR}): {}; both {both}, the twin only {trace_only}, the oracle only {oracle_only}",
        sticky.len(),
        datasets::simulate::population::NO_TRACE_LR,
        both + trace_only,
        both + oracle_only
    );
    let mut only: Vec<f64> = sticky
        .iter()
        .filter(|c| !c.no_trace && oracle_hidden(c))
        .filter_map(|c| c.trace_lr)
        .collect();
    only.sort_by(f64::total_cmp);
    if let (Some(first), Some(mid)) = (only.first(), only.get(only.len() / 2)) {
        println!(
            "  the twin's LR on the loops hidden to the oracle only: smallest {first:.1}, median {mid:.1}"
        );
    }
    let mut lrs: Vec<f64> = sticky.iter().filter_map(|c| c.trace_lr).collect();
    lrs.sort_by(f64::total_cmp);
    if !lrs.is_empty() {
        let at = |q: f64| lrs[((lrs.len() - 1) as f64 * q).round() as usize];
        println!(
            "  the twin's LR over those loops: 10 % {:.1}, 25 % {:.1}, median {:.1}, 75 % {:.1}",
            at(0.1),
            at(0.25),
            at(0.5),
            at(0.75)
        );
    }
    for (name, cases) in valid {
        let n = cases.iter().filter(|c| c.no_trace).count();
        let k = cases.iter().filter(|c| c.sticky && c.judgeable).count();
        println!("  {name:24} no trace {n:>3} of {k:>3} sticky");
    }
}

/// The fewest `inconclusive` verdicts, as a share of `v`, at which two thresholds on the score
/// are right on at least `share` of the conclusive (`score < lo`: `no-stiction`, `score >= hi`:
/// `stiction`); `None` when no pair is. And the best right share with one threshold (none
/// `inconclusive`).
fn frontier(v: &[(f64, bool)], share: f64) -> (Option<f64>, f64) {
    let mut v = v.to_vec();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = v.len();
    // the boundaries between distinct scores (and both ends)
    let cuts: Vec<usize> = (0..=n)
        .filter(|&i| i == 0 || i == n || v[i - 1].0 < v[i].0)
        .collect();
    // free loops below each cut, sticky loops from it on
    let mut free_below = vec![0usize; n + 1];
    for i in 0..n {
        free_below[i + 1] = free_below[i] + usize::from(!v[i].1);
    }
    let sticky = v.iter().filter(|x| x.1).count();
    let sticky_from = |j: usize| sticky - (j - free_below[j]);
    let (mut least, mut single) = (None::<f64>, 0.0f64);
    for (a, &i) in cuts.iter().enumerate() {
        for &j in &cuts[a..] {
            let conclusive = i + n - j;
            if conclusive == 0 {
                continue;
            }
            let right = (free_below[i] + sticky_from(j)) as f64 / conclusive as f64;
            if i == j {
                single = single.max(right);
            }
            if right >= share {
                let out = (j - i) as f64 / n.max(1) as f64;
                least = Some(least.map_or(out, |l| l.min(out)));
            }
        }
    }
    (least, single)
}

/// What the data can show at best: per population and loop kind, the AUC of the observer that
/// knows everything but the noise ([`known_model_lr`]), its sticky loops that show nothing
/// (ratio below χ²₁(95 %)), how often it is right with one threshold and how many
/// `inconclusive` it needs to be right on 95 % of the conclusive; beside it the shipped
/// score's AUC on the same loops, and on the loops the observer sees.
pub(super) fn ceiling(valid: &[(&str, Vec<Case>)]) -> Result<()> {
    println!(
        "
what the data can show at best: an observer who knows the plant, the noise's colour, the valve and its parameters, not the noise (known_model_lr, AR order {KNOWN_MODEL_ORDER}); loops that can be judged:"
    );
    println!(
        "| population | loops | sticky / free | its AUC | sticky, ratio < {} | right, one threshold | inconclusive for 95 % right | the score's AUC | the score's AUC where it sees |",
        datasets::simulate::population::NO_TRACE_LR
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let all: Vec<&Case> = valid.iter().flat_map(|(_, c)| c.iter()).collect();
    let mut groups: Vec<(String, Vec<&Case>)> = Vec::new();
    for (name, cases) in valid {
        for (kind, integrating) in [("self-regulating", false), ("integrating", true)] {
            let g: Vec<&Case> = cases
                .iter()
                .filter(|c| c.kind_integrating == integrating)
                .collect();
            groups.push((format!("{name} | {kind}"), g));
        }
    }
    for (kind, integrating) in [
        ("self-regulating", Some(false)),
        ("integrating", Some(true)),
        ("all", None),
    ] {
        let g: Vec<&Case> = all
            .iter()
            .copied()
            .filter(|c| integrating.is_none_or(|i| c.kind_integrating == i))
            .collect();
        groups.push((format!("**every validation loop** | {kind}"), g));
    }
    for (name, g) in groups {
        let g: Vec<&Case> = g
            .into_iter()
            .filter(|c| c.judgeable && c.known_model.is_some())
            .collect();
        if g.is_empty() {
            continue;
        }
        let lr = |c: &Case| c.known_model.unwrap_or(0.0);
        let known: Vec<(f64, bool)> = g.iter().map(|c| (lr(c), c.sticky)).collect();
        let hidden = g
            .iter()
            .filter(|c| c.sticky && lr(c) < datasets::simulate::population::NO_TRACE_LR)
            .count();
        let sticky = g.iter().filter(|c| c.sticky).count();
        let (least, single) = frontier(&known, 0.95);
        let mut score = Vec::new();
        let mut seen = Vec::new();
        for c in &g {
            let s = c.judged()?.score;
            score.push((s, c.sticky));
            if !c.sticky || lr(c) >= datasets::simulate::population::NO_TRACE_LR {
                seen.push((s, c.sticky));
            }
        }
        println!(
            "| {name} | {} / {} | {} | {hidden} of {sticky} | {:.1} % | {} | {} | {} |",
            sticky,
            g.len() - sticky,
            fmt_auc(auc(&known)),
            100.0 * single,
            least.map_or("never".to_string(), |l| format!("{:.1} %", 100.0 * l)),
            fmt_auc(auc(&score)),
            fmt_auc(auc(&seen)),
        );
    }
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
        what: format!("{preset:?} a={a} S={s} J={j} seed {seed}"),
        sticky: s > 0.0,
        no_trace: false,
        trace_lr: None,
        tie: false,
        judged: None,
        judgeable: true,
        kind_integrating: false,
        oracle: None,
        known_model: None,
        kind_from_data: None,
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
pub(super) fn paper_benchmark(model: &Model) -> Result<()> {
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
                    Ok((judge(&c, model)?.verdict, c.sticky))
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

/// How well the record alone tells integrating loops from self-regulating ones.
pub(super) fn kind_table(sets: &[(&str, Vec<Case>)]) {
    println!(
        "  {:24} {:>4}  {:>18}  {:>22}  {:>22}",
        "population", "n", "decided by data", "right where decided", "right with tag as tie-break"
    );
    let mut all = (0, 0, 0, 0);
    for (name, cases) in sets.iter().map(|(n, c)| (*n, c)) {
        let n = cases.len();
        let decided: Vec<&Case> = cases
            .iter()
            .filter(|c| c.kind_from_data.is_some())
            .collect();
        let right = decided
            .iter()
            .filter(|c| c.kind_from_data == Some(c.kind_integrating))
            .count();
        // tie: the level family carries `L` in its tag
        let right_tag = right + (n - decided.len());
        println!(
            "  {name:24} {n:>4}  {:>12} ({:>3.0} %)  {:>14.1} % of {:>3}  {:>20.1} %",
            decided.len(),
            100.0 * decided.len() as f64 / n.max(1) as f64,
            100.0 * right as f64 / decided.len().max(1) as f64,
            decided.len(),
            100.0 * right_tag as f64 / n.max(1) as f64
        );
        all = (
            all.0 + n,
            all.1 + decided.len(),
            all.2 + right,
            all.3 + right_tag,
        );
    }
    let every = || sets.iter().flat_map(|(_, c)| c.iter());
    let called = |truth: bool, said: bool| {
        every()
            .filter(|c| c.kind_integrating == truth && c.kind_from_data == Some(said))
            .count()
    };
    println!(
        "  integrating loops called self-regulating by the data: {} of {}; self-regulating called integrating: {} of {}",
        called(true, false),
        every().filter(|c| c.kind_integrating).count(),
        called(false, true),
        every().filter(|c| !c.kind_integrating).count()
    );
    println!(
        "  {:24} {:>4}  {:>12} ({:>3.0} %)  {:>14.1} % of {:>3}  {:>20.1} %",
        "every validation loop",
        all.0,
        all.1,
        100.0 * all.1 as f64 / all.0.max(1) as f64,
        100.0 * all.2 as f64 / all.1.max(1) as f64,
        all.1,
        100.0 * all.3 as f64 / all.0.max(1) as f64
    );
}

#[cfg(test)]
mod tests {
    use super::frontier;

    #[test]
    fn the_frontier_counts_the_inconclusive_it_needs() {
        // separated: one threshold is right on everything
        let apart = [(0.0, false), (0.0, false), (5.0, true), (9.0, true)];
        assert_eq!(frontier(&apart, 0.95), (Some(0.0), 1.0));
        // one sticky loop scores as the free ones do: one threshold is right on 4 of 5 at
        // best, and 95 % needs the tied three left out (the sticky one cannot be told apart)
        let tied = [
            (0.0, false),
            (0.0, false),
            (0.0, true),
            (5.0, true),
            (9.0, true),
        ];
        assert_eq!(frontier(&tied, 0.95), (Some(0.6), 0.8));
        // no pair reaches it when every sticky loop scores below every free one
        let backwards = [(1.0, true), (2.0, false)];
        assert_eq!(frontier(&backwards, 0.95), (None, 0.5));
    }
}
