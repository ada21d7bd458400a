//! Populations of simulated control loops randomised wide, for calibrating and validating a
//! stiction detector on loops it was not tuned on.
//!
//! A [`PopulationSpec`] names the ranges (plant families, sampling time, record length) and a
//! seed; [`PopulationSpec::generate`] gives loop `index` of the population, the same on every
//! machine (one `ChaCha8Rng` per loop, seeded from the population's seed and the index; the
//! loop itself is a [`Scenario`] simulated by [`Scenario::simulate`]).
//!
//! What a loop is made of (every choice drawn per loop):
//! * **Process** ([`Family`]): flow (first order, τ 1-15 s, dead time 0-3 s), pressure (first or
//!   second order, τ 5-120 s, dead time 0-10 s), composition (second order, τ 60-600 s, dead
//!   time 10-120 s) — self-regulating, static gain 0.3-3 — and level (integrating: filling
//!   time 60-1200 s per % of OP, an optional lag up to 30 s, dead time 0-10 s). Continuous
//!   time constants are discretised at the loop's sampling time (zero-order hold; dead time
//!   rounded to whole samples, at most [`MAX_DELAY`]).
//! * **Sampling and length**: `Ts` log-uniform in [`PopulationSpec::sample_time`], `N`
//!   log-uniform in [`PopulationSpec::samples`].
//! * **Transport delay**: a dead time added to every process, uniform in
//!   [`PopulationSpec::transport_delay`] (none by default).
//! * **Tuning**: SIMC/IMC-like PI with the closed-loop time constant a factor 0.3-4 of the
//!   process's (aggressive to sluggish), scaled down until the closed loop is stable. A share
//!   [`PopulationSpec::proportional`] of the loops (none by default) runs the same gain without
//!   integral action: a proportional-only controller, as averaging level control and some
//!   pressure loops use, whose OP is a static function of PV and SP.
//! * **Noise**: white noise through `(1 + c₁ q⁻¹)` at PV (the plant's `C = A (1 + c₁ q⁻¹)`),
//!   `c₁` in [-0.3, 0.9], σ 0.02-0.5 % of span.
//! * **Excitation**: each with its own chance — set-point moves (random walk), load steps,
//!   a drift, an external oscillation (period 10 samples to a third of the record); sized in %
//!   of the valve's travel through the plant's gain.
//! * **Valve**: sticky ([`Label::Sticky`]: Kano, He, asymmetric Kano or Kano with an installed
//!   equal-percentage characteristic; S log-uniform 0.5-10 %, J uniform in [0, S]; one in
//!   eight "stuck for long stretches", S 10-25 % with small J) or free ([`Label::Healthy`],
//!   linear or with a characteristic: a nonlinearity that is not stiction).
//! * **Historian**: with a chance each, PV logged through swinging-door compression and PV/OP
//!   quantised to a step of 0.01-0.2 % of span.
//! * **OP that barely moves**: about one loop in sixteen is quiet (little noise, no set-point
//!   move or disturbance, a sluggish controller). A loop whose OP spans less than
//!   [`BARELY_MOVES`] % (1st to 99th percentile) is labelled [`Label::CannotJudge`] whatever
//!   its valve: no record can show stiction the valve was never asked to cross.
//! * **A frozen transmitter**: about one loop in sixteen logs PV at one value from 30-45 % of
//!   the record to its end while the controller integrates the error it sees. A loop whose PV
//!   holds one value over more than half of the record is labelled [`Label::CannotJudge`]
//!   whatever its valve: a valve stuck that long and a frozen transmitter give the same PV and
//!   OP.
//! * **Stiction that leaves no trace** ([`Label::NoTrace`]): a sticky valve whose effect on
//!   the record is below what the record can show, decided from the simulation alone (never
//!   from a detector), by [`trace`] below.
//!
//! # Stiction that leaves no trace
//! Each sticky loop has a *twin*: the same [`Scenario`] (the same seed, so the same noise,
//! set-point moves and disturbances; the same plant, controller, installed characteristic
//! and historian) with a free valve. What separates the two records is the stiction's effect
//! on the record, and nothing else. The label asks whether a perfect model — one that knows
//! that effect exactly — could tell it from the noise in this record:
//!
//! `LR = N ln(1 + var(X_sticky − X_twin) / σ²_X)` for `X` = PV and for `X` = OP,
//!
//! the log-likelihood gain of a model that explains the difference over one that does not,
//! with Gaussian white residuals of variance `σ²_X`: the variance of the noise's contribution
//! to `X` in the twin (the twin simulated again without noise, subtracted), plus the
//! historian's (a quantisation step `q` adds `q²/12`, swinging-door compression with
//! deviation `d` adds `d²/3` to PV). OP counts as well as PV: the controller reacts to the
//! valve, and the difference may stand further above OP's noise than above PV's. The
//! difference is centred (its mean left out): a constant offset between the records — a
//! backlash's offset in OP under a valve that never reverses — is absorbed by any model's
//! constant and shows nothing. When the larger of the two is below χ²₁(95 %) = 3.84
//! ([`NO_TRACE_LR`]), not even that perfect model would find the stiction in the record at the
//! 5 % level: the loop is labelled [`Label::NoTrace`] (its S is kept). Neither verdict is
//! wrong about such a record: the valve sticks, and the data show no effect a repair would
//! remove. Residuals are taken as white: where the noise is coloured and the difference slow,
//! the gain is overstated, so the label errs towards "shows a trace" (it is conservative).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use stiction_models::{He, Kano, KanoAsym, StictionModel};

