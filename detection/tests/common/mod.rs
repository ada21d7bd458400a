//! Helpers shared by the detector's integration tests.
#![allow(dead_code)]

/// ROC AUC of `score` for `sticky` (ties count one half).
pub fn auc(v: &[(f64, bool)]) -> f64 {
    let (mut pairs, mut wins) = (0.0, 0.0);
    for &(a, pa) in v {
        for &(b, pb) in v {
            if pa && !pb {
                pairs += 1.0;
                wins += if a > b {
                    1.0
                } else if a == b {
                    0.5
                } else {
                    0.0
                };
            }
        }
    }
    wins / pairs
}

/// The detector on a record read from the file `name`, as `stiction detect --integrating auto`
/// runs it: the median sampling time, the loop kind from the record (the tag letter `L`
/// breaking a tie), SP when there is one.
pub fn detect_read(d: &datasets::LoopData, name: &str) -> detection::Detection {
    let t = d.t.clone().expect("time column");
    let mut dts: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    dts.sort_by(f64::total_cmp);
    let ts = dts[dts.len() / 2];
    let level_tag = name
        .chars()
        .find(|c| c.is_ascii_alphabetic())
        .is_some_and(|c| c == 'L');
    let pv = d.require_pv().expect("PV").to_vec();
    let integrating = detection::kind::evidence(&pv, &d.op)
        .and_then(|e| e.integrating)
        .unwrap_or(level_tag);
    let reg = detection::Registration::new(&pv, &d.op, ts)
        .expect("a registration")
        .integrating(integrating);
    let reg = match &d.sp {
        Some(sp) => reg.with_sp(sp).expect("SP as long as PV"),
        None => reg,
    };
    detection::detect(&reg)
}
