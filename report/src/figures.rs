//! The figures of a report, built from a loop's signals and the results of a run.

use grid_search::{Criterion, GridPlan, NodeFit, Quantification};
use stiction_models::{run_valve, InitialState, Initialization, StictionModel};

use crate::chart::{
    palette, render_heatmap, render_lines, Cell, HeatMap, LineChart, Mark, Panel, Rule, Series,
};
use crate::ReportError;

mod detection;
pub use detection::{cross_correlation, pv_op_plot, DETECTION_TESTS};

/// A rendered figure.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File stem (the SVG is written as `<name>.svg`); unique within a report.
    pub name: String,
    /// Caption under the figure: what is shown and how to read it.
    pub caption: String,
    /// The SVG document.
    pub svg: String,
}

/// The measured signals of one loop, as the figures need them.
#[derive(Debug, Clone, Copy)]
pub struct LoopSignals<'a> {
    /// Loop name for titles (file stem or example name).
    pub name: &'a str,
    /// Time from the first sample, s.
    pub t: Option<&'a [f64]>,
    /// Set point.
    pub sp: Option<&'a [f64]>,
    /// Process variable.
    pub pv: &'a [f64],
    /// Controller output, in [`op_unit`]`(span_unknown)`.
    pub op: &'a [f64],
    /// Measured valve position, when logged.
    pub mv: Option<&'a [f64]>,
    /// OP's valve span is unknown: the reader rescaled OP to % of the range seen, and OP, MV,
    /// S and J are in % of the OP range seen (the record's answer's `span_unknown`, as the
    /// text output says it).
    pub span_unknown: bool,
}

/// The unit of OP, MV, S and J on the figures: `% of valve span`, or `% of the OP range seen`
/// when OP's valve span is unknown (`span_unknown`; the unit of S in the text output and the
/// JSON's `S_unit`).
pub fn op_unit(span_unknown: bool) -> &'static str {
    if span_unknown {
        discrepancy::RANGE_SEEN_UNIT
    } else {
        monitoring::answer::SPAN_UNIT
    }
}

/// The time axis of a loop: values and description with unit.
struct TimeAxis {
    x: Vec<f64>,
    label: &'static str,
    scale: f64,
}

impl TimeAxis {
    /// The unit of the axis in words (`s`, `min`, `h`, `samples`).
    fn label_unit(&self) -> &'static str {
        match self.label {
            "time (s)" => "s",
            "time (min)" => "min",
            "time (h)" => "h",
            _ => "samples",
        }
    }

    fn of(sig: &LoopSignals<'_>) -> TimeAxis {
        match sig.t {
            Some(t) if t.len() == sig.op.len() && !t.is_empty() => {
                let dur = t[t.len() - 1] - t[0];
                let (label, scale) = if dur <= 3600.0 {
                    ("time (s)", 1.0)
                } else if dur <= 2.0 * 86400.0 {
                    ("time (min)", 60.0)
                } else {
                    ("time (h)", 3600.0)
                };
                TimeAxis {
                    x: t.iter().map(|v| v / scale).collect(),
                    label,
                    scale,
                }
            }
            _ => TimeAxis {
                x: (0..sig.op.len()).map(|i| i as f64).collect(),
                label: "sample (-)",
                scale: f64::NAN,
            },
        }
    }

    /// Sampling interval in s, when the record has times.
    fn ts(&self) -> Option<f64> {
        if !self.scale.is_finite() || self.x.len() < 2 {
            return None;
        }
        let n = self.x.len();
        let dt = (self.x[n - 1] - self.x[0]) * self.scale / (n - 1) as f64;
        (dt > 0.0).then_some(dt)
    }

    fn at(&self, i: usize) -> f64 {
        self.x.get(i).copied().unwrap_or(f64::NAN)
    }
}

/// `loop — model` for titles.
fn title(kind: &str, sig: &LoopSignals<'_>, model: &str) -> String {
    format!("{kind}: loop {}, {model}", sig.name)
}

fn split_rule(axis: &TimeAxis, split: usize) -> Rule {
    Rule {
        at: axis.at(split),
        name: "start of validation data".into(),
        color: palette::RED,
        vertical: true,
    }
}

