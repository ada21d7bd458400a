//! The grid over a stiction model's parameters.

use stiction_models::ModelEntry;

/// The nodes of a grid: every parameter on `0, step, 2 step, …` up to its upper bound
/// (`max_span_fraction · span`), keeping the admissible combinations (the model's constraints,
/// e.g. the triangle `J <= S` for Kano). Nodes are in lexicographic order of the parameter
/// vector, which fixes the tie-breaking (smaller first parameter, then second, …).
pub fn nodes(entry: &ModelEntry, span: f64, step: f64) -> Vec<Vec<f64>> {
    nodes_in_box(entry, span, step, None)
}

/// Like [`nodes`], restricted to the box `[lo_i, hi_i]` per parameter (for local refinement):
/// values are multiples of `step` inside the box.
pub fn nodes_in_box(
    entry: &ModelEntry,
    span: f64,
    step: f64,
    bounds: Option<&[(f64, f64)]>,
) -> Vec<Vec<f64>> {
    let axes: Vec<Vec<f64>> = entry
        .params
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let top = p.max_span_fraction * span;
            let (lo, hi) = bounds.map_or((0.0, top), |b| (b[i].0.max(0.0), b[i].1.min(top)));
            axis(lo, hi, step)
        })
        .collect();
    let mut out = Vec::new();
    let mut current = Vec::with_capacity(axes.len());
    product(&axes, &mut current, &mut |v| {
        if entry.admissible(v, span) {
            out.push(v.to_vec());
        }
    });
    out
}

/// Multiples of `step` in `[lo, hi]` (with a relative tolerance of 1e-9 at the ends).
///
/// Callers bound the size first ([`crate::budget::count_nodes`]); an axis of more than 2^32
/// values (or a non-finite or non-positive step) is empty rather than an allocation failure.
fn axis(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let len = crate::budget::axis_len(lo, hi, step);
    if hi < lo || !(len > 0.0 && len <= 4_294_967_296.0) {
        return Vec::new();
    }
    let first = (lo / step - 1e-9).ceil().max(0.0) as usize;
    let last = (hi / step + 1e-9).floor() as usize;
    (first..=last).map(|i| i as f64 * step).collect()
}

fn product(axes: &[Vec<f64>], current: &mut Vec<f64>, f: &mut dyn FnMut(&[f64])) {
    if current.len() == axes.len() {
        f(current);
        return;
    }
    let axis = &axes[current.len()];
    for &v in axis {
        current.push(v);
        product(axes, current, f);
        current.pop();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use stiction_models::find_model;

    #[test]
    fn kano_grid_is_the_triangle() {
        let kano = find_model("kano").unwrap();
        let n = nodes(kano, 1.0, 0.25);
        // S in {0, .25, .5, .75, 1}, J <= S: 1 + 2 + 3 + 4 + 5 = 15 nodes.
        assert_eq!(n.len(), 15);
        assert!(n.iter().all(|v| v[1] <= v[0]));
        assert_eq!(n[0], vec![0.0, 0.0]);
        assert_eq!(n.last().unwrap(), &vec![1.0, 1.0]);
    }

    #[test]
    fn asym_grid_respects_the_span() {
        let e = find_model("kano-asym").unwrap();
        let n = nodes(e, 1.0, 0.5);
        // D in {0, .5, 1}; J_up, J_dn in [0, 1 - D]: 9 + 4 + 1 = 14.
        assert_eq!(n.len(), 14);
        assert!(n
            .iter()
            .all(|v| v[0] + v[1] <= 1.0 + 1e-12 && v[0] + v[2] <= 1.0 + 1e-12));
    }

    #[test]
    fn refinement_box_stays_on_the_fine_lattice() {
        let kano = find_model("kano").unwrap();
        let n = nodes_in_box(kano, 10.0, 0.1, Some(&[(2.95, 3.25), (0.0, 0.2)]));
        let s: Vec<f64> = n.iter().map(|v| v[0]).collect();
        assert!(
            s.iter().all(|&x| (3.0 - 1e-9..=3.2 + 1e-9).contains(&x)),
            "{s:?}"
        );
        assert_eq!(n.len(), 3 * 3);
    }
}
