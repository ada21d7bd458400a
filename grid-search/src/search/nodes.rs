//! Evaluating grid nodes: the valve run, the identification and the fits of one node or a
//! batch of nodes sharing the output record, by the fast path or sample by sample.

use super::*;

pub(crate) struct Ctx<'a, I: ?Sized> {
    pub(crate) entry: &'a ModelEntry,
    pub(crate) identifier: &'a I,
    pub(crate) problem: Problem<'a>,
    pub(crate) init: Initialization,
    pub(crate) split_index: usize,
    pub(crate) path: NodePath,
    /// The fast path runs the free-run simulation at every node.
    pub(crate) simulate: bool,
    /// The fast path computes F_MV at every node (when MV is measured); otherwise only the
    /// refitted best node gets it ([`NodeFits`]).
    pub(crate) node_mv: bool,
    /// OP indexed for event-driven valve runs (fast path).
    pub(crate) index: Option<OpIndex>,
    /// PV's prefix sums for ARX from normal equations (fast path, ARX only).
    pub(crate) arx_sums: Option<linear_id::ArxOutputSums>,
    /// PV as the identifier prepared it for its batches ([`LinearIdentifier::prepare`]),
    /// once, when the first batch asks.
    pub(crate) output: std::sync::OnceLock<linear_id::PreparedOutput>,
    /// Sum of squares of PV about its mean over the validation window.
    pub(crate) val_ss: f64,
    /// Nodes whose ARX came from sums / fell back to the QR (fast path).
    pub(crate) gram_count: [AtomicUsize; 2],
}

/// Everything computed at one node; the big vectors only kept for the final refit.
pub(crate) struct Evaluated {
    pub(crate) linear: LinearFit,
    pub(crate) mv: Vec<f64>,
    pub(crate) pred: Vec<f64>,
    pub(crate) sim: Vec<f64>,
}

/// Per-thread buffers, reused from node to node.
#[derive(Default)]
pub(crate) struct Scratch {
    pub(crate) valve: ValveScratch,
    pub(crate) pred: Vec<f64>,
    pub(crate) sim: Vec<f64>,
}

/// Where [`Ctx::node_fits`] takes the one-step prediction from.
pub(crate) enum Predicted<'a> {
    /// Already run over `mv[k0..]` (the identifier's batch), with whether it came out.
    Given(&'a [f64], Result<(), linear_id::IdError>),
    /// Computed there; `sums_fit`: the model came from ARX sums, whose `FitInfo` already
    /// holds the identification rows' one-step fit.
    Here { sums_fit: bool },
}

/// Per-thread buffers of [`Ctx::evaluate_batch`]: one MV and one prediction per node.
#[derive(Default)]
pub(crate) struct BatchScratch {
    pub(crate) node: Scratch,
    pub(crate) mvs: Vec<Vec<f64>>,
    pub(crate) outs: Vec<Vec<f64>>,
}

/// Nodes per batch of [`Ctx::evaluate_batch`]: a batch is the unit of parallel work, and
/// the recursive identifiers' lanes are formed within it (sorted by washout sample). On the
/// paper loop's earmax grid 16 and 64 took the same time (1.09-1.14 s of CPU for 20
/// searches, `perf stat` on `examples/profile_exhaustive`); 16 shares small grids better.
pub(crate) const BATCH: usize = 16;

