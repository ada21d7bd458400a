//! The closed-loop benchmark of the reference paper (§3.1, eqs. 10-12; spec §6).
//!
//! An ARMAX [`Plant`] in deviation variables, a velocity-form PI controller, a sticky valve from
//! any registered [`StictionModel`], a random-walk set point and optional external
//! disturbances, all configured by a serialisable [`Scenario`]:
//!
//! ```
//! use datasets::simulate::Scenario;
//! let scenario = Scenario::from_json(r#"{
//!     "plant": "paper",
//!     "valve": {"kind": "kano", "S": 9, "J": 3},
//!     "disturbances": [{"kind": "paper", "a": 0.25}],
//!     "samples": 600, "warmup": 100
//! }"#)?;
//! let sim = scenario.simulate()?;
//! assert_eq!(sim.op.len(), 600);
//! // The valve model reproduces MV from OP exactly (the kept record starts from `valve_init`).
//! assert_eq!(scenario.valve.simulate(&sim.op, &scenario.valve_init)?, sim.mv);
//! # Ok::<(), datasets::DataError>(())
//! ```
//!
//! # Per-sample order (spec §6.2)
//! For `k = 0 .. warmup + samples - 1`:
//! 1. draw the random numbers of sample `k` (see [RNG](#random-numbers));
//! 2. `SP(k) = SP(k-1) + w(k)` (eq. 12 random walk plus scheduled [`SetpointStep`]s),
//!    `SP(-1) = pv_bias`;
//! 3. `y(k) = -Σ a_i y(k-i) + Σ b_i u(k-delay-i) + e(k) + Σ c_i e(k-i) [+ η(k)]` with
//!    `u = MV - op_bias` (or, with an installed [`Characteristic`], `u = h(MV - op_bias)`)
//!    and terms with negative index 0;
//! 4. `PV(k) = pv_bias + y(k) [+ η(k)]`;
//! 5. `err(k) = SP(k) - PV(k)`;
//! 6. `OP(k) = OP(k-1) + Kc (err(k) - err(k-1)) + KI err(k)`, `OP(-1) = op_bias`,
//!    `err(-1) = 0`, then clipping (see [`Scenario::op_limits`]);
//! 7. `MV(k) = valve.step(OP(k))`; at `k = 0` and again at `k = warmup` the valve is
//!    (re)started from [`Scenario::valve_init`] at `OP(k)`.
//!
//! # Where the disturbance enters
//! The paper's eq. (10) puts `η_k` *inside* the difference equation,
//! `A(q) y = B(q) u + C(q) e + η`, so the plant's own dynamics filter it (`y = (B u + C e + η) / A`); this is the default,
//! [`DisturbanceEntry::Equation`]. The specification's §6.2 adds it to the output instead
//! (`PV = pv_bias + y + η`), available as [`DisturbanceEntry::Output`]. Where the two
//! disagree the paper wins, hence the default.
//!
//! # Why the valve restarts at the first kept sample
//! The kept record is exactly what the stiction model produces from its own OP column with the
//! scenario's initial state: `valve.simulate(&sim.op, &scenario.valve_init) == sim.mv`, bit
//! for bit (a must-hold of the project: `stiction valve` on a simulated file gives back its
//! MV). The warm-up still settles the plant, the controller, the noise filter and the set point;
//! the restart perturbs the valve as the start at `k = 0` does (with the default initial state
//! the valve is at rest at `OP + (S - J)/2`), and a linear valve (`S = J = 0`) is not
//! perturbed at all.
//!
//! # Random numbers
//! One `ChaCha8Rng::seed_from_u64(seed)` stream. At every sample `k` (warm-up included), in
//! this order and whether or not they are used: `R1 ~ U[0,1)` and `R2 ~ U[0,1)` of eq. (12),
//! then `z ~ N(0,1)` with `e(k) = noise_sigma · z`, then for each
//! [`Disturbance::RandomSteps`] in list order a `U[0,1)` switch and a `N(0,1)` size. The
//! same seed therefore gives the same output on every machine (ChaCha is portable), and
//! changing a probability or σ does not shift the other streams (common random numbers).
//! The sines use the platform's `f64::sin`.

