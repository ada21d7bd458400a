//! The sentences on an estimate that the pages share: what one model's quantification says
//! ([`verdict`]), the model's own parameters ([`own_params`]) and the two-decimal numbers.
//! The record's one verdict is [`monitoring::Answer`]'s.

use grid_search::{Quantification, Severity, HARMFUL_S, MAINTENANCE_S, NEGLIGIBLE_S};
use stiction_models::ModelEntry;

/// `x` with two decimals, `-` when not finite.
pub(crate) fn f2(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2}")
    } else {
        "-".into()
    }
}

/// An optional number with two decimals, `-` when absent or not finite.
pub(crate) fn opt2(x: Option<f64>) -> String {
    x.map_or_else(|| "-".into(), f2)
}

/// One sentence on what a quantification says about the valve, with how far to trust it. The
/// levels are [`grid_search::trust`]'s, the only place they are defined: "the valve sticks"
/// only for S >= [`HARMFUL_S`] with no doubt; a slight S or a doubtful estimate says so. With
/// OP's valve span unknown (`span_unknown`), S is in % of the OP range seen and is judged
/// against none of those thresholds: the sentence gives S and asks for the span.
pub fn verdict(q: &Quantification, label: &str, span_unknown: bool) -> String {
    let (_, val) = q.fits.rank(q.criterion);
    let fit = format!(
        "validation F_PV {:.1} % ({})",
        val,
        match q.criterion {
            grid_search::Criterion::Prediction => "one-step prediction",
            grid_search::Criterion::Simulation => "free-run simulation",
        }
    );
    let v = q.verdict();
    let region = format!(
        "S = {:.2} % of valve span (deadband + stickband; {:.0} % region {:.2}-{:.2}), J = {:.2} % (region {:.2}-{:.2})",
        q.s,
        100.0 * q.interval.confidence,
        q.interval.s[0],
        q.interval.s[1],
        q.j,
        q.interval.j[0],
        q.interval.j[1]
    );
    let doubts: Vec<String> = v.doubts.iter().map(grid_search::Doubt::short).collect();
    if span_unknown {
        let weak = if doubts.is_empty() {
            String::new()
        } else {
            format!(", and the evidence is weak: {}", doubts.join("; "))
        };
        return format!(
            "{label}: estimated S = {} (deadband + stickband; {:.0} % region {:.2}-{:.2}), J = {} (region {:.2}-{:.2}); {fit}. OP's valve span is unknown, so no threshold in % of valve span applies to S{weak}: state the span (--op-range LO,HI) to judge it.",
            discrepancy::in_unit(q.s, true),
            100.0 * q.interval.confidence,
            q.interval.s[0],
            q.interval.s[1],
            discrepancy::in_unit(q.j, true),
            q.interval.j[0],
            q.interval.j[1]
        );
    }
    match v.severity {
        Severity::Negligible if doubts.is_empty() => format!(
            "{label}: no stiction found (S = {:.2} % of valve span, at most {NEGLIGIBLE_S} %); {fit}.",
            q.s
        ),
        Severity::Negligible => format!(
            "{label}: no stiction found (S = {:.2} % of valve span, at most {NEGLIGIBLE_S} %), but the evidence is weak: {}; {fit}.",
            q.s,
            doubts.join("; ")
        ),
        _ if !doubts.is_empty() => format!(
            "{label}: estimated {region}, but the evidence is weak: {}; {fit}. Do not act on this estimate alone: look at the figures, or repeat the registration.",
            doubts.join("; ")
        ),
        Severity::Slight => format!(
            "{label}: slight stiction, {region}; {fit}. Below the {HARMFUL_S} % at which stiction degrades control."
        ),
        Severity::Harmful => {
            let maintenance = if q.s >= MAINTENANCE_S {
                format!(
                    " It is at or above the {MAINTENANCE_S} % maintenance threshold of `stiction trend`."
                )
            } else {
                String::new()
            };
            format!(
                "{label}: the valve sticks, {region}; {fit}. Stiction of {HARMFUL_S} % or more degrades control.{maintenance}"
            )
        }
    }
}

/// The best model's own parameters and derived values, `name = value` (3 decimals).
pub fn own_params(entry: &ModelEntry, q: &Quantification) -> Vec<String> {
    entry
        .params
        .iter()
        .zip(q.stiction.param_values())
        .map(|(p, v)| format!("{} = {v:.3}", p.name))
        .chain(
            q.stiction
                .derived_values()
                .into_iter()
                .map(|(k, v)| format!("{k} = {v:.3}")),
        )
        .collect()
}
