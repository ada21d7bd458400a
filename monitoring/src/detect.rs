//! The detection crate's verdict on a loop read by the workflow: the time series of the record
//! (PV, OP, SP when there is one), its sampling time and whether the loop is integrating —
//! never the file name beyond that flag, the labels or the source path.
//!
//! [`detect_loop`] is what `registration::evaluate` runs on each record it reads (so `batch`,
//! `trend`, `quantify` and `diagnose` all see the same answer) and what `stiction detect`
//! prints in full.

use std::path::Path;

use datasets::{DataError, LoopData};
use detection::figures::{CrossCorrelation, PvOpEllipse};
use detection::{Detection, DetectionError, Verdict};
use serde::Serialize;

use crate::kind::{file_name, Integrating, KindDecision};
use run::sample_time;

/// Why the detector could not run on a record.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DetectError {
    /// The record has no PV (or the reader refused it).
    #[error(transparent)]
    Data(#[from] DataError),
    /// The series cannot make a detection registration (lengths, sampling time).
    #[error(transparent)]
    Detection(#[from] DetectionError),
}

/// The detector's answer on one record: the [`Detection`], or why it could not run (an
/// inconclusive result with that reason).
#[derive(Debug)]
pub enum Detected {
    /// The detector ran (its verdict may still be `inconclusive`, with its reason).
    Ran(Detection),
    /// It could not run.
    Failed(DetectError),
}

impl Detected {
    /// The verdict (`inconclusive` when the detector could not run).
    pub fn verdict(&self) -> Verdict {
        match self {
            Detected::Ran(d) => d.verdict,
            Detected::Failed(_) => Verdict::Inconclusive,
        }
    }

    /// The score in `[0, 1]` (`None` when the detector could not run).
    pub fn score(&self) -> Option<f64> {
        match self {
            Detected::Ran(d) => Some(d.score).filter(|s| s.is_finite()),
            Detected::Failed(_) => None,
        }
    }

    /// Why, in one sentence.
    pub fn reason(&self) -> String {
        match self {
            Detected::Ran(d) => d.reason.clone(),
            Detected::Failed(e) => format!("the detector could not run: {e}"),
        }
    }

    /// The full detection, when the detector ran.
    pub fn detection(&self) -> Option<&Detection> {
        match self {
            Detected::Ran(d) => Some(d),
            Detected::Failed(_) => None,
        }
    }

    /// The `detection` object of the JSON documents.
    pub fn record(&self) -> DetectionRecord {
        DetectionRecord {
            verdict: self.verdict().as_str(),
            score: self.score(),
            reason: self.reason(),
        }
    }
}

/// The `detection` object of `quantify --json`, `diagnose --json` and each registration of
/// `trend --json` (`stiction detect --json` gives every test besides).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DetectionRecord {
    /// `stiction`, `no-stiction` or `inconclusive`.
    pub verdict: &'static str,
    /// The score in `[0, 1]`; `null` when the detector could not run.
    pub score: Option<f64>,
    /// Why, in one sentence.
    pub reason: String,
}

/// Score at or above which a `stiction` verdict stands on a PV held between updates
/// ([`hold_on_held_pv`]); chosen with [`HELD_NO_STICTION_AT`] by `cargo xtask
/// detect-calibrate --hold K`: over the training loops with PV held over 5 and over 10 samples
/// (pooled), the loosest score on a 0.05 grid at which each verdict is right at least as
/// often as the verdicts on the live training loops (90.6 %), so that a verdict on a held PV
/// means what it means on a live one (`docs/decisions/2026-11-30-held-thresholds.md`).
pub const HELD_STICTION_AT: f64 = 0.85;
/// Score at or below which a `no-stiction` verdict stands on a PV held between updates (as
/// [`HELD_STICTION_AT`]).
pub const HELD_NO_STICTION_AT: f64 = 0.15;

