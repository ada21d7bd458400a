//! The causes one valve's registrations agree on: a diagnosis whose causes shift from one
//! day's record to the next gives a planner nothing to act on, so the causes named on most
//! registrations are the valve's, and every registration that names other causes is listed
//! with the likelihood ratios that made it differ.

pub use run::{Consensus, Disagreement};

use crate::Diagnosis;

/// The consensus of one valve's registrations, each `(label, diagnosis)`.
pub fn consensus(diagnoses: &[(&str, &Diagnosis)]) -> Consensus {
    let n = diagnoses.len();
    let mut counts: Vec<(String, usize)> = Vec::new();
    for (_, d) in diagnoses {
        let mut seen: Vec<&String> = Vec::new();
        for c in &d.causes {
            if seen.contains(&c) {
                continue;
            }
            seen.push(c);
            match counts.iter_mut().find(|(name, _)| name == c) {
                Some(entry) => entry.1 += 1,
                None => counts.push((c.clone(), 1)),
            }
        }
    }
    let mut causes: Vec<(String, usize)> = counts.into_iter().filter(|(_, k)| 2 * k > n).collect();
    causes.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let held: Vec<&str> = causes.iter().map(|(c, _)| c.as_str()).collect();
    let disagreeing = diagnoses
        .iter()
        .filter_map(|(label, d)| {
            let named: Vec<&str> = d.causes.iter().map(String::as_str).collect();
            let missing = held.iter().filter(|c| !named.contains(c));
            let extra = named.iter().filter(|c| !held.contains(c));
            let why: Vec<String> = missing
                .map(|c| format!("no {c}: {}", standing(d, c)))
                .chain(extra.map(|c| format!("also {c}: {}", standing(d, c))))
                .collect();
            (!why.is_empty()).then(|| Disagreement {
                label: label.to_string(),
                causes: d.causes.clone(),
                why,
            })
        })
        .collect();
    Consensus {
        registrations: n,
        causes,
        disagreeing,
    }
}

/// How `cause` stood in diagnosis `d`, in words: for a cause it names, the likelihood ratio
/// and threshold of the step that added it ([`Diagnosis::standing`]); for another, those of its
/// last test: on the final model (the forward selection's last step, which tested every cause
/// not named) or, when there was no forward selection, on the baseline.
fn standing(d: &Diagnosis, cause: &str) -> String {
    let named = d.causes.iter().any(|c| c == cause);
    let (finding, place) = if named {
        match d.standing(cause) {
            Some(s) => (s.finding, ""),
            None => return "named without a test of its own".to_string(),
        }
    } else {
        let last = d
            .steps
            .last()
            .and_then(|step| step.iter().find(|f| f.cause == cause))
            .map(|f| (f, " on the final model"));
        let first = d
            .findings
            .iter()
            .find(|f| f.cause == cause)
            .map(|f| (f, " on the baseline"));
        match last.or(first) {
            Some(x) => x,
            None => return "not tested".to_string(),
        }
    };
    if finding.lr.is_finite() {
        format!(
            "likelihood ratio {:.1}{place} (threshold {:.1}){}",
            finding.lr,
            finding.threshold,
            if finding.significant {
                ""
            } else {
                ", not significant"
            }
        )
    } else {
        match &finding.error {
            Some(e) => format!("not fitted{place} ({e})"),
            None => format!("no likelihood ratio{place}"),
        }
    }
}
