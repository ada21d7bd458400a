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

mod fleet;

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

// ---------------------------------------------------------------------------------------------
// Report generation

/// Builds the CLI and writes the reports; returns the `index.html` files that exist. Commands
/// that fail are recorded in `failures` (with their stderr) and generation goes on.
fn generate(args: &Args, failures: &mut Vec<(String, String)>) -> Result<Vec<PathBuf>> {
    let exe = build_cli(&args.profile)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let mut pages = Vec::new();

    let detect_loop = args.out.join("sticky-loop.csv");
    let detect_args: Vec<std::ffi::OsString> =
        vec!["detect".into(), detect_loop.clone().into_os_string()];
    let mut runs: Vec<(&str, Vec<std::ffi::OsString>)> = REPORTS
        .iter()
        .map(|(name, cli_args)| (*name, cli_args.iter().map(Into::into).collect()))
        .collect();
    match simulate_loop(&exe, &detect_loop) {
        Ok(()) => runs.push(("detect", detect_args)),
        Err(e) => failures.push((format!("stiction {DETECT_LOOP}"), format!("{e:#}"))),
    }

    for (name, cli_args) in &runs {
        let dir = args.out.join(name);
        let started = Instant::now();
        let run = run_report(&exe, cli_args.iter().map(|s| s.as_os_str()), &dir)?;
        let secs = started.elapsed().as_secs_f64();
        let index = dir.join("index.html");
        let has_index = index.is_file();
        if run.success {
            if has_index {
                eprintln!("report-check: {} ({secs:.1} s)", run.command);
                pages.push(index);
            } else {
                failures.push((
                    run.command.clone(),
                    format!("exited successfully but wrote no {}", index.display()),
                ));
            }
        } else {
            eprintln!("report-check: FAILED {} ({})", run.command, run.status);
            failures.push((
                run.command.clone(),
                format!(
                    "failed ({}); its stderr:\n{}",
                    run.status,
                    tail(&run.stderr, 30)
                ),
            ));
            if has_index {
                pages.push(index);
            }
        }
    }

    if let Some(plant) = &args.plant {
        pages.extend(generate_plant(
            &exe,
            plant,
            &args.out.join("plant"),
            failures,
        )?);
        pages.extend(generate_trends(
            &exe,
            plant,
            &args.out.join("trend"),
            failures,
        )?);
        pages.extend(generate_audit(
            &exe,
            plant,
            &args.out.join("plant-fleet"),
            failures,
        )?);
    }
    Ok(pages)
}

/// `stiction audit PLANT --db OUT.sqlite --report OUT`: the fleet page of the plant data and
/// the page of each valve's latest registration.
fn generate_audit(
    exe: &Path,
    plant: &Path,
    out: &Path,
    failures: &mut Vec<(String, String)>,
) -> Result<Vec<PathBuf>> {
    let mut db = out.as_os_str().to_owned();
    db.push(".sqlite");
    let db = PathBuf::from(db);
    for suffix in ["", "-wal", "-shm"] {
        let mut p = db.as_os_str().to_owned();
        p.push(suffix);
        let _ = std::fs::remove_file(PathBuf::from(p));
    }
    let started = Instant::now();
    let cli_args: [&std::ffi::OsStr; 4] = [
        "audit".as_ref(),
        plant.as_os_str(),
        "--db".as_ref(),
        db.as_os_str(),
    ];
    let run = run_report(exe, cli_args.into_iter(), out)?;
    eprintln!(
        "report-check: {} ({:.1} s)",
        run.command,
        started.elapsed().as_secs_f64()
    );
    let index = out.join("index.html");
    if !(run.success && index.is_file()) {
        failures.push((
            run.command.clone(),
            format!(
                "failed ({}); its stderr:\n{}",
                run.status,
                tail(&run.stderr, 30)
            ),
        ));
        return Ok(Vec::new());
    }
    let mut pages = vec![index];
    if let Ok(entries) = std::fs::read_dir(out.join("valves")) {
        let mut valves: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path().join("index.html")))
            .filter(|p| p.is_file())
            .collect();
        valves.sort();
        pages.extend(valves);
    }
    Ok(pages)
}

