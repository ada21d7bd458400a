//! Several hidden effects at once: the forward selection must find each of them, and add
//! nothing to a loop with one effect.
//!
//! CI size: 6 loops of each pair (a disturbance and an extra dead time, a disturbance and an
//! asymmetric valve, a dead time and an asymmetric valve) and 6 loops of each single effect
//! (disturbance, time-delay, valve-characteristic); `STICTION_SUITE_SIZE=N` runs N of each.
//! Acceptance: the set of causes right in at least two thirds of each pair's loops and of
//! each single effect's loops (measured at size 6 in docs/decisions/2026-11-26-diagnose-logbook.md, item 5). Without the
//! forward selection no two-cause loop can be right (one cause at most); without re-testing
//! the causes that gained nothing in the first round, the asymmetric pairs were right in 1/6
//! and 3/6.
#![allow(clippy::unwrap_used)]

mod common;

use common::{case, Effect};

fn causes_of(effect: Effect, seed: u64, disabled: &[String]) -> (Vec<String>, String) {
    let c = case(seed, effect, 3000);
    let d = c.diagnose(disabled);
    let steps: Vec<String> = d
        .steps
        .iter()
        .flatten()
        .map(|f| {
            format!(
                "{} LR {:.1}/{:.0} stat {:.2} S {:.2}{}",
                f.cause,
                f.lr,
                f.threshold,
                f.statistic,
                f.extended.as_ref().map_or(f64::NAN, |e| e.s),
                f.error
                    .as_deref()
                    .map_or(String::new(), |e| format!(" error {e}"))
            )
        })
        .collect();
    let first: Vec<String> = d
        .findings
        .iter()
        .map(|f| {
            format!(
                "{} LR {:.1}/{:.0} stat {:.2}",
                f.cause, f.lr, f.threshold, f.statistic
            )
        })
        .collect();
    let mut causes = d.causes.clone();
    causes.sort();
    let line = format!(
        "seed {seed} {:?} ({}): causes {:?}, S true {:.2} final {:.2} ({} ms)\n   first {first:?}\n   then {steps:?}",
        effect,
        c.what,
        d.causes,
        c.s,
        d.final_fit().map_or(d.baseline.s, |f| f.result.s),
        d.elapsed_ms as u64
    );
    (causes, line)
}

