//! ARMAX, EARX and EARMAX by the recursive (extended) least-squares algorithm of Karra &
//! Karim (2009), with, for the extended models, a time-varying bias β_k (= η_k of eqs. 7-8)
//! estimated by a second, decoupled RLS with its own forgetting factor.
//!
//! One step at sample k (spec §4.3; φ holds `-y` lags, `u` lags and a-posteriori residual
//! lags ε):
//!
//! ```text
//! z    = y_k - β                                       (β = 0 for armax)
//! K_θ  = P_θ φ / (λ_θ + φᵀ P_θ φ);  θ += K_θ (z - φᵀθ);  P_θ = (P_θ - K_θ φᵀ P_θ) / λ_θ
//! λ_θ  = λ_rate λ_θ + (1 - λ_rate)                     (variable forgetting, λ_θ → 1)
//! r    = y_k - φᵀθ;  K_β = P_β / (λ_β + P_β);  β += K_β (r - β);  P_β = (1 - K_β) P_β / λ_β
//! ε_k  = y_k - φᵀθ - β
//! ```
//! `P_θ` is symmetrised every step and its trace bounded by `trace_max`.

use serde::{Deserialize, Serialize};

mod lanes;

use crate::arx::{MAX_DELAY, MAX_ORDER};
use crate::error::{check_data, check_order, check_real};
use crate::{la, mean, BiasTracking, IdError, LinearFit, OrderValue, Structure};

/// Tuning of the recursive estimator (shared by armax, earx, earmax).
///
/// | name | default | meaning | valid range |
/// |------|---------|---------|-------------|
/// | `p0` | 1e4 | initial covariance `P_θ(0) = p0 I` | (0, 1e12] |
/// | `lambda_theta0` | 0.95 | initial forgetting factor λ_θ of the LTI part | [0.5, 1] |
/// | `lambda_rate` | 0.99 | λ_θ ← rate λ_θ + (1 - rate): λ_θ → 1 with time constant 1/(1-rate) | [0, 1] |
/// | `lambda_beta` | 0.8 | constant forgetting factor λ_β of the bias (earx/earmax only) | [0.05, 1] |
/// | `p_beta0` | 1e4 | initial bias variance `P_β(0)` | (0, 1e12] |
/// | `trace_max` | 1e8 | bound on `trace(P_θ)` (rescaled when exceeded) | (0, 1e15] |
///
/// The defaults are those of the specification §4.3 except `lambda_beta = 0.8` (spec: 0.9),
/// chosen by a sweep on the paper's loop (see the crate documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecursiveOptions {
    /// Initial covariance scale.
    pub p0: f64,
    /// Initial λ_θ.
    pub lambda_theta0: f64,
    /// Rate at which λ_θ tends to 1.
    pub lambda_rate: f64,
    /// Bias forgetting factor λ_β.
    pub lambda_beta: f64,
    /// Initial bias variance.
    pub p_beta0: f64,
    /// Bound on trace(P_θ).
    pub trace_max: f64,
}

impl Default for RecursiveOptions {
    fn default() -> Self {
        RecursiveOptions {
            p0: 1e4,
            lambda_theta0: 0.95,
            lambda_rate: 0.99,
            lambda_beta: 0.8,
            p_beta0: 1e4,
            trace_max: 1e8,
        }
    }
}

impl RecursiveOptions {
    fn check(&self, identifier: &'static str) -> Result<(), IdError> {
        check_real(identifier, "p0", self.p0, 1e-12, 1e12)?;
        check_real(identifier, "lambda_theta0", self.lambda_theta0, 0.5, 1.0)?;
        check_real(identifier, "lambda_rate", self.lambda_rate, 0.0, 1.0)?;
        check_real(identifier, "lambda_beta", self.lambda_beta, 0.05, 1.0)?;
        check_real(identifier, "p_beta0", self.p_beta0, 1e-12, 1e12)?;
        check_real(identifier, "trace_max", self.trace_max, 1e-12, 1e15)?;
        Ok(())
    }
}

/// Shared configuration of the three recursive identifiers.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Recursive {
    name: &'static str,
    na: usize,
    nb: usize,
    nc: usize,
    delay: usize,
    bias: bool,
    tuning: RecursiveOptions,
}

/// Result of one pass of the recursion.
struct RlsRun {
    theta: Vec<f64>,
    betas: Vec<f64>,
}