mod overrides;
mod plant;
pub mod population;

pub use overrides::{OverrideError, Overrides, MAX_GAIN};
pub use plant::{Plant, PlantPreset};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};
use stiction_models::{InitialState, Kano, StictionModel, ValveState};

use crate::{DataError, LoopData};

/// The plant of a scenario: a preset name or explicit polynomials.
///
/// JSON: `"paper"`, `"slow"`, or `{"a": [...], "b": [...], "c": [...], "delay": 0}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum PlantSpec {
    /// A named plant.
    Preset(PlantPreset),
    /// Explicit polynomials.
    Explicit(Plant),
}

impl Default for PlantSpec {
    fn default() -> Self {
        PlantSpec::Preset(PlantPreset::Paper)
    }
}

impl PlantSpec {
    /// The plant.
    pub fn plant(&self) -> Plant {
        match self {
            PlantSpec::Preset(p) => p.plant(),
            PlantSpec::Explicit(p) => p.clone(),
        }
    }
}

/// Velocity-form PI controller `C(q) = Kc + KI / (1 - q^-1)`.
///
/// | field | default | meaning |
/// |-------|---------|---------|
/// | `kc` | 0.5 | proportional gain (paper: nominal 0.5, aggressive 1.2, sluggish 0.2) |
/// | `ki` | 0.5 | integral gain (same values) |
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Controller {
    /// Proportional gain.
    pub kc: f64,
    /// Integral gain.
    pub ki: f64,
}

impl Default for Controller {
    fn default() -> Self {
        Controller { kc: 0.5, ki: 0.5 }
    }
}

/// A scheduled set-point step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetpointStep {
    /// Sample of the kept record at which SP jumps (0 = first kept sample).
    pub at: usize,
    /// Size of the jump (PV units).
    pub size: f64,
}

/// The set point: eq. (12) random walk plus scheduled steps, starting at `pv_bias`.
///
/// | field | default | meaning | valid |
/// |-------|---------|---------|-------|
/// | `step` | 2 | Δ: a switch moves SP by `Δ (R2 - 0.5)` | finite |
/// | `switch_probability` | 0.05 | δ_sw: probability of a switch per sample | `[0, 1]` |
/// | `steps` | `[]` | scheduled steps in kept-record samples | finite sizes |
///
/// `switch_probability = 0` (or `step = 0`) gives a constant set point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Setpoint {
    /// Δ of eq. (12).
    pub step: f64,
    /// δ_sw of eq. (12).
    pub switch_probability: f64,
    /// Scheduled steps.
    pub steps: Vec<SetpointStep>,
}

impl Default for Setpoint {
    fn default() -> Self {
        Setpoint {
            step: 2.0,
            switch_probability: 0.05,
            steps: Vec::new(),
        }
    }
}

impl Setpoint {
    /// A constant set point (no random walk, no steps).
    pub fn constant() -> Setpoint {
        Setpoint {
            step: 0.0,
            switch_probability: 0.0,
            steps: Vec::new(),
        }
    }
}

/// An external disturbance η. Time `k` is the sample index of the kept record (negative during
/// the warm-up), so `k = 0` is the first output row.
///
/// JSON: `{"kind": "paper", "a": 0.25}`, `{"kind": "sine", "amplitude": 1, "frequency": 0.05,
/// "phase": 0}`, `{"kind": "drift", "slope": 0.001}`, `{"kind": "step", "at": 1000, "size": 2}`,
/// `{"kind": "random-steps", "probability": 0.01, "sigma": 1}`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Disturbance {
    /// Eq. (11): `a (sin(0.03 k) + 0.5 sin(0.07 k))`, `a >= 0`.
    Paper {
        /// Amplitude `a`.
        a: f64,
    },
    /// `amplitude · sin(frequency · k + phase)`, frequency in rad/sample.
    Sine {
        /// Amplitude.
        amplitude: f64,
        /// Angular frequency, rad/sample.
        frequency: f64,
        /// Phase, rad (default 0).
        #[serde(default)]
        phase: f64,
    },
    /// `slope · k` (zero at the first kept sample).
    Drift {
        /// Slope per sample.
        slope: f64,
    },
    /// `size` from kept sample `at` on.
    Step {
        /// First kept sample with the step.
        at: usize,
        /// Step size.
        size: f64,
    },
    /// A level that jumps by `N(0, sigma²)` with probability `probability` at every sample
    /// (warm-up included), starting at 0.
    RandomSteps {
        /// Jump probability per sample, `[0, 1]`.
        probability: f64,
        /// Standard deviation of a jump, `>= 0`.
        sigma: f64,
    },
}