/// `stiction simulate DETECT_LOOP -o csv`: the loop the `detect` page is checked on.
fn simulate_loop(exe: &Path, csv: &Path) -> Result<()> {
    let out = Command::new(exe)
        .args(DETECT_LOOP.split_whitespace())
        .arg("-o")
        .arg(csv)
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("could not start {}", exe.display()))?;
    if !out.status.success() {
        bail!(
            "failed ({}); its stderr:\n{}",
            out.status,
            tail(&String::from_utf8_lossy(&out.stderr), 30)
        );
    }
    Ok(())
}

/// `stiction trend DIR --valve TAG --report OUT/TAG` for every valve with two or more
/// registrations in `plant` (valve = file-name prefix before `_`).
fn generate_trends(
    exe: &Path,
    plant: &Path,
    out: &Path,
    failures: &mut Vec<(String, String)>,
) -> Result<Vec<PathBuf>> {
    let mut count: std::collections::BTreeMap<String, usize> = Default::default();
    for entry in std::fs::read_dir(plant).with_context(|| format!("reading {}", plant.display()))? {
        let path = entry?.path();
        if path.extension().and_then(|e| e.to_str()) != Some("csv") {
            continue;
        }
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        if let Some((valve, _)) = name.split_once('_') {
            *count.entry(valve.to_string()).or_default() += 1;
        }
    }
    let mut pages = Vec::new();
    for (valve, n) in count.into_iter().filter(|(_, n)| *n >= 2) {
        let dir = out.join(&valve);
        let started = Instant::now();
        let plant_arg = plant.display().to_string();
        let run = run_report(
            exe,
            ["trend", plant_arg.as_str(), "--valve", valve.as_str()]
                .into_iter()
                .map(std::ffi::OsStr::new),
            &dir,
        )?;
        let index = dir.join("index.html");
        eprintln!(
            "report-check: {} ({n} registrations, {:.1} s)",
            run.command,
            started.elapsed().as_secs_f64()
        );
        if run.success && index.is_file() {
            pages.push(index);
        } else {
            failures.push((
                run.command.clone(),
                format!(
                    "exit {}, index.html written: {}; its stderr:\n{}",
                    run.status,
                    index.is_file(),
                    tail(&run.stderr, 30)
                ),
            ));
        }
    }
    Ok(pages)
}

/// `cargo build --profile PROFILE -p stiction-cli --bin stiction`; returns the binary's path.
/// (`test` reuses what `cargo xtask test` built, which is how CI runs the check.)
fn build_cli(profile: &str) -> Result<PathBuf> {
    crate::status(crate::cargo().args([
        "build",
        "--profile",
        profile,
        "-p",
        "stiction-cli",
        "--bin",
        "stiction",
    ]))?;
    let dir = match profile {
        "dev" | "test" => "debug",
        "bench" => "release",
        other => other,
    };
    let exe = target_dir()?
        .join(dir)
        .join(format!("stiction{}", std::env::consts::EXE_SUFFIX));
    if !exe.is_file() {
        bail!(
            "`cargo build --profile {profile} -p stiction-cli` succeeded but {} does not exist",
            exe.display()
        );
    }
    Ok(exe)
}

