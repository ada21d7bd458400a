//! What a valve repair would buy, from the identified Hammerstein loop.
//!
//! A stiction index says how sticky a valve is; a planner needs to know what fixing it would
//! change. This crate answers that from a fitted loop model:
//!
//! 1. [`identify_controller`]: the controller, a PI or PID law in velocity form, from SP, PV and
//!    OP by least squares (Householder QR; the derivative term kept when it gains
//!    [`MIN_DERIVATIVE_GAIN`] points, a proportional law when the integral term comes out with
//!    the other sign),
//!    `ΔOP_k = θ_p Δe_{k-L} + θ_i e_{k-L} + θ_d Δ²e_{k-L}` with `e = SP − PV` and a timing lag
//!    `L` of 0 or 1 samples (a historian may stamp OP with the sample before or after the PV it
//!    answered). Samples where OP is pinned at its extreme are left out (the law does not act
//!    there). `kc = θ_p`, `ti = kc·Ts/θ_i`, `td = θ_d·Ts/kc`.
//! 2. [`assess`]: the same loop simulated twice, sample by sample: the identified controller
//!    drives the fitted valve ("now") or a free valve `MV = OP + c` ("repaired", `c` the
//!    valve's offset at the start, which the integral action absorbs anyway), the fitted linear
//!    model maps MV to PV, and both runs see the same set point and the same disturbance.
//!
//! # The disturbance that is replayed
//! The disturbance is what the deterministic part of the fitted model does not explain:
//! `v = y − G(q) MV̂`, with `MV̂` the fitted valve's position and `G(q)` the model's free-run
//! simulation from it. For a model `A y = B u + C e (+ β)` this is `v = (C e + β)/A`: the
//! identified residuals replayed through the model's own noise model (and the time-varying bias
//! of EARX/EARMAX), whatever the structure (polynomial or state space). Replayed this way the
//! "now" run reproduces the record exactly when the controller and the valve are exact
//! (`now_run_reproduces_the_record`), which is the check that the loop was identified: the
//! report carries the measured control error's spread beside the simulated one.
//!
//! # Integrating loops
//! When the model maps MV to ΔPV (an integrating loop), the runs integrate it: `PV_k = PV_{k-1}
//! + y_{k-1}`, with the model's sample `j` at the record's sample `j + 1` (as
//! `monitoring::registration::increments` lays it out).
//!
//! # What is reported
//! The control error's standard deviation now and repaired over the simulated samples, the
//! `reduction` `1 − σ_repaired/σ_now` clamped to `[0, 1]` (a repair that would not reduce the
//! error buys nothing; the two σ say by how much it would not), and the valve's reversals per
//! hour (direction changes of MV; wear) in both runs. A loop where this cannot be answered gets
//! a [`NoRepair`] with the reason: no set point, a controller in manual, a law that is not PI
//! (less than [`MIN_CONTROLLER_FIT`] % of ΔOP explained), an unstable or algebraic model, a
//! closed loop that diverges.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use stiction_models::{InitialState, StictionModel};

use linear_id::{LinearFit, Structure};

/// The controller law explains at least this share of ΔOP (%, the fit index of eq. 9 on ΔOP)
/// for the loop to be replayed. Below it more than half of the controller's moves come from
/// something the law does not see (an operator, a cascade master, a feed-forward), so a
/// simulated loop driven by the law is not this loop.
pub const MIN_CONTROLLER_FIT: f64 = 50.0;

/// The derivative term is kept when it raises the controller fit by at least this many points
/// (and gives `td > 0`); a significance test alone would keep it on any long record.
pub const MIN_DERIVATIVE_GAIN: f64 = 1.0;

/// Fewest usable samples for the controller's least squares.
pub const MIN_SAMPLES: usize = 20;

/// A "now" run whose control error spreads more than this factor above or below the record's
/// gets a note (what simulated twin loops give is in
/// `docs/decisions/2026-11-26-repair-audit.md`).
pub const LOOSE_REPLAY: f64 = 1.5;

/// A closed-loop run whose control error spreads this many times more than the record's is
/// taken as diverged (the identified loop is not stable, or not this loop).
pub const DIVERGENCE_RATIO: f64 = 20.0;

/// The controller's law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ControllerKind {
    /// Proportional only (`ti` infinite, JSON `null`).
    #[serde(rename = "P")]
    P,
    /// Proportional + integral.
    #[serde(rename = "PI")]
    Pi,
    /// Proportional + integral + derivative.
    #[serde(rename = "PID")]
    Pid,
}