impl<I: LinearIdentifier + ?Sized> Ctx<'_, I> {
    /// Evaluate one node; with `keep`, also return the model and the series.
    pub(crate) fn evaluate(
        &self,
        params: &[f64],
        scratch: &mut Scratch,
        keep: bool,
    ) -> Result<(Fits, Option<Evaluated>), Skip> {
        let model = (self.entry.build)(params)?;
        let run = run_valve_with(
            model.as_ref(),
            self.problem.op,
            &self.init,
            &mut scratch.valve,
        )?;
        let mv = &scratch.valve.mv;
        let (op, pv) = (self.problem.op, self.problem.pv);
        let n = op.len();
        let k0 = run.valid_from;
        let ni = self.split_index;
        self.identifiable(mv, k0)?;
        let mv_id = &mv[k0..ni];
        let linear = self.identifier.identify(mv_id, &pv[k0..ni])?;
        linear.check_stable(true)?;
        scratch.pred.resize(n - k0, 0.0);
        linear.predict_one_step_into(&mv[k0..], &pv[k0..], &mut scratch.pred)?;
        let pred = &scratch.pred;
        let init_len = linear.first_sample().min(n - k0);
        let sim = linear
            .simulate(&mv[k0..], &pv[k0..k0 + init_len])
            .unwrap_or_else(|_| vec![f64::NAN; n - k0]);
        let split = ni - k0;
        let first = linear.first_sample().min(split);
        let score = |est: &[f64], range: std::ops::Range<usize>| {
            let f = fit_pv(&pv[k0 + range.start..k0 + range.end], &est[range]);
            if f.is_finite() {
                f
            } else {
                f64::NEG_INFINITY
            }
        };
        let fits = self.fits(
            (score(pred, first..split), score(pred, split..n - k0)),
            (score(&sim, first..split), score(&sim, split..n - k0)),
            mv,
            run,
            true,
        )?;
        let full = keep.then(|| Evaluated {
            linear,
            mv: mv.clone(),
            pred: pred.clone(),
            sim,
        });
        Ok((fits, full))
    }

    /// The skip reasons both node paths check before identifying, in this order: too few
    /// identification samples after the valve's initial state washed out (`k0`), or an
    /// estimated MV that hardly moves in the identification window. Returns the statistics
    /// of MV over that window (`None` if it holds a NaN), which the fast path hands on to the
    /// identification.
    pub(crate) fn identifiable(&self, mv: &[f64], k0: usize) -> Result<Option<WindowStats>, Skip> {
        let ni = self.split_index;
        let needed = self.identifier.min_samples().max(10);
        if ni <= k0 || ni - k0 < needed {
            return Err(Skip::InitialState { valid_from: k0 });
        }
        let window = &mv[k0..ni];
        // the count first: a valve that hardly moves (a third of the nodes of a fine grid)
        // is skipped without the statistics' pass, and one that moves shows three values in
        // its first samples
        if !three_distinct(window) {
            return Err(Skip::ValveHardlyMoves);
        }
        Ok(WindowStats::of(window))
    }
}

