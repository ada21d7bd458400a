//! The plain-text output of each command (what `stiction` prints without `--json`), from the
//! typed results. Each function returns the text; the CLI prints it.

use std::fmt::{self, Write};
use std::path::Path;

use datasets::{format_epoch, LoopData};
use detection::Detection;
use discrepancy::Diagnosis;
use grid_search::Criterion;
use linear_id::Structure;
use monitoring::batch::{self, BatchRun, OkRow, Row};
use monitoring::trend::ValveTrend;
use monitoring::{Answer, Detected, Evidence, Flag, Roc, Trend};
use run::identify::Identification;
use run::Fitted;

use crate::verdict::{opt2, own_params};

/// The text of `quantify`: the combination, S and J with their ranges, the fits, the grid, the
/// verdict (the record's one answer, [`monitoring::Answer`]) and the warnings. `init` is the
/// initialization's label.
pub fn quantify(
    source: &str,
    r: &Fitted,
    init: &str,
    answer: &Answer,
) -> Result<String, fmt::Error> {
    let q = &r.result;
    let mut text = String::new();
    let out = &mut text;

    let orders: Vec<String> = r
        .identifier
        .orders()
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    let delay_note = match &r.delay_scan {
        Some(_) => format!("dead time {} samples (estimated)", r.delay),
        None => format!("dead time {} samples", r.delay),
    };
    writeln!(
        out,
        "{}: {} + {} ({}), {}, {delay_note}, ranked by {}",
        source,
        r.stiction.name,
        r.linear,
        orders.join(", "),
        init,
        q.criterion.describe()
    )?;
    let own = own_params(r.stiction, q);
    writeln!(
        out,
        "  S = {}  [{:.2}, {:.2}]    J = {}  [{:.2}, {:.2}]    ({})",
        answer.s_text(q.s),
        q.interval.s[0],
        q.interval.s[1],
        answer.s_text(q.j),
        q.interval.j[0],
        q.interval.j[1],
        own.join(", ")
    )?;
    let (fid, fval) = q.fits.rank(q.criterion);
    let (oid, oval) = q.fits.rank(q.criterion.other());
    writeln!(
        out,
        "  F_PV id {:.2} %, val {:.2} %   (other fit: id {}, val {})   F_MV {}   no stiction: val {}",
        fid,
        fval,
        opt2(Some(oid)),
        opt2(Some(oval)),
        opt2(q.fits.mv),
        opt2(q.fit_no_stiction)
    )
    ?;
    writeln!(
        out,
        "  [S, J] ranges: {} within the {:.0} % likelihood-ratio region; grid {} nodes ({} skipped), step {}, OP span {:.2}; {:.0} ms",
        if q.interval.nodes == 1 {
            "1 node".to_string()
        } else {
            format!("{} nodes", q.interval.nodes)
        },
        100.0 * q.interval.confidence,
        q.nodes_evaluated,
        q.nodes_skipped,
        (q.grid.step() * 1e6).round() / 1e6,
        q.span,
        r.elapsed_ms
    )
    ?;
    writeln!(out, "  loop: {}", answer.integrating_by)?;
    writeln!(out, "  verdict: {}", answer.line())?;
    for (i, w) in q.warnings.iter().enumerate() {
        let kind = if i < q.doubts.len() {
            "warning"
        } else {
            "note"
        };
        writeln!(out, "  {kind}: {w}")?;
    }
    Ok(text)
}

/// `x` with `decimals` decimals (and its sign when `signed`), or `-` when it is not a finite
/// number: tables never show `NaN` or `inf`.
pub fn finite_or_dash(x: f64, decimals: usize, signed: bool) -> String {
    match (x.is_finite(), signed) {
        (false, _) => "-".into(),
        (true, true) => format!("{x:+.decimals$}"),
        (true, false) => format!("{x:.decimals$}"),
    }
}