use super::{
    swinging_door, Characteristic, Controller, Disturbance, Plant, PlantSpec, Scenario, Setpoint,
    SimulatedLoop,
};
use crate::DataError;

/// Longest dead time in samples (the stability check's polynomial grows with it).
pub const MAX_DELAY: usize = 60;

/// OP span (1st to 99th percentile, % of travel) under which a loop cannot be judged.
pub const BARELY_MOVES: f64 = 0.5;

/// The process behind a loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Family {
    /// Fast, first order, little dead time.
    Flow,
    /// First or second order, seconds to minutes.
    Pressure,
    /// Integrating (a tank level).
    Level,
    /// Slow, second order, long dead time (an analyser, a temperature).
    Composition,
}

impl Family {
    /// Every family.
    pub const ALL: [Family; 4] = [
        Family::Flow,
        Family::Pressure,
        Family::Level,
        Family::Composition,
    ];

    /// Lower-case name.
    pub fn as_str(self) -> &'static str {
        match self {
            Family::Flow => "flow",
            Family::Pressure => "pressure",
            Family::Level => "level",
            Family::Composition => "composition",
        }
    }

    /// Whether PV integrates the valve's flow.
    pub fn integrating(self) -> bool {
        self == Family::Level
    }
}

/// What a loop's valve is, as a detector should answer it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Label {
    /// The valve sticks (and OP moves enough to show it).
    Sticky,
    /// The valve is free.
    Healthy,
    /// OP barely moves, or PV holds one value over more than half of the record (a stuck valve
    /// or a frozen transmitter): the record cannot show whether the valve sticks (expected
    /// `inconclusive`).
    CannotJudge,
    /// The valve sticks, but its effect on the record is below what the record can show
    /// ([`trace`]): neither `stiction` nor `no-stiction` is wrong about the record.
    NoTrace,
}

/// The log-likelihood gain under which a sticky valve leaves no trace in its record: χ²₁ at
/// 95 % ([`Label::NoTrace`]).
pub const NO_TRACE_LR: f64 = 3.84;

/// How far a sticky loop's record stands from its free twin's, in the log-likelihood gain of
/// a perfect model (module docs, "Stiction that leaves no trace").
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Trace {
    /// `N ln(1 + var(PV_sticky − PV_twin) / σ²_PV)`.
    pub lr_pv: f64,
    /// The same of OP.
    pub lr_op: f64,
}

impl Trace {
    /// The larger of the two gains.
    pub fn lr(&self) -> f64 {
        self.lr_pv.max(self.lr_op)
    }

    /// Whether the stiction shows in the record (the gain at least [`NO_TRACE_LR`]).
    pub fn shows(&self) -> bool {
        self.lr() >= NO_TRACE_LR
    }
}