/// An identified controller in velocity form.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Controller {
    /// PI or PID.
    pub kind: ControllerKind,
    /// Proportional gain `kc` (OP units per PV unit; negative for a direct-acting controller).
    pub kc: f64,
    /// Integral time `ti`, seconds (`kc·Ts/θ_i`; infinite, JSON `null`, without integral
    /// action).
    #[serde(deserialize_with = "null_as_inf")]
    pub ti: f64,
    /// Derivative time `td`, seconds (0 for PI).
    pub td: f64,
    /// Share of ΔOP the law explains, % (eq. 9 of the paper, squared norms, on ΔOP).
    pub fit: f64,
    /// Timing lag `L`, samples: OP answers the control error `L` samples earlier.
    pub lag: usize,
    /// Samples used in the least squares.
    pub samples: usize,
    /// `[θ_p, θ_i, θ_d]`, the velocity-form coefficients.
    pub theta: [f64; 3],
}

impl Controller {
    /// `ΔOP` of the law at sample `k` of the error series `e` (needs `k >= lag + 2`).
    fn delta(&self, e: &[f64], k: usize) -> f64 {
        let i = k - self.lag;
        let de = e[i] - e[i - 1];
        let d2e = e[i] - 2.0 * e[i - 1] + e[i - 2];
        self.theta[0] * de + self.theta[1] * e[i] + self.theta[2] * d2e
    }
}

/// Reads `null` (how JSON writes a non-finite number) as infinity.
fn null_as_inf<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::INFINITY))
}

/// What a repair of the valve would buy: the JSON object `repair` of the contract.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Repair {
    /// Standard deviation of the control error `SP − PV` with the valve as fitted (PV units).
    pub error_std_now: f64,
    /// The same with a free valve.
    pub error_std_repaired: f64,
    /// `1 − error_std_repaired / error_std_now`, clamped to `[0, 1]`.
    pub reduction: f64,
    /// Direction changes of the valve per hour, as fitted.
    pub reversals_per_hour_now: f64,
    /// The same with a free valve.
    pub reversals_per_hour_repaired: f64,
    /// The identified controller.
    pub controller: Controller,
    /// Standard deviation of the record's own control error over the same samples: what the
    /// "now" run should reproduce.
    pub error_std_measured: f64,
    /// Seconds per sample the rates are computed with.
    pub sample_time: f64,
    /// Samples simulated (the first samples of the record are given, not simulated).
    pub samples: usize,
    /// What qualifies the numbers, in words (`None` when nothing does).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// [`Repair::note`] of a valve the fit cannot tell from a free one.
pub const INDISTINGUISHABLE_NOTE: &str =
    "the fit cannot tell this valve from a free one (negligible S, or S = 0 inside its region): a repair buys nothing the record shows";

/// Why a loop gets no repair estimate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum NoRepair {
    /// The record has no set point.
    #[error("no set point: the controller cannot be identified without SP")]
    NoSetPoint,
    /// OP hardly moves while the error does.
    #[error("the controller looks to be in manual: OP moves on {moving} of {samples} samples")]
    Manual {
        /// Samples where OP changed.
        moving: usize,
        /// Samples.
        samples: usize,
    },
    /// The control error never changes.
    #[error("the control error SP - PV is constant: the controller cannot be identified")]
    ConstantError,
    /// The law explains too little of OP.
    #[error("the loop is not PI-like: a PI/PID law explains {fit:.1} % of the OP moves (at least {min} % needed)")]
    NotPiLike {
        /// The best fit, %.
        fit: f64,
        /// [`MIN_CONTROLLER_FIT`].
        min: f64,
    },
    /// Too few samples.
    #[error("too few usable samples ({got}, at least {needed}) to identify the controller")]
    TooFewSamples {
        /// Usable samples.
        got: usize,
        /// Needed.
        needed: usize,
    },
    /// Series of different lengths.
    #[error("internal: series of different lengths ({0})")]
    Lengths(String),
    /// The process model cannot be replayed.
    #[error("the identified process model {0}")]
    Model(String),
    /// A closed-loop run diverged.
    #[error("the identified closed loop {which} diverges (control error spread {ratio:.0} x the record's)")]
    Diverged {
        /// `now` or `repaired`.
        which: &'static str,
        /// Its error spread over the record's.
        ratio: f64,
    },
    /// The fitted valve is not the one the record's answer describes: its S contradicts the
    /// detector's verdict, so a loop simulated with it is another loop's repair.
    #[error("the fitted valve (S = {s:.2}) contradicts the detector's verdict {verdict}: a repair simulated with it would not be this valve's")]
    Contradicted {
        /// The fitted valve's S.
        s: f64,
        /// The detector's verdict, in words.
        verdict: &'static str,
    },
}

