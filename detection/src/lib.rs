//! Is it the valve? Published stiction detection tests behind one plugin trait, and one
//! calibrated verdict.
//!
//! A plant engineer's first question is whether a valve sticks, before how much. This crate
//! answers it from the loop's time series only — set point SP, process variable PV, controller
//! output OP, the sampling time, and whether the process is integrating (a level) — never from
//! a file name or a label.
//!
//! * [`Registration`] holds the series and caches what every test shares (the control error,
//!   the detrended signals and the oscillation found by [`oscillation`]).
//! * [`DetectionTest`] is one published test: its statistic, its own [`Verdict`] and one line
//!   of evidence ([`TestOutcome`]). Tests register themselves with `inventory` through a
//!   [`TestEntry`], like the stiction models; [`registry`] lists them.
//! * [`run_all`] runs every registered test; a test that cannot judge the registration gives
//!   an `inconclusive` outcome with the reason.
//! * [`detect`] runs them and combines their statistics into a score in `[0, 1]` and one
//!   verdict ([`score`]: a logistic model whose coefficients come from
//!   `cargo xtask detect-calibrate`).
//!
//! ```
//! use detection::{detect, Registration, Verdict};
//! // A loop whose OP and PV never move: nothing to detect.
//! let pv = vec![50.0; 400];
//! let op = vec![30.0; 400];
//! let reg = Registration::new(&pv, &op, 1.0)?;
//! let d = detect(&reg);
//! assert_eq!(d.verdict, Verdict::Inconclusive);
//! assert!(d.reason.contains("OP is flat"));
//! # Ok::<(), detection::DetectionError>(())
//! ```
//!
//! Built-in tests (each module cites its source): [`oscillation`] (Thornhill et al. 2003),
//! [`horch`] (Horch 1999; Horch & Isaksson 2001), [`curve_fit`] (He et al. 2007),
//! [`bicoherence`] (Choudhury et al. 2004, 2006), [`shape`] (Yamashita 2006; Singhal &
//! Salsbury 2005), [`hammerstein`] (the reference paper's identification used for detection,
//! after Choudhury, Jain & Shah 2008).
//!
//! **Hook for more evidence.** A test implemented in another crate registers a [`TestEntry`]
//! the same way; [`detect`] runs it and lists its outcome. It enters the score once
//! [`score::FEATURES`] has a feature for it and `cargo xtask detect-calibrate` has re-fitted
//! [`score::WEIGHTS`]; a caller that computes such evidence itself appends its outcome and
//! calls [`combine`].

use std::sync::OnceLock;

/// The valve position's stand-in of a registration ([`Registration::valve_proxy`]).
pub(crate) struct ValveProxy<'a> {
    /// `PV` or `ΔPV`.
    pub name: &'static str,
    /// The proxy series.
    pub y: Vec<f64>,
    /// OP aligned with it.
    pub op: &'a [f64],
    /// PV aligned with it.
    pub pv: &'a [f64],
}

pub mod bicoherence;
pub mod curve_fit;
pub mod figures;
pub mod hammerstein;
pub mod horch;
pub mod kind;
pub mod logistic;
pub mod oscillation;
pub mod score;
pub mod shape;
mod signal;
#[cfg(test)]
mod testing;

pub use oscillation::Oscillation;
pub use score::{combine, detect, detect_with, Detection, Model};

/// Re-exported so that plugin crates use the same `inventory` as the registry.
pub use inventory;

/// Fewest samples a registration needs (about three periods of a fast limit cycle).
pub const MIN_SAMPLES: usize = 100;

/// OP span (1st to 99th percentile, OP's units: % of travel as the reader gives it) below
/// which a record cannot be judged ([`DetectionError::BarelyMoves`]): the smallest stiction
/// band worth finding is 0.5 % and a limit cycle's OP spans at least its S. The simulated
/// populations label such loops "cannot be judged" by the same number
/// (`datasets::simulate::population::BARELY_MOVES`).
pub const BARELY_MOVES: f64 = 0.5;

/// Fewest quantisation steps OP's span must cover to be judged: with fewer, every move of the
/// valve is one or two steps of the logging and a stick cannot be told from the rounding.
pub const MIN_OP_STEPS: f64 = 5.0;

