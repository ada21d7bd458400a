//! The seeded generator of the hidden-effect suite: closed-loop loops from `datasets::simulate`
//! with exactly one hidden effect (or none), drawn from a seed.
//!
//! Draw order (ChaCha8, `seed_from_u64(seed)`): plant (paper | slow), noise σ, S, J, then the
//! effect's own draws, then the simulator seed. Ranges are documented in `docs/DIAGNOSE.md`.
#![allow(dead_code)]

use datasets::simulate::{Characteristic, Disturbance, Plant, PlantSpec, Scenario, SimulatedLoop};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stiction_models::{Kano, KanoAsym, StictionModel};

/// The hidden effect of a generated loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Effect {
    /// No hidden effect: Kano valve, the plant's own coloured noise, nothing else.
    Clean,
    /// An external disturbance in the difference equation (eq. 11 shape or one sine).
    Disturbance,
    /// Kano-asym valve: slip jump differs by direction.
    Asymmetric,
    /// Extra dead time of the plant.
    Delay,
    /// A fourth-order-like slow process (extra slow pole), see `process-order`.
    Order,
    /// No stiction at all (linear valve) and an external oscillation: `no-stiction`.
    Oscillation,
    /// A disturbance (as `Disturbance`) and an extra dead time (as `Delay`) at once.
    DisturbanceDelay,
    /// A disturbance and an asymmetric valve (as `Asymmetric`) at once.
    DisturbanceAsymmetric,
    /// An extra dead time and an asymmetric valve at once.
    DelayAsymmetric,
    /// An installed flow characteristic after the Kano valve: equal-percentage or
    /// quick-opening (`datasets::simulate::Characteristic`), rangeability 20-50.
    Characteristic,
    /// The process dynamics change at 20-33 % of the record (the other preset's poles, gain
    /// x0.6-1.0): no plugin models it, the right answer is `unexplained`.
    ProcessChange,
    /// PV logged through a swinging-door archive (deviation 0.3-0.8 PV units) and read back by
    /// linear interpolation: `compression`, named alone.
    Compression,
    /// An installed flow characteristic (as `Characteristic`) and an extra dead time (as
    /// `Delay`) at once.
    CharacteristicDelay,
    /// The valve cannot pass a position L 4-10 % of span above the operating point
    /// (`MV = min(f(OP), L)`, `datasets::simulate::Scenario::travel_limit`), OP clamped to
    /// 0-100 %; a set point without random walk whose steps ask for 3-8 % of span beyond L
    /// come and go three times, so OP winds up to its clamp while PV stays short of SP:
    /// `travel-limit`.
    TravelLimit,
}

impl Effect {
    /// The cause name `diagnose` must report.
    pub fn cause(self) -> &'static str {
        match self {
            Effect::Clean => "none",
            Effect::Disturbance => "disturbance",
            Effect::Asymmetric => "asymmetric-stiction",
            Effect::Delay => "time-delay",
            Effect::Order => "process-order",
            Effect::Oscillation => "no-stiction",
            Effect::DisturbanceDelay | Effect::DisturbanceAsymmetric => "disturbance",
            Effect::DelayAsymmetric | Effect::CharacteristicDelay => "time-delay",
            Effect::Characteristic => "valve-characteristic",
            Effect::ProcessChange => "unexplained",
            Effect::Compression => "compression",
            Effect::TravelLimit => "travel-limit",
        }
    }

    /// The set of causes `diagnose` must report (sorted).
    pub fn causes(self) -> Vec<&'static str> {
        match self {
            Effect::Clean => Vec::new(),
            Effect::DisturbanceDelay => vec!["disturbance", "time-delay"],
            Effect::DisturbanceAsymmetric => vec!["asymmetric-stiction", "disturbance"],
            Effect::DelayAsymmetric => vec!["asymmetric-stiction", "time-delay"],
            Effect::CharacteristicDelay => vec!["time-delay", "valve-characteristic"],
            e => vec![e.cause()],
        }
    }
}

/// One generated loop and its ground truth.
pub struct Case {
    pub seed: u64,
    pub effect: Effect,
    pub plant: &'static str,
    pub noise: f64,
    /// PI gains kc = ki.
    pub gain: f64,
    /// True equivalent S and J of the valve.
    pub s: f64,
    pub j: f64,
    /// What was hidden, in words.
    pub what: String,
    pub sim: SimulatedLoop,
}

fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// The disturbance of `Effect::Disturbance` (the paper's shape or one sine), drawn from `rng`.
fn draw_disturbance(rng: &mut ChaCha8Rng, disturbances: &mut Vec<Disturbance>) -> String {
    if rng.random::<f64>() < 0.5 {
        let a = uniform(rng, 0.4, 1.0);
        disturbances.push(Disturbance::Paper { a });
        format!("paper disturbance a = {a:.2}")
    } else {
        let amplitude = uniform(rng, 0.4, 1.0);
        let frequency = uniform(rng, 0.01, 0.08);
        // 6.28, not TAU: the seeded suite's draws were set with this bound.
        #[allow(clippy::approx_constant)]
        let phase = uniform(rng, 0.0, 6.28);
        disturbances.push(Disturbance::Sine {
            amplitude,
            frequency,
            phase,
        });
        format!("sine amplitude {amplitude:.2} frequency {frequency:.3} rad/sample")
    }
}

/// A kano-asym valve (slip jumps 2-4 apart by direction, deadband D 1-5) with its equivalent
/// S and J and a description, drawn from `rng`.
fn draw_asymmetric(rng: &mut ChaCha8Rng) -> (Box<dyn StictionModel>, f64, f64, String) {
    let small = uniform(rng, 0.2, 1.0);
    let big = small + uniform(rng, 2.0, 4.0);
    let d = uniform(rng, 1.0, 5.0);
    let (j_up, j_dn) = if rng.random::<f64>() < 0.5 {
        (big, small)
    } else {
        (small, big)
    };
    let k = KanoAsym::params()
        .d(d)
        .j_up(j_up)
        .j_dn(j_dn)
        .check()
        .expect("valid kano-asym");
    let eq = k.equivalent();
    (
        Box::new(k),
        eq.s,
        eq.j,
        format!("kano-asym D = {d:.2}, J_up = {j_up:.2}, J_dn = {j_dn:.2}"),
    )
}

/// An extra dead time of 3-6 samples, shortened while the PI loop would be unstable.
fn draw_delay(rng: &mut ChaCha8Rng, plant: &mut Plant, gain: &mut f64) -> String {
    let d = rng.random_range(3..=6usize);
    plant.delay = d;
    while plant.check_stability(*gain, *gain).is_err() {
        *gain *= 0.8;
    }
    format!("extra dead time {d} samples")
}

/// An installed characteristic (equal-percentage or quick-opening, rangeability 20-50) drawn
/// from `rng`, the set point's random walk widened and the PI `gain` lowered until the loop
/// is stable where the characteristic's gain is highest in the range it visits.
fn draw_characteristic(
    rng: &mut ChaCha8Rng,
    plant: &Plant,
    gain: &mut f64,
    setpoint: &mut datasets::simulate::Setpoint,
) -> (Characteristic, String) {
    let rangeability = uniform(rng, 20.0, 50.0);
    let c = if rng.random::<f64>() < 0.5 {
        Characteristic::EqualPercentage { rangeability }
    } else {
        Characteristic::QuickOpening { rangeability }
    };
    let what = format!(
        "{} R = {rangeability:.1} (a = {:+.2})",
        if c.shape() > 0.0 {
            "equal-percentage"
        } else {
            "quick-opening"
        },
        c.shape()
    );
    // A characteristic matters over the range the valve travels: a set point that wanders 2.5
    // times as far (random-walk step 5 instead of 2) makes the valve cover enough of its span
    // for the local gain to change by 1.5 or more.
    setpoint.step = 5.0;
    // The loop must stay stable where the characteristic's gain is highest in the range it
    // visits (25 % of span from the operating point): PI gains lowered as for a dead time.
    let peak = (c.shape().abs() * 0.25).exp();
    while plant.check_stability(*gain * peak, *gain * peak).is_err() {
        *gain *= 0.8;
    }
    (c, what)
}