/// The record as logged: set point, process variable, controller output (all as long), and
/// the seconds per sample.
#[derive(Debug, Clone, Copy)]
pub struct Signals<'a> {
    /// Set point (`None` when the record has none).
    pub sp: Option<&'a [f64]>,
    /// Process variable.
    pub pv: &'a [f64],
    /// Controller output.
    pub op: &'a [f64],
    /// Seconds per sample.
    pub sample_time: f64,
}

/// The fitted loop model.
#[derive(Debug, Clone, Copy)]
pub struct FittedLoop<'a> {
    /// The fitted valve.
    pub valve: &'a dyn StictionModel,
    /// Its position over the model's samples: the record's last samples (all of them, all but
    /// the first for the increments of an integrating loop, or those after a change of the
    /// process that the model was refitted on).
    pub mv_est: &'a [f64],
    /// The linear model from MV to PV (or to ΔPV when `integrating`).
    pub linear: &'a LinearFit,
    /// Whether the model's output is ΔPV.
    pub integrating: bool,
    /// The fit cannot tell this valve from a free one (its S is negligible, or S = 0 lies in
    /// its likelihood region): both runs then use the free valve, and the reduction is 0 with
    /// a note, for the record shows nothing a repair would remove.
    pub indistinguishable: bool,
}

/// Identify the loop's controller from SP, PV and OP (see the crate docs).
pub fn identify_controller(s: &Signals<'_>) -> Result<Controller, NoRepair> {
    let sp = s.sp.ok_or(NoRepair::NoSetPoint)?;
    let (pv, op) = (s.pv, s.op);
    let n = op.len();
    if sp.len() != n || pv.len() != n {
        return Err(NoRepair::Lengths(format!(
            "SP {}, PV {}, OP {}",
            sp.len(),
            pv.len(),
            n
        )));
    }
    let e: Vec<f64> = sp.iter().zip(pv).map(|(a, b)| a - b).collect();
    if n < MIN_SAMPLES + 3 {
        return Err(NoRepair::TooFewSamples {
            got: n.saturating_sub(3),
            needed: MIN_SAMPLES,
        });
    }
    let (lo, hi) = min_max(op);
    let pinned = |k: usize| (op[k] == lo || op[k] == hi) && op[k] == op[k - 1];
    let moving = (1..n).filter(|&k| op[k] != op[k - 1]).count();
    let (elo, ehi) = min_max(&e);
    if ehi - elo <= f64::EPSILON * ehi.abs().max(elo.abs()).max(1.0) {
        return Err(NoRepair::ConstantError);
    }
    if moving * 10 < n {
        return Err(NoRepair::Manual { moving, samples: n });
    }
    let mut best: Option<Controller> = None;
    for lag in 0..=1usize {
        let rows: Vec<usize> = (lag + 2..n).filter(|&k| !pinned(k)).collect();
        if rows.len() < MIN_SAMPLES {
            continue;
        }
        let target = DVector::from_iterator(rows.len(), rows.iter().map(|&k| op[k] - op[k - 1]));
        let column = |which: usize, k: usize| {
            let i = k - lag;
            match which {
                0 => e[i] - e[i - 1],
                1 => e[i],
                _ => e[i] - 2.0 * e[i - 1] + e[i - 2],
            }
        };
        let fit_law = |kind: ControllerKind, cols: &[usize]| -> Option<Controller> {
            let x = DMatrix::from_fn(rows.len(), cols.len(), |r, c| column(cols[c], rows[r]));
            let theta = least_squares(x.clone(), &target)?;
            let resid = &target - &x * &theta;
            let mut th = [0.0; 3];
            for (k, &c) in cols.iter().enumerate() {
                th[c] = theta[k];
            }
            let fit = fit_index(&target, &resid);
            Some(controller_from(
                kind,
                th,
                fit,
                lag,
                rows.len(),
                s.sample_time,
            ))
        };
        let Some(pi) = fit_law(ControllerKind::Pi, &[0, 1]) else {
            continue;
        };
        // an integral action of the other sign than the proportional one is no controller's:
        // the law is proportional only
        let law = if pi.theta[0] * pi.theta[1] <= 0.0 {
            fit_law(ControllerKind::P, &[0])
        } else {
            match fit_law(ControllerKind::Pid, &[0, 1, 2]) {
                Some(pid) if pid.fit >= pi.fit + MIN_DERIVATIVE_GAIN && pid.td > 0.0 => Some(pid),
                _ => Some(pi),
            }
        };
        if let Some(law) = law {
            if best.as_ref().is_none_or(|b| law.fit > b.fit) {
                best = Some(law);
            }
        }
    }
    let c = best.ok_or(NoRepair::TooFewSamples {
        got: n.saturating_sub(3),
        needed: MIN_SAMPLES,
    })?;
    if c.fit.is_nan() || c.fit < MIN_CONTROLLER_FIT {
        return Err(NoRepair::NotPiLike {
            fit: if c.fit.is_finite() { c.fit } else { 0.0 },
            min: MIN_CONTROLLER_FIT,
        });
    }
    Ok(c)
}

