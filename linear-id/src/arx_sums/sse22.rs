//! The grid's ARX(2, 2) one-step SSE on explicit four-wide registers ([`arx22_one_step_sse`]),
//! a [`RowsPass`] of the parent's fused passes.

use super::{Arch, Dispatch, Quad, RowsPass};

/// The squared one-step residuals of an ARX(2, 2) summed over rows `t`, each given by its
/// lagged samples: `y0[t] = y(t)`, `y1[t] = y(t - 1)`, `y2[t] = y(t - 2)`, `u1[t] =
/// u(t - delay - 1)`, `u2[t] = u(t - delay - 2)` (equal lengths). Per row the prediction is
/// `((((kconst - a1 y1) - a2 y2) + b1 u1) + b2 u2) + ym` and the error that minus `y0`,
/// rounded at every step (`predict_one_step`'s order); the squares are summed in eight lanes
/// (row `t` in lane `t mod 8`) combined as `((l0 + l4) + (l2 + l6)) + ((l1 + l5) + (l3 + l7))`,
/// then the rows past the last multiple of eight one by one. Two four-lane AVX2 registers
/// where the processor has them (the compiler's own vectorisation of the same loop used
/// SSE2's two lanes), the same bits everywhere.
pub fn arx22_one_step_sse(
    [a1, a2, b1, b2]: [f64; 4],
    kconst: f64,
    ym: f64,
    [y0, y1, y2]: [&[f64]; 3],
    [u1, u2]: [&[f64]; 2],
) -> f64 {
    let len = y0.len();
    assert!(
        [y1.len(), y2.len(), u1.len(), u2.len()]
            .iter()
            .all(|&l| l == len),
        "lagged columns of different lengths"
    );
    let pass = Sse22Pass {
        coeffs: [a1, a2, b1, b2],
        kconst,
        ym,
        cols: [y0, y1, y2, u1, u2],
    };
    Arch::new().dispatch(Dispatch(pass))
}

/// [`arx22_one_step_sse`] as a [`RowsPass`].
pub(super) struct Sse22Pass<'a> {
    pub(super) coeffs: [f64; 4],
    pub(super) kconst: f64,
    pub(super) ym: f64,
    /// `y0, y1, y2, u1, u2`.
    pub(super) cols: [&'a [f64]; 5],
}

impl RowsPass for Sse22Pass<'_> {
    type Output = f64;
    #[inline(always)]
    fn run<Q: Quad>(self, q: Q) -> f64 {
        let [a1, a2, b1, b2] = self.coeffs;
        let (kconst, ym) = (self.kconst, self.ym);
        let [y0, y1, y2, u1, u2] = self.cols;
        let (va1, va2, vb1, vb2) = (q.splat(a1), q.splat(a2), q.splat(b1), q.splat(b2));
        let (vk, vym) = (q.splat(kconst), q.splat(ym));
        let mut acc = [q.splat(0.0); 2];
        let (c0, c1, c2, c3, c4) = (
            y0.chunks_exact(8),
            y1.chunks_exact(8),
            y2.chunks_exact(8),
            u1.chunks_exact(8),
            u2.chunks_exact(8),
        );
        let rem = (
            c0.remainder(),
            c1.remainder(),
            c2.remainder(),
            c3.remainder(),
            c4.remainder(),
        );
        for ((((w0, w1), w2), w3), w4) in c0.zip(c1).zip(c2).zip(c3).zip(c4) {
            for (h, acc) in acc.iter_mut().enumerate() {
                let r = 4 * h..4 * h + 4;
                let mut v = q.sub(vk, q.mul(va1, q.load(&w1[r.clone()])));
                v = q.sub(v, q.mul(va2, q.load(&w2[r.clone()])));
                v = q.add(v, q.mul(vb1, q.load(&w3[r.clone()])));
                v = q.add(v, q.mul(vb2, q.load(&w4[r.clone()])));
                let e = q.sub(q.add(v, vym), q.load(&w0[r]));
                *acc = q.add_mul(*acc, e, e);
            }
        }
        let (lo, hi) = (q.lanes(acc[0]), q.lanes(acc[1]));
        let mut s = ((lo[0] + hi[0]) + (lo[2] + hi[2])) + ((lo[1] + hi[1]) + (lo[3] + hi[3]));
        for t in 0..rem.0.len() {
            let mut v = kconst;
            v -= a1 * rem.1[t];
            v -= a2 * rem.2[t];
            v += b1 * rem.3[t];
            v += b2 * rem.4[t];
            let e = (v + ym) - rem.0[t];
            s += e * e;
        }
        s
    }
}
