//! What a model that knows everything but the noise can see of a sticky valve
//! ([`known_model_lr`]): the ceiling of any stiction detector on a simulated population.

use stiction_models::{Direction, InitialState};

use crate::simulate::{Plant, SimulatedLoop};

/// The log-likelihood ratio of the record `sim` (PV and OP as logged) under its own valve
/// against a free valve, for an observer who knows everything of the loop but the noise and
/// disturbance realisation: the plant (`A`, `B`, dead time), the noise's colour `C`, the
/// installed characteristic, the valve model with its parameters and the valve's position at
/// the first sample. `None` for a record of fewer than `4·order + 20` samples or a plant that
/// changes during the record.
///
/// Both hypotheses drive the true plant from the logged OP: one through the loop's valve
/// (replayed from its true first position, resting after a move up or down, the better of the
/// two), the other through a free valve. PV and both plant outputs go through the noise
/// model's inverse `A/C`, which leaves white noise plus what the disturbances add; each
/// hypothesis's residual (its mean out) is then whitened by an AR(`order`) model fitted to it
/// by least squares, which takes up the disturbances' own dynamics as a prediction-error
/// method does. `LR = n ln(RSS_free / RSS_valve)` over the `n` rows after the first tenth of
/// the record (at most 100 samples, where both outputs still hold the start's transient) and
/// the AR model's own start.
///
/// What it is for: no detector that must find the plant, the noise model and the valve from
/// the record can see more than this observer, so the statistic's AUC over a population
/// (sticky against free) is a ceiling on any detector's there, and a sticky loop whose ratio
/// stays below χ²₁(95 %) shows nothing that separates it from a free valve's record. A free
/// valve replays as OP itself, so its ratio is 0 exactly. It is an approximation of the best
/// test from above in every respect but one: the AR model is Gaussian, and a test that knew
/// the disturbances' kind (a load that steps) could read a little more from them.
pub fn known_model_lr(sim: &SimulatedLoop, order: usize) -> Option<f64> {
    let sc = &sim.scenario;
    let n = sim.pv.len().min(sim.op.len()).min(sim.mv.len());
    if sc.plant_change.is_some() || n < 4 * order + 20 {
        return None;
    }
    let plant = sc.plant.plant();
    let deviation = |mv: f64| {
        let mv = sc.travel_limit.map_or(mv, |l| mv.min(l));
        match &sc.characteristic {
            Some(c) => c.deviation(mv - sc.op_bias),
            None => mv - sc.op_bias,
        }
    };
    let through = |u: Vec<f64>| noise_inverse(&plant, &plant_output(&plant, &u));
    let free = through(sim.op[..n].iter().map(|&v| deviation(v)).collect());
    let pv: Vec<f64> = sim.pv[..n].iter().map(|v| v - sc.pv_bias).collect();
    let y = noise_inverse(&plant, &pv);
    let skip = (n / 10).min(100);
    let rss = |x: &[f64]| residual_rss(&y[skip..], &x[skip..], order);
    let sticky = [Direction::Up, Direction::Down]
        .into_iter()
        .filter_map(|direction| {
            let init = InitialState {
                direction,
                stuck: true,
                stuck_at: None,
                position: Some(sim.mv[0]),
            };
            let mut valve = sc.valve.start(sim.op[0], &init).ok()?;
            let mut u = Vec::with_capacity(n);
            u.push(deviation(valve.position()));
            u.extend(sim.op[1..n].iter().map(|&o| deviation(valve.step(o))));
            Some(rss(&through(u)))
        })
        .fold(f64::INFINITY, f64::min);
    let free = rss(&free);
    let rows = (n - skip - order) as f64;
    (sticky.is_finite() && sticky > 0.0 && free > 0.0).then(|| rows * (free / sticky).ln())
}

/// `x` through `q^-delay num / den` from rest (`den` monic).
fn filter(num: &[f64], delay: usize, den: &[f64], x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; x.len()];
    for k in 0..x.len() {
        let input: f64 = num
            .iter()
            .enumerate()
            .filter_map(|(i, b)| k.checked_sub(i + delay).map(|j| b * x[j]))
            .sum();
        let past: f64 = den
            .iter()
            .enumerate()
            .skip(1)
            .filter_map(|(i, a)| k.checked_sub(i).map(|j| a * y[j]))
            .sum();
        y[k] = input - past;
    }
    y
}

/// The plant's deterministic output `q^-d B/A u` from rest at the first sample.
fn plant_output(plant: &Plant, u: &[f64]) -> Vec<f64> {
    filter(&plant.b, plant.delay, &plant.a, u)
}

/// Whether every root of the monic polynomial `c` (in powers of `q⁻¹`) lies inside the unit
/// circle, so that `1/C` is stable (the Schur–Cohn step-down recursion).
pub(super) fn minimum_phase(c: &[f64]) -> bool {
    let mut p: Vec<f64> = c.to_vec();
    while p.len() > 1 {
        let m = p.len() - 1;
        let k = p[m] / p[0];
        if !k.is_finite() || k.abs() >= 1.0 {
            return false;
        }
        p = (0..m)
            .map(|i| (p[i] - k * p[m - i]) / (1.0 - k * k))
            .collect();
    }
    true
}

/// `s` through the inverse `A/C` of the plant's noise model (from rest); through `A` alone
/// when `1/C` is unstable (a `C` with a root on or outside the unit circle has no causal
/// inverse, and the AR model of [`residual_rss`] is left to whiten what it can).
fn noise_inverse(plant: &Plant, s: &[f64]) -> Vec<f64> {
    let c: &[f64] = if minimum_phase(&plant.c) {
        &plant.c
    } else {
        &[1.0]
    };
    filter(&plant.a, 0, c, s)
}

/// The residual sum of squares of `y − x` (its mean out) through an AR(`order`) model fitted
/// to it by least squares (the model's own first `order` samples left out).
fn residual_rss(y: &[f64], x: &[f64], order: usize) -> f64 {
    let r: Vec<f64> = y.iter().zip(x).map(|(a, b)| a - b).collect();
    let mean = r.iter().sum::<f64>() / r.len() as f64;
    let r: Vec<f64> = r.iter().map(|v| v - mean).collect();
    let rows = r.len() - order;
    // regressors: the `order` past values and a constant (the whitened mean)
    let x = nalgebra::DMatrix::from_fn(rows, order + 1, |t, j| {
        if j == order {
            1.0
        } else {
            r[t + order - 1 - j]
        }
    });
    let target = nalgebra::DVector::from_fn(rows, |t, _| r[t + order]);
    let mut gram = x.transpose() * &x;
    let ridge = 1e-10 * gram.trace().max(f64::MIN_POSITIVE);
    for j in 0..=order {
        gram[(j, j)] += ridge;
    }
    let theta = gram
        .cholesky()
        .map(|c| c.solve(&(x.transpose() * &target)))
        .unwrap_or_else(|| nalgebra::DVector::zeros(order + 1));
    (target - x * theta).norm_squared()
}