fn controller_from(
    kind: ControllerKind,
    theta: [f64; 3],
    fit: f64,
    lag: usize,
    samples: usize,
    ts: f64,
) -> Controller {
    let kc = theta[0];
    let ti = if kind != ControllerKind::P && theta[1] != 0.0 {
        kc * ts / theta[1]
    } else {
        f64::INFINITY
    };
    let td = if kind == ControllerKind::Pid && kc != 0.0 {
        theta[2] * ts / kc
    } else {
        0.0
    };
    Controller {
        kind,
        kc,
        ti,
        td,
        fit,
        lag,
        samples,
        theta,
    }
}

/// Least squares by Householder QR (nalgebra); `None` when the columns are rank deficient.
fn least_squares(x: DMatrix<f64>, y: &DVector<f64>) -> Option<DVector<f64>> {
    let p = x.ncols();
    let scale: Vec<f64> = (0..p).map(|c| x.column(c).norm()).collect();
    if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return None;
    }
    let mut xs = x;
    for (c, s) in scale.iter().enumerate() {
        xs.column_mut(c).scale_mut(1.0 / s);
    }
    let qr = xs.qr();
    let r = qr.r();
    let diag: Vec<f64> = (0..p).map(|i| r[(i, i)].abs()).collect();
    let dmax = diag.iter().cloned().fold(0.0, f64::max);
    if diag.iter().any(|d| *d <= 1e-10 * dmax) {
        return None;
    }
    let qty = qr.q().transpose() * y;
    let sol = r.solve_upper_triangular(&qty)?;
    Some(DVector::from_iterator(
        p,
        sol.iter().zip(&scale).map(|(v, s)| v / s),
    ))
}

/// The paper's fit index (eq. 9, squared norms), %, of `y` with residual `r`.
fn fit_index(y: &DVector<f64>, r: &DVector<f64>) -> f64 {
    let mean = y.mean();
    let tot: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    if tot <= 0.0 {
        return f64::NAN;
    }
    100.0 * (1.0 - r.norm_squared() / tot)
}

fn min_max(x: &[f64]) -> (f64, f64) {
    x.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        })
}

/// The deterministic part of a linear model, stepped one sample at a time on centered data.
enum Stepper {
    Poly {
        a: Vec<f64>,
        b: Vec<f64>,
        delay: usize,
    },
    Ss {
        a: Vec<Vec<f64>>,
        b: Vec<f64>,
        c: Vec<f64>,
        x: Vec<f64>,
    },
}

impl Stepper {
    fn new(fit: &LinearFit) -> Result<Stepper, NoRepair> {
        match fit.structure() {
            Structure::Polynomial { a, b, delay, .. } => Ok(Stepper::Poly {
                a: a.clone(),
                b: b.clone(),
                delay: *delay,
            }),
            Structure::StateSpace { a, b, c, d, x0, .. } => {
                if *d != 0.0 {
                    return Err(NoRepair::Model(
                        "has a direct feedthrough (D != 0): PV and OP of one sample would form an algebraic loop".into(),
                    ));
                }
                Ok(Stepper::Ss {
                    a: a.clone(),
                    b: b.clone(),
                    c: c.clone(),
                    x: x0.clone(),
                })
            }
        }
    }

