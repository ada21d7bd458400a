//! `cargo xtask report-check`: open the HTML reports of the CLI (`--report DIR`) in headless
//! Chromium, the way a person would see them, and fail on what a person would notice: console
//! errors, uncaught exceptions, resources that fail to load, images that do not decode, plots
//! that render at zero size, links to figure files that do not exist. A full-page screenshot
//! of every page is saved next to it (`DIR/screenshot.png`).
//!
//! The browser is driven over the Chrome DevTools Protocol (CDP): Chromium is started with
//! `--remote-debugging-port=0`, prints `DevTools listening on ws://...` on stderr, and this
//! module talks JSON to that websocket ([`tungstenite`], synchronous). Every page gets its own
//! target (tab) attached in "flat" mode, so commands and events carry a `sessionId`.
//!
//! Besides the CLI's reports, the fleet page (`report::fleet`) of a synthetic fleet is written
//! into `OUT/fleet/`, checked like the others, and driven: sort by the benefit header, tag
//! filter, area select, the first row's `latest` link ([`fleet`]).
//!
//! Every run starts with a self-test on hand-written pages (a good one and broken ones, and a
//! fleet page whose sort toggle is broken) to prove that the check can fail.

use std::collections::{BTreeSet, VecDeque};
use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{bail, Context, Result};
use base64::Engine as _;
use serde_json::{json, Value};
use tungstenite::protocol::WebSocketConfig;
use tungstenite::{Message, WebSocket};

mod chromium;
mod fleet;
mod generate;
mod judge;
mod self_test;

use chromium::*;
use generate::*;
use judge::*;
use self_test::*;

const USAGE: &str = "\
usage: cargo xtask report-check [--out DIR] [--plant DIR] [--profile P] [--html FILE...]

  --out DIR      where the reports are generated (default target/report-check)
  --profile P    cargo profile of the CLI build (default release; CI uses test, which
                 `cargo xtask test` has already built)
  --plant DIR    also run `stiction diagnose FILE --report OUT/plant/STEM` for every *.csv in DIR
                 that has an OP column (e.g. ../shared/data/plant) and check each report
  --html FILE... check only these existing HTML files (no build, no generation)

Without --html: builds the CLI (`cargo build --profile P -p stiction-cli`), writes the reports of
the table REPORTS in xtask/src/browser.rs into OUT/<name>/ and the `detect` report of a sticky
loop written by `stiction simulate` (DETECT_LOOP) into OUT/detect/, and checks them. Each page
is loaded in headless Chromium (/usr/bin/chromium, or $CHROMIUM) and fails on: console errors,
uncaught exceptions, failed resource loads, <img> not loaded, top-level <svg> of zero size, no
figure at all, links to figure files that do not exist. Closed <details> are opened before
measuring. A full-page screenshot is saved next to each page (index.html -> screenshot.png,
X.html -> X.screenshot.png). Also writes the fleet page of six synthetic valves into OUT/fleet/
(report::fleet), checks it the same way and then drives it: a click on the benefit header sorts
largest first, a second smallest first; the tag filter and the area select leave the expected
rows and count; the first row's `latest` link opens its page without console errors
(OUT/fleet/sorted.screenshot.png after the first sort). A self-test on hand-written good and
broken pages (and a fleet page with a broken sort toggle) runs first.";

/// The reports generated in the default mode: (directory name under `--out`, CLI arguments).
/// `--report OUT/<name>` is appended to the arguments.
const REPORTS: &[(&str, &[&str])] = &[
    ("example", &["compare", "--example", "paper"]),
    ("example-diagnose", &["diagnose", "--example", "paper"]),
];

/// `detect` reads a file: the loop it is checked on is written first by `stiction simulate
/// ARGS -o OUT/sticky-loop.csv` (a sticky valve in a limit cycle, so the page has the PV-OP
/// ellipse as well as the cross-correlation), then `stiction detect OUT/sticky-loop.csv --report
/// OUT/detect`.
const DETECT_LOOP: &str = "simulate --plant slow --kc 0.3 --ki 0.1 --valve kano --param S=4 \
                           --param J=1 --noise 0.02 --samples 1000";

/// Chromium used when `$CHROMIUM` is not set (Debian package `chromium`).
const DEFAULT_CHROMIUM: &str = "/usr/bin/chromium";

/// Flags for a headless browser on a machine without network that may run as root.
const CHROMIUM_FLAGS: &[&str] = &[
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--no-default-browser-check",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-extensions",
    "--disable-dev-shm-usage",
    "--hide-scrollbars",
    "--mute-audio",
    "--remote-debugging-port=0",
];

/// How long one page may take (load, measurements, screenshot) before it fails.
const PAGE_TIMEOUT: Duration = Duration::from_secs(30);