/// The ranges of a population.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PopulationSpec {
    /// Seed of the population (loop `i` is seeded from it and `i`).
    pub seed: u64,
    /// The plant families drawn from, in turn.
    pub families: Vec<Family>,
    /// Sampling time range, seconds (log-uniform; equal ends: fixed).
    pub sample_time: [f64; 2],
    /// Record length range, samples (log-uniform; equal ends: fixed).
    pub samples: [usize; 2],
    /// The share of loops under a proportional-only controller (the PI's gain, no integral
    /// action), drawn from a stream of its own: every other draw of a loop is the same
    /// whatever this share. 0 (the default) for PI controllers only.
    #[serde(default)]
    pub proportional: f64,
    /// A dead time added to every loop's process, seconds, uniform in this range (drawn from
    /// a stream of its own, like [`PopulationSpec::proportional`]): a transport delay between
    /// the valve and the measurement (a long line, an analyser's sample system). `[0, 0]`
    /// (the default) for the families' own dead times only.
    #[serde(default)]
    pub transport_delay: [f64; 2],
}

impl Default for PopulationSpec {
    /// [`PopulationSpec::wide`] with seed 0: every family, the full ranges, PI controllers, no
    /// transport delay.
    fn default() -> Self {
        PopulationSpec::wide(0)
    }
}

impl PopulationSpec {
    /// The full ranges: every family, `Ts` 1-60 s, `N` 200-5000.
    pub fn wide(seed: u64) -> PopulationSpec {
        PopulationSpec {
            seed,
            families: Family::ALL.to_vec(),
            sample_time: [1.0, 60.0],
            samples: [200, 5000],
            proportional: 0.0,
            transport_delay: [0.0, 0.0],
        }
    }

    /// Loop `index` of the population.
    pub fn generate(&self, index: usize) -> Result<PopulationLoop, DataError> {
        generate(self, index)
    }
}

/// One loop of a population.
#[derive(Debug, Clone)]
pub struct PopulationLoop {
    /// Index in the population.
    pub index: usize,
    /// The process family.
    pub family: Family,
    /// Whether the process is integrating.
    pub integrating: bool,
    /// The label.
    pub label: Label,
    /// The valve's S (% of span; 0 for a free valve).
    pub s: f64,
    /// How far the record stands from its free twin's ([`trace`]; sticky valves only).
    pub trace: Option<Trace>,
    /// One line saying what the loop is.
    pub what: String,
    /// Seconds per sample.
    pub sample_time: f64,
    /// The simulation (PV and OP as logged: after compression and quantisation).
    pub sim: SimulatedLoop,
}

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    if hi <= lo {
        return lo;
    }
    (lo.ln() + (hi.ln() - lo.ln()) * rng.random::<f64>()).exp()
}

fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

fn chance(rng: &mut ChaCha8Rng, p: f64) -> bool {
    rng.random::<f64>() < p
}

/// `(1 - p q⁻¹)` products: the ZOH poles of the lags `taus` at `ts`.
fn lag_poly(ts: f64, taus: &[f64]) -> (Vec<f64>, f64) {
    let mut a = vec![1.0];
    let mut gain = 1.0;
    for &tau in taus {
        let p = (-ts / tau).exp();
        a = convolve(&a, &[1.0, -p]);
        gain *= 1.0 - p;
    }
    (a, gain)
}

fn convolve(x: &[f64], y: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; x.len() + y.len() - 1];
    for (i, a) in x.iter().enumerate() {
        for (j, b) in y.iter().enumerate() {
            out[i + j] += a * b;
        }
    }
    out
}

fn percentile_span(x: &[f64]) -> f64 {
    let mut v: Vec<f64> = x.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return 0.0;
    }
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    at(0.99) - at(0.01)
}

/// The longest run of exactly repeated values.
fn longest_run(x: &[f64]) -> usize {
    let (mut best, mut run) = (0usize, 0usize);
    for i in 0..x.len() {
        run = if i > 0 && x[i] == x[i - 1] {
            run + 1
        } else {
            1
        };
        best = best.max(run);
    }
    best
}

fn quantise(x: &mut [f64], step: f64) {
    for v in x {
        *v = (*v / step).round() * step;
    }
}

