//! OP units: which valve span OP is expressed in, and OP rescaled to % of that span.
//!
//! Stiction S and J are "% of valve span" (the paper, the CLI contract). Historians log OP
//! as % (0-100), as a fraction (0-1), or as raw counts of an analogue output (0-4095,
//! 0-16383, 0-27648, 0-32767, 0-65535, ...). The search itself works in OP units; so that S
//! and J — and every decision made from them (negligible stiction, the diagnosis) — mean
//! the same whatever the units, the reader rescales OP to % of the valve span and says so in
//! [`crate::LoopData::notes`].
//!
//! Decisions:
//! * "Span" is the **valve span** (the full range OP can command, 0-100 %), not the OP range
//!   seen in the record (which is what the grid covers). The valve span cannot be measured
//!   from the data, only assumed from the range seen; the assumption is always named in the
//!   notes and `--op-range LO,HI` ([`OpRange::Given`]) states it.
//! * Fraction: every OP in [-0.05, 1.05] → valve span 0-1, OP × 100 (the decimal point of
//!   its shortest digits moved two places: `0.29` is 29, not 28.999999999999996).
//! * Percent: every OP in [-10, 110] (controllers over-range by a few %) → unchanged.
//! * Counts: every OP an integer in [0, 65535] and above 110 → the smallest of the usual
//!   full scales ([`FULL_SCALES`]) that holds the largest OP; OP × 100 / full scale.
//! * Anything else (values beyond 110 that are not integer counts, or negative beyond -10):
//!   the valve span is unknown; the range seen stands for it (OP rescaled to % of it), so
//!   that every command and the diagnosis' thresholds work in % of one span whatever OP's
//!   units, and the note says so and how to state the span.
//! * A given span must hold OP (up to 10 % of the span beyond it, a controller's over-range)
//!   and OP must move over at least a millionth of it; otherwise it is refused, naming
//!   `--op-range`.
//! * OP within 3.5-20.5 is read as % but gets a note: it may be a 4-20 mA signal.
//! * A measured MV column is taken to be in OP's units and rescaled with it.

/// The usual full scales of analogue outputs in counts (8, 10, 12, 14 bit, Siemens S7 27648,
/// signed and unsigned 16 bit).
pub const FULL_SCALES: [f64; 7] = [255.0, 1023.0, 4095.0, 16383.0, 27648.0, 32767.0, 65535.0];

/// The words of the units note when OP's valve span is unknown (the range seen stands for
/// it): [`span_unknown`] finds them.
pub const SPAN_UNKNOWN: &str = "the valve span is unknown";

/// Whether the reader's `notes` say OP's valve span is unknown: S and J are then in % of the
/// OP range seen, not of the valve's span, and no threshold in % of span applies to them.
pub fn span_unknown(notes: &[crate::Note]) -> bool {
    notes
        .iter()
        .any(|n| n.kind == crate::NoteKind::Units && n.text.contains(SPAN_UNKNOWN))
}

/// How the reader finds OP's valve span.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OpRange {
    /// Assume it from the range seen (see the module documentation).
    #[default]
    Detect,
    /// OP is in these units: `lo` is the closed valve, `hi` the fully open one
    /// (`--op-range LO,HI`).
    Given(f64, f64),
    /// Keep OP as it is, without a note (callers that know OP is in %).
    Keep,
}

// `Given` is checked finite with lo < hi before use; equality is never asked of NaN.
impl Eq for OpRange {}

impl OpRange {
    /// The span `lo` (closed valve) to `hi` (fully open) in OP's units, checked finite with
    /// `lo < hi`; the error says what is expected. The CLI's `--op-range` and the Python
    /// package's `op_range` both end here.
    pub fn given(lo: f64, hi: f64) -> Result<OpRange, String> {
        if lo.is_finite() && hi.is_finite() && lo < hi {
            Ok(OpRange::Given(lo, hi))
        } else {
            Err(
                "expected finite LO < HI (the closed and the fully open valve in OP's units)"
                    .into(),
            )
        }
    }

