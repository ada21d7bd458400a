//! Test data shared by the unit tests of several modules.
#![allow(clippy::needless_range_loop)]

/// A sticky-valve-like input (held levels with jumps) through a second-order plant with
/// noise of amplitude `noise`.
pub(crate) fn valve_loop(len: usize, seed: u64, noise: f64) -> (Vec<f64>, Vec<f64>) {
    let mut state = seed;
    let mut rnd = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let (mut u, mut y) = (vec![0.0; len], vec![0.0; len]);
    let mut level = 50.0;
    for k in 0..len {
        if rnd() > 0.3 {
            level += 2.0 * rnd();
        }
        u[k] = level;
        let mut v = 40.0 + noise * rnd();
        if k >= 2 {
            v += 1.5 * (y[k - 1] - 40.0) - 0.7 * (y[k - 2] - 40.0)
                + 0.4 * (u[k - 1] - 50.0)
                + 0.1 * (u[k - 2] - 50.0);
        }
        y[k] = v;
    }
    (u, y)
}
