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
//! ([`datasets::compression`], the reader's `compressed` note), it is named first, the
//! baseline stands with that warning, and no other cause is tested (their tests assume
//! residuals the interpolation has shaped). It does not refit the baseline: two refits that
//! the interpolation cannot bias were measured on the six loops of `tests/compression.rs`
//! and neither estimated S better than the baseline (within max(0.5, 10 %) of the truth:
//! ranked by one-step prediction 3/6, by free run 2/6, output error fitted at the kept points
//! only and ranked by free run 2/6; the same loops uncompressed 5/6): the information lost
//! between kept points is lost to all three.

use grid_search::{Problem, SearchOptions};

use crate::{Baseline, Cause, Context, DiagnoseError, Evidence, Extension, Reframe};

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
        let text = format!(
            "PV is historian-compressed: {:.0} % of the samples lie on {} exactly straight sloped segments (median {} samples), the interpolation between kept points. One-step prediction is biased on such data (a straight line predicts itself whatever the valve does): the baseline's S and J are less reliable than usual, and no other cause is tested (their likelihood-ratio tests need residuals the interpolation has not shaped). Where possible, read the registration from the historian without compression or at its raw (archived) resolution.",
            100.0 * c.share,
            c.segments,
            c.median_len,
        );
        Some(Reframe {
            baseline: baseline.clone(),
            search: *search,
            evidence: Evidence {
                statistic: c.share,
                text,
            },
        })
    }
}
