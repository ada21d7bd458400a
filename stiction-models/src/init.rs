//! Initial valve states and the paper's three initialization strategies In.1, In.2, In.3.

use serde::{Deserialize, Serialize};

use crate::{check_finite, Runs, StictionError, StictionModel};

/// Direction of the valve's most recent motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// MV increasing (`d = +1`).
    Up,
    /// MV decreasing (`d = -1`).
    Down,
}

/// The valve's state at sample 0 (Kano's auxiliary variables `d`, `stp`, `u_s` and `MV(0)`).
///
/// | field | Kano variable | default | meaning |
/// |-------|---------------|---------|---------|
/// | `direction` | `d0` | down | direction of the last motion |
/// | `stuck` | `stp0` | true | at rest (`stp0 = 1`) or moving (`stp0 = 0`) |
/// | `stuck_at` | `u_s0` | `OP(0)` | OP value where the valve stopped (used only when stuck) |
/// | `position` | `MV(0)` | consistent | `u_s0 - d0 (S-J)/2` when stuck, `OP(0) - d0 (S-J)/2` when moving |
///
/// The default is the specification's `CodeDefault` preset: the valve is at rest at `OP(0)`
/// after moving down, so the first upward motion needs an OP rise `> S` and the first downward
/// one `> J`. With `stuck = true` the Kano update is exactly the specification's `KANO_INIT`
/// (`du_prev = 0`). A *moving* start (`stuck = false`) is ours: the previous OP increment is
/// taken to have the sign of `direction`, so the valve keeps moving while OP keeps going that
/// way. (With the specification's `du_prev = 0` a moving start would stop at sample 1 and be
/// indistinguishable from a stuck one, whereas the paper's Fig. 4 shows four distinct
/// sequences for the four `(stp, d)` combinations.)
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InitialState {
    /// Direction of the last motion (`d0`).
    pub direction: Direction,
    /// At rest (`stp0 = 1`) or moving.
    pub stuck: bool,
    /// Where the valve stopped, in OP units (`u_s0`); `None` = `OP(0)`.
    pub stuck_at: Option<f64>,
    /// Valve position at sample 0 (`MV(0)`); `None` = the consistent value.
    pub position: Option<f64>,
}

impl Default for InitialState {
    fn default() -> Self {
        InitialState {
            direction: Direction::Down,
            stuck: true,
            stuck_at: None,
            position: None,
        }
    }
}

impl InitialState {
    /// At rest after moving up (the specification's golden-vector start, preset `Up`).
    pub fn up() -> Self {
        InitialState {
            direction: Direction::Up,
            ..Self::default()
        }
    }
    /// At rest after moving down (preset `CodeDefault`, the default).
    pub fn down() -> Self {
        Self::default()
    }
    /// The four `(stp, d)` combinations used by In.2 and In.3: stuck/moving × up/down.
    pub fn four_variants() -> [InitialState; 4] {
        let mk = |direction, stuck| InitialState {
            direction,
            stuck,
            stuck_at: None,
            position: None,
        };
        [
            mk(Direction::Down, true),
            mk(Direction::Up, true),
            mk(Direction::Down, false),
            mk(Direction::Up, false),
        ]
    }
    /// Reject non-finite explicit values.
    pub fn validate(&self) -> Result<(), StictionError> {
        for (name, v) in [("stuck_at", self.stuck_at), ("position", self.position)] {
            if let Some(v) = v {
                if !v.is_finite() {
                    return Err(StictionError::InvalidInit(format!(
                        "{name} = {v} must be a finite number"
                    )));
                }
            }
        }
        Ok(())
    }

    /// [`InitialState::validate`], then a finite `OP(0)`: the checks of a model's start.
    pub(crate) fn validate_at(&self, op0: f64) -> Result<(), StictionError> {
        self.validate()?;
        if !op0.is_finite() {
            return Err(StictionError::NonFiniteInput {
                index: 0,
                value: op0,
            });
        }
        Ok(())
    }

    /// The start of a Kano-type valve whose moving position lags OP by `offset`: the sign `d`
    /// of the last motion, the OP `u_s` where the valve stopped and `MV(0)` (the given
    /// position, else `u_s - d offset` when stuck and `OP(0) - d offset` when moving).
    pub(crate) fn kano_start(&self, op0: f64, offset: f64) -> (f64, f64, f64) {
        let d = self.direction.sign();
        let u_s = self.stuck_at.unwrap_or(op0);
        let mv0 = self.position.unwrap_or(if self.stuck {
            u_s - d * offset
        } else {
            op0 - d * offset
        });
        (d, u_s, mv0)
    }
}