    /// [`OpRange::given`] from the text `LO,HI`.
    pub fn parse(s: &str) -> Result<OpRange, String> {
        let number = |t: &str| t.trim().parse::<f64>().ok();
        let pair = s
            .split_once(',')
            .and_then(|(a, b)| number(a).zip(number(b)));
        match pair.and_then(|(lo, hi)| OpRange::given(lo, hi).ok()) {
            Some(range) => Ok(range),
            None => Err(format!(
                "expected LO,HI with LO < HI (the closed and the fully open valve in OP's units), got {s:?}"
            )),
        }
    }
}

/// The units assumed for OP and the affine map to % of valve span.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct OpUnits {
    /// Valve span `(lo, hi)` in OP's units; `None`: leave OP as it is.
    pub span: Option<(f64, f64)>,
    /// What was assumed, for the notes (`None`: OP already in %, nothing to say).
    pub note: Option<String>,
}

impl OpUnits {
    /// Map `x` (OP units) to % of valve span.
    pub fn to_percent(&self, x: f64) -> f64 {
        match self.span {
            // a fraction: its decimal point moved two places, so a file holding OP / 100 in
            // decimals gives the % file's OP bit for bit
            Some((lo, hi)) if lo == 0.0 && hi == 1.0 => percent_of_fraction(x),
            // Kept exact for the % case; `x * 100 / (hi - lo)` keeps counts consistent with a
            // file holding `counts * 100 / full_scale`.
            Some((lo, hi)) if !(lo == 0.0 && hi == 100.0) => (x - lo) * 100.0 / (hi - lo),
            _ => x,
        }
    }
}

/// `100 x` as the decimal number `x` prints as (its shortest round-trip digits) with the
/// point moved two places, rounded once: `0.29` gives 29 exactly, where `0.29 * 100.0` is
/// 28.999999999999996. A record exported as a fraction (`29` written `0.29`) is read back
/// to the same % it was written from, so a grid node that lands on OP's quantisation step
/// meets the same OP either way (a fuzz finding, seed 57).
fn percent_of_fraction(x: f64) -> f64 {
    if !x.is_finite() {
        return x * 100.0;
    }
    let mut buf = ryu::Buffer::new();
    let digits = buf.format_finite(x);
    let shifted = match digits.split_once(['e', 'E']) {
        Some((mantissa, exp)) => exp
            .parse::<i32>()
            .ok()
            .map(|e| format!("{mantissa}e{}", e + 2)),
        None => Some(format!("{digits}e2")),
    };
    shifted
        .and_then(|t| t.parse::<f64>().ok())
        .unwrap_or(x * 100.0)
}

/// `x` to 5 significant digits, without trailing zeros (notes quote numbers people read;
/// `(x * 1e4).round() / 1e4` printed 300 digits for OP near 1e300).
pub fn sig(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let e = x.abs().log10().floor() as i32;
    if (-4..6).contains(&e) {
        let decimals = (4 - e).max(0) as usize;
        let t = format!("{x:.decimals$}");
        let t = if t.contains('.') {
            t.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            t
        };
        if t == "-0" {
            "0".into()
        } else {
            t
        }
    } else {
        let t = format!("{x:.4e}");
        match t.split_once('e') {
            Some((m, e)) if m.contains('.') => {
                format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
            }
            _ => t,
        }
    }
}