/// Errors of the detection tests. A test that cannot judge a registration says why with one
/// of these; [`detect`] turns it into an `inconclusive` outcome carrying the sentence.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DetectionError {
    /// The series have different lengths.
    #[error("series of different lengths: PV {pv}, OP {op}, SP {sp:?}")]
    LengthMismatch {
        /// PV samples.
        pv: usize,
        /// OP samples.
        op: usize,
        /// SP samples, when given.
        sp: Option<usize>,
    },
    /// The sampling time is not a positive finite number of seconds.
    #[error("sampling time {value} s: expected a positive number of seconds")]
    InvalidSampleTime {
        /// The rejected value.
        value: f64,
    },
    /// Too few samples to judge.
    #[error("{got} samples: at least {needed} are needed")]
    TooShort {
        /// Samples needed.
        needed: usize,
        /// Samples given.
        got: usize,
    },
    /// A sample is NaN or infinite.
    #[error("{signal} sample {sample} is not a finite number")]
    NonFinite {
        /// `SP`, `PV` or `OP`.
        signal: &'static str,
        /// Index of the first bad sample.
        sample: usize,
    },
    /// A series does not move at all.
    #[error("{signal} is flat: {why}")]
    Flat {
        /// `PV` or `OP`.
        signal: &'static str,
        /// What that means for detection.
        why: &'static str,
    },
    /// PV holds one exact value over more than half of the record (not all of it): a valve
    /// stuck that long and a frozen transmitter (or a historian that stopped logging PV) give
    /// the same PV and OP, and no test can tell them apart.
    #[error("PV holds one value for {run} of {rows} samples (from sample {start}) while OP moves over {op_span:.2} meanwhile: a valve stuck that long and a frozen transmitter look the same in these data, which cannot tell which")]
    Frozen {
        /// Length of the run.
        run: usize,
        /// Samples in the record.
        rows: usize,
        /// First sample of the run (0-based).
        start: usize,
        /// OP's range over the run.
        op_span: f64,
    },
    /// OP barely moves: the valve was never asked to cross a stiction band.
    #[error("OP moves over only {span:.3} between its 1st and 99th percentiles{why}: the valve was barely asked to move, so no stiction band can show")]
    BarelyMoves {
        /// OP's 1st-to-99th-percentile span.
        span: f64,
        /// What it is small against (empty, or its quantisation).
        why: String,
    },
    /// The test needs a regular oscillation and the loop has none.
    #[error("no regular oscillation to analyse (regularity {regularity:.2})")]
    NoOscillation {
        /// Thornhill's regularity of the control error (`r > 1` is regular).
        regularity: f64,
    },
    /// The test does not apply to this kind of loop.
    #[error("{0}")]
    NotApplicable(&'static str),
    /// A registered test name is unknown.
    #[error("unknown detection test {name:?}; registered tests are {known}")]
    UnknownTest {
        /// The name asked for.
        name: String,
        /// Comma-separated registered names.
        known: String,
    },
}

/// A test's (or the combined) decision.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Verdict {
    /// The evidence points at valve stiction.
    Stiction,
    /// The evidence points away from valve stiction.
    NoStiction,
    /// The test cannot tell (or does not apply).
    Inconclusive,
}

impl Verdict {
    /// `stiction`, `no-stiction` or `inconclusive`.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Stiction => "stiction",
            Verdict::NoStiction => "no-stiction",
            Verdict::Inconclusive => "inconclusive",
        }
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What one test says about one registration.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TestOutcome {
    /// The test's registered name.
    pub name: &'static str,
    /// The test's statistic (its meaning is in the test's documentation); `None` when the test
    /// could not compute it.
    pub statistic: Option<f64>,
    /// The test's own verdict by its published rule.
    pub verdict: Verdict,
    /// One line of evidence, for people.
    pub evidence: String,
    /// Further named numbers the test computed (for the score and the report), e.g. the
    /// bicoherence test's `ngi`, `nli` and `apparent_stiction`.
    #[serde(skip)]
    pub values: Vec<(&'static str, f64)>,
}

impl TestOutcome {
    /// An outcome with no extra values.
    pub fn new(
        name: &'static str,
        statistic: Option<f64>,
        verdict: Verdict,
        evidence: impl Into<String>,
    ) -> TestOutcome {
        TestOutcome {
            name,
            statistic,
            verdict,
            evidence: evidence.into(),
            values: Vec::new(),
        }
    }

    /// The outcome of a test that could not judge: inconclusive, with the reason.
    pub fn from_error(name: &'static str, e: &DetectionError) -> TestOutcome {
        TestOutcome::new(name, None, Verdict::Inconclusive, e.to_string())
    }

    /// A named extra value.
    pub fn value(&self, key: &str) -> Option<f64> {
        self.values.iter().find(|(k, _)| *k == key).map(|(_, v)| *v)
    }
}

/// One published detection test.
///
/// A test reads a [`Registration`] (time series only) and returns its [`TestOutcome`], or a
/// [`DetectionError`] saying why it cannot judge this registration (too short, flat, no
/// oscillation, not applicable to this loop kind). It must never panic on any input.
pub trait DetectionTest: Send + Sync {
    /// The registered name (lowercase, e.g. `horch-xcorr`).
    fn name(&self) -> &'static str;
    /// Run the test.
    fn run(&self, reg: &Registration<'_>) -> Result<TestOutcome, DetectionError>;
}

/// A registered detection test: what [`detect`] runs and `stiction detect` lists.
pub struct TestEntry {
    /// Registered name, equal to the test's [`DetectionTest::name`].
    pub name: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// The publication the test follows.
    pub reference: &'static str,
    /// Position in the listing and in [`detect`]'s output (smaller first; ties by name).
    pub order: u32,
    /// The test.
    pub test: &'static dyn DetectionTest,
}

impl std::fmt::Debug for TestEntry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TestEntry")
            .field("name", &self.name)
            .field("order", &self.order)
            .finish()
    }
}

