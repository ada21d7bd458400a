//! The Hammerstein evidence: does a sticky valve between OP and the process explain PV better
//! than a free one?
//!
//! After the identification approach of the reference paper (a stiction model turns OP into
//! the valve position MV, a linear model maps MV to PV) and its detection use by Choudhury,
//! Jain & Shah, "Stiction — definition, modelling, detection and quantification", Journal of
//! Process Control 18 (2008) 232-243, where a stiction model that explains the data markedly
//! better than a linear valve is the evidence of stiction. Ours is built for detection (fast,
//! on closed-loop data, no quantification):
//!
//! * every Kano valve `(S, J)` of a small grid (S from 0.25 to 12 in OP units, J in
//!   `{0, S/2, S}`, S at most OP's range: a limit cycle's OP spans little more than S) turns
//!   OP into MV, from two starts (at rest after moving down, after moving up: the paper's
//!   unknown initial state), the better kept; the free valve is `MV = OP`;
//! * **output error** (the statistic): the process output `y` — PV for a self-regulating loop,
//!   ΔPV (the level's rate) for an integrating one — against `K·x(t) + c` plus nuisance
//!   sines and cosines, at the oscillation's frequency when the loop oscillates regularly and
//!   at OP's dominant frequency ([`dominant_frequency`]) always, and at OP's next tone when it
//!   is strong and not a harmonic of those ([`second_frequency`]): an external oscillation
//!   that OP compensates would otherwise be "explained" by a deadband filtering the
//!   compensation out of OP; `x` is MV through a
//!   first-order lag `x(t) = p·x(t−1) + (1−p)·MV(t−d)`, the pole `p` on a grid refined by a
//!   golden-section search, the delay `d` from 1 to 4 samples in half samples (a continuous
//!   dead time is rarely a whole number of samples, and a free valve with whole-sample delays
//!   would lose to a backlash, which lags a sinusoid by a fraction of a sample). Strictly
//!   causal, as closed-loop identification must be: OP(t) is computed from PV(t), so a
//!   same-sample term fits the controller read backwards, which made the free valve unbeatable
//!   on aggressively tuned sticky loops. It weighs the low frequencies: OP that ramps while PV
//!   stays flat, then a jump;
//! * **one step ahead** (kept beside it, `lr_arx`): the ARX
//!   `PV(t) = a₁PV(t−1) + a₂PV(t−2) + b₁MV(t−1−d) + b₂MV(t−2−d) + c` (an ARX represents the
//!   integrator, so levels use PV here), `d` from 0 to 3. Its autoregressive part models an
//!   external disturbance's own dynamics, which the output-error fit would read through the
//!   valve model;
//! * each statistic is the likelihood ratio `LR = N ln(RSS_free / RSS_sticky)` of the best
//!   sticky valve against the best free one (Gaussian errors; `N` the rows);
//! * the likelihood region of S: the largest S of the grid whose best valve stays within
//!   χ²₁(95 %) = 3.84 of the best model ([`Comparison::s_upper`]). The verdict uses it to
//!   refuse `no-stiction` when a band of 2 % or more explains PV as well as a free valve.
//!
//! Why one step ahead and not the simulation error the quantification uses for the ARX: with a
//! free valve, a PI controller and a constant set point, OP(t−1) is an exact linear combination
//! of the other ARX regressors, so the linear model's coefficients are not identifiable (the
//! quantification's grid skips that node as a singular regression); the one-step prediction
//! error, a projection, is still well defined. A tiny ridge (1e-10 of the Gram matrix's trace)
//! gives that projection without a rank decision (nalgebra's Cholesky of the 5×5 Gram matrix).
//!
//! Verdict (ours, from the simulated loops of `cargo xtask detect-calibrate`): stiction when the
//! output-error LR is at least 25, the one-step LR at least 15 and the best valve's `S >= 0.5`;
//! no stiction when both are below 8; inconclusive between, and when OP moves less than twice
//! the smallest S.

