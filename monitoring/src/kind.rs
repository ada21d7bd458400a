//! Which loops are integrating: decided from a registration file's valve tag (level tags,
//! ISA-5.1) or from the record itself ([`Integrating::decide`]), and the file's base name the
//! tag is read from. Shared by the registrations and the detector.

use std::path::Path;

use datasets::LoopData;
use serde::{Deserialize, Serialize};

/// The base name of a path, for rows and messages.
pub fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

/// Which loops are integrating (identified from MV to ΔPV).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Integrating {
    /// Decided from the record ([`Integrating::decide`]); a level tag (letter `L`) breaks a
    /// tie.
    #[default]
    Auto,
    /// Every loop is integrating.
    Yes,
    /// No loop is integrating.
    No,
}

/// What decided whether a loop is integrating.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum KindSource {
    /// `--integrating yes` or `no`.
    Flag,
    /// The record: how PV answers OP ([`detection::kind::evidence`]).
    Data,
    /// The record did not decide; the tag's letter `L` did.
    Tag,
    /// Neither the record nor a level tag: self-regulating.
    Default,
}

/// Whether a loop is integrating, and what decided it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KindDecision {
    /// Treated as integrating.
    pub integrating: bool,
    /// What decided.
    pub by: KindSource,
    /// `ln(RSS_self / RSS_integrating)` of the record, when computed.
    pub log_ratio: Option<f64>,
}

/// The loop kind's name as every note prints it.
pub fn kind_name(integrating: bool) -> &'static str {
    if integrating {
        "integrating"
    } else {
        "self-regulating"
    }
}

impl KindDecision {
    /// One line for people: the kind and what decided it.
    pub fn note(&self) -> String {
        let kind = kind_name(self.integrating);
        let ratio = self.log_ratio.map_or(String::new(), |r| {
            format!(", ln(RSS self-regulating / RSS integrating) = {r:.2}")
        });
        match self.by {
            KindSource::Flag => format!("{kind}: as --integrating says"),
            KindSource::Data => format!(
                "{kind}: decided by the record (PV's {} follows OP{ratio})",
                if self.integrating { "rate" } else { "level" }
            ),
            KindSource::Tag => format!(
                "{kind}: the record does not decide{ratio}; the tag's letter L decided for S and the fits, and a verdict stands only when the other kind does not give the opposite"
            ),
            KindSource::Default => format!(
                "{kind}: the record does not decide{ratio} and the tag is not a level's; the default for S and the fits, and a verdict stands only when the other kind does not give the opposite"
            ),
        }
    }

    /// Whether the record left the kind undecided (the tag's letter or the default picked it
    /// under `--integrating auto`): a verdict that depends on the kind is then not supported
    /// by the data, so the detector's verdict must hold under both kinds
    /// ([`crate::detect`]).
    pub fn undecided(&self) -> bool {
        matches!(self.by, KindSource::Tag | KindSource::Default)
    }
}

impl Integrating {
    /// Whether the loop of `valve` with the record `d` (when read) is integrating: the one rule
    /// of every command. `yes` and `no` decide; `auto` lets the record decide from how PV
    /// answers OP ([`detection::kind::evidence`]: whether PV's rate or PV's level follows OP),
    /// and only on a tie (or without a record) the tag's letter `L` ([`is_level_tag`]), else
    /// self-regulating.
    pub fn decide(self, valve: &str, d: Option<&LoopData>) -> KindDecision {
        let flag = |integrating| KindDecision {
            integrating,
            by: KindSource::Flag,
            log_ratio: None,
        };
        match self {
            Integrating::Yes => flag(true),
            Integrating::No => flag(false),
            Integrating::Auto => {
                let evidence = d.and_then(|d| {
                    d.pv.as_deref()
                        .and_then(|pv| detection::kind::evidence(pv, &d.op))
                });
                let log_ratio = evidence.map(|e| e.log_ratio);
                match evidence.and_then(|e| e.integrating) {
                    Some(integrating) => KindDecision {
                        integrating,
                        by: KindSource::Data,
                        log_ratio,
                    },
                    None if is_level_tag(valve) => KindDecision {
                        integrating: true,
                        by: KindSource::Tag,
                        log_ratio,
                    },
                    None => KindDecision {
                        integrating: false,
                        by: KindSource::Default,
                        log_ratio,
                    },
                }
            }
        }
    }
}

/// The ISA-5.1 letters that follow a tag's first letter in a level loop's tag: modifiers
/// (`D` differential, `Q` totalise, `H`/`L` high/low, `S` safety) and readout or output
/// functions (`A` alarm, `C` control, `E` element, `G` glass, `I` indicate, `K` control
/// station, `R` record, `S` switch, `T` transmit, `V` valve, `X` unclassified, `Y` relay or
/// compute, `Z` driver). Letters a level tag does not use (`O` orifice, `P` test point, and
/// the user's choices) keep words such as `loop`, `line` and `load` from reading as tags.
const TAG_FUNCTION_LETTERS: &str = "ACDEGHIKLQRSTVXYZ";

/// Whether `valve` reads as an ISA-5.1 tag of a level loop: a tag has a number (`LIC101`,
/// `2111LIC31102B`) and its letters are a run of two to four, the first `L` and the others
/// function letters (`ACDEGHIKLQRSTVXYZ`). A name that is not a tag (`loop001`,
/// `line_a7`, `level`) is not a level loop: the default, self-regulating, is then kept rather
/// than guessed from a word's first letter.
pub fn is_level_tag(valve: &str) -> bool {
    if !valve.chars().any(|c| c.is_ascii_digit()) {
        return false;
    }
    let letters: String = valve
        .chars()
        .skip_while(|c| !c.is_ascii_alphabetic())
        .take_while(|c| c.is_ascii_alphabetic())
        .map(|c| c.to_ascii_uppercase())
        .collect();
    (2..=4).contains(&letters.len())
        && letters.starts_with('L')
        && letters[1..]
            .chars()
            .all(|c| TAG_FUNCTION_LETTERS.contains(c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_tags_are_integrating() {
        // without a record, the tag decides under `auto`
        assert!(Integrating::Auto.decide("2111LIC31102B", None).integrating);
        assert_eq!(
            Integrating::Auto.decide("2111LIC31102B", None).by,
            KindSource::Tag
        );
        assert!(!Integrating::Auto.decide("2411FIC20102", None).integrating);
        assert!(Integrating::Yes.decide("2411FIC20102", None).integrating);
        assert!(!Integrating::No.decide("LIC1", None).integrating);
    }

    #[test]
    fn level_tags_and_words() {
        for tag in [
            "2111LIC31102B",
            "LIC101",
            "LT-12",
            "lic7",
            "LCV-3",
            "LDIC20",
            "LSH_4",
        ] {
            assert!(is_level_tag(tag), "{tag}");
        }
        for name in [
            "loop",
            "level",
            "line_a",
            "2411FIC20102",
            "FIC7",
            "L1",
            "LOOPING1",
            "loop001",
            "loop_17",
            "line_a7",
            "load3",
            "log2",
        ] {
            assert!(!is_level_tag(name), "{name}");
        }
    }
}
