//! Structure snapshots of every figure kind on the paper's example loop (Kano valve S = 9,
//! J = 3, seed 1): title, panels, axis descriptions, legend labels and the series drawn, as
//! read back from the SVG by `report::inspect` (no pixels, no coordinates, numbers masked).
//! Every figure must also pass `inspect::check_plot`: title with loop and model, axes with
//! units, a legend.
//!
//! Update the snapshots after an intended change with `INSTA_UPDATE=always cargo test -p
//! report --test snapshots` (or `cargo insta review`) and commit `tests/snapshots/*.snap`.
#![allow(clippy::unwrap_used)]

use std::sync::OnceLock;

mod common;

use datasets::simulate::Scenario;
use detection::Registration;
use grid_search::{quantify, GridPlan, Problem, Quantification, SearchOptions};
use report::figures::{self, TrendLine};
use report::inspect::{self, Structure};
use report::{Figure, LoopSignals, TrendPoint, TrendStatus};
use stiction_models::{find_model, Kano};

/// The loop name the CLI gives the example (`reporting::loop_name`).
const LOOP: &str = "paper (example)";
const ARX: &str = "kano × arx";
const EARX: &str = "kano × earx";

struct Paper {
    t: Vec<f64>,
    sp: Vec<f64>,
    pv: Vec<f64>,
    op: Vec<f64>,
    mv: Vec<f64>,
    arx: Quantification,
    earx: Quantification,
}

/// The example of `stiction quantify --example paper`, quantified with kano × arx and
/// kano × earx as the CLI does by default.
fn paper() -> &'static Paper {
    static PAPER: OnceLock<Paper> = OnceLock::new();
    PAPER.get_or_init(|| {
        let scenario = Scenario {
            valve: Box::new(Kano::params().s(9.0).j(3.0).check().unwrap()),
            ..Scenario::default()
        };
        let sim = scenario.simulate().unwrap();
        let (lo, hi) = sim
            .op
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        let options = SearchOptions {
            grid: GridPlan::for_span(hi - lo),
            ..Default::default()
        };
        let entry = find_model("kano").unwrap();
        let problem = Problem {
            op: &sim.op,
            pv: &sim.pv,
            mv: Some(&sim.mv),
        };
        let fit = |linear: &str| {
            let id = linear_id::find_identifier(linear)
                .unwrap()
                .build_default()
                .unwrap();
            quantify(entry, id.as_ref(), problem, &options, None).unwrap()
        };
        let arx = fit("arx");
        let earx = fit("earx");
        Paper {
            t: sim.t.clone(),
            sp: sim.sp.clone(),
            pv: sim.pv.clone(),
            op: sim.op.clone(),
            mv: sim.mv.clone(),
            arx,
            earx,
        }
    })
}

fn signals(p: &Paper) -> LoopSignals<'_> {
    LoopSignals {
        name: LOOP,
        t: Some(&p.t),
        sp: Some(&p.sp),
        pv: &p.pv,
        op: &p.op,
        mv: Some(&p.mv),
        span_unknown: false,
    }
}

/// `check_plot` must pass; returns the structure.
fn checked(fig: &Figure, loop_name: &str) -> Structure {
    inspect::check_plot(&fig.svg, loop_name).unwrap_or_else(|e| panic!("{}: {e}", fig.name))
}

#[test]
fn time_trends() {
    let p = paper();
    let fig = figures::time_trends(&signals(p), &p.arx, ARX, "trends").unwrap();
    let st = checked(&fig, LOOP);
    // The same inputs give the same document (fixed seeds, embedded font).
    let again = figures::time_trends(&signals(p), &p.arx, ARX, "trends").unwrap();
    assert_eq!(fig.svg, again.svg, "the SVG must be deterministic");
    insta::assert_snapshot!("time_trends", st.summary());
}

#[test]
fn phase_plots() {
    let p = paper();
    let fig = figures::phase_plots(&signals(p), &p.arx, ARX, "phase").unwrap();
    insta::assert_snapshot!("phase_plots", checked(&fig, LOOP).summary());
}

