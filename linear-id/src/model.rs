//! The fitted linear model returned by every identifier.

use faer::c64;
use serde::{Deserialize, Serialize};

use crate::error::{check_finite, IdError};
use crate::la;

/// Structure of a fitted model, in plain numbers (serde-serialisable).
///
/// Polynomial models (arx, armax, earx, earmax) use the paper's eqs. (2)-(8) on centered data:
/// `A(q) y_k = B(q) u_{k-delay} + C(q) e_k (+ η_k)` with
/// `a = [1, a1, …, an]`, `b = [b1, …, bm]` (coefficients of `q^-1 … q^-m`, so the first input
/// lag is `1 + delay`), `c = [1, c1, …, cp]` (`[1]` for ARX/EARX).
///
/// State-space models (ss) are in innovation form, eq. (6) plus an optional feedthrough `d`:
/// `x_{k+1} = A x_k + B u_k + K e_k`, `y_k = C x_k + D u_k + e_k`, on centered data, with
/// `x0` the state at the first sample of the identification data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "form", rename_all = "snake_case")]
pub enum Structure {
    /// `A(q) y = B(q) q^-delay u + C(q) e`.
    Polynomial {
        /// `[1, a1, …, an]`.
        a: Vec<f64>,
        /// `[b1, …, bm]`, coefficient of `u_{k-delay-j}`.
        b: Vec<f64>,
        /// `[1, c1, …, cp]`.
        c: Vec<f64>,
        /// Dead time in samples (`t_d` of eq. 2).
        delay: usize,
    },
    /// Innovation-form state space (SISO).
    StateSpace {
        /// `A`, row-major `n × n`.
        #[serde(rename = "A")]
        a: Vec<Vec<f64>>,
        /// `B`, `n × 1`.
        #[serde(rename = "B")]
        b: Vec<f64>,
        /// `C`, `1 × n`.
        #[serde(rename = "C")]
        c: Vec<f64>,
        /// `D` (0 unless requested).
        #[serde(rename = "D")]
        d: f64,
        /// Kalman gain `K`, `n × 1`.
        #[serde(rename = "K")]
        k: Vec<f64>,
        /// Initial state at sample 0 of the identification data (centered coordinates).
        x0: Vec<f64>,
    },
}

impl Structure {
    /// Model order (`n` of A(q), or the state dimension).
    pub fn order(&self) -> usize {
        match self {
            Structure::Polynomial { a, .. } => a.len() - 1,
            Structure::StateSpace { a, .. } => a.len(),
        }
    }

    /// `G(e^{iω})` for each ω, as `(re, im)`.
    pub fn frequency_response(&self, omegas: &[f64]) -> Vec<(f64, f64)> {
        omegas
            .iter()
            .map(|&w| {
                let g = self.eval(w);
                (g.re, g.im)
            })
            .collect()
    }

    fn eval(&self, w: f64) -> c64 {
        let zinv = c64::new(w.cos(), -w.sin()); // e^{-iω}
        match self {
            Structure::Polynomial { a, b, delay, .. } => {
                let den = horner(a, zinv);
                let mut num = c64::new(0.0, 0.0);
                let mut p = zinv.powu(*delay as u32 + 1);
                for &bj in b {
                    num += p * bj;
                    p *= zinv;
                }
                num / den
            }
            Structure::StateSpace { a, b, c, d, .. } => {
                // C (zI - A)^{-1} B + D
                let z = c64::new(w.cos(), w.sin());
                let n = a.len();
                let mut m: Vec<Vec<c64>> = (0..n)
                    .map(|i| {
                        (0..n)
                            .map(|j| {
                                let diag = if i == j { z } else { c64::new(0.0, 0.0) };
                                diag - a[i][j]
                            })
                            .collect()
                    })
                    .collect();
                let mut rhs: Vec<c64> = b.iter().map(|&v| c64::new(v, 0.0)).collect();
                match complex_solve(&mut m, &mut rhs) {
                    Some(()) => {
                        let mut g = c64::new(*d, 0.0);
                        for i in 0..n {
                            g += rhs[i] * c[i];
                        }
                        g
                    }
                    None => c64::new(f64::INFINITY, 0.0),
                }
            }
        }
    }

