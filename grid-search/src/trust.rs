//! How much an estimate can be trusted, and the stiction levels the texts speak of.
//!
//! Every threshold a message, a report or a verdict uses is defined here, once:
//!
//! | constant | value | meaning |
//! |---|---|---|
//! | [`NEGLIGIBLE_S`] | 0.2 % | below it, no stiction is reported (the grid's own resolution near S = 0) |
//! | [`HARMFUL_S`] | 1 % | the level at which stiction already degrades control (the paper, §1) |
//! | [`MAINTENANCE_S`] | 1.6 % | `stiction trend`'s default maintenance threshold on a valve's level |
//! | [`WEAK_FIT`] | 50 % | a validation F_PV below it explains too little of PV to support an estimate |
//! | [`FIT_DISAGREEMENT`] | 20 points | identification and validation F_PV further apart than this disagree |
//! | [`MOSTLY_SKIPPED`] | 1/2 | more than this share of grid nodes skipped leaves the surface thin |
//!
//! Why these numbers: 0.2 and 1 % come from the physics the paper states (S ≈ 1 % already
//! hurts; below a few tenths the valve's effect is within the grid step of a typical 0.1 %
//! lattice). 1.6 % is `trend`'s maintenance default, chosen on the shared plant data as a
//! level clearly above the harmful one (docs/PLANT_DATA.md), and can be changed with
//! `--threshold`. The three doubt thresholds are deliberately coarse: they flag estimates a
//! person should look at, they never change the estimate.
//!
//! A [`Doubt`] is one reason to distrust an estimate; [`Quantification::doubts`] lists them
//! and [`assess`] turns S and the doubts into a [`Verdict`] that says "the valve sticks" only
//! when the evidence does.
//!
//! [`Quantification::doubts`]: crate::Quantification::doubts

use std::fmt;

/// S (% of valve span) at or below which no stiction is reported.
pub const NEGLIGIBLE_S: f64 = 0.2;
/// S (% of valve span) from which stiction degrades control.
pub const HARMFUL_S: f64 = 1.0;
/// Default maintenance threshold on a valve's level of S (% of valve span), `stiction trend`.
pub const MAINTENANCE_S: f64 = 1.6;
/// Validation F_PV (%) below which the fit is weak.
pub const WEAK_FIT: f64 = 50.0;
/// Identification and validation F_PV (points) further apart than this disagree.
pub const FIT_DISAGREEMENT: f64 = 20.0;
/// Share of skipped grid nodes above which the surface is thin.
pub const MOSTLY_SKIPPED: f64 = 0.5;
/// Share of the OP span seen at which the region of S is said to reach it
/// ([`Doubt::SAtSpan`]): by Kano's model the valve then moves only where OP reverses by more
/// than S, which a record whose OP travels less than S / 0.8 shows a few times at most.
pub const AT_SPAN: f64 = 0.8;

/// One reason to distrust an estimate of S and J.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Doubt {
    /// A valve without stiction (S = J = 0) lies inside the likelihood-ratio region.
    NoEvidence,
    /// The region of S is wide.
    SPoorlyDetermined {
        /// Region of S.
        lo: f64,
        /// Region of S.
        hi: f64,
        /// OP span.
        span: f64,
    },
    /// The region of J is wide (does not weaken S).
    JPoorlyDetermined {
        /// Region of J.
        lo: f64,
        /// Region of J.
        hi: f64,
    },
    /// In.3 could not find where the valve's initial state washes out and fell back to In.2.
    InitFellBack,
    /// The identification and validation fits disagree.
    FitsDisagree {
        /// F_PV on identification data.
        id: f64,
        /// F_PV on validation data.
        val: f64,
    },
    /// Most grid nodes were skipped.
    MostlySkipped {
        /// Nodes skipped.
        skipped: usize,
        /// Nodes evaluated.
        total: usize,
    },
    /// The validation fit is weak.
    WeakFit {
        /// F_PV on validation data.
        val: f64,
    },
    /// The region of S reaches the OP span seen: OP never moved much more than the band, so the
    /// record cannot show a wider one (S is a lower bound; does not weaken "the valve sticks").
    SAtSpan {
        /// Upper end of the region of S.
        hi: f64,
        /// OP span seen.
        span: f64,
    },
    /// PV looks read back from a historian's compressed storage (straight segments between
    /// kept points, `datasets::compression`): one-step fits on interpolated values are biased.
    CompressedPv {
        /// Share of the samples on straight sloped segments.
        share: f64,
        /// Number of segments.
        segments: usize,
    },
}

impl Doubt {
    /// Whether this doubt undermines the statement "the valve sticks" (J's width does not).
    pub fn weakens_s(&self) -> bool {
        !matches!(
            self,
            Doubt::JPoorlyDetermined { .. } | Doubt::SAtSpan { .. }
        )
    }