/// The figure `name`: `chart` drawn, with `caption` under it.
fn line_figure(
    name: &str,
    chart: &LineChart,
    caption: impl Into<String>,
) -> Result<Figure, ReportError> {
    Ok(Figure {
        name: name.into(),
        caption: caption.into(),
        svg: render_lines(chart)?,
    })
}

fn criterion_words(c: Criterion) -> &'static str {
    match c {
        Criterion::Prediction => "one-step prediction",
        Criterion::Simulation => "free-run simulation",
    }
}

/// Time trends of SP, PV, OP with the model's PV and MV (the paper's Figs. 12-16).
pub fn time_trends(
    sig: &LoopSignals<'_>,
    q: &Quantification,
    model: &str,
    name: &str,
) -> Result<Figure, ReportError> {
    let axis = TimeAxis::of(sig);
    let mut pv_panel = Panel {
        y_label: "PV (engineering units)".into(),
        caption: "process variable".into(),
        ..Panel::default()
    };
    if let Some(sp) = sig.sp {
        pv_panel.series.push(Series {
            mark: Mark::Dashed,
            ..Series::from_xy("SP", &axis.x, sp, palette::GREY)
        });
    }
    pv_panel.push_xy("PV measured", &axis.x, sig.pv, palette::BLACK);
    pv_panel.push_xy(
        "PV model, free-run simulation",
        &axis.x,
        &q.pv_sim,
        palette::BLUE,
    );
    if q.criterion == Criterion::Prediction {
        pv_panel.push_xy(
            "PV model, one-step prediction",
            &axis.x,
            &q.pv_pred,
            palette::ORANGE,
        );
    }
    pv_panel.rules.push(split_rule(&axis, q.split_index));
    let mut op_panel = Panel {
        y_label: format!("OP, MV ({})", op_unit(sig.span_unknown)),
        caption: "controller output and valve position".into(),
        ..Panel::default()
    };
    op_panel.push_xy("OP", &axis.x, sig.op, palette::BLACK);
    if let Some(mv) = sig.mv {
        op_panel.push_xy("MV measured", &axis.x, mv, palette::GREEN);
    }
    op_panel.push_xy("MV estimated", &axis.x, &q.mv_est, palette::BLUE);
    op_panel.rules.push(split_rule(&axis, q.split_index));
    line_figure(
        name,
        &LineChart {
            title: title("Time trends", sig, model),
            x_label: axis.label.into(),
            panels: vec![pv_panel, op_panel],
            side_by_side: false,
            size: (960, 620),
        },
        format!(
            "Measured SP, PV and OP with the model's PV (free-run simulation from the estimated \
             MV{}) and the estimated valve position MV. The model is identified left of the red \
             line and scored right of it (validation F_PV {:.1} %, {}).",
            if q.criterion == Criterion::Prediction {
                ", and the one-step prediction that ranks the grid"
            } else {
                ""
            },
            q.fits_score(q.criterion),
            criterion_words(q.criterion)
        ),
    )
}

/// MV(OP) of `model` for a slow sine sweep over `[lo, hi]`: the model's signature.
fn signature(model: &dyn StictionModel, lo: f64, hi: f64) -> Vec<(f64, f64)> {
    let (c, a) = ((lo + hi) / 2.0, (hi - lo) / 2.0);
    let n = 800;
    let op: Vec<f64> = (0..n)
        .map(|k| c - a * (2.0 * std::f64::consts::PI * k as f64 / 400.0).cos())
        .collect();
    match run_valve(model, &op, &Initialization::In1(InitialState::default())) {
        // The second cycle: the first may still show the initial state.
        Ok(run) => op[400..]
            .iter()
            .copied()
            .zip(run.mv[400..].iter().copied())
            .collect(),
        Err(_) => Vec::new(),
    }
}

