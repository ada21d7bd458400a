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
//! single recursion, in the same order, so its results are the same bits (test below, and
//! `grid-search/tests/fast_path.rs` against the sample path). The lanes run in the record's
//! time frame, each from its own washout sample: until a lane's first row its state is held at
//! the initial one, so λ_θ and P_β, which do not depend on the data, are per lane too.
//!
//! Lanes diverge independently: a lane whose estimate stops being finite gets the error the
//! single recursion returns at that sample, and its later (meaningless) values are dropped.

use super::{Recursive, RlsRun};
use crate::error::{check_finite, check_shared, OutputChecks};
use crate::lanes::{each, Lanes, LANES};
use crate::{mean, IdError, Identified, LinearFit};

/// One input checked, ready for a lane: its record is `u[start..]`, `y[start..]`, its
/// identification window ends at the common `split`.
struct Ready<'a> {
    index: usize,
    start: usize,
    u: &'a [f64],
    u_mean: f64,
    y_mean: f64,
}

impl Recursive {
    /// See [`crate::LinearIdentifier::identify_predict_many`]: the inputs that pass the
    /// checks of `check_data`, sorted by start, run [`LANES`] at a time (the last group
    /// padded with copies of its last input, whose results are dropped).
    pub(super) fn identify_predict_many(
        &self,
        batch: crate::Batch<'_>,
    ) -> Vec<Result<Identified, IdError>> {
        let (inputs, y, outs) = (batch.inputs, batch.output.y(), batch.outs);
        let split = batch.split.min(y.len());
        let mut results: Vec<Option<Result<Identified, IdError>>> =
            (0..inputs.len()).map(|_| None).collect();
        let mut ready = Vec::with_capacity(inputs.len());
        // the output window's checks and mean, once per start (nodes share a few)
        let mut windows: Vec<(usize, OutputChecks, f64)> = Vec::new();
        for (index, &(start, u)) in inputs.iter().enumerate() {
            let start = match crate::input_start(start, u, y, split) {
                Ok(start) => start,
                Err(e) => {
                    results[index] = Some(Err(e));
                    continue;
                }
            };
            let (u_id, y_id) = (&u[start..split], &y[start..split]);
            let w = match windows.iter().position(|w| w.0 == start) {
                Some(w) => w,
                None => {
                    windows.push((start, OutputChecks::of(y_id), mean(y_id)));
                    windows.len() - 1
                }
            };
            if let Err(e) = check_shared(u_id, &windows[w].1, self.min_samples()) {
                results[index] = Some(Err(e));
                continue;
            }
            ready.push(Ready {
                index,
                start,
                u,
                u_mean: mean(u_id),
                y_mean: windows[w].2,
            });
        }
        // lanes that start together idle least
        ready.sort_by_key(|r| r.start);
        // one check of the common output (per input only to name the sample when it fails)
        let y_finite = crate::la::all_finite(y);
        for group in ready.chunks(LANES) {
            let lanes: [&Ready; LANES] = std::array::from_fn(|l| &group[l.min(group.len() - 1)]);
            let runs = self.run_lanes(lanes, y, split);
            let mut fits: Vec<Result<LinearFit, IdError>> = runs
                .into_iter()
                .zip(group)
                .map(|(run, r)| run.map(|run| self.fit_of(run, r.u_mean, r.y_mean)))
                .collect();
            // the predictions: A and B terms per input (vectorised over samples), then the
            // C(q) and bias recursion of the fits that need it in lanes
            let mut checked: Vec<Result<(), IdError>> = Vec::with_capacity(group.len());
            let mut serial = Vec::new();
            for (g, (r, fit)) in group.iter().zip(&mut fits).enumerate() {
                let out = &mut outs[r.index];
                out.resize(y.len() - r.start, 0.0);
                let (u, y) = (&r.u[r.start..], &y[r.start..]);
                let ok = check_finite("u", u).and_then(|()| {
                    if y_finite {
                        Ok(())
                    } else {
                        check_finite("y", y)
                    }
                });
                if let (Ok(()), Ok(fit)) = (&ok, fit) {
                    if fit.polynomial_terms(u, y, out) {
                        serial.push(g);
                    }
                }
                checked.push(ok);
            }
            for part in serial.chunks(LANES) {
                let members: [usize; LANES] = std::array::from_fn(|l| part[l.min(part.len() - 1)]);
                let lane_fits: [(&LinearFit, usize); LANES] = std::array::from_fn(|l| {
                    let fit = fits[members[l]]
                        .as_ref()
                        .expect("only fits enter the recursion");
                    (fit, group[members[l]].start)
                });
                // lane l's prediction in the record's time frame: sample t is its t - start
                let mut buf = crate::lanes::Scratch::zeroed(y.len());
                for (l, &g) in members.iter().enumerate() {
                    let r = &group[g];
                    for (b, &v) in buf[r.start..].iter_mut().zip(&outs[r.index]) {
                        b[l] = v;
                    }
                }
                recursion_lanes(lane_fits, y, &mut buf);
                let n0 = lane_fits[0].0.first_sample();
                for (l, &g) in part.iter().enumerate() {
                    let r = &group[g];
                    let tail = (r.start + n0).min(y.len());
                    for (v, b) in outs[r.index][tail - r.start..].iter_mut().zip(&buf[tail..]) {
                        *v = b[l];
                    }
                }
            }
            for ((r, fit), ok) in group.iter().zip(fits).zip(checked) {
                let out = &outs[r.index];
                let predicted = ok.and_then(|()| check_finite("estimate", out));
                let record = (&r.u[r.start..], &y[r.start..]);
                results[r.index] = Some(fit.and_then(|fit| {
                    fit.diagnose_from_prediction(record, split - r.start, out, predicted)
                }));
            }
        }
        results
            .into_iter()
            .map(|r| r.expect("every input has a result"))
            .collect()
    }