    /// Static gain `G(1)` (infinite or NaN for a pole at 1).
    pub fn static_gain(&self) -> f64 {
        self.eval(0.0).re
    }

    /// Poles of `G` (roots of `A(z)` / eigenvalues of `A`), `(re, im)`.
    pub fn poles(&self) -> Vec<(f64, f64)> {
        let r = match self {
            Structure::Polynomial { a, .. } => la::poly_roots(a),
            Structure::StateSpace { a, .. } => la::eigenvalues(a),
        };
        r.unwrap_or_else(|| vec![(f64::NAN, f64::NAN)])
    }

    /// Poles of the one-step predictor: roots of `C(z)` (polynomial) or eigenvalues of
    /// `A - K C` (state space).
    pub fn predictor_poles(&self) -> Vec<(f64, f64)> {
        let r = match self {
            Structure::Polynomial { c, .. } => la::poly_roots(c),
            Structure::StateSpace { a, c, k, .. } => {
                let ak: Vec<Vec<f64>> = a
                    .iter()
                    .enumerate()
                    .map(|(i, row)| {
                        row.iter()
                            .enumerate()
                            .map(|(j, v)| v - k[i] * c[j])
                            .collect()
                    })
                    .collect();
                la::eigenvalues(&ak)
            }
        };
        r.unwrap_or_else(|| vec![(f64::NAN, f64::NAN)])
    }

    /// The first `len` samples of the impulse response `h_0, h_1, …` (Markov parameters:
    /// `h_0 = D`, `h_k = C A^{k-1} B`).
    pub fn impulse_response(&self, len: usize) -> Vec<f64> {
        match self {
            Structure::Polynomial { a, b, delay, .. } => {
                let mut h = vec![0.0; len];
                for k in 0..len {
                    let mut v = 0.0;
                    for (j, &bj) in b.iter().enumerate() {
                        if k == delay + j + 1 {
                            v += bj;
                        }
                    }
                    for (i, &ai) in a.iter().enumerate().skip(1) {
                        if k >= i {
                            v -= ai * h[k - i];
                        }
                    }
                    h[k] = v;
                }
                h
            }
            Structure::StateSpace { a, b, c, d, .. } => {
                let mut h = Vec::with_capacity(len);
                if len > 0 {
                    h.push(*d);
                }
                let mut x = b.clone();
                while h.len() < len {
                    h.push(dot(c, &x));
                    x = matvec(a, &x);
                }
                h
            }
        }
    }
}

fn horner(p: &[f64], zinv: c64) -> c64 {
    // Σ p_i zinv^i
    let mut acc = c64::new(0.0, 0.0);
    for &pi in p.iter().rev() {
        acc = acc * zinv + pi;
    }
    acc
}

/// Gaussian elimination with partial pivoting on a small complex system (in place).
#[allow(clippy::needless_range_loop)]
fn complex_solve(m: &mut [Vec<c64>], rhs: &mut [c64]) -> Option<()> {
    let n = rhs.len();
    for col in 0..n {
        let piv = (col..n).max_by(|&i, &j| m[i][col].norm().total_cmp(&m[j][col].norm()))?;
        if m[piv][col].norm() == 0.0 || !m[piv][col].norm().is_finite() {
            return None;
        }
        m.swap(col, piv);
        rhs.swap(col, piv);
        for r in col + 1..n {
            let f = m[r][col] / m[col][col];
            for c in col..n {
                let t = m[col][c];
                m[r][c] -= f * t;
            }
            let t = rhs[col];
            rhs[r] -= f * t;
        }
    }
    for col in (0..n).rev() {
        let mut v = rhs[col];
        for c in col + 1..n {
            v -= m[col][c] * rhs[c];
        }
        rhs[col] = v / m[col][col];
    }
    Some(())
}

pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub(crate) fn matvec(a: &[Vec<f64>], x: &[f64]) -> Vec<f64> {
    a.iter().map(|row| dot(row, x)).collect()
}

/// Tuning of the time-varying bias recursion kept running at prediction time (EARX/EARMAX).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BiasTracking {
    /// Forgetting factor λ_β of the bias recursion.
    pub lambda: f64,
    /// Initial bias variance P_β(0).
    pub p0: f64,
}