/// PV(OP) and MV(OP) phase plots with the fitted model's signature (Figs. 2, 3, 11, 18).
pub fn phase_plots(
    sig: &LoopSignals<'_>,
    q: &Quantification,
    model: &str,
    name: &str,
) -> Result<Figure, ReportError> {
    let k0 = q.fits.valid_from.min(sig.op.len());
    let xy = |y: &[f64]| -> Vec<(f64, f64)> {
        sig.op[k0..]
            .iter()
            .copied()
            .zip(y[k0.min(y.len())..].iter().copied())
            .collect()
    };
    let pv_panel = Panel {
        y_label: "PV (engineering units)".into(),
        caption: "PV(OP)".into(),
        series: vec![
            Series {
                mark: Mark::Line(1),
                ..Series::line("measured", xy(sig.pv), palette::BLACK)
            },
            Series::line("model, free-run simulation", xy(&q.pv_sim), palette::BLUE),
        ],
        ..Panel::default()
    };
    let (lo, hi) = sig.op[k0..]
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    // Sweep wide enough for the valve to slip in both directions.
    let half = ((hi - lo) / 2.0).max(0.6 * q.s.max(0.0) + 0.5);
    let mid = (lo + hi) / 2.0;
    let mut mv_series = Vec::new();
    if let Some(mv) = sig.mv {
        mv_series.push(Series::line("MV measured", xy(mv), palette::GREEN));
    }
    mv_series.push(Series::line(
        "MV estimated from OP",
        xy(&q.mv_est),
        palette::BLUE,
    ));
    mv_series.push(Series {
        mark: Mark::Line(2),
        ..Series::line(
            format!("signature S={:.2} J={:.2}", q.s, q.j),
            signature(q.stiction.as_ref(), mid - half, mid + half),
            palette::RED,
        )
    });
    let unit = op_unit(sig.span_unknown);
    let mv_panel = Panel {
        y_label: format!("MV ({unit})"),
        caption: "MV(OP)".into(),
        series: mv_series,
        ..Panel::default()
    };
    line_figure(
        name,
        &LineChart {
            title: title("Phase plots", sig, model),
            x_label: format!("OP ({unit})"),
            panels: vec![pv_panel, mv_panel],
            side_by_side: true,
            size: (1200, 520),
        },
        format!(
            "Left: PV against OP, measured and simulated by the model. Right: the estimated valve \
             position against OP and the fitted model's signature for a slow sweep (red): the \
             horizontal stretches are the valve stuck (deadband + stickband S = {:.2}), the \
             vertical jumps the slip J = {:.2}, in {unit}.",
            q.s, q.j
        ),
    )
}

fn on_lattice(v: f64, step: f64) -> bool {
    let r = v / step;
    (r - r.round()).abs() < 1e-6
}