/// The `repair:` line of `quantify` and `diagnose`: what a free valve would change in the
/// identified loop ([`repair::assess`]), or why that could not be estimated.
pub fn repair_line(outcome: &Result<repair::Repair, repair::NoRepair>) -> String {
    match outcome {
        Err(e) => format!("  repair: not estimated: {e}"),
        Ok(r) => {
            let c = &r.controller;
            let law = match c.kind {
                repair::ControllerKind::P => format!("P kc {}", sig3(c.kc)),
                repair::ControllerKind::Pi => format!("PI kc {}, ti {} s", sig3(c.kc), sig3(c.ti)),
                repair::ControllerKind::Pid => format!(
                    "PID kc {}, ti {} s, td {} s",
                    sig3(c.kc),
                    sig3(c.ti),
                    sig3(c.td)
                ),
            };
            let mut line = format!(
                "  repair: a free valve would remove {:.0} % of the control error's spread ({} -> {}; the record's {}), valve reversals {:.0} -> {:.0} per hour; controller {law} (explains {:.1} % of the OP moves)",
                100.0 * r.reduction,
                sig3(r.error_std_now),
                sig3(r.error_std_repaired),
                sig3(r.error_std_measured),
                r.reversals_per_hour_now,
                r.reversals_per_hour_repaired,
                c.fit
            );
            if let Some(note) = &r.note {
                line.push_str(&format!("\n  note: {note}"));
            }
            line
        }
    }
}

/// `x` with three significant digits (plain notation in the usual range).
fn sig3(x: f64) -> String {
    if !x.is_finite() {
        return "none".into();
    }
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e6).contains(&a) {
        return format!("{x:.2e}");
    }
    let decimals = if a == 0.0 {
        0
    } else {
        (2 - a.log10().floor() as i32).max(0) as usize
    };
    format!("{x:.decimals$}")
}

/// One combination of a `compare`: its names and its fit or its error.
pub type CompareRow<'a> = (&'a str, &'a str, Result<&'a Fitted, String>);

/// The table of `compare` (the layout of the paper's Tables 3-8).
pub fn compare(
    d: &LoopData,
    split: f64,
    init: &str,
    criterion: Criterion,
    rows: &[CompareRow<'_>],
) -> Result<String, fmt::Error> {
    let mut text = String::new();
    let out = &mut text;

    writeln!(
        out,
        "{}: {} samples, identification {} / validation {}, {}, ranked by {}",
        d.source,
        d.len(),
        (d.len() as f64 * split).floor(),
        d.len() - (d.len() as f64 * split).floor() as usize,
        init,
        criterion.describe()
    )?;
    writeln!(
        out,
        "{:<10} {:<7} {:>6} {:>13} {:>6} {:>13} {:>9} {:>9} {:>7} {:>8}",
        "stiction", "linear", "S", "S range", "J", "J range", "F_PV id", "F_PV val", "F_MV", "time"
    )?;
    for (st, li, r) in rows {
        match r {
            Ok(r) => {
                let q = &r.result;
                let (fid, fval) = q.fits.rank(q.criterion);
                writeln!(
                    out,
                    "{:<10} {:<7} {:>6.2} {:>13} {:>6.2} {:>13} {:>9.2} {:>9.2} {:>7} {:>7.1}s",
                    st,
                    li,
                    q.s,
                    format!("{:.2}-{:.2}", q.interval.s[0], q.interval.s[1]),
                    q.j,
                    format!("{:.2}-{:.2}", q.interval.j[0], q.interval.j[1]),
                    fid,
                    fval,
                    opt2(q.fits.mv),
                    r.elapsed_ms / 1e3
                )?;
            }
            Err(msg) => {
                writeln!(out, "{st:<10} {li:<7} error: {msg}")?;
            }
        }
    }
    Ok(text)
}

/// The rows of a diagnosis' table of causes: the causes held in the final model first, in
/// the order they were added, each with the finding of the step that added it; then the
/// others, in the order of [`Diagnosis::findings`].
pub fn cause_rows(dg: &Diagnosis) -> Vec<discrepancy::Standing<'_>> {
    let mut rows: Vec<discrepancy::Standing<'_>> =
        dg.causes.iter().filter_map(|c| dg.standing(c)).collect();
    for f in &dg.findings {
        if !rows.iter().any(|r| r.finding.cause == f.cause) {
            rows.push(discrepancy::Standing {
                finding: f,
                step: None,
                held: false,
            });
        }
    }
    rows
}

