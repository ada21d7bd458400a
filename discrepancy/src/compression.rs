//! `compression`: PV stored by a historian's compression and read back as straight lines
//! between the kept points.
//!
//! The interpolated stretches bias the one-step prediction every likelihood-ratio test of the
//! diagnosis compares: on a straight stretch `PV(k) = 2 PV(k-1) - PV(k-2)` exactly, so any
//! model that leans on its own past PV predicts it whatever the valve does, and the kinks at
//! the kept points read as a dead time. On a simulated loop (paper plant, Kano S = 2.3,
//! J = 0.8, swinging door 0.6) the plain diagnosis named `time-delay`; the one-step fits with
//! and without stiction differed by 0.01 points, one step from naming `no-stiction`.
//!
//! So this cause acts through [`Cause::reframe`]: detected from the data
//! ([`datasets::compression`], the reader's `compressed` note), it is named first, no other
//! cause is tested (their tests assume residuals the interpolation has not shaped), and the
//! baseline is refitted with [`linear_id::Larx`], ARX at a lag of `r` samples (PV from PV
//! `r` and `2r` samples back and from MV averaged over the blocks of `r` samples before
//! them), `r` the archive's median distance between kept points (the median straight
//! segment, less one), at most [`MAX_LAG`]. Three consecutive lags then mostly lie on
//! different segments, and what the model must explain is the change from one kept point to
//! the next, which the interpolation did not write.
//!
//! Measured on the 24 compressed loops of the hidden-effect suite (`Effect::Compression`,
//! seeds 1006-1236 step 10; the paper's or the slow plant, Kano S 3-10 %, swinging door
//! 0.3-0.8): S within max(0.5, 10 %) of the truth in 17/24 with LARX against 13/24 with the
//! paper's ARX, which put S at 1.5-2.6 for true values of 6.5-9.6 in five loops. On the 24
//! loops of `tests/compression.rs` (S 2-8 %): 14/24 against 12/24, and S under 60 % of the
//! truth in none of them against 8 of 24 (the ARX's smallest ratio 0.21). Tried and not used,
//! on the suite's 24 loops with an exhaustive grid at 0.5 (where this lag gave 20/24): the lag
//! at half the median segment (8/24) or at 1.5 or 2 times it (12/24, 5/24); MV as 2r separate lags instead of two block
//! means (5/24: the freer input part absorbs the valve's timing); averaging PV over the
//! blocks as well as MV (1/24: an average is another interpolation); earlier, ranking the
//! paper's ARX by free-run simulation and an output-error model fitted at the kept points
//! only (2/6 each on this file's first six loops of `tests/compression.rs`). A finer grid
//! (coarse step span/120 instead of span/40) reached 19/24 at two to four times the time; the
//! default grid is kept.

use grid_search::{Problem, SearchOptions};

/// Largest lag of the refit: the model's polynomials have `2r + 1` coefficients, whose roots
/// every grid node computes. Three of the suite's 24 loops had longer median segments (30,
/// 31, 47 samples); at 24 two of them kept their S within tolerance.
pub const MAX_LAG: usize = 24;

use crate::{Baseline, Cause, CauseEntry, Context, DiagnoseError, Evidence, Extension, Reframe};

/// PV reconstructed by a historian from compressed storage (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct Compression;

impl Compression {
    fn detect(pv: &[f64]) -> Option<datasets::Compression> {
        datasets::compression(pv).filter(datasets::Compression::detected)
    }
}

impl Cause for Compression {
    fn name(&self) -> &'static str {
        "compression"
    }
    /// Never tested as an extension: it acts on every model through [`Cause::reframe`].
    fn applies(&self, _ctx: &Context<'_>) -> bool {
        false
    }
    fn evidence(&self, ctx: &Context<'_>) -> Evidence {
        self.reframe(ctx.problem, ctx.baseline_spec, &ctx.options.search)
            .map_or_else(
                || Evidence {
                    statistic: 0.0,
                    text: "PV shows no historian compression.".into(),
                },
                |r| r.evidence,
            )
    }
    fn extend(&self, _ctx: &Context<'_>) -> Result<Extension, DiagnoseError> {
        Err(DiagnoseError::NotAnExtension {
            cause: "compression",
        })
    }
    fn reframe(
        &self,
        problem: Problem<'_>,
        baseline: &Baseline,
        search: &SearchOptions,
    ) -> Option<Reframe> {
        let c = Self::detect(problem.pv)?;
        let lag = c.median_len.saturating_sub(1).clamp(1, MAX_LAG);
        let text = format!(
            "PV is historian-compressed: {:.0} % of the samples lie on {} exactly straight sloped segments (median {} samples), the interpolation between kept points. One-step prediction is biased on such data (a straight line predicts itself whatever the valve does), so the baseline is refitted as ARX at a lag of {lag} samples (larx: PV from PV {lag} and {} samples back, the archive's typical distance between kept points) and no other cause is tested (their likelihood-ratio tests need residuals the interpolation has not shaped). S and J are less certain than on uncompressed data: where possible, read the registration from the historian without compression or at its raw (archived) resolution.",
            100.0 * c.share,
            c.segments,
            c.median_len,
            2 * lag,
        );
        let larx = linear_id::find_identifier("larx").ok()?;
        let mut refit = baseline.with(baseline.stiction, larx, baseline.fixed_delay());
        // ARX's orders carry over (LARX at lag 1 is ARX); another identifier's do not mean
        // the same thing
        refit
            .orders
            .retain(|(k, _)| matches!(baseline.linear.name, "arx" | "larx") && k != "lag");
        refit
            .orders
            .push(("lag".into(), linear_id::OrderValue::Int(lag)));
        Some(Reframe {
            baseline: refit,
            search: *search,
            evidence: Evidence {
                statistic: c.share,
                text,
            },
        })
    }
}

inventory::submit! {
    CauseEntry {
        name: "compression",
        role: crate::Role::Reframe,
        description: "PV read back from a historian's compressed storage: named first, the baseline stands with a warning, no other cause is tested",
        statistic: "share of the PV samples on exactly straight sloped segments",
        build: || Box::new(Compression),
    }
}