/// The fit surface over (S, J) as a heat map with the optimum and its region; S and J in
/// [`op_unit`]`(span_unknown)`.
pub fn fit_surface(
    q: &Quantification,
    (loop_name, span_unknown): (&str, bool),
    model: &str,
    name: &str,
) -> Result<Figure, ReportError> {
    let c = q.criterion;
    let (coarse, fine) = match q.grid {
        GridPlan::Exhaustive { step } => (step, step),
        GridPlan::CoarseToFine { coarse, fine, .. } => (coarse, fine),
    };
    // Refined nodes: a parameter off the coarse lattice; the refinement box is their extent.
    let mut bbox = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    if fine < coarse {
        for n in &q.surface {
            if n.params.iter().any(|&p| !on_lattice(p, coarse)) {
                bbox = (
                    bbox.0.min(n.s),
                    bbox.1.max(n.s),
                    bbox.2.min(n.j),
                    bbox.3.max(n.j),
                );
            }
        }
    }
    let tol = 1e-9 * coarse.max(1e-12);
    let inside = |s: f64, j: f64| {
        s >= bbox.0 - tol && s <= bbox.1 + tol && j >= bbox.2 - tol && j <= bbox.3 + tol
    };
    let mut values: Vec<f64> = q
        .surface
        .iter()
        .map(|n| n.score(c))
        .filter(|v| v.is_finite())
        .collect();
    values.sort_by(f64::total_cmp);
    let best = q.fits_score(c);
    let lo = if values.is_empty() {
        best - 1.0
    } else {
        let p10 = values[values.len() / 10];
        p10.max(best - 50.0).min(best - 0.5)
    };
    let mut cells: Vec<Cell> = q
        .surface
        .iter()
        .map(|n| {
            let size = if inside(n.s, n.j) { fine } else { coarse };
            let v = n.score(c);
            Cell {
                x: n.s,
                y: n.j,
                w: size,
                h: size,
                value: v.is_finite().then_some(v),
            }
        })
        .collect();
    // Large cells first, then the better fits on top.
    cells.sort_by(|a, b| {
        b.w.total_cmp(&a.w).then(
            a.value
                .unwrap_or(f64::NEG_INFINITY)
                .total_cmp(&b.value.unwrap_or(f64::NEG_INFINITY)),
        )
    });
    // The axes reach the largest node and the optimum, and at least one coarse step.
    let top = |at: fn(&NodeFit) -> f64, optimum: f64| {
        q.surface.iter().map(at).fold(optimum, f64::max).max(coarse)
    };
    let (s_max, j_max) = (top(|n| n.s, q.s), top(|n| n.j, q.j));
    let j_min = q.surface.iter().map(|n| n.j).fold(0.0, f64::min);
    let iv = q.interval;
    let region: Vec<(f64, f64)> = q
        .surface
        .iter()
        .filter(|n| n.score(c) >= iv.fit_threshold)
        .map(|n| (n.s, n.j))
        .collect();
    let mut overlay = Vec::new();
    if iv.s[1] > iv.s[0] || iv.j[1] > iv.j[0] {
        let (s0, s1, j0, j1) = (iv.s[0], iv.s[1], iv.j[0], iv.j[1]);
        overlay.push(Series::marked(
            format!(
                "{:.0} % region: S {:.2}-{:.2}, J {:.2}-{:.2}",
                100.0 * iv.confidence,
                s0,
                s1,
                j0,
                j1
            ),
            vec![(s0, j0), (s1, j0), (s1, j1), (s0, j1), (s0, j0)],
            Mark::Dashed,
            palette::RED,
        ));
    }
    overlay.push(Series::marked(
        format!("nodes in the region ({})", region.len()),
        region,
        Mark::Dots(2),
        RGB_WHITE,
    ));
    overlay.push(Series::marked(
        format!("optimum S = {:.2}, J = {:.2}", q.s, q.j),
        vec![(q.s, q.j)],
        Mark::Crosses,
        palette::RED,
    ));
    let pad = coarse;
    let svg = render_heatmap(&HeatMap {
        title: format!("Fit surface: loop {loop_name}, {model}"),
        x_label: format!("S ({})", op_unit(span_unknown)),
        y_label: format!("J ({})", op_unit(span_unknown)),
        value_label: format!("validation F_PV, {} (%)", criterion_words(c)),
        cells,
        range: (lo, best),
        overlay,
        x_range: (-pad / 2.0, s_max + pad / 2.0),
        y_range: (j_min - pad / 2.0, j_max + pad / 2.0),
        size: (820, 620),
    })?;
    Ok(Figure {
        name: name.into(),
        caption: format!(
            "Validation F_PV ({}) of every grid node over the equivalent S and J ({} nodes, {} \
             skipped, grey). Colours below {:.1} % are clipped. The cross marks the optimum, the \
             dashed box the range of the nodes not significantly worse ({:.0} % likelihood-ratio \
             region, F_PV ≥ {:.2} %).",
            criterion_words(c),
            q.surface.len(),
            q.nodes_skipped,
            lo,
            100.0 * iv.confidence,
            iv.fit_threshold
        ),
        svg,
    })
}

const RGB_WHITE: plotters::style::RGBColor = plotters::style::RGBColor(255, 255, 255);

/// `baseline vs extended` (or the baseline alone) for the titles of the residual figures.
fn pair_label(base: &str, extended: Option<&str>) -> String {
    match extended {
        Some(l) => format!("{base} vs {l}"),
        None => base.to_string(),
    }
}

