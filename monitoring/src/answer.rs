//! One answer per record: the loop kind decided once ([`analyse`]), then one verdict — the
//! detector's — and the S that explains it ([`Answer`]), shown alike by `quantify`, `diagnose`,
//! `detect` and each registration of `trend`.
//!
//! A record is fitted by two model structures: the paper's Hammerstein identification ranked by
//! one-step prediction (`quantify`'s grid, [`SFrom::OneStep`]) and the detector's output-error
//! fit of a Kano valve through a first-order lag ([`detection::hammerstein`],
//! [`SFrom::OutputError`]). Neither is known to be the right structure for a given plant, so
//! the range of S is the hull of both structures' 95 % likelihood regions: the S values that
//! either structure leaves as likely as its best. The S reported is chosen by [`RULE`], set by
//! measurement on simulated populations (`cargo run -p monitoring --example s_evidence`;
//! docs/DETECTION.md, "One answer per record"), never by plant data; the output says which
//! evidence it rests on.

use std::path::Path;

use datasets::LoopData;
use detection::{Detection, Verdict};
use grid_search::{Quantification, MAINTENANCE_S, NEGLIGIBLE_S};
use serde::{Deserialize, Serialize};

use crate::detect::{detect_view, DetectionView};
use crate::kind::{file_name, Integrating, KindDecision};
use crate::registration::increments;

/// A record as every command analyses it: the loop kind decided once, the record as searched
/// (the increments ΔPV of an integrating loop, else the record itself) and whether OP's valve
/// span is known.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// Integrating or not, and what decided it.
    pub kind: KindDecision,
    /// The record as the fits search it: MV → ΔPV for an integrating loop.
    pub searched: LoopData,
    /// OP's valve span is unknown: S is in % of the OP range seen.
    pub span_unknown: bool,
    /// PV read back from a historian's compressed storage ([`datasets::compression`], as the
    /// reader notes it): `None` when PV is not.
    pub pv_compression: Option<datasets::Compression>,
    /// PV held between updates every few samples ([`datasets::held`]: an analyser's cycle, or
    /// a historian's step retrieval): `None` when PV is live.
    pub pv_held: Option<datasets::held::Held>,
}

/// The [`Analysis`] of the record `d` read from `file` (`None` for a made-up record): the
/// loop kind as [`Integrating::decide`] decides it from the record and the file's valve tag
/// (the file name up to the first `_`).
pub fn analyse(d: &LoopData, file: Option<&Path>, integrating: Integrating) -> Analysis {
    let valve = file
        .map(|f| datasets::parse_registration_name(&file_name(f)).valve)
        .unwrap_or_default();
    let kind = integrating.decide(&valve, Some(d));
    Analysis::of(d, kind)
}

impl Analysis {
    /// The analysis of the record `d` with its loop kind already decided.
    pub fn of(d: &LoopData, kind: KindDecision) -> Analysis {
        Analysis {
            searched: if kind.integrating {
                increments(d)
            } else {
                d.clone()
            },
            span_unknown: datasets::units::span_unknown(&d.notes),
            pv_compression: d
                .pv
                .as_deref()
                .and_then(datasets::compression)
                .filter(datasets::Compression::detected),
            pv_held: d.pv.as_deref().and_then(datasets::held::held_period),
            kind,
        }
    }

    /// The detector on the record as read (`d`, the same record [`analyse`] took), with the
    /// decided kind.
    pub fn detect(&self, d: &LoopData) -> DetectionView {
        detect_view(d, self.kind)
    }
}

/// Which fit an S comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SFrom {
    /// The paper's Hammerstein identification, ranked by one-step prediction (`quantify`).
    OneStep,
    /// The detector's Hammerstein test: a Kano valve through a first-order lag, output error.
    OutputError,
}

impl SFrom {
    /// In words, for the text output.
    pub fn describe(self) -> &'static str {
        match self {
            SFrom::OneStep => "the one-step-prediction fit",
            SFrom::OutputError => "the detector's output-error fit",
        }
    }
}