/// Cargo's target directory (honours `CARGO_TARGET_DIR` and `build.target-dir`).
fn target_dir() -> Result<PathBuf> {
    let mut cmd = crate::cargo();
    cmd.args(["metadata", "--format-version", "1", "--no-deps"]);
    let out = cmd
        .output()
        .with_context(|| format!("could not start {cmd:?}"))?;
    if !out.status.success() {
        bail!(
            "{cmd:?} failed ({}):\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let meta: Value = serde_json::from_slice(&out.stdout).context("parsing `cargo metadata`")?;
    let dir = meta["target_directory"]
        .as_str()
        .context("`cargo metadata` has no target_directory")?;
    Ok(PathBuf::from(dir))
}

/// What one `stiction ... --report DIR` run did.
struct ReportRun {
    /// The command line, for messages.
    command: String,
    success: bool,
    /// Exit status, for messages.
    status: String,
    stderr: String,
}

/// Runs `stiction ARGS --report DIR` into a fresh `DIR` (an old `DIR` is removed first, so a
/// stale `index.html` cannot pass for a new one).
fn run_report<'a>(
    exe: &Path,
    cli_args: impl Iterator<Item = &'a std::ffi::OsStr>,
    dir: &Path,
) -> Result<ReportRun> {
    if dir.exists() {
        std::fs::remove_dir_all(dir)
            .with_context(|| format!("removing the old report {}", dir.display()))?;
    }
    if let Some(parent) = dir.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    let mut cmd = Command::new(exe);
    cmd.args(cli_args).arg("--report").arg(dir);
    let command = format!(
        "stiction {}",
        cmd.get_args()
            .map(|a| a.to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(" ")
    );
    let out = cmd
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("could not start {}", exe.display()))?;
    Ok(ReportRun {
        command,
        success: out.status.success(),
        status: out.status.to_string(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    })
}

/// The last `n` lines of `s`, indented, or a note that it is empty.
fn tail(s: &str, n: usize) -> String {
    let lines: Vec<&str> = s.lines().collect();
    if lines.is_empty() {
        return "    (nothing on stderr)".to_string();
    }
    let skip = lines.len().saturating_sub(n);
    let mut out = String::new();
    if skip > 0 {
        out.push_str(&format!("    ... ({skip} earlier lines)\n"));
    }
    let shown: Vec<String> = lines[skip..].iter().map(|l| format!("    {l}")).collect();
    out.push_str(&shown.join("\n"));
    out
}

/// Does the first line of the CSV file name an `OP` column? (`labels.csv` does not.)
fn has_op_column(path: &Path) -> Result<bool> {
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let mut header = String::new();
    BufReader::new(file)
        .read_line(&mut header)
        .with_context(|| format!("reading the header of {}", path.display()))?;
    Ok(header
        .split(',')
        .any(|c| c.trim().trim_matches('"').eq_ignore_ascii_case("op")))
}

/// `stiction diagnose FILE --report OUT/STEM` for every loop CSV in `plant`, [`PLANT_JOBS`] at
/// a time. A non-zero exit is fine if the report (explaining the refusal) was written.
fn generate_plant(
    exe: &Path,
    plant: &Path,
    out: &Path,
    failures: &mut Vec<(String, String)>,
) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(plant).with_context(|| format!("listing {}", plant.display()))? {
        let path = entry
            .with_context(|| format!("listing {}", plant.display()))?
            .path();
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
        {
            if has_op_column(&path)? {
                files.push(path);
            } else {
                eprintln!(
                    "report-check: skipping {} (no OP column)",
                    path.file_name().unwrap_or_default().to_string_lossy()
                );
            }
        }
    }
    files.sort();
    if files.is_empty() {
        bail!("--plant {}: no CSV file with an OP column", plant.display());
    }

    let n = files.len();
    let done = AtomicUsize::new(0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(PLANT_JOBS)
        .build()
        .context("starting the worker threads")?;
    let results: Vec<Result<(PathBuf, ReportRun, f64)>> = pool.install(|| {
        use rayon::prelude::*;
        files
            .par_iter()
            .map(|file| {
                let stem = file
                    .file_stem()
                    .with_context(|| format!("{} has no file name", file.display()))?;
                let dir = out.join(stem);
                let started = Instant::now();
                let args = [std::ffi::OsStr::new("diagnose"), file.as_os_str()];
                let run = run_report(exe, args.into_iter(), &dir)?;
                let secs = started.elapsed().as_secs_f64();
                let k = done.fetch_add(1, Ordering::SeqCst) + 1;
                let what = match (run.success, dir.join("index.html").is_file()) {
                    (true, true) => "report written".to_string(),
                    (false, true) => format!("{}, refusal report written", run.status),
                    (true, false) => "FAILED: exited successfully but no index.html".to_string(),
                    (false, false) => format!("FAILED: {}, no index.html", run.status),
                };
                eprintln!(
                    "report-check: [{k:>w$}/{n}] {}: {what} ({secs:.1} s)",
                    stem.to_string_lossy(),
                    w = n.to_string().len()
                );
                Ok((dir, run, secs))
            })
            .collect()
    });

    let mut pages = Vec::new();
    for r in results {
        let (dir, run, _) = r?;
        let index = dir.join("index.html");
        if index.is_file() {
            pages.push(index);
        } else {
            failures.push((
                run.command.clone(),
                format!(
                    "wrote no {} ({}); its stderr:\n{}",
                    index.display(),
                    run.status,
                    tail(&run.stderr, 10)
                ),
            ));
        }
    }
    Ok(pages)
}

// ---------------------------------------------------------------------------------------------
// Self-test

/// A figure file for the self-test pages.
const SELF_TEST_SVG: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60" height="30"><rect width="60" height="30" fill="steelblue"/></svg>"#;

/// Self-test pages: (name, html, what the problems must mention; empty = the page must pass).
/// The missing image must be caught twice: as an `<img>` that did not load and as a failed
/// resource load in the console (`Log.entryAdded`).
const SELF_TEST_PAGES: &[(&str, &str, &[&str])] = &[
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
fn self_test(browser: &mut Browser) -> Result<()> {
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

// ---------------------------------------------------------------------------------------------
// Browser and DevTools protocol

/// A directory under the system temp dir, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(prefix: &str) -> Result<Self> {
        let nanos = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        let path = std::env::temp_dir().join(format!("{prefix}-{}-{nanos}", std::process::id()));
        std::fs::create_dir(&path).with_context(|| format!("creating {}", path.display()))?;
        Ok(TempDir(path))
    }

    fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        // Chromium's helper processes may still be writing to the profile for a moment.
        for _ in 0..20 {
            if std::fs::remove_dir_all(&self.0).is_ok() || !self.0.exists() {
                return;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        eprintln!("report-check: could not remove {}", self.0.display());
    }
}

/// A running headless Chromium and the DevTools connection to it. Dropping it closes the
/// browser (killing it if it does not exit) and removes its temporary profile.
struct Browser {
    cdp: Option<Cdp>,
    child: Child,
    /// Declared after `child` so the profile is removed after the browser has exited.
    _profile: TempDir,
}

impl Browser {
    fn launch(exe: &Path) -> Result<Self> {
        let profile = TempDir::new("stiction-report-check-profile")?;
        let child = Command::new(exe)
            .args(CHROMIUM_FLAGS)
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg("about:blank")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .with_context(|| format!("could not start {}", exe.display()))?;
        let mut browser = Browser {
            cdp: None,
            child,
            _profile: profile,
        };
        let stderr = browser
            .child
            .stderr
            .take()
            .context("Chromium's stderr is not captured")?;

        // Read stderr in a thread for the whole life of the browser (a full pipe would block
        // it); pass on the DevTools address, keep the last lines for error messages.
        let last_lines = Arc::new(Mutex::new(VecDeque::new()));
        let (tx, rx) = mpsc::channel();
        {
            let last_lines = Arc::clone(&last_lines);
            std::thread::spawn(move || {
                for line in BufReader::new(stderr).lines() {
                    let Ok(line) = line else { break };
                    if let Some((_, url)) = line.split_once("DevTools listening on ") {
                        let _ = tx.send(url.trim().to_string());
                    }
                    if let Ok(mut q) = last_lines.lock() {
                        if q.len() == 20 {
                            q.pop_front();
                        }
                        q.push_back(line);
                    }
                }
            });
        }
        let url = match rx.recv_timeout(LAUNCH_TIMEOUT) {
            Ok(url) => url,
            Err(e) => {
                let why = match e {
                    mpsc::RecvTimeoutError::Timeout => {
                        format!("did not print its DevTools address within {LAUNCH_TIMEOUT:?}")
                    }
                    mpsc::RecvTimeoutError::Disconnected => {
                        let status = browser.child.wait().map(|s| s.to_string());
                        format!(
                            "exited ({}) without printing its DevTools address",
                            status.unwrap_or_else(|e| e.to_string())
                        )
                    }
                };
                let lines = last_lines
                    .lock()
                    .map(|q| q.iter().cloned().collect::<Vec<_>>().join("\n    "))
                    .unwrap_or_default();
                bail!(
                    "Chromium ({}) {why}; its last stderr lines:\n    {lines}",
                    exe.display()
                );
            }
        };
        browser.cdp = Some(Cdp::connect(&url)?);
        Ok(browser)
    }

    fn cdp(&mut self) -> Result<&mut Cdp> {
        self.cdp.as_mut().context("no DevTools connection")
    }

    /// Loads `page` in a new tab, checks it and saves a full-page screenshot to `shot`.
    /// `Err` means the check itself could not be done (timeout, browser gone).
    fn check_page(&mut self, page: &Path, shot: &Path) -> Result<PageReport> {
        let started = Instant::now();
        let mut report = PageReport::default();
        let abs = match std::fs::canonicalize(page) {
            Ok(p) if p.is_file() => p,
            _ => {
                report
                    .problems
                    .push(format!("{} does not exist", page.display()));
                return Ok(report);
            }
        };
        let url = file_url(&abs)?;
        self.in_new_tab(started + PAGE_TIMEOUT, |cdp, target_id, deadline| {
            cdp.check_in_target(target_id, &url, shot, deadline, &mut report)
        })?;
        report.elapsed = started.elapsed();
        Ok(report)
    }

    /// Runs `f` in a new tab (target) and closes the tab whatever happened.
    fn in_new_tab<T>(
        &mut self,
        deadline: Instant,
        f: impl FnOnce(&mut Cdp, &str, Instant) -> Result<T>,
    ) -> Result<T> {
        let cdp = self.cdp()?;
        let target = cdp.call(
            None,
            "Target.createTarget",
            json!({ "url": "about:blank" }),
            deadline,
            &mut Vec::new(),
        )?;
        let target_id = target["targetId"]
            .as_str()
            .context("Target.createTarget returned no targetId")?
            .to_string();
        let result = f(cdp, &target_id, deadline);
        // Close the tab whatever happened (with a fresh deadline: the page's may be spent).
        let closed = cdp.call(
            None,
            "Target.closeTarget",
            json!({ "targetId": target_id }),
            Instant::now() + Duration::from_secs(5),
            &mut Vec::new(),
        );
        let value = result?;
        closed?;
        Ok(value)
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if let Some(cdp) = self.cdp.as_mut() {
            let _ = cdp.send(None, "Browser.close", json!({}));
        }
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            match self.child.try_wait() {
                Ok(Some(_)) => break,
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(50));
                }
                _ => {
                    let _ = self.child.kill();
                    let _ = self.child.wait();
                    break;
                }
            }
        }
        self.cdp = None;
    }
}

