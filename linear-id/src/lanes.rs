//! What the lane-parallel recursions share (`recursive/lanes.rs`, `parsim/lanes.rs`): several
//! grid nodes advance through one serial recursion together, one per SIMD lane, each lane
//! performing the single recursion's operations in the same order (so the same bits).

/// Nodes run side by side (four doubles: one AVX register, two SSE2 registers).
pub(crate) const LANES: usize = 4;

/// One scalar of the recursion, per lane.
pub(crate) type Lanes = [f64; LANES];

/// `f(l)` for every lane.
#[inline(always)]
pub(crate) fn each(mut f: impl FnMut(usize) -> f64) -> Lanes {
    let mut out = [0.0; LANES];
    for (l, v) in out.iter_mut().enumerate() {
        *v = f(l);
    }
    out
}