/// Where η enters the loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DisturbanceEntry {
    /// Inside the difference equation, as in the paper's eq. (10) (default).
    #[default]
    Equation,
    /// Added to the plant output (`PV = pv_bias + y + η`), as in spec §6.2.
    Output,
}

/// A closed-loop benchmark simulation.
///
/// | field | default | meaning | valid |
/// |-------|---------|---------|-------|
/// | `plant` | `"paper"` | [`PlantSpec`] | see [`Plant`] |
/// | `controller` | `{kc: 0.5, ki: 0.5}` | [`Controller`] | finite, stable closed loop (B3) |
/// | `setpoint` | Δ = 2, δ = 0.05 | [`Setpoint`] | |
/// | `valve` | `{"kind": "kano", "S": 0, "J": 0}` (linear valve) | any registered stiction model | the model's own checks |
/// | `valve_init` | at rest after moving down | [`InitialState`] at `k = 0` and at the first kept sample | |
/// | `disturbances` | `[]` | [`Disturbance`]s, summed | finite; probabilities in `[0, 1]` |
/// | `disturbance_entry` | `"equation"` | [`DisturbanceEntry`] | |
/// | `noise_sigma` | 0.1 | σ_e of the white noise `e` | `>= 0` |
/// | `samples` | 3000 | samples kept | `>= 1`, `samples + warmup <= 5e7` |
/// | `warmup` | 500 | samples simulated first and discarded | |
/// | `seed` | 1 | RNG seed | |
/// | `op_bias` | 50 | OP (and MV) operating point, % | finite |
/// | `pv_bias` | 50 | PV (and initial SP) operating point | finite |
/// | `op_limits` | none | `[lo, hi]` OP clipping with conditional integration | `lo < hi` |
/// | `sample_time` | 1 | seconds per sample, for the `t` column | `> 0` |
/// | `characteristic` | none (linear valve) | the installed flow [`Characteristic`] between the valve position MV and the plant: `u = (100/a) (e^(a (MV - op_bias)/100) - 1)`, the same local gain as a linear valve at `op_bias` | see [`Characteristic`] |
/// | `plant_change` | none | another plant from kept sample `at` on ([`PlantChange`]: a process that changes during the record, e.g. fouling; the signals carry over) | a valid plant, the loop stable with it |
/// | `travel_limit` | none | the valve cannot pass this position (% of span): `MV = min(f(OP), L)`, `f` the valve model | finite |
/// | `pv_compression` | none | the logged PV as a historian's swinging-door archive with this deviation (PV units), read back by linear interpolation ([`swinging_door`]); the loop itself runs on the true PV | `> 0` |
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scenario {
    /// The plant.
    pub plant: PlantSpec,
    /// PI gains.
    pub controller: Controller,
    /// Set point.
    pub setpoint: Setpoint,
    /// The valve: any registered stiction model (`{"kind": "kano", "S": 9, "J": 3}`).
    pub valve: Box<dyn StictionModel>,
    /// The valve's initial state.
    pub valve_init: InitialState,
    /// External disturbances η (summed).
    pub disturbances: Vec<Disturbance>,
    /// Where η enters.
    pub disturbance_entry: DisturbanceEntry,
    /// σ_e of the white noise.
    pub noise_sigma: f64,
    /// Number of samples kept.
    pub samples: usize,
    /// Number of samples simulated and discarded first.
    pub warmup: usize,
    /// RNG seed.
    pub seed: u64,
    /// OP operating point (%): `OP(-1)` and the MV at which the plant's deviation `u` is 0.
    pub op_bias: f64,
    /// PV operating point: `PV = pv_bias + y`; also the initial set point.
    pub pv_bias: f64,
    /// Optional OP clipping `[lo, hi]`: OP is clamped, and while OP sits at a limit the
    /// integral term is dropped when it pushes further out (conditional integration).
    pub op_limits: Option<[f64; 2]>,
    /// Seconds per sample.
    pub sample_time: f64,
    /// Log PV through a swinging-door archive with this deviation ([`swinging_door`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pv_compression: Option<f64>,
    /// The installed flow characteristic between MV and the plant (none: linear).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub characteristic: Option<Characteristic>,
    /// A change of the process during the record (none: the plant never changes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plant_change: Option<PlantChange>,
    /// The valve cannot pass this position (% of span): `MV = min(f(OP), L)` (none: no
    /// limit).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub travel_limit: Option<f64>,
}