/// One structure's S with its 95 % likelihood region.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Estimate {
    /// The best S.
    #[serde(rename = "S")]
    pub s: f64,
    /// Its region `[lo, hi]`.
    pub range: [f64; 2],
}

impl Estimate {
    /// Rounded to four decimals (finer than any grid step), as the JSON shows it.
    fn rounded(self) -> Estimate {
        let r = |x: f64| (x * 1e4).round() / 1e4;
        Estimate {
            s: r(self.s),
            range: [r(self.range[0]), r(self.range[1])],
        }
    }

    /// The one-step-prediction fit's S.
    pub fn one_step(q: &Quantification) -> Estimate {
        Estimate {
            s: q.s,
            range: q.interval.s,
        }
    }

    /// The detector's output-error S (its Hammerstein test), when the test fitted one; its
    /// region runs between the grid's nodes around the nodes in it (`S_lower`, `S_above`).
    pub fn output_error(det: &Detection) -> Option<Estimate> {
        let t = det.tests.iter().find(|t| t.name == "hammerstein")?;
        let s = t.value("S").filter(|s| s.is_finite())?;
        let lo = t.value("S_lower").unwrap_or(s).min(s);
        let hi = t.value("S_above").unwrap_or(s).max(s);
        Some(Estimate { s, range: [lo, hi] })
    }
}

/// How the S reported is chosen between the two fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rule {
    /// Always the one-step fit's S (the paper's).
    OneStep,
    /// Always the output-error fit's S (the detector's), the one-step S when there is none.
    OutputError,
    /// The one-step S when it agrees with the verdict, else the output-error S when that
    /// does.
    Agreeing,
}

/// The rule every command uses, chosen by measurement on simulated populations
/// (`examples/s_evidence.rs`; docs/DETECTION.md, "One answer per record").
pub const RULE: Rule = Rule::Agreeing;

/// Whether `s` (in % of valve span) agrees with `verdict`: a sticky valve has more than a
/// negligible band, a free one less than the maintenance threshold. An inconclusive verdict
/// agrees with any S.
pub fn agrees(verdict: Verdict, s: f64) -> bool {
    match verdict {
        Verdict::Stiction => s > NEGLIGIBLE_S,
        Verdict::NoStiction => s < MAINTENANCE_S,
        Verdict::Inconclusive => true,
    }
}

/// Whether the estimate `e` agrees with `verdict`. With OP's valve span known, [`agrees`]
/// on its S. With the span unknown (`span_unknown`), S is in % of the OP range seen and no
/// threshold in % of valve span applies: the fit's own 95 % region decides, which needs no
/// unit. A sticky valve's region excludes a free valve (its lower end above 0); a free
/// valve's region holds one (its lower end at 0). An inconclusive verdict agrees with any S.
pub fn agrees_in(verdict: Verdict, e: Estimate, span_unknown: bool) -> bool {
    if !span_unknown {
        return agrees(verdict, e.s);
    }
    match verdict {
        Verdict::Stiction => e.range[0] > 0.0,
        Verdict::NoStiction => e.range[0] <= 0.0,
        Verdict::Inconclusive => true,
    }
}

/// Why a repair estimated with the one-step fit's valve (`run::Fitted::repair`) does not go
/// with the record's answer: the fit's S `one_step` contradicts the detector's `verdict`
/// ([`agrees_in`]), so the loop it simulates is not this one (a sticky valve "repaired" from a
/// negligible fitted S buys nothing; a healthy one gets a benefit from a band the detector
/// does not see). `None` when the fit agrees.
pub fn repair_refusal(
    verdict: Verdict,
    one_step: Estimate,
    span_unknown: bool,
) -> Option<repair::NoRepair> {
    (!agrees_in(verdict, one_step, span_unknown)).then(|| repair::NoRepair::Contradicted {
        s: one_step.s,
        verdict: verdict.as_str(),
    })
}