/// How the model's unknown initial state is handled (paper §2.4).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "strategy", deny_unknown_fields)]
pub enum Initialization {
    /// In.1: one arbitrary initial state, the same for every parameter set.
    #[serde(rename = "In.1")]
    In1(InitialState),
    /// In.2: the average of the four `(stp, d)` sequences, used after a stationary time fixed a
    /// priori as a fraction of the record (the paper uses one tenth).
    #[serde(rename = "In.2")]
    In2 {
        /// Fraction of the record discarded, in `[0, 1)`.
        stationary_fraction: f64,
    },
    /// In.3 (default): the stationary time is the first sample after which the four
    /// sequences coincide; only MV from there on is used. Falls back to In.2 with a tenth of
    /// the record when they never coincide.
    #[serde(rename = "In.3")]
    #[default]
    In3,
}

impl Initialization {
    /// The paper's In.2 with a stationary time of one tenth of the record.
    pub const IN2_DEFAULT_FRACTION: f64 = 0.1;

    /// Parse `In.1`, `In.2`, `In.3` (case-insensitive, the dot optional); In.1 uses the default
    /// [`InitialState`].
    pub fn parse(s: &str) -> Option<Initialization> {
        match s.to_ascii_lowercase().replace('.', "").as_str() {
            "in1" => Some(Initialization::In1(InitialState::default())),
            "in2" => Some(Initialization::In2 {
                stationary_fraction: Self::IN2_DEFAULT_FRACTION,
            }),
            "in3" => Some(Initialization::In3),
            _ => None,
        }
    }

    /// The paper's label: `In.1`, `In.2` or `In.3`.
    pub fn label(&self) -> &'static str {
        match self {
            Initialization::In1(_) => "In.1",
            Initialization::In2 { .. } => "In.2",
            Initialization::In3 => "In.3",
        }
    }
}

/// MV for a whole OP record under an initialization strategy.
#[derive(Debug, Clone, PartialEq)]
pub struct ValveRun {
    /// The valve position for every sample. Before `valid_from` it is, for In.2 and In.3, the
    /// average of the four sequences (which then still differ).
    pub mv: Vec<f64>,
    /// First sample whose MV does not depend on the unknown initial state (0 for In.1).
    pub valid_from: usize,
    /// In.3 only: the four sequences never coincided and In.2 was used instead.
    pub fell_back: bool,
}

impl ValveRun {
    /// For In.2 and In.3 (`init`), the sentence saying from which sample MV no longer depends
    /// on the valve's initial state (and when In.3 fell back to In.2); `None` for In.1.
    ///
    /// ```
    /// use stiction_models::{run_valve, Initialization, Kano};
    /// let valve = Kano::params().s(4.0).j(1.0).check()?;
    /// let op: Vec<f64> = (0..300).map(|k| 50.0 + 5.0 * (k as f64 * 0.1).sin()).collect();
    /// let run = run_valve(&valve, &op, &Initialization::In3)?;
    /// let note = run.start_note(&Initialization::In3).unwrap_or_default();
    /// assert!(note.starts_with("In.3: MV does not depend on the valve's initial state from sample"));
    /// let in1 = Initialization::In1(Default::default());
    /// assert_eq!(run_valve(&valve, &op, &in1)?.start_note(&in1), None);
    /// # Ok::<(), stiction_models::StictionError>(())
    /// ```
    pub fn start_note(&self, init: &Initialization) -> Option<String> {
        if matches!(init, Initialization::In1(_)) {
            return None;
        }
        let how = if self.fell_back {
            " the four starts never coincide (fell back to In.2);"
        } else {
            ""
        };
        Some(format!(
            "{}:{how} MV does not depend on the valve's initial state from sample {} on (0-based); before it, MV is the average of the four starts",
            init.label(),
            self.valid_from
        ))
    }
}

/// Reusable buffers for [`run_valve_with`]: a grid search keeps one per thread so that the
/// thousands of valve runs it makes allocate nothing.
#[derive(Debug, Clone, Default)]
pub struct ValveScratch {
    pub(crate) runs: [Vec<f64>; 4],
    /// The intervals of the event-driven runs ([`crate::run_valve_indexed`]).
    pub(crate) segs: [Vec<crate::events::Seg>; 4],
    /// The MV of the last run (see [`ValveRun::mv`]).
    pub mv: Vec<f64>,
}

/// [`ValveRun`] without the MV, which [`run_valve_with`] leaves in [`ValveScratch::mv`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunInfo {
    /// See [`ValveRun::valid_from`].
    pub valid_from: usize,
    /// See [`ValveRun::fell_back`].
    pub fell_back: bool,
}