inventory::collect!(TestEntry);

/// Every registered test, by `order` then name.
pub fn registry() -> Vec<&'static TestEntry> {
    let mut v: Vec<&'static TestEntry> = inventory::iter::<TestEntry>.into_iter().collect();
    v.sort_by(|a, b| a.order.cmp(&b.order).then(a.name.cmp(b.name)));
    v
}

/// Run every registered test on `reg`, in registry order. A test that cannot judge the
/// registration (a [`DetectionError`]) gives an `inconclusive` outcome saying why.
pub fn run_all(reg: &Registration<'_>) -> Vec<TestOutcome> {
    registry().into_iter().map(|e| run_entry(e, reg)).collect()
}

/// Run one registered test on `reg`, as [`run_all`] runs each.
pub(crate) fn run_entry(e: &TestEntry, reg: &Registration<'_>) -> TestOutcome {
    match e.test.run(reg) {
        Ok(o) => finite_or_inconclusive(o),
        Err(err) => TestOutcome::from_error(e.name, &err),
    }
}

/// An outcome whose statistic or values are not finite numbers (the data overflowed a sum, a
/// variance vanished) is no evidence: inconclusive, with the reason instead of its sentence
/// (which would read "NGI NaN, NLI NaN" and gave `no-stiction`).
fn finite_or_inconclusive(o: TestOutcome) -> TestOutcome {
    let bad = o.statistic.is_some_and(|s| !s.is_finite())
        || o.values.iter().any(|(_, v)| !v.is_finite())
        || o.evidence
            .split(|c: char| !c.is_alphanumeric())
            .any(|w| w == "NaN" || w == "inf");
    if !bad {
        return o;
    }
    TestOutcome::new(
        o.name,
        None,
        Verdict::Inconclusive,
        "its statistic is not a finite number on this record (an overflowing or vanishing intermediate value)",
    )
}

/// The registered test called `name`.
pub fn find_test(name: &str) -> Result<&'static TestEntry, DetectionError> {
    let all = registry();
    all.iter()
        .find(|e| e.name == name)
        .copied()
        .ok_or_else(|| DetectionError::UnknownTest {
            name: name.to_string(),
            known: all.iter().map(|e| e.name).collect::<Vec<_>>().join(", "),
        })
}

/// One registration of a control loop, as the detection tests see it: SP (optional), PV, OP,
/// the sampling time and whether the process is integrating.
///
/// Built with [`Registration::new`] (lengths and sampling time checked) and the setters
/// [`Registration::with_sp`] and [`Registration::integrating`]. What the tests share is
/// computed once, on first use: [`Registration::oscillation`] and the prepared signals.
#[derive(Debug)]
pub struct Registration<'a> {
    sp: Option<&'a [f64]>,
    pv: &'a [f64],
    op: &'a [f64],
    ts: f64,
    integrating: bool,
    prepared: OnceLock<Result<Prepared, DetectionError>>,
}

