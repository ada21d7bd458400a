//! Synthetic signals for the unit tests (no RNG crate: a seeded xorshift and Box-Muller).

/// `sin(2πk/period)`.
pub(crate) fn sine(n: usize, period: f64) -> Vec<f64> {
    (0..n)
        .map(|k| (2.0 * std::f64::consts::PI * k as f64 / period).sin())
        .collect()
}

/// A triangle wave of amplitude 1 and the same phase as [`sine`].
pub(crate) fn triangle(n: usize, period: f64) -> Vec<f64> {
    (0..n)
        .map(|k| {
            let u = (k as f64 / period + 0.25).rem_euclid(1.0);
            if u < 0.5 {
                4.0 * u - 1.0
            } else {
                3.0 - 4.0 * u
            }
        })
        .collect()
}

/// Gaussian white noise of deviation `sigma`, reproducible from `seed`.
pub(crate) fn noise(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut uniform = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let (u1, u2) = (uniform(), uniform());
            sigma * (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        })
        .collect()
}

/// A signal wandering as a first-order lag (time constant 40 s) of white noise, plus white
/// noise of deviation 0.3 of its own (an OP's share of PV's noise through the controller's
/// gain), read every `ts` seconds over 20 000 s: the lag is simulated every 0.5 s, so records
/// at different `ts` are the same signal sampled differently.
pub(crate) fn wandering(ts: f64, seed: u64) -> Vec<f64> {
    let fine = 0.5;
    let (steps, every) = ((20_000.0 / fine) as usize, (ts / fine).round() as usize);
    let a = (-fine / 40.0_f64).exp();
    let mut x = 0.0;
    let slow: Vec<f64> = noise(steps, 10.0, seed)
        .iter()
        .map(|e| {
            x = a * x + (1.0 - a) * e;
            x
        })
        .collect();
    let read: Vec<f64> = slow.iter().step_by(every.max(1)).copied().collect();
    let white = noise(read.len(), 0.3, seed + 1);
    read.iter().zip(&white).map(|(s, w)| s + w).collect()
}

/// `op` through a Kano valve `(s, j)` (at rest at its default start) into the first-order
/// process `y(t) = 0.6 y(t−1) + 0.4 MV(t−1) + e(t)`, `e` white of deviation 0.05 (seed 3):
/// the process output.
pub(crate) fn kano_first_order(op: &[f64], s: f64, j: f64) -> Vec<f64> {
    use stiction_models::{InitialState, Kano, StictionModel};
    let valve = Kano::params()
        .s(s)
        .j(j)
        .check()
        .expect("a valid Kano valve");
    let mv = valve
        .simulate(op, &InitialState::default())
        .expect("the valve simulates OP");
    let e = noise(op.len(), 0.05, 3);
    let mut y = vec![0.0; op.len()];
    for t in 1..op.len() {
        y[t] = 0.6 * y[t - 1] + 0.4 * mv[t - 1] + e[t];
    }
    y
}