/// The plant replaced by `plant` from kept sample `at` on; the past inputs, outputs and noise
/// carry over (the process changes, the signals do not jump).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlantChange {
    /// First kept sample of the new plant.
    pub at: usize,
    /// The new plant.
    pub plant: Plant,
}

/// An installed flow characteristic: a static monotone map from the valve position MV (% of
/// span) to what the process sees.
///
/// Every kind is the exponential family `f_a(x) = 100 (e^(a x/100) - 1) / (e^a - 1)` of
/// `stiction_models::characteristic` (the model `kano-char` fits): an equal-percentage valve
/// `100 R^(x/100 - 1)` of rangeability `R` is `a = ln R` up to an offset and a scale, and the
/// quick-opening valve here is its mirror image `100 - f_a(100 - x)`, i.e. `a = -ln R`. The
/// plant's deviation input is `u = (f_a(MV) - f_a(op_bias)) / f_a'(op_bias)
/// = (100/a) (e^(a (MV - op_bias)/100) - 1)`: the local gain at the operating point is the
/// linear valve's, and it changes by the factor `e^(a Δ/100)` over `Δ` % of opening.
///
/// JSON: `{"kind": "equal-percentage", "rangeability": 50}`, `{"kind": "quick-opening",
/// "rangeability": 20}`, `{"kind": "exponential", "a": 3.2}`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Characteristic {
    /// Equal-percentage, `a = ln R` (rangeability `R > 1`, typically 20-50).
    EqualPercentage {
        /// Rangeability R.
        rangeability: f64,
    },
    /// Quick-opening, the mirror image of equal-percentage: `a = -ln R`.
    QuickOpening {
        /// Rangeability R.
        rangeability: f64,
    },
    /// The family directly: `a > 0` equal-percentage-like, `a < 0` quick-opening-like, 0 linear.
    Exponential {
        /// Shape a, `|a| <= 20`.
        a: f64,
    },
}

impl Characteristic {
    /// The shape `a` of the exponential family.
    pub fn shape(&self) -> f64 {
        match *self {
            Characteristic::EqualPercentage { rangeability } => rangeability.ln(),
            Characteristic::QuickOpening { rangeability } => -rangeability.ln(),
            Characteristic::Exponential { a } => a,
        }
    }

    /// The plant's deviation input for the valve position's deviation `dx = MV - op_bias`.
    pub fn deviation(&self, dx: f64) -> f64 {
        let a = self.shape();
        if a == 0.0 {
            dx
        } else {
            100.0 / a * (a * dx / 100.0).exp_m1()
        }
    }

    fn validate(&self) -> Result<(), DataError> {
        match *self {
            Characteristic::EqualPercentage { rangeability }
            | Characteristic::QuickOpening { rangeability } => param(
                "characteristic.rangeability",
                rangeability,
                rangeability > 1.0 && rangeability.ln() <= stiction_models::MAX_SHAPE,
                "1 < R <= e^20",
            ),
            Characteristic::Exponential { a } => param(
                "characteristic.a",
                a,
                a.abs() <= stiction_models::MAX_SHAPE,
                "|a| <= 20",
            ),
        }
    }
}

