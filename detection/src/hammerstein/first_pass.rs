//! The first pass of the output-error sums ([`super::oe_rss_fixed`]): the lag's recursion,
//! its squares, neighbour products and products with the target, on the lane arrays or, for
//! four lanes, on one AVX2 register.

use super::SHIFTS;

/// The first pass's sums ([`super::oe_rss_fixed`]): the target's products with the shifts, the
/// squares and the neighbour products, per lane.
pub(super) struct FirstSums<const L: usize> {
    pub(super) a: [[f64; L]; SHIFTS],
    pub(super) sq: [f64; L],
    pub(super) nb: [f64; L],
}

/// Who runs [`super::oe_rss_fixed`]'s first pass: the lane arrays as written there ([`Arrays`]),
/// or four lanes in one AVX2 register ([`Avx`]); each lane the same operations in the same
/// order, so the same bits.
pub(super) trait FirstPass: Copy {
    /// The pass over `[1, n)` (`x[0]`, `x[1]` already hold the start-up value); `None`: the
    /// lane arrays'.
    #[allow(clippy::too_many_arguments)]
    fn run<const L: usize>(
        self,
        u: &[[f64; L]],
        x: &mut [[f64; L]],
        ry: &[f64],
        start: usize,
        p: [f64; L],
        g: [f64; L],
    ) -> Option<FirstSums<L>>;
}

/// The lane arrays of [`super::oe_rss_fixed`].
#[cfg(test)]
#[derive(Clone, Copy)]
pub(super) struct Arrays;

#[cfg(test)]
impl FirstPass for Arrays {
    #[inline(always)]
    fn run<const L: usize>(
        self,
        _: &[[f64; L]],
        _: &mut [[f64; L]],
        _: &[f64],
        _: usize,
        _: [f64; L],
        _: [f64; L],
    ) -> Option<FirstSums<L>> {
        None
    }
}

/// Four lanes as one vector of pulp's `S` (AVX2); any other width or lane count: `None`.
/// Written as vectors because the compiler, given the lane arrays, gathered the five shifts'
/// lanes through shuffles and kept two of the sums on the stack.
#[derive(Clone, Copy)]
pub(super) struct Avx<S>(pub(super) S);

impl<S: faer::traits::pulp::Simd> FirstPass for Avx<S> {
    #[inline(always)]
    fn run<const L: usize>(
        self,
        u: &[[f64; L]],
        x: &mut [[f64; L]],
        ry: &[f64],
        start: usize,
        p: [f64; L],
        g: [f64; L],
    ) -> Option<FirstSums<L>> {
        use faer::traits::pulp::bytemuck;
        if L != 4 || S::F64_LANES != 4 {
            return None;
        }
        let simd = self.0;
        let load = |v: &[f64]| -> S::f64s { bytemuck::pod_read_unaligned(bytemuck::cast_slice(v)) };
        let lanes = |v: S::f64s| -> [f64; 4] { bytemuck::cast(v) };
        let mul_add =
            |acc: S::f64s, a: S::f64s, b: S::f64s| simd.add_f64s(acc, simd.mul_f64s(a, b));
        let n = x.len();
        let (pv, gv) = (load(&p[..]), load(&g[..]));
        let u0 = load(&u[0][..]);
        let (mut l0, mut l1, mut l2, mut l3, mut l4) = (u0, u0, u0, u0, u0);
        let zero = simd.splat_f64s(0.0);
        let (mut a0, mut a1, mut a2, mut a3, mut a4) = (zero, zero, zero, zero, zero);
        let (mut sq, mut nb) = (zero, zero);
        // t = 1 holds the start-up value; from 2 the recursion; the target's products from
        // `start` on (the loop split there, the same order per sum)
        let split = start.clamp(2, n.max(2));
        if n > 1 {
            sq = mul_add(sq, l0, l0);
            nb = mul_add(nb, l0, l1);
            if start <= 1 {
                let r = simd.splat_f64s(ry[1]);
                (a0, a1, a2, a3, a4) = (
                    mul_add(a0, l0, r),
                    mul_add(a1, l1, r),
                    mul_add(a2, l2, r),
                    mul_add(a3, l3, r),
                    mul_add(a4, l4, r),
                );
            }
        }
        for t in 2..split.min(n) {
            let v = simd.add_f64s(
                simd.mul_f64s(pv, l0),
                simd.mul_f64s(gv, load(&u[t - 1][..])),
            );
            x[t][..].copy_from_slice(&lanes(v));
            // (the oldest shift is read only with the target's products, after the next shift)
            (l3, l2, l1, l0) = (l2, l1, l0, v);
            sq = mul_add(sq, l0, l0);
            nb = mul_add(nb, l0, l1);
        }
        for t in split..n {
            let v = simd.add_f64s(
                simd.mul_f64s(pv, l0),
                simd.mul_f64s(gv, load(&u[t - 1][..])),
            );
            x[t][..].copy_from_slice(&lanes(v));
            (l4, l3, l2, l1, l0) = (l3, l2, l1, l0, v);
            sq = mul_add(sq, l0, l0);
            nb = mul_add(nb, l0, l1);
            let r = simd.splat_f64s(ry[t]);
            a0 = mul_add(a0, l0, r);
            a1 = mul_add(a1, l1, r);
            a2 = mul_add(a2, l2, r);
            a3 = mul_add(a3, l3, r);
            a4 = mul_add(a4, l4, r);
        }
        let arr = |v: S::f64s| -> [f64; L] {
            let w = lanes(v);
            std::array::from_fn(|l| w[l])
        };
        Some(FirstSums {
            a: [arr(a0), arr(a1), arr(a2), arr(a3), arr(a4)],
            sq: arr(sq),
            nb: arr(nb),
        })
    }
}

/// [`super::oe_rss_fixed`]'s first pass on the lane arrays: the recursion, the squares, the
/// neighbour products and the target's products with the shifts (from `start` on). t = 1
/// holds the start-up value.
#[inline(always)]
pub(super) fn first_pass_arrays<const L: usize>(
    u: &[[f64; L]],
    x: &mut [[f64; L]],
    ry: &[f64],
    start: usize,
    p: [f64; L],
    g: [f64; L],
) -> FirstSums<L> {
    let n = x.len();
    let mut a = [[0.0; L]; SHIFTS];
    let (mut sq, mut nb) = ([0.0; L], [0.0; L]);
    // The last SHIFTS values of the lag, newest first, in named variables (registers): the
    // recursion and the products read them without a round trip through memory.
    let (mut l0, mut l1, mut l2, mut l3, mut l4) = (u[0], u[0], u[0], u[0], u[0]);
    let mul_add = |acc: &mut [f64; L], x: &[f64; L], y: &[f64; L]| {
        for l in 0..L {
            acc[l] += x[l] * y[l];
        }
    };
    for t in 1..n {
        if t >= 2 {
            let ut = &u[t - 1];
            let mut v = [0.0; L];
            for l in 0..L {
                v[l] = p[l] * l0[l] + g[l] * ut[l];
            }
            x[t] = v;
            (l4, l3, l2, l1, l0) = (l3, l2, l1, l0, v);
        }
        mul_add(&mut sq, &l0, &l0);
        mul_add(&mut nb, &l0, &l1);
        if t >= start {
            let r = [ry[t]; L];
            mul_add(&mut a[0], &l0, &r);
            mul_add(&mut a[1], &l1, &r);
            mul_add(&mut a[2], &l2, &r);
            mul_add(&mut a[3], &l3, &r);
            mul_add(&mut a[4], &l4, &r);
        }
    }
    FirstSums { a, sq, nb }
}