/// Diagnostics of the identification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitInfo {
    /// Samples in the identification data.
    pub n_samples: usize,
    /// First sample with all lags available (polynomial models) / past horizon (ss).
    pub first_sample: usize,
    /// Mean squared one-step residual over `[first_sample, n_samples)`.
    pub residual_variance: f64,
    /// F_PV (eq. 9, squared norms) of the one-step prediction over the same samples, in %.
    pub fit_pv: f64,
    /// Largest modulus of the process poles.
    pub process_max_pole: f64,
    /// Largest modulus of the one-step-predictor poles (C(q) or A - K C; 0 for ARX).
    pub predictor_max_pole: f64,
    /// Singular values of the weighted SVD (ss only; empty otherwise).
    pub singular_values: Vec<f64>,
}

/// A fitted linear model: what [`crate::LinearIdentifier::identify`] returns.
///
/// All models work on data centered with the identification-window means (`u_mean`,
/// `y_mean`); the methods take and return raw (uncentered) signals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearFit {
    pub(crate) kind: String,
    pub(crate) structure: Structure,
    pub(crate) u_mean: f64,
    pub(crate) y_mean: f64,
    pub(crate) bias: Option<BiasTracking>,
    pub(crate) disturbance: Option<Vec<f64>>,
    pub(crate) info: FitInfo,
}

/// Stability margin: a pole with modulus `>= 1 - STABILITY_MARGIN` counts as unstable.
pub const STABILITY_MARGIN: f64 = 1e-9;

impl LinearFit {
    /// Build a fit from its parts and compute the diagnostics (`info`) on `(u, y)`.
    ///
    /// This is how a third-party identifier returns its model.
    pub fn new(
        kind: &str,
        structure: Structure,
        u_mean: f64,
        y_mean: f64,
        bias: Option<BiasTracking>,
        u: &[f64],
        y: &[f64],
    ) -> Result<LinearFit, IdError> {
        let mut fit = LinearFit {
            kind: kind.to_string(),
            structure,
            u_mean,
            y_mean,
            bias,
            disturbance: None,
            info: FitInfo {
                n_samples: u.len(),
                first_sample: 0,
                residual_variance: f64::NAN,
                fit_pv: f64::NAN,
                process_max_pole: f64::NAN,
                predictor_max_pole: f64::NAN,
                singular_values: Vec::new(),
            },
        };
        fit.refresh_info(u, y)?;
        Ok(fit)
    }

    pub(crate) fn refresh_info(&mut self, u: &[f64], y: &[f64]) -> Result<(), IdError> {
        let n0 = self.first_sample().min(y.len());
        let mut pred = vec![0.0; y.len()];
        let dist = self.predict_core(u, y, &mut pred)?;
        if self.bias.is_some() && self.disturbance.is_none() {
            self.disturbance = Some(dist);
        }
        let rss: f64 = y[n0..]
            .iter()
            .zip(&pred[n0..])
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        let cnt = (y.len() - n0).max(1) as f64;
        self.info.n_samples = y.len();
        self.info.first_sample = n0;
        self.info.residual_variance = rss / cnt;
        self.info.fit_pv = crate::fit::fit_pv(&y[n0..], &pred[n0..]);
        self.info.process_max_pole = la::max_modulus(&self.structure.poles());
        self.info.predictor_max_pole = la::max_modulus(&self.structure.predictor_poles());
        Ok(())
    }

    /// Registered name of the identifier that produced the model.
    pub fn kind(&self) -> &str {
        &self.kind
    }
    /// The model's structure (polynomials or state-space matrices).
    pub fn structure(&self) -> &Structure {
        &self.structure
    }
    /// Identification-window means subtracted from u and y.
    pub fn means(&self) -> (f64, f64) {
        (self.u_mean, self.y_mean)
    }
    /// Identification diagnostics.
    pub fn info(&self) -> &FitInfo {
        &self.info
    }
    /// Bias-recursion tuning (EARX/EARMAX), `None` for the other models.
    pub fn bias_tracking(&self) -> Option<BiasTracking> {
        self.bias
    }
    /// The estimated disturbance series η̂ (= β̂, centered PV units) over the identification
    /// data, for EARX/EARMAX; `None` otherwise.
    pub fn disturbance(&self) -> Option<&[f64]> {
        self.disturbance.as_deref()
    }

