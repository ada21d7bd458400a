//! Time stamps written at a coarser resolution than the sampling.
//!
//! A historian that samples on a regular clock may write some stamps one sampling interval
//! off (its stamp clock rounds to a coarser resolution, or ticks with an offset): a stamp then
//! repeats its neighbour's and the next step, two intervals long, restores the grid
//! (`300, 300, 320` at 10 s). The rows are the samples in their order and their count matches
//! the grid; only the label of one row's time is wrong. Duplicated rows or a clock that jumps
//! back do not restore the grid: those stay refused (the rows' order is then not
//! trustworthy).
//!
//! The rule, from what an export can do and not fitted to any record, with `Ts` the median
//! interval: a row is a *stamp glitch* when its stamp equals a neighbour's while the stamps
//! around it are two intervals apart (`t[k+1] − t[k−1] = 2 Ts`), so that `t[k−1] + Ts` puts
//! it back on its neighbours' grid. A first or last row (one neighbour only) one interval off
//! (its stamp repeating its neighbour's, or two intervals from it) is taken for the same
//! glitch only when the record shows the glitch inside; alone it is a duplicated row (refused)
//! or a missing sample (the gap policy). Any other repeated or backward stamp refuses the
//! record.

use crate::{Note, NoteKind};

/// The stamps of `t` with every stamp glitch put back on the grid, and the glitched rows (in
/// file order); `None` when a repeated or backward stamp is not such a glitch.
pub(crate) fn on_grid(t: &[f64]) -> Option<(Vec<f64>, Vec<usize>)> {
    let n = t.len();
    if n < 3 {
        return None;
    }
    let mut dt: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    dt.sort_by(f64::total_cmp);
    let ts = dt[dt.len() / 2];
    if !(ts.is_finite() && ts > 0.0) {
        return None;
    }
    let near = |x: f64, y: f64| (x - y).abs() <= 1e-6 * ts;
    let mut fixed = t.to_vec();
    let mut inside = Vec::new();
    let (mut first, mut last) = (false, false);
    for i in 1..n {
        if t[i] > t[i - 1] {
            continue;
        }
        if !near(t[i], t[i - 1]) {
            return None; // backward, or not a number
        }
        if i + 1 < n && near(t[i + 1] - t[i - 1], 2.0 * ts) {
            // row i repeats row i-1's stamp; the next step restores the grid
            fixed[i] = t[i - 1] + ts;
            inside.push(i);
        } else if i >= 2 && near(t[i] - t[i - 2], 2.0 * ts) {
            // row i-1 is one interval ahead: its stamp is the next row's
            fixed[i - 1] = t[i - 2] + ts;
            inside.push(i - 1);
        } else if i == n - 1 {
            last = true;
        } else if i == 1 {
            first = true;
        } else {
            return None;
        }
    }
    if inside.is_empty() {
        return None;
    }
    // the ends, one interval off, when the record shows the glitch inside
    let off = |d: f64| near(d, 0.0) || near(d, 2.0 * ts);
    let mut rows = Vec::new();
    if first || (off(t[1] - t[0]) && near(t[2] - t[1], ts)) {
        if !near(t[2] - t[1], ts) {
            return None;
        }
        fixed[0] = t[1] - ts;
        rows.push(0);
    }
    rows.extend(inside);
    if last || (off(t[n - 1] - t[n - 2]) && near(t[n - 2] - t[n - 3], ts)) {
        if !near(t[n - 2] - t[n - 3], ts) {
            return None;
        }
        fixed[n - 1] = t[n - 2] + ts;
        rows.push(n - 1);
    }
    rows.sort_unstable();
    rows.dedup();
    fixed
        .windows(2)
        .all(|w| w[1] > w[0])
        .then_some((fixed, rows))
}

/// The reader's note on `glitches` stamps of the time column `name` put back on the grid, the
/// first at line `first` (header = 1), `repeats` of them repeating the previous stamp.
pub(crate) fn note(name: &str, glitches: usize, first: u64, repeats: usize) -> Note {
    Note::new(
        NoteKind::Stamps,
        format!(
            "column {name}: {glitches} time stamp(s) one sampling interval off the regular grid of their neighbours, the first at row {first} ({repeats} repeating the previous stamp): stamps written at a coarser resolution than the sampling, not reordered rows; read in file order on the grid"
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::on_grid;

    fn grid(n: usize) -> Vec<f64> {
        (0..n).map(|k| 10.0 * k as f64).collect()
    }

    #[test]
    fn a_repeat_restored_by_the_next_step_is_put_back() {
        let mut t = grid(12);
        t[5] = t[4]; // 40, 40, 60
        let (fixed, rows) = on_grid(&t).unwrap();
        assert_eq!(fixed, grid(12));
        assert_eq!(rows, vec![5]);
        // a stamp one interval ahead: 30, 50, 50
        let mut t = grid(12);
        t[4] = t[5];
        let (fixed, rows) = on_grid(&t).unwrap();
        assert_eq!(fixed, grid(12));
        assert_eq!(rows, vec![4]);
    }

    #[test]
    fn ends_one_interval_off_count_only_with_the_glitch_inside() {
        // every stamp but one in ten one interval late, the first and last rows too
        let mut t: Vec<f64> = (0..31)
            .map(|k: usize| 10.0 * (k + usize::from(!k.is_multiple_of(10))) as f64)
            .collect();
        t[30] = t[29];
        let (fixed, rows) = on_grid(&t).unwrap();
        assert!(fixed.windows(2).all(|w| w[1] - w[0] == 10.0), "{fixed:?}");
        assert_eq!(rows, vec![0, 10, 20, 30]);
        // a last row repeating its neighbour, alone: a duplicated row
        let mut t = grid(12);
        t[11] = t[10];
        assert!(on_grid(&t).is_none());
    }

    #[test]
    fn duplicates_and_backward_jumps_are_not_glitches() {
        let mut dup = grid(12);
        dup[5] = dup[4];
        for v in &mut dup[6..] {
            *v -= 10.0; // 40, 40, 50: a duplicated row, the grid not restored
        }
        assert!(on_grid(&dup).is_none());
        let mut back = grid(12);
        back[5] = 35.0;
        assert!(on_grid(&back).is_none());
        let mut nan = grid(12);
        nan[5] = f64::NAN;
        assert!(on_grid(&nan).is_none());
    }
}