/// The one-panel chart of the baseline's `line(fit)` in black and, when there is one, the
/// extended model's in blue, titled `kind: loop …, baseline vs extended`.
fn base_and_extended(
    sig: &LoopSignals<'_>,
    (kind, x_label): (&str, &str),
    mut panel: Panel,
    base: (&Quantification, &str),
    extended: Option<(&Quantification, &str)>,
    line: impl Fn(&Quantification) -> Vec<(f64, f64)>,
) -> LineChart {
    panel.series.push(Series::line(
        format!("baseline {}", base.1),
        line(base.0),
        palette::BLACK,
    ));
    if let Some((q, label)) = extended {
        panel.series.push(Series::line(
            format!("extended {label}"),
            line(q),
            palette::BLUE,
        ));
    }
    LineChart {
        title: title(kind, sig, &pair_label(base.1, extended.map(|e| e.1))),
        x_label: x_label.into(),
        panels: vec![panel],
        side_by_side: false,
        size: (960, 380),
    }
}

/// One-step residuals `pv - pv_pred` (NaN where there is no prediction).
pub fn residuals(pv: &[f64], q: &Quantification) -> Vec<f64> {
    pv.iter()
        .zip(&q.pv_pred)
        .map(|(y, p)| y - p)
        .collect::<Vec<_>>()
}

/// Residuals of the baseline and (when one was found) the extended model over time.
pub fn residual_trends(
    sig: &LoopSignals<'_>,
    base: (&Quantification, &str),
    extended: Option<(&Quantification, &str)>,
    name: &str,
) -> Result<Figure, ReportError> {
    let axis = TimeAxis::of(sig);
    let panel = Panel {
        y_label: "PV residual (engineering units)".into(),
        caption: "one-step prediction residual, PV measured - PV predicted".into(),
        rules: vec![split_rule(&axis, base.0.split_index)],
        ..Panel::default()
    };
    let chart = base_and_extended(sig, ("Residuals", axis.label), panel, base, extended, |q| {
        axis.x.iter().copied().zip(residuals(sig.pv, q)).collect()
    });
    line_figure(
        name,
        &chart,
        "What the model gets wrong: the one-step prediction residuals of the baseline \
         model and of the extended model, over the whole record (validation right of \
         the red line). Slow drifts and oscillations left in the residuals are \
         structure the model has not captured.",
    )
}

/// Welch power spectral density (Hann window, 50 % overlap) in dB of `x`, with frequency in
/// cycles per sample. Non-finite samples are dropped; the mean is removed per segment.
pub fn welch_db(x: &[f64]) -> Vec<(f64, f64)> {
    let x: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    let n = x.len();
    if n < 16 {
        return Vec::new();
    }
    let seg = 256.min(n / 2).max(16);
    let hop = seg / 2;
    let w: Vec<f64> = (0..seg)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / seg as f64).cos())
        .collect();
    let wss: f64 = w.iter().map(|v| v * v).sum();
    let bins = seg / 2 + 1;
    let mut psd = vec![0.0; bins];
    let mut count = 0usize;
    let mut start = 0;
    while start + seg <= n {
        let s = &x[start..start + seg];
        let mean = s.iter().sum::<f64>() / seg as f64;
        for (k, p) in psd.iter_mut().enumerate() {
            let (mut re, mut im) = (0.0, 0.0);
            let om = 2.0 * std::f64::consts::PI * k as f64 / seg as f64;
            for (i, (&v, &wi)) in s.iter().zip(&w).enumerate() {
                let a = (v - mean) * wi;
                let ph = om * i as f64;
                re += a * ph.cos();
                im -= a * ph.sin();
            }
            *p += (re * re + im * im) / wss;
        }
        count += 1;
        start += hop;
    }
    psd.iter()
        .enumerate()
        .skip(1)
        .map(|(k, p)| {
            let v = p / count as f64;
            (k as f64 / seg as f64, 10.0 * v.max(1e-300).log10())
        })
        .collect()
}

