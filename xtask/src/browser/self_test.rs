//! The self-test: hand-written good and broken pages that the check must pass and fail.

use super::*;

/// A figure file for the self-test pages.
pub(crate) const SELF_TEST_SVG: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60" height="30"><rect width="60" height="30" fill="steelblue"/></svg>"#;

/// Self-test pages: (name, html, what the problems must mention; empty = the page must pass).
/// The missing image must be caught twice: as an `<img>` that did not load and as a failed
/// resource load in the console (`Log.entryAdded`).
pub(crate) const SELF_TEST_PAGES: &[(&str, &str, &[&str])] = &[
    (
        "good",
        r#"<!doctype html><html><head><meta charset="utf-8"><title>good</title></head><body>
<h1>good</h1>
<svg width="100" height="50"><line x1="0" y1="0" x2="100" y2="50" stroke="black"/></svg>
<p><img src="fig.svg" alt="fig"> <a href="fig.svg">fig.svg</a></p>
</body></html>"#,
        &[],
    ),
    (
        "missing-image",
        r#"<!doctype html><html><head><meta charset="utf-8"><title>missing image</title></head><body>
<img src="missing.svg" alt="missing">
</body></html>"#,
        &[
            "<img src=\"missing.svg\"> did not load",
            "ERR_FILE_NOT_FOUND",
        ],
    ),
    (
        "console-error",
        r#"<!doctype html><html><head><meta charset="utf-8"><title>console error</title></head><body>
<svg width="100" height="50"><line x1="0" y1="0" x2="100" y2="50" stroke="black"/></svg>
<script>console.error("boom")</script>
</body></html>"#,
        &["console.error: boom"],
    ),
    (
        "missing-link",
        r#"<!doctype html><html><head><meta charset="utf-8"><title>missing link</title></head><body>
<svg width="100" height="50"><line x1="0" y1="0" x2="100" y2="50" stroke="black"/></svg>
<a href="gone.svg">gone.svg</a>
</body></html>"#,
        &["links to \"gone.svg\""],
    ),
    (
        "zero-size-svg",
        r#"<!doctype html><html><head><meta charset="utf-8"><title>zero size</title></head><body>
<svg width="0" height="50"><line x1="0" y1="0" x2="100" y2="50" stroke="black"/></svg>
</body></html>"#,
        &["zero size"],
    ),
    (
        "unreadable-figure",
        r#"<!doctype html><html><head><meta charset="utf-8"><title>unreadable figure</title></head><body>
<figure><svg width="300" height="100" viewBox="0 0 300 100"><text x="10" y="50" font-size="8">tiny</text></svg></figure>
</body></html>"#,
        &["text drawn at 8.0 px", "of the page width"],
    ),
];

/// Checks hand-written pages and fails unless the good one passes and every broken one fails
/// for the expected reason.
pub(crate) fn self_test(browser: &mut Browser) -> Result<()> {
    let started = Instant::now();
    let dir = TempDir::new("stiction-report-check-selftest")?;
    let mut caught = Vec::new();
    for (name, html, expect) in SELF_TEST_PAGES {
        let page_dir = dir.path().join(name);
        std::fs::create_dir(&page_dir)
            .with_context(|| format!("creating {}", page_dir.display()))?;
        let page = page_dir.join("index.html");
        std::fs::write(&page, html).with_context(|| format!("writing {}", page.display()))?;
        let fig = page_dir.join("fig.svg");
        std::fs::write(&fig, SELF_TEST_SVG)
            .with_context(|| format!("writing {}", fig.display()))?;
        let shot = screenshot_path(&page);
        let r = browser
            .check_page(&page, &shot)
            .with_context(|| format!("self-test: checking the {name:?} page"))?;
        if expect.is_empty() {
            if !r.problems.is_empty() {
                bail!(
                    "self-test: the browser check fails a good page ({}):\n  {}",
                    page.display(),
                    r.problems.join("\n  ")
                );
            }
            if r.svgs != 1 || r.imgs != 1 {
                bail!("self-test: the browser check cannot see the figures of the good page: {} svg, {} img (expected 1 and 1)", r.svgs, r.imgs);
            }
            let png = std::fs::read(&shot)
                .with_context(|| format!("self-test: reading {}", shot.display()))?;
            if !png.starts_with(b"\x89PNG\r\n\x1a\n") {
                bail!("self-test: the screenshot {} is not a PNG", shot.display());
            }
            continue;
        }
        for needle in *expect {
            if !r.problems.iter().any(|p| p.contains(needle)) {
                bail!(
                    "self-test: the browser check cannot detect a {} (page {}: expected a problem mentioning {needle:?}, got {:?})",
                    name.replace('-', " "),
                    page.display(),
                    r.problems
                );
            }
        }
        caught.push(*name);
    }
    // A fleet page whose sort toggle is broken (the second click sorts like the first) must
    // fail the sort assertion.
    let fleet_dir = dir.path().join("fleet-broken-sort");
    let broken = fleet::write_example(&fleet_dir, |h| {
        assert!(
            h.contains(fleet::TOGGLE),
            "the fleet script has no {:?}",
            fleet::TOGGLE
        );
        h.replace(fleet::TOGGLE, "dir = dir;")
    })?;
    let r = browser
        .check_fleet(&broken)
        .context("self-test: driving the fleet page with a broken sort")?;
    if !r.problems.iter().any(|p| p.contains("after 2 click(s)")) {
        bail!(
            "self-test: the fleet check cannot detect a broken sort toggle (page {}: got {:?})",
            broken.index.display(),
            r.problems
        );
    }
    caught.push("fleet-broken-sort");
    eprintln!(
        "report-check: self-test ok in {:.1} s (good page passes; caught: {})",
        started.elapsed().as_secs_f64(),
        caught.join(", ")
    );
    Ok(())
}