/// Run `model` over `op` under `init`.
///
/// For In.3 two sequences coincide at a sample when they differ by at most
/// `1e-12 · max(1, |MV|)`; in practice they are bit-identical once both valves move in the
/// same direction, because MV is then a function of OP alone.
pub fn run_valve(
    model: &dyn StictionModel,
    op: &[f64],
    init: &Initialization,
) -> Result<ValveRun, StictionError> {
    let mut scratch = ValveScratch::default();
    let info = run_valve_with(model, op, init, &mut scratch)?;
    Ok(ValveRun {
        mv: scratch.mv,
        valid_from: info.valid_from,
        fell_back: info.fell_back,
    })
}

/// [`run_valve`] into reusable buffers: the MV is left in `scratch.mv`.
pub fn run_valve_with(
    model: &dyn StictionModel,
    op: &[f64],
    init: &Initialization,
    scratch: &mut ValveScratch,
) -> Result<RunInfo, StictionError> {
    check_finite(op)?;
    let n = op.len();
    scratch.mv.resize(n, 0.0);
    match init {
        Initialization::In1(state) => {
            model.simulate_into(op, state, &mut scratch.mv)?;
            Ok(RunInfo::without_fallback(0))
        }
        Initialization::In2 {
            stationary_fraction,
        } => {
            let info = RunInfo::without_fallback(in2_valid_from(*stationary_fraction, n)?);
            let merge = four_runs(model, op, &mut scratch.runs)?;
            average_into(&scratch.runs, merge, &mut scratch.mv);
            Ok(info)
        }
        Initialization::In3 => {
            let merge = four_runs(model, op, &mut scratch.runs)?;
            let info = RunInfo::in3(in3_valid_from(&scratch.runs, merge, n), n);
            average_into(&scratch.runs, merge, &mut scratch.mv);
            Ok(info)
        }
    }
}

/// In.2's stationary time on `n` samples: the first sample past the fraction, or the error of
/// a fraction outside [0, 1).
pub(crate) fn in2_valid_from(stationary_fraction: f64, n: usize) -> Result<usize, StictionError> {
    if !(0.0..1.0).contains(&stationary_fraction) {
        return Err(StictionError::InvalidInit(format!(
            "In.2 stationary fraction {stationary_fraction} must be in [0, 1)"
        )));
    }
    Ok((stationary_fraction * n as f64).ceil() as usize)
}

impl RunInfo {
    /// A run valid from `valid_from` on, without fallback (In.1: 0; In.2).
    pub(crate) fn without_fallback(valid_from: usize) -> Self {
        RunInfo {
            valid_from,
            fell_back: false,
        }
    }

    /// In.3's answer from the sample after the last one where the four runs differ (`n`:
    /// they never coincide, and it falls back to In.2's default fraction).
    pub(crate) fn in3(valid_from: usize, n: usize) -> Self {
        let fell_back = n > 0 && valid_from == n;
        let valid_from = if fell_back {
            (Initialization::IN2_DEFAULT_FRACTION * n as f64).ceil() as usize
        } else {
            valid_from
        };
        RunInfo {
            valid_from,
            fell_back,
        }
    }
}

/// In.3's stationary time before the fallback ([`RunInfo::in3`]): the sample after the last
/// one (before `merge`) where the four runs differ by more than `1e-12 · max(1, |MV|)`.
pub(crate) fn in3_valid_from(runs: &[Vec<f64>; 4], merge: usize, n: usize) -> usize {
    let mut valid_from = 0;
    for k in (0..merge.min(n)).rev() {
        let first = runs[0][k];
        let tol = 1e-12 * first.abs().max(1.0);
        if runs[1..].iter().any(|r| (r[k] - first).abs() > tol) {
            valid_from = k + 1;
            break;
        }
    }
    valid_from
}

/// The runs from the four `(stp, d)` starts of In.2 and In.3 into `out`; the merge sample
/// ([`crate::FastPaths::simulate_starts`]).
fn four_runs(
    model: &dyn StictionModel,
    op: &[f64],
    out: &mut [Vec<f64>],
) -> Result<usize, StictionError> {
    let starts = InitialState::four_variants();
    model.simulate_starts(&mut Runs {
        op,
        starts: &starts,
        out,
    })
}

/// The average of the four runs where they differ (before `merge`), the common value elsewhere.
pub(crate) fn average_into(runs: &[Vec<f64>], merge: usize, mv: &mut [f64]) {
    mv.copy_from_slice(&runs[0][..mv.len()]);
    for (k, m) in mv.iter_mut().enumerate().take(merge) {
        let first = *m;
        if runs[1..].iter().any(|r| r[k] != first) {
            *m = runs.iter().map(|r| r[k]).sum::<f64>() / runs.len() as f64;
        }
    }
}
