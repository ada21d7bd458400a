//! The linear plant of the benchmark and the closed-loop stability check.

use serde::{Deserialize, Serialize};

use crate::DataError;

/// An ARMAX plant `A(q) y = q^-delay B(q) u + C(q) e (+ η)` in deviation variables.
///
/// Coefficients are in powers of `q^-1`: `a = [1, a1, a2, ...]` (leading 1), `b = [b0, b1, ...]`
/// (`b0 = 0` for the usual one-sample lag of a sampled process), `c = [1, c1, ...]` (leading
/// 1). `delay` is extra dead time in samples on top of B's own lag.
///
/// | field | meaning | valid |
/// |-------|---------|-------|
/// | `a` | denominator, leading 1 | non-empty, finite, `a[0] = 1` |
/// | `b` | numerator (MV → PV) | non-empty, finite; `b[0] = 0` unless `delay >= 1` (the output at `k` may only depend on past MV) |
/// | `c` | noise numerator, leading 1 | non-empty, finite, `c[0] = 1` |
/// | `delay` | extra dead time (samples), default 0 | `<= 10000` |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plant {
    /// `A(q)`, leading 1.
    pub a: Vec<f64>,
    /// `B(q)`.
    pub b: Vec<f64>,
    /// `C(q)`, leading 1.
    pub c: Vec<f64>,
    /// Extra dead time in samples.
    #[serde(default)]
    pub delay: usize,
}

/// Named plants: the paper's and a slower one for tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PlantPreset {
    /// [`Plant::paper`].
    Paper,
    /// [`Plant::slow`].
    Slow,
}

impl PlantPreset {
    /// The plant.
    pub fn plant(self) -> Plant {
        match self {
            PlantPreset::Paper => Plant::paper(),
            PlantPreset::Slow => Plant::slow(),
        }
    }
    /// Parse `paper` or `slow` (case-insensitive).
    pub fn parse(name: &str) -> Option<PlantPreset> {
        match name.to_ascii_lowercase().as_str() {
            "paper" => Some(PlantPreset::Paper),
            "slow" => Some(PlantPreset::Slow),
            _ => None,
        }
    }
}

impl Plant {
    /// The paper's plant, eq. (10): ARMAX (3, 3, 3) with unit static gain.
    pub fn paper() -> Plant {
        Plant {
            a: vec![1.0, -0.5215, 0.0590, -0.0009],
            b: vec![0.0, 0.2836, 0.2442, 0.0088],
            c: vec![1.0, 0.5, 1.0, -1.0],
            delay: 0,
        }
    }

    /// The slower test plant of the specification (§6.3): poles 0.816, 0.4, 0.184, static gain
    /// about 1.889.
    pub fn slow() -> Plant {
        Plant {
            a: vec![1.0, -1.4, 0.55, -0.06],
            b: vec![0.0, 0.1, 0.05, 0.02],
            c: vec![1.0, 0.3, 0.1, 0.05],
            delay: 0,
        }
    }

    /// `B(1) / A(1)`, the steady-state gain from MV to PV (infinite for an integrating plant).
    pub fn static_gain(&self) -> f64 {
        self.b.iter().sum::<f64>() / self.a.iter().sum::<f64>()
    }

    /// Check the structure (see the table on [`Plant`]).
    pub fn validate(&self) -> Result<(), DataError> {
        let bad = |reason: String| Err(DataError::InvalidPlant { reason });
        for (name, p) in [("a", &self.a), ("b", &self.b), ("c", &self.c)] {
            if p.is_empty() {
                return bad(format!("polynomial {name} is empty"));
            }
            if let Some(i) = p.iter().position(|v| !v.is_finite()) {
                return bad(format!("{name}[{i}] = {} is not finite", p[i]));
            }
        }
        if self.a[0] != 1.0 {
            return bad(format!("a[0] = {} must be 1", self.a[0]));
        }
        if self.c[0] != 1.0 {
            return bad(format!("c[0] = {} must be 1", self.c[0]));
        }
        if self.delay == 0 && self.b[0] != 0.0 {
            return bad(format!(
                "b[0] = {} must be 0 when delay = 0 (PV(k) may only depend on past MV)",
                self.b[0]
            ));
        }
        if self.delay > 10_000 {
            return bad(format!(
                "delay = {} samples is too large (at most 10000)",
                self.delay
            ));
        }
        Ok(())
    }