#[test]
fn fit_surface() {
    let p = paper();
    let fig = figures::fit_surface(&p.arx, (LOOP, false), ARX, "surface").unwrap();
    let st = checked(&fig, LOOP);
    assert!(
        st.panels[0].series.iter().any(|s| s.color == "cells"),
        "the heat map has cells"
    );
    insta::assert_snapshot!("fit_surface", st.summary());
}

#[test]
fn residual_trends_baseline_only() {
    let p = paper();
    let fig = figures::residual_trends(&signals(p), (&p.arx, ARX), None, "residuals").unwrap();
    insta::assert_snapshot!("residual_trends_baseline", checked(&fig, LOOP).summary());
}

#[test]
fn residual_trends_with_extended_model() {
    let p = paper();
    let fig = figures::residual_trends(
        &signals(p),
        (&p.arx, ARX),
        Some((&p.earx, EARX)),
        "residuals",
    )
    .unwrap();
    insta::assert_snapshot!("residual_trends_extended", checked(&fig, LOOP).summary());
}

#[test]
fn residual_spectrum() {
    let p = paper();
    let fig = figures::residual_spectrum(
        &signals(p),
        (&p.arx, ARX),
        Some((&p.earx, EARX)),
        "spectrum",
    )
    .unwrap();
    insta::assert_snapshot!("residual_spectrum", checked(&fig, LOOP).summary());
}

#[test]
fn disturbance() {
    let p = paper();
    assert!(
        figures::disturbance(&signals(p), &p.arx, ARX, "eta")
            .unwrap()
            .is_none(),
        "ARX has no disturbance term"
    );
    let fig = figures::disturbance(&signals(p), &p.earx, EARX, "eta")
        .unwrap()
        .expect("EARX estimates a disturbance");
    insta::assert_snapshot!("disturbance", checked(&fig, LOOP).summary());
}

#[test]
fn s_trend() {
    let status = [
        TrendStatus::Used,
        TrendStatus::Used,
        TrendStatus::Weak,
        TrendStatus::Used,
        TrendStatus::Outlier,
        TrendStatus::Used,
        TrendStatus::Used,
    ];
    let points: Vec<TrendPoint> = status
        .iter()
        .enumerate()
        .map(|(i, &status)| {
            let s = 1.0
                + 0.1 * i as f64
                + if status == TrendStatus::Outlier {
                    2.0
                } else {
                    0.0
                };
            TrendPoint {
                day: 19_900.0 + 9.0 * i as f64,
                s,
                interval: (i != 3).then_some([s - 0.2, s + 0.3]),
                status,
            }
        })
        .collect();
    let line = TrendLine {
        day0: 19_900.0,
        s0: 1.0,
        slope: 0.011,
    };
    let fig = figures::s_trend(
        "FIC-101",
        ARX,
        &points,
        1.6,
        Some(line),
        true,
        false,
        "kano-arx-s-trend",
    )
    .unwrap();
    insta::assert_snapshot!("s_trend", checked(&fig, "FIC-101").summary());
}

#[test]
fn raw_signals_of_refused_data() {
    let n = 200;
    let cols = vec![
        ("SP".to_string(), vec![50.0; n]),
        ("PV".to_string(), vec![3.5e-44; n]),
        (
            "OP".to_string(),
            (0..n)
                .map(|i| {
                    if i == 50 {
                        f64::NAN
                    } else {
                        (i as f64 / 9.0).sin()
                    }
                })
                .collect(),
        ),
    ];
    let fig = figures::raw_signals("FIC10112_x", &cols, "raw").unwrap();
    let st = checked(&fig, "FIC10112_x");
    assert_eq!(st.panels.len(), 3, "one panel per column");
    insta::assert_snapshot!("raw_signals", st.summary());
}

/// A self-regulating loop in a limit cycle through a sticky valve (slow plant, PI 0.3/0.1,
/// Kano S = 4, J = 1, constant set point; the loop of the CLI's detection tests): the detection
/// figures with a regular oscillation.
struct Sticky {
    t: Vec<f64>,
    sp: Vec<f64>,
    pv: Vec<f64>,
    op: Vec<f64>,
}

fn sticky() -> &'static Sticky {
    static STICKY: OnceLock<Sticky> = OnceLock::new();
    STICKY.get_or_init(|| {
        let sim = common::sticky_simulation();
        Sticky {
            t: sim.t,
            sp: sim.sp,
            pv: sim.pv,
            op: sim.op,
        }
    })
}