/// How long Chromium may take to print its DevTools address.
const LAUNCH_TIMEOUT: Duration = Duration::from_secs(30);

/// Viewport (CSS pixels) the pages are laid out in.
const VIEWPORT: (u32, u32) = (1400, 900);

/// The smallest text a figure may draw, in CSS pixels in [`VIEWPORT`].
const MIN_TEXT_PX: f64 = 13.0;

/// The share of the page's width a figure must take.
const MIN_FIGURE_SHARE: f64 = 0.95;

/// Screenshots are cut at this height (CSS pixels).
const MAX_SCREENSHOT_HEIGHT: f64 = 32_000.0;

/// Parallel `stiction diagnose` runs for `--plant`.
const PLANT_JOBS: usize = 2;

/// Runs in the page after the load event: opens closed `<details>`, measures the figures and
/// lists the figure files the page refers to. Returns a JSON object (see [`Measured`]).
const MEASURE_JS: &str = r#"(() => {
  let opened = 0;
  for (const d of document.querySelectorAll('details:not([open])')) { d.open = true; opened++; }
  const resolve = (raw) => {
    try {
      const u = new URL(raw, document.baseURI);
      return { raw, protocol: u.protocol, path: decodeURIComponent(u.pathname) };
    } catch (e) {
      return { raw, protocol: '', path: '' };
    }
  };
  const short = (s) => (s.length > 60 ? s.slice(0, 57) + '...' : s);
  const imgs = Array.from(document.images, (im) => ({
    src: short(im.getAttribute('src') || ''),
    complete: im.complete,
    naturalWidth: im.naturalWidth,
  }));
  const svgs = Array.from(document.querySelectorAll('svg'))
    .filter((s) => !(s.parentElement && s.parentElement.closest('svg')))
    .map((s, i) => {
      const r = s.getBoundingClientRect();
      const title = s.querySelector(':scope > title');
      const label = s.id ? '#' + s.id
        : s.getAttribute('aria-label') || (title && title.textContent.trim()) || 'svg no. ' + (i + 1);
      // A figure's smallest text as drawn (its font size times the scale the page draws the
      // figure at) and the share of the page width the figure takes.
      const fig = s.closest('figure');
      let minText = null, share = null;
      if (fig) {
        for (const t of s.querySelectorAll('text')) {
          if (!t.textContent.trim()) continue;
          const m = t.getScreenCTM();
          const k = m ? Math.hypot(m.a, m.b) : 1;
          const px = parseFloat(getComputedStyle(t).fontSize) * k;
          if (minText === null || px < minText) minText = px;
        }
        const page = fig.parentElement.getBoundingClientRect().width;
        share = page > 0 ? r.width / page : null;
      }
      return { label: short(label), width: r.width, height: r.height, minText, share };
    });
  const figure = /\.(svg|png|jpe?g|gif|webp|pdf)$/i;
  const refs = [];
  for (const a of document.querySelectorAll('a[href]')) {
    const r = resolve(a.getAttribute('href'));
    if (figure.test(r.path)) refs.push(r);
  }
  for (const im of document.images) {
    const raw = im.getAttribute('src');
    if (raw) refs.push(resolve(raw));
  }
  return { href: location.href, readyState: document.readyState, opened, imgs, svgs, refs };
})()"#;

/// Command-line options of `report-check`.
struct Args {
    /// Where the reports are generated.
    out: PathBuf,
    /// Directory of plant CSV files to diagnose (`--plant`).
    plant: Option<PathBuf>,
    /// Existing pages to check instead of generating reports (`--html`).
    html: Vec<PathBuf>,
    /// Cargo profile the CLI is built with (`--profile`, default `release`).
    profile: String,
}

fn parse_args(rest: &[String]) -> Result<Args> {
    let mut a = Args {
        out: PathBuf::from("target/report-check"),
        plant: None,
        html: Vec::new(),
        profile: "release".into(),
    };
    let mut it = rest.iter().peekable();
    while let Some(flag) = it.next() {
        match flag.as_str() {
            "--out" => a.out = PathBuf::from(it.next().context("--out needs a directory")?),
            "--profile" => {
                a.profile = it
                    .next()
                    .context("--profile needs a cargo profile")?
                    .clone()
            }
            "--plant" => {
                a.plant = Some(PathBuf::from(
                    it.next().context("--plant needs a directory")?,
                ))
            }
            "--html" => {
                while let Some(f) = it.next_if(|f| !f.starts_with("--")) {
                    a.html.push(PathBuf::from(f));
                }
                if a.html.is_empty() {
                    bail!("--html needs at least one file\n{USAGE}");
                }
            }
            "-h" | "--help" => {
                println!("{USAGE}");
                std::process::exit(0);
            }
            other => bail!("unknown option {other:?}\n{USAGE}"),
        }
    }
    if !a.html.is_empty() && a.plant.is_some() {
        bail!("--html checks existing files only; it cannot be combined with --plant");
    }
    Ok(a)
}