impl Default for Scenario {
    fn default() -> Self {
        Scenario {
            plant: PlantSpec::default(),
            controller: Controller::default(),
            setpoint: Setpoint::default(),
            valve: Box::new(
                Kano::params()
                    .check()
                    .expect("S = J = 0 is a valid Kano valve"),
            ),
            valve_init: InitialState::default(),
            disturbances: Vec::new(),
            disturbance_entry: DisturbanceEntry::default(),
            noise_sigma: 0.1,
            samples: 3000,
            warmup: 500,
            seed: 1,
            op_bias: 50.0,
            pv_bias: 50.0,
            op_limits: None,
            sample_time: 1.0,
            pv_compression: None,
            characteristic: None,
            plant_change: None,
            travel_limit: None,
        }
    }
}

/// The output of [`Scenario::simulate`]: the kept samples and what produced them.
#[derive(Debug, Clone, Serialize)]
pub struct SimulatedLoop {
    /// Time, `k · sample_time` for kept sample `k`.
    pub t: Vec<f64>,
    /// Set point.
    pub sp: Vec<f64>,
    /// Process variable.
    pub pv: Vec<f64>,
    /// Controller output.
    pub op: Vec<f64>,
    /// Valve position (ground truth).
    pub mv: Vec<f64>,
    /// The disturbance η actually injected.
    pub disturbance: Vec<f64>,
    /// The white noise `e`.
    pub noise: Vec<f64>,
    /// The scenario that produced this record.
    pub scenario: Scenario,
}

/// Upper bound on `samples + warmup` (memory: about 100 bytes per sample).
const MAX_SAMPLES: usize = 50_000_000;

fn param(name: &str, value: f64, ok: bool, expected: &str) -> Result<(), DataError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(DataError::InvalidParameter {
            name: name.to_string(),
            value,
            expected: expected.to_string(),
        })
    }
}

impl Scenario {
    /// Loop `seed` of the benchmark fleet (`grid-search`'s `fleet` bench and `profile_fleet`
    /// example): the default scenario with that seed and a Kano valve with
    /// `S = 1 + (7919 seed mod 1100) / 100` in [1, 12] and
    /// `J = min(S, (104729 seed mod 400) / 100)` in [0, 4], reproducible per seed.
    pub fn fleet(seed: u64) -> Scenario {
        let s = 1.0 + (seed.wrapping_mul(7919) % 1100) as f64 / 100.0;
        let j = (seed.wrapping_mul(104_729) % 400) as f64 / 100.0;
        Scenario {
            valve: Box::new(
                Kano::params()
                    .s(s)
                    .j(j.min(s))
                    .check()
                    .expect("S in [1, 12] and 0 <= J <= S are valid"),
            ),
            seed,
            ..Scenario::default()
        }
    }

    /// Parse a scenario from JSON (unknown fields are rejected; missing ones take their
    /// defaults) and [validate](Scenario::validate) it.
    pub fn from_json(json: &str) -> Result<Scenario, DataError> {
        let s: Scenario = serde_json::from_str(json).map_err(|e| DataError::Config {
            message: e.to_string(),
        })?;
        s.validate()?;
        Ok(s)
    }

    /// The scenario as pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }

