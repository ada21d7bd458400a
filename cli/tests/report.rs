//! `--report DIR` end to end, in memory: every figure written passes
//! `report::inspect::check_plot` (title with loop and model, axes with units, a legend), the
//! page inlines each figure once, refused data still get a page, and the reports of all the
//! plant loops in `../shared/data/plant` render.
#![allow(clippy::unwrap_used)]

mod common;
use common::{run, run_ok};

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;
use report::inspect;

/// The example's loop name in titles (`reporting::loop_name`).
const EXAMPLE: &str = "paper (example)";

/// A fresh directory under the system's temp dir, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> TempDir {
        static N: AtomicUsize = AtomicUsize::new(0);
        let p = std::env::temp_dir().join(format!(
            "stiction-report-test-{}-{}-{tag}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }

    fn path(&self) -> &Path {
        &self.0
    }

    fn arg(&self, sub: &str) -> String {
        self.0.join(sub).display().to_string()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The files of `dir` ending in `.ext`, sorted.
fn files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|e| e == ext))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Check a report directory: `index.html` exists, every `*.svg` passes `check_plot` with
/// `loop_name` and is inline in the page (once per file), one `<svg` and one `<figure` per
/// file.
/// Returns the page and the number of figures.
fn check_report(dir: &Path, loop_name: &str) -> Result<(String, usize), String> {
    let index = dir.join("index.html");
    let html = std::fs::read_to_string(&index).map_err(|e| format!("{}: {e}", index.display()))?;
    let svgs = files(dir, "svg");
    let texts = svgs
        .iter()
        .map(|f| std::fs::read_to_string(f).map_err(|e| format!("{}: {e}", f.display())))
        .collect::<Result<Vec<String>, String>>()?;
    for (f, svg) in svgs.iter().zip(&texts) {
        inspect::check_plot(svg, loop_name).map_err(|e| format!("{}: {e}", f.display()))?;
        // Inline once per file with this content (two figures can be the same picture).
        let same = texts.iter().filter(|t| *t == svg).count();
        let inline = html.matches(svg.trim_end()).count();
        if inline != same {
            return Err(format!(
                "{}: inline {inline} times, expected {same}",
                f.display()
            ));
        }
    }
    let (n_svg, n_fig) = (
        html.matches("<svg").count(),
        html.matches("<figure").count(),
    );
    if n_svg != svgs.len() || n_fig != svgs.len() {
        return Err(format!(
            "{}: {n_svg} <svg and {n_fig} <figure for {} figure files",
            index.display(),
            svgs.len()
        ));
    }
    Ok((html, svgs.len()))
}

#[test]
fn compare_example_report_with_png() {
    let dir = TempDir::new("compare");
    let out = dir.arg("report");
    let o = run(
        &["compare", "--example", "paper", "--report", &out, "--png"],
        b"",
    );
    if !report::PNG {
        // A CLI built without the `png` feature (e.g. `cargo test -p stiction-cli` alone;
        // `cargo xtask test` builds the workspace, where the report crate's default has it)
        // refuses `--png` up front, saying how to get it.
        println!("skipping the PNG half: this build of the CLI has no `png` feature");
        assert_eq!(o.code, 2, "{}", o.stderr);
        assert!(o.stderr.contains("--features png"), "{}", o.stderr);
        return;
    }
    assert_eq!(o.code, 0, "{}", o.stderr);
    assert!(o.stderr.contains("report: "), "{}", o.stderr);
    let out = Path::new(&out);
    let (html, n) = check_report(out, EXAMPLE).unwrap_or_else(|e| panic!("{e}"));
    // Time trends, phase plots and fit surface of each of the 2 × 5 default combinations.
    assert_eq!(n, 30, "figures");
    assert!(html.contains("kano × arx") && html.contains("he × earmax"));
    let svgs = files(out, "svg");
    let pngs = files(out, "png");
    assert_eq!(pngs.len(), svgs.len(), "one PNG per SVG");
    for s in &svgs {
        let png = std::fs::read(s.with_extension("png")).unwrap();
        assert!(png.len() > 1000, "{}: {} bytes", s.display(), png.len());
        assert!(
            png.starts_with(b"\x89PNG\r\n\x1a\n"),
            "{}: not a PNG",
            s.display()
        );
    }
}

#[test]
fn diagnose_example_report() {
    let dir = TempDir::new("diagnose");
    let out = dir.arg("report");
    run_ok(&["diagnose", "--example", "paper", "--report", &out], b"");
    let (html, n) = check_report(Path::new(&out), EXAMPLE).unwrap_or_else(|e| panic!("{e}"));
    assert!(n >= 3, "{n} figures");
    detection_section(&html);
}

/// The detection section of the quantify and diagnose pages: the detector's line as the text
/// output ends, the test table, the PV-OP plot and the cross-correlation.
fn detection_section(html: &str) {
    let at = html
        .find("<h2>Detection: is it the valve?</h2>")
        .expect("a detection section");
    let sec = &html[at..];
    assert!(sec.contains("<p>Detection: stiction (score"), "{sec}");
    assert!(sec.contains("<th class=\"t\">test</th><th>statistic</th>"));
    assert!(sec.contains("<td class=\"t nw\">horch-xcorr</td>"));
    assert!(sec.contains("<figure id=\"detection-pv-op\">"));
    assert!(sec.contains("<figure id=\"detection-xcorr\">"));
}

#[test]
fn quantify_example_report_has_the_detection_section() {
    let dir = TempDir::new("quantify");
    let out = dir.arg("report");
    run_ok(&["quantify", "--example", "paper", "--report", &out], b"");
    let (html, n) = check_report(Path::new(&out), EXAMPLE).unwrap_or_else(|e| panic!("{e}"));
    // Time trends, phase plots, fit surface; PV-OP plot and cross-correlation.
    assert_eq!(n, 5, "figures");
    detection_section(&html);
}

#[test]
fn refused_data_get_a_report_and_a_failure() {
    let dir = TempDir::new("refused");
    // Every time stamp twice: duplicated rows, which the reader refuses.
    let mut csv = String::from("t,SP,PV,OP\n");
    for k in 0..300 {
        let x = k as f64;
        csv.push_str(&format!(
            "{},50,{:.4},{:.4}\n",
            k / 2,
            50.0 + (x / 7.0).cos(),
            40.0 + 5.0 * (x / 10.0).sin()
        ));
    }
    let file = dir.path().join("dup-times.csv");
    std::fs::write(&file, csv).unwrap();
    let out = dir.arg("report");
    let file_arg = file.display().to_string();
    let o = run(&["quantify", &file_arg, "--report", &out], b"");
    assert_eq!(o.code, 1, "{}", o.stderr);
    let errors: Vec<&str> = o
        .stderr
        .lines()
        .filter(|l| l.starts_with("error:"))
        .collect();
    assert_eq!(errors.len(), 1, "one error line: {}", o.stderr);
    assert!(errors[0].contains(&file_arg), "{}", errors[0]);
    let (html, n) = check_report(Path::new(&out), "dup-times").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(n, 1, "the raw columns");
    let msg = errors[0].trim_start_matches("error:").trim();
    assert!(
        html.contains(&report::html::escape(msg)),
        "the page has the error {msg:?}"
    );
    assert!(html.contains("refused"));
}

/// `../shared/data/plant`, next to the workspace.
const PLANT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/plant");

#[test]
fn reports_of_all_plant_loops_render() {
    let plant = Path::new(PLANT);
    if !plant.is_dir() {
        println!("SKIPPED: no plant data at {}", plant.display());
        return;
    }
    let started = Instant::now();
    let csvs: Vec<PathBuf> = files(plant, "csv")
        .into_iter()
        .filter(|p| p.file_name().is_some_and(|n| n != "labels.csv"))
        .collect();
    assert!(!csvs.is_empty(), "no CSV in {}", plant.display());
    let dir = TempDir::new("plant");
    let results: Vec<Result<usize, String>> = csvs
        .par_iter()
        .map(|csv| {
            let stem = csv.file_stem().unwrap().to_string_lossy().into_owned();
            let out = dir.arg(&stem);
            let o = run(
                &["diagnose", &csv.display().to_string(), "--report", &out],
                b"",
            );
            let refused = stem.starts_with("FIC10112_");
            let want = if refused { 1 } else { 0 };
            if o.code != want {
                return Err(format!(
                    "{stem}: exit {} (expected {want}): {}",
                    o.code, o.stderr
                ));
            }
            let (html, n) = check_report(Path::new(&out), &stem)?;
            if refused && !html.contains("refused") {
                return Err(format!(
                    "{stem}: the page does not say the data were refused"
                ));
            }
            if !refused && n < 3 {
                return Err(format!("{stem}: {n} figures"));
            }
            Ok(n)
        })
        .collect();
    let failures: Vec<&String> = results.iter().filter_map(|r| r.as_ref().err()).collect();
    let figures: usize = results.iter().filter_map(|r| r.as_ref().ok()).sum();
    println!(
        "plant reports: {} files, {} reports, {} figures, {:.1} s",
        csvs.len(),
        results.iter().filter(|r| r.is_ok()).count(),
        figures,
        started.elapsed().as_secs_f64()
    );
    assert!(
        failures.is_empty(),
        "{} of {} loops:\n{}",
        failures.len(),
        csvs.len(),
        failures
            .iter()
            .map(|s| s.as_str())
            .collect::<Vec<_>>()
            .join("\n")
    );
}