    /// Samples whose output is taken as given (every lag exists from here on).
    fn given(&self) -> usize {
        match self {
            Stepper::Poly { a, b, delay } => (a.len() - 1).max(delay + b.len()),
            Stepper::Ss { .. } => 0,
        }
    }

    /// The centered deterministic output at `j` (`j >= given()`), from the centered inputs
    /// `u[..j]` and outputs `det[..j]`. State space: call in order `j = 0, 1, ...` with the
    /// input of `j` pushed afterwards by [`Stepper::advance`].
    fn output(&self, j: usize, u: &[f64], det: &[f64]) -> f64 {
        match self {
            Stepper::Poly { a, b, delay } => {
                let mut v = 0.0;
                for (i, ai) in a.iter().enumerate().skip(1) {
                    v -= ai * det[j - i];
                }
                for (l, bl) in b.iter().enumerate() {
                    v += bl * u[j - delay - l - 1];
                }
                v
            }
            Stepper::Ss { c, x, .. } => c.iter().zip(x).map(|(ci, xi)| ci * xi).sum(),
        }
    }

    /// State space: advance the state with the centered input of the current sample.
    fn advance(&mut self, u: f64) {
        if let Stepper::Ss { a, b, x, .. } = self {
            let next: Vec<f64> = a
                .iter()
                .zip(b.iter())
                .map(|(row, bi)| {
                    row.iter().zip(x.iter()).map(|(r, xi)| r * xi).sum::<f64>() + bi * u
                })
                .collect();
            *x = next;
        }
    }
}

/// How the valve behaves in a run.
enum Valve {
    /// The fitted model from its matched initial state.
    Fitted(Box<dyn stiction_models::ValveState>),
    /// `MV = OP + offset`.
    Free { offset: f64 },
}

/// One closed-loop run over the record (the first [`Replay::given`] samples are the record's).
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// Process variable.
    pub pv: Vec<f64>,
    /// Controller output.
    pub op: Vec<f64>,
    /// Valve position (`NaN` before the model's first sample of an integrating loop).
    pub mv: Vec<f64>,
}

/// The two closed-loop runs of [`replay`].
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    /// The identified controller.
    pub controller: Controller,
    /// With the fitted valve.
    pub now: Run,
    /// With a free valve.
    pub repaired: Run,
    /// Samples taken from the record before the runs start.
    pub given: usize,
}

/// What a repair of the valve would buy (see the crate docs).
pub fn assess(s: &Signals<'_>, m: &FittedLoop<'_>) -> Result<Repair, NoRepair> {
    let r = replay(s, m)?;
    summarise(s, m, r)
}