    /// Check every setting (the valve's own parameters are checked when it is built).
    pub fn validate(&self) -> Result<(), DataError> {
        self.plant.plant().validate()?;
        let c = &self.controller;
        param("controller.kc", c.kc, true, "a finite number")?;
        param("controller.ki", c.ki, true, "a finite number")?;
        let sp = &self.setpoint;
        param("setpoint.step", sp.step, true, "a finite number")?;
        let p = sp.switch_probability;
        param(
            "setpoint.switch_probability",
            p,
            (0.0..=1.0).contains(&p),
            "0 <= p <= 1",
        )?;
        for s in &sp.steps {
            param("setpoint.steps.size", s.size, true, "a finite number")?;
        }
        for d in &self.disturbances {
            match *d {
                Disturbance::Paper { a } => param("disturbances.a", a, a >= 0.0, "a >= 0")?,
                Disturbance::Sine {
                    amplitude,
                    frequency,
                    phase,
                } => {
                    param("disturbances.amplitude", amplitude, true, "a finite number")?;
                    param("disturbances.frequency", frequency, true, "a finite number")?;
                    param("disturbances.phase", phase, true, "a finite number")?;
                }
                Disturbance::Drift { slope } => {
                    param("disturbances.slope", slope, true, "a finite number")?
                }
                Disturbance::Step { size, .. } => {
                    param("disturbances.size", size, true, "a finite number")?
                }
                Disturbance::RandomSteps { probability, sigma } => {
                    let ok = (0.0..=1.0).contains(&probability);
                    param("disturbances.probability", probability, ok, "0 <= p <= 1")?;
                    param("disturbances.sigma", sigma, sigma >= 0.0, "sigma >= 0")?;
                }
            }
        }
        let s = self.noise_sigma;
        param("noise_sigma", s, s >= 0.0, "sigma >= 0")?;
        param(
            "samples",
            self.samples as f64,
            self.samples >= 1,
            "at least 1",
        )?;
        let total = self.samples.saturating_add(self.warmup);
        param(
            "samples + warmup",
            total as f64,
            total <= MAX_SAMPLES,
            "at most 50000000 samples in all",
        )?;
        param("op_bias", self.op_bias, true, "a finite number")?;
        param("pv_bias", self.pv_bias, true, "a finite number")?;
        let ts = self.sample_time;
        param("sample_time", ts, ts > 0.0, "a positive number of seconds")?;
        if let Some(l) = self.travel_limit {
            param("travel_limit", l, true, "a finite position")?;
        }
        if let Some(dev) = self.pv_compression {
            param("pv_compression", dev, dev > 0.0, "a positive deviation")?;
        }
        if let Some([lo, hi]) = self.op_limits {
            param("op_limits[0]", lo, lo < hi, "lo < hi, both finite")?;
            param("op_limits[1]", hi, true, "lo < hi, both finite")?;
        }
        if let Some(c) = &self.characteristic {
            c.validate()?;
        }
        if let Some(c) = &self.plant_change {
            c.plant.validate()?;
        }
        self.valve_init.validate()?;
        Ok(())
    }