/// The process of a `family`, in continuous time (seconds): its lag time constants, dead
/// time and gain.
fn process(rng: &mut ChaCha8Rng, family: Family) -> (Vec<f64>, f64, f64) {
    match family {
        Family::Flow => (
            vec![uniform(rng, 1.0, 15.0)],
            uniform(rng, 0.0, 3.0),
            log_uniform(rng, 0.3, 3.0),
        ),
        Family::Pressure => {
            let t1 = log_uniform(rng, 5.0, 120.0);
            let taus = if chance(rng, 0.5) {
                vec![t1, t1 * uniform(rng, 0.1, 0.5)]
            } else {
                vec![t1]
            };
            (taus, uniform(rng, 0.0, 10.0), log_uniform(rng, 0.3, 3.0))
        }
        Family::Composition => {
            let t1 = log_uniform(rng, 60.0, 600.0);
            (
                vec![t1, t1 * uniform(rng, 0.2, 1.0)],
                uniform(rng, 10.0, 120.0),
                log_uniform(rng, 0.3, 3.0),
            )
        }
        Family::Level => {
            let fill = log_uniform(rng, 60.0, 1200.0);
            let taus = if chance(rng, 0.5) {
                vec![uniform(rng, 2.0, 30.0)]
            } else {
                Vec::new()
            };
            (taus, uniform(rng, 0.0, 10.0), 1.0 / fill)
        }
    }
}

/// PI tuning for a closed-loop time constant `factor` × the process's (λ tuning), detuned
/// tenfold for a quiet loop and by 0.8 until stable: `(kc, ki, the tuning in words)`.
fn tune(
    rng: &mut ChaCha8Rng,
    family: Family,
    (ts, dead, gain): (f64, f64, f64),
    taus: &[f64],
    quiet: bool,
    plant: &Plant,
    index: usize,
) -> Result<(f64, f64, &'static str), DataError> {
    let tau_sum: f64 = taus.iter().sum();
    let theta = dead + ts / 2.0 + taus.iter().skip(1).sum::<f64>() / 2.0;
    let factor = log_uniform(rng, 0.3, 4.0);
    let (mut kc, ti) = if family.integrating() {
        let lambda = factor * (theta + tau_sum + 60.0);
        (1.0 / (gain * (lambda + theta)), 4.0 * (lambda + theta))
    } else {
        let lambda = factor * (theta + 0.3 * tau_sum);
        (
            tau_sum.max(ts) / (gain * (lambda + theta)),
            tau_sum.max(ts).min(4.0 * (lambda + theta)),
        )
    };
    let mut ki = kc * ts / ti;
    if quiet {
        kc *= 0.1;
        ki *= 0.1;
    }
    let mut stable = false;
    for _ in 0..80 {
        if plant.check_stability(kc, ki).is_ok() {
            stable = true;
            break;
        }
        kc *= 0.8;
        ki *= 0.8;
    }
    if !stable {
        return Err(DataError::InvalidParameter {
            name: format!("population loop {index}: PI gains"),
            value: kc,
            expected: "a stabilising tuning".into(),
        });
    }
    let tuning = if factor < 0.7 {
        "aggressive"
    } else if factor > 2.0 {
        "sluggish"
    } else {
        "moderate"
    };
    Ok((kc, ki, tuning))
}

/// Measurement noise (PV in % of span) and excitation: set-point moves, load steps, drift and
/// an external oscillation, each by chance (none for a quiet loop), the disturbances in % of
/// valve travel through the input gain `b1`; with the parts in words.
fn excitation(
    rng: &mut ChaCha8Rng,
    quiet: bool,
    ts: f64,
    samples: usize,
    input_gain: f64,
) -> (f64, Setpoint, Vec<Disturbance>, Vec<&'static str>) {
    let noise = if quiet {
        log_uniform(rng, 0.002, 0.01)
    } else {
        log_uniform(rng, 0.02, 0.5)
    };
    let duration = samples as f64 * ts;
    let mut parts = Vec::new();
    let mut disturbances = Vec::new();
    let mut setpoint = Setpoint::constant();
    let r_sp = chance(rng, 0.4);
    let r_load = chance(rng, 0.4);
    let r_drift = chance(rng, 0.3);
    let r_sine = chance(rng, 0.3);
    let sp_step = log_uniform(rng, 0.5, 5.0);
    let sp_every = log_uniform(rng, 20.0, 300.0);
    let load_sigma = log_uniform(rng, 0.5, 5.0);
    let load_every_s = log_uniform(rng, 0.05, 0.5) * duration;
    let drift_total = uniform(rng, -5.0, 5.0);
    let sine_amp = log_uniform(rng, 0.3, 3.0);
    let sine_period = log_uniform(rng, 10.0, (samples as f64 / 3.0).max(11.0));
    if !quiet {
        if r_sp {
            setpoint = Setpoint {
                step: 2.0 * sp_step,
                switch_probability: 1.0 / sp_every,
                steps: Vec::new(),
            };
            parts.push("set-point moves");
        }
        if r_load {
            disturbances.push(Disturbance::RandomSteps {
                probability: (ts / load_every_s).min(0.5),
                sigma: load_sigma * input_gain,
            });
            parts.push("load steps");
        }
        if r_drift {
            disturbances.push(Disturbance::Drift {
                slope: drift_total / samples as f64 * input_gain,
            });
            parts.push("drift");
        }
        if r_sine {
            disturbances.push(Disturbance::Sine {
                amplitude: sine_amp * input_gain,
                frequency: 2.0 * std::f64::consts::PI / sine_period,
                phase: 0.0,
            });
            parts.push("external oscillation");
        }
    }
    if parts.is_empty() {
        parts.push(if quiet { "quiet" } else { "noise only" });
    }
    (noise, setpoint, disturbances, parts)
}

