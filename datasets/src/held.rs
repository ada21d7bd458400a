//! PV that updates only every `k` samples: an analyser's result held between its cycles, or a
//! historian's archive read back with "previous value" (step) retrieval at a finer interval
//! than it stored. Between two updates the logged PV repeats itself exactly while OP moves,
//! which is what a stuck valve looks like to the tests that compare OP's motion with PV's
//! (the stick-slip test's stuck windows, the Hammerstein fit's deadband). `monitoring`'s one
//! answer carries a caution on a `stiction` verdict for such a record. A property of the logged
//! column, beside [`crate::quantisation`] and [`crate::compression`].
//!
//! A held PV is recognised by the *phase* of its changes, not by how often it repeats: nearly
//! all the samples where PV changes fall on one residue class modulo `k`. Noise on a finely
//! quantised PV, a slow ramp through coarse quantisation steps or a swinging-door archive
//! interpolated linearly change PV at instants with no common period, and are not held.

/// Least number of PV changes needed to call PV held (fewer: the phase of its changes is no
/// evidence of a period).
pub const MIN_UPDATES: usize = 20;

/// Share of PV's changes that must fall on one residue class modulo the period. A change at
/// a random instant falls on a given class with probability `1/k`, at most a half.
pub const ON_PHASE: f64 = 0.9;

/// Longest update period looked for, in samples.
pub const MAX_PERIOD: usize = 60;

/// How PV is held: it changes only at samples `phase`, `phase + period`, ...
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Held {
    /// Samples between PV's updates (at least 2).
    pub period: usize,
    /// Index of the first update slot (`0..period`).
    pub phase: usize,
}

/// Whether PV is held between updates every `k` samples ([`Held`]), the longest such period
/// (a PV held for 10 samples also changes on one class modulo 5 and 2); `None` when PV
/// changes at instants with no common period, or too seldom to tell (fewer than
/// [`MIN_UPDATES`] changes, or fewer than 20 update slots in the record).
pub fn held_period(pv: &[f64]) -> Option<Held> {
    let n = pv.len();
    let changes: Vec<usize> = (1..n)
        .filter(|&i| pv[i].to_bits() != pv[i - 1].to_bits())
        .collect();
    if changes.len() < MIN_UPDATES {
        return None;
    }
    let longest = MAX_PERIOD.min(n / 20);
    (2..=longest).rev().find_map(|k| {
        let mut count = vec![0usize; k];
        for &i in &changes {
            count[i % k] += 1;
        }
        let (phase, &most) = count.iter().enumerate().max_by_key(|&(_, c)| *c)?;
        (most as f64 >= ON_PHASE * changes.len() as f64).then_some(Held { period: k, phase })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noisy(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|k| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (k as f64 * 0.05).sin() + ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.1
            })
            .collect()
    }

    #[test]
    fn a_pv_held_between_updates_is_recognised_with_its_phase() {
        let pv = noisy(1000, 3);
        assert_eq!(held_period(&pv), None, "a live PV is not held");
        for (period, phase) in [(2, 1), (5, 0), (10, 3), (30, 17)] {
            let held: Vec<f64> = (0..pv.len())
                .map(|i| {
                    let slot = if i < phase {
                        0
                    } else {
                        phase + (i - phase) / period * period
                    };
                    pv[slot]
                })
                .collect();
            assert_eq!(
                held_period(&held),
                Some(Held { period, phase }),
                "held {period} from {phase}"
            );
        }
        // coarse quantisation of a live PV: repeats, but no common period of the changes
        let coarse: Vec<f64> = pv.iter().map(|v| (v * 8.0).round() / 8.0).collect();
        assert_eq!(held_period(&coarse), None);
        // too few changes to tell
        let steps: Vec<f64> = (0..1000).map(|i| (i / 100) as f64).collect();
        assert_eq!(held_period(&steps), None);
    }
}
