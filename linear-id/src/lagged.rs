//! LARX: ARX at a lag of `r` samples, for an output read back from a historian's compressed
//! storage.
//!
//! A historian that keeps a point only when the signal leaves a band (swinging door, box-car)
//! and is read back by linear interpolation returns an output that is exactly straight between
//! its kept points. On such data the one-step ARX regression is dominated by
//! `y_k = 2 y_{k-1} − y_{k-2}`, which holds on every interpolated sample whatever the input
//! did: the fit leans on the output's own past, the input's coefficients shrink, and a grid
//! search over a valve model ranks its nodes on what the interpolation left, not on the valve.
//! Measured on the 24 compressed loops of the hidden-effect suite (seeds 1006-1236, step 10):
//! the Kano S of the paper's ARX was within max(0.5, 10 %) of the truth in 13 of 24, and fell
//! to 1.5-2.6 for true values of 6.5-9.6 on five of them.
//!
//! LARX predicts `y_k` from `y_{k−r}, …, y_{k−nr}` and from the input averaged over each
//! block of `r` samples before them:
//!
//! `y_k = −Σᵢ aᵢ y_{k−ir} + Σⱼ bⱼ ū_j(k) + c`, `ū_j(k) = (1/r) Σ_{l=1..r} u_{k−delay−(j−1)r−l}`.
//!
//! With `r` the archive's typical distance between kept points (the median length of its
//! straight segments), `y_k`, `y_{k−r}` and `y_{k−2r}` mostly lie on different segments, so the
//! regression must explain the output's changes from segment to segment by the input, which is
//! what the interpolation did not write. The model is an ordinary polynomial model in `q`:
//! `A(q) = 1 + Σ aᵢ q^{−ir}` and `B(q) = Σⱼ (bⱼ / r) Σₗ q^{−(j−1)r−l}`, so its one-step
//! predictor is the `r`-step prediction above, and its free run, static gain `B(1)/A(1)` and
//! stability (`A`'s roots are the `r`-th roots of the lag-`r` polynomial's) follow from the
//! usual code. With `r = 1` it is ARX with an intercept.

use crate::arx::{MAX_DELAY, MAX_ORDER};
use crate::error::{check_data, check_order};
use crate::{mean, IdError, LinearFit, LinearIdentifier, Structure};

/// Largest accepted lag (the model's polynomials have `n · lag` and `m · lag` coefficients).
pub const LARX_MAX_LAG: usize = 100;

crate::declare::identifier_params! {
    /// ARX at lag `r` (module docs): `y_k` from `y_{k−ir}` (i = 1..n) and the input's means over
    /// the `m` blocks of `r` samples before, with an intercept, by least squares.
    ///
    /// | name | default | meaning | valid range |
    /// |------|---------|---------|-------------|
    /// | `n` | 2 | lagged outputs `y_{k−r} … y_{k−nr}` | 1 ..= 50 |
    /// | `m` | 2 | input blocks of `r` samples | 1 ..= 50 |
    /// | `delay` | 0 | dead time `t_d` in samples | 0 ..= 10000 |
    /// | `lag` | 1 | `r`, samples per lag (1: ARX) | 1 ..= 100 |
    #[derive(Eq)]
    pub struct Larx;
    /// Unchecked parameters of [`Larx`]; [`LarxParams::check`] builds the identifier.
    #[derive(Eq)]
    pub struct LarxParams {
        /// Number of lagged outputs.
        n: usize = 2,
        /// Number of input blocks.
        m: usize = 2,
        /// Dead time in samples.
        delay: usize = 0,
        /// Samples per lag.
        lag: usize = 1,
    }
    check |p| {
        check_order("larx", "n", p.n, 1, MAX_ORDER)?;
        check_order("larx", "m", p.m, 1, MAX_ORDER)?;
        check_order("larx", "delay", p.delay, 0, MAX_DELAY)?;
        check_order("larx", "lag", p.lag, 1, LARX_MAX_LAG)?;
    }
}

impl Larx {
    /// Samples per lag.
    pub fn lag(&self) -> usize {
        self.lag
    }

    /// First row of the regression: every lag of it inside the data.
    fn n0(&self) -> usize {
        (self.n * self.lag).max(self.delay + self.m * self.lag)
    }