/// `file://` URL of an absolute path (percent-encoding everything but unreserved characters
/// and `/`).
fn file_url(abs: &Path) -> Result<String> {
    let s = abs
        .to_str()
        .with_context(|| format!("{} is not valid UTF-8", abs.display()))?;
    let mut url = String::from("file://");
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~".contains(&b) {
            url.push(char::from(b));
        } else {
            url.push_str(&format!("%{b:02X}"));
        }
    }
    Ok(url)
}

/// The outcome of checking one page.
#[derive(Default)]
struct PageReport {
    elapsed: Duration,
    svgs: usize,
    imgs: usize,
    /// Console errors, uncaught exceptions and error log entries (failed loads).
    console_errors: usize,
    problems: Vec<String>,
    screenshot: Option<PathBuf>,
    /// Set when the screenshot does not show the whole page.
    screenshot_note: Option<String>,
}

impl PageReport {
    fn print(&self, page: &Path) {
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
struct Measured {
    href: String,
    ready_state: String,
    /// (src attribute, complete, naturalWidth)
    imgs: Vec<(String, bool, f64)>,
    /// (label, width, height) of top-level svgs
    svgs: Vec<(String, f64, f64)>,
    /// (label, smallest text in CSS px, share of the page width) of the svgs in a `<figure>`
    figures: Vec<(String, Option<f64>, Option<f64>)>,
    /// (attribute as written, URL protocol, decoded path) of referenced figure files
    refs: Vec<(String, String, String)>,
}

impl Measured {
    fn from_json(v: &Value) -> Self {
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

/// A synchronous DevTools protocol client over the browser's websocket.
struct Cdp {
    ws: WebSocket<TcpStream>,
    next_id: u64,
}

impl Cdp {
    /// Connects to `ws://HOST:PORT/devtools/browser/ID`.
    fn connect(url: &str) -> Result<Self> {
        let host_port = url
            .strip_prefix("ws://")
            .and_then(|rest| rest.split('/').next())
            .with_context(|| format!("unexpected DevTools address {url:?}"))?;
        let stream = TcpStream::connect(host_port)
            .with_context(|| format!("connecting to Chromium's DevTools at {host_port}"))?;
        stream
            .set_read_timeout(Some(LAUNCH_TIMEOUT))
            .context("setting a socket timeout")?;
        stream
            .set_write_timeout(Some(PAGE_TIMEOUT))
            .context("setting a socket timeout")?;
        // Screenshots of long pages come as one large message.
        let config = WebSocketConfig::default()
            .max_message_size(Some(512 << 20))
            .max_frame_size(Some(512 << 20));
        let (ws, _) = tungstenite::client::client_with_config(url, stream, Some(config))
            .map_err(|e| anyhow::anyhow!("{e}"))
            .with_context(|| format!("websocket handshake with {url}"))?;
        Ok(Cdp { ws, next_id: 1 })
    }

    /// Sends a command (to the page session `session`, or to the browser); returns its id.
    fn send(&mut self, session: Option<&str>, method: &str, params: Value) -> Result<u64> {
        let id = self.next_id;
        self.next_id += 1;
        let mut msg = json!({ "id": id, "method": method, "params": params });
        if let Some(s) = session {
            msg["sessionId"] = json!(s);
        }
        self.ws
            .send(Message::Text(msg.to_string().into()))
            .with_context(|| format!("sending {method} to Chromium"))?;
        Ok(id)
    }

    /// The next JSON message from the browser, or an error once `deadline` has passed.
    fn next_message(&mut self, deadline: Instant) -> Result<Value> {
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                bail!("timed out (page limit {PAGE_TIMEOUT:?})");
            }
            self.ws
                .get_mut()
                .set_read_timeout(Some(left.max(Duration::from_millis(1))))
                .context("setting a socket timeout")?;
            match self.ws.read() {
                Ok(Message::Text(t)) => {
                    return serde_json::from_str(t.as_str()).context("parsing a DevTools message")
                }
                Ok(Message::Binary(b)) => {
                    return serde_json::from_slice(&b).context("parsing a DevTools message")
                }
                Ok(Message::Close(_)) => bail!("Chromium closed the DevTools connection"),
                Ok(_) => {}
                Err(tungstenite::Error::Io(e))
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) =>
                {
                    bail!("timed out (page limit {PAGE_TIMEOUT:?})")
                }
                Err(e) => return Err(e).context("reading from Chromium's DevTools connection"),
            }
        }
    }

    /// Sends a command and waits for its result. Events of `session` that arrive meanwhile
    /// are appended to `events`; other messages are dropped.
    fn call(
        &mut self,
        session: Option<&str>,
        method: &str,
        params: Value,
        deadline: Instant,
        events: &mut Vec<Value>,
    ) -> Result<Value> {
        let id = self.send(session, method, params)?;
        loop {
            let msg = self
                .next_message(deadline)
                .with_context(|| format!("waiting for the reply to {method}"))?;
            if msg["id"].as_u64() == Some(id) {
                if let Some(err) = msg.get("error") {
                    bail!("{method} failed: {err}");
                }
                return Ok(msg["result"].clone());
            }
            self.keep_event(session, msg, events);
        }
    }

    /// Waits until `events[from..]` holds an event `method` of `session`.
    fn wait_event(
        &mut self,
        session: &str,
        method: &str,
        from: usize,
        deadline: Instant,
        events: &mut Vec<Value>,
    ) -> Result<()> {
        loop {
            if events
                .iter()
                .skip(from)
                .any(|e| e["method"].as_str() == Some(method))
            {
                return Ok(());
            }
            let msg = self
                .next_message(deadline)
                .with_context(|| format!("waiting for {method}"))?;
            self.keep_event(Some(session), msg, events);
        }
    }

    fn keep_event(&self, session: Option<&str>, msg: Value, events: &mut Vec<Value>) {
        if session.is_some() && msg["sessionId"].as_str() == session && msg.get("method").is_some()
        {
            events.push(msg);
        }
    }

    /// Attaches to the tab `target_id` (flat session), enables the page, runtime and log
    /// events and sets the viewport; returns the session id.
    fn attach(
        &mut self,
        target_id: &str,
        deadline: Instant,
        events: &mut Vec<Value>,
    ) -> Result<String> {
        let attached = self.call(
            None,
            "Target.attachToTarget",
            json!({ "targetId": target_id, "flatten": true }),
            deadline,
            events,
        )?;
        let session = attached["sessionId"]
            .as_str()
            .context("Target.attachToTarget returned no sessionId")?
            .to_string();
        let s = Some(session.as_str());
        for domain in ["Page.enable", "Runtime.enable", "Log.enable"] {
            self.call(s, domain, json!({}), deadline, events)?;
        }
        self.call(
            s,
            "Emulation.setDeviceMetricsOverride",
            json!({ "width": VIEWPORT.0, "height": VIEWPORT.1, "deviceScaleFactor": 1, "mobile": false }),
            deadline,
            events,
        )?;
        Ok(session)
    }

    /// Navigates the session's tab to `url` and waits for its load event. `Ok(Some(text))` when
    /// the navigation itself failed.
    fn navigate(
        &mut self,
        session: &str,
        url: &str,
        deadline: Instant,
        events: &mut Vec<Value>,
    ) -> Result<Option<String>> {
        let from = events.len();
        let nav = self.call(
            Some(session),
            "Page.navigate",
            json!({ "url": url }),
            deadline,
            events,
        )?;
        if let Some(err) = nav["errorText"].as_str() {
            return Ok(Some(err.to_string()));
        }
        self.wait_event(session, "Page.loadEventFired", from, deadline, events)?;
        Ok(None)
    }

    /// Evaluates `expression` in the page and returns its value (by value); an exception in
    /// the expression is an error.
    fn evaluate(
        &mut self,
        session: &str,
        expression: &str,
        deadline: Instant,
        events: &mut Vec<Value>,
    ) -> Result<Value> {
        let eval = self.call(
            Some(session),
            "Runtime.evaluate",
            json!({ "expression": expression, "returnByValue": true }),
            deadline,
            events,
        )?;
        if let Some(ex) = eval.get("exceptionDetails") {
            bail!("the script failed: {ex}");
        }
        Ok(eval["result"]["value"].clone())
    }

    /// Full-page screenshot of the session's tab into `shot`.
    fn screenshot(
        &mut self,
        session: &str,
        shot: &Path,
        deadline: Instant,
        events: &mut Vec<Value>,
        report: &mut PageReport,
    ) -> Result<()> {
        let s = Some(session);
        let metrics = self.call(s, "Page.getLayoutMetrics", json!({}), deadline, events)?;
        let size = &metrics["cssContentSize"];
        let width = size["width"]
            .as_f64()
            .unwrap_or(0.0)
            .max(f64::from(VIEWPORT.0))
            .ceil();
        let full_height = size["height"].as_f64().unwrap_or(0.0).ceil();
        let height = full_height.clamp(1.0, MAX_SCREENSHOT_HEIGHT);
        if height < full_height {
            report.screenshot_note = Some(format!("(cut at {height} of {full_height} px)"));
        }
        let png = self.call(
            s,
            "Page.captureScreenshot",
            json!({
                "format": "png",
                "captureBeyondViewport": true,
                "clip": { "x": 0, "y": 0, "width": width, "height": height, "scale": 1 },
            }),
            deadline,
            events,
        )?;
        let data = png["data"]
            .as_str()
            .context("Page.captureScreenshot returned no data")?;
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(data)
            .context("decoding the screenshot")?;
        std::fs::write(shot, bytes).with_context(|| format!("writing {}", shot.display()))?;
        report.screenshot = Some(shot.to_path_buf());
        Ok(())
    }

    /// Attaches to the tab `target_id`, loads `url`, measures, screenshots; fills `report`.
    fn check_in_target(
        &mut self,
        target_id: &str,
        url: &str,
        shot: &Path,
        deadline: Instant,
        report: &mut PageReport,
    ) -> Result<()> {
        let mut events = Vec::new();
        let session = self.attach(target_id, deadline, &mut events)?;
        if let Some(err) = self.navigate(&session, url, deadline, &mut events)? {
            report.problems.push(format!("navigation failed: {err}"));
            return Ok(());
        }
        let value = self
            .evaluate(&session, MEASURE_JS, deadline, &mut events)
            .context("the measuring script")?;
        let m = Measured::from_json(&value);
        if m.href != url {
            report.problems.push(format!(
                "the tab shows {:?} instead of the page (readyState {})",
                m.href, m.ready_state
            ));
        }
        report.svgs = m.svgs.len();
        report.imgs = m.imgs.len();
        judge_figures(&m, report);
        self.screenshot(&session, shot, deadline, &mut events, report)?;
        judge_events(&events, report);
        Ok(())
    }
}

/// Problems with the figures: images not loaded, zero-size svgs, no figure, missing files.
fn judge_figures(m: &Measured, report: &mut PageReport) {
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
fn judge_events(events: &[Value], report: &mut PageReport) {
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
