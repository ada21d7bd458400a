//! What a report costs beside the search it reports on, in one run (`cargo xtask bench`):
//! the kano × arx search of the paper's example loop (3000 samples, default grid), the three
//! figures of a quantify report, the whole page, and one figure as PNG.
#![allow(missing_docs, clippy::unwrap_used)]

use std::sync::OnceLock;

use grid_search::{quantify, GridPlan, Problem, Quantification, SearchOptions};
use report::{figures, Block, LoopSignals, Report, Section};
use stiction_models::{find_model, Kano};

fn main() {
    divan::main();
}

struct Case {
    op: Vec<f64>,
    pv: Vec<f64>,
    sp: Vec<f64>,
    opts: SearchOptions,
    q: Quantification,
}

fn search(op: &[f64], pv: &[f64], opts: &SearchOptions) -> Quantification {
    let entry = find_model("kano").unwrap();
    let id = (linear_id::find_identifier("arx").unwrap().build)(&[]).unwrap();
    quantify(entry, id.as_ref(), Problem { op, pv, mv: None }, opts, None).unwrap()
}

fn case() -> &'static Case {
    static CASE: OnceLock<Case> = OnceLock::new();
    CASE.get_or_init(|| {
        let scenario = datasets::simulate::Scenario {
            valve: Box::new(Kano::params().s(9.0).j(3.0).check().unwrap()),
            ..Default::default()
        };
        let d = scenario.simulate().unwrap().to_loop_data();
        let pv = d.pv.clone().unwrap();
        let span = d.op.iter().cloned().fold(f64::MIN, f64::max)
            - d.op.iter().cloned().fold(f64::MAX, f64::min);
        let opts = SearchOptions {
            grid: GridPlan::for_span(span),
            ..Default::default()
        };
        let q = search(&d.op, &pv, &opts);
        Case {
            sp: d.sp.clone().unwrap_or_else(|| vec![0.0; d.op.len()]),
            op: d.op,
            pv,
            opts,
            q,
        }
    })
}

fn signals(c: &Case) -> LoopSignals<'_> {
    LoopSignals {
        name: "paper",
        t: None,
        sp: Some(&c.sp),
        pv: &c.pv,
        op: &c.op,
        mv: None,
        span_unknown: false,
    }
}

fn quantify_report(c: &Case) -> Report {
    let sig = signals(c);
    let mut sec = Section::new("Figures");
    sec.push(Block::Figure(
        figures::time_trends(&sig, &c.q, "kano × arx", "trends").unwrap(),
    ));
    sec.push(Block::Figure(
        figures::phase_plots(&sig, &c.q, "kano × arx", "phase").unwrap(),
    ));
    sec.push(Block::Figure(
        figures::fit_surface(&c.q, ("paper", false), "kano × arx", "surface").unwrap(),
    ));
    Report {
        title: "bench".into(),
        subtitle: String::new(),
        summary: Vec::new(),
        sections: vec![sec],
    }
}

/// The search being reported on (the reference for the ratios).
#[divan::bench(sample_count = 10)]
fn search_kano_arx() -> Quantification {
    let c = case();
    search(&c.op, &c.pv, &c.opts)
}

#[divan::bench]
fn figure_time_trends() -> String {
    let c = case();
    figures::time_trends(&signals(c), &c.q, "kano × arx", "trends")
        .unwrap()
        .svg
}

#[divan::bench]
fn figure_phase_plots() -> String {
    let c = case();
    figures::phase_plots(&signals(c), &c.q, "kano × arx", "phase")
        .unwrap()
        .svg
}

#[divan::bench]
fn figure_fit_surface() -> String {
    let c = case();
    figures::fit_surface(&c.q, ("paper", false), "kano × arx", "surface")
        .unwrap()
        .svg
}

/// The three figures and the page of a `quantify --report`, in memory.
#[divan::bench]
fn quantify_report_page() -> String {
    quantify_report(case()).to_html(false)
}

/// One figure rasterised to PNG (what `--png` adds per figure).
#[divan::bench(sample_count = 10)]
fn png_time_trends() -> Vec<u8> {
    let c = case();
    let svg = figures::time_trends(&signals(c), &c.q, "kano × arx", "trends")
        .unwrap()
        .svg;
    report::chart::svg_to_png(&svg).unwrap()
}