/// Decide OP's units from `op` (finite values) and `range`; `Err` for an invalid given range.
pub(crate) fn op_units(op: &[f64], range: OpRange) -> Result<OpUnits, String> {
    let (lo, hi) = op
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    match range {
        OpRange::Keep => Ok(OpUnits {
            span: None,
            note: None,
        }),
        OpRange::Given(a, b) => {
            if !(a.is_finite() && b.is_finite() && a < b) {
                return Err(format!(
                    "OP range {a},{b}: expected LO,HI with LO < HI (the closed and the fully open valve)"
                ));
            }
            // OP beyond the stated valve span by more than a controller's over-range (10 % of
            // the span) is a span that does not hold OP: S and J would be scaled by a wrong
            // factor (`--op-range 0,10` on OP in 50-60 gave S = 40 %).
            let margin = 0.1 * (b - a);
            if lo.is_finite() && hi.is_finite() && (lo < a - margin || hi > b + margin) {
                return Err(format!(
                    "--op-range {},{} does not contain OP, which ranges {}-{}: give the closed and the fully open valve in OP's units",
                    sig(a),
                    sig(b),
                    sig(lo),
                    sig(hi)
                ));
            }
            if lo.is_finite() && hi.is_finite() && hi - lo < 1e-6 * (b - a) {
                return Err(format!(
                    "--op-range {},{}: OP ({}-{}) moves over less than a millionth of it: give the closed and the fully open valve in OP's units",
                    sig(a),
                    sig(b),
                    sig(lo),
                    sig(hi)
                ));
            }
            let note = (!(a == 0.0 && b == 100.0)).then(|| {
                format!(
                    "OP in {}-{} (as given): rescaled to % of valve span",
                    sig(a),
                    sig(b)
                )
            });
            Ok(OpUnits {
                span: Some((a, b)),
                note,
            })
        }
        OpRange::Detect => {
            if !(lo.is_finite() && hi.is_finite()) {
                return Ok(OpUnits {
                    span: None,
                    note: None,
                });
            }
            if lo >= -0.05 && hi <= 1.05 {
                return Ok(OpUnits {
                    span: Some((0.0, 1.0)),
                    note: Some(format!(
                        "OP ranges {}-{}: taken as a fraction of valve span (0-1) and rescaled to %; give --op-range to state otherwise",
                        sig(lo),
                        sig(hi)
                    )),
                });
            }
            if lo >= -10.0 && hi <= 110.0 {
                // A 4-20 mA signal logged as such also lies within 0-100; read as % it makes S
                // and J 6.25 times too small. It cannot be told from % for sure: a note.
                let milliamps = lo >= 3.5 && hi <= 20.5 && hi - lo >= 4.0;
                return Ok(OpUnits {
                    span: Some((0.0, 100.0)),
                    note: milliamps.then(|| format!(
                        "OP ranges {}-{}, within 4-20: read as % of valve span; if it is a 4-20 mA signal, give --op-range 4,20",
                        sig(lo),
                        sig(hi)
                    )),
                });
            }
            let integral = op.iter().all(|v| v.fract() == 0.0);
            if integral && lo >= 0.0 {
                if let Some(&fs) = FULL_SCALES.iter().find(|&&fs| hi <= fs) {
                    return Ok(OpUnits {
                        span: Some((0.0, fs)),
                        note: Some(format!(
                            "OP ranges {}-{} in integer steps: taken as counts of a 0-{fs} output and rescaled to % of valve span; give --op-range to state otherwise",
                            sig(lo),
                            sig(hi)
                        )),
                    });
                }
            }
            // The valve span is unknown: the range seen stands for it, so that S and J, the
            // detection's stiction bands and the diagnosis' thresholds are all in % of one span
            // (kept in OP's units, detect searched bands in % steps of a span of 1e9 and the
            // diagnosis printed "S = 39949948.12 %").
            Ok(OpUnits {
                span: Some((lo, hi)),
                note: Some(format!(
                    "OP ranges {}-{}, neither 0-1, 0-100 nor integer counts: {SPAN_UNKNOWN}, so S and J are in % of the OP range seen ({}-{}); give --op-range LO,HI to state the valve span",
                    sig(lo),
                    sig(hi),
                    sig(lo),
                    sig(hi)
                )),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn span_of(op: &[f64]) -> Option<(f64, f64)> {
        op_units(op, OpRange::Detect).unwrap().span
    }

    #[test]
    fn op_range_text_and_pair_are_checked_alike() {
        assert_eq!(OpRange::parse(" 4, 20"), Ok(OpRange::Given(4.0, 20.0)));
        assert_eq!(OpRange::parse("-1,1"), Ok(OpRange::Given(-1.0, 1.0)));
        for bad in ["5,1", "3,3", "a,1", "1", "1,inf", "nan,2", ""] {
            assert!(OpRange::parse(bad).is_err(), "{bad}");
        }
        assert!(OpRange::given(1.0, f64::NAN).is_err());
        assert!(OpRange::given(2.0, 1.0).is_err());
        assert_eq!(OpRange::given(0.0, 1.0), Ok(OpRange::Given(0.0, 1.0)));
        let gaps = |s: &str| s.parse::<crate::GapPolicy>();
        assert_eq!(gaps("hold"), Ok(crate::GapPolicy::FillHold));
        assert_eq!(gaps("drop"), Ok(crate::GapPolicy::DropGaps));
        assert_eq!(gaps("refuse"), Ok(crate::GapPolicy::Refuse));
        assert!(gaps("Hold").is_err());
    }

    #[test]
    fn detects_fraction_percent_counts_and_unknown() {
        assert_eq!(span_of(&[0.2, 0.7]), Some((0.0, 1.0)));
        assert_eq!(span_of(&[20.0, 70.0]), Some((0.0, 100.0)));
        assert_eq!(span_of(&[0.78, 6.64]), Some((0.0, 100.0)));
        assert_eq!(span_of(&[-3.0, 104.0]), Some((0.0, 100.0)));
        assert_eq!(span_of(&[3277.0, 11468.0]), Some((0.0, 16383.0)));
        assert_eq!(span_of(&[200.0, 900.0]), Some((0.0, 1023.0)));
        assert_eq!(span_of(&[389.5, 395.5]), Some((389.5, 395.5)));
        assert_eq!(span_of(&[2e10, 6e10]), Some((2e10, 6e10)));
        assert_eq!(span_of(&[-50.0, 50.0]), Some((-50.0, 50.0)));
    }

    #[test]
    fn numbers_in_notes_have_five_significant_digits() {
        assert_eq!(sig(1.7e296), "1.7e296");
        assert_eq!(sig(-1.23456789e-7), "-1.2346e-7");
        assert_eq!(sig(389.5), "389.5");
        assert_eq!(sig(0.123456), "0.12346");
        assert_eq!(sig(16383.0), "16383");
        assert_eq!(sig(0.0), "0");
    }

    #[test]
    fn fractions_become_the_percent_they_print_as() {
        let u = op_units(&[0.14, 0.87], OpRange::Detect).unwrap();
        assert_eq!(u.span, Some((0.0, 1.0)));
        for (fraction, percent) in [
            (0.15, 15.0),
            (0.29, 29.0),
            (1e-7, 1e-5),
            (0.0, 0.0),
            (-0.03, -3.0),
            (1.0, 100.0),
            (0.123456789, 12.3456789),
        ] {
            assert_eq!(u.to_percent(fraction), percent, "{fraction}");
        }
        // every % value with two decimals, exported as the fraction it prints as (its decimal
        // point moved), comes back bit for bit; multiplying by 100 missed many of them
        let mut products_off = 0;
        for k in -500..=10500 {
            let pct = f64::from(k) / 100.0;
            let fraction: f64 = format!("{pct}e-2").parse().unwrap();
            assert_eq!(u.to_percent(fraction), pct, "{pct} -> {fraction}");
            products_off += usize::from(fraction * 100.0 != pct);
        }
        assert!(products_off > 1000, "{products_off}");
    }

    #[test]
    fn given_ranges_are_checked_and_used() {
        let u = op_units(&[5.0, 15.0], OpRange::Given(4.0, 20.0)).unwrap();
        for (a, b) in [(0.0, 10.0), (0.0, 1e-9), (0.0, 1e-300), (0.0, 1e300)] {
            let e = op_units(&[50.0, 60.0], OpRange::Given(a, b)).unwrap_err();
            assert!(e.starts_with("--op-range"), "{e}");
        }
        assert!(op_units(&[-2.0, 101.0], OpRange::Given(0.0, 100.0)).is_ok());
        let ma = op_units(&[4.3, 17.9], OpRange::Detect).unwrap();
        assert_eq!(op_units(&[5.0, 6.0], OpRange::Detect).unwrap().note, None);
        assert!(ma.note.unwrap().contains("--op-range 4,20"));
        assert_eq!(op_units(&[20.0, 70.0], OpRange::Detect).unwrap().note, None);
        assert_eq!(u.to_percent(12.0), 50.0);
        assert!(op_units(&[1.0], OpRange::Given(1.0, 1.0)).is_err());
        assert!(op_units(&[1.0], OpRange::Given(f64::NAN, 1.0)).is_err());
        let pct = op_units(&[5.0, 15.0], OpRange::Given(0.0, 100.0)).unwrap();
        assert_eq!(pct.note, None);
        assert_eq!(pct.to_percent(12.345), 12.345);
    }
}