    /// A short phrase for a verdict sentence.
    pub fn short(&self) -> String {
        match self {
            Doubt::NoEvidence => "S = 0 is inside the region".into(),
            Doubt::SPoorlyDetermined { lo, hi, .. } => {
                format!("S is poorly determined ({lo:.2}-{hi:.2} %)")
            }
            Doubt::JPoorlyDetermined { lo, hi } => {
                format!("J is poorly determined ({lo:.2}-{hi:.2} %)")
            }
            Doubt::InitFellBack => "the valve's initial state never washed out".into(),
            Doubt::FitsDisagree { id, val } => {
                format!("identification and validation fits disagree ({id:.1} vs {val:.1} %)")
            }
            Doubt::MostlySkipped { skipped, total } => {
                format!("{skipped} of {total} grid nodes were skipped")
            }
            Doubt::WeakFit { val } => format!("the fit is weak (validation F_PV {val:.1} %)"),
            Doubt::SAtSpan { hi, span } => {
                format!("S reaches the OP span ({hi:.2} of {span:.2}): a lower bound")
            }
            Doubt::CompressedPv { share, .. } => format!(
                "PV looks interpolated from compressed storage ({:.0} % on straight segments)",
                100.0 * share
            ),
        }
    }
}

impl fmt::Display for Doubt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Doubt::NoEvidence => f.write_str(
                "a valve without stiction (S = J = 0) explains PV as well (it is inside the region): no evidence of stiction",
            ),
            Doubt::SPoorlyDetermined { lo, hi, span } => write!(
                f,
                "S is poorly determined: the region spans {lo:.2} to {hi:.2} % (OP span {span:.2} %)"
            ),
            Doubt::JPoorlyDetermined { lo, hi } => {
                write!(f, "J is poorly determined: the region spans {lo:.2} to {hi:.2} %")
            }
            Doubt::InitFellBack => f.write_str(
                "the valve model's initial state never washed out (In.3 fell back to In.2)",
            ),
            Doubt::FitsDisagree { id, val } => write!(
                f,
                "the identification and validation fits disagree (F_PV {id:.1} % vs {val:.1} %, more than {FIT_DISAGREEMENT} points apart): the model does not describe the whole record alike"
            ),
            Doubt::MostlySkipped { skipped, total } => write!(
                f,
                "{skipped} of {total} grid nodes were skipped (valve hardly moving, singular or unstable fits): the estimate rests on the rest"
            ),
            Doubt::WeakFit { val } => write!(
                f,
                "the fit is weak: validation F_PV {val:.1} % (below {WEAK_FIT} %) leaves most of PV unexplained"
            ),
            Doubt::SAtSpan { hi, span } => write!(
                f,
                "S reaches {hi:.2} while OP moved over {span:.2} only: the record cannot show a wider band than OP travelled, so S is a lower bound; a registration with more OP movement (a set-point step, or a manual OP step, of a few times S) would bound it"
            ),
            Doubt::CompressedPv { share, segments } => write!(
                f,
                "PV looks read back from a historian's compressed storage ({:.0} % of the samples on {segments} straight segments between kept points): the one-step fits see interpolated values, which they predict too well, and S can be far off (less so with `larx`, ARX at the archive's typical distance between kept points, which `stiction diagnose` fits on such data); get the raw values or the archive's kept points if you can",
                100.0 * share
            ),
        }
    }
}

/// How much stiction an S means, by the constants above.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// S <= [`NEGLIGIBLE_S`].
    Negligible,
    /// [`NEGLIGIBLE_S`] < S < [`HARMFUL_S`].
    Slight,
    /// S >= [`HARMFUL_S`].
    Harmful,
}

impl Severity {
    /// The severity of `s` (% of valve span).
    pub fn of(s: f64) -> Severity {
        if s <= NEGLIGIBLE_S {
            Severity::Negligible
        } else if s < HARMFUL_S {
            Severity::Slight
        } else {
            Severity::Harmful
        }
    }
}

/// What a single estimate says about the valve, and how far to trust it.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// Severity of the estimated S.
    pub severity: Severity,
    /// The doubts that weaken the statement about S (empty: the estimate can be trusted).
    pub doubts: Vec<Doubt>,
}

impl Verdict {
    /// True when the estimate says the valve sticks and nothing undermines it.
    pub fn sticks(&self) -> bool {
        self.severity != Severity::Negligible && self.doubts.is_empty()
    }
}

/// The verdict on an estimate S with its doubts.
pub fn assess(s: f64, doubts: &[Doubt]) -> Verdict {
    Verdict {
        severity: Severity::of(s),
        doubts: doubts.iter().filter(|d| d.weakens_s()).cloned().collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn severity_boundaries() {
        assert_eq!(Severity::of(0.0), Severity::Negligible);
        assert_eq!(Severity::of(NEGLIGIBLE_S), Severity::Negligible);
        assert_eq!(Severity::of(0.51), Severity::Slight);
        assert_eq!(Severity::of(HARMFUL_S), Severity::Harmful);
        assert_eq!(Severity::of(MAINTENANCE_S), Severity::Harmful);
    }

    #[test]
    fn a_doubt_on_j_does_not_weaken_s() {
        let v = assess(2.0, &[Doubt::JPoorlyDetermined { lo: 0.0, hi: 2.0 }]);
        assert!(v.sticks());
        let v = assess(2.0, &[Doubt::WeakFit { val: 10.0 }]);
        assert!(!v.sticks());
        assert!(!assess(0.1, &[]).sticks());
    }
}
