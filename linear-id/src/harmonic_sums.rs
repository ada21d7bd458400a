//! HARX for many inputs against one output record
//! ([`crate::LinearIdentifier::identify_predict_many`]: a grid search's or local search's
//! nodes), from the normal equations of its filtered regression instead of a QR per input.
//!
//! `Harx::solve` (`harmonic.rs`) regresses `L y(t)` on the columns `-L y(t-i)` (i = 1..n),
//! `L u(t-delay-j)` (j = 1..m), 1 and the notch's transient pair over the rows
//! `t ∈ [n0, len)` of the identification window, `L` the notch from a zero state at the
//! window's first sample and each signal centred by its window mean. Only the m input columns
//! change from one input to the next; the n output columns, the intercept, the transient pair
//! and the target are the same for every input whose window starts at the same sample. So:
//!
//! 1. per output record, once ([`crate::LinearIdentifier::prepare`], [`HarxOutput`]): the
//!    notch's step response and transient pair; per window (built when a batch first asks for
//!    it, then kept with the prepared output): the output's checks, the filtered output and the
//!    products of its columns;
//! 2. per input: its filtered columns' products with every column (m (n + m + 4) dot
//!    products), the unit-diagonal Gram matrix's Cholesky factor, and one step of iterative
//!    refinement from the residual over the rows (the normal equations square the condition
//!    number: the step brings the solution back to the QR's round-off; test
//!    `sums_path_matches_the_qr`).
//!
//! The one-step prediction over the record follows from the same filtered signals: HARX's
//! predictor (`LinearFit::predict_core`) filters the input and output again, centred by the
//! fit's operating point `(u_op, y_op)` instead of the window means, and
//! `L (y - y_op) = L (y - ym) - (y_op - ym) L 1`: the output's filtered record is kept with the
//! window and the notch's step response `L 1` with the record, the input's is filtered once
//! over the record (its window part is the regression's), and the prediction is one pass.
//!
//! As in `arx_sums.rs`, the solve is only trusted when every pivot of the scaled Cholesky
//! factor is at least [`crate::GRAM_PIVOT_TOL`] (a QR pivot of 1e-2, eight decades above the QR's own
//! rank threshold); otherwise, and for orders above `n + m = 9`, the input takes the QR path
//! (`Harx::fit_bare`), which reports what it makes of it. The model, its operating point,
//! one-step prediction and diagnostics are then built exactly as `identify` builds them from
//! its solution: the results differ from the QR path's by round-off only.

// Dense small-matrix code reads best with index loops.
#![allow(clippy::needless_range_loop)]

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

use crate::arx_sums::{cholesky_in_place, cholesky_solve, MAX_COLS};
use crate::error::{check_shared, OutputChecks};
use crate::harmonic::{notch_filter, pole_radius, transient_pair};
use crate::la::{dot, sum};
use crate::{mean, Harx, IdError, Identified, LinearFit, LinearIdentifier, Structure};

/// Products of the regression's columns over the rows, in the layout of `Harx::solve`:
/// `0..n` the output lags (unsigned), `n..n+m` the input lags, `n+m` the intercept, `n+m+1` and
/// `n+m+2` the transient pair, `n+m+3` the target.
type Gram = [[f64; MAX_COLS + 1]; MAX_COLS + 1];

/// What HARX's [`LinearIdentifier::prepare`] computes from the output record alone (the
/// cache of its [`crate::PreparedOutput`]): the notch's step response and transient over the
/// record, and per identification window the output's block, built when a batch first asks
/// for that window and kept for the whole search (its nodes start at the few samples where
/// their valves' initial states washed out).
pub(crate) struct HarxOutput {
    /// The orders and frequency (bits) it was prepared for.
    key: (usize, usize, usize, u64),
    /// The last sample of the record that is not finite.
    last_non_finite: Option<usize>,
    /// The notch's step response `L 1` from a zero state, as long as the record (from any
    /// window's first sample: the filter starts from a zero state there).
    step: Vec<f64>,
    /// The notch's transient pair `(ρ^k cos ωk, ρ^k sin ωk)` for `k = 0..len`, `k` counted from
    /// the window's first sample.
    tc: Vec<f64>,
    ts: Vec<f64>,
    /// The output's blocks by window `(first sample, length)`.
    windows: Mutex<HashMap<(usize, usize), Arc<OutputBlock>>>,
}

