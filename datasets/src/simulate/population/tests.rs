use super::super::{Controller, Plant, Setpoint};
use super::*;

#[test]
fn a_population_is_deterministic_and_spans_its_ranges() {
    let spec = PopulationSpec::wide(7);
    let loops: Vec<PopulationLoop> = (0..24).map(|i| spec.generate(i).unwrap()).collect();
    let again = spec.generate(5).unwrap();
    assert_eq!(again.sim.pv, loops[5].sim.pv);
    assert_eq!(again.what, loops[5].what);
    for l in &loops {
        assert!((1.0..=60.0).contains(&l.sample_time), "{}", l.what);
        assert!((200..=5000).contains(&l.sim.len()), "{}", l.what);
        assert!(l.sim.op.iter().all(|v| (0.0..=100.0).contains(v)));
        assert_eq!(l.integrating, l.family == Family::Level);
    }
    for f in Family::ALL {
        assert!(loops.iter().any(|l| l.family == f));
    }
    assert!(loops.iter().any(|l| l.label == Label::Sticky));
    assert!(loops.iter().any(|l| l.label == Label::Healthy));
    // another seed, another population
    let other = PopulationSpec::wide(8).generate(5).unwrap();
    assert_ne!(other.sim.pv, loops[5].sim.pv);
}

#[test]
fn a_share_of_proportional_controllers_leaves_the_other_loops_as_they_were() {
    let pi = PopulationSpec::wide(21);
    let half = PopulationSpec {
        proportional: 0.5,
        ..PopulationSpec::wide(21)
    };
    let (mut p_only, mut same) = (0, 0);
    for i in 0..40 {
        let (a, b) = (pi.generate(i).unwrap(), half.generate(i).unwrap());
        assert!(!a.what.contains("P-only"), "{}", a.what);
        if b.what.contains("P-only") {
            p_only += 1;
            // OP is the bias plus Kc times the error: its moves are PV's and SP's, scaled
            let (dp, ds, du) = (
                b.sim.pv[11] - b.sim.pv[10],
                b.sim.sp[11] - b.sim.sp[10],
                b.sim.op[11] - b.sim.op[10],
            );
            let (dp2, ds2, du2) = (
                b.sim.pv[21] - b.sim.pv[20],
                b.sim.sp[21] - b.sim.sp[20],
                b.sim.op[21] - b.sim.op[20],
            );
            let logged_as_seen = !b.what.contains('|')
                || !b.what.rsplit('|').next().is_some_and(|h| {
                    h.contains("swinging") || h.contains("quantised") || h.contains("frozen")
                });
            if logged_as_seen && ds == 0.0 && ds2 == 0.0 && dp.abs() > 1e-9 && dp2.abs() > 1e-9 {
                assert!(
                    (du / dp - du2 / dp2).abs() < 1e-6 * (du / dp).abs().max(1.0),
                    "{}",
                    b.what
                );
            }
        } else {
            same += 1;
            assert_eq!(a.what, b.what);
            assert_eq!(a.sim.pv, b.sim.pv);
        }
    }
    assert!(p_only >= 10 && same >= 10, "{p_only} P-only, {same} PI");
}

#[test]
fn a_transport_delay_lengthens_every_dead_time_by_its_samples() {
    let delay = |l: &PopulationLoop| -> usize {
        let w = l.what.split("delay=").nth(1).unwrap();
        w.split(' ').next().unwrap().parse().unwrap()
    };
    for i in 0..12 {
        let plain = PopulationSpec::wide(31).generate(i).unwrap();
        let late = PopulationSpec {
            transport_delay: [30.0, 30.0],
            ..PopulationSpec::wide(31)
        }
        .generate(i)
        .unwrap();
        assert_eq!(plain.sample_time, late.sample_time);
        let added = (30.0 / late.sample_time).round() as usize;
        let (a, b) = (delay(&plain), delay(&late));
        assert!(
            b == MAX_DELAY || b + 1 >= a + added && b <= a + added + 1,
            "{a} + {added} samples -> {b}: {}",
            late.what
        );
    }
}

#[test]
fn a_frozen_transmitter_cannot_be_judged() {
    let spec = PopulationSpec {
        seed: 11,
        families: vec![Family::Flow],
        sample_time: [5.0, 5.0],
        samples: [300, 300],
        ..PopulationSpec::default()
    };
    let frozen: Vec<PopulationLoop> = (0..200)
        .map(|i| spec.generate(i).unwrap())
        .filter(|l| l.what.contains("PV frozen"))
        .take(3)
        .collect();
    assert_eq!(frozen.len(), 3);
    for l in &frozen {
        assert_eq!(l.label, Label::CannotJudge, "{}", l.what);
        assert!(2 * longest_run(&l.sim.pv) > l.sim.len(), "{}", l.what);
        let last = l.sim.pv[l.sim.len() - 1];
        assert_eq!(l.sim.pv[l.sim.len() / 2], last, "{}", l.what);
    }
}

