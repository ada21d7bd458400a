//! One-step predictions of several state-space fits side by side, one per SIMD lane
//! ([`ParsimK`]'s `identify_predict_many`: the grid nodes of a batch, each fit on its own MV
//! and the same PV).
//!
//! The predictor `ŷ = C x + D u`, `x+ = A x + B u + K (y − ŷ)` is a chain of dependent
//! operations from sample to sample; four fits of the same order advance together, every
//! scalar a `[f64; LANES]`, each lane performing the single predictor's operations in the
//! same order (`model.rs`'s `ss_run`), so the same bits (test in `parsim.rs`). The lanes run
//! in the record's time frame: a lane whose record starts later holds its `x0` until then.

pub(super) use crate::lanes::LANES;
use crate::lanes::{each, Lanes};
use crate::{LinearFit, Structure};

/// One lane: a state-space fit of order `N`, its input record and its start in `y`.
pub(super) struct Lane<'a> {
    pub fit: &'a LinearFit,
    /// The whole input record (as long as `y`).
    pub u: &'a [f64],
    pub start: usize,
    /// Position among the caller's inputs.
    pub index: usize,
}

/// The one-step predictions of `lanes` (state-space fits of order `N`) over
/// `(u[start..], y[start..])`, into `out[t][l]` at the record's sample `t >= start`.
pub(super) fn predict<const N: usize>(lanes: [&Lane<'_>; LANES], y: &[f64], out: &mut [Lanes]) {
    struct Run<'a, 'b, const N: usize> {
        lanes: [&'a Lane<'a>; LANES],
        y: &'a [f64],
        out: &'b mut [Lanes],
    }
    impl<const N: usize> faer::traits::pulp::WithSimd for Run<'_, '_, N> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: faer::traits::pulp::Simd>(self, _: S) {
            predict_fixed::<N>(self.lanes, self.y, self.out);
        }
    }
    // compiled for the best instruction set (four lanes per AVX2 instruction); the same
    // IEEE operations, so the same bits
    faer::traits::pulp::Arch::new().dispatch(Run::<N> { lanes, y, out });
}

#[inline(always)]
fn predict_fixed<const N: usize>(lanes: [&Lane<'_>; LANES], y: &[f64], out: &mut [Lanes]) {
    let mut a = [[[0.0; LANES]; N]; N];
    let (mut b, mut c, mut k, mut x0) = (
        [[0.0; LANES]; N],
        [[0.0; LANES]; N],
        [[0.0; LANES]; N],
        [[0.0; LANES]; N],
    );
    let mut d = [0.0; LANES];
    for (l, lane) in lanes.iter().enumerate() {
        let Structure::StateSpace {
            a: al,
            b: bl,
            c: cl,
            d: dl,
            k: kl,
            x0: x0l,
        } = lane.fit.structure()
        else {
            unreachable!("PARSIM-K fits are state space")
        };
        for i in 0..N {
            for j in 0..N {
                a[i][j][l] = al[i][j];
            }
            (b[i][l], c[i][l], k[i][l], x0[i][l]) = (bl[i], cl[i], kl[i], x0l[i]);
        }
        d[l] = *dl;
    }
    let (um, ym) = (
        each(|l| lanes[l].fit.means().0),
        each(|l| lanes[l].fit.means().1),
    );
    let starts = lanes.map(|lane| lane.start);
    let first = starts.iter().min().copied().unwrap_or(0);
    let all_active = starts.iter().max().copied().unwrap_or(0);
    let mut x = x0;
    for t in first..y.len() {
        let uc = each(|l| lanes[l].u[t] - um[l]);
        let mut yhat = [0.0; LANES];
        for i in 0..N {
            for l in 0..LANES {
                yhat[l] += c[i][l] * x[i][l];
            }
        }
        for l in 0..LANES {
            yhat[l] += d[l] * uc[l];
        }
        out[t] = each(|l| yhat[l] + ym[l]);
        let e = each(|l| (y[t] - ym[l]) - yhat[l]);
        let mut xn = [[0.0; LANES]; N];
        for i in 0..N {
            let mut v = [0.0; LANES];
            for j in 0..N {
                for l in 0..LANES {
                    v[l] += a[i][j][l] * x[j][l];
                }
            }
            xn[i] = each(|l| v[l] + b[i][l] * uc[l] + k[i][l] * e[l]);
        }
        x = xn;
        if t < all_active {
            for l in 0..LANES {
                if t < starts[l] {
                    for i in 0..N {
                        x[i][l] = x0[i][l];
                    }
                }
            }
        }
    }
}