/// Spectrum of the validation residuals of the baseline and the extended model.
pub fn residual_spectrum(
    sig: &LoopSignals<'_>,
    base: (&Quantification, &str),
    extended: Option<(&Quantification, &str)>,
    name: &str,
) -> Result<Figure, ReportError> {
    let (x_label, fscale) = match TimeAxis::of(sig).ts() {
        Some(ts) => ("frequency (mHz)", 1000.0 / ts),
        None => ("frequency (cycles/sample)", 1.0),
    };
    let panel = Panel {
        y_label: "power spectral density (dB)".into(),
        caption: "residual spectrum, validation data".into(),
        ..Panel::default()
    };
    let labels = ("Residual spectrum", x_label);
    let chart = base_and_extended(sig, labels, panel, base, extended, |q| {
        let r = residuals(sig.pv, q);
        welch_db(&r[q.split_index.min(r.len())..])
            .into_iter()
            .map(|(f, p)| (f * fscale, p))
            .collect()
    });
    line_figure(
        name,
        &chart,
        "Welch spectrum (Hann window, 50 % overlap) of the one-step residuals on the \
         validation data. White residuals give a flat spectrum; a peak is an \
         oscillation the model does not explain, a rise at low frequency a slow \
         disturbance.",
    )
}

/// The disturbance η̂ estimated by an extended (EARX/EARMAX) model over the identification
/// data, or `None` when the model has no disturbance term.
pub fn disturbance(
    sig: &LoopSignals<'_>,
    q: &Quantification,
    model: &str,
    name: &str,
) -> Result<Option<Figure>, ReportError> {
    let Some(eta) = q.linear.disturbance() else {
        return Ok(None);
    };
    let axis = TimeAxis::of(sig);
    let end = q.split_index.min(axis.x.len());
    let start = end.saturating_sub(eta.len());
    let skip = q.linear.first_sample();
    let pts: Vec<(f64, f64)> = eta
        .iter()
        .enumerate()
        .skip(skip)
        .map(|(i, &v)| (axis.at(start + i), v))
        .collect();
    let span = |k: usize| axis.at(k.min(axis.x.len().saturating_sub(1)));
    let (from, to) = (span(start + skip), span(end.saturating_sub(1)));
    let chart = LineChart {
        title: title("Estimated disturbance", sig, model),
        x_label: axis.label.into(),
        panels: vec![Panel {
            y_label: "disturbance η (PV engineering units)".into(),
            caption: "time-varying disturbance term of the extended model".into(),
            series: vec![Series::line("η estimated", pts, palette::PURPLE)],
            ..Panel::default()
        }],
        side_by_side: false,
        size: (960, 340),
    };
    line_figure(
        name,
        &chart,
        format!(
            "The nonstationary disturbance η̂ the extended model estimates alongside the process \
             model (PV units, around the PV mean). It covers {from:.0}-{to:.0} {} only: η̂ is \
             estimated on the identification data, which starts where the valve model's initial \
             state has washed out (and after the regression's first lags) and ends where the \
             validation data begin; on the validation data the model predicts without it.",
            axis.label_unit()
        ),
    )
    .map(Some)
}

/// How a registration counts in a trend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrendStatus {
    /// Used in the trend.
    Used,
    /// Validation fit too low.
    Weak,
    /// Outside the band around the median.
    Outlier,
}

/// One registration in a trend of S.
#[derive(Debug, Clone, PartialEq)]
pub struct TrendPoint {
    /// Days since the Unix epoch (or the registration index when undated).
    pub day: f64,
    /// Estimated S, % of valve span.
    pub s: f64,
    /// The region's S range.
    pub interval: Option<[f64; 2]>,
    /// How it counts.
    pub status: TrendStatus,
}

/// A fitted trend line: S = level at `day0` + slope·(day - day0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrendLine {
    /// Reference day.
    pub day0: f64,
    /// S at `day0`.
    pub s0: f64,
    /// Slope, % per day.
    pub slope: f64,
}

/// The y axis of [`s_trend`] when a registration's OP has no known valve span.
pub const S_TREND_RANGE_SEEN: &str = "S (% of the OP range seen, per registration)";

