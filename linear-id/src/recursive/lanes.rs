//! Several recursive identifications with the same output side by side, one per SIMD lane
//! ([`Recursive::identify_predict_many`], used by grid searches: every node identifies the
//! same PV window from its own MV).
//!
//! The recursion of [`Recursive::run_with`] and the serial part of the one-step prediction
//! ([`LinearFit::polynomial_recursion`]) are chains of dependent floating-point operations: a
//! sample cannot start before the previous one ends, so one identification leaves most of the
//! core's arithmetic units idle. Here [`LANES`] inputs advance together, every scalar of the
//! recursion becomes a `[f64; LANES]` and every operation a loop over the lanes, which the
//! compiler turns into vector instructions. Each lane performs exactly the operations of the
//! single recursion, in the same order, so its results are the same bits (tests below and
//! `tests/recursive.rs`); what does not depend on the data (λ_θ, P_β and the bias gain K_β)
//! is computed once for all lanes.
//!
//! Lanes diverge independently: a lane whose estimate stops being finite gets the error the
//! single recursion returns at that sample, and its later (meaningless) values are dropped.

use super::{Recursive, RlsRun};
use crate::error::{check_data, check_finite};
use crate::{mean, IdError, Identified, LinearFit};

/// Inputs run side by side (four doubles: one AVX register, two SSE2 registers).
pub(crate) const LANES: usize = 4;

type Lanes = [f64; LANES];

/// `f(l)` for every lane.
#[inline(always)]
fn each(mut f: impl FnMut(usize) -> f64) -> Lanes {
    let mut out = [0.0; LANES];
    for (l, v) in out.iter_mut().enumerate() {
        *v = f(l);
    }
    out
}

/// One input checked and centered, ready for a lane.
struct Centered<'a> {
    index: usize,
    u: &'a [f64],
    u_mean: f64,
    uc: Vec<f64>,
}

impl Recursive {
    /// See [`crate::LinearIdentifier::identify_predict_many`]: the inputs that pass
    /// [`check_data`] run [`LANES`] at a time (the last group padded with copies of its
    /// first input, whose results are dropped).
    pub(super) fn identify_predict_many(
        &self,
        inputs: &[&[f64]],
        y: &[f64],
        split: usize,
        outs: &mut [Vec<f64>],
    ) -> Vec<Result<Identified, IdError>> {
        let split = split.min(y.len());
        let y_id = &y[..split];
        let mut results: Vec<Option<Result<Identified, IdError>>> =
            (0..inputs.len()).map(|_| None).collect();
        let mut ready = Vec::with_capacity(inputs.len());
        for (index, u) in inputs.iter().enumerate() {
            if u.len() != y.len() {
                results[index] = Some(Err(IdError::LengthMismatch {
                    u: u.len(),
                    y: y.len(),
                }));
                continue;
            }
            let u_id = &u[..split];
            if let Err(e) = check_data(u_id, y_id, self.min_samples()) {
                results[index] = Some(Err(e));
                continue;
            }
            let u_mean = mean(u_id);
            ready.push(Centered {
                index,
                u,
                u_mean,
                uc: u_id.iter().map(|v| v - u_mean).collect(),
            });
        }
        let y_mean = mean(y_id);
        let yc: Vec<f64> = y_id.iter().map(|v| v - y_mean).collect();
        for group in ready.chunks(LANES) {
            let lane = |l: usize| &group[l.min(group.len() - 1)];
            let ucs: [&[f64]; LANES] = std::array::from_fn(|l| lane(l).uc.as_slice());
            let runs = self.run_lanes(ucs, &yc);
            let mut fits: Vec<Result<LinearFit, IdError>> = runs
                .into_iter()
                .take(group.len())
                .zip(group)
                .map(|(run, c)| run.map(|run| self.fit_of(run, c.u_mean, y_mean)))
                .collect();
            // the predictions: A and B terms per input (vectorised over samples), then the
            // C(q) and bias recursion of the fits that need it in lanes
            let mut status: Vec<Result<(), IdError>> = Vec::with_capacity(group.len());
            let mut serial = Vec::new();
            for (g, (c, fit)) in group.iter().zip(&mut fits).enumerate() {
                let Ok(fit) = fit else {
                    status.push(Ok(()));
                    continue;
                };
                let out = &mut outs[c.index];
                out.resize(y.len(), 0.0);
                let checked = check_finite("u", c.u).and_then(|()| check_finite("y", y));
                if checked.is_ok() && fit.polynomial_terms(c.u, y, out) {
                    serial.push(g);
                }
                status.push(checked);
            }
            for part in serial.chunks(LANES) {
                let lanes: [usize; LANES] = std::array::from_fn(|l| part[l.min(part.len() - 1)]);
                let lane_fits: [&LinearFit; LANES] = std::array::from_fn(|l| {
                    fits[lanes[l]]
                        .as_ref()
                        .expect("only fits enter the recursion")
                });
                let mut buf: Vec<Lanes> = (0..y.len())
                    .map(|k| each(|l| outs[group[lanes[l]].index][k]))
                    .collect();
                recursion_lanes(lane_fits, y, &mut buf);
                for (l, &g) in part.iter().enumerate() {
                    for (v, b) in outs[group[g].index].iter_mut().zip(&buf) {
                        *v = b[l];
                    }
                }
            }
            for ((c, fit), checked) in group.iter().zip(fits).zip(status) {
                let out = &outs[c.index];
                let predicted = checked.and_then(|()| check_finite("estimate", out));
                results[c.index] =
                    Some(fit.and_then(|fit| {
                        fit.diagnose_from_prediction((c.u, y), split, out, predicted)
                    }));
            }
        }
        results
            .into_iter()
            .map(|r| r.expect("every input has a result"))
            .collect()
    }

