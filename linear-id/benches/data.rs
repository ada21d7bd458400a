//! The identifier workload shared by the benchmark and `examples/profile_identify.rs`.

/// Deterministic closed-loop-like data: an ARMAX(3,3,3) plant driven by a pseudo-random
/// square wave plus a small LCG noise.
pub fn data(len: usize) -> (Vec<f64>, Vec<f64>) {
    let mut state: u64 = 12345;
    let mut rnd = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let a = [1.0, -0.5215, 0.0590, -0.0009];
    let b = [0.2836, 0.2442, 0.0088];
    let mut u = vec![0.0; len];
    let mut y = vec![0.0; len];
    let mut level = 1.0;
    for k in 0..len {
        if rnd() > 0.45 {
            level = -level;
        }
        u[k] = 50.0 + level + 0.1 * rnd();
        let mut v = 0.2 * rnd();
        for i in 1..4 {
            if k >= i {
                v += -a[i] * y[k - i] + b[i - 1] * u[k - i];
            }
        }
        y[k] = v;
    }
    (u, y)
}