/// The output's side of one identification window.
struct OutputBlock {
    /// The checks of the window's output (`check_shared` with each input).
    checks: OutputChecks,
    /// The output's side of the normal equations, when the window can take the sums path.
    sums: Option<WindowSums>,
}

/// The output's side of the normal equations on one identification window.
struct WindowSums {
    /// The identification window's length.
    window: usize,
    /// The output's window mean.
    ym: f64,
    /// `L (y - ym)` over the record from the window's first sample.
    yf: Vec<f64>,
    /// The products among the output's columns (every entry whose both indices are outside
    /// `n..n+m`).
    g: Gram,
}

/// One column over the rows.
#[derive(Clone, Copy)]
enum Col<'a> {
    Data(&'a [f64]),
    Ones,
}

fn product(a: Col<'_>, b: Col<'_>, rows: usize) -> f64 {
    match (a, b) {
        (Col::Data(x), Col::Data(y)) => dot(x, y),
        (Col::Data(x), Col::Ones) | (Col::Ones, Col::Data(x)) => sum(x),
        (Col::Ones, Col::Ones) => rows as f64,
    }
}

fn key_of(h: &Harx) -> (usize, usize, usize, u64) {
    let (n, m, delay) = h.orders_tuple();
    (n, m, delay, h.omega().to_bits())
}

impl HarxOutput {
    /// The record-wide part for `h` and the output record `y`.
    pub(crate) fn new(h: &Harx, y: &[f64]) -> HarxOutput {
        let (omega, rho) = (h.omega(), pole_radius(h.omega()));
        let (tc, ts) = (0..y.len()).map(|k| transient_pair(omega, rho, k)).unzip();
        HarxOutput {
            key: key_of(h),
            last_non_finite: y.iter().rposition(|v| !v.is_finite()),
            step: notch_filter(&vec![1.0; y.len()], 0.0, omega),
            tc,
            ts,
            windows: Mutex::new(HashMap::new()),
        }
    }

    /// The block of the window `y[..window]`, `y` the record from the window's first sample
    /// `start`: from the map, or built (and kept).
    fn block(&self, h: &Harx, start: usize, y: &[f64], window: usize) -> Arc<OutputBlock> {
        let key = (start, window);
        let map = || self.windows.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(b) = map().get(&key) {
            return b.clone();
        }
        // built outside the lock; a block built twice at once is the same bits
        let b = Arc::new(self.build(h, start, y, window));
        map().entry(key).or_insert(b).clone()
    }

    fn build(&self, h: &Harx, start: usize, y: &[f64], window: usize) -> OutputBlock {
        let (n, m, _) = h.orders_tuple();
        let checks = OutputChecks::of(&y[..window]);
        // the sums path needs orders within the Gram's size, a window long enough and a
        // finite record from the window on (the prediction runs over all of it); a window
        // whose output the checks refuse never gets to use it
        let usable = n + m + 3 <= MAX_COLS
            && window >= h.min_samples()
            && self.last_non_finite.is_none_or(|i| i < start);
        OutputBlock {
            sums: usable.then(|| self.window_sums(h, y, window)),
            checks,
        }
    }