    /// Coefficients (powers of `q^-1`) of the closed-loop characteristic polynomial with a
    /// linear valve and the velocity-form PI controller:
    /// `A(q)(1 - q^-1) + q^-delay B(q) ((Kc + KI) - Kc q^-1)`, trailing zeros removed.
    pub fn characteristic_polynomial(&self, kc: f64, ki: f64) -> Vec<f64> {
        let len = (self.a.len() + 1).max(self.delay + self.b.len() + 1);
        let mut p = vec![0.0; len];
        for (i, &ai) in self.a.iter().enumerate() {
            p[i] += ai;
            p[i + 1] -= ai;
        }
        for (i, &bi) in self.b.iter().enumerate() {
            p[self.delay + i] += bi * (kc + ki);
            p[self.delay + i + 1] -= bi * kc;
        }
        while p.len() > 1 && p.last() == Some(&0.0) {
            p.pop();
        }
        p
    }

    /// Roots (in `z`) of the closed-loop characteristic polynomial, as `[re, im]` pairs, from the
    /// eigenvalues of its companion matrix.
    pub fn closed_loop_roots(&self, kc: f64, ki: f64) -> Result<Vec<[f64; 2]>, DataError> {
        self.validate()?;
        roots(&self.characteristic_polynomial(kc, ki))
    }

    /// Coefficients of the closed-loop characteristic polynomial under a proportional-only
    /// controller (`KI = 0`): `A(q) + Kc q^-delay B(q)`. The velocity form's polynomial is this
    /// times `(1 - q^-1)`, a root at 1 that the controller's difference and its sum cancel (OP
    /// is a bias plus `Kc` times the error), so stability is decided on this one.
    pub fn proportional_polynomial(&self, kc: f64) -> Vec<f64> {
        let len = self.a.len().max(self.delay + self.b.len());
        let mut p = vec![0.0; len];
        for (i, &ai) in self.a.iter().enumerate() {
            p[i] += ai;
        }
        for (i, &bi) in self.b.iter().enumerate() {
            p[self.delay + i] += bi * kc;
        }
        while p.len() > 1 && p.last() == Some(&0.0) {
            p.pop();
        }
        p
    }

    /// Check B3: every closed-loop root strictly inside the unit circle. Returns the largest
    /// root modulus, or [`DataError::Unstable`].
    /// A proportional-only controller (`KI = 0`) is judged on [`Plant::proportional_polynomial`].
    pub fn check_stability(&self, kc: f64, ki: f64) -> Result<f64, DataError> {
        let roots = if ki == 0.0 {
            self.validate()?;
            roots(&self.proportional_polynomial(kc))?
        } else {
            self.closed_loop_roots(kc, ki)?
        };
        let max_modulus = roots
            .iter()
            .map(|[re, im]| re.hypot(*im))
            .fold(0.0_f64, f64::max);
        if max_modulus.is_finite() && max_modulus < 1.0 {
            Ok(max_modulus)
        } else {
            Err(DataError::Unstable {
                kc,
                ki,
                delay: self.delay,
                max_modulus,
            })
        }
    }
}