use crate::signal::mean;
use crate::{DetectionError, DetectionTest, Registration, TestEntry, TestOutcome, Verdict};
use nalgebra::{SMatrix, SVector};
use stiction_models::{InitialState, Kano, StictionModel};

/// The stiction band S of the grid, in OP units.
const S_GRID: [f64; 13] = [
    0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0,
];
/// Delays tried for every valve: the one-step ARX uses MV from `t−1−d`, `d` up to this; the
/// output-error model delays of 1 to `MAX_DELAY + 1` samples in half samples. Both span 1-4
/// samples.
const MAX_DELAY: usize = 3;
/// Regressors: two outputs, two inputs, a constant.
const P: usize = 5;

/// Residual sum of squares of `y(t)` on `[y(t−1), y(t−2), u(t−1−d), u(t−2−d), 1]`, `t` from
/// `start` (the same rows for every model, so that the sums compare).
fn arx_rss(y: &[f64], u: &[f64], d: usize, start: usize) -> f64 {
    let mut gram = SMatrix::<f64, P, P>::zeros();
    let mut b = SVector::<f64, P>::zeros();
    let mut yy = 0.0;
    for t in start..y.len() {
        let x = SVector::<f64, P>::from([y[t - 1], y[t - 2], u[t - 1 - d], u[t - 2 - d], 1.0]);
        gram.ger(1.0, &x, &x, 1.0);
        b.axpy(y[t], &x, 1.0);
        yy += y[t] * y[t];
    }
    let ridge = 1e-10 * gram.trace().max(f64::MIN_POSITIVE);
    gram += SMatrix::<f64, P, P>::identity() * ridge;
    // RSS = yᵀy − zᵀz with L z = b (L the Cholesky factor): the projection of y on the
    // regressors.
    let Some(chol) = gram.cholesky() else {
        return yy;
    };
    let Some(z) = chol.l().solve_lower_triangular(&b) else {
        return yy;
    };
    (yy - z.norm_squared()).max(0.0)
}

/// Nuisance regressors of the output-error target at most: a constant and three sine-cosine
/// pairs.
const MAX_BASIS: usize = 7;

/// The dominant frequency (rad/sample) of `x` with its mean and linear trend removed, over
/// periods from 8 samples to a quarter of the record: the periodogram's peak on the Fourier
/// grid, refined by a golden-section search between its neighbours. `None` when the record is
/// too short for such periods or has no power in them.
pub fn dominant_frequency(x: &[f64]) -> Option<f64> {
    if x.len() < 64 {
        return None;
    }
    linear_id::dominant_frequency(x, 8.0, x.len() as f64 / 4.0)
}

/// Least share of OP's variance (what the first tones leave) at its next tone for
/// [`second_frequency`] to keep it. Set once, before measuring, at the 15 % that the first
/// tone's former condition used (DETECTION.md, "Choices measured"); not tuned.
const SECOND_TONE_SHARE: f64 = 0.15;

/// OP's dominant frequency once a constant and the sines at `omegas` are projected out, when
/// it carries at least [`SECOND_TONE_SHARE`] of what they leave of OP's variance and is not a
/// harmonic of one of them (within a tenth of the fundamental: a limit cycle's OP has
/// harmonics, an external disturbance of several tones has incommensurate frequencies) nor
/// within two Fourier bins of one.
fn second_frequency(op: &[f64], omegas: &[f64]) -> Option<f64> {
    let n = op.len();
    if omegas.is_empty() || n < 64 {
        return None;
    }
    let tg = Target::new(op, 0, omegas);
    let w = dominant_frequency(&tg.ry)?;
    let resolution = 2.0 * std::f64::consts::PI / n as f64;
    let harmonic = omegas.iter().any(|&v| {
        let k = (w / v).round();
        (w - v).abs() <= 2.0 * resolution || (k >= 2.0 && (w / v - k).abs() <= 0.1)
    });
    // Enough power: the residual's share at w (a pair's projection) at least 15 %.
    let (mut a, mut b) = (0.0, 0.0);
    for (t, v) in tg.ry.iter().enumerate() {
        let (sn, cs) = (w * t as f64).sin_cos();
        a += v * cs;
        b += v * sn;
    }
    let share = 2.0 * (a * a + b * b) / n as f64 / tg.yy.max(f64::MIN_POSITIVE);
    (!harmonic && share >= SECOND_TONE_SHARE).then_some(w)
}

