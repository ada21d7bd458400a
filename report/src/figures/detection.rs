//! The detection tests' figures: the PV-OP plot with the bicoherence test's ellipse and the
//! OP-PV cross-correlation, drawn from what the detector computed
//! (`monitoring::DetectionFigures`).

use super::{title, Figure, LoopSignals, TimeAxis};
use crate::chart::{
    decimate, palette, render_lines, LineChart, Mark, Panel, Rule, Series, MAX_POINTS,
};
use crate::ReportError;

/// What stands for the model in the titles of the detection figures: no model made them.
/// [`crate::inspect::check_plot`] takes a title ending in `, detection tests` for one naming a
/// model.
pub const DETECTION_TESTS: &str = "detection tests";

/// The PV-OP plot of the detection tests: every sample as a point (min/max-decimated to
/// [`MAX_POINTS`] as the line figures are), with the bicoherence test's fitted ellipse and its
/// chord along OP (the apparent stiction) when the loop oscillates regularly (`ellipse`, from
/// [`detection::figures::pv_op_ellipse`]).
pub fn pv_op_plot(
    sig: &LoopSignals<'_>,
    ellipse: Option<&detection::figures::PvOpEllipse>,
    name: &str,
) -> Result<Figure, ReportError> {
    let axis = TimeAxis::of(sig);
    let points: Vec<(f64, f64)> = sig
        .op
        .iter()
        .copied()
        .zip(sig.pv.iter().copied())
        .filter(|(o, p)| o.is_finite() && p.is_finite())
        .collect();
    let shown = decimate(&points, MAX_POINTS);
    let measured = if shown.len() < points.len() {
        format!("measured ({} of {} samples)", shown.len(), points.len())
    } else {
        "measured".to_string()
    };
    let mut series = vec![Series::marked(
        measured,
        shown,
        Mark::Dots(1),
        palette::GREY,
    )];
    let period = |p: f64| match axis.ts() {
        Some(ts) => format!("{:.0} s", p * ts),
        None => format!("{p:.1} samples"),
    };
    let caption = match ellipse {
        Some(e) => {
            series.push(Series {
                mark: Mark::Line(2),
                ..Series::line(
                    format!(
                        "ellipse, period {}, fits {:.0} %",
                        period(e.period),
                        100.0 * e.fit.explained.max(0.0)
                    ),
                    e.curve.clone(),
                    palette::BLUE,
                )
            });
            series.push(Series {
                mark: Mark::Line(3),
                ..Series::line(
                    format!(
                        "apparent stiction {}",
                        discrepancy::in_unit(e.apparent_stiction, sig.span_unknown)
                    ),
                    e.chord.to_vec(),
                    palette::RED,
                )
            });
            format!(
                "PV against OP with the PV-OP ellipse as the bicoherence test fits it: the \
                 fundamental harmonic of OP and of PV at the oscillation's period ({}), fitted by \
                 least squares to the detrended signals (it explains {:.0} % of the variance of \
                 the one it fits worse) and drawn around the record's mean. Its width along OP \
                 through the centre (red) is Choudhury's apparent stiction, {:.2} {}: how far apart OP is at the two moments of a cycle PV crosses its mean. OP \
                 and PV in phase draw a line; a width alone is a phase lag, which the test takes for stiction only when \
                 the control error is also nonlinear (NGI and NLI in the table).",
                period(e.period),
                100.0 * e.fit.explained.max(0.0),
                e.apparent_stiction,
                super::op_unit(sig.span_unknown)
            )
        }
        None => "PV against OP. The loop has no regular oscillation, so the bicoherence test \
                 fits no ellipse (and measures no apparent stiction)."
            .to_string(),
    };
    let panel = Panel {
        y_label: "PV (engineering units)".into(),
        caption: if ellipse.is_some() {
            "PV(OP) with the ellipse of its fundamental harmonics".into()
        } else {
            "PV(OP), no regular oscillation: no ellipse".into()
        },
        series,
        ..Panel::default()
    };
    let svg = render_lines(&LineChart {
        title: title("PV-OP plot", sig, DETECTION_TESTS),
        x_label: format!("OP ({})", super::op_unit(sig.span_unknown)),
        panels: vec![panel],
        side_by_side: false,
        size: (760, 560),
    })?;
    Ok(Figure {
        name: name.into(),
        caption,
        svg,
    })
}