/// The signals every test starts from (computed once per registration).
#[derive(Debug, Clone)]
pub(crate) struct Prepared {
    /// Control error `SP − PV` (or `−PV` without SP), detrended.
    pub(crate) error: Vec<f64>,
    /// PV detrended.
    pub(crate) pv: Vec<f64>,
    /// OP detrended.
    pub(crate) op: Vec<f64>,
    /// PV in units of its own spread: `(PV − mean) / standard deviation`. What the model fits
    /// read (the valve's proxy), so that their statistics do not depend on PV's engineering
    /// units: a least-squares fit on PV × 2e6 with an absolute ridge or a raw offset loses the
    /// valve's evidence to rounding.
    pub(crate) pv_unit: Vec<f64>,
    /// The oscillation of the control error.
    pub(crate) oscillation: Oscillation,
}

impl<'a> Registration<'a> {
    /// A registration of `pv` and `op` sampled every `sample_time` seconds (self-regulating,
    /// no SP until set).
    pub fn new(
        pv: &'a [f64],
        op: &'a [f64],
        sample_time: f64,
    ) -> Result<Registration<'a>, DetectionError> {
        if pv.len() != op.len() {
            return Err(DetectionError::LengthMismatch {
                pv: pv.len(),
                op: op.len(),
                sp: None,
            });
        }
        if !(sample_time.is_finite() && sample_time > 0.0) {
            return Err(DetectionError::InvalidSampleTime { value: sample_time });
        }
        Ok(Registration {
            sp: None,
            pv,
            op,
            ts: sample_time,
            integrating: false,
            prepared: OnceLock::new(),
        })
    }

    /// With the set point `sp` (same length).
    pub fn with_sp(mut self, sp: &'a [f64]) -> Result<Registration<'a>, DetectionError> {
        if sp.len() != self.pv.len() {
            return Err(DetectionError::LengthMismatch {
                pv: self.pv.len(),
                op: self.op.len(),
                sp: Some(sp.len()),
            });
        }
        self.sp = Some(sp);
        self.prepared = OnceLock::new();
        Ok(self)
    }

    /// Whether the process is integrating (a level: PV integrates the valve's flow).
    pub fn integrating(mut self, yes: bool) -> Registration<'a> {
        self.integrating = yes;
        self
    }

    /// PV.
    pub fn pv(&self) -> &[f64] {
        self.pv
    }
    /// OP.
    pub fn op(&self) -> &[f64] {
        self.op
    }
    /// SP, when given.
    pub fn sp(&self) -> Option<&[f64]> {
        self.sp
    }
    /// Seconds per sample.
    pub fn sample_time(&self) -> f64 {
        self.ts
    }
    /// Whether the process is integrating.
    pub fn is_integrating(&self) -> bool {
        self.integrating
    }
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.pv.len()
    }
    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.pv.is_empty()
    }

    /// Check the data can be judged at all: enough samples, finite, PV and OP not flat.
    pub fn check(&self) -> Result<(), DetectionError> {
        self.prepared().map(|_| ())
    }

    /// The oscillation of the control error (Thornhill's ACF regularity; computed once).
    pub fn oscillation(&self) -> Result<&Oscillation, DetectionError> {
        self.prepared().map(|p| &p.oscillation)
    }

    /// What stands for the valve position: PV for a self-regulating loop, ΔPV (the level's
    /// rate, proportional to the flow) for an integrating one; OP and PV aligned with it.
    /// PV is in units of its own spread (see `Prepared::pv_unit`); the caller has checked
    /// [`Registration::prepared`] (before that, and on data that cannot be judged, PV as given).
    pub(crate) fn valve_proxy(&self) -> ValveProxy<'_> {
        let pv: &[f64] = match self.prepared() {
            Ok(p) => &p.pv_unit,
            Err(_) => self.pv,
        };
        if self.integrating {
            ValveProxy {
                name: "ΔPV",
                y: pv.windows(2).map(|w| w[1] - w[0]).collect(),
                op: &self.op[1..],
                pv: &pv[1..],
            }
        } else {
            ValveProxy {
                name: "PV",
                y: pv.to_vec(),
                op: self.op,
                pv,
            }
        }
    }

    pub(crate) fn prepared(&self) -> Result<&Prepared, DetectionError> {
        self.prepared
            .get_or_init(|| self.prepare())
            .as_ref()
            .map_err(Clone::clone)
    }

    fn prepare(&self) -> Result<Prepared, DetectionError> {
        let n = self.len();
        if n < MIN_SAMPLES {
            return Err(DetectionError::TooShort {
                needed: MIN_SAMPLES,
                got: n,
            });
        }
        let mut signals: Vec<(&'static str, &[f64])> = vec![("PV", self.pv), ("OP", self.op)];
        if let Some(sp) = self.sp {
            signals.push(("SP", sp));
        }
        for (signal, x) in &signals {
            if let Some(sample) = x.iter().position(|v| !v.is_finite()) {
                return Err(DetectionError::NonFinite { signal, sample });
            }
        }
        let flat = |x: &[f64]| {
            let (lo, hi) = x
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                });
            hi - lo <= 1e-9 * hi.abs().max(lo.abs()).max(1e-300)
        };
        if flat(self.op) {
            return Err(DetectionError::Flat {
                signal: "OP",
                why: "the valve was never asked to move, so stiction cannot show",
            });
        }
        moves_enough(self.op)?;
        // PV flat throughout under a moving OP: the frozen run is the whole record
        let (start, run) = if flat(self.pv) {
            (0, n)
        } else {
            signal::longest_run(self.pv)
        };
        if 2 * run > n {
            let (lo, hi) = self.op[start..start + run]
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                });
            return Err(DetectionError::Frozen {
                run,
                rows: n,
                start,
                op_span: hi - lo,
            });
        }
        let raw_error: Vec<f64> = match self.sp {
            Some(sp) => sp.iter().zip(self.pv).map(|(s, p)| s - p).collect(),
            None => self.pv.iter().map(|p| -p).collect(),
        };
        let error = signal::detrend(&raw_error);
        let oscillation = oscillation::analyse(&error);
        let pv_unit = signal::standardise(self.pv);
        Ok(Prepared {
            error,
            pv: signal::detrend(self.pv),
            op: signal::detrend(self.op),
            pv_unit,
            oscillation,
        })
    }
}