    /// The fitted model without its diagnostics (`info` not computed).
    fn fit_bare(&self, u: &[f64], y: &[f64]) -> Result<LinearFit, IdError> {
        check_data(u, y, self.min_samples())?;
        let (n, m, r, delay) = (self.n, self.m, self.lag, self.delay);
        let (um, ym) = (mean(u), mean(y));
        let n0 = self.n0();
        let len = y.len();
        let rows = len - n0;
        let d = n + m + 1;
        // prefix sums of the centered input: the block means in O(1) each
        let mut cum = Vec::with_capacity(len + 1);
        cum.push(0.0);
        let mut acc = 0.0;
        for &v in u {
            acc += v - um;
            cum.push(acc);
        }
        let inv_r = 1.0 / r as f64;
        let mut ab = vec![0.0; rows * (d + 1)];
        let mut cols = ab.chunks_exact_mut(rows);
        for i in 1..=n {
            let col = cols.next().unwrap_or_default();
            for (dst, &v) in col.iter_mut().zip(&y[n0 - i * r..len - i * r]) {
                *dst = -(v - ym);
            }
        }
        for j in 1..=m {
            // samples k − delay − (j−1) r − r ..= k − delay − (j−1) r − 1
            let hi = delay + (j - 1) * r;
            let col = cols.next().unwrap_or_default();
            for (row, dst) in col.iter_mut().enumerate() {
                let k = n0 + row;
                *dst = (cum[k - hi] - cum[k - hi - r]) * inv_r;
            }
        }
        cols.next().unwrap_or_default().fill(1.0);
        for (dst, &v) in cols.next().unwrap_or_default().iter_mut().zip(&y[n0..]) {
            *dst = v - ym;
        }
        let sol = crate::la::lstsq_colmajor(&mut ab, rows, d + 1).map_err(|pivot| {
            IdError::Singular {
                identifier: "larx",
                detail: format!(
                    "regression matrix {rows}x{d} at lag {r}: smallest relative QR pivot {pivot:.3e} < 1e-10"
                ),
            }
        })?;
        let mut a = vec![0.0; n * r + 1];
        a[0] = 1.0;
        for i in 1..=n {
            a[i * r] = sol.x[i - 1];
        }
        let mut b = vec![0.0; m * r];
        for j in 1..=m {
            let bj = sol.x[n + j - 1] * inv_r;
            b[(j - 1) * r..j * r].fill(bj);
        }
        let c0 = sol.x[n + m];
        let (a1, b1): (f64, f64) = (a.iter().sum(), b.iter().sum());
        // the intercept of A yc = B uc + c0 is the operating point's offset
        let (mut u_op, mut y_op) = (um, ym);
        if a1.abs() >= b1.abs() && a1 != 0.0 {
            y_op += c0 / a1;
        } else if b1 != 0.0 {
            u_op -= c0 / b1;
        }
        let structure = Structure::Polynomial {
            a,
            b,
            c: vec![1.0],
            delay,
        };
        Ok(LinearFit::bare("larx", structure, u_op, y_op, None))
    }
}