impl Recursive {
    fn check(&self) -> Result<(), IdError> {
        check_order(self.name, "n", self.na, 0, MAX_ORDER)?;
        check_order(self.name, "m", self.nb, 1, MAX_ORDER)?;
        if self.name != "earx" {
            check_order(
                self.name,
                "p",
                self.nc,
                if self.name == "armax" { 1 } else { 0 },
                MAX_ORDER,
            )?;
        }
        check_order(self.name, "delay", self.delay, 0, MAX_DELAY)?;
        self.tuning.check(self.name)
    }

    fn n0(&self) -> usize {
        self.na.max(self.nb + self.delay).max(self.nc)
    }

    fn dim(&self) -> usize {
        self.na + self.nb + self.nc
    }

    fn min_samples(&self) -> usize {
        self.n0() + 2 * self.dim() + 2
    }

    /// The recursion over centered data. Dimensions up to 8 (every default order) run on
    /// fixed-size stack arrays, so the compiler unrolls the `d × d` loops; larger ones on
    /// heap vectors; both through the same code ([`Recursive::run_with`]).
    fn run(&self, uc: &[f64], yc: &[f64]) -> Result<RlsRun, IdError> {
        macro_rules! fixed {
            ($($d:literal)*) => {
                match self.dim() {
                    $($d => return self.run_fixed::<$d>(uc, yc),)*
                    _ => {}
                }
            };
        }
        fixed!(1 2 3 4 5 6 7 8);
        let d = self.dim();
        let mut theta = vec![0.0; d];
        let mut p = vec![0.0; d * d];
        let mut phi = vec![0.0; d];
        let mut pphi = vec![0.0; d];
        let betas = self.run_with(uc, yc, &mut theta, &mut p, &mut phi, &mut pphi)?;
        Ok(RlsRun { theta, betas })
    }

    fn run_fixed<const D: usize>(&self, uc: &[f64], yc: &[f64]) -> Result<RlsRun, IdError> {
        let mut theta = [0.0; D];
        let mut p = [[0.0; D]; D];
        let mut phi = [0.0; D];
        let mut pphi = [0.0; D];
        let betas = self.run_with(
            uc,
            yc,
            &mut theta,
            p.as_flattened_mut(),
            &mut phi,
            &mut pphi,
        )?;
        Ok(RlsRun {
            theta: theta.to_vec(),
            betas,
        })
    }

    /// The recursion with caller storage (`theta`, `phi`, `pphi` of length `d`, `p` of
    /// `d²`, row-major); returns the β series (empty without bias).
    #[inline(always)]
    fn run_with(
        &self,
        uc: &[f64],
        yc: &[f64],
        theta: &mut [f64],
        p: &mut [f64],
        phi: &mut [f64],
        pphi: &mut [f64],
    ) -> Result<Vec<f64>, IdError> {
        let (na, nb, nc, delay) = (self.na, self.nb, self.nc, self.delay);
        let t = &self.tuning;
        let d = theta.len();
        let (p, phi, pphi) = (&mut p[..d * d], &mut phi[..d], &mut pphi[..d]);
        let len = yc.len();
        let n0 = self.n0();
        for i in 0..d {
            p[i * d + i] = t.p0;
        }
        let mut lam = t.lambda_theta0;
        let mut beta = 0.0;
        let mut pb = t.p_beta0;
        let mut eps = vec![0.0; len];
        let mut betas = vec![0.0; if self.bias { len } else { 0 }];
        for k in n0..len {
            for i in 0..na {
                phi[i] = -yc[k - 1 - i];
            }
            for j in 0..nb {
                phi[na + j] = uc[k - 1 - delay - j];
            }
            for i in 0..nc {
                phi[na + nb + i] = eps[k - 1 - i];
            }
            // LTI part on the bias-corrected output
            let z = yc[k] - beta;
            let mut quad = 0.0;
            for (r, row) in p.chunks_exact(d).enumerate() {
                let v: f64 = row.iter().zip(&*phi).map(|(a, b)| a * b).sum();
                pphi[r] = v;
                quad += phi[r] * v;
            }
            let den = lam + quad;
            let pred: f64 = phi.iter().zip(&*theta).map(|(a, b)| a * b).sum();
            let err = z - pred;
            let inv = 1.0 / den;
            for r in 0..d {
                theta[r] += pphi[r] * inv * err;
            }
            let inv_lam = 1.0 / lam;
            let mut trace = 0.0;
            for r in 0..d {
                for c in r..d {
                    let v = (p[r * d + c] - pphi[r] * pphi[c] * inv) * inv_lam;
                    p[r * d + c] = v;
                    p[c * d + r] = v;
                }
                trace += p[r * d + r];
            }
            if trace > t.trace_max {
                let s = t.trace_max / trace;
                p.iter_mut().for_each(|v| *v *= s);
            }
            lam = t.lambda_rate * lam + (1.0 - t.lambda_rate);
            let lti: f64 = phi.iter().zip(&*theta).map(|(a, b)| a * b).sum();
            if self.bias {
                let r = yc[k] - lti;
                let kb = pb / (t.lambda_beta + pb);
                beta += kb * (r - beta);
                pb = (1.0 - kb) * pb / t.lambda_beta;
                betas[k] = beta;
            }
            eps[k] = yc[k] - lti - beta;
            if !(eps[k].is_finite() && trace.is_finite()) {
                return Err(IdError::NotConverged {
                    identifier: self.name,
                    detail: format!("recursive estimate diverged at sample {k}"),
                });
            }
        }
        Ok(betas)
    }