/// `cargo xtask report-check`: see the module documentation and `USAGE`.
pub fn report_check(rest: &[String]) -> Result<()> {
    let args = parse_args(rest)?;
    let chromium = find_chromium()?;

    let started = Instant::now();
    let mut browser = Browser::launch(&chromium)?;
    eprintln!(
        "report-check: {} started in {:.1} s",
        chromium.display(),
        started.elapsed().as_secs_f64()
    );
    self_test(&mut browser)?;

    // Pages to check, and failures that happened before any page could be checked.
    let mut failures: Vec<(String, String)> = Vec::new();
    let mut pages = if args.html.is_empty() {
        generate(&args, &mut failures)?
    } else {
        args.html.clone()
    };

    // The fleet page (report::fleet) of a synthetic fleet: checked like every page, then
    // driven (sort, filters, link) below.
    let fleet = if args.html.is_empty() {
        let f = fleet::write_example(&args.out.join("fleet"), |h| h)?;
        eprintln!(
            "report-check: fleet page of {} synthetic valves written",
            fleet::example_valves().len()
        );
        pages.push(f.index.clone());
        Some(f)
    } else {
        None
    };

    let mut passed = 0usize;
    for page in &pages {
        let shot = screenshot_path(page);
        match browser.check_page(page, &shot) {
            Ok(r) => {
                r.print(page);
                if r.problems.is_empty() {
                    passed += 1;
                } else {
                    failures.push((page.display().to_string(), r.problems.join("\n")));
                }
            }
            Err(e) => {
                println!("FAIL  {}: the check did not finish: {e:#}", page.display());
                failures.push((
                    page.display().to_string(),
                    format!("the check did not finish: {e:#}"),
                ));
            }
        }
    }
    let mut checks = pages.len();
    if let Some(f) = &fleet {
        checks += 1;
        let what = format!("{} (sort, filters, link)", f.index.display());
        match browser.check_fleet(f) {
            Ok(r) => {
                let shot = r
                    .screenshot
                    .as_ref()
                    .map_or_else(|| "none".to_string(), |p| p.display().to_string());
                println!(
                    "{}  {what}: {} problems, {} console errors, {:.1} s, screenshot after sorting {shot}",
                    if r.problems.is_empty() { "ok  " } else { "FAIL" },
                    r.problems.len(),
                    r.console_errors,
                    r.elapsed.as_secs_f64(),
                );
                for p in &r.problems {
                    println!("        {p}");
                }
                if r.problems.is_empty() {
                    passed += 1;
                } else {
                    failures.push((what, r.problems.join("\n")));
                }
            }
            Err(e) => {
                println!("FAIL  {what}: the check did not finish: {e:#}");
                failures.push((what, format!("the check did not finish: {e:#}")));
            }
        }
    }
    drop(browser);

    if failures.is_empty() {
        println!(
            "report-check: all {passed} checks passed ({:.1} s); screenshots are next to the pages",
            started.elapsed().as_secs_f64()
        );
        return Ok(());
    }
    let mut msg = format!(
        "report-check: {} failure(s), {passed} of {checks} checks passed:",
        failures.len()
    );
    for (what, why) in &failures {
        msg.push_str(&format!("\n  {what}:"));
        for line in why.lines() {
            msg.push_str(&format!("\n      {line}"));
        }
    }
    bail!(msg)
}

/// The Chromium binary: `$CHROMIUM`, else `/usr/bin/chromium`.
fn find_chromium() -> Result<PathBuf> {
    let (path, from_env) = match std::env::var_os("CHROMIUM") {
        Some(p) if !p.is_empty() => (PathBuf::from(p), true),
        _ => (PathBuf::from(DEFAULT_CHROMIUM), false),
    };
    if !path.is_file() {
        if from_env {
            bail!(
                "CHROMIUM={} does not exist; point it at a Chromium binary or unset it to use {DEFAULT_CHROMIUM} (apt-get install -y chromium)",
                path.display()
            );
        }
        bail!("report-check needs Chromium at {DEFAULT_CHROMIUM} (or set CHROMIUM=/path/to/chromium); install it with `apt-get install -y chromium`");
    }
    Ok(path)
}

/// `index.html` -> `screenshot.png`, `X.html` -> `X.screenshot.png`, in the page's directory.
fn screenshot_path(page: &Path) -> PathBuf {
    let stem = page.file_stem().and_then(|s| s.to_str()).unwrap_or("page");
    let name = if stem == "index" {
        "screenshot.png".to_string()
    } else {
        format!("{stem}.screenshot.png")
    };
    page.with_file_name(name)
}