    /// [`Recursive::run`] for [`LANES`] inputs and one output; dimensions above 8 run one
    /// input at a time.
    fn run_lanes(&self, uc: [&[f64]; LANES], yc: &[f64]) -> [Result<RlsRun, IdError>; LANES] {
        macro_rules! fixed {
            ($($d:literal)*) => {
                match self.dim() {
                    $($d => return self.run_lanes_fixed::<$d>(uc, yc),)*
                    _ => {}
                }
            };
        }
        fixed!(1 2 3 4 5 6 7 8);
        uc.map(|u| self.run(u, yc))
    }

    /// [`Recursive::run_with`] lane by lane: the same operations in the same order.
    fn run_lanes_fixed<const D: usize>(
        &self,
        uc: [&[f64]; LANES],
        yc: &[f64],
    ) -> [Result<RlsRun, IdError>; LANES] {
        let (na, nb, nc, delay) = (self.na, self.nb, self.nc, self.delay);
        let t = &self.tuning;
        let len = yc.len();
        let n0 = self.n0();
        let mut theta = [[0.0; LANES]; D];
        let mut p = [[[0.0; LANES]; D]; D];
        for (i, row) in p.iter_mut().enumerate() {
            row[i] = [t.p0; LANES];
        }
        let mut lam = t.lambda_theta0;
        let mut beta = [0.0; LANES];
        let mut pb = t.p_beta0;
        let mut eps = vec![[0.0; LANES]; len];
        let mut betas = vec![[0.0; LANES]; if self.bias { len } else { 0 }];
        let mut diverged: [Option<usize>; LANES] = [None; LANES];
        let mut phi = [[0.0; LANES]; D];
        for k in n0..len {
            for i in 0..na {
                phi[i] = [-yc[k - 1 - i]; LANES];
            }
            for j in 0..nb {
                phi[na + j] = each(|l| uc[l][k - 1 - delay - j]);
            }
            for i in 0..nc {
                phi[na + nb + i] = eps[k - 1 - i];
            }
            let z = each(|l| yc[k] - beta[l]);
            let mut pphi = [[0.0; LANES]; D];
            let mut quad = [0.0; LANES];
            for r in 0..D {
                let v = dot(&p[r], &phi);
                pphi[r] = v;
                for l in 0..LANES {
                    quad[l] += phi[r][l] * v[l];
                }
            }
            let den = each(|l| lam + quad[l]);
            let pred = dot(&phi, &theta);
            let err = each(|l| z[l] - pred[l]);
            let inv = each(|l| 1.0 / den[l]);
            for r in 0..D {
                for l in 0..LANES {
                    theta[r][l] += pphi[r][l] * inv[l] * err[l];
                }
            }
            let inv_lam = 1.0 / lam;
            let mut trace = [0.0; LANES];
            for r in 0..D {
                for c in r..D {
                    let v = each(|l| (p[r][c][l] - pphi[r][l] * pphi[c][l] * inv[l]) * inv_lam);
                    p[r][c] = v;
                    p[c][r] = v;
                }
                for l in 0..LANES {
                    trace[l] += p[r][r][l];
                }
            }
            if trace.iter().any(|&tr| tr > t.trace_max) {
                for l in 0..LANES {
                    if trace[l] > t.trace_max {
                        let s = t.trace_max / trace[l];
                        p.iter_mut().flatten().for_each(|v| v[l] *= s);
                    }
                }
            }
            lam = t.lambda_rate * lam + (1.0 - t.lambda_rate);
            let lti = dot(&phi, &theta);
            if self.bias {
                let r = each(|l| yc[k] - lti[l]);
                let kb = pb / (t.lambda_beta + pb);
                for l in 0..LANES {
                    beta[l] += kb * (r[l] - beta[l]);
                }
                pb = (1.0 - kb) * pb / t.lambda_beta;
                betas[k] = beta;
            }
            eps[k] = each(|l| yc[k] - lti[l] - beta[l]);
            for l in 0..LANES {
                if diverged[l].is_none() && !(eps[k][l].is_finite() && trace[l].is_finite()) {
                    diverged[l] = Some(k);
                }
            }
        }
        std::array::from_fn(|l| match diverged[l] {
            Some(k) => Err(IdError::NotConverged {
                identifier: self.name,
                detail: format!("recursive estimate diverged at sample {k}"),
            }),
            None => Ok(RlsRun {
                theta: theta.iter().map(|v| v[l]).collect(),
                betas: betas.iter().map(|v| v[l]).collect(),
            }),
        })
    }
}

