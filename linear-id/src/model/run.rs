//! Free runs of a fitted model: the polynomial and state-space loops (orders as compile-time
//! constants where small) and the blocked free run.

use super::*;

/// The free run of a polynomial model once every lag exists (`k >= start`):
/// `ŷ_k = -Σ a_i ŷ_{k-i} + Σ b_j (u_{k-delay-j} - ū)`, summed in that order.
pub(crate) struct PolyTail<'a> {
    /// `[a1, …, an]`.
    pub(crate) a: &'a [f64],
    pub(crate) b: &'a [f64],
    pub(crate) delay: usize,
    pub(crate) um: f64,
}

impl PolyTail<'_> {
    /// Orders as compile-time constants: the lag loops unroll into straight-line code.
    pub(crate) fn run<const NA: usize, const NB: usize>(
        &self,
        u: &[f64],
        out: &mut [f64],
        start: usize,
    ) {
        let (Ok(a), Ok(b)) = (<[f64; NA]>::try_from(self.a), <[f64; NB]>::try_from(self.b)) else {
            return self.run_dyn(u, out, start);
        };
        for k in start..out.len() {
            let (done, rest) = out.split_at_mut(k);
            let ys: &[f64; NA] = match done[k - NA..].try_into() {
                Ok(v) => v,
                Err(_) => return,
            };
            let lo = k - self.delay - NB;
            let us: &[f64; NB] = match u[lo..lo + NB].try_into() {
                Ok(v) => v,
                Err(_) => return,
            };
            let mut v = 0.0;
            for i in 0..NA {
                v -= a[i] * ys[NA - 1 - i];
            }
            for j in 0..NB {
                v += b[j] * (us[NB - 1 - j] - self.um);
            }
            rest[0] = v;
        }
    }

    pub(crate) fn run_dyn(&self, u: &[f64], out: &mut [f64], start: usize) {
        let (na, nb, delay) = (self.a.len(), self.b.len(), self.delay);
        for k in start..out.len() {
            let mut v = 0.0;
            for (ai, oi) in self.a.iter().zip(out[k - na..k].iter().rev()) {
                v -= ai * oi;
            }
            for (bj, uj) in self.b.iter().zip(u[k - delay - nb..k - delay].iter().rev()) {
                v += bj * (uj - self.um);
            }
            out[k] = v;
        }
    }
}

/// A state-space model borrowed for [`ss_run`]; `a` row-major `n × n`.
pub(crate) struct SsModel<'a> {
    pub(crate) a: &'a [f64],
    pub(crate) b: &'a [f64],
    pub(crate) c: &'a [f64],
    pub(crate) d: f64,
    pub(crate) k: &'a [f64],
    pub(crate) x0: &'a [f64],
}

/// Call `$f(n)` with `n` a literal for state dimensions up to 4 (the body, inlined, then
/// works on fixed-size loops), with the runtime value otherwise.
macro_rules! dispatch_state_dim {
    ($n:expr, |$v:ident| $body:expr) => {
        match $n {
            1 => {
                let $v = 1;
                $body
            }
            2 => {
                let $v = 2;
                $body
            }
            3 => {
                let $v = 3;
                $body
            }
            4 => {
                let $v = 4;
                $body
            }
            other => {
                let $v = other;
                $body
            }
        }
    };
}

/// State-space run on centered data, no allocation per sample. With `y`: the one-step
/// predictor `ŷ = C x + D u`, `x+ = A x + B u + K (y - ŷ)`, out = ŷ + `y_off`; without:
/// the free run `x+ = A x + B u`, out = `C x + D u` (+ `y_off`). Same operation order as the
/// straightforward loops (`dot` then the input terms), so the same bits.
#[inline(always)]
pub(crate) fn ss_run(
    n: usize,
    m: &SsModel<'_>,
    u: &[f64],
    y: Option<&[f64]>,
    um: f64,
    ym: f64,
    out: &mut [f64],
) {
    let (a, b, c) = (&m.a[..n * n], &m.b[..n], &m.c[..n]);
    let mut x = m.x0[..n].to_vec();
    let mut xn = vec![0.0; n];
    let (x, xn) = (&mut x[..n], &mut xn[..n]);
    for t in 0..out.len() {
        let uc = u[t] - um;
        let mut yhat = 0.0;
        for i in 0..n {
            yhat += c[i] * x[i];
        }
        yhat += m.d * uc;
        out[t] = yhat + ym;
        match y {
            Some(y) => {
                let k = &m.k[..n];
                let e = (y[t] - ym) - yhat;
                for (i, row) in a.chunks_exact(n).enumerate() {
                    let mut v = 0.0;
                    for j in 0..n {
                        v += row[j] * x[j];
                    }
                    xn[i] = v + b[i] * uc + k[i] * e;
                }
            }
            None => {
                for (i, row) in a.chunks_exact(n).enumerate() {
                    let mut v = 0.0;
                    for j in 0..n {
                        v += row[j] * x[j];
                    }
                    xn[i] = v + b[i] * uc;
                }
            }
        }
        x.copy_from_slice(xn);
    }
}

pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub(crate) fn matvec(a: &[Vec<f64>], x: &[f64]) -> Vec<f64> {
    a.iter().map(|row| dot(row, x)).collect()
}

/// The first `out.len()` samples of a polynomial model's free run (centered): the given
/// `y_init` (less its mean `ym`) while it lasts, then `A(q) ŷ = B(q) (u - um)` with the lags
/// before sample 0 at zero.
fn free_run_head(
    a: &[f64],
    b: &[f64],
    delay: usize,
    (u, um): (&[f64], f64),
    (y_init, ym): (&[f64], f64),
    out: &mut [f64],
) {
    let na = a.len() - 1;
    for k in 0..out.len() {
        if k < y_init.len() {
            out[k] = y_init[k] - ym;
            continue;
        }
        let mut v = 0.0;
        for i in 1..=na.min(k) {
            v -= a[i] * out[k - i];
        }
        for (j, &bj) in b.iter().enumerate() {
            let lag = delay + j + 1;
            if k >= lag {
                v += bj * (u[k - lag] - um);
            }
        }
        out[k] = v;
    }
}

impl LinearFit {
    /// [`LinearFit::simulate`] into `out` (length of `u`), computed in independent blocks:
    /// the tail of a polynomial model's free run (an all-pole recursion on
    /// `w_k = Σ b_j (u_{k-delay-j} - ū)`) is split into chunks run side by side from a zero
    /// state, with the responses to a unit initial state in the other lanes, and each chunk is
    /// then corrected by its true initial state. Same values as `simulate` up to round-off
    /// (the sums are associated differently; relative differences ~1e-14 for stable models,
    /// test `blocked_free_run_matches_simulate`), several times faster, since the serial
    /// recursion's latency is shared by the chunks. Models of order above 4, state-space
    /// models and short records take `simulate` itself.
    pub fn simulate_blocked_into(
        &self,
        u: &[f64],
        y_init: &[f64],
        out: &mut [f64],
    ) -> Result<(), IdError> {
        const LANES: usize = 16;
        let n_data = u.len();
        let Structure::Polynomial { a, b, delay, .. } = &self.structure else {
            return self.simulate_copy(u, y_init, out);
        };
        let na = a.len() - 1;
        let nb = b.len();
        let full = na.max(delay + nb);
        let head_end = full.max(y_init.len()).min(n_data);
        let chunks = LANES.saturating_sub(na);
        if na == 0 || na > 4 || out.len() != n_data || n_data < head_end + 16 * chunks {
            return self.simulate_copy(u, y_init, out);
        }
        check_finite("u", u)?;
        check_finite("y", y_init)?;
        let (um, ym) = (self.u_mean, self.y_mean);
        // head: as `simulate`
        free_run_head(a, b, *delay, (u, um), (y_init, ym), &mut out[..head_end]);
        // tail input w_k, into `out` (vectorisable: no recursion)
        let tail = n_data - head_end;
        {
            let t = &mut out[head_end..];
            t.iter_mut().for_each(|v| *v = 0.0);
            for (j, &bj) in b.iter().enumerate() {
                let lag = delay + j + 1;
                let src = &u[head_end - lag..n_data - lag];
                for (v, &x) in t.iter_mut().zip(src) {
                    *v += bj * (x - um);
                }
            }
        }
        let len = tail.div_ceil(chunks);
        let mut coef = [0.0; 4];
        coef[..na].copy_from_slice(&a[1..]);
        crate::la::with_buffer((len + 4) * LANES, |buf| {
            // lanes 0..na: response to out[-1-i] = 1 (zero input); lanes na..: chunk c from a
            // zero state, chunk 0 from the true head
            let (init, z) = buf.split_at_mut(4 * LANES);
            init.iter_mut().for_each(|v| *v = 0.0);
            // init row r (0..4) holds the state at lag 4 - r, i.e. row 3 = lag 1
            for i in 0..na {
                init[(3 - i) * LANES + i] = 1.0;
            }
            for i in 0..na {
                if head_end > i {
                    init[(3 - i) * LANES + na] = out[head_end - 1 - i];
                }
            }
            // orders as compile-time constants: straight-line lane loops
            macro_rules! run {
                ($na:literal) => {{
                    let mut s: [[f64; LANES]; $na] = [[0.0; LANES]; $na];
                    for (r, row) in s.iter_mut().enumerate() {
                        // s[$na - 1] is lag 1
                        let src = 4 - $na + r;
                        row.copy_from_slice(&init[src * LANES..(src + 1) * LANES]);
                    }
                    let c: [f64; $na] = match coef[..$na].try_into() {
                        Ok(c) => c,
                        Err(_) => return,
                    };
                    let w = &out[head_end..];
                    let full_rows = tail.saturating_sub((chunks - 1) * len).min(len);
                    for t in 0..len {
                        let mut x = [0.0; LANES];
                        if t < full_rows {
                            for ch in 0..chunks {
                                x[na + ch] = w[ch * len + t];
                            }
                        } else {
                            for ch in 0..chunks {
                                let k = ch * len + t;
                                if k < tail {
                                    x[na + ch] = w[k];
                                }
                            }
                        }
                        // the lag-1 term last: the only one on the recursion's critical path
                        let mut v = x;
                        for i in (0..$na).rev() {
                            let row = &s[$na - 1 - i];
                            for l in 0..LANES {
                                v[l] -= c[i] * row[l];
                            }
                        }
                        s.rotate_left(1);
                        s[$na - 1] = v;
                        z[t * LANES..(t + 1) * LANES].copy_from_slice(&v);
                    }
                }};
            }
            match na {
                1 => run!(1),
                2 => run!(2),
                3 => run!(3),
                _ => run!(4),
            }
            // write chunk 0, then correct each next chunk by the true state at its start
            let t_out = &mut out[head_end..];
            for c in 0..chunks {
                let start = c * len;
                if start >= tail {
                    break;
                }
                let end = (start + len).min(tail);
                let mut st = [0.0; 4];
                if c > 0 {
                    for i in 0..na {
                        st[i] = t_out[start - 1 - i];
                    }
                }
                for (t, o) in t_out[start..end].iter_mut().enumerate() {
                    let row = &z[t * LANES..(t + 1) * LANES];
                    let mut v = row[na + c];
                    for i in 0..na {
                        v += row[i] * st[i];
                    }
                    *o = v;
                }
            }
        });
        out.iter_mut().for_each(|v| *v += ym);
        check_finite("estimate", out)
    }