crate::linear_identifier! {
    Larx("larx") from LarxParams;
    description "ARX at a lag of r samples: PV from PV r, 2r .. samples back and MV averaged over blocks of r (for historian-compressed PV)";
    orders {
        n: Int(2), crate::Arx::ORDERS[0].meaning, |p| p.n;
        m: Int(2), crate::Arx::ORDERS[1].meaning, |p| p.m;
        delay: Int(0), crate::Arx::ORDERS[2].meaning, |p| p.delay;
        lag: Int(1),
            "samples per lag r: y_k from y_(k-r) .. y_(k-nr) and the input's means over blocks of r samples (1: ARX)",
            |p| p.lag;
    }
    impl {
        fn min_samples(&self) -> usize {
            // strictly more equations than the n + m + 1 unknowns (with the intercept)
            self.n0() + self.n + self.m + 2
        }
        crate::declare::identify_from_bare!(fit_bare);
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::{Arx, OrderValue};

    /// A second-order process `y_k = 1.5 y_{k−1} − 0.6 y_{k−2} + 0.3 u_{k−1} + 0.1 u_{k−2}`
    /// (static gain 4) driven by a random switching input, with a little output noise, offset
    /// by (40, 12).
    fn process(len: usize) -> (Vec<f64>, Vec<f64>) {
        let mut state: u64 = 11;
        let mut rnd = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut u = vec![0.0; len];
        let mut x = vec![0.0; len];
        let mut level = 0.0;
        for k in 0..len {
            if rnd() < 0.05 {
                level = 4.0 * rnd() - 2.0;
            }
            u[k] = level;
            if k >= 2 {
                x[k] = 1.5 * x[k - 1] - 0.6 * x[k - 2] + 0.3 * u[k - 1] + 0.1 * u[k - 2];
            }
        }
        let y = x.iter().map(|v| v + 12.0 + 0.01 * (rnd() - 0.5)).collect();
        (u.iter().map(|v| v + 40.0).collect(), y)
    }

    #[test]
    fn lag_one_is_arx() {
        let (u, y) = process(1500);
        let l = Larx::params().check().unwrap().identify(&u, &y).unwrap();
        let a = Arx::params().check().unwrap().identify(&u, &y).unwrap();
        let (
            Structure::Polynomial { a: la, b: lb, .. },
            Structure::Polynomial { a: aa, b: ab, .. },
        ) = (l.structure(), a.structure())
        else {
            panic!("polynomial models")
        };
        for (p, q) in la.iter().zip(aa).chain(lb.iter().zip(ab)) {
            assert!((p - q).abs() < 1e-9, "{la:?} {lb:?} vs {aa:?} {ab:?}");
        }
        assert!((l.static_gain() - a.static_gain()).abs() < 1e-9);
    }

    #[test]
    fn a_lagged_model_keeps_the_static_gain_and_predicts_r_steps_ahead() {
        let (u, y) = process(3000);
        let r = 6;
        let fit = Larx::params()
            .lag(r)
            .check()
            .unwrap()
            .identify(&u, &y)
            .unwrap();
        // the process's static gain, from the lag-r regression of the same data
        assert!(
            (fit.static_gain() - 4.0).abs() < 0.3,
            "{}",
            fit.static_gain()
        );
        assert!(fit.is_stable());
        let Structure::Polynomial { a, b, .. } = fit.structure() else {
            panic!("polynomial")
        };
        assert_eq!((a.len(), b.len()), (2 * r + 1, 2 * r));
        assert!(a.iter().enumerate().all(|(i, v)| i % r == 0 || *v == 0.0));
        assert_eq!(fit.first_sample(), 2 * r);
        // a switching input makes the r-step prediction good but not perfect
        assert!(
            fit.info().fit_pv > 50.0 && fit.info().fit_pv < 100.0,
            "{}",
            fit.info().fit_pv
        );
    }

    #[test]
    fn a_compressed_output_does_not_make_the_input_vanish() {
        // the output kept every 8 samples and read back by linear interpolation: one-step
        // ARX explains it by the straight lines (its input gain collapses), LARX at lag 8
        // keeps the process's gain
        let (u, y) = process(3000);
        let r = 8;
        let mut yc = y.clone();
        for s in (0..y.len() - r).step_by(r) {
            for l in 1..r {
                yc[s + l] = y[s] + (y[s + r] - y[s]) * l as f64 / r as f64;
            }
        }
        let arx = Arx::params().check().unwrap().identify(&u, &yc).unwrap();
        let larx = Larx::params()
            .lag(r)
            .check()
            .unwrap()
            .identify(&u, &yc)
            .unwrap();
        let b_sum = |f: &LinearFit| match f.structure() {
            Structure::Polynomial { b, .. } => b.iter().sum::<f64>(),
            Structure::StateSpace { .. } => f64::NAN,
        };
        // measured: ARX's input coefficients sum to 0.22 (the process's 0.4) and its gain
        // is 3.49; LARX's gain is 3.89
        assert!(b_sum(&arx) < 0.3, "arx's input gain {}", b_sum(&arx));
        assert!(
            (arx.static_gain() - 4.0).abs() > 0.4,
            "{}",
            arx.static_gain()
        );
        assert!(
            (larx.static_gain() - 4.0).abs() < 0.2,
            "{}",
            larx.static_gain()
        );
    }

    #[test]
    fn bad_orders_and_short_data_are_errors() {
        assert!(Larx::params().lag(0).check().is_err());
        assert!(Larx::params().lag(LARX_MAX_LAG + 1).check().is_err());
        assert!(Larx::params().n(0).check().is_err());
        let l = Larx::params().lag(10).check().unwrap();
        let (u, y) = process(20);
        assert!(matches!(
            l.identify(&u, &y),
            Err(IdError::TooFewSamples { .. })
        ));
        let (_, y) = process(200);
        assert!(matches!(
            l.identify(&[1.0; 200], &y),
            Err(IdError::ConstantInput { signal: "u", .. })
        ));
    }

    #[test]
    fn round_trips_through_serde_and_the_registry() {
        let l = Larx::params().lag(5).delay(2).check().unwrap();
        let boxed: Box<dyn LinearIdentifier> = Box::new(l);
        let json = serde_json::to_string(&boxed).unwrap();
        assert!(json.contains("\"kind\":\"larx\""), "{json}");
        let back: Box<dyn LinearIdentifier> = serde_json::from_str(&json).unwrap();
        assert_eq!(back.orders(), boxed.orders());
        let built = (crate::find_identifier("larx").unwrap().build)(&[(
            "lag".to_string(),
            OrderValue::Int(5),
        )])
        .unwrap();
        assert_eq!(built.orders()[3], ("lag", OrderValue::Int(5)));
    }
}