const STICKY: &str = "sticky";

fn sticky_signals(l: &Sticky) -> LoopSignals<'_> {
    LoopSignals {
        name: STICKY,
        t: Some(&l.t),
        sp: Some(&l.sp),
        pv: &l.pv,
        op: &l.op,
        mv: None,
        span_unknown: false,
    }
}

fn registration<'a>(sp: &'a [f64], pv: &'a [f64], op: &'a [f64]) -> Registration<'a> {
    Registration::new(pv, op, 1.0).unwrap().with_sp(sp).unwrap()
}

#[test]
fn detection_pv_op_plot_with_the_ellipse() {
    let l = sticky();
    let reg = registration(&l.sp, &l.pv, &l.op);
    let e = detection::figures::pv_op_ellipse(&reg).expect("a limit cycle has an ellipse");
    let fig = figures::pv_op_plot(&sticky_signals(l), Some(&e), "detection-pv-op").unwrap();
    let st = checked(&fig, STICKY);
    assert_eq!(
        st.legend[1..],
        [
            format!(
                "ellipse, period {:.0} s, fits {:.0} %",
                e.period,
                100.0 * e.fit.explained.max(0.0)
            ),
            format!("apparent stiction {:.2} %", e.apparent_stiction)
        ]
    );
    assert!(fig
        .caption
        .contains(&format!("{:.2} % of valve span", e.apparent_stiction)));
    insta::assert_snapshot!("detection_pv_op_ellipse", st.summary());
}

#[test]
fn detection_pv_op_plot_without_an_oscillation() {
    let p = paper();
    let reg = registration(&p.sp, &p.pv, &p.op);
    let e = detection::figures::pv_op_ellipse(&reg);
    assert!(e.is_none(), "the paper's loop does not oscillate regularly");
    let fig = figures::pv_op_plot(&signals(p), e.as_ref(), "detection-pv-op").unwrap();
    let st = checked(&fig, LOOP);
    // 3000 samples, min/max-decimated as the line figures are.
    assert_eq!(st.legend, ["measured (2000 of 3000 samples)"]);
    assert!(fig.caption.contains("no regular oscillation"));
    insta::assert_snapshot!("detection_pv_op_no_ellipse", st.summary());
}

#[test]
fn detection_cross_correlation() {
    let l = sticky();
    let reg = registration(&l.sp, &l.pv, &l.op);
    let cc = detection::figures::cross_correlation(&reg).unwrap();
    let t = cc.period.expect("a limit cycle");
    assert_eq!(cc.max_lag, (t / 2.0).round() as usize);
    let fig = figures::cross_correlation(&sticky_signals(l), &cc, "detection-xcorr").unwrap();
    let st = checked(&fig, STICKY);
    assert_eq!(
        st.legend,
        [
            "lag 0".to_string(),
            format!("r(lag), odd share {:.2}", cc.odd_share),
            format!("±T/4 = ±{:.0} s", t / 4.0)
        ]
    );
    assert_eq!(st.axes, ["cross-correlation OP-PV (-)", "lag (s)"]);
    insta::assert_snapshot!("detection_xcorr", st.summary());
    // Without a regular oscillation: the fixed lags, no quarter periods, no odd share.
    let p = paper();
    let reg = registration(&p.sp, &p.pv, &p.op);
    let cc = detection::figures::cross_correlation(&reg).unwrap();
    assert_eq!(cc.max_lag, detection::figures::FIXED_LAGS);
    let fig = figures::cross_correlation(&signals(p), &cc, "detection-xcorr").unwrap();
    let st = checked(&fig, LOOP);
    assert_eq!(st.legend, ["lag 0", "r(lag)"]);
    assert!(fig.caption.contains("does not judge it"), "{}", fig.caption);
}

#[test]
fn check_plot_rejects_a_figure_of_another_loop() {
    let p = paper();
    let fig = figures::time_trends(&signals(p), &p.arx, ARX, "trends").unwrap();
    let err = inspect::check_plot(&fig.svg, "some other loop").unwrap_err();
    assert!(err.contains("does not name the loop"), "{err}");
}