/// The detection `det` of a record whose PV is `pv`, with a conclusive verdict kept on a PV
/// held between updates ([`datasets::held`]: an analyser's cycle, or a historian's values read
/// back with step retrieval) only at a score beyond [`HELD_STICTION_AT`] or
/// [`HELD_NO_STICTION_AT`]; else it is `inconclusive`, with the reason. Between two updates
/// such a PV repeats itself exactly while OP moves, as behind a stuck valve, and the evidence
/// the tests read from PV's motion is partly gone: on the simulated validation loops with PV
/// held over 5 or 10 samples the verdicts at the live thresholds were right on 74 % of the
/// conclusive (`docs/decisions/2026-11-30-held-thresholds.md`). The held thresholds lie
/// inside the live ones, so the verdict is the live one or `inconclusive`: a part of the
/// record, or the record renamed, that is judged live never gets the opposite verdict.
pub fn hold_on_held_pv(pv: Option<&[f64]>, mut det: Detection) -> Detection {
    let Some(h) = pv.and_then(datasets::held::held_period) else {
        return det;
    };
    let needed = match det.verdict {
        Verdict::Stiction if det.score < HELD_STICTION_AT => {
            format!("a score of {HELD_STICTION_AT:.2} or more")
        }
        Verdict::NoStiction if det.score > HELD_NO_STICTION_AT => {
            format!("a score of {HELD_NO_STICTION_AT:.2} or less")
        }
        _ => return det,
    };
    det.reason = format!(
        "{} ({}), but PV changes only every {} samples and repeats itself between (an analyser's cycle, or a historian's values held between the ones it stored): on such a record `{}` needs {needed} (score {:.2}); confirm on a live export",
        det.verdict.as_str(),
        det.reason,
        h.period,
        det.verdict.as_str(),
        det.score
    );
    det.verdict = Verdict::Inconclusive;
    det
}

/// Run every detection test on the record `d` (PV, OP, SP when there is one, the sampling
/// time of [`sample_time`]) for a loop that is `integrating` or not. Never panics on bad data:
/// a record the detector cannot take is [`Detected::Failed`], a record it cannot judge (flat,
/// too short, not oscillating) gets an `inconclusive` or `no-stiction` verdict with the reason.
pub fn detect_loop(d: &LoopData, integrating: bool) -> Detected {
    match try_detect(d, integrating) {
        Ok(det) => Detected::Ran(hold_on_held_pv(d.pv.as_deref(), det)),
        Err(e) => Detected::Failed(e),
    }
}

/// [`detect_loop`] with the loop kind as [`Integrating::decide`] decided it; the detection
/// carries the decision's note (what decided the kind) and, when the record did not decide
/// the kind, holds only under both kinds ([`hold_across_kinds`]).
pub fn detect_decided(d: &LoopData, kind: KindDecision) -> Detected {
    match try_detect(d, kind.integrating) {
        Ok(det) => Detected::Ran(held_and_kinds(d, kind, det)),
        Err(e) => Detected::Failed(e),
    }
}

/// The rules every command's verdict on the record `d` passes after the detector's own: the
/// kind tie ([`hold_across_kinds`]), then the held-PV thresholds ([`hold_on_held_pv`]).
fn held_and_kinds(d: &LoopData, kind: KindDecision, det: Detection) -> Detection {
    hold_on_held_pv(d.pv.as_deref(), hold_across_kinds(d, kind, det))
}

/// The detection `det` of the record `d` under the kind `kind` decided, with the decision's
/// note. When the record does not decide the kind ([`KindDecision::undecided`]: the tag's
/// letter or the default picked it), a verdict that depends on the kind is not supported by
/// the data: the detector runs again under the other kind, and a conclusive verdict stands
/// only when that reading does not give the opposite one; else the verdict is `inconclusive`
/// with the reason. (The other reading may be `inconclusive`, as a part of the record may be
/// in [`detection::score::settle`]: requiring the same verdict under both kinds was measured
/// on the training population and left out, `docs/decisions/2026-11-27-kind-tie.md`.) The
/// score, the tests and the fits stay those of the kind decided. So renaming a file (which
/// changes only the tag letter) never turns `stiction` into `no-stiction`.
pub fn hold_across_kinds(d: &LoopData, kind: KindDecision, mut det: Detection) -> Detection {
    det.integrating_by = Some(kind.note());
    let opposite = match det.verdict {
        Verdict::Stiction => Verdict::NoStiction,
        Verdict::NoStiction => Verdict::Stiction,
        Verdict::Inconclusive => return det,
    };
    if !kind.undecided() {
        return det;
    }
    let other = try_detect(d, !kind.integrating).map_or(Verdict::Inconclusive, |o| o.verdict);
    if other == opposite {
        det.reason = format!(
            "the record does not decide whether the loop is integrating, and the two readings disagree: {} as {} ({}), {} as {}",
            det.verdict.as_str(),
            crate::kind::kind_name(kind.integrating),
            det.reason,
            other.as_str(),
            crate::kind::kind_name(!kind.integrating)
        );
        det.verdict = Verdict::Inconclusive;
    }
    det
}

