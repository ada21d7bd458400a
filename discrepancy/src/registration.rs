//! The diagnosis of one registration of a valve's trend, in one sentence: what the model
//! misses in that record and what the extension changes. `monitoring::trend` asks it, with the
//! data it has read, for each registration, for the weak and outlying ones' evidence and for
//! the causes the valve's registrations agree on ([`consensus`]).

use datasets::LoopData;
use grid_search::Problem;
use run::{span_of, Combination, Delay};

use rayon::prelude::*;

use crate::{consensus, diagnose, Consensus, DiagnoseOptions, Diagnosis};

/// The diagnosis of the record `d` (as searched: the increments of an integrating loop) with
/// `combination` as baseline: its orders in full (defaults filled in), dead time 0, its grid
/// and search options ([`diagnose`], as `stiction diagnose`); or why it failed, in words.
pub fn diagnosis(d: &LoopData, combination: &Combination) -> Result<Diagnosis, String> {
    let pv = d.require_pv().map_err(|e| e.to_string())?;
    let span = span_of(&d.op);
    let identifier = combination.identifier(0).map_err(|e| run::error_line(&e))?;
    let baseline = Combination {
        orders: crate::orders_without_delay(identifier.as_ref()),
        delay: Delay::Fixed(0),
        grid: None,
        search: grid_search::SearchOptions::default(),
        ..combination.clone()
    };
    let mut options = DiagnoseOptions::for_span(span);
    options.search = combination.options(span);
    let problem = Problem {
        op: &d.op,
        pv,
        mv: d.mv.as_deref(),
    };
    diagnose(problem, &baseline, &options).map_err(|e| e.to_string())
}

/// The diagnosis of the record `d` with `combination` as baseline ([`diagnosis`]) in one
/// sentence, or why it failed.
pub fn diagnose_one(d: &LoopData, combination: &Combination) -> Result<String, String> {
    diagnosis(d, combination).map(|dg| sentence(&dg))
}

/// Diagnose each of `records` once with `combination` as baseline (in parallel): each one's
/// sentence (or why its diagnosis failed), in order, and what the diagnosed ones agree on,
/// each labelled by `labels` (same order).
pub fn diagnose_all(
    records: &[&LoopData],
    labels: &[String],
    combination: &Combination,
) -> (Vec<Result<String, String>>, Consensus) {
    let found: Vec<Result<Diagnosis, String>> = records
        .par_iter()
        .map(|d| diagnosis(d, combination))
        .collect();
    let diagnosed: Vec<(&str, &Diagnosis)> = labels
        .iter()
        .zip(&found)
        .filter_map(|(label, d)| d.as_ref().ok().map(|d| (label.as_str(), d)))
        .collect();
    let agreed = consensus(&diagnosed);
    let sentences = found
        .iter()
        .map(|d| d.as_ref().map(sentence).map_err(Clone::clone))
        .collect();
    (sentences, agreed)
}

/// The diagnosis in one sentence.
pub fn sentence(dg: &Diagnosis) -> String {
    match dg.chosen.and_then(|i| dg.findings.get(i)) {
        Some(f) if f.role == crate::Role::NullHypothesis => format!(
            "diagnosis: no-stiction (a valve with negligible stiction, S {} % at most {} %, explains PV as well as S {:.2} %: validation F_PV {:+.1} points)",
            f.extended.as_ref().map_or("-".into(), |x| format!("{:.2}", x.s)),
            grid_search::NEGLIGIBLE_S,
            dg.baseline.s,
            f.gain_fit_pv_val
        ),
        Some(f) => {
            let s = f.extended.as_ref().map_or(String::new(), |x| {
                format!(", S {:.2} -> {:.2} %", dg.baseline.s, x.s)
            });
            format!(
                "diagnosis: {} (validation F_PV {:+.1} points{s})",
                f.cause, f.gain_fit_pv_val
            )
        }
        None => "diagnosis: none (no extension explains this record significantly better)".into(),
    }
}