impl<I: LinearIdentifier + ?Sized> Ctx<'_, I> {
    /// [`Ctx::evaluate`] without the series, on the fast path (see [`NodePath::Fast`]): same
    /// checks in the same order, so the same skip reasons.
    pub(crate) fn evaluate_fast(
        &self,
        params: &[f64],
        scratch: &mut Scratch,
    ) -> Result<Fits, Skip> {
        let Some(index) = &self.index else {
            return self.evaluate(params, scratch, false).map(|(f, _)| f);
        };
        let (run, mv_stats) = self.valve_at(params, index, &mut scratch.valve)?;
        let mv = &scratch.valve.mv;
        let pv = self.problem.pv;
        let k0 = run.valid_from;
        let ni = self.split_index;
        let mv_id = &mv[k0..ni];
        let from_sums = self
            .arx_sums
            .as_ref()
            .zip(mv_stats)
            .and_then(|(s, stats)| s.identify_window_with(mv, k0, ni, &stats));
        if self.arx_sums.is_some() {
            self.gram_count[usize::from(from_sums.is_none())].fetch_add(1, Ordering::Relaxed);
        }
        let sums_fit = from_sums.is_some();
        let linear = match from_sums {
            Some(fit) => fit,
            None => self.identifier.identify(mv_id, &pv[k0..ni])?,
        };
        linear.check_stable(true)?;
        let computed = Predicted::Here { sums_fit };
        self.node_fits(
            &linear,
            mv,
            run,
            computed,
            &mut scratch.pred,
            &mut scratch.sim,
        )
    }

    /// The valve at node `params` (MV left in `valve.mv`) and the checks before identifying
    /// (with MV's statistics over the identification window, see [`Ctx::identifiable`]).
    pub(crate) fn valve_at(
        &self,
        params: &[f64],
        index: &OpIndex,
        valve: &mut ValveScratch,
    ) -> Result<(RunInfo, Option<WindowStats>), Skip> {
        let model = (self.entry.build)(params)?;
        let run = run_valve_indexed(model.as_ref(), index, &self.init, valve)?;
        let stats = self.identifiable(&valve.mv, run.valid_from)?;
        Ok((run, stats))
    }

    /// [`Ctx::evaluate_fast`] for several nodes at once, for identifiers other than ARX: the
    /// nodes' MV go to [`LinearIdentifier::identify_predict_many`] together, each from the
    /// sample its valve's initial state washed out (the recursive identifiers run them in SIMD
    /// lanes). Node by node the same results as
    /// [`Ctx::evaluate_fast`] (the identifier's batch is bit for bit its one-at-a-time path).
    pub(crate) fn evaluate_batch(
        &self,
        nodes: &[Vec<f64>],
        scratch: &mut BatchScratch,
    ) -> Vec<Result<Fits, Skip>> {
        let Some(index) = &self.index else {
            return nodes
                .iter()
                .map(|p| self.evaluate_fast(p, &mut scratch.node))
                .collect();
        };
        let pv = self.problem.pv;
        let ni = self.split_index;
        let mut results: Vec<Option<Result<Fits, Skip>>> = (0..nodes.len()).map(|_| None).collect();
        scratch.mvs.resize_with(nodes.len(), Vec::new);
        let mut pending = Vec::with_capacity(nodes.len());
        for (i, params) in nodes.iter().enumerate() {
            match self.valve_at(params, index, &mut scratch.node.valve) {
                Ok((run, _)) => {
                    scratch.mvs[i].clone_from(&scratch.node.valve.mv);
                    pending.push((i, run));
                }
                Err(e) => results[i] = Some(Err(e)),
            }
        }
        let inputs: Vec<(usize, &[f64])> = pending
            .iter()
            .map(|&(i, run)| (run.valid_from, scratch.mvs[i].as_slice()))
            .collect();
        scratch.outs.resize_with(pending.len(), Vec::new);
        let outs = &mut scratch.outs[..pending.len()];
        // what PV alone gives (PV was checked finite): an identifier that cannot prepare it
        // gets the plain record, the same results without the saved work
        let output = self.output.get_or_init(|| {
            self.identifier
                .prepare(pv)
                .unwrap_or_else(|_| linear_id::PreparedOutput::plain(pv))
        });
        let identified = self.identifier.identify_predict_many(linear_id::Batch {
            inputs: &inputs,
            output,
            split: ni,
            outs,
        });
        for ((&(i, run), id), out) in pending.iter().zip(identified).zip(outs.iter()) {
            let fits = id.map_err(Skip::from).and_then(|id| {
                id.fit.check_stable(true)?;
                self.node_fits(
                    &id.fit,
                    &scratch.mvs[i],
                    run,
                    Predicted::Given(out, id.prediction),
                    &mut scratch.node.pred,
                    &mut scratch.node.sim,
                )
            });
            results[i] = Some(fits);
        }
        results
            .into_iter()
            .map(|r| r.expect("every node has a result"))
            .collect()
    }

    /// The fits of an identified node (its model `linear` checked stable): the one-step
    /// prediction's from `predicted`; the free run's when every node gets it.
    pub(crate) fn node_fits(
        &self,
        linear: &LinearFit,
        mv: &[f64],
        run: RunInfo,
        predicted: Predicted<'_>,
        pred_buf: &mut Vec<f64>,
        sim_buf: &mut Vec<f64>,
    ) -> Result<Fits, Skip> {
        let (op, pv) = (self.problem.op, self.problem.pv);
        let n = op.len();
        let k0 = run.valid_from;
        let ni = self.split_index;
        let split = ni - k0;
        let first = linear.first_sample().min(split);
        let fits_of = |est: &[f64]| {
            (
                fit_from(
                    sse(&est[first..split], &pv[k0 + first..ni]),
                    ss_about_mean(&pv[k0 + first..ni]),
                ),
                fit_from(sse(&est[split..], &pv[ni..]), self.val_ss),
            )
        };
        let pred_fits = match predicted {
            Predicted::Given(pred, status) => {
                status?;
                fits_of(pred)
            }
            Predicted::Here { sums_fit } => {
                // the identification rows' fit: ARX from sums computed it from the data (its
                // `FitInfo` is the one-step prediction's over these very rows), otherwise a
                // pass
                let id_fit = |buf: &mut Vec<f64>| {
                    if sums_fit {
                        Some(linear.info().fit_pv)
                    } else {
                        let lo = k0 + first;
                        polynomial_prediction_sse(linear, mv, pv, lo, ni, buf)
                            .map(|e| fit_from(e, ss_about_mean(&pv[lo..ni])))
                    }
                };
                match polynomial_prediction_sse(linear, mv, pv, ni, n, pred_buf)
                    .and_then(|e| Some((id_fit(pred_buf)?, fit_from(e, self.val_ss))))
                {
                    Some(f) => f,
                    None => {
                        // anything unusual (a model with C(q) or a bias, a non-finite
                        // prediction): the sample path's prediction, its errors included
                        pred_buf.resize(n - k0, 0.0);
                        linear.predict_one_step_into(&mv[k0..], &pv[k0..], pred_buf)?;
                        fits_of(pred_buf)
                    }
                }
            }
        };
        let sim_fits = if self.simulate {
            let init_len = linear.first_sample().min(n - k0);
            sim_buf.resize(n - k0, 0.0);
            let sim_ok = linear
                .simulate_blocked_into(&mv[k0..], &pv[k0..k0 + init_len], sim_buf)
                .is_ok();
            if sim_ok {
                fits_of(sim_buf)
            } else {
                (f64::NEG_INFINITY, f64::NEG_INFINITY)
            }
        } else {
            (f64::NAN, f64::NAN)
        };
        self.fits(pred_fits, sim_fits, mv, run, self.node_mv)
    }

    /// A node's [`Fits`] from the (identification, validation) F_PV of its one-step prediction
    /// and of its free run, with F_MV when MV is measured and `with_mv`;
    /// [`Skip::NonFinitePrediction`] when the prediction's validation F_PV is not finite.
    fn fits(
        &self,
        (pred_id, pred_val): (f64, f64),
        (sim_id, sim_val): (f64, f64),
        mv: &[f64],
        run: RunInfo,
        with_mv: bool,
    ) -> Result<Fits, Skip> {
        if !pred_val.is_finite() {
            return Err(Skip::NonFinitePrediction);
        }
        let k0 = run.valid_from;
        Ok(Fits {
            pred_id,
            pred_val,
            sim_id,
            sim_val,
            mv: self
                .problem
                .mv
                .filter(|_| with_mv)
                .map(|m| linear_id::fit_mv(&m[k0..], &mv[k0..])),
            valid_from: k0,
            init_fell_back: run.fell_back,
        })
    }
}

