//! ARX (paper eq. 2) by linear least squares through a Householder QR (ours for
//! `n + m <= 15`, faer's blocked QR above).

use serde::{Deserialize, Serialize};

use crate::error::{check_data, check_order};
use crate::{la, mean, IdError, LinearFit, PreparedOutput, Structure};

/// Largest accepted polynomial order.
pub(crate) const MAX_ORDER: usize = 50;
/// Largest accepted dead time.
pub(crate) const MAX_DELAY: usize = 10_000;

/// How ARX handles the signals' offsets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Centering {
    /// Default. Least squares with an intercept (every regression column centered with its own
    /// mean over the regression rows, which is the same thing), the intercept then folded into
    /// the model's operating point ([`LinearFit::means`]). Exact for noise-free ARX data with
    /// any offset.
    #[default]
    OperatingPoint,
    /// Subtract the identification-window means of u and y, then least squares without an
    /// intercept (SIPPY's `centering = "MeanVal"`). Off by O(1/N) on offset data.
    Mean,
}

crate::declare::identifier_params! {
    /// ARX, eq. (2): `A(q) y_k = B(q) u_{k-delay} + e_k`, by least squares (QR, no normal
    /// equations) on mean-centered data.
    ///
    /// | name | default | meaning | valid range |
    /// |------|---------|---------|-------------|
    /// | `n` | 2 | order of A(q) (`a1 … an`) | 0 ..= 50 |
    /// | `m` | 2 | order of B(q) (`b1 q^-1 … bm q^-m`) | 1 ..= 50 |
    /// | `delay` | 0 | dead time `t_d`: first input lag is `1 + delay` | 0 ..= 10000 |
    ///
    /// | `centering` | `"operating_point"` | offset handling, see [`Centering`] | |
    ///
    /// A regression whose column-equilibrated QR has a relative pivot below 1e-10 is
    /// [`IdError::Singular`].
    #[derive(Eq)]
    pub struct Arx;
    /// Unchecked parameters of [`Arx`]; [`ArxParams::check`] builds the identifier.
    #[derive(Eq)]
    pub struct ArxParams {
        /// Order of A(q).
        n: usize = 2,
        /// Order of B(q).
        m: usize = 2,
        /// Dead time in samples.
        delay: usize = 0,
        /// Offset handling.
        centering: Centering = Centering::OperatingPoint,
    }
    check |p| {
        check_order("arx", "n", p.n, 0, MAX_ORDER)?;
        check_order("arx", "m", p.m, 1, MAX_ORDER)?;
        check_order("arx", "delay", p.delay, 0, MAX_DELAY)?;
    }
}

impl crate::FastPaths for Arx {
    fn output_sums(&self, y: &[f64]) -> Option<crate::ArxOutputSums> {
        Arx::output_sums(self, y)
    }
}

/// Cached centered output for [`LinearIdentifier::prepare`].
struct ArxCache {
    y_mean: f64,
    yc: Vec<f64>,
}

impl Arx {
    /// `(n, m, delay)`.
    pub(crate) fn orders_tuple(&self) -> (usize, usize, usize) {
        (self.n, self.m, self.delay)
    }

    /// The offset handling.
    pub fn centering_mode(&self) -> Centering {
        self.centering
    }

    /// First usable sample `n0 = max(n, m + delay)`.
    fn n0(&self) -> usize {
        self.n.max(self.m + self.delay)
    }

    fn solve(&self, u: &[f64], y: &[f64], yc: &[f64], y_mean: f64) -> Result<LinearFit, IdError> {
        let rows = y.len() - self.n0();
        let nc = self.n + self.m + 1;
        let u_mean = mean(u);
        la::with_buffer(rows * nc, |ab| {
            self.fill_and_solve(ab, u, y, yc, y_mean, u_mean)
        })
    }