/// The identified loop run twice over the record, with the fitted valve and with a free one
/// (see the crate docs).
pub fn replay(s: &Signals<'_>, m: &FittedLoop<'_>) -> Result<Replay, NoRepair> {
    let controller = identify_controller(s)?;
    let sp = s.sp.ok_or(NoRepair::NoSetPoint)?;
    let (pv, op) = (s.pv, s.op);
    let n = op.len();
    // the model's samples are the record's last ones (all, all but the first for the
    // increments of an integrating loop, or those after a change of the process)
    let shift = n.checked_sub(m.mv_est.len()).unwrap_or(usize::MAX);
    if shift == usize::MAX || (m.integrating && shift == 0) {
        return Err(NoRepair::Lengths(format!(
            "MV {} for {} samples{}",
            m.mv_est.len(),
            n,
            if m.integrating { " (integrating)" } else { "" }
        )));
    }
    if !m.linear.is_stable() {
        return Err(NoRepair::Model(format!(
            "is unstable (largest pole modulus {:.4}): it cannot be replayed",
            m.linear.info().process_max_pole
        )));
    }
    let (um, ym) = m.linear.means();
    // the model's output series: PV, or its increments for an integrating loop
    let y: Vec<f64> = if m.integrating {
        (shift..n).map(|i| pv[i] - pv[i - 1]).collect()
    } else {
        pv[shift..].to_vec()
    };
    let nm = y.len();
    let u: Vec<f64> = m.mv_est.iter().map(|v| v - um).collect();

    // the disturbance: what the deterministic part does not explain, on the fitted valve
    let mut stepper = Stepper::new(m.linear)?;
    let j0 = stepper.given().min(nm);
    let mut det = vec![0.0; nm];
    let mut v = vec![0.0; nm];
    for j in 0..nm {
        if j < j0 {
            det[j] = y[j] - ym;
        } else {
            det[j] = stepper.output(j, &u, &det);
            v[j] = y[j] - ym - det[j];
        }
        stepper.advance(u[j]);
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(NoRepair::Model("gives a non-finite disturbance".into()));
    }

    // the first samples are given: the model's own, and the controller's error history
    let i0 = (j0.max(1) + shift).max(controller.lag + 2).min(n);
    if n - i0 < MIN_SAMPLES {
        return Err(NoRepair::TooFewSamples {
            got: n - i0,
            needed: MIN_SAMPLES,
        });
    }
    let init = matched_start(m.valve, &op[shift..], m.mv_est);
    let (olo, ohi) = op_limits(op);
    let run = |valve: Valve| -> Result<Run, NoRepair> {
        let mut valve = valve;
        let mut st = Stepper::new(m.linear)?;
        let mut rp = pv.to_vec();
        let mut rop = op.to_vec();
        let mut rmv = vec![f64::NAN; n];
        let mut e: Vec<f64> = sp.iter().zip(pv).map(|(a, b)| a - b).collect();
        let mut uc = vec![0.0; nm];
        let mut dt = vec![0.0; nm];
        for i in 0..n {
            if i < i0 {
                rmv[i] = if i >= shift {
                    m.mv_est[i - shift]
                } else {
                    f64::NAN
                };
            } else {
                let j = i - shift;
                dt[j] = st.output(j, &uc, &dt);
                let yj = dt[j] + ym + v[j];
                rp[i] = if m.integrating { rp[i - 1] + yj } else { yj };
                e[i] = sp[i] - rp[i];
                rop[i] = (rop[i - 1] + controller.delta(&e, i)).clamp(olo, ohi);
                rmv[i] = match &mut valve {
                    Valve::Fitted(state) => state.step(rop[i]),
                    Valve::Free { offset } => rop[i] + *offset,
                };
            }
            // the fitted valve walks the given samples' OP so that its state is the fit's
            // (the model's input there stays the fit's MV, from which the disturbance came)
            if i < i0 && i > shift {
                if let Valve::Fitted(state) = &mut valve {
                    state.step(rop[i]);
                }
            }
            if i >= shift {
                let j = i - shift;
                if j < j0 {
                    dt[j] = y[j] - ym;
                }
                uc[j] = rmv[i] - um;
                st.advance(uc[j]);
            }
            if !rp[i].is_finite() {
                return Err(NoRepair::Diverged {
                    which: "run",
                    ratio: f64::INFINITY,
                });
            }
        }
        Ok(Run {
            pv: rp,
            op: rop,
            mv: rmv,
        })
    };
    let start = m
        .valve
        .start(op[shift], &init)
        .map_err(|e| NoRepair::Model(format!("valve: {e}")))?;
    let offset = m.mv_est[i0 - 1 - shift] - op[i0 - 1];
    let repaired = run(Valve::Free { offset })?;
    let now = if m.indistinguishable {
        repaired.clone()
    } else {
        run(Valve::Fitted(start))?
    };

    Ok(Replay {
        controller,
        now,
        repaired,
        given: i0,
    })
}