/// The valve: for a sticky loop one of Kano, He, asymmetric Kano or Kano with an
/// equal-percentage characteristic (S sometimes far larger: stuck long), else a free valve
/// (sometimes equal-percentage); with its description, its characteristic, its S and whether
/// it is stuck long.
#[allow(clippy::type_complexity)]
fn valve(
    rng: &mut ChaCha8Rng,
    sticky: bool,
) -> Result<
    (
        Box<dyn StictionModel>,
        String,
        Option<Characteristic>,
        f64,
        bool,
    ),
    DataError,
> {
    let kind = rng.random_range(0..4u32);
    let stuck_long = chance(rng, 1.0 / 8.0);
    let (s, j) = if stuck_long {
        let s = uniform(rng, 10.0, 25.0);
        (s, s * uniform(rng, 0.0, 0.2))
    } else {
        let s = log_uniform(rng, 0.5, 10.0);
        (s, s * rng.random::<f64>())
    };
    let asym = uniform(rng, 0.2, 1.0);
    let rangeability = log_uniform(rng, 10.0, 50.0);
    let healthy_char = chance(rng, 0.25);
    let mut characteristic = None;
    let (valve, valve_what): (Box<dyn StictionModel>, String) = if sticky {
        match kind {
            0 => (
                Box::new(Kano::params().s(s).j(j).check()?),
                format!("kano S={s:.1} J={j:.1}"),
            ),
            1 => (
                Box::new(He::from_sj(s, j)?),
                format!("he S={s:.1} J={j:.1}"),
            ),
            2 => {
                // Direction-dependent slip: D = S - J, J_up = J, J_dn = asym·J.
                let d = s - j;
                (
                    Box::new(KanoAsym::params().d(d).j_up(j).j_dn(asym * j).check()?),
                    format!("asymmetric D={d:.1} J_up={j:.1} J_dn={:.1}", asym * j),
                )
            }
            _ => {
                characteristic = Some(Characteristic::EqualPercentage { rangeability });
                (
                    Box::new(Kano::params().s(s).j(j).check()?),
                    format!("kano S={s:.1} J={j:.1} equal-percentage R={rangeability:.0}"),
                )
            }
        }
    } else {
        if healthy_char {
            characteristic = Some(Characteristic::EqualPercentage { rangeability });
        }
        (
            Box::new(Kano::params().check()?),
            if healthy_char {
                format!("free, equal-percentage R={rangeability:.0}")
            } else {
                "free".to_string()
            },
        )
    };
    Ok((valve, valve_what, characteristic, s, stuck_long))
}