    pub(crate) fn simulate_copy(
        &self,
        u: &[f64],
        y_init: &[f64],
        out: &mut [f64],
    ) -> Result<(), IdError> {
        let v = self.simulate(u, y_init)?;
        if v.len() != out.len() {
            return Err(IdError::LengthMismatch {
                u: u.len(),
                y: out.len(),
            });
        }
        out.copy_from_slice(&v);
        Ok(())
    }

    /// Free-run simulation of the deterministic part from the input `u`.
    ///
    /// Polynomial models: `A(q) ŷ = B(q) u_{k-delay}`, where the first `y_init.len()` outputs
    /// are taken as given (measured PV at the start of the record) and lags before sample 0
    /// are the identification mean. State space: process form from `x0` (`y_init` is not
    /// used). The disturbance β̂ is not added (it is only known on the identification data;
    /// see [`LinearFit::disturbance`]).
    pub fn simulate(&self, u: &[f64], y_init: &[f64]) -> Result<Vec<f64>, IdError> {
        check_finite("u", u)?;
        check_finite("y", y_init)?;
        let (um, ym) = (self.u_mean, self.y_mean);
        let n_data = u.len();
        let mut out = vec![0.0; n_data];
        match &self.structure {
            Structure::Polynomial { a, b, delay, .. } => {
                let na = a.len() - 1;
                let nb = b.len();
                // from `full` on every lag exists: the branch-free tail (same sums, same order)
                let full = na.max(delay + nb);
                let head_end = full.max(y_init.len()).min(n_data);
                free_run_head(a, b, *delay, (u, um), (y_init, ym), &mut out[..head_end]);
                let tail = PolyTail {
                    a: &a[1..],
                    b,
                    delay: *delay,
                    um,
                };
                macro_rules! fixed {
                    ($(($na:literal, $nb:literal))*) => {
                        match (na, nb) {
                            $(($na, $nb) => tail.run::<$na, $nb>(u, &mut out, head_end),)*
                            _ => tail.run_dyn(u, &mut out, head_end),
                        }
                    };
                }
                fixed!((0, 1)(0, 2)(0, 3)(1, 1)(1, 2)(1, 3)(2, 1)(2, 2)(2, 3)(3, 1)(3, 2)(3, 3));
            }
            Structure::StateSpace { a, b, c, d, x0, .. } => {
                let a_flat: Vec<f64> = a.iter().flatten().copied().collect();
                let m = SsModel {
                    a: &a_flat,
                    b,
                    c,
                    d: *d,
                    k: &[],
                    x0,
                };
                dispatch_state_dim!(a.len(), |n| ss_run(n, &m, u, None, um, 0.0, &mut out));
            }
        }
        out.iter_mut().for_each(|v| *v += ym);
        check_finite("estimate", &out)?;
        Ok(out)
    }
}
