//! The closed-loop benchmark: invariants B1-B5 of spec §6.4 and the paper-plant behaviour.

#![allow(clippy::unwrap_used)]

use datasets::simulate::{
    Controller, Disturbance, Plant, PlantPreset, PlantSpec, Scenario, Setpoint, SetpointStep,
};
use datasets::{read_csv, DataError, ReadOptions};
use stiction_models::{find_model, InitialState, Kano, StictionModel};

fn kano(s: f64, j: f64) -> Box<dyn StictionModel> {
    Box::new(Kano::params().s(s).j(j).check().unwrap())
}

fn peak_to_peak(v: &[f64]) -> f64 {
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = v.iter().copied().fold(f64::INFINITY, f64::min);
    max - min
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// B1: linear valve, no noise, no disturbance, constant SP after an initial step of +3:
/// PV settles on SP (mean error over the last 2000 of 6000 samples < 1e-6) and OP settles on
/// the value that gives MV = op_bias + 3 / static gain.
#[test]
fn b1_linear_valve_settles_on_setpoint() {
    for preset in [PlantPreset::Paper, PlantPreset::Slow] {
        let s = Scenario {
            plant: PlantSpec::Preset(preset),
            setpoint: Setpoint {
                steps: vec![SetpointStep { at: 0, size: 3.0 }],
                ..Setpoint::constant()
            },
            noise_sigma: 0.0,
            samples: 6000,
            warmup: 0,
            ..Scenario::default()
        };
        let sim = s.simulate().unwrap();
        let tail = 4000..6000;
        let err: Vec<f64> = tail
            .clone()
            .map(|k| (sim.pv[k] - sim.sp[k]).abs())
            .collect();
        assert!(
            mean(&err) < 1e-6,
            "{preset:?}: mean |PV - SP| = {}",
            mean(&err)
        );
        assert_eq!(sim.sp[5999], 53.0);
        let op_tail = &sim.op[tail];
        assert!(peak_to_peak(op_tail) < 1e-6, "{preset:?}: OP not constant");
        let want = 50.0 + 3.0 / preset.plant().static_gain();
        assert!(
            (op_tail[0] - want).abs() < 1e-6,
            "{preset:?}: OP {} vs {want}",
            op_tail[0]
        );
        // ... and the loop did move (the test is not trivially satisfied).
        let early: Vec<f64> = (0..100).map(|k| (sim.pv[k] - sim.sp[k]).abs()).collect();
        assert!(mean(&early) > 0.03, "{preset:?}: {}", mean(&early));
    }
}

fn b2_scenario(noise_sigma: f64, seed: u64) -> Scenario {
    Scenario {
        plant: PlantSpec::Preset(PlantPreset::Slow),
        valve: kano(3.0, 1.0),
        setpoint: Setpoint::constant(),
        noise_sigma,
        samples: 6000,
        warmup: 500,
        seed,
        ..Scenario::default()
    }
}

/// B2: slow plant, Kano S = 3, J = 1, σ_e = 0, constant SP: the valve's initial offset
/// ((S - J)/2 = 1 from OP) starts a sustained limit cycle whose PV peak-to-peak over the last
/// 2000 samples is 6.0 (spec, one decimal; we measure 5.984, the same for both initial
/// directions since the cycle is self-sustained). Tolerance ±0.1: the spec's rounding plus a
/// margin, while a wrong sign, a wrong J or a missing slip jump changes the cycle by far more.
/// The fraction of samples with MV(k) = MV(k-1) at σ_e = 0.05 is 0.38 in the spec; we measure
/// 0.369-0.375 for seeds 1-3 (0.379 at σ_e = 0): tolerance ±0.02.
#[test]
fn b2_stiction_limit_cycle_on_slow_plant() {
    for init in [InitialState::down(), InitialState::up()] {
        let s = Scenario {
            valve_init: init,
            ..b2_scenario(0.0, 1)
        };
        let sim = s.simulate().unwrap();
        let p2p = peak_to_peak(&sim.pv[4000..]);
        assert!((p2p - 6.0).abs() < 0.1, "PV peak-to-peak {p2p}");
        // Sustained: the last and the previous 1000 samples swing as much (up to where the
        // samples fall on the cycle, which is not an integer number of samples long).
        let (a, b) = (
            peak_to_peak(&sim.pv[4000..5000]),
            peak_to_peak(&sim.pv[5000..]),
        );
        assert!(a > 5.5 && b > 5.5 && (a - b).abs() < 0.2, "{a} vs {b}");
        // SP did not move: the oscillation is the valve's.
        assert!(sim.sp.iter().all(|&v| v == 50.0));
    }
    for seed in 1..=3 {
        let sim = b2_scenario(0.05, seed).simulate().unwrap();
        let f = sim.stuck_fraction();
        assert!((f - 0.38).abs() < 0.02, "seed {seed}: stuck fraction {f}");
    }
}

/// B2 counterpart: the same loop with a linear valve and σ_e = 0 does not oscillate.
#[test]
fn b2_no_limit_cycle_without_stiction() {
    let s = Scenario {
        valve: kano(0.0, 0.0),
        ..b2_scenario(0.0, 1)
    };
    let sim = s.simulate().unwrap();
    assert!(peak_to_peak(&sim.pv[4000..]) < 1e-9);
}

/// B3: an unstable tuning is refused before simulating, naming the largest root modulus; the
/// roots are roots of the characteristic polynomial (residual check, independent of the
/// eigenvalue solver) and the paper's three tunings are stable on its plant.
#[test]
fn b3_unstable_tuning_is_refused() {
    let s = Scenario {
        controller: Controller { kc: 2.0, ki: 2.0 },
        ..Scenario::default()
    };
    let err = s.simulate().unwrap_err();
    match err {
        DataError::Unstable { max_modulus, .. } => assert!((max_modulus - 1.0265).abs() < 1e-3),
        e => panic!("unexpected {e}"),
    }
    assert_eq!(
        s.simulate().unwrap_err().to_string(),
        "closed loop unstable with Kc = 2, KI = 2, delay 0: largest closed-loop root modulus \
         1.026501 >= 1"
    );
    let paper = Plant::paper();
    for (kc, ki) in [(0.5, 0.5), (1.2, 1.2), (0.2, 0.2)] {
        assert!(paper.check_stability(kc, ki).unwrap() < 1.0);
    }
    assert!(Plant::slow().check_stability(0.5, 0.5).unwrap() < 1.0);
    assert!(matches!(
        Plant::slow().check_stability(1.2, 1.2),
        Err(DataError::Unstable { .. })
    ));
    // Residuals: p(z) = Σ p_i z^(n-i) vanishes at every root.
    for (plant, kc, ki) in [(Plant::paper(), 2.0, 2.0), (Plant::slow(), 0.5, 0.5)] {
        let p = plant.characteristic_polynomial(kc, ki);
        let roots = plant.closed_loop_roots(kc, ki).unwrap();
        assert_eq!(roots.len(), p.len() - 1);
        for [re, im] in roots {
            let (mut vr, mut vi) = (0.0, 0.0);
            for &c in &p {
                (vr, vi) = (vr * re - vi * im + c, vr * im + vi * re);
            }
            assert!(vr.hypot(vi) < 1e-9, "residual {vr} {vi}");
        }
    }
}

/// B4: identical seeds give bit-identical output; different seeds differ.
#[test]
fn b4_reproducible_by_seed() {
    let s = Scenario {
        valve: kano(5.0, 2.0),
        disturbances: vec![
            Disturbance::Paper { a: 0.25 },
            Disturbance::RandomSteps {
                probability: 0.01,
                sigma: 1.0,
            },
        ],
        samples: 1000,
        warmup: 100,
        ..Scenario::default()
    };
    let a = s.simulate().unwrap();
    let b = s.simulate().unwrap();
    for (x, y) in [
        (&a.sp, &b.sp),
        (&a.pv, &b.pv),
        (&a.op, &b.op),
        (&a.mv, &b.mv),
    ] {
        assert_eq!(x, y);
    }
    assert_eq!(a.disturbance, b.disturbance);
    let c = Scenario { seed: 2, ..s }.simulate().unwrap();
    assert_ne!(a.pv, c.pv);
    assert_ne!(a.sp, c.sp);
    assert_ne!(a.disturbance, c.disturbance);
}

/// B5: with a linear valve a positive SP step gives a positive PV response.
#[test]
fn b5_positive_setpoint_step_gives_positive_pv_response() {
    for preset in [PlantPreset::Paper, PlantPreset::Slow] {
        let s = Scenario {
            plant: PlantSpec::Preset(preset),
            setpoint: Setpoint {
                steps: vec![SetpointStep { at: 100, size: 1.0 }],
                ..Setpoint::constant()
            },
            noise_sigma: 0.0,
            samples: 300,
            warmup: 50,
            ..Scenario::default()
        };
        let sim = s.simulate().unwrap();
        assert!(sim.pv[..=100].iter().all(|&v| v == 50.0));
        let first_move = sim.pv[101..].iter().find(|&&v| v != 50.0).unwrap();
        assert!(
            *first_move > 50.0,
            "{preset:?}: PV first moved to {first_move}"
        );
        assert!(mean(&sim.pv[110..130]) > 50.5);
        assert!(sim.op[100] > 50.0, "OP must rise with the error");
    }
}

/// The paper's plant with a linear valve tracks the random-walk set point: the mean tracking
/// error (noise σ_e = 0.1 included) is small relative to the set point's variation.
#[test]
fn paper_plant_linear_valve_tracks_setpoint() {
    let sim = Scenario::default().simulate().unwrap();
    let err: Vec<f64> = sim
        .pv
        .iter()
        .zip(&sim.sp)
        .map(|(p, s)| (p - s).abs())
        .collect();
    let sp_mean = mean(&sim.sp);
    let sp_sd = (sim.sp.iter().map(|v| (v - sp_mean).powi(2)).sum::<f64>() / 3000.0).sqrt();
    assert!(sp_sd > 1.0, "the set point should move");
    // Measured: mean |PV - SP| = 0.21, SP standard deviation 2.8.
    assert!(mean(&err) < 0.15 * sp_sd, "{} vs {}", mean(&err), sp_sd);
    // MV = OP for k >= 1 with S = J = 0.
    assert_eq!(&sim.mv[1..], &sim.op[1..]);
}

fn paper_s9_j3() -> Scenario {
    Scenario {
        valve: kano(9.0, 3.0),
        ..Scenario::default()
    }
}

/// S = 9, J = 3 on the paper's plant: a stick-slip cycle. MV is piecewise constant (long flat
/// runs) and moves in jumps larger than J (measured: stuck 89.5 % of samples, 225 of 316
/// moves larger than 2), while OP swings over more than S.
#[test]
fn paper_plant_stick_slip_cycle() {
    let sim = paper_s9_j3().simulate().unwrap();
    let stuck = sim.stuck_fraction();
    assert!(stuck > 0.8, "stuck fraction {stuck}");
    let jumps: Vec<f64> = sim
        .mv
        .windows(2)
        .filter(|w| w[1] != w[0])
        .map(|w| (w[1] - w[0]).abs())
        .collect();
    let big = jumps.iter().filter(|&&j| j > 2.0).count();
    assert!(
        big * 2 > jumps.len(),
        "{big} of {} moves larger than 2",
        jumps.len()
    );
    let mut runs = Vec::new();
    let mut run = 0;
    for w in sim.mv.windows(2) {
        if w[1] == w[0] {
            run += 1;
        } else if run > 0 {
            runs.push(run);
            run = 0;
        }
    }
    assert!(mean(&runs.iter().map(|&r| r as f64).collect::<Vec<_>>()) > 5.0);
    assert!(peak_to_peak(&sim.op) > 9.0);
    // OP oscillates: it crosses its mean many times (measured 207 in 3000 samples).
    let m = mean(&sim.op);
    let crossings = sim
        .op
        .windows(2)
        .filter(|w| (w[0] - m) * (w[1] - m) < 0.0)
        .count();
    assert!(crossings > 50, "{crossings}");
}

/// Must-hold: running the valve model with the scenario's initial state over the simulated OP
/// reproduces the simulated MV exactly, for every registered model, with noise and a
/// disturbance; also after a CSV round trip.
#[test]
fn valve_model_reproduces_mv_from_op() {
    let mut cases: Vec<(Box<dyn StictionModel>, InitialState)> = vec![
        (kano(9.0, 3.0), InitialState::default()),
        (kano(5.0, 2.0), InitialState::up()),
    ];
    for entry in stiction_models::registry() {
        let pairs: Vec<(String, f64)> = match entry.name {
            "kano" => vec![("S".into(), 4.0), ("J".into(), 1.0)],
            "he" => vec![("fs".into(), 2.5), ("fd".into(), 1.5)],
            "kano-asym" => vec![
                ("D".into(), 3.0),
                ("J_up".into(), 1.0),
                ("J_dn".into(), 2.0),
            ],
            "kano-char" => vec![("S".into(), 4.0), ("J".into(), 1.0), ("a".into(), 3.0)],
            _ => entry
                .params
                .iter()
                .map(|p| (p.name.to_string(), p.default))
                .collect(),
        };
        cases.push((
            find_model(entry.name).unwrap().build_named(&pairs).unwrap(),
            InitialState::default(),
        ));
    }
    for (valve, init) in cases {
        let s = Scenario {
            valve,
            valve_init: init,
            disturbances: vec![Disturbance::Paper { a: 0.25 }],
            samples: 1500,
            warmup: 300,
            ..Scenario::default()
        };
        let sim = s.simulate().unwrap();
        let mv = s.valve.simulate(&sim.op, &s.valve_init).unwrap();
        assert_eq!(mv, sim.mv, "{}", s.valve.name());
        // The valve did move and stick (the check is not vacuous).
        let moves = sim.mv.windows(2).filter(|w| w[1] != w[0]).count();
        assert!(
            moves > 20 && moves < 1499,
            "{}: {moves} moves",
            s.valve.name()
        );

        let mut csv = Vec::new();
        sim.write_csv(&mut csv).unwrap();
        let data = read_csv(&csv[..], "sim.csv", &ReadOptions::default()).unwrap();
        assert_eq!(data.op, sim.op);
        assert_eq!(data.mv.as_deref(), Some(&sim.mv[..]));
        assert_eq!(s.valve.simulate(&data.op, &s.valve_init).unwrap(), sim.mv);
    }
}

/// The paper's disturbance (eq. 11) is what is injected, indexed from the first kept sample.
#[test]
fn injected_disturbance_is_eq_11() {
    let s = Scenario {
        disturbances: vec![Disturbance::Paper { a: 0.5 }],
        samples: 200,
        ..Scenario::default()
    };
    let sim = s.simulate().unwrap();
    for (k, &eta) in sim.disturbance.iter().enumerate() {
        let k = k as f64;
        assert_eq!(eta, 0.5 * ((0.03 * k).sin() + 0.5 * (0.07 * k).sin()));
    }
    assert!(sim.noise.iter().any(|&e| e != 0.0));
}

/// `to_loop_data` keeps every series and marks MV as measured.
#[test]
fn loop_data_conversion() {
    let sim = Scenario {
        samples: 50,
        warmup: 10,
        ..Scenario::default()
    }
    .simulate()
    .unwrap();
    let d = sim.to_loop_data();
    assert_eq!(d.len(), 50);
    assert_eq!(d.op, sim.op);
    assert_eq!(d.mv.as_deref(), Some(&sim.mv[..]));
    assert_eq!(d.pv.as_deref(), Some(&sim.pv[..]));
    assert_eq!(d.sp.as_deref(), Some(&sim.sp[..]));
    assert_eq!(d.columns(), ["t", "SP", "PV", "OP", "MV"]);
}