/// The controller a loop runs: the PI of [`tune`], or, for a share
/// [`PopulationSpec::proportional`] of the loops (drawn from a stream of its own so that the
/// share leaves every other draw of the loop as it is), the PI's gain without integral action,
/// reduced by 0.8 until stable.
fn proportional(
    spec: &PopulationSpec,
    seed: u64,
    plant: &Plant,
    (kc, ki, tuning): (f64, f64, &'static str),
) -> (f64, f64, &'static str) {
    let drawn = spec.proportional > 0.0
        && chance(
            &mut ChaCha8Rng::seed_from_u64(seed ^ 0x5052_4F50_4F52_5449),
            spec.proportional,
        );
    if !drawn {
        return (kc, ki, tuning);
    }
    let mut kc = kc;
    for _ in 0..80 {
        if plant.check_stability(kc, 0.0).is_ok() {
            break;
        }
        kc *= 0.8;
    }
    (kc, 0.0, "P-only")
}

/// The dead time [`PopulationSpec::transport_delay`] adds to a loop's process, seconds (drawn
/// from a stream of its own).
fn transport_delay(spec: &PopulationSpec, seed: u64) -> f64 {
    match spec.transport_delay {
        [lo, hi] if hi > 0.0 => uniform(
            &mut ChaCha8Rng::seed_from_u64(seed ^ 0x5452_414E_5350_4F52),
            lo,
            hi,
        ),
        _ => 0.0,
    }
}

/// A frozen transmitter from sample `k0` on: PV logged at one value to the end of the record,
/// and OP as the controller (`kc`, `ki`) computes it from that PV, quantised by `quant`.
fn freeze(sim: &mut SimulatedLoop, k0: usize, (kc, ki): (f64, f64), quant: Option<f64>) {
    let v0 = sim.pv[k0];
    let mut err_prev = sim.sp[k0 - 1] - sim.pv[k0 - 1];
    for k in k0..sim.pv.len() {
        sim.pv[k] = v0;
        let err = sim.sp[k] - v0;
        sim.op[k] = (sim.op[k - 1] + kc * (err - err_prev) + ki * err).clamp(0.0, 100.0);
        err_prev = err;
    }
    if let Some(step) = quant {
        quantise(&mut sim.op[k0..], step);
    }
}

fn generate(spec: &PopulationSpec, index: usize) -> Result<PopulationLoop, DataError> {
    if spec.families.is_empty() {
        return Err(DataError::InvalidParameter {
            name: "families".into(),
            value: 0.0,
            expected: "at least one plant family".into(),
        });
    }
    let seed = spec
        .seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(index as u64);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let family = spec.families[(index / 2) % spec.families.len()];
    let sticky = index.is_multiple_of(2);
    let ts = log_uniform(&mut rng, spec.sample_time[0], spec.sample_time[1]);
    let samples = log_uniform(
        &mut rng,
        spec.samples[0] as f64,
        spec.samples[1] as f64 + 0.999,
    )
    .floor() as usize;
    let quiet = chance(&mut rng, 1.0 / 16.0);

    // Process, in continuous time (seconds), discretised at `ts`.
    let (taus, dead, gain) = process(&mut rng, family);
    let dead = dead + transport_delay(spec, seed);
    let delay = ((dead / ts).round() as usize).min(MAX_DELAY);
    let (lags, lag_gain) = lag_poly(ts, &taus);
    let (a, b1) = if family.integrating() {
        // y(k) = y(k-1) + gain·Ts·u(k-1) through the lags.
        (convolve(&lags, &[1.0, -1.0]), gain * ts * lag_gain)
    } else {
        (lags, gain * lag_gain)
    };
    let c1 = uniform(&mut rng, -0.3, 0.9);
    let plant = Plant {
        c: convolve(&a, &[1.0, c1]),
        a,
        b: vec![0.0, b1],
        delay,
    };
    // Tuning: closed-loop time constant λ = factor × the process's.
    let tau_sum: f64 = taus.iter().sum();
    let (kc, ki, tuning) = tune(
        &mut rng,
        family,
        (ts, dead, gain),
        &taus,
        quiet,
        &plant,
        index,
    )?;

    let (kc, ki, tuning) = proportional(spec, seed, &plant, (kc, ki, tuning));

    // Noise and excitation (PV in % of span; disturbances in % of valve travel through B(1)).
    let (noise, setpoint, disturbances, parts) = excitation(&mut rng, quiet, ts, samples, b1);

    // Valve.
    let (valve, valve_what, characteristic, s, stuck_long) = valve(&mut rng, sticky)?;

    // Historian.
    let compress = chance(&mut rng, 0.25).then(|| noise * uniform(&mut rng, 0.5, 3.0));
    let quant = chance(&mut rng, 0.25).then(|| log_uniform(&mut rng, 0.01, 0.2));

    let settle = (5.0 * (tau_sum + dead + 60.0) / ts).ceil() as usize;
    let mut sim = Scenario {
        plant: PlantSpec::Explicit(plant),
        controller: Controller { kc, ki },
        setpoint,
        valve,
        disturbances,
        noise_sigma: noise,
        samples,
        warmup: settle.clamp(300, 5000),
        seed,
        sample_time: ts,
        op_limits: Some([0.0, 100.0]),
        characteristic,
        ..Scenario::default()
    }
    .simulate()?;
    // The historian's own error, as measurement noise: (PV, OP) variances.
    let historian_var = {
        let q = quant.map_or(0.0, |q| q * q / 12.0);
        (q + compress.map_or(0.0, |d| d * d / 3.0), q)
    };
    let trace = if sticky {
        Some(trace(&sim, historian_var)?)
    } else {
        None
    };
    let mut historian = Vec::new();
    if let Some(dev) = compress {
        sim.pv = swinging_door(&sim.pv, dev).0;
        historian.push(format!("swinging door {dev:.3}"));
    }
    if let Some(step) = quant {
        quantise(&mut sim.pv, step);
        quantise(&mut sim.op, step);
        historian.push(format!("quantised {step:.3}"));
    }
    // A frozen transmitter (drawn last, so that every other loop of a population stays what it
    // was): from a point on to the end of the record PV is logged at one value, and the
    // controller, which reads it, integrates the constant error it sees.
    let frozen = chance(&mut rng, 1.0 / 16.0).then(|| uniform(&mut rng, 0.3, 0.45));
    if let Some(at) = frozen {
        let k0 = ((samples as f64 * at) as usize).max(1);
        freeze(&mut sim, k0, (kc, ki), quant);
        historian.push(format!("PV frozen from sample {k0}"));
    }
    let op_span = percentile_span(&sim.op);
    let label = label_of(&sim, op_span, sticky, trace);
    let what = format!(
        "{} Ts={ts:.1}s N={samples} delay={delay} {tuning} | {} | {valve_what}{} | OP span {op_span:.2} %{}",
        family.as_str(),
        parts.join(" + "),
        if sticky && stuck_long { " (stuck long)" } else { "" },
        if historian.is_empty() {
            String::new()
        } else {
            format!(" | {}", historian.join(", "))
        }
    );
    Ok(PopulationLoop {
        index,
        family,
        integrating: family.integrating(),
        label,
        s: if sticky { s } else { 0.0 },
        trace,
        what,
        sample_time: ts,
        sim,
    })
}

/// The label of a loop as logged: cannot be judged (OP spans less than [`BARELY_MOVES`], or PV
/// holds one value over more than half of the record), else sticky (without a trace when its
/// [`Trace`] does not show) or healthy.
fn label_of(sim: &SimulatedLoop, op_span: f64, sticky: bool, trace: Option<Trace>) -> Label {
    if op_span < BARELY_MOVES || 2 * longest_run(&sim.pv) > sim.len() {
        Label::CannotJudge
    } else if sticky && trace.is_some_and(|t| !t.shows()) {
        Label::NoTrace
    } else if sticky {
        Label::Sticky
    } else {
        Label::Healthy
    }
}

/// The sample variance (about the mean) of `a − b`.
fn var_of_difference(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    if n < 2 {
        return 0.0;
    }
    let d = || a.iter().zip(b).map(|(x, y)| x - y);
    let mean = d().sum::<f64>() / n as f64;
    d().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64
}

/// `N ln(1 + var(difference) / σ²)`; infinite for a difference on a record without noise.
fn gain(n: usize, var_difference: f64, noise_var: f64) -> f64 {
    if noise_var > 0.0 {
        n as f64 * (var_difference / noise_var).ln_1p()
    } else if var_difference > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

/// How far the record `sim` (as simulated, before the historian) of a sticky valve stands from
/// its free twin's: the same scenario with a free valve, and again without noise for the
/// noise's own contribution; `historian_var` adds the historian's error to the noise's
/// variance of (PV, OP). The module docs, "Stiction that leaves no trace", give the rule.
pub fn trace(sim: &SimulatedLoop, historian_var: (f64, f64)) -> Result<Trace, DataError> {
    let free = || -> Result<Scenario, DataError> {
        Ok(Scenario {
            valve: Box::new(Kano::params().check()?),
            ..sim.scenario.clone()
        })
    };
    let twin = free()?.simulate()?;
    let quiet = Scenario {
        noise_sigma: 0.0,
        ..free()?
    }
    .simulate()?;
    let n = sim.len();
    let noise_pv = var_of_difference(&twin.pv, &quiet.pv) + historian_var.0;
    let noise_op = var_of_difference(&twin.op, &quiet.op) + historian_var.1;
    Ok(Trace {
        lr_pv: gain(n, var_of_difference(&sim.pv, &twin.pv), noise_pv),
        lr_op: gain(n, var_of_difference(&sim.op, &twin.op), noise_op),
    })
}

mod known_model;
pub use known_model::known_model_lr;

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests;