/// The one-step prediction's sum of squared errors over `[lo, hi)` of a polynomial model
/// without C(q) or bias, in one vectorised pass: each prediction is `predict_one_step`'s tail
/// formula term by term (the same bits), only the sum of squares is lane-wise. `None` for
/// other models, an empty range or a non-finite result.
pub(crate) fn polynomial_prediction_sse(
    linear: &LinearFit,
    u: &[f64],
    y: &[f64],
    lo: usize,
    hi: usize,
    buf: &mut Vec<f64>,
) -> Option<f64> {
    const L: usize = 8;
    let linear_id::Structure::Polynomial { a, b, c, delay } = linear.structure() else {
        return None;
    };
    if c.len() != 1 || linear.bias_tracking().is_some() || lo >= hi || hi > y.len() {
        return None;
    }
    let (um, ym) = linear.means();
    let kconst = ym * a[1..].iter().sum::<f64>() - um * b.iter().sum::<f64>();
    let one_step = OneStep {
        a: &a[1..],
        b,
        delay: *delay,
        kconst,
        ym,
        u,
        y,
    };
    // compiled for AVX2 where the processor has it: the same operations, so the same bits
    /// [`fixed_order_sse`] as a kernel of [`linear_id::vectorized`].
    struct Sse<'a>(OneStep<'a>, usize, usize);
    impl linear_id::Kernel for Sse<'_> {
        type Output = Option<f64>;
        #[inline(always)]
        fn run(self) -> Option<f64> {
            fixed_order_sse(self.0, self.1, self.2)
        }
    }
    let sse = match linear_id::vectorized(Sse(one_step, lo, hi)) {
        Some(sse) => sse,
        None => {
            // predictions over [lo, hi) coefficient by coefficient (vectorised), in `buf`
            buf.clear();
            buf.resize(hi - lo, kconst);
            for (i, &ai) in a.iter().enumerate().skip(1) {
                for (v, yi) in buf.iter_mut().zip(&y[lo - i..hi - i]) {
                    *v -= ai * yi;
                }
            }
            for (j, &bj) in b.iter().enumerate() {
                let lag = delay + j + 1;
                for (v, uj) in buf.iter_mut().zip(&u[lo - lag..hi - lag]) {
                    *v += bj * uj;
                }
            }
            let mut acc = [0.0; L];
            let (pc, mc) = (buf.chunks_exact(L), y[lo..hi].chunks_exact(L));
            let (pr, mr) = (pc.remainder(), mc.remainder());
            for (pp, mm) in pc.zip(mc) {
                for l in 0..L {
                    let e = (pp[l] + ym) - mm[l];
                    acc[l] += e * e;
                }
            }
            let mut s = lanes8(acc);
            for (pp, mm) in pr.iter().zip(mr) {
                let e = (pp + ym) - mm;
                s += e * e;
            }
            s
        }
    };
    sse.is_finite().then_some(sse)
}