/// The `held` cell of a cause row: `yes (step k)`, `yes`, or `no`.
pub fn held_cell(row: &discrepancy::Standing<'_>) -> String {
    match (row.held, row.step) {
        (true, Some(k)) => format!("yes, step {k}"),
        (true, None) => "yes".into(),
        (false, _) => "no".into(),
    }
}

/// The text of `diagnose`: the cause to act on (S in the unit of the record's `answer`: no %
/// threshold when OP's valve span is unknown), the summary and the table of causes.
pub fn diagnose(d: &LoopData, dg: &Diagnosis, answer: &Answer) -> Result<String, fmt::Error> {
    let mut text = String::new();
    let out = &mut text;

    writeln!(
        out,
        "{}: diagnosis of {} + {} ({} samples, {:.1} s)",
        d.source,
        dg.baseline.stiction_model,
        dg.baseline.linear_model,
        d.len(),
        dg.elapsed_ms / 1e3
    )?;
    let head = dg.headline_in(answer.span_unknown());
    writeln!(out, "action: {}", head.action_line())?;
    writeln!(out, "causes: {}", head.causes_line())?;
    writeln!(out)?;
    writeln!(
        out,
        "{:<20} {:>9} {:>11} {:>8} {:>11}  {:<24} {:>7} {:>7} {:>9} {:>8}",
        "cause", "statistic", "LR", "needed", "held", "model fitted", "S", "J", "F_PV val", "ΔF_PV"
    )?;
    let b = &dg.baseline;
    writeln!(
        out,
        "{:<20} {:>9} {:>11} {:>8} {:>11}  {:<24} {:>7.2} {:>7.2} {:>9.2} {:>8}",
        "(baseline)",
        "-",
        "-",
        "-",
        "-",
        format!("{} + {} d={}", b.stiction_model, b.linear_model, b.delay),
        b.s,
        b.j,
        b.fit_pv_val,
        "-"
    )?;
    for row in cause_rows(dg) {
        let f = row.finding;
        let (ext, s_, j_, fv) = match &f.extended {
            Some(e) => (
                format!("{} + {} d={}", e.stiction_model, e.linear_model, e.delay),
                format!("{:.2}", e.s),
                format!("{:.2}", e.j),
                format!("{:.2}", e.fit_pv_val),
            ),
            None => (
                f.error.clone().unwrap_or_else(|| "-".into()),
                "-".into(),
                "-".into(),
                "-".into(),
            ),
        };
        writeln!(
            out,
            "{:<20} {:>9} {:>11} {:>8} {:>11}  {:<24} {:>7} {:>7} {:>9} {:>8}",
            f.cause,
            finite_or_dash(f.statistic, 2, false),
            finite_or_dash(f.lr, 1, false),
            finite_or_dash(f.threshold.abs(), 1, false),
            held_cell(&row),
            ext,
            s_,
            j_,
            fv,
            finite_or_dash(f.gain_fit_pv_val, 2, true)
        )?;
    }
    writeln!(
        out,
        "held: in the final model, with the forward selection's step that added the cause; LR, needed and ΔF_PV are that step's (step 1 against the baseline, step k on top of the causes before it). S, J: the fitted model's{} (no-stiction: the best valve with S at most {}).",
        if answer.span_unknown() {
            format!(", in {}", head.s_unit)
        } else {
            String::new()
        },
        if answer.span_unknown() {
            discrepancy::in_unit(grid_search::NEGLIGIBLE_S, true)
        } else {
            format!("{} %", grid_search::NEGLIGIBLE_S)
        }
    )?;
    writeln!(out)?;
    writeln!(out, "{}", dg.summary)?;
    Ok(text)
}

