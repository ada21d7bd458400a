//! Shared data generators for the integration tests (seeded, deterministic).
#![allow(dead_code)]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// A third-order ARMAX plant `A(q) y = B(q) u + C(q) e`, `b` on q^-1..q^-3.
pub struct Plant {
    pub a: [f64; 4],
    pub b: [f64; 3],
    pub c: [f64; 4],
}

/// The paper's plant, eq. (10): A, B (b0 = 0), C.
pub const PAPER: Plant = Plant {
    a: [1.0, -0.5215, 0.0590, -0.0009],
    b: [0.2836, 0.2442, 0.0088],
    c: [1.0, 0.5, 1.0, -1.0],
};

/// The second plant of spec §6.3 (static gain 1.889).
pub const PLANT2: Plant = Plant {
    a: [1.0, -1.4, 0.55, -0.06],
    b: [0.1, 0.05, 0.02],
    c: [1.0, 0.3, 0.1, 0.05],
};

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// Generalised binary noise ±1 with switching probability `p_switch`.
pub fn gbn(len: usize, p_switch: f64, seed: u64) -> Vec<f64> {
    let mut r = rng(seed);
    let mut v = 1.0;
    (0..len)
        .map(|_| {
            if r.random::<f64>() < p_switch {
                v = -v;
            }
            v
        })
        .collect()
}

pub fn white(len: usize, sigma: f64, seed: u64) -> Vec<f64> {
    let mut r = rng(seed);
    let nd = Normal::new(0.0, sigma).expect("normal");
    (0..len).map(|_| nd.sample(&mut r)).collect()
}

/// `A(q) y = B(q) u_{k-delay} + C(q) e + eta` with `b = [b1..bm]` on `q^-1..q^-m`;
/// zero initial conditions.
pub fn simulate(
    a: &[f64],
    b: &[f64],
    c: &[f64],
    delay: usize,
    u: &[f64],
    e: &[f64],
    eta: &[f64],
) -> Vec<f64> {
    let n = u.len();
    let mut y = vec![0.0; n];
    for k in 0..n {
        let mut v = 0.0;
        for i in 1..a.len() {
            if k >= i {
                v -= a[i] * y[k - i];
            }
        }
        for (j, bj) in b.iter().enumerate() {
            let lag = delay + 1 + j;
            if k >= lag {
                v += bj * u[k - lag];
            }
        }
        if !e.is_empty() {
            v += e[k];
            for i in 1..c.len() {
                if k >= i {
                    v += c[i] * e[k - i];
                }
            }
        }
        if !eta.is_empty() {
            v += eta[k];
        }
        y[k] = v;
    }
    y
}

/// The paper's disturbance, eq. (11).
pub fn paper_disturbance(len: usize, a: f64, offset: usize) -> Vec<f64> {
    (0..len)
        .map(|k| {
            let k = (k + offset) as f64;
            a * ((0.03 * k).sin() + 0.5 * (0.07 * k).sin())
        })
        .collect()
}

/// Closed loop of the paper (§6.1): plant eq. (10) with disturbance eq. (11) entering the
/// difference equation, PI Kc = KI = 0.5, random-walk set point eq. (12), valve MV = OP
/// (no stiction: the identifiers get the true MV). Returns (MV, PV) after `warm` samples.
pub fn paper_closed_loop(len: usize, a_dist: f64, sigma_e: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    closed_loop(&PAPER, len, a_dist, sigma_e, seed)
}

/// Closed loop with `plant`, PI 0.5/0.5, random-walk set point, disturbance eq. (11) with
/// amplitude `a_dist`, MV = OP.
pub fn closed_loop(
    plant: &Plant,
    len: usize,
    a_dist: f64,
    sigma_e: f64,
    seed: u64,
) -> (Vec<f64>, Vec<f64>) {
    closed_loop_valve(plant, len, a_dist, sigma_e, seed, (0.0, 0.0))
}

/// Kano's valve (spec §1.3), no clipping; starts at rest at OP = MV = 0, d = +1.
struct Kano {
    s: f64,
    j: f64,
    u_prev: f64,
    du_prev: f64,
    u_s: f64,
    stp: bool,
    d: f64,
    mv: f64,
}