fn summarise(s: &Signals<'_>, m: &FittedLoop<'_>, r: Replay) -> Result<Repair, NoRepair> {
    let Replay {
        controller,
        now,
        repaired,
        given: i0,
    } = r;
    let sp = s.sp.ok_or(NoRepair::NoSetPoint)?;
    let (pv, op, n) = (s.pv, s.op, s.op.len());
    let shift = n - m.mv_est.len();
    let err_std = |p: &[f64]| std_dev(sp[i0..].iter().zip(&p[i0..]).map(|(a, b)| a - b));
    let measured = err_std(pv);
    let (sn, sr) = (err_std(&now.pv), err_std(&repaired.pv));
    let scale = measured.max(f64::MIN_POSITIVE);
    for (which, sd) in [("now", sn), ("repaired", sr)] {
        if !(sd.is_finite() && sd <= DIVERGENCE_RATIO * scale) {
            return Err(NoRepair::Diverged {
                which,
                ratio: sd / scale,
            });
        }
    }
    let reduction = if sn > 0.0 {
        (1.0 - sr / sn).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let ts = if s.sample_time.is_finite() && s.sample_time > 0.0 {
        s.sample_time
    } else {
        1.0
    };
    let hours = (n - i0) as f64 * ts / 3600.0;
    let (mlo, mhi) = min_max(&op[shift..]);
    let tol = 1e-9 * (mhi - mlo).abs().max(1.0);
    let mut controller = controller;
    controller.kc = sig6(controller.kc);
    controller.ti = sig6(controller.ti);
    controller.td = sig6(controller.td);
    controller.fit = sig6(controller.fit);
    controller.theta = controller.theta.map(sig6);
    let reversals = |mv: &[f64]| sig6(reversals(mv, tol) as f64 / hours);
    Ok(Repair {
        error_std_now: sig6(sn),
        error_std_repaired: sig6(sr),
        reduction: sig6(reduction),
        reversals_per_hour_now: reversals(&now.mv[i0 - 1..]),
        reversals_per_hour_repaired: reversals(&repaired.mv[i0 - 1..]),
        controller,
        error_std_measured: sig6(measured),
        sample_time: ts,
        samples: n - i0,
        note: if m.indistinguishable {
            Some(INDISTINGUISHABLE_NOTE.to_string())
        } else {
            loose_note(sn, measured)
        },
    })
}

/// The note of a "now" run whose control error spreads more than [`LOOSE_REPLAY`] times more
/// or less than the record's: the identified loop reproduces the record loosely.
fn loose_note(now: f64, measured: f64) -> Option<String> {
    let ratio = now / measured;
    (ratio.is_finite() && !(1.0 / LOOSE_REPLAY..=LOOSE_REPLAY).contains(&ratio)).then(|| {
        format!(
            "the replayed loop's control error spreads {ratio:.2} x the record's: the identified loop reproduces the record loosely, read the reduction as indicative"
        )
    })
}

/// The initial state among the default and the four `(stp, d)` starts whose run on `op` comes
/// closest to `mv_est` (the search chose one of them under In.1/In.2/In.3).
fn matched_start(valve: &dyn StictionModel, op: &[f64], mv_est: &[f64]) -> InitialState {
    let mut candidates = vec![InitialState::default()];
    candidates.extend(InitialState::four_variants());
    let mut best = (f64::INFINITY, InitialState::default());
    for c in candidates {
        let Ok(mv) = valve.simulate(op, &c) else {
            continue;
        };
        let d: f64 = mv.iter().zip(mv_est).map(|(a, b)| (a - b).powi(2)).sum();
        if d < best.0 {
            best = (d, c);
        }
    }
    best.1
}

/// Where the simulated controller output is clamped: 0-100 % when the record's OP lies within
/// it (a percentage of valve span, as the reader delivers it), else unclamped.
fn op_limits(op: &[f64]) -> (f64, f64) {
    let (lo, hi) = min_max(op);
    if lo >= 0.0 && hi <= 100.0 {
        (0.0, 100.0)
    } else {
        (f64::NEG_INFINITY, f64::INFINITY)
    }
}

/// `x` to six significant digits (the reported numbers; no round-off noise in JSON).
fn sig6(x: f64) -> f64 {
    if !x.is_finite() || x == 0.0 {
        return x;
    }
    format!("{x:.5e}").parse().unwrap_or(x)
}

fn std_dev(x: impl Iterator<Item = f64> + Clone) -> f64 {
    let (mut n, mut sum) = (0usize, 0.0);
    for v in x.clone() {
        n += 1;
        sum += v;
    }
    if n < 2 {
        return f64::NAN;
    }
    let mean = sum / n as f64;
    (x.map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
}

/// Direction changes of `mv` (moves of at most `tol` are no move).
fn reversals(mv: &[f64], tol: f64) -> usize {
    let mut last = 0i8;
    let mut count = 0;
    for w in mv.windows(2) {
        let d = w[1] - w[0];
        let sign = if d > tol {
            1
        } else if d < -tol {
            -1
        } else {
            0
        };
        if sign != 0 {
            if last != 0 && sign != last {
                count += 1;
            }
            last = sign;
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reversals_count_direction_changes_only() {
        assert_eq!(
            reversals(&[0.0, 1.0, 1.0, 2.0, 1.0, 1.0, 0.5, 3.0], 1e-9),
            2
        );
        assert_eq!(reversals(&[1.0; 5], 1e-9), 0);
    }

    #[test]
    fn op_limits_follow_the_units() {
        assert_eq!(op_limits(&[10.0, 60.0]), (0.0, 100.0));
        assert_eq!(op_limits(&[-3.0, 60.0]).0, f64::NEG_INFINITY);
    }
}
