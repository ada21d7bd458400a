//! The structure of a fitted model in plain numbers: polynomial or state space, and what
//! follows from it alone (frequency response, static gain, poles, impulse response).

use super::*;

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

    pub(crate) fn eval(&self, w: f64) -> c64 {
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

pub(crate) fn horner(p: &[f64], zinv: c64) -> c64 {
    // Σ p_i zinv^i
    let mut acc = c64::new(0.0, 0.0);
    for &pi in p.iter().rev() {
        acc = acc * zinv + pi;
    }
    acc
}

/// Gaussian elimination with partial pivoting on a small complex system (in place).
#[allow(clippy::needless_range_loop)]
pub(crate) fn complex_solve(m: &mut [Vec<c64>], rhs: &mut [c64]) -> Option<()> {
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