/// Whether OP moves enough to show a stiction band: its 1st-to-99th-percentile span at least
/// [`BARELY_MOVES`] and at least [`MIN_OP_STEPS`] steps of its quantisation.
fn moves_enough(op: &[f64]) -> Result<(), DetectionError> {
    let span = signal::percentile_span(op);
    let quantum = quantisation_step(op, span);
    if span < BARELY_MOVES {
        return Err(DetectionError::BarelyMoves {
            span,
            why: String::new(),
        });
    }
    if span < MIN_OP_STEPS * quantum {
        return Err(DetectionError::BarelyMoves {
            span,
            why: format!(
                ", {:.1} steps of its quantisation {quantum:.3}",
                span / quantum
            ),
        });
    }
    Ok(())
}

/// OP's quantisation step: the smallest gap between two of the distinct values it takes
/// (gaps below `1e-12 · span` are rounding, not steps). OP walking over a logged lattice of
/// step `q` leaves gaps of `q`. The smallest change between successive samples is no estimate
/// of it: an OP that swings between its limits every sample (a loop on the edge of
/// instability) never changes by less than most of its range, yet takes hundreds of values.
/// Not `datasets::quantisation::step`, the reader's lattice test: `datasets` is a crate of the
/// same layer, and that step is only defined for a lattice (none for fewer than four distinct
/// values), where this guard needs a step for every OP, two or three values included.
fn quantisation_step(op: &[f64], span: f64) -> f64 {
    let mut values: Vec<f64> = op.iter().copied().filter(|v| v.is_finite()).collect();
    values.sort_by(f64::total_cmp);
    values
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|&d| d > 1e-12 * span)
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// OP on a lattice of a quarter of its span is too coarse to judge; an OP that swings
    /// between its limits every sample and takes hundreds of values between them is not, though
    /// no change between two samples is smaller than most of its range.
    #[test]
    fn the_quantisation_step_is_the_lattice_not_the_smallest_move() {
        let coarse: Vec<f64> = (0..400).map(|k| 25.0 * ((k % 5) as f64)).collect();
        assert!(matches!(
            moves_enough(&coarse),
            Err(DetectionError::BarelyMoves { .. })
        ));
        let swinging: Vec<f64> = (0..400)
            .map(|k| {
                let inner = 0.37 * (k as f64) % 17.0;
                if k % 2 == 0 {
                    inner
                } else {
                    100.0 - inner
                }
            })
            .collect();
        assert!(moves_enough(&swinging).is_ok());
        assert!((quantisation_step(&coarse, 100.0) - 25.0).abs() < 1e-12);
    }
}