    fn identify(&self, u: &[f64], y: &[f64]) -> Result<LinearFit, IdError> {
        check_data(u, y, self.min_samples())?;
        let u_mean = mean(u);
        let y_mean = mean(y);
        let uc: Vec<f64> = u.iter().map(|v| v - u_mean).collect();
        let yc: Vec<f64> = y.iter().map(|v| v - y_mean).collect();
        let run = self.run(&uc, &yc)?;
        let mut fit = self.fit_of(run, u_mean, y_mean);
        fit.refresh_info(u, y)?;
        Ok(fit)
    }

    /// The model of a finished recursion, its diagnostics not yet computed.
    fn fit_of(&self, run: RlsRun, u_mean: f64, y_mean: f64) -> LinearFit {
        let (na, nb) = (self.na, self.nb);
        let mut a = vec![1.0];
        a.extend_from_slice(&run.theta[..na]);
        let mut c = vec![1.0];
        c.extend_from_slice(&run.theta[na + nb..]);
        let structure = Structure::Polynomial {
            a,
            b: run.theta[na..na + nb].to_vec(),
            c,
            delay: self.delay,
        };
        let bias = self.bias.then_some(BiasTracking {
            lambda: self.tuning.lambda_beta,
            p0: self.tuning.p_beta0,
        });
        LinearFit {
            kind: self.name.to_string(),
            structure,
            u_mean,
            y_mean,
            bias,
            disturbance: self.bias.then_some(run.betas),
            harmonic: None,
            info: crate::FitInfo::unset(),
        }
    }
}