/// What the detection figures draw, computed once on the registration the tests judged: the
/// report draws them and computes nothing.
#[derive(Debug, Clone)]
pub struct DetectionFigures {
    /// The PV-OP ellipse of the bicoherence test; `None` without a regular oscillation.
    pub ellipse: Option<PvOpEllipse>,
    /// The OP-PV cross-correlation, or why there is none (the record cannot be judged).
    pub cross_correlation: Result<CrossCorrelation, String>,
}

/// The detector's answer on a record shown to a user (`stiction detect`, the detection
/// section of the `quantify` and `diagnose` pages and outputs), with what its figures draw.
#[derive(Debug)]
pub struct DetectionView {
    /// The answer.
    pub detected: Detected,
    /// The figures, or why there are none (the detector could not take the record).
    pub figures: Result<DetectionFigures, String>,
}

/// [`detect_decided`] with the figures of the registration the tests judged (those of the
/// kind decided).
pub fn detect_view(d: &LoopData, kind: KindDecision) -> DetectionView {
    match registration(d, kind.integrating) {
        Ok(reg) => {
            let det = held_and_kinds(d, kind, detection::detect(&reg));
            DetectionView {
                detected: Detected::Ran(det),
                figures: Ok(figures_of(&reg)),
            }
        }
        Err(e) => DetectionView {
            figures: Err(e.to_string()),
            detected: Detected::Failed(e),
        },
    }
}

/// The detection figures of the record `d` for a loop that is `integrating` or not, or why
/// there are none.
pub fn detection_figures(d: &LoopData, integrating: bool) -> Result<DetectionFigures, String> {
    registration(d, integrating)
        .map(|reg| figures_of(&reg))
        .map_err(|e| e.to_string())
}

fn figures_of(reg: &detection::Registration<'_>) -> DetectionFigures {
    let cross_correlation = detection::figures::cross_correlation(reg).ok_or_else(|| {
        reg.check().err().map_or_else(
            || "the record cannot be judged".to_string(),
            |e| e.to_string(),
        )
    });
    DetectionFigures {
        ellipse: detection::figures::pv_op_ellipse(reg),
        cross_correlation,
    }
}

/// [`detect_view`] on the record of `file` (`None` for a made-up record, e.g. an example),
/// integrating as `integrating` decides from the file's valve tag (the file name up to the
/// first `_`), as `trend` and `batch` do.
pub fn detect_file(d: &LoopData, file: Option<&Path>, integrating: Integrating) -> DetectionView {
    let valve = file
        .map(|f| datasets::parse_registration_name(&file_name(f)).valve)
        .unwrap_or_default();
    detect_view(d, integrating.decide(&valve, Some(d)))
}

fn try_detect(d: &LoopData, integrating: bool) -> Result<Detection, DetectError> {
    Ok(detection::detect(&registration(d, integrating)?))
}