    /// Fill the column-major regression `[Φ | y]` (`rows × (d + 1)`) into `ab` and solve.
    ///
    /// The diagnostics come from the QR: the residual sum of squares of the regression is
    /// that of the one-step prediction over `[n0, len)` (the intercept folded into the
    /// operating point changes nothing there), so no prediction is run.
    #[allow(clippy::too_many_arguments)]
    fn fill_and_solve(
        &self,
        ab: &mut [f64],
        u: &[f64],
        y: &[f64],
        yc: &[f64],
        y_mean: f64,
        u_mean: f64,
    ) -> Result<LinearFit, IdError> {
        let (n, m, delay) = (self.n, self.m, self.delay);
        let len = y.len();
        let n0 = self.n0();
        let rows = len - n0;
        let d = n + m;
        let mut cols = ab.chunks_exact_mut(rows);
        for i in 0..n {
            let src = &yc[n0 - 1 - i..len - 1 - i];
            let col = cols.next().unwrap_or_default();
            for (dst, &s) in col.iter_mut().zip(src) {
                *dst = -s;
            }
        }
        for j in 0..m {
            let lag = delay + 1 + j;
            let src = &u[n0 - lag..len - lag];
            let col = cols.next().unwrap_or_default();
            for (dst, &s) in col.iter_mut().zip(src) {
                *dst = s - u_mean;
            }
        }
        let ycol = cols.next().unwrap_or_default();
        ycol.copy_from_slice(&yc[n0..]);
        let mut col_means = [0.0; 2 * MAX_ORDER + 1];
        if self.centering == Centering::OperatingPoint {
            for (cm, col) in col_means.iter_mut().zip(ab.chunks_exact_mut(rows)) {
                *cm = la::sum(col) / rows as f64;
                col.iter_mut().for_each(|v| *v -= *cm);
            }
        }
        // ‖y - mean(y)‖² over the regression rows, the denominator of F_PV
        let ycol = &ab[d * rows..(d + 1) * rows];
        let y_ss = la::sum_sq_about(ycol, la::sum(ycol) / rows as f64);
        let sol = la::lstsq_colmajor(ab, rows, d + 1).map_err(|pivot| IdError::Singular {
            identifier: "arx",
            detail: format!(
                "regression matrix {rows}x{d}: smallest relative QR pivot {pivot:.3e} < 1e-10"
            ),
        })?;
        let mut a = Vec::with_capacity(n + 1);
        a.push(1.0);
        a.extend_from_slice(&sol.x[..n]);
        let (mut u_mean, mut y_mean) = (u_mean, y_mean);
        let mut intercept_kept = true;
        if self.centering == Centering::OperatingPoint {
            // intercept of A yc = B uc + c0, folded into the operating point
            let c0 = col_means[d] - (0..d).map(|j| sol.x[j] * col_means[j]).sum::<f64>();
            let a1: f64 = a.iter().sum();
            let b1: f64 = sol.x[n..].iter().sum();
            if a1.abs() >= b1.abs() && a1 != 0.0 {
                y_mean += c0 / a1;
            } else if b1 != 0.0 {
                u_mean -= c0 / b1;
            } else {
                intercept_kept = false;
            }
        }
        let structure = Structure::Polynomial {
            a,
            b: sol.x[n..].to_vec(),
            c: vec![1.0],
            delay,
        };
        if !intercept_kept || !sol.rss.is_finite() {
            // A(1) = B(1) = 0: the prediction differs from the regression by the dropped
            // intercept; compute the diagnostics the long way
            return LinearFit::new("arx", structure, u_mean, y_mean, None, u, y);
        }
        Ok(LinearFit::with_diagnostics(
            "arx", structure, u_mean, y_mean, len, n0, sol.rss, y_ss,
        ))
    }
}