    /// First sample whose one-step prediction uses only measured lags.
    pub fn first_sample(&self) -> usize {
        match &self.structure {
            Structure::Polynomial { a, b, c, delay } => {
                (a.len() - 1).max(b.len() + delay).max(c.len() - 1)
            }
            Structure::StateSpace { .. } => 0,
        }
    }

    /// Static gain `G(1)`.
    pub fn static_gain(&self) -> f64 {
        self.structure.static_gain()
    }
    /// `G(e^{iω})` at each ω (rad/sample), as `(re, im)`.
    pub fn frequency_response(&self, omegas: &[f64]) -> Vec<(f64, f64)> {
        self.structure.frequency_response(omegas)
    }
    /// Process poles.
    pub fn poles(&self) -> Vec<(f64, f64)> {
        self.structure.poles()
    }
    /// Whether every process pole is strictly inside the unit circle.
    pub fn is_stable(&self) -> bool {
        self.info.process_max_pole < 1.0 - STABILITY_MARGIN
    }
    /// Whether the one-step predictor is stable (roots of C(q), eigenvalues of A - K C).
    pub fn is_predictor_stable(&self) -> bool {
        self.info.predictor_max_pole < 1.0 - STABILITY_MARGIN
    }
    /// `Err(IdError::Unstable)` if the process (`part = "process"`) or, when `predictor` is
    /// set, the one-step predictor is unstable. The grid search calls this before using a
    /// model, so that an unstable model is reported rather than silently used.
    pub fn check_stable(&self, predictor: bool) -> Result<(), IdError> {
        let identifier = crate::registry::static_name(&self.kind);
        if !self.is_stable() {
            return Err(IdError::Unstable {
                identifier,
                part: "process",
                max_modulus: self.info.process_max_pole,
            });
        }
        if predictor && !self.is_predictor_stable() {
            return Err(IdError::Unstable {
                identifier,
                part: "predictor",
                max_modulus: self.info.predictor_max_pole,
            });
        }
        Ok(())
    }

    /// One-step-ahead prediction of `y` from `u` and the measured `y` (same length).
    ///
    /// Polynomial models use measured lags (lags before sample 0 are the identification mean,
    /// i.e. 0 after centering; `ε = 0` before [`LinearFit::first_sample`]). EARX/EARMAX keep
    /// running the bias recursion over the given data with θ frozen, restarting from β = 0,
    /// and return the a-priori prediction. State space runs the predictor form from `x0`.
    pub fn predict_one_step(&self, u: &[f64], y: &[f64]) -> Result<Vec<f64>, IdError> {
        let mut out = vec![0.0; y.len()];
        self.predict_one_step_into(u, y, &mut out)?;
        Ok(out)
    }

    /// [`LinearFit::predict_one_step`] into a caller buffer (allocation-free for ARX/ss).
    pub fn predict_one_step_into(
        &self,
        u: &[f64],
        y: &[f64],
        out: &mut [f64],
    ) -> Result<(), IdError> {
        if u.len() != y.len() || out.len() != y.len() {
            return Err(IdError::LengthMismatch {
                u: u.len(),
                y: y.len().max(out.len()),
            });
        }
        check_finite("u", u)?;
        check_finite("y", y)?;
        self.predict_core(u, y, out)?;
        check_finite("estimate", out)
    }