/// The one-step prediction of a polynomial model without C(q) or bias on a record `(u, y)`:
/// `kconst - Σ a_i y(k - i) + Σ b_j u(k - delay - j) + ym`, summed in `predict_one_step`'s
/// order (`kconst`, then the A terms, then the B terms, then `ym`).
#[derive(Clone, Copy)]
pub(crate) struct OneStep<'a> {
    /// `a_1..a_n` (without the leading 1).
    pub a: &'a [f64],
    /// `b_1..b_m`.
    pub b: &'a [f64],
    pub delay: usize,
    pub kconst: f64,
    pub ym: f64,
    pub u: &'a [f64],
    pub y: &'a [f64],
}

/// The squared one-step residuals summed over `[lo, hi)`, for orders up to (3, 3) as
/// compile-time constants: one fused pass.
#[inline(always)]
pub(crate) fn fixed_order_sse(one_step: OneStep<'_>, lo: usize, hi: usize) -> Option<f64> {
    // inlined, as the ARX(2, 2) pass below, into the caller's dispatched code
    #[inline(always)]
    fn run<const NA: usize, const NB: usize>(p: OneStep<'_>, lo: usize, hi: usize) -> Option<f64> {
        const L: usize = 8;
        let (delay, kconst, ym, u, y) = (p.delay, p.kconst, p.ym, p.u, p.y);
        let a: [f64; NA] = p.a.try_into().ok()?;
        let b: [f64; NB] = p.b.try_into().ok()?;
        if lo < NA.max(delay + NB) || hi > y.len() || lo >= hi {
            return if lo >= hi { Some(0.0) } else { None };
        }
        let pred = |k: usize| {
            let mut v = kconst;
            for i in 0..NA {
                v -= a[i] * y[k - 1 - i];
            }
            for j in 0..NB {
                v += b[j] * u[k - delay - 1 - j];
            }
            v + ym
        };
        let mut acc = [0.0; L];
        let mut k = lo;
        while k + L <= hi {
            for l in 0..L {
                let e = pred(k + l) - y[k + l];
                acc[l] += e * e;
            }
            k += L;
        }
        let mut s =
            ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]));
        while k < hi {
            let e = pred(k) - y[k];
            s += e * e;
            k += 1;
        }
        Some(s)
    }
    // the paper's ARX(2, 2): the five lagged slices through `linear_id`'s explicit four-wide
    // pass, the same per-sample operations and lanes as `run` (the compiler vectorised the
    // zip of the slices written here on SSE2's two lanes even in AVX2's dispatched code)
    #[inline(always)]
    fn sse22(p: OneStep<'_>, [a1, a2, b1, b2]: [f64; 4], lo: usize, hi: usize) -> Option<f64> {
        let OneStep {
            delay,
            kconst,
            ym,
            u,
            y,
            ..
        } = p;
        let n = y.len();
        {
            if lo < 2.max(delay + 2) || hi > n || lo > hi {
                return None;
            }
            let (y0, y1, y2) = (&y[lo..hi], &y[lo - 1..hi - 1], &y[lo - 2..hi - 2]);
            let (u1, u2) = (
                &u[lo - delay - 1..hi - delay - 1],
                &u[lo - delay - 2..hi - delay - 2],
            );
            // `run::<2, 2>`'s per-sample operations and lanes, on AVX2's four-wide registers
            let s =
                linear_id::arx22_one_step_sse([a1, a2, b1, b2], kconst, ym, [y0, y1, y2], [u1, u2]);
            Some(s)
        }
    }
    let (a, b) = (one_step.a, one_step.b);
    if let (&[a1, a2], &[b1, b2]) = (a, b) {
        return sse22(one_step, [a1, a2, b1, b2], lo, hi);
    }
    macro_rules! fixed {
        ($(($na:literal, $nb:literal))*) => {
            match (a.len(), b.len()) {
                $(($na, $nb) => run::<$na, $nb>(one_step, lo, hi),)*
                _ => None,
            }
        };
    }
    fixed!((1, 1)(1, 2)(1, 3)(2, 1)(2, 2)(2, 3)(3, 1)(3, 2)(3, 3))
}

