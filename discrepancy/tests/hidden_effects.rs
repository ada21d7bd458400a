//! The seeded hidden-effect suite: loops with one hidden effect drawn at random (or none) must
//! be diagnosed with the right cause.
//!
//! CI size: 6 loops per effect (disturbance, asymmetric-stiction, time-delay, no-stiction,
//! valve-characteristic, travel-limit, a process whose dynamics change during the record,
//! which no plugin models, PV through a historian's compression, and the pairs of causes that
//! can co-occur: disturbance + dead time, disturbance + asymmetric valve, dead time +
//! asymmetric valve, and characteristic + dead time) and 10 clean
//! loops, 3000 samples each. `STICTION_SUITE_SIZE=N` runs N loops per effect and
//! max(N, 10) clean ones (`cargo xtask suite` uses 24). `STICTION_SUITE_ONLY=Effect,...` runs only
//! those situations. `STICTION_SUITE_DISABLE=cause` disables a detector
//! (the check that the suite fails without it, recorded in docs/DIAGNOSE.md).
//!
//! Acceptance (all sizes): right cause in >= 90 % of effect loops, `none` in >= 90 % of clean
//! loops, and the extended model's S closer to the truth than the baseline's in most effect
//! loops where stiction exists (disturbance, asymmetric-stiction, time-delay,
//! valve-characteristic); for the characteristic loops, the set of causes exactly
//! `valve-characteristic` in >= 80 % (the target is 90 % at full size; one miss of 6 at CI
//! size is 83 %); for the process-change loops, `unexplained` among the causes in >= 2/3
//! and exactly `[unexplained]` in >= 2/3 (docs/DIAGNOSE.md has the measured rates). They do not count
//! in the 90 % of the effect loops: a registered cause that gains significantly on them is
//! named before `unexplained`); for each pair, both causes exactly in >= 1/2 at every size
//! and >= 90 % at 24 loops or more (not counted in the 90 % of the effect loops; measured
//! at both sizes in docs/DIAGNOSE.md); for the compressed loops, exactly `[compression]` in >= 80 %. A table per effect gives the first cause, the exact set and the final
//! model's S within max(0.5, 10 %) of the truth.
#![allow(clippy::unwrap_used)]

mod common;

use common::{case, Effect};