    /// Runs the predictor; returns the β series for bias models (empty otherwise).
    fn predict_core(&self, u: &[f64], y: &[f64], out: &mut [f64]) -> Result<Vec<f64>, IdError> {
        let (um, ym) = (self.u_mean, self.y_mean);
        let n_data = y.len();
        match &self.structure {
            Structure::Polynomial { a, b, c, delay } => {
                let n0 = self.first_sample();
                let na = a.len() - 1;
                let nc = c.len() - 1;
                let nb = b.len();
                let mut eps = vec![0.0; if nc > 0 { n_data } else { 0 }];
                let mut betas = Vec::new();
                let mut beta = 0.0;
                let mut pb = self.bias.map_or(0.0, |bt| bt.p0);
                if self.bias.is_some() {
                    betas.resize(n0.min(n_data), 0.0);
                    betas.reserve(n_data);
                }
                // head: lags before sample 0 are the operating point (0 after centering)
                for k in 0..n0.min(n_data) {
                    let mut v = 0.0;
                    for i in 1..=na.min(k) {
                        v -= a[i] * (y[k - i] - ym);
                    }
                    for (j, &bj) in b.iter().enumerate() {
                        let lag = delay + j + 1;
                        if k >= lag {
                            v += bj * (u[k - lag] - um);
                        }
                    }
                    out[k] = v + ym;
                }
                // tail: every lag measured; centering folded into one constant
                let kconst = ym * a[1..].iter().sum::<f64>() - um * b.iter().sum::<f64>();
                for k in n0..n_data {
                    let mut v = kconst;
                    for (ai, yi) in a[1..].iter().zip(y[k - na..k].iter().rev()) {
                        v -= ai * yi;
                    }
                    for (bj, uj) in b.iter().zip(u[k - delay - nb..k - delay].iter().rev()) {
                        v += bj * uj;
                    }
                    if nc > 0 {
                        for (ci, ei) in c[1..].iter().zip(eps[k - nc..k].iter().rev()) {
                            v += ci * ei;
                        }
                    }
                    let yc = y[k] - ym;
                    match self.bias {
                        Some(bt) => {
                            out[k] = v + beta + ym;
                            let kb = pb / (bt.lambda + pb);
                            beta += kb * (yc - v - beta);
                            pb = (1.0 - kb) * pb / bt.lambda;
                            if nc > 0 {
                                eps[k] = yc - v - beta;
                            }
                            betas.push(beta);
                        }
                        None => {
                            out[k] = v + ym;
                            if nc > 0 {
                                eps[k] = yc - v;
                            }
                        }
                    }
                }
                Ok(betas)
            }
            Structure::StateSpace { a, b, c, d, k, x0 } => {
                let n = a.len();
                // predictor form: A_K = A - K C, B_K = B - K D
                let mut x = x0.clone();
                let mut xn = vec![0.0; n];
                for t in 0..n_data {
                    let uc = u[t] - um;
                    let yc = y[t] - ym;
                    let yhat = dot(c, &x) + d * uc;
                    out[t] = yhat + ym;
                    let e = yc - yhat;
                    for i in 0..n {
                        xn[i] = dot(&a[i], &x) + b[i] * uc + k[i] * e;
                    }
                    std::mem::swap(&mut x, &mut xn);
                }
                Ok(Vec::new())
            }
        }
    }

    /// Free-run simulation of the deterministic part from the input `u`.
    ///
    /// Polynomial models: `A(q) ŷ = B(q) u_{k-delay}`, where the first `y_init.len()` outputs
    /// are taken as given (measured PV at the start of the record) and lags before sample 0
    /// are the identification mean. State space: process form from `x0` (`y_init` is not
    /// used). The disturbance β̂ is not added (it is only known on the identification data;
    /// see [`LinearFit::disturbance`]).
    pub fn simulate(&self, u: &[f64], y_init: &[f64]) -> Result<Vec<f64>, IdError> {
        check_finite("u", u)?;
        check_finite("y", y_init)?;
        let (um, ym) = (self.u_mean, self.y_mean);
        let n_data = u.len();
        let mut out = vec![0.0; n_data];
        match &self.structure {
            Structure::Polynomial { a, b, delay, .. } => {
                let na = a.len() - 1;
                for k in 0..n_data {
                    if k < y_init.len() {
                        out[k] = y_init[k] - ym;
                        continue;
                    }
                    let mut v = 0.0;
                    for i in 1..=na.min(k) {
                        v -= a[i] * out[k - i];
                    }
                    for (j, &bj) in b.iter().enumerate() {
                        let lag = delay + j + 1;
                        if k >= lag {
                            v += bj * (u[k - lag] - um);
                        }
                    }
                    out[k] = v;
                }
            }
            Structure::StateSpace { a, b, c, d, x0, .. } => {
                let mut x = x0.clone();
                for t in 0..n_data {
                    let uc = u[t] - um;
                    out[t] = dot(c, &x) + d * uc;
                    let mut xn = matvec(a, &x);
                    for (xi, bi) in xn.iter_mut().zip(b) {
                        *xi += bi * uc;
                    }
                    x = xn;
                }
            }
        }
        out.iter_mut().for_each(|v| *v += ym);
        check_finite("estimate", &out)?;
        Ok(out)
    }
}