/// Poles of the first-order lag of the output-error model: a coarse grid, refined by a
/// golden-section search between the best pole's neighbours.
const POLES: [f64; 8] = [0.0, 0.3, 0.5, 0.7, 0.82, 0.9, 0.95, 0.98];
/// Golden-section steps of the pole refinement (the bracket shrinks by 0.618 per step).
const GOLDEN_STEPS: usize = 12;

/// The output-error model's target: the output with the nuisance regressors (a constant, and
/// with a regular oscillation a sine and a cosine at its frequency) projected out, rows from
/// `start` on.
struct Target {
    /// The output's residual on the nuisance regressors (0 before `start`).
    ry: Vec<f64>,
    /// Its sum of squares.
    yy: f64,
    /// Orthonormal nuisance regressors over the rows (0 before `start`).
    basis: Vec<Vec<f64>>,
    start: usize,
}

impl Target {
    fn new(y: &[f64], start: usize, omegas: &[f64]) -> Target {
        let n = y.len();
        // A regressor over the rows from `start` (0 before).
        let rows = |f: &dyn Fn(f64) -> f64| -> Vec<f64> {
            (0..n)
                .map(|t| if t >= start { f(t as f64) } else { 0.0 })
                .collect()
        };
        let mut raw: Vec<Vec<f64>> = vec![rows(&|_| 1.0)];
        for &w in omegas {
            raw.push(rows(&|t| (w * t).sin()));
            raw.push(rows(&|t| (w * t).cos()));
        }
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let mut basis: Vec<Vec<f64>> = Vec::new();
        for mut v in raw {
            for q in &basis {
                let c = dot(&v, q);
                v.iter_mut().zip(q).for_each(|(x, qq)| *x -= c * qq);
            }
            let norm = dot(&v, &v).sqrt();
            if norm > 1e-9 {
                v.iter_mut().for_each(|x| *x /= norm);
                basis.push(v);
            }
        }
        let mut ry: Vec<f64> = (0..n)
            .map(|t| if t >= start { y[t] } else { 0.0 })
            .collect();
        for q in &basis {
            let c = dot(&ry, q);
            ry.iter_mut().zip(q).for_each(|(x, qq)| *x -= c * qq);
        }
        let yy = dot(&ry, &ry);
        Target {
            ry,
            yy,
            basis,
            start,
        }
    }
}

/// Residual sum of squares of `y(t) = K·x(t) + nuisance` on the target's rows, `x` the input
/// `u` delayed by `d` samples through the lag `x(t) = p·x(t−1) + (1−p)·u(t−d)`.
fn oe_rss_at(tg: &Target, u: &[f64], d: usize, p: f64, x: &mut [f64]) -> f64 {
    let n = tg.ry.len();
    x[..=d].fill(u[0]);
    for t in d + 1..n {
        x[t] = p * x[t - 1] + (1.0 - p) * u[t - d];
    }
    let (mut sxx, mut sxy) = (0.0, 0.0);
    let mut proj = [0.0; MAX_BASIS];
    for t in tg.start..n {
        sxx += x[t] * x[t];
        sxy += x[t] * tg.ry[t];
        for (pi, q) in proj.iter_mut().zip(&tg.basis) {
            *pi += q[t] * x[t];
        }
    }
    let vxx = sxx - proj.iter().map(|v| v * v).sum::<f64>();
    let rss = if vxx > 1e-12 * tg.yy.max(f64::MIN_POSITIVE) {
        tg.yy - sxy * sxy / vxx
    } else {
        tg.yy
    };
    rss.max(0.0)
}