/// S over repeated registrations (the paper's Figs. 15, 19, 21). With `span_unknown` (a
/// registration's OP has no known valve span, so its S is in % of the OP range that record
/// shows) the axis says so ([`S_TREND_RANGE_SEEN`]) and no threshold in % of valve span is
/// drawn.
#[allow(clippy::too_many_arguments)]
pub fn s_trend(
    valve: &str,
    model: &str,
    points: &[TrendPoint],
    threshold: f64,
    line: Option<TrendLine>,
    dated: bool,
    span_unknown: bool,
    name: &str,
) -> Result<Figure, ReportError> {
    let first = points.iter().map(|p| p.day).fold(f64::INFINITY, f64::min);
    let mut series = Vec::new();
    for (status, label, color, mark) in [
        (TrendStatus::Used, "S, used", palette::BLUE, Mark::Dots(4)),
        (
            TrendStatus::Weak,
            "S, weak fit (not used)",
            palette::GREY,
            Mark::Rings(4),
        ),
        (
            TrendStatus::Outlier,
            "S, outlier (not used)",
            palette::ORANGE,
            Mark::Rings(5),
        ),
    ] {
        let sel: Vec<&TrendPoint> = points.iter().filter(|p| p.status == status).collect();
        if sel.is_empty() {
            continue;
        }
        series.push(Series {
            name: label.into(),
            points: sel.iter().map(|p| (p.day, p.s)).collect(),
            mark,
            color,
            bars: sel
                .iter()
                .filter_map(|p| p.interval.map(|iv| (p.day, iv[0], iv[1])))
                .collect(),
        });
    }
    if let Some(l) = line {
        let last = points
            .iter()
            .map(|p| p.day)
            .fold(f64::NEG_INFINITY, f64::max);
        series.push(Series::line(
            format!("trend {:+.3} % per 30 days", 30.0 * l.slope),
            [first, last]
                .iter()
                .map(|&d| (d, l.s0 + l.slope * (d - l.day0)))
                .collect(),
            palette::GREEN,
        ));
    }
    let (y_label, rules) = if span_unknown {
        (S_TREND_RANGE_SEEN.to_string(), Vec::new())
    } else {
        (
            "S (% of valve span)".to_string(),
            vec![Rule {
                at: threshold,
                name: format!("maintenance threshold {threshold:.2} %"),
                color: palette::RED,
                vertical: false,
            }],
        )
    };
    let panel = Panel {
        y_label,
        caption: String::new(),
        series,
        rules,
        y_range: None,
        x_range: None,
        x_label: String::new(),
        x_dates: dated,
    };
    line_figure(
        name,
        &LineChart {
            title: format!("S over registrations: valve {valve}, {model}"),
            x_label: if dated {
                "start of the registration (date, UTC)".into()
            } else {
                "registration (-)".into()
            },
            panels: vec![panel],
            side_by_side: false,
            size: (960, 420),
        },
        if span_unknown {
            "Estimated stiction S of each registration with its likelihood-ratio range \
             (bars), in % of the OP range each record shows (OP's valve span is unknown): \
             registrations compare only where their OP ranges match, and no threshold in % of \
             valve span applies. Filled: used in the trend; hollow: left out (weak validation \
             fit, or outside the band around the median). The green line is the Theil-Sen \
             trend of the used registrations."
        } else {
            "Estimated stiction S of each registration with its likelihood-ratio range \
             (bars). Filled: used in the trend; hollow: left out (weak validation fit, or \
             outside the band around the median). The green line is the Theil-Sen trend \
             of the used registrations."
        },
    )
}

/// The raw columns of a file the reader refused, against the row number.
pub fn raw_signals(
    loop_name: &str,
    columns: &[(String, Vec<f64>)],
    name: &str,
) -> Result<Figure, ReportError> {
    let colors = [
        palette::BLACK,
        palette::BLUE,
        palette::ORANGE,
        palette::GREEN,
        palette::PURPLE,
        palette::GREY,
    ];
    let panels = columns
        .iter()
        .zip(colors.iter().cycle())
        .map(|((col, v), &color)| Panel {
            y_label: format!("{col} (as logged)"),
            caption: String::new(),
            series: vec![Series::line(
                col.clone(),
                v.iter().enumerate().map(|(i, &y)| (i as f64, y)).collect(),
                color,
            )],
            ..Panel::default()
        })
        .collect::<Vec<_>>();
    let h = (160 * panels.len() as u32 + 80).clamp(300, 1100);
    line_figure(
        name,
        &LineChart {
            title: format!("Raw data: loop {loop_name}, not analysed"),
            x_label: "row (-)".into(),
            panels,
            side_by_side: false,
            size: (960, h),
        },
        "The file's numeric columns as logged, against the row number (cells that are \
         not numbers are left out). The data were refused for the reason above.",
    )
}