/// Generate the loop of `seed` with `effect`, `samples` long.
pub fn case(seed: u64, effect: Effect, samples: usize) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1A6);
    let slow = rng.random::<f64>() < 0.5;
    let mut plant = if slow { Plant::slow() } else { Plant::paper() };
    let noise = uniform(&mut rng, 0.05, 0.15);
    let mut gain = uniform(&mut rng, 0.25, 0.6);
    let s = uniform(&mut rng, 3.0, 10.0);
    let j = uniform(&mut rng, 0.5, 0.5 * s);
    let mut valve: Box<dyn StictionModel> =
        Box::new(Kano::params().s(s).j(j).check().expect("valid kano"));
    let (mut ts, mut tj) = (s, j);
    let mut disturbances = Vec::new();
    let mut characteristic = None;
    let mut plant_change = None;
    let mut pv_compression = None;
    let mut travel_limit = None;
    let mut op_limits = None;
    let mut setpoint = datasets::simulate::Setpoint::default();
    let what;
    match effect {
        Effect::Clean => what = "none".to_string(),
        Effect::Disturbance => what = draw_disturbance(&mut rng, &mut disturbances),
        Effect::Asymmetric => {
            (valve, ts, tj, what) = draw_asymmetric(&mut rng);
        }
        Effect::DisturbanceAsymmetric => {
            let a = draw_disturbance(&mut rng, &mut disturbances);
            let b;
            (valve, ts, tj, b) = draw_asymmetric(&mut rng);
            what = format!("{a}; {b}");
        }
        Effect::DelayAsymmetric => {
            let a = draw_delay(&mut rng, &mut plant, &mut gain);
            let b;
            (valve, ts, tj, b) = draw_asymmetric(&mut rng);
            what = format!("{a}; {b}");
        }
        Effect::Delay => what = draw_delay(&mut rng, &mut plant, &mut gain),
        Effect::DisturbanceDelay => {
            let a = draw_disturbance(&mut rng, &mut disturbances);
            let b = draw_delay(&mut rng, &mut plant, &mut gain);
            what = format!("{a}; {b}");
        }
        Effect::Order => {
            // An extra slow first-order lag in series: A(q) (1 - p q^-1), B scaled by (1 - p).
            let p = uniform(&mut rng, 0.85, 0.93);
            let a = &plant.a;
            let mut a2 = vec![0.0; a.len() + 1];
            for (i, &ai) in a.iter().enumerate() {
                a2[i] += ai;
                a2[i + 1] -= p * ai;
            }
            let b2: Vec<f64> = plant.b.iter().map(|b| b * (1.0 - p)).collect();
            plant.a = a2;
            plant.b = b2;
            what = format!("extra lag pole {p:.3}");
        }
        Effect::Oscillation => {
            valve = Box::new(Kano::params().check().expect("linear valve"));
            ts = 0.0;
            tj = 0.0;
            let amplitude = uniform(&mut rng, 0.5, 1.5);
            let frequency = uniform(&mut rng, 0.02, 0.06);
            disturbances.push(Disturbance::Sine {
                amplitude,
                frequency,
                phase: 0.0,
            });
            what = format!("linear valve, sine amplitude {amplitude:.2} frequency {frequency:.3}");
        }
        Effect::Characteristic => {
            let (c, w) = draw_characteristic(&mut rng, &plant, &mut gain, &mut setpoint);
            what = w;
            characteristic = Some(c);
        }
        Effect::CharacteristicDelay => {
            let a = draw_delay(&mut rng, &mut plant, &mut gain);
            let (c, b) = draw_characteristic(&mut rng, &plant, &mut gain, &mut setpoint);
            what = format!("{a}; {b}");
            characteristic = Some(c);
        }
        Effect::ProcessChange => {
            // the dynamics change at 20-33 % of the record: the other preset's poles and
            // zeros, its B scaled to the current static gain times 0.6-1.0 (a slower or faster
            // process, a little less gain), e.g. fouling
            let factor = uniform(&mut rng, 0.6, 1.0);
            let at = (uniform(&mut rng, 0.2, 0.33) * samples as f64) as usize;
            let mut other = if slow { Plant::paper() } else { Plant::slow() };
            let scale = factor * plant.static_gain() / other.static_gain();
            other.b.iter_mut().for_each(|b| *b *= scale);
            other.delay = plant.delay;
            while plant.check_stability(gain, gain).is_err()
                || other.check_stability(gain, gain).is_err()
            {
                gain *= 0.8;
            }
            what = format!(
                "from sample {at} the {} plant's dynamics, gain x{factor:.2}",
                if slow { "paper" } else { "slow" }
            );
            plant_change = Some(datasets::simulate::PlantChange { at, plant: other });
        }
        Effect::Compression => {
            let deviation = uniform(&mut rng, 0.3, 0.8);
            pv_compression = Some(deviation);
            what = format!("PV through a swinging door of {deviation:.2}");
        }
        Effect::TravelLimit => {
            // the operating point is OP = MV = 50 % (`Scenario::op_bias`)
            let above = uniform(&mut rng, 4.0, 10.0);
            let beyond = uniform(&mut rng, 3.0, 8.0);
            let limit = 50.0 + above;
            let size = plant.static_gain() * (above + beyond);
            let n = samples as f64;
            // three episodes, the last in the validation window (the last third)
            for (at, sign) in [
                (0.1, 1.0),
                (0.2, -1.0),
                (0.45, 1.0),
                (0.55, -1.0),
                (0.8, 1.0),
                (0.9, -1.0),
            ] {
                setpoint.steps.push(datasets::simulate::SetpointStep {
                    at: (at * n) as usize,
                    size: sign * size,
                });
            }
            // no random walk: the steps alone ask for the travel beyond L (a walk of the
            // set point drifts by several % of span over the record and can cancel a step)
            setpoint.step = 0.0;
            travel_limit = Some(limit);
            op_limits = Some([0.0, 100.0]);
            what = format!(
                "travel limit L = {limit:.2} % (set point asks for {beyond:.1} % beyond it)"
            );
        }
    }
    let sim_seed = rng.random::<u64>() % 1_000_000;
    let mut scenario = Scenario {
        plant: PlantSpec::Explicit(plant),
        valve,
        disturbances,
        noise_sigma: noise,
        controller: datasets::simulate::Controller { kc: gain, ki: gain },
        samples,
        seed: sim_seed,
        characteristic,
        setpoint,
        plant_change,
        pv_compression,
        travel_limit,
        op_limits,
        ..Scenario::default()
    };
    let mut sim = scenario.simulate().expect("stable scenario");
    // With a characteristic the valve must stay inside its travel (5-95 % of span): a set
    // point beyond what the valve can deliver winds OP up for good. Such a loop is drawn again
    // with the next simulator seed (only the effects with a characteristic draw further
    // numbers).
    while characteristic.is_some() && sim.mv.iter().any(|&m| !(5.0..=95.0).contains(&m)) {
        scenario.seed = rng.random::<u64>() % 1_000_000;
        sim = scenario.simulate().expect("stable scenario");
    }
    let what = match characteristic {
        Some(c) => format!("{what}, gain ratio {:.2}", gain_ratio(c.shape(), &sim.mv)),
        None => what,
    };
    Case {
        seed,
        effect,
        plant: if slow { "slow" } else { "paper" },
        noise,
        gain,
        s: ts,
        j: tj,
        what,
        sim,
    }
}

impl Case {
    /// `diagnose` on this loop from the paper's baseline, the diagnosis's default options for
    /// its OP span, with the causes `disabled` left out.
    pub fn diagnose(&self, disabled: &[String]) -> discrepancy::Diagnosis {
        let problem = grid_search::Problem {
            op: &self.sim.op,
            pv: &self.sim.pv,
            mv: None,
        };
        let span = self.sim.op.iter().cloned().fold(f64::MIN, f64::max)
            - self.sim.op.iter().cloned().fold(f64::MAX, f64::min);
        let mut options = discrepancy::DiagnoseOptions::for_span(span);
        options.disabled = disabled.to_vec();
        let baseline = discrepancy::Baseline::paper().expect("the paper's baseline");
        discrepancy::diagnose(problem, &baseline, &options).expect("a diagnosis")
    }
}

/// The ratio of the characteristic's local gain at the 95th and the 5th percentile of the
/// valve position (`e^(|a| Δ/100)`): how much the process gain changes over the range the
/// valve actually covers.
pub fn gain_ratio(a: f64, mv: &[f64]) -> f64 {
    let mut v = mv.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return 1.0;
    }
    let at = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    (a.abs() * (at(0.95) - at(0.05)) / 100.0).exp()
}