#[test]
fn diagnose_names_the_hidden_effect() {
    let size: u64 = std::env::var("STICTION_SUITE_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(6);
    let samples: usize = std::env::var("STICTION_SUITE_SAMPLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3000);
    // At least 10 clean loops, so that one wrong call does not decide the 90 % rate.
    let clean: u64 = size.max(10);
    let disabled: Vec<String> = std::env::var("STICTION_SUITE_DISABLE")
        .ok()
        .map(|s| s.split(',').map(str::to_string).collect())
        .unwrap_or_default();
    let effects = [
        Effect::Disturbance,
        Effect::Asymmetric,
        Effect::Delay,
        Effect::Oscillation,
        Effect::Characteristic,
        Effect::ProcessChange,
        Effect::Compression,
        // two causes at once (after the single effects, so their seeds stay as they were)
        Effect::DisturbanceDelay,
        Effect::DisturbanceAsymmetric,
        Effect::DelayAsymmetric,
    ];
    let (mut effect_ok, mut effect_n, mut clean_ok, mut clean_n) = (0, 0, 0, 0);
    let (mut closer, mut compared) = (0, 0);
    let (mut unexplained_ok, mut unexplained_n) = (0, 0);
    let mut lines = Vec::new();
    let mut loops: Vec<(u64, Effect)> = Vec::new();
    // per effect: loops, first cause right, set of causes right, final S within tolerance,
    // loops with stiction, slowest diagnosis (ms)
    let mut table: Vec<(Effect, [usize; 5], f64)> = Vec::new();
    for i in 0..size {
        for (k, &e) in effects.iter().enumerate() {
            loops.push((1000 + 10 * i + k as u64, e));
        }
    }
    // situations added later have seeds of their own, so that every other loop stays as it was
    for i in 0..size {
        loops.push((6000 + i, Effect::CharacteristicDelay));
    }
    for i in 0..size {
        loops.push((7000 + i, Effect::TravelLimit));
    }
    for i in 0..clean {
        loops.push((5000 + i, Effect::Clean));
    }
    // `STICTION_SUITE_ONLY=CharacteristicDelay,Delay`: only those situations (by their
    // `Effect` names), to iterate on a few at full size; the acceptance then counts only them
    let only: Option<Vec<String>> = std::env::var("STICTION_SUITE_ONLY")
        .ok()
        .map(|s| s.split(',').map(str::to_string).collect());
    loops.retain(|(_, e)| only.as_ref().is_none_or(|o| o.contains(&format!("{e:?}"))));
    for (seed, effect) in loops {
        let c = case(seed, effect, samples);
        let d = c.diagnose(&disabled);
        let right = d.cause == effect.cause();
        // `cause` is the first of `causes` (none: empty)
        assert_eq!(
            d.causes.first().map_or("none", String::as_str),
            d.cause,
            "seed {seed}"
        );
        if effect == Effect::Clean {
            clean_n += 1;
            clean_ok += usize::from(right);
        } else if effect.causes().len() > 1 {
            // two causes: judged by the set of causes (the table), not by the first
        } else if effect == Effect::ProcessChange {
            // no plugin models it: `unexplained` must be among the causes (a registered cause
            // that gains significantly may come first)
            unexplained_n += 1;
            unexplained_ok += usize::from(d.causes.iter().any(|c| c == "unexplained"));
        } else {
            effect_n += 1;
            effect_ok += usize::from(right);
        }
        let mut note =
            d.findings
                .iter()
                .find(|f| f.cause == "no-stiction")
                .map_or(String::new(), |f| {
                    format!(
                        "no-stiction LR {:.1} {}",
                        f.lr,
                        f.error.as_deref().unwrap_or("")
                    )
                });
        if !matches!(
            effect,
            Effect::Clean | Effect::Oscillation | Effect::ProcessChange | Effect::Compression
        ) && effect.causes().len() == 1
        {
            if let Some(f) = d.findings.iter().find(|f| f.cause == effect.cause()) {
                if let Some(x) = &f.extended {
                    compared += 1;
                    let better = (x.s - c.s).abs() < (d.baseline.s - c.s).abs();
                    closer += usize::from(better);
                    note.push_str(&format!("ext S {:.2}", x.s));
                }
            }
        }
        let mut set: Vec<&str> = d.causes.iter().map(String::as_str).collect();
        set.sort_unstable();
        let set_right = set == effect.causes();
        let final_s = d.final_fit().map_or(d.baseline.s, |f| f.result.s);
        let sticky = c.s > 0.0;
        let s_ok = sticky && (final_s - c.s).abs() <= (0.1 * c.s).max(0.5);
        let row = match table.iter().position(|r| r.0 == effect) {
            Some(i) => i,
            None => {
                table.push((effect, [0; 5], 0.0));
                table.len() - 1
            }
        };
        let r = &mut table[row];
        for (k, v) in [true, right, set_right, s_ok, sticky]
            .into_iter()
            .enumerate()
        {
            r.1[k] += usize::from(v);
        }
        r.2 = r.2.max(d.elapsed_ms);
        note.push_str(&format!(" final S {final_s:.2}"));
        lines.push(format!(
            "{} seed {seed} {:?} ({}, {}) true S {:.2} | cause {} (causes {}) | base S {:.2} {note}",
            if (effect.causes().len() < 2 && right) || (effect.causes().len() > 1 && set_right) {
                "ok "
            } else {
                "BAD"
            },
            effect,
            c.plant,
            c.what,
            c.s,
            d.cause,
            d.causes.join(", "),
            d.baseline.s
        ));
    }
    for l in &lines {
        println!("{l}");
    }
    println!("effect | loops | first cause right | set of causes right | final S within max(0.5, 10 %) | slowest ms");
    for (e, [n, first, set, s_ok, sticky], ms) in &table {
        println!("{e:?} | {n} | {first} | {set} | {s_ok}/{sticky} | {ms:.0}");
    }
    println!(
        "effect loops: {effect_ok}/{effect_n} right; clean loops: {clean_ok}/{clean_n} none; extended S closer than baseline's: {closer}/{compared}"
    );
    assert!(
        effect_ok * 10 >= effect_n * 9,
        "right cause in {effect_ok}/{effect_n} effect loops (< 90 %)"
    );
    assert!(
        clean_ok * 10 >= clean_n * 9,
        "none in {clean_ok}/{clean_n} clean loops (< 90 %)"
    );
    if let Some((_, [n, _, set, _, _], _)) = table.iter().find(|r| r.0 == Effect::Characteristic) {
        assert!(
            set * 10 >= n * 8,
            "valve-characteristic exactly in {set}/{n} characteristic loops (< 80 %)"
        );
    }
    for pair in [
        Effect::DisturbanceDelay,
        Effect::DisturbanceAsymmetric,
        Effect::DelayAsymmetric,
        Effect::CharacteristicDelay,
    ] {
        if let Some((_, [n, _, set, _, _], _)) = table.iter().find(|r| r.0 == pair) {
            assert!(
                set * 2 >= *n,
                "{pair:?}: both causes exactly in {set}/{n} loops (< 1/2)"
            );
            // at full size the target: 90 %
            assert!(
                *n < 24 || set * 10 >= n * 9,
                "{pair:?}: both causes exactly in {set}/{n} loops (< 90 %)"
            );
        }
    }
    if let Some((_, [n, _, set, _, _], _)) = table.iter().find(|r| r.0 == Effect::Compression) {
        assert!(
            set * 10 >= n * 8,
            "exactly [compression] in {set}/{n} compressed loops (< 80 %)"
        );
    }
    println!("process change: unexplained among the causes in {unexplained_ok}/{unexplained_n}");
    assert!(
        unexplained_ok * 3 >= unexplained_n * 2,
        "unexplained in {unexplained_ok}/{unexplained_n} process-change loops (< 2/3)"
    );
    // each cause on its own evidence: a cause that gains only across the change is not named
    // beside `unexplained` (the stationary stretches' re-test)
    if let Some((_, [n, _, set, _, _], _)) = table.iter().find(|r| r.0 == Effect::ProcessChange) {
        println!("process change: exactly [unexplained] in {set}/{n}");
        assert!(
            set * 3 >= n * 2,
            "exactly [unexplained] in {set}/{n} process-change loops (< 2/3)"
        );
    }
    assert!(
        compared == 0 || closer * 2 > compared,
        "extended S closer in only {closer}/{compared}"
    );
}