/// The OP-PV cross-correlation Horch's test reads (from
/// [`detection::figures::cross_correlation`]), against the lag in seconds (in samples when the
/// record has no time), with lag 0 and, with a regular oscillation, the quarter periods
/// marked.
pub fn cross_correlation(
    sig: &LoopSignals<'_>,
    cc: &detection::figures::CrossCorrelation,
    name: &str,
) -> Result<Figure, ReportError> {
    let axis = TimeAxis::of(sig);
    let (x_label, scale, unit) = match axis.ts() {
        Some(ts) => ("lag (s)", ts, "s"),
        None => ("lag (samples)", 1.0, "samples"),
    };
    let points: Vec<(f64, f64)> = cc
        .values
        .iter()
        .map(|&(lag, r)| (lag as f64 * scale, r))
        .collect();
    // Horch's statistic only where his test reads it: a self-regulating loop, ±T/2.
    let horch = cc.period.is_some() && !cc.integrating;
    let mut series = vec![Series {
        mark: Mark::Line(2),
        ..Series::line(
            if horch {
                format!("r(lag), odd share {:.2}", cc.odd_share)
            } else {
                "r(lag)".to_string()
            },
            points,
            palette::BLACK,
        )
    }];
    if let Some(t) = cc.period {
        let q = (t / 4.0).round() as i64;
        let at = |lag: i64| cc.values.iter().find(|v| v.0 == lag).map(|v| v.1);
        let marks: Vec<(f64, f64)> = [-q, q]
            .iter()
            .filter_map(|&l| at(l).map(|r| (l as f64 * scale, r)))
            .collect();
        series.push(Series::marked(
            format!("±T/4 = ±{:.0} {unit}", t / 4.0 * scale),
            marks,
            Mark::Rings(5),
            palette::RED,
        ));
    }
    let panel = Panel {
        y_label: "cross-correlation OP-PV (-)".into(),
        caption: "r(lag) = corr(OP(k), PV(k + lag)), detrended".into(),
        series,
        rules: vec![Rule {
            at: 0.0,
            name: "lag 0".into(),
            color: palette::GREY,
            vertical: true,
        }],
        y_range: Some((-1.05, 1.05)),
        ..Panel::default()
    };
    let svg = render_lines(&LineChart {
        title: title("OP-PV cross-correlation", sig, DETECTION_TESTS),
        x_label: x_label.into(),
        panels: vec![panel],
        side_by_side: false,
        size: (960, 400),
    })?;
    let lags = match cc.period {
        Some(t) => format!(
            "over ±T/2 = ±{:.0} {unit}, half the oscillation's period T = {:.0} {unit}",
            cc.max_lag as f64 * scale,
            t * scale
        ),
        None => format!(
            "over a fixed ±{} samples: the loop has no regular oscillation, so Horch's test \
             does not judge it",
            cc.max_lag
        ),
    };
    let reading = if cc.integrating {
        " The loop is integrating: Horch's reading is for self-regulating loops (an integrating \
         loop is judged by the distribution of PV's second difference instead)."
            .to_string()
    } else if horch {
        format!(
            " Its odd share is {:.2} (Horch's test: stiction above 0.67, not stiction below \
             0.33).",
            cc.odd_share
        )
    } else {
        String::new()
    };
    Ok(Figure {
        name: name.into(),
        caption: format!(
            "Normalised cross-correlation of the detrended OP and PV, {lags}; a positive lag \
             pairs OP with PV that much later. In a self-regulating loop a sticky valve makes it \
             odd (near zero at lag 0, opposite extremes near ±T/4: OP, integrating the control \
             error, is a quarter period behind it), an external oscillation or aggressive \
             tuning even (an extremum at lag 0).{reading}"
        ),
        svg,
    })
}