    /// Run the simulation (validates first, then checks closed-loop stability, B3).
    pub fn simulate(&self) -> Result<SimulatedLoop, DataError> {
        self.validate()?;
        let plant = self.plant.plant();
        let Controller { kc, ki } = self.controller;
        plant.check_stability(kc, ki)?;
        if let Some(c) = &self.plant_change {
            c.plant.check_stability(kc, ki)?;
        }

        let total = self.warmup + self.samples;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut y = vec![0.0; total];
        let mut u = vec![0.0; total];
        let mut e = vec![0.0; total];
        let mut out = SimulatedLoop {
            t: (0..self.samples)
                .map(|k| k as f64 * self.sample_time)
                .collect(),
            sp: Vec::with_capacity(self.samples),
            pv: Vec::with_capacity(self.samples),
            op: Vec::with_capacity(self.samples),
            mv: Vec::with_capacity(self.samples),
            disturbance: Vec::with_capacity(self.samples),
            noise: Vec::with_capacity(self.samples),
            scenario: self.clone(),
        };
        let mut levels = vec![0.0; self.disturbances.len()];
        let (mut sp_prev, mut op_prev, mut err_prev) = (self.pv_bias, self.op_bias, 0.0);
        let mut valve: Option<Box<dyn ValveState>> = None;
        let delta = self.setpoint.step;
        let threshold = 1.0 - self.setpoint.switch_probability;

        for k in 0..total {
            let kr = k as i64 - self.warmup as i64; // index in the kept record
                                                    // 1. random numbers, fixed order
            let r1: f64 = rng.random();
            let r2: f64 = rng.random();
            let z: f64 = rng.sample(StandardNormal);
            for (level, d) in levels.iter_mut().zip(&self.disturbances) {
                let switch: f64 = rng.random();
                let size: f64 = rng.sample(StandardNormal);
                if let Disturbance::RandomSteps { probability, sigma } = *d {
                    if switch < probability {
                        *level += sigma * size;
                    }
                }
            }
            // 2. set point
            let mut sp = sp_prev;
            if r1 > threshold {
                sp += delta * (r2 - 0.5);
            }
            for s in &self.setpoint.steps {
                if kr == s.at as i64 {
                    sp += s.size;
                }
            }
            // 3. plant
            e[k] = self.noise_sigma * z;
            let eta: f64 = self
                .disturbances
                .iter()
                .zip(&levels)
                .map(|(d, level)| d.value(kr, *level))
                .sum();
            let plant = match &self.plant_change {
                Some(c) if kr >= c.at as i64 => &c.plant,
                _ => &plant,
            };
            let mut yk = plant.output(k, &y, &u, &e);
            let pv = match self.disturbance_entry {
                DisturbanceEntry::Equation => {
                    yk += eta;
                    self.pv_bias + yk
                }
                DisturbanceEntry::Output => self.pv_bias + yk + eta,
            };
            y[k] = yk;
            if !pv.is_finite() {
                return Err(DataError::Diverged {
                    signal: "PV",
                    sample: k,
                });
            }
            // 4. controller
            let err = sp - pv;
            let integral = ki * err;
            let mut op = op_prev + kc * (err - err_prev) + integral;
            if let Some([lo, hi]) = self.op_limits {
                // Conditional integration: while OP sits at a limit, the integral term may not
                // push it further out (it may still pull it back in).
                if (op_prev >= hi && integral > 0.0) || (op_prev <= lo && integral < 0.0) {
                    op -= integral;
                }
                op = op.clamp(lo, hi);
            }
            if !op.is_finite() {
                return Err(DataError::Diverged {
                    signal: "OP",
                    sample: k,
                });
            }
            // 5. valve
            let mv = match valve.as_mut() {
                Some(state) if k != self.warmup => state.step(op),
                _ => {
                    let state = self.valve.start(op, &self.valve_init)?;
                    let mv = state.position();
                    valve = Some(state);
                    mv
                }
            };
            // a travel limit: the valve stops at L
            let mv = self.travel_limit.map_or(mv, |l| mv.min(l));
            if !mv.is_finite() {
                return Err(DataError::Diverged {
                    signal: "MV",
                    sample: k,
                });
            }
            u[k] = match &self.characteristic {
                Some(c) => c.deviation(mv - self.op_bias),
                None => mv - self.op_bias,
            };
            if kr >= 0 {
                out.sp.push(sp);
                out.pv.push(pv);
                out.op.push(op);
                out.mv.push(mv);
                out.disturbance.push(eta);
                out.noise.push(e[k]);
            }
            sp_prev = sp;
            op_prev = op;
            err_prev = err;
        }
        if let Some(dev) = self.pv_compression {
            out.pv = swinging_door(&out.pv, dev).0;
        }
        Ok(out)
    }
}

impl Plant {
    /// The ARMAX output at sample `k` from the past outputs `y`, inputs `u` and noise `e`
    /// (`e[k]` included; samples before 0 are 0), without the disturbance.
    fn output(&self, k: usize, y: &[f64], u: &[f64], e: &[f64]) -> f64 {
        let mut yk = e[k];
        for (i, ai) in self.a.iter().enumerate().skip(1) {
            if let Some(j) = k.checked_sub(i) {
                yk -= ai * y[j];
            }
        }
        for (i, bi) in self.b.iter().enumerate() {
            if let Some(j) = k.checked_sub(i + self.delay) {
                yk += bi * u[j];
            }
        }
        for (i, ci) in self.c.iter().enumerate().skip(1) {
            if let Some(j) = k.checked_sub(i) {
                yk += ci * e[j];
            }
        }
        yk
    }
}

impl Disturbance {
    /// η contribution at kept-record sample `k`; `level` is the state of a random-steps term.
    fn value(&self, k: i64, level: f64) -> f64 {
        let kf = k as f64;
        match *self {
            Disturbance::Paper { a } => a * ((0.03 * kf).sin() + 0.5 * (0.07 * kf).sin()),
            Disturbance::Sine {
                amplitude,
                frequency,
                phase,
            } => amplitude * (frequency * kf + phase).sin(),
            Disturbance::Drift { slope } => slope * kf,
            Disturbance::Step { at, size } => {
                if k >= at as i64 {
                    size
                } else {
                    0.0
                }
            }
            Disturbance::RandomSteps { .. } => level,
        }
    }
}

