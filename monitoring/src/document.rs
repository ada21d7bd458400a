//! The JSON documents of the commands, built in one place from typed records: `quantify
//! --json` ([`quantify`]), `detect --json` ([`detect`]) and `diagnose --json` ([`diagnose`]).
//! The CLI and the Python package print them as they come.

use datasets::LoopData;
use detection::Detection;
use discrepancy::Diagnosis;
use run::{sample_time, QuantifyRecord};
use serde_json::{json, Value};
use stiction_models::Initialization;

use crate::answer::Answer;
use crate::detect::Detected;
use crate::kind::KindDecision;

/// The `quantify --json` document: the quantify `record` (its repair estimate filled in),
/// with the loop's `source`, the detector's `detection` object and the `answer` (one verdict
/// and the S that explains it).
pub fn quantify(
    source: &str,
    record: &QuantifyRecord,
    det: &Detected,
    answer: &Answer,
) -> Result<Value, serde_json::Error> {
    let mut v = serde_json::to_value(record)?;
    v["source"] = json!(source);
    v["detection"] = json!(det.record());
    v["answer"] = serde_json::to_value(answer)?;
    Ok(v)
}

/// The `compare --json` document: the combinations' records with the loop kind (`integrating`,
/// `integrating_by`) they were fitted for.
pub fn compare(doc: &run::CompareRecord, kind: &KindDecision) -> Result<Value, serde_json::Error> {
    let mut v = serde_json::to_value(doc)?;
    v["integrating"] = json!(kind.integrating);
    v["integrating_by"] = json!(kind.note());
    Ok(v)
}

/// The `diagnose --json` document: the diagnosis of the loop of `source` searched with
/// `init` ([`Diagnosis::record`]), with the detector's `detection` object and what a repair
/// would buy in the final model (`repair`, or `null` and `repair_reason`) and the `answer`.
pub fn diagnose(
    source: &str,
    dg: &Diagnosis,
    init: &Initialization,
    det: &Detected,
    repair: &Result<repair::Repair, repair::NoRepair>,
    answer: &Answer,
) -> Value {
    let mut v = dg.record(source, init);
    // the headline in S's unit: no % threshold when OP's valve span is unknown
    v["headline"] = json!(dg.headline_in(answer.span_unknown()));
    v["detection"] = json!(det.record());
    v["answer"] = json!(answer);
    let (value, reason) = match repair {
        Ok(r) => (json!(r), Value::Null),
        Err(e) => (Value::Null, json!(e.to_string())),
    };
    v["repair"] = value;
    v["repair_reason"] = reason;
    v
}

/// The `detect --json` document of `d`'s detection: `source`, `score`, `verdict`, `reason`,
/// `oscillating`, `period_s`, `integrating`, `sample_time_s`, `tests` (array of `{name,
/// statistic, verdict, evidence}`), `answer` (the verdict and the S that explains it).
pub fn detect(d: &LoopData, det: &Detection, answer: &Answer) -> Value {
    let tests: Vec<Value> = det
        .tests
        .iter()
        .map(|t| {
            json!({
                "name": t.name,
                "statistic": t.statistic.filter(|v| v.is_finite()),
                "verdict": t.verdict.as_str(),
                "evidence": t.evidence,
            })
        })
        .collect();
    json!({
        "source": d.source,
        "score": det.score,
        "verdict": det.verdict.as_str(),
        "reason": det.reason,
        "oscillating": det.oscillating,
        "period_s": det.period_s,
        "integrating": det.integrating,
        "integrating_by": det.integrating_by,
        "sample_time_s": sample_time(d),
        "tests": tests,
        "answer": answer,
    })
}