/// One verdict on a record and the S that explains it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Answer {
    /// The detector's verdict, computed once.
    #[serde(serialize_with = "verdict_str")]
    pub verdict: Verdict,
    /// The detector's score (`None` when it could not run).
    pub score: Option<f64>,
    /// The S reported (`None` when no fit gave one).
    #[serde(rename = "S")]
    pub s: Option<f64>,
    /// The hull of both fits' regions (and the S reported).
    #[serde(rename = "S_range")]
    pub s_range: Option<[f64; 2]>,
    /// Which fit the S comes from.
    #[serde(rename = "S_from")]
    pub s_from: Option<SFrom>,
    /// The unit of S: `% of valve span`, or `% of the OP range seen` when the span is unknown.
    #[serde(rename = "S_unit")]
    pub s_unit: &'static str,
    /// The one-step-prediction fit's S and region (absent for `detect`, which does not run it).
    pub one_step: Option<Estimate>,
    /// The output-error fit's S and region.
    pub output_error: Option<Estimate>,
    /// Whether the loop was treated as integrating.
    pub integrating: bool,
    /// What decided it.
    pub integrating_by: String,
    /// What limits the statement: no fit agrees with the verdict; `None` otherwise.
    pub caution: Option<String>,
}

fn verdict_str<S: serde::Serializer>(v: &Verdict, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(v.as_str())
}

/// The unit of S when OP's span is known.
pub const SPAN_UNIT: &str = "% of valve span";
/// The unit of S when it is not.
pub const RANGE_UNIT: &str = discrepancy::RANGE_SEEN_UNIT;

impl Answer {
    /// The answer on a record analysed as `a`, from the detector's `det` and the one-step
    /// fit `q` (when the command ran it), with [`RULE`].
    pub fn new(a: &Analysis, det: &crate::Detected, q: Option<&Quantification>) -> Answer {
        Answer::with_rule(a, det, q, RULE)
    }

    /// [`Answer::new`] with another `rule` (for the measurement that chose [`RULE`]).
    pub fn with_rule(
        a: &Analysis,
        det: &crate::Detected,
        q: Option<&Quantification>,
        rule: Rule,
    ) -> Answer {
        let verdict = det.verdict();
        let one_step = q.map(|q| Estimate::one_step(q).rounded());
        let output_error = det
            .detection()
            .and_then(Estimate::output_error)
            .map(Estimate::rounded);
        let chosen = choose(verdict, one_step, output_error, rule, a.span_unknown)
            .map(|(e, f)| (e.rounded(), f));
        let s = chosen.map(|(e, _)| e.s);
        let s_range = chosen.map(|(e, _)| {
            [one_step, output_error]
                .into_iter()
                .flatten()
                .map(Estimate::rounded)
                .fold(e.range, |r, x| [r[0].min(x.range[0]), r[1].max(x.range[1])])
        });
        let caution = match chosen {
            Some((e, _)) if !agrees_in(verdict, e, a.span_unknown) => Some(format!(
                "no fit gives an S that agrees with the verdict {verdict} (S {:.2}): the S is not evidence for it; look at the figures, or repeat the registration",
                e.s
            )),
            None if verdict != Verdict::Inconclusive => {
                Some("no fit gave an S: the verdict rests on the detector's tests alone".into())
            }
            _ => None,
        };
        let cautions: Vec<String> = [
            caution,
            edge_caution(chosen, a.span_unknown),
            compression_caution(verdict, a.pv_compression),
            held_caution(verdict, a.pv_held),
        ]
        .into_iter()
        .flatten()
        .collect();
        let caution = (!cautions.is_empty()).then(|| cautions.join("; "));
        Answer {
            verdict,
            score: det.score(),
            s,
            s_range,
            s_from: chosen.map(|(_, f)| f),
            s_unit: if a.span_unknown {
                RANGE_UNIT
            } else {
                SPAN_UNIT
            },
            one_step,
            output_error,
            integrating: a.kind.integrating,
            integrating_by: a.kind.note(),
            caution,
        }
    }

