//! The detection section and the `detect` page from typed results: the test table, the two
//! figures drawn from the registration the tests judged (each passing `check_plot`), and a
//! record the detector could not take.
#![allow(clippy::unwrap_used)]

mod common;

use datasets::LoopData;
use report::inspect;
use report::pages::{detect_page, detection_section};
use report::{Block, Report};

/// The sticky limit cycle of the snapshot tests as the reader would give it (file `sticky.csv`).
fn sticky() -> LoopData {
    let sim = common::sticky_simulation();
    LoopData {
        source: "plant/sticky.csv".into(),
        start: None,
        t: Some(sim.t),
        sp: Some(sim.sp),
        pv: Some(sim.pv),
        op: sim.op,
        mv: None,
        notes: Vec::new(),
    }
}

fn tables(r: &Report) -> Vec<(&Vec<String>, &Vec<Vec<String>>)> {
    r.sections
        .iter()
        .flat_map(|s| &s.blocks)
        .filter_map(|b| match b {
            Block::Table { header, rows } => Some((header, rows)),
            _ => None,
        })
        .collect()
}

#[test]
fn detect_page_has_the_verdict_the_test_table_and_two_checked_figures() {
    let d = sticky();
    let view = monitoring::detect_file(&d, None, monitoring::Integrating::No);
    let det = view.detected.detection().unwrap();
    let a = monitoring::analyse(&d, None, monitoring::Integrating::No);
    let answer = monitoring::Answer::new(&a, &view.detected, None);
    let page = detect_page(&d, det, &view.figures, &answer).unwrap();
    assert_eq!(page.title, "detect: loop sticky");
    // the record's one answer, as the command computed it, is on the page
    let line = format!("Answer: {}.", answer.line());
    assert!(
        page.sections[0]
            .blocks
            .iter()
            .any(|b| matches!(b, Block::Paragraph(p) if *p == line)),
        "no {line:?} on the page"
    );
    let verdict = page.sections[0]
        .blocks
        .iter()
        .find_map(|b| match b {
            Block::Verdict(v) => Some(v.clone()),
            _ => None,
        })
        .unwrap();
    assert_eq!(
        verdict,
        format!(
            "Detection: {} ({}).",
            det.verdict,
            report::text::score_and_tests(det)
        )
    );
    let t = tables(&page);
    assert_eq!(t.len(), 1);
    let (header, rows) = t[0];
    assert_eq!(*header, ["test", "statistic", "verdict", "evidence"]);
    assert_eq!(rows.len(), det.tests.len());
    for (row, test) in rows.iter().zip(&det.tests) {
        assert_eq!(row[0], test.name);
        assert_eq!(row[2], test.verdict.as_str());
        assert_eq!(row[3], test.evidence);
    }
    let figs: Vec<_> = page.figures().collect();
    let names: Vec<&str> = figs.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["detection-pv-op", "detection-xcorr"]);
    for f in figs {
        inspect::check_plot(&f.svg, "sticky").unwrap_or_else(|e| panic!("{}: {e}", f.name));
    }
    // The cross-correlation's odd share is Horch's statistic; the limit cycle has its ellipse.
    let horch = det.tests.iter().find(|t| t.name == "horch-xcorr").unwrap();
    let html = page.to_html(false);
    assert!(html.contains(&format!("Its odd share is {:.2}", horch.statistic.unwrap())));
    assert!(html.contains("Choudhury&#39;s apparent stiction"));
}

#[test]
fn a_record_the_detector_cannot_take_gets_its_reason_and_no_figure() {
    let mut d = sticky();
    d.sp.as_mut().unwrap().pop();
    let view = monitoring::detect_file(&d, None, monitoring::Integrating::No);
    assert!(view.detected.detection().is_none());
    let sec = detection_section(&d, &view, false).unwrap();
    assert!(sec.blocks.iter().all(|b| !matches!(b, Block::Figure(_))));
    let Block::Paragraph(first) = &sec.blocks[0] else {
        panic!("{:?}", sec.blocks[0]);
    };
    assert!(
        first.starts_with("Detection: inconclusive (no score)"),
        "{first}"
    );
    assert!(first.contains("different lengths"), "{first}");
}

#[test]
fn a_flat_op_has_the_table_and_the_pv_op_plot_but_no_cross_correlation() {
    let mut d = sticky();
    d.op = vec![30.0; d.op.len()];
    let view = monitoring::detect_file(&d, None, monitoring::Integrating::No);
    let sec = detection_section(&d, &view, false).unwrap();
    let names: Vec<&str> = sec
        .blocks
        .iter()
        .filter_map(|b| match b {
            Block::Figure(f) => Some(f.name.as_str()),
            _ => None,
        })
        .collect();
    assert_eq!(names, ["detection-pv-op"]);
    assert!(sec.blocks.iter().any(|b| matches!(
        b,
        Block::Note(n) if n.starts_with("No cross-correlation: OP is flat")
    )));
}