/// What `trend`'s text and page say when a registration's OP has no known valve span.
pub const RANGE_SEEN_NOTE: &str = "OP's valve span is unknown in some registration(s): their S is \
     in % of the OP range each record shows, not of valve span; registrations compare only where \
     their OP ranges match, and no threshold in % of valve span applies (give --op-range LO,HI).";

/// The text of `trend`: per combination the registrations with their flags and evidence (S:
/// the S each reports, [`monitoring::registration::Registration::reported`], marked `*` when
/// it is the detector's output-error fit's), the level and the slope; then the verdict and its
/// rule.
pub fn trend(vt: &ValveTrend) -> Result<String, fmt::Error> {
    let mut text = String::new();
    let out = &mut text;

    let regs = &vt.registrations;
    let first = regs.iter().find_map(|r| r.start).map(format_epoch);
    let last = regs.iter().rev().find_map(|r| r.start).map(format_epoch);
    writeln!(
        out,
        "valve {}: {} registration(s), {} .. {}{}",
        vt.valve,
        regs.len(),
        first.unwrap_or_else(|| "?".into()),
        last.unwrap_or_else(|| "?".into()),
        if regs.iter().any(|r| r.integrating) {
            "; integrating loop: identified from MV to ΔPV"
        } else {
            ""
        }
    )?;
    let unknown = regs.iter().any(monitoring::trend::span_unknown);
    for (c, ct) in vt.combinations.iter().enumerate() {
        let t = &ct.trend;
        writeln!(out, "\n{} + {}", ct.stiction, ct.linear)?;
        writeln!(
            out,
            "{:>3}  {:<16}  {:>6} {:>13}  {:>5} {:>11}  {:>8}  {:<7}  why",
            "#", "time", "S", "S range", "J", "J range", "F_PV val", "flag"
        )?;
        let mut marked = false;
        for (k, (r, flag)) in regs.iter().zip(&t.flags).enumerate() {
            let time = r.start.map(format_epoch).unwrap_or_else(|| r.file.clone());
            match (r.fit(c).zip(r.reported(c)), r.error(c)) {
                (Some((f, rep)), _) => {
                    let mark = if rep.from == monitoring::SFrom::OutputError {
                        marked = true;
                        "*"
                    } else {
                        " "
                    };
                    let why = if *flag == Flag::Used {
                        String::new()
                    } else if f.evidence.is_empty() {
                        "no evidence of a disturbance in this registration: the valve itself \
                         may have changed (maintenance, operating range)"
                            .to_string()
                    } else {
                        join(&f.evidence)
                    };
                    writeln!(
                        out,
                        "{:>3}  {time:<16}  {:>6.2}{mark}{:>13}  {:>5.2} {:>11}  {:>8.1}  {:<7}  {why}",
                        k + 1,
                        rep.s,
                        format!("{:.2}-{:.2}", rep.range[0], rep.range[1]),
                        f.j,
                        format!("{:.2}-{:.2}", f.j_range[0], f.j_range[1]),
                        f.fit_val,
                        flag.label()
                    )?;
                }
                (None, Some(e)) if *flag == Flag::Inconclusive => {
                    let why = r
                        .detection
                        .as_ref()
                        .map_or_else(String::new, |d| d.reason());
                    writeln!(
                        out,
                        "{:>3}  {time:<16}  inconclusive: {why}; no fit: {e}",
                        k + 1
                    )?;
                }
                (None, e) => {
                    let e = e.map(ToString::to_string).unwrap_or_default();
                    writeln!(out, "{:>3}  {time:<16}  error: {}: {e}", k + 1, r.file)?;
                }
            }
        }
        if marked {
            writeln!(
                out,
                "  *: S from the detector's output-error fit, which explains its verdict where this combination's one-step S does not; S range: both fits' 95 % regions"
            )?;
        }
        let count = |x: Flag| t.flags.iter().filter(|f| **f == x).count();
        writeln!(
            out,
            "  usable {}, weak {}, outliers {}, errors {}{}{}",
            count(Flag::Used),
            count(Flag::Weak),
            count(Flag::Outlier),
            count(Flag::Error),
            match count(Flag::Inconclusive) {
                0 => String::new(),
                n => format!(", inconclusive without a fit {n}"),
            },
            t.band
                .map(|b| format!("; outlier band S in [{:.2}, {:.2}]", b[0], b[1]))
                .unwrap_or_default()
        )?;
        writeln!(out, "  {}", level_line(t, unknown))?;
    }
    if unknown {
        writeln!(out, "\nnote: {RANGE_SEEN_NOTE}")?;
    }
    if let Some(c) = &vt.causes {
        let lines = causes_lines(c, &baseline_of(vt));
        writeln!(out, "\n{}", lines[0])?;
        for l in &lines[1..] {
            writeln!(out, "  {l}")?;
        }
    }
    writeln!(out, "\nverdict: {}: {}", vt.verdict, vt.reason)?;
    writeln!(out, "rule: {}", vt.rule())?;
    Ok(text)
}