#[test]
fn forward_selection_finds_both_causes() {
    let size: u64 = std::env::var("STICTION_SUITE_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(6);
    let disabled: Vec<String> = std::env::var("STICTION_SUITE_DISABLE")
        .ok()
        .map(|s| s.split(',').map(str::to_string).collect())
        .unwrap_or_default();
    let rate = |effect: Effect, seed0: u64| {
        let mut right = 0;
        for i in 0..size {
            let (causes, line) = causes_of(effect, seed0 + i, &disabled);
            let expected: Vec<String> = effect.causes().iter().map(|c| c.to_string()).collect();
            let ok = causes == expected;
            right += usize::from(ok);
            println!("{} {line}", if ok { "right" } else { "WRONG" });
        }
        right as f64 / size as f64
    };
    let both = rate(Effect::DisturbanceDelay, 7000);
    let single_d = rate(Effect::Disturbance, 7100);
    let single_t = rate(Effect::Delay, 7200);
    let single_c = rate(Effect::Characteristic, 7300);
    let dist_asym = rate(Effect::DisturbanceAsymmetric, 7400);
    let delay_asym = rate(Effect::DelayAsymmetric, 7500);
    println!("disturbance + asymmetric {dist_asym:.2}, dead time + asymmetric {delay_asym:.2}");
    println!(
        "two causes {both:.2}, disturbance alone {single_d:.2}, dead time alone {single_t:.2}, characteristic alone {single_c:.2}"
    );
    let two_thirds = 2.0 / 3.0 - 1e-9;
    assert!(both >= two_thirds, "two-cause loops right {both:.2}");
    assert!(
        dist_asym >= two_thirds && delay_asym >= two_thirds,
        "disturbance + asymmetric right {dist_asym:.2}, dead time + asymmetric {delay_asym:.2}"
    );
    assert!(
        single_d >= two_thirds && single_t >= two_thirds && single_c >= two_thirds,
        "single causes right {single_d:.2} / {single_t:.2} / {single_c:.2}"
    );
}

/// The headline a planner acts on names every cause of the final model with the step that
/// added it (1, 2, ... in order), and the S of the final model with its region.
#[test]
fn headline_names_the_causes_held_with_their_steps_and_the_final_s() {
    let mut checked = 0;
    for seed in 7000..7004 {
        let c = case(seed, Effect::DisturbanceDelay, 3000);
        let d = c.diagnose(&[]);
        if d.causes.len() < 2 {
            continue;
        }
        let h = d.headline();
        let names: Vec<&str> = h.causes.iter().map(|(c, _)| c.as_str()).collect();
        assert_eq!(
            names,
            d.causes.iter().map(String::as_str).collect::<Vec<_>>()
        );
        let steps: Vec<usize> = h.causes.iter().filter_map(|(_, k)| *k).collect();
        assert_eq!(
            steps,
            (1..=steps.len()).collect::<Vec<_>>(),
            "{:?}",
            h.causes
        );
        assert!(steps.len() >= 2, "{:?}", h.causes);
        let fin = d.final_fit().expect("a final model");
        assert_eq!(h.s, fin.result.s);
        assert!(h.s_range[0] <= h.s && h.s <= h.s_range[1], "{h:?}");
        assert!(h
            .action_line()
            .contains(&format!("S = {:.2} %", fin.result.s)));
        for (cause, k) in &h.causes {
            let st = d.standing(cause).expect("standing");
            assert!(st.held);
            assert_eq!(st.step, *k);
            if k.is_some() {
                assert!(
                    st.finding.significant,
                    "{cause} added without a significant test"
                );
            }
        }
        checked += 1;
    }
    assert!(checked >= 2, "only {checked} of 4 loops had two causes");
}

/// Two causes that mask each other: suite loop 1159 (the slow plant, 3 samples of extra dead
/// time and a kano-asym valve). On the baseline the dead time gains less than its threshold
/// and on the asymmetric valve's model it gains nothing significant; started from the dead
/// time, the asymmetric valve is found on top, and that pair's model gains significantly over
/// the asymmetric valve's alone. With the pair search disabled (`pairs`) the causes are
/// `[asymmetric-stiction]` alone.
#[test]
fn two_causes_that_mask_each_other_are_named_together() {
    let c = case(1159, Effect::DelayAsymmetric, 3000);
    let d = c.diagnose(&[]);
    let delay = d.standing("time-delay").expect("time-delay tested");
    println!("causes {:?}\n{}", d.causes, delay.finding.evidence);
    let mut causes = d.causes.clone();
    causes.sort();
    assert_eq!(causes, ["asymmetric-stiction", "time-delay"]);
    assert!(delay.held && delay.finding.significant);
    assert!(
        delay.finding.evidence.contains("Named as a pair"),
        "{}",
        delay.finding.evidence
    );
    assert_eq!(d.headline().causes.len(), 2);
    let without = c.diagnose(&[discrepancy::PAIRS.to_string()]);
    assert_eq!(without.causes, ["asymmetric-stiction"]);
}

/// A characteristic and a dead time: suite loop 6003 (an equal-percentage
/// valve of rangeability 38.5 and 6 samples of extra dead time). The characteristic is chosen
/// first; the dead time is then tested on its `kano-char` model (the valve's three parameters
/// searched from the current valve at the best dead time, the characteristic's shape kept) and
/// added. Without that test the causes are `[valve-characteristic]`.
#[test]
fn a_dead_time_is_found_on_top_of_a_characteristic() {
    let c = case(6003, Effect::CharacteristicDelay, 3000);
    let d = c.diagnose(&[]);
    let final_s = d.final_fit().map(|f| f.result.s);
    println!(
        "{} causes {:?}, final S {final_s:?} (true {:.2})",
        c.what, d.causes, c.s
    );
    assert_eq!(d.causes, ["valve-characteristic", "time-delay"]);
    let last = d.final_fit().expect("a final model");
    assert_eq!(last.stiction.name, "kano-char");
    assert!(last.delay >= 1, "dead time {}", last.delay);
}

/// Suite loop 6013 (the slow plant, a quick-opening valve of rangeability 48.1 and 3 samples
/// of extra dead time, PI gains 0.056: the loop detuned for both). Neither cause gains
/// significantly on the baseline (the characteristic LR 17, the dead time LR 10, threshold
/// 20); on the dead time's model the characteristic gains LR 30, and the pair's model gains
/// significantly over each cause's extension alone: both are named. Without the search of a
/// pair of weak causes (`pairs` disabled) nothing is named.
#[test]
fn two_weak_causes_are_named_as_a_pair() {
    let c = case(6013, Effect::CharacteristicDelay, 3000);
    let d = c.diagnose(&[]);
    println!("{} causes {:?}\n{}", c.what, d.causes, d.summary);
    let mut causes = d.causes.clone();
    causes.sort();
    assert_eq!(causes, ["time-delay", "valve-characteristic"]);
    // the first cause did not gain significantly alone: named as a pair
    let first = &d.findings[d.chosen.expect("a first cause")];
    let (lr, threshold, evidence) = (first.lr, first.threshold, &first.evidence);
    assert!(lr < threshold, "LR {lr} threshold {threshold}");
    assert!(evidence.contains("Named as a pair"), "{evidence}");
    let without = c.diagnose(&[discrepancy::PAIRS.to_string()]);
    assert!(without.causes.is_empty(), "{:?}", without.causes);
}

/// Suite loop 6002 (the slow plant, a quick-opening valve of rangeability 39.2 and 3 samples
/// of extra dead time, PI gains 0.066). The dead time's extension estimates 2 samples with a
/// linear characteristic; the characteristic tested on that model searches the dead time
/// again with its shape free (the pair's model as one) and finds 3, where it gains
/// significantly. With the dead time kept at the dead time's estimate the characteristic
/// gained LR 19.8 (threshold 20) and the causes were `[time-delay]`.
#[test]
fn the_characteristic_searches_the_dead_time_with_its_shape() {
    let c = case(6002, Effect::CharacteristicDelay, 3000);
    let d = c.diagnose(&[]);
    println!("{} causes {:?}", c.what, d.causes);
    assert_eq!(d.causes, ["time-delay", "valve-characteristic"]);
    let alone = d.standing("time-delay").expect("time-delay tested");
    let alone_delay = alone
        .finding
        .fitted
        .as_ref()
        .expect("a dead-time model")
        .delay;
    // the step that added the characteristic
    let pair = d.steps[0][d.picks[0]]
        .fitted
        .as_ref()
        .expect("the pair's model");
    assert_eq!(pair.stiction.name, "kano-char");
    assert!(
        pair.delay > alone_delay,
        "the pair's dead time {} against the dead time's alone {alone_delay}",
        pair.delay
    );
}

/// Suite loop 6014 (the slow plant, a quick-opening valve of rangeability 34.1 and 3 samples
/// of extra dead time, PI gains 0.056). The characteristic is named first (LR 36.5); the dead
/// time gains under its threshold on the baseline (LR 4.0, estimated at 5 samples) and
/// nothing on the characteristic's model. Started from the dead time's model (two causes that
/// mask each other), the characteristic searches the dead time again with its shape free
/// (4 samples) and gains LR 174, and the pair's model gains significantly over the
/// characteristic's alone: both are named. With the dead time kept at the dead time's
/// estimate the causes were `[valve-characteristic]`.
#[test]
fn a_characteristic_moves_a_masked_dead_time_to_its_own() {
    let c = case(6014, Effect::CharacteristicDelay, 3000);
    let d = c.diagnose(&[]);
    println!("{} causes {:?}", c.what, d.causes);
    let mut causes = d.causes.clone();
    causes.sort();
    assert_eq!(causes, ["time-delay", "valve-characteristic"]);
    let delay = d.standing("time-delay").expect("time-delay tested");
    assert!(
        delay.finding.evidence.contains("Named as a pair"),
        "{}",
        delay.finding.evidence
    );
    let last = d.final_fit().expect("a final model");
    assert_eq!(last.stiction.name, "kano-char");
    assert!(last.delay >= 1, "dead time {}", last.delay);
}

/// Suite loop 6001 (the paper plant, a quick-opening valve of rangeability 33.1 and 3 samples
/// of extra dead time, PI gains 0.162). The open set sees a change on the baseline (not on
/// the final model); on the stationary stretch after it the characteristic gains nothing
/// significant against the stretch's baseline (LR 9), but it does on top of the dead time
/// there, the test it passed on the record: both are named and no change. Testing each cause
/// on the stretch's baseline alone dropped the characteristic and named
/// `[time-delay, unexplained]`.
#[test]
fn a_cause_added_on_top_of_another_is_retested_on_top_of_it_on_a_stretch() {
    let c = case(6001, Effect::CharacteristicDelay, 3000);
    let d = c.diagnose(&[]);
    println!("{} causes {:?}\n{}", c.what, d.causes, d.summary);
    assert_eq!(d.causes, ["time-delay", "valve-characteristic"]);
}