/// `Σ_c a[c] b[c]` lane by lane, summed from the first term on as `Iterator::sum` does.
#[inline(always)]
fn dot<const D: usize>(a: &[Lanes; D], b: &[Lanes; D]) -> Lanes {
    let mut v = [-0.0; LANES];
    for c in 0..D {
        for l in 0..LANES {
            v[l] += a[c][l] * b[c][l];
        }
    }
    v
}

/// [`LinearFit::polynomial_recursion`] for [`LANES`] fits of one identifier (same orders and
/// bias tuning), `out[k][l]` holding lane `l`'s A and B terms on entry and its prediction on
/// return.
fn recursion_lanes(fits: [&LinearFit; LANES], y: &[f64], out: &mut [Lanes]) {
    let first = fits[0];
    let cs: [&[f64]; LANES] = std::array::from_fn(|l| match &fits[l].structure {
        crate::Structure::Polynomial { c, .. } => &c[1..],
        crate::Structure::StateSpace { .. } => unreachable!("a recursive fit is polynomial"),
    });
    let nc = cs[0].len();
    let ym = each(|l| fits[l].y_mean);
    let mut eps = vec![[0.0; LANES]; if nc > 0 { y.len() } else { 0 }];
    let mut beta = [0.0; LANES];
    let mut pb = first.bias.map_or(0.0, |bt| bt.p0);
    for k in first.first_sample()..y.len() {
        let mut v = out[k];
        for i in 0..nc {
            for l in 0..LANES {
                v[l] += cs[l][i] * eps[k - 1 - i][l];
            }
        }
        let yc = each(|l| y[k] - ym[l]);
        match first.bias {
            Some(bt) => {
                out[k] = each(|l| v[l] + beta[l] + ym[l]);
                let kb = pb / (bt.lambda + pb);
                for l in 0..LANES {
                    beta[l] += kb * (yc[l] - v[l] - beta[l]);
                }
                pb = (1.0 - kb) * pb / bt.lambda;
                if nc > 0 {
                    eps[k] = each(|l| yc[l] - v[l] - beta[l]);
                }
            }
            None => {
                out[k] = each(|l| v[l] + ym[l]);
                if nc > 0 {
                    eps[k] = each(|l| yc[l] - v[l]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use crate::test_data::identify_predict_many_matches;
    use crate::{Armax, Earmax, Earx};

    #[test]
    fn lanes_equal_one_at_a_time_bit_for_bit() {
        for n in [1, 3, 4, 6, 9] {
            identify_predict_many_matches(&Armax::params().check().unwrap(), n);
            identify_predict_many_matches(&Earx::params().check().unwrap(), n);
            identify_predict_many_matches(&Earmax::params().check().unwrap(), n);
            let other = Armax::params().n(3).m(2).p(3).delay(2).check().unwrap();
            identify_predict_many_matches(&other, n);
        }
    }
}