fn loop_with(s: f64, j: f64, noise: f64, kc: f64, set_point_moves: bool) -> SimulatedLoop {
    Scenario {
        valve: Box::new(Kano::params().s(s).j(j).check().unwrap()),
        noise_sigma: noise,
        controller: Controller { kc, ki: 0.5 },
        setpoint: if set_point_moves {
            Setpoint::default()
        } else {
            Setpoint::constant()
        },
        samples: 1000,
        ..Scenario::default()
    }
    .simulate()
    .unwrap()
}

#[test]
fn a_dithered_valve_leaves_no_trace_and_a_limit_cycle_does() {
    // A valve of S = 0.5 % under a controller that turns PV's noise into OP swings of
    // tens of %: it follows OP almost as a free valve does.
    let dithered = loop_with(0.5, 0.2, 2.0, 2.0, false);
    assert!(percentile_span(&dithered.op) > 20.0);
    let t = trace(&dithered, (0.0, 0.0)).unwrap();
    assert!(!t.shows(), "{t:?}");
    // the historian's error only hides it further
    let t2 = trace(&dithered, (0.5, 0.5)).unwrap();
    assert!(t2.lr() < t.lr(), "{t2:?} {t:?}");
    // The paper's S = 9, J = 3 valve cycles: stuck most of the time, PV square-ish.
    let cycling = loop_with(9.0, 3.0, 0.1, 0.5, true);
    assert!(cycling.stuck_fraction() > 0.5);
    let t = trace(&cycling, (0.0, 0.0)).unwrap();
    assert!(t.shows() && t.lr_pv > 100.0, "{t:?}");
}

#[test]
fn a_population_labels_its_traceless_sticky_loops_and_keeps_their_s() {
    let spec = PopulationSpec {
        seed: 5,
        families: vec![Family::Flow, Family::Level],
        sample_time: [2.0, 30.0],
        samples: [300, 3000],
        ..PopulationSpec::default()
    };
    let loops: Vec<PopulationLoop> = (0..120).map(|i| spec.generate(i).unwrap()).collect();
    let mut no_trace = 0;
    for l in &loops {
        let sticky = l.index % 2 == 0;
        assert_eq!(l.trace.is_some(), sticky, "{}", l.what);
        match l.label {
            Label::NoTrace => {
                no_trace += 1;
                assert!(l.s > 0.0 && !l.trace.unwrap().shows(), "{}", l.what);
            }
            Label::Sticky => assert!(l.trace.unwrap().shows(), "{}", l.what),
            Label::Healthy => assert!(!sticky),
            Label::CannotJudge => {}
        }
    }
    assert!(no_trace > 0, "no sticky loop without a trace in 60");
}

#[test]
fn fixed_settings_are_kept_and_a_quiet_op_cannot_be_judged() {
    let spec = PopulationSpec {
        seed: 3,
        families: vec![Family::Level],
        sample_time: [60.0, 60.0],
        samples: [400, 400],
        ..PopulationSpec::default()
    };
    for i in 0..6 {
        let l = spec.generate(i).unwrap();
        assert_eq!(l.sim.len(), 400);
        assert_eq!(l.sample_time, 60.0);
        assert!(l.integrating);
        let span = percentile_span(&l.sim.op);
        assert_eq!(
            l.label == Label::CannotJudge,
            span < BARELY_MOVES,
            "{}",
            l.what
        );
    }
}

#[test]
fn the_known_model_sees_a_limit_cycle_and_a_free_valve_replays_as_op() {
    // the paper's S = 9, J = 3 valve, cycling: its own valve explains PV far better than a
    // free one through the same plant
    let cycling = loop_with(9.0, 3.0, 0.1, 0.5, true);
    let lr = known_model_lr(&cycling, 20).unwrap();
    assert!(lr > 100.0, "{lr}");
    // a free valve replays as OP itself: the two hypotheses are one
    let free = loop_with(0.0, 0.0, 0.1, 0.5, true);
    assert_eq!(known_model_lr(&free, 20), Some(0.0));
    // a valve that follows OP's swings of tens of % almost as a free one does shows little
    let dithered = loop_with(0.5, 0.2, 2.0, 2.0, false);
    let lr = known_model_lr(&dithered, 20).unwrap();
    assert!(lr < NO_TRACE_LR, "{lr}");
    // too short for the noise model
    let mut short = free.clone();
    for v in [&mut short.pv, &mut short.op, &mut short.mv] {
        v.truncate(80);
    }
    assert_eq!(known_model_lr(&short, 20), None);
}

#[test]
fn a_noise_model_without_a_stable_inverse_is_left_to_the_ar_model() {
    assert!(known_model::minimum_phase(&[1.0, -0.9]));
    assert!(known_model::minimum_phase(&[1.0, -1.4, 0.55, -0.06]));
    // the paper's C has roots outside the unit circle
    assert!(!known_model::minimum_phase(&Plant::paper().c));
    assert!(!known_model::minimum_phase(&[1.0, -1.0]));
}