    /// Column `p` over the rows of `sums`'s window (`uf`: the filtered input, for `n..n+m`).
    fn col<'a>(&'a self, sums: &'a WindowSums, h: &Harx, uf: &'a [f64], p: usize) -> Col<'a> {
        let (n, m, delay) = h.orders_tuple();
        let n0 = n.max(m + delay);
        let len = sums.window;
        if p < n {
            Col::Data(&sums.yf[n0 - p - 1..len - p - 1])
        } else if p < n + m {
            let lag = delay + p - n + 1;
            Col::Data(&uf[n0 - lag..len - lag])
        } else if p == n + m {
            Col::Ones
        } else if p == n + m + 1 {
            Col::Data(&self.tc[n0..len])
        } else if p == n + m + 2 {
            Col::Data(&self.ts[n0..len])
        } else {
            Col::Data(&sums.yf[n0..len])
        }
    }

    /// The output's side of the normal equations of the output `y` (from the window's first
    /// sample to the record's end) and the window `y[..window]`.
    fn window_sums(&self, h: &Harx, y: &[f64], window: usize) -> WindowSums {
        let (n, m, delay) = h.orders_tuple();
        let n0 = n.max(m + delay);
        let ym = mean(&y[..window]);
        let mut sums = WindowSums {
            window,
            ym,
            yf: notch_filter(y, ym, h.omega()),
            g: [[0.0; MAX_COLS + 1]; MAX_COLS + 1],
        };
        let rows = window - n0;
        let d = n + m + 3;
        let outside: Vec<usize> = (0..n).chain(n + m..=d).collect();
        let mut g = sums.g;
        for (i, &p) in outside.iter().enumerate() {
            for &q in &outside[i..] {
                let v = product(self.col(&sums, h, &[], p), self.col(&sums, h, &[], q), rows);
                g[p][q] = v;
                g[q][p] = v;
            }
        }
        sums.g = g;
        sums
    }
}

/// The fit of `h` on the window `(u[..window], y[..window])` (checked by `check_shared`) from
/// the normal equations, the output's side from `sums` (of `prepared`), and its one-step
/// prediction of `y` (all of it) in `out`; `None` when the solve is not trusted or the
/// prediction not finite (module documentation).
fn fit_from_sums(
    h: &Harx,
    (prepared, sums): (&HarxOutput, &WindowSums),
    (u, y): (&[f64], &[f64]),
    window: usize,
    out: &mut [f64],
) -> Option<LinearFit> {
    let (n, m, delay) = h.orders_tuple();
    let d = n + m + 3;
    if !crate::la::all_finite(u) {
        return None;
    }
    let n0 = n.max(m + delay);
    let rows = window - n0;
    let um = mean(&u[..window]);
    let uf = notch_filter(u, um, h.omega());
    let col = |p: usize| prepared.col(sums, h, &uf, p);
    let mut g = sums.g;
    for p in n..n + m {
        for q in 0..=d {
            let v = product(col(p), col(q), rows);
            g[p][q] = v;
            g[q][p] = v;
        }
    }
    let sign = |p: usize| if p < n { -1.0 } else { 1.0 };
    let mut scale = [0.0; MAX_COLS];
    for p in 0..d {
        let c = g[p][p];
        if !(c > 0.0 && c.is_finite()) {
            return None;
        }
        scale[p] = 1.0 / c.sqrt();
    }
    let mut a = [[0.0; MAX_COLS]; MAX_COLS];
    let mut rhs = [0.0; MAX_COLS];
    for p in 0..d {
        for q in 0..d {
            a[p][q] = sign(p) * sign(q) * g[p][q] * scale[p] * scale[q];
        }
        rhs[p] = sign(p) * g[p][d] * scale[p];
    }
    cholesky_in_place(&mut a, d)?;
    let z = cholesky_solve(&a, &rhs, d);
    let mut x = [0.0; MAX_COLS];
    for p in 0..d {
        x[p] = z[p] * scale[p];
    }
    // one step of iterative refinement from the residual over the rows
    let mut rhs2 = [0.0; MAX_COLS];
    crate::la::with_buffer(rows, |r| {
        let Col::Data(target) = col(d) else {
            unreachable!("the target is data")
        };
        r.copy_from_slice(target);
        for p in 0..d {
            let w = sign(p) * x[p];
            match col(p) {
                Col::Data(c) => r.iter_mut().zip(c).for_each(|(r, c)| *r -= w * c),
                Col::Ones => r.iter_mut().for_each(|r| *r -= w),
            }
        }
        for p in 0..d {
            rhs2[p] = sign(p) * product(Col::Data(r), col(p), rows) * scale[p];
        }
    });
    let dx = cholesky_solve(&a, &rhs2, d);
    for p in 0..d {
        x[p] += dx[p] * scale[p];
    }
    if x[..d].iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mut a_poly = Vec::with_capacity(n + 1);
    a_poly.push(1.0);
    a_poly.extend_from_slice(&x[..n]);
    let structure = Structure::Polynomial {
        a: a_poly,
        b: x[n..n + m].to_vec(),
        c: vec![1.0],
        delay,
    };
    let fit = h.folded(structure, x[n + m], (um, sums.ym));
    let (u_op, y_op) = fit.means();
    predict(
        &x[..n + m],
        (n, delay),
        (&uf, u_op - um),
        (y, &sums.yf, &prepared.step),
        (y_op - sums.ym, out),
    )?;
    Some(fit)
}