/// The output-error model's residual sum of squares at its best pole (see [`POLES`]).
fn oe_rss(tg: &Target, u: &[f64], d: usize, x: &mut [f64]) -> (f64, f64) {
    let at: Vec<f64> = POLES.iter().map(|&p| oe_rss_at(tg, u, d, p, x)).collect();
    let i = (0..POLES.len())
        .min_by(|&a, &b| at[a].total_cmp(&at[b]))
        .unwrap_or(0);
    let mut best = (at[i], POLES[i]);
    let (mut lo, mut hi) = (
        POLES[i.saturating_sub(1)],
        POLES[(i + 1).min(POLES.len() - 1)],
    );
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut fa, mut fb) = (oe_rss_at(tg, u, d, a, x), oe_rss_at(tg, u, d, b, x));
    for _ in 0..GOLDEN_STEPS {
        if fa < fb {
            hi = b;
            (b, fb) = (a, fa);
            a = hi - g * (hi - lo);
            fa = oe_rss_at(tg, u, d, a, x);
        } else {
            lo = a;
            (a, fa) = (b, fb);
            b = lo + g * (hi - lo);
            fb = oe_rss_at(tg, u, d, b, x);
        }
    }
    for (f, p) in [(fa, a), (fb, b)] {
        if f < best.0 {
            best = (f, p);
        }
    }
    best
}

/// Buffers of the output-error fits, allocated once per comparison.
struct Scratch {
    /// The lagged input.
    x: Vec<f64>,
    /// The input delayed by half a sample.
    half: Vec<f64>,
}

/// The best output-error residual over the delays for input `u`: `(rss, delay in samples)`.
fn best_oe(tg: &Target, u: &[f64], scratch: &mut Scratch) -> (f64, f64) {
    // Half-sample delays too: a continuous dead time is rarely a whole number of samples,
    // and a free valve with an integer delay against a sticky one (whose backlash lags a
    // sinusoid by a fraction of a sample) would favour the sticky one on clean oscillations.
    let Scratch { x, half } = scratch;
    half.clear();
    half.extend((0..u.len()).map(|t| 0.5 * (u[t] + u[t.saturating_sub(1)])));
    let mut best = (f64::INFINITY, 0.0);
    for (input, extra) in [(u, 0.0), (&half[..], 0.5)] {
        for d in 1..=MAX_DELAY + 1 {
            let r = oe_rss(tg, input, d, x).0;
            if r < best.0 {
                best = (r, d as f64 + extra);
            }
        }
    }
    best
}

/// The best one-step ARX residual over the delays for input `u`.
fn best_arx(y: &[f64], u: &[f64], start: usize) -> f64 {
    (0..=MAX_DELAY)
        .map(|d| arx_rss(y, u, d, start))
        .fold(f64::INFINITY, f64::min)
}

/// The Hammerstein comparison of a registration's output `y` and OP (same length).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// `N ln(RSS₀/RSS₁)` of the output-error models: the statistic.
    pub lr: f64,
    /// The best sticky valve's S (OP units), output error.
    pub s: f64,
    /// Its J.
    pub j: f64,
    /// Its delay (samples, in half samples).
    pub delay: f64,
    /// Regression rows.
    pub rows: usize,
    /// Relative reduction of the output-error residual variance, `1 − RSS₁/RSS₀`.
    pub reduction: f64,
    /// `N ln(RSS₀/RSS₁)` of the one-step-ahead ARX models.
    pub lr_arx: f64,
    /// The S of the best sticky valve one step ahead.
    pub s_arx: f64,
    /// The largest S of the grid still in the output-error likelihood region: its best valve
    /// (over J and the two starts) within [`REGION_LR`] of the best model, free or sticky.
    /// Below 1 (% of span, the size that already hurts) the data exclude a harmful stiction
    /// band; at or above it they do not, whatever the likelihood ratio says.
    pub s_upper: f64,
}

/// Likelihood-ratio margin of the S region: χ²₁ at 95 %.
pub const REGION_LR: f64 = 3.84;