pub(crate) fn lanes8(x: [f64; 8]) -> f64 {
    ((x[0] + x[4]) + (x[2] + x[6])) + ((x[1] + x[5]) + (x[3] + x[7]))
}

/// `Σ (x - mean(x))²`, lane-wise.
pub(crate) fn ss_about_mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mut acc = [0.0; 8];
    let ch = x.chunks_exact(8);
    let r = ch.remainder();
    for c in ch {
        for l in 0..8 {
            acc[l] += c[l];
        }
    }
    let mean = (lanes8(acc) + r.iter().sum::<f64>()) / x.len() as f64;
    let mut acc = [0.0; 8];
    for c in x.chunks_exact(8) {
        for l in 0..8 {
            acc[l] += (c[l] - mean) * (c[l] - mean);
        }
    }
    lanes8(acc) + r.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>()
}

/// `Σ (est - measured)²`, lane-wise.
pub(crate) fn sse(est: &[f64], measured: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let (ec, mc) = (est.chunks_exact(8), measured.chunks_exact(8));
    let (er, mr) = (ec.remainder(), mc.remainder());
    for (e, m) in ec.zip(mc) {
        for l in 0..8 {
            let d = e[l] - m[l];
            acc[l] += d * d;
        }
    }
    lanes8(acc)
        + er.iter()
            .zip(mr)
            .map(|(e, m)| (e - m) * (e - m))
            .sum::<f64>()
}

/// F_PV from its sums, `-inf` where `fit_pv` gives it.
pub(crate) fn fit_from(num: f64, den: f64) -> f64 {
    if !num.is_finite() || den.is_nan() || den <= 0.0 {
        f64::NEG_INFINITY
    } else {
        100.0 * (1.0 - num / den)
    }
}

/// `distinct_at_least(x, 3) >= 3` (NaN, which equals nothing, included), without the
/// statistics: the first sample `a`, the first later one `b` unlike it, then any later one
/// unlike both (`distinct_at_least`'s test against the values seen), eight samples at a
/// time without a branch inside, on AVX2 where the processor has it. A valve stuck over the
/// window costs one pass of comparisons; a moving one stops within its first samples.
pub(crate) fn three_distinct(x: &[f64]) -> bool {
    struct Three<'a>(&'a [f64]);
    impl linear_id::Kernel for Three<'_> {
        type Output = bool;
        #[inline(always)]
        fn run(self) -> bool {
            three_distinct_lanes(self.0)
        }
    }
    linear_id::vectorized(Three(x))
}

#[inline(always)]
fn three_distinct_lanes(x: &[f64]) -> bool {
    const L: usize = 8;
    let Some(&a) = x.first() else {
        return false;
    };
    let mut i = 1;
    while i + L <= x.len() && x[i..i + L].iter().fold(true, |all, &v| all & (v == a)) {
        i += L;
    }
    let Some(p) = x[i..].iter().position(|&v| v != a) else {
        return false;
    };
    let b = x[i + p];
    let third = |c: &[f64]| c.iter().fold(false, |any, &v| any | ((v != a) & (v != b)));
    let chunks = x[i + p + 1..].chunks_exact(L);
    let rest = chunks.remainder();
    chunks.into_iter().any(third) || third(rest)
}

/// Number of distinct values, counting up to `cap` (the reference of [`three_distinct`]).
#[cfg(test)]
pub(crate) fn distinct_at_least(x: &[f64], cap: usize) -> usize {
    let mut seen: Vec<f64> = Vec::with_capacity(cap);
    let mut i = 0;
    while i < x.len() {
        // skip, 8 at a time, the samples equal to a value already seen (a stuck valve's MV is
        // constant over long stretches)
        while i + 8 <= x.len() && x[i..i + 8].iter().all(|v| seen.contains(v)) {
            i += 8;
        }
        let Some(&v) = x.get(i) else {
            break;
        };
        if !seen.contains(&v) {
            seen.push(v);
            if seen.len() >= cap {
                break;
            }
        }
        i += 1;
    }
    seen.len()
}

pub(crate) fn check_signal(signal: &'static str, x: &[f64]) -> Result<(), SearchError> {
    if let Some(index) = x.iter().position(|v| !v.is_finite()) {
        return Err(SearchError::NonFinite {
            signal,
            index,
            value: x[index],
        });
    }
    Ok(())
}