impl Kano {
    fn step(&mut self, u: f64) -> f64 {
        let du = u - self.u_prev;
        if !self.stp && du * self.du_prev <= 0.0 {
            self.u_s = self.u_prev;
            self.stp = true;
        }
        let off = (self.s - self.j) / 2.0;
        if !self.stp {
            self.mv = u - self.d * off;
        } else if -self.d * (u - self.u_s) > self.s {
            self.d = -self.d;
            self.mv = u - self.d * off;
            self.stp = false;
        } else if self.d * (u - self.u_s) > self.j {
            self.mv = u - self.d * off;
            self.stp = false;
        }
        self.du_prev = du;
        self.u_prev = u;
        self.mv
    }
}

/// As [`closed_loop`] with a sticky valve: Kano's model (spec §1.3) with `(s, j)` (MV = OP
/// when both are 0).
pub fn closed_loop_valve(
    plant: &Plant,
    len: usize,
    a_dist: f64,
    sigma_e: f64,
    seed: u64,
    (s, j): (f64, f64),
) -> (Vec<f64>, Vec<f64>) {
    let mut valve = Kano {
        s,
        j,
        u_prev: 0.0,
        du_prev: 0.0,
        u_s: 0.0,
        stp: true,
        d: 1.0,
        mv: 0.0,
    };
    let warm = 500;
    let total = len + warm;
    let mut r = rng(seed);
    let nd = Normal::new(0.0, sigma_e.max(1e-300)).expect("normal");
    let (kc, ki) = (0.5, 0.5);
    let eta = paper_disturbance(total, a_dist, 0);
    let mut sp = 0.0;
    let mut y = vec![0.0; total];
    let mut mv = vec![0.0; total];
    let mut e = vec![0.0; total];
    let (mut op_prev, mut err_prev) = (0.0, 0.0);
    for k in 0..total {
        if r.random::<f64>() > 1.0 - 0.05 {
            sp += 2.0 * (r.random::<f64>() - 0.5);
        }
        e[k] = if sigma_e > 0.0 {
            nd.sample(&mut r)
        } else {
            0.0
        };
        let mut v = e[k] + eta[k];
        for i in 1..4 {
            if k >= i {
                v += -plant.a[i] * y[k - i] + plant.b[i - 1] * mv[k - i] + plant.c[i] * e[k - i];
            }
        }
        y[k] = v;
        let err = sp - y[k];
        let op = op_prev + kc * (err - err_prev) + ki * err;
        mv[k] = if s == 0.0 && j == 0.0 {
            op
        } else {
            valve.step(op)
        };
        op_prev = op;
        err_prev = err;
    }
    (mv[warm..].to_vec(), y[warm..].to_vec())
}

pub fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// SIPPY's example system (spec P1): A = diag(0.89, 0.45), B = [0.3; 2.5], C = [0.7, 1.0],
/// D = 0, driven by GBN ±1 (switch probability 0.05), plus white output noise of std `sigma`.
pub fn sippy_ss_data(len: usize, sigma: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let u = gbn(len, 0.05, seed);
    let noise = white(len, sigma.max(1e-300), seed + 1000);
    let mut x = [0.0, 0.0];
    let mut y = vec![0.0; len];
    for k in 0..len {
        y[k] = 0.7 * x[0] + 1.0 * x[1] + if sigma > 0.0 { noise[k] } else { 0.0 };
        x = [0.89 * x[0] + 0.3 * u[k], 0.45 * x[1] + 2.5 * u[k]];
    }
    (u, y)
}

/// Markov parameters C A^i B of the SIPPY example, i = 0..5.
pub const SIPPY_MARKOV: [f64; 5] = [2.71, 1.3119, 0.6726, 0.3759, 0.2343];

/// PARSIM-K of order 2 with horizons `(f, p)` and no centering (SIPPY's default), fitted to
/// `(u, y)`.
pub fn parsim_sippy(f: usize, p: usize, u: &[f64], y: &[f64]) -> linear_id::LinearFit {
    use linear_id::LinearIdentifier;
    let id = linear_id::ParsimK::params()
        .n(2)
        .f(f)
        .p(p)
        .center(false)
        .check()
        .expect("valid orders");
    id.identify(u, y).expect("identified")
}