macro_rules! recursive_identifier {
    (
        $ty:ident, $params:ident, $pstr:literal, $tag:literal, $bias:expr, $doc:literal,
        n = $n:expr, m = $m:expr, p = $p:expr, has_p = $has_p:tt,
        description $description:expr;
        $(order p { $($c_order:tt)* })?
        $(option { $($bias_option:tt)* })?
    ) => {
        #[doc = $doc]
        ///
        /// | name | default | meaning | valid range |
        /// |------|---------|---------|-------------|
        #[doc = concat!("| `n` | ", stringify!($n), " | order of A(q) | 0 ..= 50 |")]
        #[doc = concat!("| `m` | ", stringify!($m), " | order of B(q) | 1 ..= 50 |")]
        #[doc = concat!("| `p` | ", stringify!($p), " | order of C(q) (absent for earx) | see `check` |")]
        /// | `delay` | 0 | dead time: first input lag is `1 + delay` | 0 ..= 10000 |
        /// | `tuning` | see [`RecursiveOptions`] | forgetting factors and initial covariances | |
        #[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
        #[serde(try_from = $pstr, into = $pstr)]
        pub struct $ty {
            inner: Recursive,
        }

        /// Unchecked parameters; `check()` builds the identifier.
        #[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
        #[serde(deny_unknown_fields, default)]
        pub struct $params {
            /// Order of A(q).
            pub n: usize,
            /// Order of B(q).
            pub m: usize,
            /// Order of C(q) (always 0 for earx).
            #[serde(skip_serializing_if = "skip_p")]
            pub p: usize,
            /// Dead time in samples.
            pub delay: usize,
            /// Recursive-estimator tuning.
            pub tuning: RecursiveOptions,
        }

        impl Default for $params {
            fn default() -> Self {
                $params {
                    n: $n,
                    m: $m,
                    p: $p,
                    delay: 0,
                    tuning: RecursiveOptions::default(),
                }
            }
        }

        impl $params {
            crate::declare::setters!(n: usize, m: usize, delay: usize, p: usize, tuning: RecursiveOptions);
            /// Set the bias forgetting factor λ_β (ignored by armax).
            pub fn lambda_beta(mut self, lambda_beta: f64) -> Self {
                self.tuning.lambda_beta = lambda_beta;
                self
            }
            /// Validate and build.
            pub fn check(self) -> Result<$ty, IdError> {
                if !$has_p && self.p != 0 {
                    return Err(IdError::InvalidOrder {
                        identifier: $tag,
                        name: "p".into(),
                        value: OrderValue::Int(self.p),
                        expected: "0 (earx has no C(q); use earmax)".into(),
                    });
                }
                let inner = Recursive {
                    name: $tag,
                    na: self.n,
                    nb: self.m,
                    nc: self.p,
                    delay: self.delay,
                    bias: $bias,
                    tuning: self.tuning,
                };
                inner.check()?;
                Ok($ty { inner })
            }
        }

        impl From<$ty> for $params {
            fn from(t: $ty) -> Self {
                $params {
                    n: t.inner.na,
                    m: t.inner.nb,
                    p: t.inner.nc,
                    delay: t.inner.delay,
                    tuning: t.inner.tuning,
                }
            }
        }

        crate::linear_identifier! {
            $ty($tag) from $params;
            description $description;
            orders {
                n: Int($n), "order of A(q)", |q| q.n;
                m: Int($m), "order of B(q) (b1 q^-1 .. bm q^-m)", |q| q.m;
                $($($c_order)*)?
                delay: Int(0), "dead time t_d in samples (first input lag is 1 + delay)", |q| q.delay;
                $($($bias_option)*)?
            }
            impl {
                fn min_samples(&self) -> usize {
                    self.inner.min_samples()
                }
                fn identify(&self, u: &[f64], y: &[f64]) -> Result<LinearFit, IdError> {
                    self.inner.identify(u, y)
                }
                fn identify_predict_many(
                    &self,
                    batch: crate::Batch<'_>,
                ) -> Vec<Result<crate::Identified, IdError>> {
                    self.inner.identify_predict_many(batch)
                }
            }
        }
    };
}

fn skip_p(p: &usize) -> bool {
    *p == 0
}

recursive_identifier! {
    Armax, ArmaxParams, "ArmaxParams", "armax", false,
    "ARMAX, eq. (4), by recursive extended least squares (Karra & Karim without the bias).",
    n = 2, m = 2, p = 2, has_p = true,
    description "ARMAX (eq. 4) by recursive extended least squares (Karra & Karim, no bias)";
    order p { p: Int(2), "order of C(q) (moving average)", |q| q.p; }
}

recursive_identifier! {
    Earx, EarxParams, "EarxParams", "earx", true,
    "EARX, eq. (7): ARX plus a time-varying bias η_k, by the decoupled recursive estimator of Karra & Karim.",
    n = 2, m = 2, p = 0, has_p = false,
    description "EARX (eq. 7): ARX + time-varying bias, decoupled recursive LS with forgetting";
    option {
        lambda_beta: Real(0.8),
            "forgetting factor of the time-varying bias (smaller tracks faster)",
            |q| q.tuning.lambda_beta;
    }
}

recursive_identifier! {
    Earmax, EarmaxParams, "EarmaxParams", "earmax", true,
    "EARMAX, eq. (8): ARMAX plus a time-varying bias η_k, by the decoupled recursive estimator of Karra & Karim.",
    n = 2, m = 2, p = 2, has_p = true,
    description "EARMAX (eq. 8): ARMAX + time-varying bias, decoupled recursive ELS with forgetting";
    order p { p: Int(2), "order of C(q) (moving average)", |q| q.p; }
    option {
        lambda_beta: Real(0.8),
            "forgetting factor of the time-varying bias (smaller tracks faster)",
            |q| q.tuning.lambda_beta;
    }
}

