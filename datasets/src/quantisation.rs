//! The quantisation step of a column: the lattice its values sit on when it was written as
//! counts of an analogue output card or a transmitter (OP as 14-bit counts read back in %: a
//! step of 100/16383 %) or with a fixed number of decimals (a PV logged to 0.01).
//!
//! The rule (fixed, unit-free, not fitted to any data): the distinct values of the column,
//! sorted; `q` the smallest gap between neighbours divided by `k = 1, 2, ..., 10` (a lattice
//! whose neighbouring points are never both visited shows its step only as a multiple); the
//! step is the first such `q` of which at least 99 % of the gaps are whole multiples (within
//! 1 % of `q`). A column with fewer than four distinct values, or whose `q` is below 1e-9 of
//! its largest magnitude (the resolution of the numbers themselves, not of an instrument), has
//! no measured step. Values computed in floating point from continuous signals have gaps that
//! are no whole multiples of anything coarse, so they get `None`.

/// The quantisation step of `x` in its own units, `None` when `x` is not on a lattice (see the
/// module documentation). Non-finite values are ignored.
pub fn step(x: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    if v.len() < 4 {
        return None;
    }
    let magnitude = v[0].abs().max(v[v.len() - 1].abs());
    let gaps: Vec<f64> = v.windows(2).map(|w| w[1] - w[0]).collect();
    let smallest = gaps.iter().copied().fold(f64::INFINITY, f64::min);
    (1..=10).map(|k| smallest / k as f64).find(|&q| {
        q > 1e-9 * magnitude && {
            let on = gaps
                .iter()
                .filter(|&&g| ((g / q) - (g / q).round()).abs() <= 0.01)
                .count();
            on as f64 >= 0.99 * gaps.len() as f64
        }
    })
}

/// The median absolute change between neighbouring samples that differ, the motion a step is
/// compared with (`None` when every sample equals its neighbour).
pub fn median_move(x: &[f64]) -> Option<f64> {
    let mut d: Vec<f64> = x
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 0.0 && d.is_finite())
        .collect();
    if d.is_empty() {
        return None;
    }
    d.sort_by(f64::total_cmp);
    Some(d[d.len() / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn walk(n: usize) -> Vec<f64> {
        // a deterministic wandering signal, not on any lattice
        (0..n)
            .map(|i| 50.0 + 3.0 * (i as f64 * 0.037).sin() + 0.7 * (i as f64 * 0.61).cos())
            .collect()
    }

    #[test]
    fn counts_read_back_in_percent_have_their_step() {
        for full in [4095.0, 16383.0, 65535.0] {
            let x: Vec<f64> = walk(3000)
                .iter()
                .map(|v| (v / 100.0 * full).round() * 100.0 / full)
                .collect();
            let q = step(&x).unwrap();
            assert!((q / (100.0 / full) - 1.0).abs() < 1e-9, "{full}: {q}");
        }
    }

    #[test]
    fn decimals_are_a_step_in_any_units() {
        for scale in [1e-6, 1.0, 1e9] {
            let x: Vec<f64> = walk(3000)
                .iter()
                .map(|v| (v * 100.0).round() / 100.0 * scale)
                .collect();
            let q = step(&x).unwrap();
            assert!((q / (0.01 * scale) - 1.0).abs() < 1e-6, "{scale}: {q}");
        }
    }

    #[test]
    fn a_sparse_lattice_is_found_from_its_gaps() {
        // only every second or third lattice point visited: gaps 2q and 3q, step q
        let x: Vec<f64> = (0..200).map(|i| 0.25 * (5 * i / 2) as f64).collect();
        assert_eq!(step(&x), Some(0.25));
    }

    #[test]
    fn continuous_values_have_no_step() {
        assert_eq!(step(&walk(3000)), None);
        assert_eq!(step(&[1.0, 2.0, 3.0]), None);
        assert_eq!(median_move(&[1.0, 1.0]), None);
        assert_eq!(median_move(&[1.0, 1.5, 1.5, 3.5, 4.0]), Some(0.5));
    }
}