    /// Why a repair estimated with the one-step fit's valve does not go with this answer
    /// ([`repair_refusal`]); `None` when it does, or without a one-step fit.
    pub fn repair_refusal(&self) -> Option<repair::NoRepair> {
        self.one_step
            .and_then(|e| repair_refusal(self.verdict, e, self.span_unknown()))
    }

    /// The repair `r`, estimated with the one-step fit's valve, when that fit agrees with the
    /// verdict; else why it does not go with this answer ([`Answer::repair_refusal`]).
    pub fn repair(
        &self,
        r: Result<repair::Repair, repair::NoRepair>,
    ) -> Result<repair::Repair, repair::NoRepair> {
        match self.repair_refusal() {
            Some(refusal) => Err(refusal),
            None => r,
        }
    }

    /// Whether OP's valve span is unknown (S in % of the OP range seen).
    pub fn span_unknown(&self) -> bool {
        self.s_unit != SPAN_UNIT
    }

    /// S with its unit: `2.00 %`, or `2.00 (% of the OP range seen)` when OP's span is
    /// unknown (no threshold in % of span applies to it then).
    pub fn s_text(&self, s: f64) -> String {
        if self.s_unit == SPAN_UNIT {
            format!("{s:.2} %")
        } else {
            format!("{s:.2} ({})", self.s_unit)
        }
    }

    /// The answer in one line: `stiction: S = 2.00 % [0.50, 3.00] (the detector's output-error
    /// fit; the one-step-prediction fit says 0.04 %)`, and the caution when there is one.
    pub fn line(&self) -> String {
        let mut out = format!("{}", self.verdict);
        if let (Some(s), Some(r), Some(from)) = (self.s, self.s_range, self.s_from) {
            out.push_str(&format!(
                ": S = {} [{:.2}, {:.2}] ({}",
                self.s_text(s),
                r[0],
                r[1],
                from.describe()
            ));
            let other = match from {
                SFrom::OneStep => self.output_error.map(|e| (SFrom::OutputError, e)),
                SFrom::OutputError => self.one_step.map(|e| (SFrom::OneStep, e)),
            };
            if let Some((f, e)) = other {
                out.push_str(&format!("; {} says {:.2}", f.describe(), e.s));
            }
            out.push_str("; range: both fits' 95 % regions)");
        }
        if let Some(c) = &self.caution {
            out.push_str(&format!("; caution: {c}"));
        }
        out
    }
}

/// The caution a `stiction` verdict carries on a PV read back from compressed storage: swinging
/// door and box-car archives keep a point only when PV has moved by more than their deviation,
/// so the PV read back lacks its small moves, as a deadband's MV lacks OP's. On the simulated
/// populations of `cargo xtask detect-calibrate` the verdict `stiction` is wrong (a free valve)
/// 1.5 to 3 times as often when PV is compressed (docs/DETECTION.md, Failures). `None` for
/// any other verdict or an uncompressed PV.
pub fn compression_caution(verdict: Verdict, pv: Option<datasets::Compression>) -> Option<String> {
    let c = pv.filter(|_| verdict == Verdict::Stiction)?;
    Some(format!(
        "PV reads back from compressed storage ({:.0} % of its samples on {} straight segments): compression drops PV's small moves as a deadband drops OP's, and free valves are called sticky more often on such records; confirm on an uncompressed export",
        100.0 * c.share,
        c.segments
    ))
}

/// The caution a `stiction` verdict carries on a PV held between updates every `k` samples
/// ([`datasets::held`]): between two updates PV repeats itself exactly while OP moves, as PV
/// does behind a stuck valve. On 60 loops of a simulator written apart from ours, PV held over
/// 10 samples made 5 of 9 `stiction` verdicts free valves (at the held thresholds of
/// [`crate::detect::hold_on_held_pv`]), against 1 of 21 on the live PV (docs/DETECTION.md,
/// Failures). `None` for any other verdict or a live PV.
pub fn held_caution(verdict: Verdict, held: Option<datasets::held::Held>) -> Option<String> {
    let h = held.filter(|_| verdict == Verdict::Stiction)?;
    Some(format!(
        "PV changes only every {} samples and repeats itself between (an analyser's cycle, or a historian's values held between the ones it stored), as PV does behind a stuck valve; free valves are called sticky more often on such records: confirm on a live export",
        h.period
    ))
}