    /// [`Recursive::run`] for [`LANES`] inputs of one output, each on its own window
    /// `[start, split)`; dimensions above 8 run one input at a time.
    fn run_lanes(
        &self,
        lanes: [&Ready; LANES],
        y: &[f64],
        split: usize,
    ) -> [Result<RlsRun, IdError>; LANES] {
        macro_rules! fixed {
            ($($d:literal)*) => {
                match self.dim() {
                    $($d => return self.run_lanes_dispatch::<$d>(lanes, y, split),)*
                    _ => {}
                }
            };
        }
        fixed!(1 2 3 4 5 6 7 8);
        lanes.map(|r| {
            let uc: Vec<f64> = r.u[r.start..split].iter().map(|v| v - r.u_mean).collect();
            let yc: Vec<f64> = y[r.start..split].iter().map(|v| v - r.y_mean).collect();
            self.run(&uc, &yc)
        })
    }

    /// [`Recursive::run_lanes_fixed`] compiled for the best instruction set the processor has
    /// (pulp's runtime dispatch, through faer: with AVX2, four lanes per instruction instead
    /// of two). The IEEE operations are the same, so are the bits: the compiler fuses no
    /// multiply-add unless asked to.
    fn run_lanes_dispatch<const D: usize>(
        &self,
        lanes: [&Ready; LANES],
        y: &[f64],
        split: usize,
    ) -> [Result<RlsRun, IdError>; LANES] {
        struct Run<'a, const D: usize> {
            rls: &'a Recursive,
            lanes: [&'a Ready<'a>; LANES],
            y: &'a [f64],
            split: usize,
        }
        impl<const D: usize> faer::traits::pulp::WithSimd for Run<'_, D> {
            type Output = [Result<RlsRun, IdError>; LANES];
            #[inline(always)]
            fn with_simd<S: faer::traits::pulp::Simd>(self, _: S) -> Self::Output {
                self.rls
                    .run_lanes_fixed::<D>(self.lanes, self.y, self.split)
            }
        }
        faer::traits::pulp::Arch::new().dispatch(Run::<D> {
            rls: self,
            lanes,
            y,
            split,
        })
    }

    /// [`Recursive::run_with`] lane by lane: the same operations in the same order. The
    /// lanes run in the record's time frame, lane `l` from its own `start`: until a lane's
    /// first regression row, its state is held at the initial one (theta 0, P = p0 I, λ_θ,
    /// P_β and β at their initial values, residuals 0).
    #[inline(always)]
    fn run_lanes_fixed<const D: usize>(
        &self,
        lanes: [&Ready; LANES],
        y: &[f64],
        split: usize,
    ) -> [Result<RlsRun, IdError>; LANES] {
        let (na, nb, nc, delay) = (self.na, self.nb, self.nc, self.delay);
        let t = &self.tuning;
        let n0 = self.n0();
        let starts: [usize; LANES] = lanes.map(|r| r.start);
        let (um, ym) = (lanes.map(|r| r.u_mean), lanes.map(|r| r.y_mean));
        let u = lanes.map(|r| r.u);
        let first = starts.iter().min().copied().unwrap_or(0) + n0;
        let all_active = starts.iter().max().copied().unwrap_or(0) + n0;
        let mut theta = [[0.0; LANES]; D];
        let mut p = [[[0.0; LANES]; D]; D];
        for (i, row) in p.iter_mut().enumerate() {
            row[i] = [t.p0; LANES];
        }
        let mut lam = [t.lambda_theta0; LANES];
        let mut beta = [0.0; LANES];
        let mut pb = [t.p_beta0; LANES];
        let mut eps = crate::lanes::Scratch::zeroed(split);
        let mut betas = crate::lanes::Scratch::zeroed(if self.bias { split } else { 0 });
        let mut diverged: [Option<usize>; LANES] = [None; LANES];
        let mut phi = [[0.0; LANES]; D];
        for k in first..split {
            for i in 0..na {
                phi[i] = each(|l| -(y[k - 1 - i] - ym[l]));
            }
            for j in 0..nb {
                phi[na + j] = each(|l| u[l][k - 1 - delay - j] - um[l]);
            }
            for i in 0..nc {
                phi[na + nb + i] = eps[k - 1 - i];
            }
            let yc = each(|l| y[k] - ym[l]);
            let z = each(|l| yc[l] - beta[l]);
            let mut pphi = [[0.0; LANES]; D];
            let mut quad = [0.0; LANES];
            for r in 0..D {
                let v = dot(&p[r], &phi);
                pphi[r] = v;
                for l in 0..LANES {
                    quad[l] += phi[r][l] * v[l];
                }
            }
            let den = each(|l| lam[l] + quad[l]);
            let pred = dot(&phi, &theta);
            let err = each(|l| z[l] - pred[l]);
            let inv = each(|l| 1.0 / den[l]);
            for r in 0..D {
                for l in 0..LANES {
                    theta[r][l] += pphi[r][l] * inv[l] * err[l];
                }
            }
            let inv_lam = each(|l| 1.0 / lam[l]);
            let mut trace = [0.0; LANES];
            for r in 0..D {
                for c in r..D {
                    let v = each(|l| (p[r][c][l] - pphi[r][l] * pphi[c][l] * inv[l]) * inv_lam[l]);
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
            lam = each(|l| t.lambda_rate * lam[l] + (1.0 - t.lambda_rate));
            let lti = dot(&phi, &theta);
            if self.bias {
                let r = each(|l| yc[l] - lti[l]);
                let kb = each(|l| pb[l] / (t.lambda_beta + pb[l]));
                for l in 0..LANES {
                    beta[l] += kb[l] * (r[l] - beta[l]);
                }
                pb = each(|l| (1.0 - kb[l]) * pb[l] / t.lambda_beta);
                betas[k] = beta;
            }
            eps[k] = each(|l| yc[l] - lti[l] - beta[l]);
            if k < all_active {
                for l in 0..LANES {
                    if k < starts[l] + n0 {
                        theta.iter_mut().for_each(|v| v[l] = 0.0);
                        for (i, row) in p.iter_mut().enumerate() {
                            for (c, v) in row.iter_mut().enumerate() {
                                v[l] = if i == c { t.p0 } else { 0.0 };
                            }
                        }
                        (lam[l], beta[l], pb[l]) = (t.lambda_theta0, 0.0, t.p_beta0);
                        eps[k][l] = 0.0;
                        if self.bias {
                            betas[k][l] = 0.0;
                        }
                    }
                }
            }
            for l in 0..LANES {
                if diverged[l].is_none()
                    && k >= starts[l] + n0
                    && !(eps[k][l].is_finite() && trace[l].is_finite())
                {
                    diverged[l] = Some(k - starts[l]);
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
                betas: betas[starts[l].min(betas.len())..]
                    .iter()
                    .map(|v| v[l])
                    .collect(),
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

/// [`LinearFit::polynomial_recursion`] for [`LANES`] fits `(fit, start)` of one identifier
/// (same orders and bias tuning), in the record's time frame: `out[t][l]` holds lane `l`'s
/// A and B terms at its sample `t - start` on entry and its prediction from its first
/// sample with measured lags on. Until then a lane's state is held at the initial one.
fn recursion_lanes(fits: [(&LinearFit, usize); LANES], y: &[f64], out: &mut [Lanes]) {
    let first = fits[0].0;
    let cs: [&[f64]; LANES] = fits.map(|(fit, _)| match &fit.structure {
        crate::Structure::Polynomial { c, .. } => &c[1..],
        crate::Structure::StateSpace { .. } => unreachable!("a recursive fit is polynomial"),
    });
    let starts = fits.map(|(_, start)| start);
    let nc = cs[0].len();
    let n0 = first.first_sample();
    let ym = fits.map(|(fit, _)| fit.y_mean);
    let mut eps = crate::lanes::Scratch::zeroed(if nc > 0 { y.len() } else { 0 });
    let mut beta = [0.0; LANES];
    let p0 = first.bias.map_or(0.0, |bt| bt.p0);
    let mut pb = [p0; LANES];
    let from = starts.iter().min().copied().unwrap_or(0) + n0;
    let all_active = starts.iter().max().copied().unwrap_or(0) + n0;
    for k in from..y.len() {
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
                let kb = each(|l| pb[l] / (bt.lambda + pb[l]));
                for l in 0..LANES {
                    beta[l] += kb[l] * (yc[l] - v[l] - beta[l]);
                }
                pb = each(|l| (1.0 - kb[l]) * pb[l] / bt.lambda);
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
        if k < all_active {
            for l in 0..LANES {
                if k < starts[l] + n0 {
                    (beta[l], pb[l]) = (0.0, p0);
                    if nc > 0 {
                        eps[k][l] = 0.0;
                    }
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