crate::linear_identifier! {
    Arx("arx") from ArxParams;
    description "ARX (eq. 2) by least squares (Householder QR)";
    orders {
        n: Int(2), "order of A(q) (auto-regressive part)", |p| p.n;
        m: Int(2), "order of B(q) (exogenous part, b1 q^-1 .. bm q^-m)", |p| p.m;
        delay: Int(0), "dead time t_d in samples (first input lag is 1 + delay)", |p| p.delay;
    }
    impl {
        fn min_samples(&self) -> usize {
            // strictly more equations than unknowns
            self.n0() + self.n + self.m + 1
        }
        /// A grid search identifies an ARX from sums over the record ([`Arx::output_sums`]), linear
        /// in its p = n + m parameters: about 10 p in the units of the default p² (measured:
        /// `docs/decisions/2026-11-27-long-records-and-fuzz.md`).
        fn cost_per_sample(&self) -> f64 {
            10.0 * (self.n + self.m).max(1) as f64
        }
        fn identify(&self, u: &[f64], y: &[f64]) -> Result<LinearFit, IdError> {
            check_data(u, y, self.min_samples())?;
            let y_mean = mean(y);
            let yc: Vec<f64> = y.iter().map(|v| v - y_mean).collect();
            self.solve(u, y, &yc, y_mean)
        }
        fn prepare(&self, y: &[f64]) -> Result<PreparedOutput, IdError> {
            crate::error::check_finite("y", y)?;
            let y_mean = mean(y);
            let yc: Vec<f64> = y.iter().map(|v| v - y_mean).collect();
            Ok(PreparedOutput::with_cache(
                y,
                Box::new(ArxCache { y_mean, yc }),
            ))
        }
        fn identify_prepared(
            &self,
            prepared: &PreparedOutput,
            u: &[f64],
        ) -> Result<LinearFit, IdError> {
            let y = prepared.y();
            match prepared.cache::<ArxCache>() {
                Some(c) => {
                    check_data(u, y, self.min_samples())?;
                    self.solve(u, y, &c.yc, c.y_mean)
                }
                None => self.identify(u, y),
            }
        }
        fn fast_paths(&self) -> Option<&dyn crate::FastPaths> {
            Some(self)
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::LinearIdentifier;

    /// Noisy ARX-like data with offsets.
    fn data(len: usize) -> (Vec<f64>, Vec<f64>) {
        let mut state: u64 = 99;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let mut u = vec![0.0; len];
        let mut y = vec![0.0; len];
        let mut level = 1.0;
        for k in 0..len {
            if rnd() > 0.4 {
                level = -level;
            }
            u[k] = 20.0 + level;
            let mut v = 3.0 + 0.3 * rnd();
            if k >= 2 {
                v += 0.9 * y[k - 1] - 0.2 * y[k - 2] + 0.4 * u[k - 1] + 0.1 * u[k - 2] - 0.3 * 3.0;
            }
            y[k] = v;
        }
        (u, y)
    }

    /// An output that settles to the last digits (spread 1e-12 at 47: below any logged
    /// signal's resolution) is constant for both solvers; a spread of 1e-6 is identified.
    #[test]
    fn a_numerically_constant_output_is_refused() {
        let (u, _) = data(40);
        let arx = Arx::params().check().unwrap();
        let flat: Vec<f64> = (0..40).map(|k| 47.3 + 1e-12 / (1.0 + k as f64)).collect();
        assert!(matches!(
            arx.identify(&u, &flat),
            Err(IdError::ConstantInput { signal: "y", .. })
        ));
        let sums = arx.output_sums(&flat).unwrap();
        assert!(sums.identify_window(&u, 0, 40).is_none());
        let small: Vec<f64> = (0..40)
            .map(|k| 47.3 + 1e-6 * ((k * 7 % 5) as f64))
            .collect();
        assert!(arx.identify(&u, &small).is_ok());
    }

    #[test]
    fn fast_diagnostics_match_prediction() {
        let (u, y) = data(1500);
        for centering in [Centering::OperatingPoint, Centering::Mean] {
            for (n, m, delay) in [(2, 2, 0), (1, 3, 2), (4, 1, 0)] {
                let id = Arx::params()
                    .n(n)
                    .m(m)
                    .delay(delay)
                    .centering(centering)
                    .check()
                    .unwrap();
                let fast = id.identify(&u, &y).unwrap();
                // the reference: diagnostics from a full one-step prediction
                let mut slow = fast.clone();
                slow.refresh_info(&u, &y).unwrap();
                let (f, s) = (fast.info(), slow.info());
                assert_eq!(f.first_sample, s.first_sample);
                assert_eq!(f.n_samples, s.n_samples);
                assert!(
                    (f.residual_variance - s.residual_variance).abs() < 1e-9 * s.residual_variance,
                    "{centering:?} {n} {m} {delay}: {} vs {}",
                    f.residual_variance,
                    s.residual_variance
                );
                assert!(
                    (f.fit_pv - s.fit_pv).abs() < 1e-9,
                    "{} vs {}",
                    f.fit_pv,
                    s.fit_pv
                );
                assert_eq!(f.process_max_pole, s.process_max_pole);
                assert_eq!(f.predictor_max_pole, s.predictor_max_pole);
            }
        }
    }
}