/// Compare the best sticky Kano valve of the grid with a free valve: the output-error models
/// on `y` (PV, or ΔPV for an integrating loop), the one-step ARX models on PV itself (`pv`, an
/// ARX represents an integrator), both against `op` (all aligned). `None` when OP's range is
/// below twice the smallest S or a residual vanishes.
pub fn compare(y: &[f64], pv: &[f64], op: &[f64], omegas: &[f64]) -> Option<Comparison> {
    let n = y.len().min(op.len()).min(pv.len());
    let (y, pv, op) = (&y[..n], &pv[..n], &op[..n]);
    let start = MAX_DELAY + 2;
    if n < start + 20 {
        return None;
    }
    let (lo, hi) = op
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let range = hi - lo;
    if range < 2.0 * S_GRID[0] {
        return None;
    }
    let ym = mean(y);
    let y: Vec<f64> = y.iter().map(|v| v - ym).collect();
    let zm = mean(pv);
    let z: Vec<f64> = pv.iter().map(|v| v - zm).collect();
    let om = mean(op);
    let u0: Vec<f64> = op.iter().map(|v| v - om).collect();
    let tg = Target::new(&y, start, omegas);
    let mut scratch = Scratch {
        x: vec![0.0; n],
        half: Vec::with_capacity(n),
    };
    let (oe0, _) = best_oe(&tg, &u0, &mut scratch);
    let arx0 = best_arx(&z, &u0, start);
    let mut best = (f64::INFINITY, 0.0, 0.0, 0.0);
    let mut arx1 = (f64::INFINITY, 0.0);
    // The valve's state at the start of the record is unknown: at rest after moving down or
    // after moving up (a creeping OP that keeps going one way holds a valve of the second kind
    // for S, the first only for J); each node keeps the better of the two.
    let starts = [InitialState::down(), InitialState::up()];
    // The profile over S: the best output-error residual of each S (over J and the starts).
    let mut profile: Vec<(f64, f64)> = Vec::with_capacity(S_GRID.len());
    for &s in S_GRID.iter().filter(|&&s| s <= range) {
        // A stop requested (Ctrl-C in Python): the caller discards the answer.
        if stiction_models::cancel::requested() {
            return None;
        }
        profile.push((s, f64::INFINITY));
        for j in [0.0, 0.5 * s, s] {
            let Ok(valve) = Kano::params().s(s).j(j).check() else {
                continue;
            };
            for init in &starts {
                let Ok(mv) = valve.simulate(&u0, init) else {
                    continue;
                };
                let (oe, d) = best_oe(&tg, &mv, &mut scratch);
                let arx = best_arx(&z, &mv, start);
                if oe < best.0 {
                    best = (oe, s, j, d);
                }
                if let Some(last) = profile.last_mut() {
                    last.1 = last.1.min(oe);
                }
                if arx < arx1.0 {
                    arx1 = (arx, s);
                }
            }
        }
    }
    let rows = n - start;
    let positive = |v: f64| v > 0.0 && v.is_finite();
    if !(positive(oe0) && positive(best.0) && positive(arx0) && positive(arx1.0)) {
        return None;
    }
    let ratio = (oe0 / best.0).max(1.0);
    let floor = oe0.min(best.0);
    let s_upper = profile
        .iter()
        .filter(|&&(_, r)| rows as f64 * (r / floor).ln() <= REGION_LR)
        .map(|&(s, _)| s)
        .fold(0.0, f64::max);
    Some(Comparison {
        s_upper,
        lr: rows as f64 * ratio.ln(),
        s: best.1,
        j: best.2,
        delay: best.3,
        rows,
        reduction: 1.0 - 1.0 / ratio,
        lr_arx: rows as f64 * (arx0 / arx1.0).max(1.0).ln(),
        s_arx: arx1.1,
    })
}