/// The detection registration [`detect_loop`] judges the record `d` on: PV, OP, SP when there
/// is one, the sampling time of [`sample_time`], `integrating` or not (and the figures of
/// [`detect_view`]).
pub fn registration(
    d: &LoopData,
    integrating: bool,
) -> Result<detection::Registration<'_>, DetectError> {
    let pv = d.require_pv()?;
    let mut reg = detection::Registration::new(pv, &d.op, sample_time(d))?.integrating(integrating);
    if let Some(sp) = d.sp.as_deref() {
        reg = reg.with_sp(sp)?;
    }
    Ok(reg)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(pv: Vec<f64>, op: Vec<f64>, t: Option<Vec<f64>>) -> LoopData {
        LoopData {
            source: "x".into(),
            start: None,
            t,
            sp: None,
            pv: Some(pv),
            op,
            mv: None,
            notes: Vec::new(),
        }
    }

    #[test]
    fn sample_time_is_the_median_step_else_one_second() {
        let d = record(vec![0.0; 4], vec![0.0; 4], Some(vec![0.0, 5.0, 10.0, 16.0]));
        assert_eq!(sample_time(&d), 5.0);
        let d = record(vec![0.0; 4], vec![0.0; 4], None);
        assert_eq!(sample_time(&d), 1.0);
        let d = record(vec![0.0; 3], vec![0.0; 3], Some(vec![3.0, 3.0, 3.0]));
        assert_eq!(sample_time(&d), 1.0);
    }

    #[test]
    fn a_flat_record_is_inconclusive_with_the_reason() {
        let d = record(vec![50.0; 400], vec![30.0; 400], None);
        let det = detect_loop(&d, false);
        assert_eq!(det.verdict(), Verdict::Inconclusive);
        assert!(det.score().is_some());
        assert!(det.reason().contains("flat"), "{}", det.reason());
    }

    #[test]
    fn a_record_the_detector_cannot_take_is_an_inconclusive_failure() {
        let d = record(vec![50.0; 400], vec![30.0; 399], None);
        let det = detect_loop(&d, false);
        assert!(matches!(det, Detected::Failed(DetectError::Detection(_))));
        assert_eq!(det.verdict(), Verdict::Inconclusive);
        assert_eq!(det.score(), None);
        assert!(
            det.reason().contains("different lengths"),
            "{}",
            det.reason()
        );
        let mut no_pv = record(vec![], vec![30.0; 400], None);
        no_pv.pv = None;
        assert!(matches!(
            detect_loop(&no_pv, false),
            Detected::Failed(DetectError::Data(_))
        ));
    }

    /// A detection with `verdict` at `score` (no tests).
    fn said(verdict: Verdict, score: f64) -> Detection {
        Detection {
            score,
            verdict,
            reason: "the record's evidence".into(),
            oscillating: false,
            period_s: None,
            integrating: false,
            integrating_by: None,
            tests: Vec::new(),
        }
    }

    /// On a PV held between updates, a conclusive verdict stands only beyond the held
    /// thresholds; on a live PV, and for `inconclusive`, the detection is unchanged.
    #[test]
    fn a_verdict_on_a_held_pv_needs_a_stronger_score() {
        let live: Vec<f64> = (0..600).map(|t| (t as f64 * 0.37).sin()).collect();
        let held: Vec<f64> = (0..600).map(|t| live[t - t % 5]).collect();
        let cases = [
            (Verdict::Stiction, 0.7, Verdict::Inconclusive),
            (Verdict::Stiction, HELD_STICTION_AT, Verdict::Stiction),
            (Verdict::NoStiction, 0.3, Verdict::Inconclusive),
            (
                Verdict::NoStiction,
                HELD_NO_STICTION_AT,
                Verdict::NoStiction,
            ),
            (Verdict::Inconclusive, 0.3, Verdict::Inconclusive),
        ];
        for (verdict, score, on_held) in cases {
            let d = hold_on_held_pv(Some(&held), said(verdict, score));
            assert_eq!(d.verdict, on_held, "{verdict} at {score}: {}", d.reason);
            if on_held != verdict {
                assert!(d.reason.contains("every 5 samples"), "{}", d.reason);
                assert!(d.reason.contains("the record's evidence"), "{}", d.reason);
            }
            assert_eq!(d.score, score);
            assert_eq!(
                hold_on_held_pv(Some(&live), said(verdict, score)),
                said(verdict, score)
            );
        }
        assert_eq!(
            hold_on_held_pv(None, said(Verdict::Stiction, 0.7)).verdict,
            Verdict::Stiction
        );
    }
}
