//! The fitted linear model returned by every identifier.

use faer::c64;
use serde::{Deserialize, Serialize};

use crate::error::{check_finite, IdError};
use crate::la;

#[macro_use]
mod run;
mod structure;

use run::*;
pub use structure::Structure;

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

impl FitInfo {
    /// The diagnostics before they are computed: no samples, NaN indices and poles.
    pub(crate) fn unset() -> Self {
        FitInfo {
            n_samples: 0,
            first_sample: 0,
            residual_variance: f64::NAN,
            fit_pv: f64::NAN,
            process_max_pole: f64::NAN,
            predictor_max_pole: f64::NAN,
            singular_values: Vec::new(),
        }
    }
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
    /// HARX: the frequency (rad/sample) of the sinusoidal disturbance the one-step predictor
    /// annihilates ([`crate::Harx`]); `None` for the other models.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) harmonic: Option<f64>,
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
        let mut fit = LinearFit::bare(kind, structure, u_mean, y_mean, bias);
        fit.refresh_info(u, y)?;
        Ok(fit)
    }

    /// A fit from its parts, its diagnostics not computed yet: [`LinearFit::refresh_info`] or
    /// [`LinearFit::diagnose_from_prediction`] follows.
    pub(crate) fn bare(
        kind: &str,
        structure: Structure,
        u_mean: f64,
        y_mean: f64,
        bias: Option<BiasTracking>,
    ) -> LinearFit {
        LinearFit {
            kind: kind.to_string(),
            structure,
            u_mean,
            y_mean,
            bias,
            disturbance: None,
            harmonic: None,
            info: FitInfo::unset(),
        }
    }

    /// The diagnostics of a fit identified on `(u[..split], y[..split])` after its one-step
    /// prediction over all of `(u, y)` ran into `out` with outcome `predicted` (the error
    /// [`LinearFit::predict_one_step_into`] gives): from the prediction's first `split`
    /// samples when it came out (a prediction is causal, so they are the identification
    /// window's own), otherwise by predicting that window again. For
    /// [`crate::LinearIdentifier::identify_predict_many`].
    pub(crate) fn diagnose_from_prediction(
        mut self,
        (u, y): (&[f64], &[f64]),
        split: usize,
        out: &[f64],
        predicted: Result<(), IdError>,
    ) -> Result<crate::Identified, IdError> {
        match predicted {
            Ok(()) => self.refresh_info_from(&y[..split], &out[..split]),
            Err(_) => self.refresh_info(&u[..split], &y[..split])?,
        }
        Ok(crate::Identified {
            fit: self,
            prediction: predicted,
        })
    }

    /// A fit whose one-step residual sum of squares `rss` over `[first_sample, n_samples)` and
    /// the output's sum of squares about its mean there (`y_ss`) are already known (ARX: from
    /// the QR), so that no prediction has to run. Same `info` as [`LinearFit::new`] up to
    /// round-off (test `fast_diagnostics_match_prediction` in `arx.rs`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn with_diagnostics(
        kind: &str,
        structure: Structure,
        u_mean: f64,
        y_mean: f64,
        n_samples: usize,
        first_sample: usize,
        rss: f64,
        y_ss: f64,
    ) -> LinearFit {
        let cnt = (n_samples - first_sample).max(1) as f64;
        let fit_pv = if rss.is_finite() && y_ss > 0.0 {
            100.0 * (1.0 - rss / y_ss)
        } else {
            f64::NEG_INFINITY
        };
        let process_max_pole = la::max_modulus(&structure.poles());
        let predictor_max_pole = la::max_modulus(&structure.predictor_poles());
        LinearFit {
            kind: kind.to_string(),
            structure,
            u_mean,
            y_mean,
            bias: None,
            disturbance: None,
            harmonic: None,
            info: FitInfo {
                n_samples,
                first_sample,
                residual_variance: rss / cnt,
                fit_pv,
                process_max_pole,
                predictor_max_pole,
                singular_values: Vec::new(),
            },
        }
    }

    pub(crate) fn refresh_info(&mut self, u: &[f64], y: &[f64]) -> Result<(), IdError> {
        let mut pred = vec![0.0; y.len()];
        let dist = self.predict_core(u, y, &mut pred)?;
        if self.bias.is_some() && self.disturbance.is_none() {
            self.disturbance = Some(dist);
        }
        self.refresh_info_from(y, &pred);
        Ok(())
    }

    /// [`LinearFit::refresh_info`] from the one-step prediction `pred` of `y`, already run
    /// (the disturbance series aside, which it leaves as it is).
    pub(crate) fn refresh_info_from(&mut self, y: &[f64], pred: &[f64]) {
        let n0 = self.first_sample().min(y.len());
        // one pass: the residual sum of squares is F_PV's numerator
        let (rss, fit_pv) = match crate::fit::pv_sums(&y[n0..], &pred[n0..]) {
            Some((num, den)) => (num, crate::fit::fit_of_sums(num, den)),
            None => (0.0, f64::NEG_INFINITY),
        };
        let cnt = (y.len() - n0).max(1) as f64;
        self.info.n_samples = y.len();
        self.info.first_sample = n0;
        self.info.residual_variance = rss / cnt;
        self.info.fit_pv = fit_pv;
        self.info.process_max_pole = la::max_modulus(&self.structure.poles());
        self.info.predictor_max_pole = la::max_modulus(&self.structure.predictor_poles());
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
        // HARX's predictor has the notch's two more lags
        let notch = if self.harmonic.is_some() { 2 } else { 0 };
        match &self.structure {
            Structure::Polynomial { a, b, c, delay } => (a.len() - 1 + notch)
                .max(b.len() + delay + notch)
                .max(c.len() - 1),
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

    /// The one-step prediction of a polynomial model without its C(q) and bias terms: the
    /// head (lags before sample 0 are the operating point, 0 after centering) complete, the
    /// tail (every lag measured, from [`LinearFit::first_sample`]) as the A and B terms only,
    /// centered, unless the model has neither C(q) nor a bias, when the tail is complete too.
    /// Returns whether [`LinearFit::polynomial_recursion`] must still run over the tail.
    /// Panics unless the structure is polynomial.
    pub(crate) fn polynomial_terms(&self, u: &[f64], y: &[f64], out: &mut [f64]) -> bool {
        let Structure::Polynomial { a, b, c, delay } = &self.structure else {
            unreachable!("polynomial_terms of a state-space model")
        };
        let (um, ym) = (self.u_mean, self.y_mean);
        let n_data = y.len();
        let n0 = self.first_sample();
        let na = a.len() - 1;
        let nc = c.len() - 1;
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
        // tail: every lag measured; centering folded into one constant. The A and B terms do
        // not depend on earlier predictions: one vectorisable pass per coefficient, in the
        // same order as the sample-by-sample sum (same bits).
        if n0 >= n_data {
            return false;
        }
        let kconst = ym * a[1..].iter().sum::<f64>() - um * b.iter().sum::<f64>();
        let tail = &mut out[n0..n_data];
        tail.iter_mut().for_each(|v| *v = kconst);
        for (i, &ai) in a.iter().enumerate().skip(1) {
            let lagged = &y[n0 - i..n_data - i];
            for (v, yi) in tail.iter_mut().zip(lagged) {
                *v -= ai * yi;
            }
        }
        for (j, &bj) in b.iter().enumerate() {
            let lag = delay + j + 1;
            let lagged = &u[n0 - lag..n_data - lag];
            for (v, uj) in tail.iter_mut().zip(lagged) {
                *v += bj * uj;
            }
        }
        if nc == 0 && self.bias.is_none() {
            tail.iter_mut().for_each(|v| *v += ym);
            return false;
        }
        true
    }

    /// The serial part of a polynomial model's one-step prediction over the tail: the C(q)
    /// terms on the a-posteriori residuals `eps` (length of `y` when C(q) has terms) and the
    /// bias recursion, pushing β to `betas` (bias models), on top of
    /// [`LinearFit::polynomial_terms`]' A and B terms in `out`.
    pub(crate) fn polynomial_recursion(
        &self,
        y: &[f64],
        out: &mut [f64],
        eps: &mut [f64],
        betas: &mut Vec<f64>,
    ) {
        let Structure::Polynomial { c, .. } = &self.structure else {
            unreachable!("polynomial_recursion of a state-space model")
        };
        let ym = self.y_mean;
        let nc = c.len() - 1;
        let mut beta = 0.0;
        let mut pb = self.bias.map_or(0.0, |bt| bt.p0);
        for k in self.first_sample()..y.len() {
            let mut v = out[k];
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
    }

    /// The frequency of HARX's sinusoidal disturbance, rad/sample ([`crate::Harx`]); `None`
    /// for the other models.
    pub fn harmonic(&self) -> Option<f64> {
        self.harmonic
    }

    /// Runs the predictor; returns the β series for bias models (empty otherwise).
    fn predict_core(&self, u: &[f64], y: &[f64], out: &mut [f64]) -> Result<Vec<f64>, IdError> {
        if let Some(omega) = self.harmonic {
            // HARX: y_k - ŷ_k is the residual of the ARX of the notch-filtered signals
            // (crate::harmonic), whose operating point is 0
            let uf = crate::harmonic::notch_filter(u, self.u_mean, omega);
            let yf = crate::harmonic::notch_filter(y, self.y_mean, omega);
            let filtered = LinearFit::bare(&self.kind, self.structure.clone(), 0.0, 0.0, None);
            let betas = filtered.predict_core(&uf, &yf, out)?;
            for ((o, &f), &v) in out.iter_mut().zip(&yf).zip(y) {
                *o += v - f;
            }
            return Ok(betas);
        }
        let (um, ym) = (self.u_mean, self.y_mean);
        let n_data = y.len();
        match &self.structure {
            Structure::Polynomial { c, .. } => {
                let nc = c.len() - 1;
                let mut eps = vec![0.0; if nc > 0 { n_data } else { 0 }];
                let mut betas = Vec::new();
                if self.bias.is_some() {
                    betas.resize(self.first_sample().min(n_data), 0.0);
                    betas.reserve(n_data);
                }
                if self.polynomial_terms(u, y, out) {
                    self.polynomial_recursion(y, out, &mut eps, &mut betas);
                }
                Ok(betas)
            }
            Structure::StateSpace { a, b, c, d, k, x0 } => {
                let a_flat: Vec<f64> = a.iter().flatten().copied().collect();
                let m = SsModel {
                    a: &a_flat,
                    b,
                    c,
                    d: *d,
                    k,
                    x0,
                };
                dispatch_state_dim!(a.len(), |n| ss_run(n, &m, u, Some(y), um, ym, out));
                Ok(Vec::new())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn fit(structure: Structure, bias: Option<BiasTracking>) -> LinearFit {
        LinearFit {
            kind: "test".into(),
            structure,
            u_mean: 1.5,
            y_mean: -0.5,
            bias,
            disturbance: None,
            harmonic: None,
            info: FitInfo {
                n_samples: 0,
                first_sample: 0,
                residual_variance: 0.0,
                fit_pv: 0.0,
                process_max_pole: 0.0,
                predictor_max_pole: 0.0,
                singular_values: Vec::new(),
            },
        }
    }

    fn signals(len: usize) -> (Vec<f64>, Vec<f64>) {
        let u = (0..len)
            .map(|k| ((k * 13) % 7) as f64 * 0.3 + 1.0)
            .collect();
        let y = (0..len).map(|k| (k as f64 * 0.1).sin() - 0.4).collect();
        (u, y)
    }

    /// The sample-by-sample one-step predictor (the specification's loop).
    fn reference_predict(f: &LinearFit, u: &[f64], y: &[f64]) -> Vec<f64> {
        let Structure::Polynomial { a, b, c, delay } = &f.structure else {
            unreachable!()
        };
        let (um, ym) = (f.u_mean, f.y_mean);
        let n0 = f.first_sample();
        let (na, nc) = (a.len() - 1, c.len() - 1);
        let mut out = vec![0.0; y.len()];
        let mut eps = vec![0.0; y.len()];
        let (mut beta, mut pb) = (0.0, f.bias.map_or(0.0, |b| b.p0));
        for k in 0..y.len() {
            let mut v = 0.0;
            for i in 1..=na.min(k) {
                v -= a[i] * (y[k - i] - ym);
            }
            for (j, &bj) in b.iter().enumerate() {
                if k > delay + j {
                    v += bj * (u[k - delay - j - 1] - um);
                }
            }
            if k < n0 {
                out[k] = v + ym;
                continue;
            }
            for i in 1..=nc {
                v += c[i] * eps[k - i];
            }
            let yc = y[k] - ym;
            match f.bias {
                Some(bt) => {
                    out[k] = v + beta + ym;
                    let kb = pb / (bt.lambda + pb);
                    beta += kb * (yc - v - beta);
                    pb = (1.0 - kb) * pb / bt.lambda;
                    eps[k] = yc - v - beta;
                }
                None => {
                    out[k] = v + ym;
                    eps[k] = yc - v;
                }
            }
        }
        out
    }

    #[test]
    fn vectorised_polynomial_prediction_matches_the_sample_loop() {
        let (u, y) = signals(400);
        let bias = Some(BiasTracking {
            lambda: 0.8,
            p0: 1e4,
        });
        for (c, bias) in [
            (vec![1.0], None),
            (vec![1.0, 0.3, -0.1], None),
            (vec![1.0], bias),
            (vec![1.0, 0.2], bias),
        ] {
            let f = fit(
                Structure::Polynomial {
                    a: vec![1.0, -0.9, 0.2],
                    b: vec![0.4, 0.1, 0.05],
                    c,
                    delay: 2,
                },
                bias,
            );
            let fast = f.predict_one_step(&u, &y).unwrap();
            let want = reference_predict(&f, &u, &y);
            for (a, b) in fast.iter().zip(&want) {
                assert!((a - b).abs() < 1e-12 * (1.0 + b.abs()), "{a} vs {b}");
            }
        }
    }

    #[test]
    fn blocked_free_run_matches_simulate() {
        let (u, y) = signals(3000);
        for (a, b, delay) in [
            (vec![1.0, -1.5, 0.7], vec![0.5, 0.3], 0),
            (vec![1.0, -0.9], vec![0.2], 3),
            (vec![1.0, -2.4, 2.1, -0.68], vec![0.1, 0.2, -0.05], 1),
            (vec![1.0, -0.999], vec![0.001, 0.002], 0),
            (vec![1.0, 0.3, -0.2, 0.1, 0.05], vec![1.0], 2),
        ] {
            let f = fit(
                Structure::Polynomial {
                    a,
                    b,
                    c: vec![1.0],
                    delay,
                },
                None,
            );
            for len in [3000, 700, 40] {
                let init = &y[..f.first_sample()];
                let want = f.simulate(&u[..len], init).unwrap();
                let mut got = vec![0.0; len];
                f.simulate_blocked_into(&u[..len], init, &mut got).unwrap();
                let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for (k, (w, g)) in want.iter().zip(&got).enumerate() {
                    assert!((w - g).abs() <= 1e-12 * scale, "{k}: {w} vs {g}");
                }
            }
        }
    }

    #[test]
    fn polynomial_free_run_matches_the_sample_loop() {
        let (u, y) = signals(200);
        // (2, 2) and (1, 3) take the fixed-order tail, (4, 1) and (2, 5) the dynamic one
        for (a, b, delay, n_init) in [
            (vec![1.0, -0.9, 0.2], vec![0.4, 0.1], 0, 2),
            (vec![1.0, -0.5], vec![0.4, 0.1, 0.05], 3, 0),
            (vec![1.0, -0.5, 0.1, 0.02, -0.01], vec![0.3], 1, 7),
            (vec![1.0, -0.9, 0.2], vec![0.1; 5], 2, 1),
        ] {
            let f = fit(
                Structure::Polynomial {
                    a: a.clone(),
                    b: b.clone(),
                    c: vec![1.0],
                    delay,
                },
                None,
            );
            let (um, ym) = (f.u_mean, f.y_mean);
            let sim = f.simulate(&u, &y[..n_init]).unwrap();
            let mut want = vec![0.0; u.len()];
            for k in 0..u.len() {
                if k < n_init {
                    want[k] = y[k] - ym;
                    continue;
                }
                let mut v = 0.0;
                for i in 1..a.len().min(k + 1) {
                    v -= a[i] * want[k - i];
                }
                for (j, &bj) in b.iter().enumerate() {
                    if k > delay + j {
                        v += bj * (u[k - delay - j - 1] - um);
                    }
                }
                want[k] = v;
            }
            for (got, w) in sim.iter().zip(&want) {
                assert_eq!(*got, w + ym);
            }
        }
    }

    #[test]
    fn state_space_runs_match_the_plain_loops() {
        let (u, y) = signals(300);
        for n in [1usize, 2, 3, 5] {
            let a: Vec<Vec<f64>> = (0..n)
                .map(|i| (0..n).map(|j| if i == j { 0.6 } else { 0.05 }).collect())
                .collect();
            let b: Vec<f64> = (0..n).map(|i| 0.1 * (i + 1) as f64).collect();
            let c: Vec<f64> = (0..n).map(|i| 1.0 - 0.2 * i as f64).collect();
            let k: Vec<f64> = (0..n).map(|i| 0.05 * i as f64).collect();
            let x0: Vec<f64> = (0..n).map(|i| 0.3 - 0.1 * i as f64).collect();
            let d = 0.2;
            let f = fit(
                Structure::StateSpace {
                    a: a.clone(),
                    b: b.clone(),
                    c: c.clone(),
                    d,
                    k: k.clone(),
                    x0: x0.clone(),
                },
                None,
            );
            let (um, ym) = (f.u_mean, f.y_mean);
            let pred = f.predict_one_step(&u, &y).unwrap();
            let sim = f.simulate(&u, &[]).unwrap();
            let (mut xp, mut xs) = (x0.clone(), x0.clone());
            for t in 0..u.len() {
                let uc = u[t] - um;
                let yhat = dot(&c, &xp) + d * uc;
                assert!((pred[t] - (yhat + ym)).abs() < 1e-12, "n={n} t={t}");
                let e = (y[t] - ym) - yhat;
                xp = (0..n)
                    .map(|i| dot(&a[i], &xp) + b[i] * uc + k[i] * e)
                    .collect();
                let ys = dot(&c, &xs) + d * uc;
                assert!((sim[t] - (ys + ym)).abs() < 1e-12, "n={n} t={t}");
                xs = (0..n).map(|i| dot(&a[i], &xs) + b[i] * uc).collect();
            }
        }
    }
}
