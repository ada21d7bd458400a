//! What the test reads from a registration ([`inputs`]), and a floor under its two likelihood
//! ratios from a few valves of its grid ([`floor`]): the parts' check of a `stiction` verdict
//! (`crate::score::settle`) needs to know only that a part cannot say `no-stiction`, and a
//! floor from the whole record's best valve usually shows that at a small part of the cost.

use super::{
    best_arx, best_oe_arx_many, dominant_frequency, rate_noise_filter, second_frequency, ArxTarget,
    Setup, LARGEST_S, S_GRID,
};
use crate::{DetectionError, Registration};
use stiction_models::{InitialState, Kano, StictionModel};

/// What the test fits, read from a registration.
pub(super) struct Inputs<'a> {
    /// The output's name: `PV`, or `ΔPV` for an integrating loop.
    pub(super) proxy: &'static str,
    /// The output-error fit's output: PV, or the level's rate through its noise filter.
    pub(super) y: Vec<f64>,
    /// PV (the one-step ARX's output), aligned with `y`.
    pub(super) pv: &'a [f64],
    /// OP, aligned with `y`.
    pub(super) op: &'a [f64],
    /// The nuisance frequencies (rad/sample).
    pub(super) omegas: Vec<f64>,
    /// The integrating loop's noise filter pole (0 for a self-regulating loop).
    pub(super) rate_filter: f64,
}

/// The test's inputs: the output, and the frequencies of the nuisance sines.
pub(super) fn inputs<'a>(reg: &'a Registration<'_>) -> Result<Inputs<'a>, DetectionError> {
    reg.prepared()?;
    let px = reg.valve_proxy();
    let (proxy, y, op, pv) = (px.name, px.y, px.op, px.pv);
    // With a regular oscillation, a sine and a cosine at its frequency are nuisance
    // regressors of the output-error fit: an external oscillation is then no longer
    // "explained" by a deadband that filters OP's compensation of it, and a limit cycle's
    // evidence must come from its shape beyond the fundamental.
    let o = reg.prepared()?.oscillation;
    let omega = o
        .period
        .filter(|_| o.is_regular())
        .map(|p| 2.0 * std::f64::consts::PI / p);
    let mut omegas: Vec<f64> = omega.into_iter().collect();
    // OP's dominant frequency too: an external oscillation that the controller compensates
    // shows in OP even when the control error does not oscillate regularly (a wandering
    // set point, a slow plant), and a deadband that filters the compensation out of OP
    // would otherwise explain PV better than the free valve does.
    if let Some(w) = dominant_frequency(op) {
        let resolution = 2.0 * std::f64::consts::PI / op.len() as f64;
        if omegas.iter().all(|&v| (v - w).abs() > resolution) {
            omegas.push(w);
        }
    }
    // And OP's next tone, when it is not a harmonic of those: an external disturbance of
    // several tones (the reference paper's two sines) leaves the free valve a second
    // oscillation to miss, which a small deadband would otherwise "explain"; a limit
    // cycle's OP has harmonics, which stay evidence.
    if let Some(w2) = second_frequency(op, &omegas) {
        omegas.push(w2);
    }
    let (y, rate_filter) = if reg.is_integrating() {
        rate_noise_filter(&y, op, &omegas)
    } else {
        (y, 0.0)
    };
    Ok(Inputs {
        proxy,
        y,
        pv,
        op,
        omegas,
        rate_filter,
    })
}

/// Lower bounds of the Hammerstein test's likelihood ratios on a registration, from some
/// valves of its grid ([`floor`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Floor {
    /// At most the output-error `LR` the test reports (its statistic).
    pub lr: f64,
    /// At most its one-step `lr_arx`.
    pub lr_arx: f64,
    /// The test's regression rows (its `rows`).
    pub rows: usize,
    /// The test's own `free_share` (the free valve's fit is the test's, bit for bit), where
    /// it reports one ([`super::reads_free_share`]).
    pub free_share: Option<f64>,
    /// Whether OP's range reaches the grid's largest band, where a best valve makes the test
    /// give no statistic at all (an optimum on the grid's edge).
    pub edge: bool,
}

/// A floor under the Hammerstein test's two likelihood ratios on `reg`, from the free valve
/// and the valves `(S, J)` of `valves` that its grid tries on this record (S of the grid up to
/// OP's range, J one of `0`, `S/2`, `S` exactly; others are ignored), each from both starts.
///
/// Each ratio is `N ln(RSS_free / min RSS_sticky)`, the minimum over the grid's valves; over a
/// subset of them the minimum is no smaller, so the ratio no larger: every valve's fit is the
/// same bits in any lane of any pass (`best_oe_arx_many`), and the free valve's residual is
/// the test's own. `None` where the test would give no comparison (too short, OP's range
/// below twice the smallest band, a residual that is not positive), or no valve of `valves`
/// is in the grid. A ratio is a floor of the test's only while the grid's best residual is
/// positive: a valve that explained a record to the last bit would make the test give none.
pub fn floor(
    reg: &Registration<'_>,
    valves: &[(f64, f64)],
) -> Result<Option<Floor>, DetectionError> {
    let Inputs {
        y, pv, op, omegas, ..
    } = inputs(reg)?;
    let Some(Setup {
        tg,
        z,
        u0,
        range,
        rows,
        phi,
        lag2,
    }) = Setup::new(&y, pv, op, &omegas, reg.is_integrating())
    else {
        return Ok(None);
    };
    let mut mvs: Vec<Vec<f64>> = vec![super::input(&u0, &phi, lag2)];
    for &(s, j) in valves {
        let in_grid =
            S_GRID.iter().any(|&g| g == s && g <= range) && [0.0, 0.5 * s, s].contains(&j);
        if !in_grid {
            continue;
        }
        let Ok(valve) = Kano::params().s(s).j(j).check() else {
            continue;
        };
        for init in [InitialState::down(), InitialState::up()] {
            if let Ok(mut mv) = valve.simulate(&u0, &init) {
                super::input_in_place(&mut mv, &phi, lag2);
                mvs.push(mv);
            }
        }
    }
    if mvs.len() < 2 {
        return Ok(None);
    }
    let arx_tg = ArxTarget::new(&z, tg.start);
    let arx0 = best_arx(&arx_tg, &mvs[0]);
    let refs: Vec<&[f64]> = mvs.iter().map(Vec::as_slice).collect();
    let fits = best_oe_arx_many(&tg, Some(&arx_tg), &refs);
    let oe0 = fits[0].0 .0;
    let oe1 = fits[1..]
        .iter()
        .map(|f| f.0 .0)
        .fold(f64::INFINITY, f64::min);
    let arx1 = fits[1..].iter().map(|f| f.1).fold(f64::INFINITY, f64::min);
    let positive = |v: f64| v > 0.0 && v.is_finite();
    if !(positive(oe0) && positive(oe1) && positive(arx0) && positive(arx1)) {
        return Ok(None);
    }
    Ok(Some(Floor {
        lr: rows as f64 * (oe0 / oe1).max(1.0).ln(),
        lr_arx: arx_tg.rows() as f64 * (arx0 / arx1).max(1.0).ln(),
        rows,
        free_share: super::reads_free_share(reg).then(|| (1.0 - oe0 / tg.yy).max(0.0)),
        edge: range >= LARGEST_S,
    }))
}