/// The one-step prediction `out = y - e`, `e(t) = A(q) L(y - y_op)(t) - B(q) L(u - u_op)(t)`
/// (lags before the first sample 0), from `L(u - um)`, `L(y - ym)` and the step response
/// (module documentation) of `y`, `L (y - ym)` and `L 1` from the window's first sample; `x`
/// holds `a_1..a_n, b_1..b_m`, `du = u_op - um`, `dy = y_op - ym`. `None` when a prediction is
/// not finite.
fn predict(
    x: &[f64],
    (n, delay): (usize, usize),
    (uf, du): (&[f64], f64),
    (y, yf, step): (&[f64], &[f64], &[f64]),
    (dy, out): (f64, &mut [f64]),
) -> Option<()> {
    let yc = |k: usize| yf[k] - dy * step[k];
    let uc = |k: usize| uf[k] - du * step[k];
    for (t, o) in out.iter_mut().enumerate() {
        let mut e = yc(t);
        for (i, a) in x[..n].iter().enumerate().filter(|(i, _)| *i < t) {
            e += a * yc(t - i - 1);
        }
        for (j, b) in x[n..].iter().enumerate() {
            let lag = delay + j + 1;
            if lag <= t {
                e -= b * uc(t - lag);
            }
        }
        *o = y[t] - e;
    }
    crate::la::all_finite(out).then_some(())
}

/// [`crate::LinearIdentifier::identify_predict_many`] of HARX: each input's fit on its
/// identification window from the normal equations (module documentation), or by the QR where
/// they are not trusted, then its one-step prediction over the record and the diagnostics from
/// that prediction's identification window, as `crate::predict_many_from_bare`. The output's
/// side comes from the batch's prepared output ([`HarxOutput`]); an output prepared otherwise
/// (e.g. [`crate::PreparedOutput::plain`], or for other orders) gets its own for this batch.
pub(crate) fn identify_predict_many(
    h: &Harx,
    batch: crate::Batch<'_>,
) -> Vec<Result<Identified, IdError>> {
    let own;
    let prepared = match batch.output.cache::<HarxOutput>() {
        Some(p) if p.key == key_of(h) => p,
        _ => {
            own = HarxOutput::new(h, batch.output.y());
            &own
        }
    };
    crate::predict_many_with(batch, |start, (u, y), window, out| {
        let block = prepared.block(h, start, y, window);
        let (uw, yw) = (&u[..window], &y[..window]);
        check_shared(uw, &block.checks, h.min_samples())?;
        let from_sums = block
            .sums
            .as_ref()
            .and_then(|sums| fit_from_sums(h, (prepared, sums), (u, y), window, out));
        Ok(match from_sums {
            Some(fit) => (fit, Ok(())),
            None => {
                let fit = h.fit_bare(uw, yw)?;
                let predicted = fit.predict_one_step_into(u, y, out);
                (fit, predicted)
            }
        })
    })
}

#[cfg(test)]
mod tests;