/// What limits an S the detector's output-error fit found at its grid's largest band
/// ([`detection::hammerstein::LARGEST_S`]): the valve's band may be wider (a valve stuck over
/// most of the record). `None` for any other S.
fn edge_caution(chosen: Option<(Estimate, SFrom)>, span_unknown: bool) -> Option<String> {
    let largest = detection::hammerstein::LARGEST_S;
    let unit = if span_unknown { "" } else { " %" };
    chosen
        .filter(|(e, f)| *f == SFrom::OutputError && e.s >= largest)
        .map(|_| {
            format!(
                "S is the largest band the detector's fit tries ({largest:.0}{unit}): the valve's band may be wider"
            )
        })
}

/// The S a registration reports ([`reported`]): the S that explains the detector's verdict,
/// the hull of both fits' regions and which fit it comes from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Reported {
    /// The S reported.
    #[serde(rename = "S")]
    pub s: f64,
    /// The hull of both fits' 95 % regions.
    #[serde(rename = "S_range")]
    pub range: [f64; 2],
    /// Which fit the S comes from.
    #[serde(rename = "S_from")]
    pub from: SFrom,
}

/// The S reported for a registration whose combination fitted `one_step` and whose record the
/// detector answered `det` (`None`: it did not run), OP's span known or not (`span_unknown`):
/// [`RULE`]'s choice, as [`Answer::new`] makes it, with the hull of both fits' regions.
/// `trend` follows this S.
pub fn reported(one_step: Estimate, det: Option<&crate::Detected>, span_unknown: bool) -> Reported {
    let verdict = det.map_or(Verdict::Inconclusive, crate::Detected::verdict);
    let output_error = det
        .and_then(crate::Detected::detection)
        .and_then(Estimate::output_error)
        .map(Estimate::rounded);
    let (e, from) = choose(verdict, Some(one_step), output_error, RULE, span_unknown)
        .unwrap_or((one_step, SFrom::OneStep));
    let range = output_error.map_or(one_step.range, |o| {
        [
            one_step.range[0].min(o.range[0]),
            one_step.range[1].max(o.range[1]),
        ]
    });
    Reported {
        s: e.s,
        range: [range[0].min(e.s), range[1].max(e.s)],
        from,
    }
}