/// How much better the valve position `mv` explains the output `y` (PV, or ΔPV for an
/// integrating loop) than OP does, through this test's output-error model (constant only, no
/// nuisance sines): `N ln(RSS_OP / RSS_MV)`, at least 0. For simulated loops, where the true
/// valve position is known, this is the evidence any PV-OP test of this model family could
/// find at best: a sticky valve whose ratio is small never stuck visibly in the record (a valve
/// dithered by OP's noise, or held still by a constant load). `None` when a residual vanishes
/// or the record is too short.
pub fn oracle_lr(y: &[f64], op: &[f64], mv: &[f64]) -> Option<f64> {
    let n = y.len().min(op.len()).min(mv.len());
    let start = MAX_DELAY + 2;
    if n < start + 20 {
        return None;
    }
    let ym = mean(&y[..n]);
    let y: Vec<f64> = y[..n].iter().map(|v| v - ym).collect();
    let om = mean(&op[..n]);
    let u: Vec<f64> = op[..n].iter().map(|v| v - om).collect();
    let m: Vec<f64> = mv[..n].iter().map(|v| v - om).collect();
    let tg = Target::new(&y, start, &[]);
    let mut scratch = Scratch {
        x: vec![0.0; n],
        half: Vec::with_capacity(n),
    };
    let (r_op, _) = best_oe(&tg, &u, &mut scratch);
    let (r_mv, _) = best_oe(&tg, &m, &mut scratch);
    (r_op > 0.0 && r_mv > 0.0 && r_op.is_finite() && r_mv.is_finite())
        .then(|| (n - start) as f64 * (r_op / r_mv).max(1.0).ln())
}

/// Output-error likelihood ratio at or above which the test says stiction (with the one-step
/// ratio at or above [`STICTION_LR_ARX`] and `S >= 0.5`).
pub const STICTION_LR: f64 = 25.0;
/// One-step ARX likelihood ratio needed besides for stiction.
pub const STICTION_LR_ARX: f64 = 15.0;
/// Likelihood ratio (of both models) below which the test says no stiction.
pub const FREE_LR: f64 = 8.0;

/// The Hammerstein likelihood-ratio test.
#[derive(Debug, Clone, Copy, Default)]
pub struct Hammerstein;

impl DetectionTest for Hammerstein {
    fn name(&self) -> &'static str {
        "hammerstein"
    }
    fn run(&self, reg: &Registration<'_>) -> Result<TestOutcome, DetectionError> {
        reg.prepared()?;
        let px = reg.valve_proxy();
        let (proxy, y, op, pv) = (px.name, px.y, px.op, px.pv);
        // With a regular oscillation, a sine and a cosine at its frequency are nuisance
        // regressors of the output-error fit: an external oscillation is then no longer
        // "explained" by a deadband that filters OP's compensation of it, and a limit cycle's
        // evidence must come from its shape beyond the fundamental.
        let o = reg.prepared()?.oscillation;
        let omega = o
            .period
            .filter(|_| o.is_regular())
            .map(|p| 2.0 * std::f64::consts::PI / p);
        let mut omegas: Vec<f64> = omega.into_iter().collect();
        // OP's dominant frequency too: an external oscillation that the controller compensates
        // shows in OP even when the control error does not oscillate regularly (a wandering
        // set point, a slow plant), and a deadband that filters the compensation out of OP
        // would otherwise explain PV better than the free valve does.
        if let Some(w) = dominant_frequency(op) {
            let resolution = 2.0 * std::f64::consts::PI / op.len() as f64;
            if omegas.iter().all(|&v| (v - w).abs() > resolution) {
                omegas.push(w);
            }
        }
        // And OP's next tone, when it is not a harmonic of those: an external disturbance of
        // several tones (the reference paper's two sines) leaves the free valve a second
        // oscillation to miss, which a small deadband would otherwise "explain"; a limit
        // cycle's OP has harmonics, which stay evidence.
        if let Some(w2) = second_frequency(op, &omegas) {
            omegas.push(w2);
        }
        let Some(c) = compare(&y, pv, op, &omegas) else {
            return Ok(TestOutcome::new(
                "hammerstein",
                None,
                Verdict::Inconclusive,
                format!(
                    "OP's range is below {} (twice the smallest stiction band tried)",
                    2.0 * S_GRID[0]
                ),
            ));
        };
        let verdict = if c.lr >= STICTION_LR && c.lr_arx >= STICTION_LR_ARX && c.s >= 0.5 {
            Verdict::Stiction
        } else if c.lr < FREE_LR && c.lr_arx < FREE_LR {
            Verdict::NoStiction
        } else {
            Verdict::Inconclusive
        };
        let mut out = TestOutcome::new(
            "hammerstein",
            Some(c.lr),
            verdict,
            format!(
                "simulated through a Kano valve S = {:.2}, J = {:.2} (delay {}), OP explains {proxy} with {:.1} % less residual variance than through a free valve (LR = {:.1} over {} rows); one step ahead, LR = {:.1}; the data leave S up to {:.2} in the likelihood region",
                c.s,
                c.j,
                c.delay,
                100.0 * c.reduction,
                c.lr,
                c.rows,
                c.lr_arx,
                c.s_upper
            ),
        );
        out.values = vec![
            ("S", c.s),
            ("J", c.j),
            ("delay", c.delay),
            ("lr_arx", c.lr_arx),
            ("S_arx", c.s_arx),
            ("S_upper", c.s_upper),
        ];
        Ok(out)
    }
}