/// The combination a trend's diagnoses start from (its first), as `kano + arx`.
pub fn baseline_of(vt: &ValveTrend) -> String {
    vt.combinations
        .first()
        .map_or_else(String::new, |c| format!("{} + {}", c.stiction, c.linear))
}

/// What a valve's diagnosed registrations agree on: the first line says which causes hold on
/// most registrations (or that none does), one more line per registration that disagrees.
pub fn causes_lines(c: &run::Consensus, baseline: &str) -> Vec<String> {
    let n = c.registrations;
    let head = if c.causes.is_empty() {
        let none = n - c.disagreeing.len();
        if 2 * none > n {
            format!(
                "causes: none (no cause named on {none} of the {n} registration(s) diagnosed with {baseline} as baseline)"
            )
        } else {
            // No consensus: every registration naming a cause disagrees; the counts say more
            // than a line for each (they stay in the JSON and the page's table).
            let mut counts: Vec<(&str, usize)> = Vec::new();
            for d in &c.disagreeing {
                for cause in &d.causes {
                    match counts.iter_mut().find(|(name, _)| name == cause) {
                        Some(e) => e.1 += 1,
                        None => counts.push((cause, 1)),
                    }
                }
            }
            counts.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
            let named: Vec<String> = counts
                .iter()
                .map(|(cause, k)| format!("{cause} on {k}"))
                .chain((none > 0).then(|| format!("none on {none}")))
                .collect();
            return vec![format!(
                "causes: no cause holds on most of the {n} registration(s) diagnosed with {baseline} as baseline: {}",
                named.join(", ")
            )];
        }
    } else {
        format!(
            "causes: {} (of the {n} registration(s) diagnosed with {baseline} as baseline)",
            c.causes
                .iter()
                .map(|(cause, k)| format!("{cause} on {k}"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    let mut lines = vec![head];
    for d in &c.disagreeing {
        lines.push(format!(
            "{} names {}: {}",
            d.label,
            if d.causes.is_empty() {
                "none".to_string()
            } else {
                d.causes.join(", ")
            },
            d.why.join("; ")
        ));
    }
    lines
}

/// The `answer:` line of `diagnose` (and `detect`): the record's one verdict and the S that
/// explains it.
pub fn answer_line(answer: &Answer) -> String {
    format!("answer: {}", answer.line())
}

/// The detector's line under `quantify` and `diagnose`:
/// `detection: <verdict> (score 0.xx): <reason>` (`no score` when it could not run).
pub fn detection_line(d: &Detected) -> String {
    format!(
        "detection: {} ({}): {}",
        d.verdict(),
        match d.detection() {
            Some(det) => score_and_tests(det),
            None => "no score".into(),
        },
        d.reason()
    )
}

/// `score 0.95; tests: 1 stiction, 2 no-stiction, 5 inconclusive`: the score with what the
/// tests say one by one, so that a verdict is never read as the tests' majority.
pub fn score_and_tests(det: &Detection) -> String {
    let count = |v: detection::Verdict| det.tests.iter().filter(|t| t.verdict == v).count();
    format!(
        "score {:.2}; tests: {} stiction, {} no-stiction, {} inconclusive",
        det.score,
        count(detection::Verdict::Stiction),
        count(detection::Verdict::NoStiction),
        count(detection::Verdict::Inconclusive)
    )
}

/// The text of `stiction detect`: the verdict with its score and reason, the loop (oscillation,
/// integrating or not, samples and sampling time), then one line per test with its statistic,
/// verdict and evidence.
pub fn detect(d: &LoopData, det: &Detection, answer: &Answer) -> Result<String, fmt::Error> {
    let mut text = String::new();
    let out = &mut text;
    let (source, ts) = (&d.source, run::sample_time(d));
    writeln!(
        out,
        "{source}: {} ({}): {}",
        det.verdict,
        score_and_tests(det),
        det.reason
    )?;
    let oscillation = match det.period_s {
        Some(p) => format!("oscillating, period {p:.0} s"),
        None => "no regular oscillation".to_string(),
    };
    let kind = match &det.integrating_by {
        Some(note) => format!("loop {note}"),
        None if det.integrating => "integrating loop".to_string(),
        None => "self-regulating loop".to_string(),
    };
    writeln!(
        out,
        "  {oscillation}; {kind}; {} samples every {ts} s",
        d.op.len()
    )?;
    writeln!(out, "  {}", answer_line(answer))?;
    writeln!(
        out,
        "  {:18} {:>9}  {:12}  evidence",
        "test", "statistic", "verdict"
    )?;
    for t in &det.tests {
        let stat = t
            .statistic
            .filter(|v| v.is_finite())
            .map_or("-".to_string(), |v| format!("{v:.3}"));
        let verdict = t.verdict.as_str();
        writeln!(
            out,
            "  {:18} {stat:>9}  {verdict:12}  {}",
            t.name, t.evidence
        )?;
    }
    Ok(text)
}

/// The text of `stiction models`: the registered stiction models with their parameters and
/// constraints, and the linear identifiers with their orders' defaults.
pub fn models() -> String {
    let mut out =
        String::from("Stiction models (OP -> MV); parameters in OP units (% of valve span):\n");
    for e in stiction_models::registry() {
        let params: Vec<&str> = e.params.iter().map(|p| p.name).collect();
        let constraints: Vec<String> = e.constraints.iter().map(|c| c.describe()).collect();
        let constraints = if constraints.is_empty() {
            String::new()
        } else {
            format!("  [{}]", constraints.join("; "))
        };
        let _ = writeln!(out, "  {:<11} {}{constraints}", e.name, params.join(", "));
        let _ = writeln!(out, "  {:<11} {}", "", e.description);
    }
    out.push_str("\nLinear identifiers (MV -> PV); orders with their defaults:\n");
    for e in linear_id::registry() {
        let orders: Vec<String> = e
            .orders
            .iter()
            .map(|o| format!("{}={}", o.name, o.default))
            .collect();
        let _ = writeln!(out, "  {:<11} {}", e.name, orders.join(", "));
        let _ = writeln!(out, "  {:<11} {}", "", e.description);
    }
    out
}

/// The lines closing `stiction batch`: files and rows (`jsonl` the run's OUT.jsonl); with
/// `labelled`, the first combination (stiction model, identifier), how well S and the
/// detector's score separate the labels (ROC AUC, Youden's threshold).
pub fn batch_summary(
    files: usize,
    run: &BatchRun,
    jsonl: Option<&Path>,
    labelled: Option<(&str, &str)>,
) -> String {
    let rows = &run.rows;
    let ok = rows.iter().filter(|r| r.is_ok()).count();
    let mut out = format!(
        "{files} file(s): {ok} row(s) ok, {} error row(s); {} file(s) computed, {} skipped (already in {})\n",
        rows.len() - ok,
        run.computed,
        run.skipped,
        jsonl.map_or("-".into(), |p| p.display().to_string())
    );
    let Some((st, li)) = labelled else {
        return out;
    };
    let sum = batch::label_summary(rows, st, li);
    let (n, npos) = (sum.rows, sum.stiction);
    let _ = match sum.roc {
        Some(Roc { auc, threshold: thr, tpr, fpr }) => writeln!(
            out,
            "labels ({st} + {li}, {n} labelled rows: {npos} stiction, {} no-stiction): ROC AUC of S = {auc:.3}; best threshold S >= {thr:.2} % (Youden: TPR {tpr:.2}, FPR {fpr:.2})",
            n - npos
        ),
        None => writeln!(
            out,
            "labels: ROC needs ok rows of both labels ({n} labelled ok rows, {npos} stiction)"
        ),
    };
    let det = batch::detect_label_summary(rows, st, li);
    let (n, npos) = (det.rows, det.stiction);
    let _ = match det.roc {
        Some(Roc { auc, threshold: thr, tpr, fpr }) => writeln!(
            out,
            "labels (detector, same rows, {n} with a score: {npos} stiction, {} no-stiction): ROC AUC of detect_score = {auc:.3}; best threshold score >= {thr:.2} (Youden: TPR {tpr:.2}, FPR {fpr:.2})",
            n - npos
        ),
        None => writeln!(
            out,
            "labels (detector): ROC needs scored ok rows of both labels ({n} labelled scored rows, {npos} stiction)"
        ),
    };
    out
}

/// Evidence joined with `; `.
pub fn join(evidence: &[Evidence]) -> String {
    let v: Vec<String> = evidence.iter().map(ToString::to_string).collect();
    v.join("; ")
}

/// `level (median S) ...; trend ...; latest usable S ...`.
/// The level, slope and latest S of a trend; without `%` when S is in % of the OP range seen
/// (`span_unknown`).
fn level_line(t: &Trend, span_unknown: bool) -> String {
    let unit = if span_unknown { "" } else { " %" };
    format!(
        "level (median S) {}; trend {}; latest usable S {}",
        t.level.map_or("-".into(), |v| format!("{v:.2}{unit}")),
        t.slope_30d.map_or("-".into(), |v| format!(
            "{v:+.3}{unit} per 30 days (Theil-Sen)"
        )),
        t.latest.map_or("-".into(), |v| format!("{v:.2}{unit}")),
    )
}

/// The text of `identify`: the model, its poles and fits.
pub fn identify(source: &str, id: &Identification) -> Result<String, fmt::Error> {
    let mut text = String::new();
    let out = &mut text;
    let (fit, stable) = (&id.fit, id.fit.is_stable());
    let (fit_id, fit_val, sim_val) = (id.fit_id, id.fit_val, id.sim_val);
    let (ni, n) = (id.samples[0], id.samples[0] + id.samples[1]);
    let o: Vec<String> = id.orders.iter().map(|(k, v)| format!("{k}={v}")).collect();
    writeln!(
        out,
        "{source}: {} from {} to PV ({}), {ni} identification / {} validation samples",
        id.linear,
        id.input,
        o.join(", "),
        n - ni
    )?;
    match fit.structure() {
        Structure::Polynomial { a, b, c, delay } => {
            let fmt = |v: &[f64]| {
                v.iter()
                    .map(|x| format!("{x:.6}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            writeln!(out, "  A(q) = [{}]", fmt(a))?;
            writeln!(
                out,
                "  B(q) = [{}]  (q^-1 .. q^-{}, dead time {delay})",
                fmt(b),
                b.len()
            )?;
            if c.len() > 1 {
                writeln!(out, "  C(q) = [{}]", fmt(c))?;
            }
        }
        Structure::StateSpace { a, .. } => {
            writeln!(
                out,
                "  state space, order {} (A, B, C, D, K, x0 with --json)",
                a.len()
            )?;
        }
    }
    let poles: Vec<String> = fit
        .poles()
        .iter()
        .map(|(re, im)| {
            if im.abs() < 1e-12 {
                format!("{re:.4}")
            } else {
                format!("{re:.4}{im:+.4}i")
            }
        })
        .collect();
    writeln!(
        out,
        "  static gain {:.4}, poles {} ({})",
        fit.static_gain(),
        poles.join(", "),
        if stable { "stable" } else { "UNSTABLE" }
    )?;
    writeln!(
        out,
        "  F_PV one-step prediction: id {fit_id:.2} %, val {fit_val:.2} %; free-run simulation val {}",
        sim_val.filter(|v| v.is_finite()).map_or("-".into(), |v| format!("{v:.2} %"))
    )
    ?;
    if let Some(eta) = fit.disturbance() {
        let (lo, hi) = eta
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        writeln!(
            out,
            "  estimated disturbance η̂: {} samples, range [{lo:.4}, {hi:.4}] (series with --json)",
            eta.len()
        )?;
    }
    Ok(text)
}

/// The rows of `batch` as a table (without `-o`).
pub fn batch_table(rows: &[Row]) -> String {
    let mut out = format!(
        "{:<34} {:<14} {:<16} {:<11} {:<6} {:>6} {:>13} {:>5} {:>8} {:>6}  {:<12}  error\n",
        "file",
        "valve",
        "time",
        "label",
        "status",
        "S",
        "S range",
        "J",
        "F_PV val",
        "repair",
        "detect"
    );
    for r in rows {
        let num = |f: &dyn Fn(&OkRow) -> f64| {
            r.ok()
                .map(f)
                .filter(|v| v.is_finite())
                .map_or("-".into(), |v| format!("{v:.2}"))
        };
        let _ = writeln!(
            out,
            "{:<34} {:<14} {:<16} {:<11} {:<6} {:>6} {:>13} {:>5} {:>8} {:>6}  {:<12}  {}",
            r.file,
            r.valve,
            r.time.as_deref().unwrap_or("?"),
            match r.label {
                Some(batch::Label::Stiction) => "stiction",
                Some(batch::Label::NoStiction) => "no-stiction",
                None => "-",
            },
            if r.is_ok() { "ok" } else { "error" },
            num(&|o| o.s),
            if r.is_ok() {
                format!("{}-{}", num(&|o| o.s_lo), num(&|o| o.s_hi))
            } else {
                "-".into()
            },
            num(&|o| o.j),
            num(&|o| o.fit_pv_val),
            // the fraction of the control error a repair would remove, in %
            r.ok()
                .and_then(|o| o.quantify.repair.as_ref())
                .map_or("-".into(), |p| format!("{:.0} %", 100.0 * p.reduction)),
            if r.detect_verdict.is_empty() {
                "-"
            } else {
                &r.detect_verdict
            },
            r.error().unwrap_or("")
        );
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn models_lists_every_order_with_its_typed_default() {
        let t = super::models();
        assert!(t.starts_with("Stiction models (OP -> MV)"), "{t}");
        assert!(
            t.contains(
                "  ss          n=2, f=10, p=10, threshold=0.1, max_order=0, d_required=false, center=true\n"
            ),
            "{t}"
        );
        assert!(
            t.contains("  earx        n=2, m=2, delay=0, lambda_beta=0.8\n"),
            "{t}"
        );
    }
}