/// A historian's swinging-door compression of `x` with deviation `dev`, read back by linear
/// interpolation between the kept points (what a historian client returns for a compressed
/// tag): `(values, kept points)`. A point is kept when no straight line from the last kept
/// point stays within `dev` of every sample since (the door closes); the first and last
/// samples are always kept.
pub fn swinging_door(x: &[f64], dev: f64) -> (Vec<f64>, usize) {
    let n = x.len();
    if n < 3 {
        return (x.to_vec(), n);
    }
    let mut kept = vec![0usize];
    let mut a = 0usize;
    while a + 1 < n {
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        let mut j = a + 1;
        while j < n {
            let d = (j - a) as f64;
            hi = hi.min((x[j] + dev - x[a]) / d);
            lo = lo.max((x[j] - dev - x[a]) / d);
            if lo > hi {
                break;
            }
            j += 1;
        }
        let k = (j - 1).max(a + 1).min(n - 1);
        kept.push(k);
        a = k;
    }
    let mut out = vec![0.0; n];
    for w in kept.windows(2) {
        let (a, b) = (w[0], w[1]);
        for (t, o) in out.iter_mut().enumerate().take(b + 1).skip(a) {
            let f = (t - a) as f64 / (b - a) as f64;
            *o = x[a] + f * (x[b] - x[a]);
        }
    }
    (out, kept.len())
}

impl SimulatedLoop {
    /// The sample standard deviation of the control error `SP - PV` from sample `from` on.
    pub fn error_std(&self, from: usize) -> f64 {
        let e: Vec<f64> = self.sp[from..]
            .iter()
            .zip(&self.pv[from..])
            .map(|(a, b)| a - b)
            .collect();
        let m = e.iter().sum::<f64>() / e.len() as f64;
        (e.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (e.len() - 1) as f64).sqrt()
    }

    /// Number of kept samples.
    pub fn len(&self) -> usize {
        self.op.len()
    }

    /// Whether no sample was kept.
    pub fn is_empty(&self) -> bool {
        self.op.is_empty()
    }

    /// Fraction of samples `k >= 1` at which the valve did not move (`MV(k) = MV(k-1)`).
    pub fn stuck_fraction(&self) -> f64 {
        if self.mv.len() < 2 {
            return 0.0;
        }
        let stuck = self.mv.windows(2).filter(|w| w[1] == w[0]).count();
        stuck as f64 / (self.mv.len() - 1) as f64
    }

    /// The line `stiction simulate` prints about this simulation of `scenario`.
    pub fn summary(&self, scenario: &Scenario) -> String {
        let eq = scenario.valve.equivalent();
        format!(
            "simulated {} samples (warm-up {} discarded), seed {}: valve {} (S = {}, J = {}), stuck at {:.1} % of samples",
            self.len(),
            scenario.warmup,
            scenario.seed,
            scenario.valve.name(),
            eq.s,
            eq.j,
            100.0 * self.stuck_fraction()
        )
    }

    /// Write CSV with the header `t,SP,PV,OP,MV` (numbers in Rust's shortest round-trip
    /// format, so reading the file back gives the same values).
    pub fn write_csv(&self, mut w: impl std::io::Write) -> std::io::Result<()> {
        writeln!(w, "t,SP,PV,OP,MV")?;
        for k in 0..self.len() {
            writeln!(
                w,
                "{},{},{},{},{}",
                self.t[k], self.sp[k], self.pv[k], self.op[k], self.mv[k]
            )?;
        }
        w.flush()
    }

    /// The record as [`LoopData`] (with MV measured), source `simulation`.
    pub fn to_loop_data(&self) -> LoopData {
        LoopData {
            source: "simulation".into(),
            start: None,
            t: Some(self.t.clone()),
            sp: Some(self.sp.clone()),
            pv: Some(self.pv.clone()),
            op: self.op.clone(),
            mv: Some(self.mv.clone()),
            notes: vec![crate::Note::new(
                crate::NoteKind::Source,
                format!(
                    "simulated: seed {}, {} samples after a warm-up of {}",
                    self.scenario.seed, self.scenario.samples, self.scenario.warmup
                ),
            )],
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests;