/// Roots (in `z`) of the polynomial `p` in powers of `q^-1`, as `[re, im]` pairs, from the
/// eigenvalues of its companion matrix.
fn roots(p: &[f64]) -> Result<Vec<[f64; 2]>, DataError> {
    let n = p.len() - 1;
    if n == 0 {
        return Ok(Vec::new());
    }
    if p[0] == 0.0 || p.iter().any(|v| !v.is_finite()) {
        return Err(DataError::InvalidParameter {
            name: "controller".into(),
            value: p[0],
            expected: "a closed loop with a finite, proper characteristic polynomial".into(),
        });
    }
    let companion = nalgebra::DMatrix::<f64>::from_fn(n, n, |i, j| {
        if i == 0 {
            -p[j + 1] / p[0]
        } else if i == j + 1 {
            1.0
        } else {
            0.0
        }
    });
    Ok(companion
        .complex_eigenvalues()
        .iter()
        .map(|z| [z.re, z.im])
        .collect())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn static_gains() {
        assert!((Plant::paper().static_gain() - 1.0).abs() < 1e-3);
        assert!((Plant::slow().static_gain() - 1.889).abs() < 1e-3);
    }

    #[test]
    fn slow_plant_open_loop_poles() {
        // A(q) alone: drop the controller by using the open-loop polynomial as "characteristic".
        let p = Plant::slow();
        let roots = Plant {
            a: p.a.clone(),
            b: vec![0.0],
            c: vec![1.0],
            delay: 0,
        }
        .closed_loop_roots(0.0, 0.0)
        .unwrap();
        // A(q)(1 - q^-1): the poles of A plus the integrator at 1.
        let mut m: Vec<f64> = roots.iter().map(|[re, im]| re.hypot(*im)).collect();
        m.sort_by(f64::total_cmp);
        for (got, want) in m.iter().zip([0.184, 0.4, 0.816, 1.0]) {
            assert!((got - want).abs() < 2e-3, "{m:?}");
        }
    }

    #[test]
    fn a_proportional_controller_is_judged_without_the_velocity_forms_root_at_one() {
        let paper = Plant::paper();
        // The velocity form's polynomial has the root at 1 whatever the gain.
        let m = paper
            .closed_loop_roots(0.5, 0.0)
            .unwrap()
            .iter()
            .map(|[re, im]| re.hypot(*im))
            .fold(0.0_f64, f64::max);
        assert!((m - 1.0).abs() < 1e-9, "{m}");
        assert!(paper.check_stability(0.5, 0.0).unwrap() < 1.0);
        // A + Kc q^-d B: unstable once the loop gain is too high for the delay.
        let delayed = Plant {
            delay: 5,
            ..Plant::paper()
        };
        assert!(delayed.check_stability(0.2, 0.0).is_ok());
        assert!(matches!(
            delayed.check_stability(20.0, 0.0),
            Err(DataError::Unstable { .. })
        ));
    }

    #[test]
    fn nominal_tunings_are_stable_and_aggressive_delay_is_not() {
        for plant in [Plant::paper(), Plant::slow()] {
            let m = plant.check_stability(0.5, 0.5).unwrap();
            assert!(m < 1.0);
        }
        assert!(Plant::paper().check_stability(1.2, 1.2).is_ok());
        let delayed = Plant {
            delay: 5,
            ..Plant::paper()
        };
        assert!(matches!(
            delayed.check_stability(1.2, 1.2),
            Err(DataError::Unstable { .. })
        ));
    }

    #[test]
    fn invalid_plants() {
        let mut p = Plant::paper();
        p.a[0] = 2.0;
        assert_eq!(
            p.validate().unwrap_err().to_string(),
            "invalid plant: a[0] = 2 must be 1"
        );
        let mut p = Plant::paper();
        p.b[0] = 0.1;
        assert!(p.validate().is_err());
        p.delay = 1;
        assert!(p.validate().is_ok());
        let mut p = Plant::paper();
        p.c.clear();
        assert_eq!(
            p.validate().unwrap_err().to_string(),
            "invalid plant: polynomial c is empty"
        );
        let mut p = Plant::paper();
        p.b[2] = f64::NAN;
        assert_eq!(
            p.validate().unwrap_err().to_string(),
            "invalid plant: b[2] = NaN is not finite"
        );
    }
}