/// The S reported under `rule`, and which fit it comes from (agreement judged by
/// [`agrees_in`]).
fn choose(
    verdict: Verdict,
    one_step: Option<Estimate>,
    output_error: Option<Estimate>,
    rule: Rule,
    span_unknown: bool,
) -> Option<(Estimate, SFrom)> {
    let os = one_step.map(|e| (e, SFrom::OneStep));
    let oe = output_error.map(|e| (e, SFrom::OutputError));
    match rule {
        Rule::OneStep => os.or(oe),
        Rule::OutputError => oe.or(os),
        Rule::Agreeing => {
            let agreeing = |x: &Option<(Estimate, SFrom)>| {
                x.filter(|(e, _)| agrees_in(verdict, *e, span_unknown))
            };
            agreeing(&os).or(agreeing(&oe)).or(os).or(oe)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn est(s: f64) -> Option<Estimate> {
        Some(Estimate { s, range: [s, s] })
    }

    /// An output-error S at the grid's largest band is a lower bound, and the answer says so;
    /// no other S gets that caution.
    #[test]
    fn an_s_at_the_grids_largest_band_is_said_to_be_a_lower_bound() {
        let top = detection::hammerstein::LARGEST_S;
        let at = |s: f64, f: SFrom| Some((Estimate { s, range: [s, s] }, f));
        let c = edge_caution(at(top, SFrom::OutputError), false).unwrap();
        assert!(c.contains("(25 %)") && c.contains("may be wider"), "{c}");
        assert!(edge_caution(at(top, SFrom::OutputError), true)
            .unwrap()
            .contains("(25)"));
        assert_eq!(edge_caution(at(20.0, SFrom::OutputError), false), None);
        assert_eq!(edge_caution(at(30.0, SFrom::OneStep), false), None);
        assert_eq!(edge_caution(None, false), None);
    }

    /// A repair simulated with the one-step valve goes with the answer only where that fit
    /// agrees with the verdict.
    #[test]
    fn a_repair_goes_with_the_answer_only_from_an_agreeing_fit() {
        let e = |s: f64, lo: f64| Estimate { s, range: [lo, s] };
        let refused = |v, x, unknown| repair_refusal(v, x, unknown).is_some();
        assert!(refused(Verdict::Stiction, e(0.1, 0.0), false));
        assert!(!refused(Verdict::Stiction, e(2.0, 1.5), false));
        assert!(refused(Verdict::NoStiction, e(2.6, 2.5), false));
        assert!(!refused(Verdict::NoStiction, e(0.3, 0.0), false));
        assert!(!refused(Verdict::Inconclusive, e(9.0, 8.0), false));
        // OP's span unknown: the fit's own region decides
        assert!(refused(Verdict::Stiction, e(5.0, 0.0), true));
        assert!(!refused(Verdict::Stiction, e(0.1, 0.05), true));
        let msg = repair_refusal(Verdict::Stiction, e(0.1, 0.0), false)
            .unwrap()
            .to_string();
        assert!(
            msg.contains("contradicts the detector's verdict stiction"),
            "{msg}"
        );
    }

    #[test]
    fn the_agreeing_rule_reports_the_fit_that_agrees_with_the_verdict() {
        let pick =
            |v, a, b| choose(v, est(a), est(b), Rule::Agreeing, false).map(|(e, f)| (e.s, f));
        assert_eq!(
            pick(Verdict::Stiction, 0.04, 2.0),
            Some((2.0, SFrom::OutputError))
        );
        assert_eq!(
            pick(Verdict::Stiction, 1.0, 2.0),
            Some((1.0, SFrom::OneStep))
        );
        assert_eq!(
            pick(Verdict::NoStiction, 2.6, 0.25),
            Some((0.25, SFrom::OutputError))
        );
        assert_eq!(
            pick(Verdict::NoStiction, 2.6, 3.0),
            Some((2.6, SFrom::OneStep))
        );
        assert_eq!(
            pick(Verdict::Inconclusive, 2.6, 0.25),
            Some((2.6, SFrom::OneStep))
        );
        assert_eq!(
            choose(Verdict::Stiction, None, est(2.0), Rule::OneStep, false).map(|(e, _)| e.s),
            Some(2.0)
        );
    }

    /// With OP's span unknown, no % threshold: a sticky verdict agrees with a region that
    /// excludes a free valve however small S is, a free verdict with one that holds a free
    /// valve however large S is.
    #[test]
    fn in_unknown_units_the_region_decides_not_a_percent_threshold() {
        let e = |s, lo, hi| Estimate { s, range: [lo, hi] };
        // below the 0.2 % negligible band, yet the region excludes 0
        assert!(agrees_in(Verdict::Stiction, e(0.1, 0.05, 0.15), true));
        assert!(!agrees_in(Verdict::Stiction, e(0.1, 0.05, 0.15), false));
        assert!(!agrees_in(Verdict::Stiction, e(5.0, 0.0, 6.0), true));
        // above the 1.6 % maintenance threshold, yet the region holds 0
        assert!(agrees_in(Verdict::NoStiction, e(2.0, 0.0, 2.5), true));
        assert!(!agrees_in(Verdict::NoStiction, e(2.0, 0.0, 2.5), false));
        assert!(!agrees_in(Verdict::NoStiction, e(0.3, 0.25, 0.35), true));
        let picked = choose(
            Verdict::NoStiction,
            Some(e(0.3, 0.25, 0.35)),
            Some(e(3.0, 0.0, 4.0)),
            Rule::Agreeing,
            true,
        );
        assert_eq!(picked.map(|(_, f)| f), Some(SFrom::OutputError));
    }
}