inventory::submit! {
    TestEntry {
        name: "hammerstein",
        description: "likelihood ratio of the best sticky Kano valve against a free one (ARX, one step ahead)",
        reference: "Choudhury, Jain & Shah (2008), J. Process Control 18:232-243; the reference paper's Hammerstein identification",
        order: 50,
        test: &Hammerstein,
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::testing::noise;

    /// A first-order process driven through a Kano valve by a slow triangular OP.
    fn process(sticky: bool) -> (Vec<f64>, Vec<f64>) {
        let n = 800;
        let op: Vec<f64> = (0..n)
            .map(|k| {
                let t = (k % 200) as f64;
                if t < 100.0 {
                    t / 10.0
                } else {
                    (200.0 - t) / 10.0
                }
            })
            .collect();
        let valve = Kano::params()
            .s(if sticky { 3.0 } else { 0.0 })
            .j(if sticky { 1.0 } else { 0.0 })
            .check()
            .unwrap();
        let mv = valve.simulate(&op, &InitialState::default()).unwrap();
        let e = noise(n, 0.05, 3);
        let mut y = vec![0.0; n];
        for t in 1..n {
            y[t] = 0.6 * y[t - 1] + 0.4 * mv[t - 1] + e[t];
        }
        (y, op)
    }

    #[test]
    fn the_oracle_sees_a_valve_that_sticks_and_not_one_that_follows_op() {
        let (y, op) = process(true);
        let valve = Kano::params().s(3.0).j(1.0).check().unwrap();
        let mv = valve.simulate(&op, &InitialState::default()).unwrap();
        let stuck = oracle_lr(&y, &op, &mv).unwrap();
        assert!(stuck > 100.0, "{stuck}");
        let (y, op) = process(false);
        let free = oracle_lr(&y, &op, &op).unwrap();
        assert!(free < 1e-9, "{free}");
        assert!(oracle_lr(&y[..20], &op[..20], &op[..20]).is_none());
    }

    #[test]
    fn the_dominant_frequency_is_the_sine_in_the_noise() {
        let e = noise(3000, 1.0, 7);
        let x: Vec<f64> = (0..3000)
            .map(|t| 0.05 * t as f64 + 0.8 * (0.0377 * t as f64 + 0.3).sin() + e[t])
            .collect();
        let w = dominant_frequency(&x).unwrap();
        assert!((w - 0.0377).abs() < 2e-4, "{w}");
        assert_eq!(dominant_frequency(&x[..40]), None);
        assert_eq!(dominant_frequency(&[1.0; 500]), None);
    }

    #[test]
    fn a_sticky_valve_is_found_and_a_free_one_is_not() {
        let (y, op) = process(true);
        let c = compare(&y, &y, &op, &[]).unwrap();
        assert!(c.lr > STICTION_LR, "{c:?}");
        assert!((c.s - 3.0).abs() <= 1.0, "{c:?}");
        let (y, op) = process(false);
        let c = compare(&y, &y, &op, &[]).unwrap();
        assert!(c.lr < FREE_LR, "{c:?}");
    }
}
