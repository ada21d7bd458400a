//! `no-stiction`: the null hypothesis, the oscillation is not the valve's.

use std::time::Instant;

use crate::{Cause, CauseEntry, Context, DiagnoseError, Evidence, Extension, Fitted};

/// The oscillation is not the valve's: a linear valve (every stiction parameter 0) explains
/// PV as well as the best stiction node, so the stiction estimate is not supported (the
/// paper's §5.2 warning; typically an external oscillation or tuning). Reported ahead of the
/// other causes when it holds.
///
/// Statistic: the LR loss of removing the stiction parameters,
/// `n_val · ln(SSE_no-stiction / SSE_best)`.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoStiction;

impl Cause for NoStiction {
    fn name(&self) -> &'static str {
        "no-stiction"
    }
    fn applies(&self, _ctx: &Context<'_>) -> bool {
        true
    }
    fn evidence(&self, ctx: &Context<'_>) -> Evidence {
        let q = &ctx.baseline.result;
        let loss = q
            .fit_no_stiction
            .map_or(f64::INFINITY, |f0| ctx.lr(f0, ctx.baseline.fit_val()));
        let text = match q.fit_no_stiction {
            Some(f0) => format!(
                "Removing the stiction (the best valve with S at most {} %) costs a likelihood ratio of {loss:.1} on validation data (validation F_PV {f0:.2} without stiction against {:.2} with it).",
                grid_search::NEGLIGIBLE_S,
                ctx.baseline.fit_val()
            ),
            // the S = J = 0 node was skipped (e.g. an unstable model): the extension below
            // fits the valves of negligible stiction instead
            None => format!(
                "The baseline's search evaluated no valve without stiction (that node was skipped); the extension fits the best valve with S at most {} % instead.",
                grid_search::NEGLIGIBLE_S
            ),
        };
        Evidence {
            statistic: loss,
            text,
        }
    }
    fn extend(&self, ctx: &Context<'_>) -> Result<Extension, DiagnoseError> {
        let started = Instant::now();
        let spec = ctx.baseline_spec;
        let identifier = spec.identifier(ctx.baseline.delay)?;
        let zero = vec![0.0; spec.stiction.params.len()];
        // The valve without stiction: every node of negligible stiction on the fine lattice
        // (the exact S = J = 0 node alone can be skipped, e.g. for an unstable model).
        let fine = ctx.options.search.grid.step();
        let bounds: Vec<(f64, f64)> = spec
            .stiction
            .params
            .iter()
            .map(|_| (0.0, grid_search::NEGLIGIBLE_S))
            .collect();
        let mut candidates: Vec<Vec<f64>> =
            grid_search::grid::nodes_in_box(spec.stiction, ctx.span, fine, Some(&bounds))
                .into_iter()
                .filter(|p| {
                    (spec.stiction.build)(p)
                        .is_ok_and(|m| m.equivalent().s <= grid_search::NEGLIGIBLE_S + 1e-12)
                })
                .collect();
        if candidates.is_empty() {
            candidates.push(zero);
        }
        let nodes = grid_search::evaluate_nodes(
            spec.stiction,
            identifier.as_ref(),
            ctx.problem,
            &ctx.options.search,
            candidates,
        )?;
        let result = grid_search::quantify_from_surface(
            spec.stiction,
            identifier.as_ref(),
            ctx.problem,
            &ctx.options.search,
            nodes,
            ctx.options.search.grid,
            Vec::new(),
        )?;
        let fitted = Fitted {
            stiction: spec.stiction,
            linear: spec.linear.name,
            identifier,
            delay: ctx.baseline.delay,
            delay_scan: None,
            result,
            elapsed_ms: started.elapsed().as_secs_f64() * 1e3,
        };
        let lr = ctx.lr(ctx.baseline.fit_val(), fitted.fit_val());
        Ok(Extension {
            fitted,
            lr,
            extra_params: -(spec.stiction.params.len() as i32),
            reference: "baseline".into(),
            data: None,
        })
    }
}

inventory::submit! {
    CauseEntry {
        name: "no-stiction",
        role: crate::Role::NullHypothesis,
        description: "the oscillation is not the valve's: a valve with negligible stiction (S <= 0.2 %) explains PV as well",
        statistic: "likelihood-ratio loss of removing the stiction parameters",
        build: || Box::new(NoStiction),
    }
}
