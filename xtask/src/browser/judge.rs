//! What one page's check found, and the rules that turn measurements and browser events
//! into problems.

use super::*;

/// The outcome of checking one page.
#[derive(Default)]
pub(crate) struct PageReport {
    pub(crate) elapsed: Duration,
    pub(crate) svgs: usize,
    pub(crate) imgs: usize,
    /// Console errors, uncaught exceptions and error log entries (failed loads).
    pub(crate) console_errors: usize,
    pub(crate) problems: Vec<String>,
    pub(crate) screenshot: Option<PathBuf>,
    /// Set when the screenshot does not show the whole page.
    pub(crate) screenshot_note: Option<String>,
}

impl PageReport {
    pub(crate) fn print(&self, page: &Path) {
        let secs = self.elapsed.as_secs_f64();
        let shot = self
            .screenshot
            .as_ref()
            .map(|p| match &self.screenshot_note {
                Some(note) => format!("{} {note}", p.display()),
                None => p.display().to_string(),
            })
            .unwrap_or_else(|| "none".to_string());
        let verdict = if self.problems.is_empty() {
            "ok  "
        } else {
            "FAIL"
        };
        println!(
            "{verdict}  {}: {} figures ({} svg, {} img), {} console errors, {secs:.1} s, screenshot {shot}",
            page.display(),
            self.svgs + self.imgs,
            self.svgs,
            self.imgs,
            self.console_errors,
        );
        for p in &self.problems {
            println!("        {p}");
        }
    }
}

/// What [`MEASURE_JS`] returns.
#[derive(Default)]
pub(crate) struct Measured {
    pub(crate) href: String,
    pub(crate) ready_state: String,
    /// (src attribute, complete, naturalWidth)
    pub(crate) imgs: Vec<(String, bool, f64)>,
    /// (label, width, height) of top-level svgs
    pub(crate) svgs: Vec<(String, f64, f64)>,
    /// (label, smallest text in CSS px, share of the page width) of the svgs in a `<figure>`
    pub(crate) figures: Vec<(String, Option<f64>, Option<f64>)>,
    /// (attribute as written, URL protocol, decoded path) of referenced figure files
    pub(crate) refs: Vec<(String, String, String)>,
}

impl Measured {
    pub(crate) fn from_json(v: &Value) -> Self {
        let s = |v: &Value, k: &str| v[k].as_str().unwrap_or_default().to_string();
        let list = |k: &str| v[k].as_array().cloned().unwrap_or_default();
        Measured {
            href: s(v, "href"),
            ready_state: s(v, "readyState"),
            imgs: list("imgs")
                .iter()
                .map(|i| {
                    (
                        s(i, "src"),
                        i["complete"].as_bool().unwrap_or(false),
                        i["naturalWidth"].as_f64().unwrap_or(0.0),
                    )
                })
                .collect(),
            svgs: list("svgs")
                .iter()
                .map(|i| {
                    (
                        s(i, "label"),
                        i["width"].as_f64().unwrap_or(0.0),
                        i["height"].as_f64().unwrap_or(0.0),
                    )
                })
                .collect(),
            figures: list("svgs")
                .iter()
                .filter(|i| i["share"].is_number())
                .map(|i| (s(i, "label"), i["minText"].as_f64(), i["share"].as_f64()))
                .collect(),
            refs: list("refs")
                .iter()
                .map(|i| (s(i, "raw"), s(i, "protocol"), s(i, "path")))
                .collect(),
        }
    }
}

/// Problems with the figures: images not loaded, zero-size svgs, no figure, missing files.
pub(crate) fn judge_figures(m: &Measured, report: &mut PageReport) {
    for (src, complete, natural_width) in &m.imgs {
        if !complete || *natural_width <= 0.0 {
            report.problems.push(format!(
                "<img src={src:?}> did not load (complete {complete}, naturalWidth {natural_width})"
            ));
        }
    }
    for (label, w, h) in &m.svgs {
        if *w <= 0.0 || *h <= 0.0 {
            report
                .problems
                .push(format!("<svg> {label} renders at zero size ({w} x {h})"));
        }
    }
    // Readable on a projector and on paper: every figure at the page's width, no text under
    // MIN_TEXT_PX as drawn in the viewport.
    for (label, min_text, share) in &m.figures {
        if let Some(px) = min_text.filter(|&px| px < MIN_TEXT_PX) {
            report.problems.push(format!(
                "figure {label}: text drawn at {px:.1} px (under {MIN_TEXT_PX} px at {} px wide)",
                VIEWPORT.0
            ));
        }
        if let Some(share) = share.filter(|&x| x < MIN_FIGURE_SHARE) {
            report.problems.push(format!(
                "figure {label}: {:.0} % of the page width (under {:.0} %)",
                100.0 * share,
                100.0 * MIN_FIGURE_SHARE
            ));
        }
    }
    if m.svgs.is_empty() && m.imgs.is_empty() {
        report
            .problems
            .push("the page has no figure (no <svg>, no <img>)".to_string());
    }
    let mut seen = BTreeSet::new();
    for (raw, protocol, path) in &m.refs {
        if !seen.insert(raw.clone()) {
            continue;
        }
        match protocol.as_str() {
            "file:" => {
                if !Path::new(path).is_file() {
                    report
                        .problems
                        .push(format!("links to {raw:?}, but {path} does not exist"));
                }
            }
            "data:" | "blob:" => {}
            other => report.problems.push(format!(
                "refers to the figure {raw:?} outside the report ({other} URL)"
            )),
        }
    }
}

/// Problems from the page's events: console errors, uncaught exceptions, error log entries.
pub(crate) fn judge_events(events: &[Value], report: &mut PageReport) {
    let mut seen = BTreeSet::new();
    for e in events {
        let p = &e["params"];
        let msg = match e["method"].as_str().unwrap_or_default() {
            "Runtime.consoleAPICalled" => {
                let kind = p["type"].as_str().unwrap_or_default();
                if kind != "error" && kind != "assert" {
                    continue;
                }
                let text: Vec<String> = p["args"]
                    .as_array()
                    .map(|args| {
                        args.iter()
                            .map(|a| match &a["value"] {
                                Value::String(s) => s.clone(),
                                Value::Null => {
                                    a["description"].as_str().unwrap_or_default().to_string()
                                }
                                v => v.to_string(),
                            })
                            .collect()
                    })
                    .unwrap_or_default();
                format!("console.{kind}: {}", text.join(" "))
            }
            "Runtime.exceptionThrown" => {
                let d = &p["exceptionDetails"];
                let text = d["exception"]["description"]
                    .as_str()
                    .or_else(|| d["text"].as_str())
                    .unwrap_or("(no description)");
                format!("uncaught exception: {text}")
            }
            "Log.entryAdded" => {
                let entry = &p["entry"];
                if entry["level"].as_str() != Some("error") {
                    continue;
                }
                let text = entry["text"].as_str().unwrap_or_default();
                match entry["url"].as_str() {
                    Some(u) if !u.is_empty() => format!("console error: {text} ({u})"),
                    _ => format!("console error: {text}"),
                }
            }
            _ => continue,
        };
        if seen.insert(msg.clone()) {
            report.console_errors += 1;
            report.problems.push(msg);
        }
    }
}