/// Batch ARMAX by iterative extended least squares (spec §4.2; the algorithm of SIPPY's
/// ARMAX), a cross-check for the recursive `armax`. Orders as in [`Armax`]; at most
/// `max_iter` iterations (each one QR least-squares solve).
pub fn armax_batch(
    u: &[f64],
    y: &[f64],
    n: usize,
    m: usize,
    p: usize,
    delay: usize,
    max_iter: usize,
) -> Result<LinearFit, IdError> {
    let cfg = Armax::params().n(n).m(m).p(p).delay(delay).check()?.inner;
    check_data(u, y, cfg.min_samples())?;
    let u_mean = mean(u);
    let y_mean = mean(y);
    let uc: Vec<f64> = u.iter().map(|v| v - u_mean).collect();
    let yc: Vec<f64> = y.iter().map(|v| v - y_mean).collect();
    let len = y.len();
    let n0 = cfg.n0();
    let d = n + m + p;
    let rows = len - n0;
    let mut eps = vec![0.0; len];
    let mut theta_old = vec![0.0; d];
    let mut v_old = f64::INFINITY;
    let resid = |x: &faer::Mat<f64>, th: &[f64]| -> (f64, Vec<f64>) {
        let mut r = vec![0.0; rows];
        let mut s = 0.0;
        for (i, ri) in r.iter_mut().enumerate() {
            let mut v = x[(i, d)];
            for (j, t) in th.iter().enumerate() {
                v -= x[(i, j)] * t;
            }
            *ri = v;
            s += v * v;
        }
        (s / rows as f64, r)
    };
    for _ in 0..max_iter.max(1) {
        let mut x = faer::Mat::<f64>::zeros(rows, d + 1);
        for r in 0..rows {
            let k = n0 + r;
            for i in 0..n {
                x[(r, i)] = -yc[k - 1 - i];
            }
            for j in 0..m {
                x[(r, n + j)] = uc[k - 1 - delay - j];
            }
            for i in 0..p {
                x[(r, n + m + i)] = eps[k - 1 - i];
            }
            x[(r, d)] = yc[k];
        }
        let sol = match la::lstsq_augmented(x.clone()) {
            Ok(s) => s,
            // residual columns identically zero on the first pass: solve without them
            Err(_) if v_old.is_infinite() => {
                let mut xa = faer::Mat::<f64>::zeros(rows, n + m + 1);
                for r in 0..rows {
                    for j in 0..n + m {
                        xa[(r, j)] = x[(r, j)];
                    }
                    xa[(r, n + m)] = x[(r, d)];
                }
                let s = la::lstsq_augmented(xa).map_err(|pv| IdError::Singular {
                    identifier: "armax",
                    detail: format!("smallest relative QR pivot {pv:.3e}"),
                })?;
                let mut xx = s.x;
                xx.resize(d, 0.0);
                la::LsSolution { x: xx, rss: s.rss }
            }
            Err(pv) => {
                return Err(IdError::Singular {
                    identifier: "armax",
                    detail: format!("smallest relative QR pivot {pv:.3e}"),
                })
            }
        };
        let (mut v, _) = resid(&x, &sol.x);
        let mut theta = sol.x.clone();
        if v > v_old {
            let mut alpha = 0.5;
            loop {
                theta = sol
                    .x
                    .iter()
                    .zip(&theta_old)
                    .map(|(a, b)| alpha * a + (1.0 - alpha) * b)
                    .collect();
                v = resid(&x, &theta).0;
                alpha /= 2.0;
                if v <= v_old {
                    break;
                }
                if alpha < f32::EPSILON as f64 {
                    theta = theta_old.clone();
                    v = v_old;
                    break;
                }
            }
        }
        let (_, r) = resid(&x, &theta);
        eps[n0..].copy_from_slice(&r);
        let stop = v >= v_old;
        theta_old = theta;
        if stop {
            break;
        }
        v_old = v;
    }
    let mut a = vec![1.0];
    a.extend_from_slice(&theta_old[..n]);
    let mut c = vec![1.0];
    c.extend_from_slice(&theta_old[n + m..]);
    let structure = Structure::Polynomial {
        a,
        b: theta_old[n..n + m].to_vec(),
        c,
        delay,
    };
    LinearFit::new("armax", structure, u_mean, y_mean, None, u, y)
}
