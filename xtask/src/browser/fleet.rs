//! The fleet page (`report::fleet`) in the browser: a synthetic fleet of six valves (two plant
//! areas, one without a repair benefit, one that could not be analysed, a cause that looks like
//! markup) is written with small pages for the `latest` links, checked like every page, and then
//! driven over CDP with `Runtime.evaluate`: the benefit header clicked once (largest first) and
//! twice (smallest first), the tag filter typed into, an area chosen, the first row's `latest`
//! link followed. The expected values come from the same synthetic valves.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use report::fleet::{FleetRegistration, FleetValve};
use serde_json::Value;

use super::{file_url, judge_events, Browser, Cdp, PageReport, PAGE_TIMEOUT};

/// Tag filter typed into the page and the plant area chosen in its select.
const FILTER: &str = "fic5";
const AREA: &str = "2411";

/// The script's toggle, replaced in the self-test's broken page (the second click then sorts
/// the same way as the first).
pub(super) const TOGGLE: &str = "dir = -dir;";

/// What the page must show, computed from the synthetic valves.
pub(super) struct FleetPage {
    /// The page.
    pub index: PathBuf,
    /// Valves in all.
    n: usize,
    /// Tag of the first-ranked valve.
    first: String,
    /// Largest and smallest repair benefit.
    max_benefit: f64,
    min_benefit: f64,
    /// Rows the tag filter and the area select must leave.
    filtered: usize,
    in_area: usize,
}

fn reg(date: &str, s: Option<f64>) -> FleetRegistration {
    FleetRegistration {
        date: Some(date.to_string()),
        s,
        s_lo: s.map(|s| s * 0.93),
        s_hi: s.map(|s| s * 1.07),
        file: format!("{}.csv", date.replace([' ', ':'], "-")),
    }
}

#[allow(clippy::too_many_arguments)]
fn valve(
    tag: &str,
    verdict: &str,
    score: Option<f64>,
    reduction: Option<f64>,
    history: &[(&str, Option<f64>)],
    causes: &[&str],
    repair_reason: Option<&str>,
    error: Option<&str>,
) -> FleetValve {
    let registrations: Vec<FleetRegistration> = history.iter().map(|(d, s)| reg(d, *s)).collect();
    let last = registrations.last().cloned().unwrap_or_default();
    FleetValve {
        valve: tag.to_string(),
        verdict: verdict.to_string(),
        verdict_reason: None,
        score,
        s: last.s,
        span_unknown: false,
        s_lo: last.s_lo,
        s_hi: last.s_hi,
        causes: causes.iter().map(|c| c.to_string()).collect(),
        reduction,
        repair_reason: repair_reason.map(str::to_string),
        error: error.map(str::to_string),
        link: Some(format!("valves/{tag}/index.html")),
        registrations,
    }
}

/// Six valves in areas 2411 and 2412. The first-ranked valve does not have the largest
/// benefit (its score is higher), so a sort that did nothing would be noticed.
pub(super) fn example_valves() -> Vec<FleetValve> {
    vec![
        valve(
            "2411FIC20102",
            "stiction",
            Some(0.92),
            Some(0.35),
            &[
                ("2023-11-02 08:00", Some(1.8)),
                ("2024-02-14 10:30", Some(2.1)),
                ("2024-05-20 07:45", Some(2.45)),
            ],
            &[
                "stick-slip: PV-OP ellipse with corners",
                "nonlinear control error (NGI 0.31)",
            ],
            None,
            None,
        ),
        valve(
            "2411PIC30011",
            "inconclusive",
            Some(0.40),
            Some(0.70),
            &[
                ("2024-01-10 12:00", Some(0.9)),
                ("2024-05-21 09:15", Some(1.6)),
            ],
            &[
                "bicoherence: nonlinear (NGI 0.12, NLI 0.41)",
                "cross-correlation: neither odd nor even",
                "oscillation period 212 s, regular (r 0.62)",
                "disturbance candidate: slow drift of the feed pressure",
            ],
            None,
            None,
        ),
        valve(
            "2411LIC10001",
            "stiction",
            Some(0.55),
            Some(0.48),
            &[("2024-05-22 16:00", Some(1.2))],
            &["stick-slip in the level loop"],
            None,
            None,
        ),
        valve(
            "2412TIC40020",
            "no-stiction",
            Some(0.08),
            Some(0.12),
            &[
                ("2023-06-01 00:00", Some(0.30)),
                ("2023-10-01 00:00", Some(0.25)),
                ("2024-02-01 00:00", Some(0.20)),
                ("2024-05-23 11:00", Some(0.22)),
            ],
            &["reads <b>as text</b> & <script>not as markup</script>"],
            None,
            None,
        ),
        valve(
            "2412FIC50003",
            "stiction",
            Some(0.81),
            None,
            &[
                ("2024-03-01 06:00", Some(3.1)),
                ("2024-05-24 06:00", Some(3.4)),
            ],
            &["stick-slip"],
            Some("controller not identified: OP saturated 40 % of the time"),
            None,
        ),
        valve(
            "2412FIC50117",
            "",
            None,
            None,
            &[("2024-05-24 13:20", None)],
            &[],
            None,
            Some("PV is constant (dead transmitter?)"),
        ),
    ]
}

/// Writes the fleet page into `dir/index.html` (after `mutate`, which the self-test uses to
/// break it) and a small page per `latest` link; returns what the page must show.
pub(super) fn write_example(dir: &Path, mutate: impl Fn(String) -> String) -> Result<FleetPage> {
    let valves = example_valves();
    for v in &valves {
        let Some(link) = &v.link else { continue };
        let page_dir = dir
            .join(link)
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let mut section = report::Section::new("Latest registration");
        section.push(report::Block::Facts(vec![
            ("verdict".into(), v.verdict.clone()),
            (
                "S (% of span)".into(),
                v.s.map_or("-".into(), |s| format!("{s:.2}")),
            ),
        ]));
        report::Report {
            title: format!("{} latest registration", v.valve),
            subtitle: "synthetic page for the fleet check".into(),
            summary: Vec::new(),
            sections: vec![section],
        }
        .write(&page_dir, report::WriteOptions::default())
        .with_context(|| format!("writing {}", page_dir.display()))?;
    }
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let html = mutate(report::fleet::fleet_page("Fleet (synthetic)", &valves));
    let index = dir.join("index.html");
    std::fs::write(&index, html).with_context(|| format!("writing {}", index.display()))?;

    let ranked = report::fleet::ranked(&valves);
    let benefits: Vec<f64> = valves.iter().filter_map(|v| v.reduction).collect();
    Ok(FleetPage {
        index,
        n: valves.len(),
        first: ranked.first().map(|v| v.valve.clone()).unwrap_or_default(),
        max_benefit: benefits.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        min_benefit: benefits.iter().copied().fold(f64::INFINITY, f64::min),
        filtered: valves
            .iter()
            .filter(|v| v.valve.to_lowercase().contains(FILTER))
            .count(),
        in_area: valves
            .iter()
            .filter(|v| report::fleet::area(&v.valve) == AREA)
            .count(),
    })
}

/// The table as the reader sees it: visible rows (tag, area, benefit `data-value`), the count
/// line, the benefit header's text, the first visible row's `latest` link (absolute).
const STATE_JS: &str = r#"(() => {
  const table = document.getElementById('fleet');
  if (!table) return { error: 'no table #fleet' };
  const heads = Array.from(table.tHead.rows[0].cells);
  const col = heads.findIndex((th) => th.dataset.key === 'benefit');
  const rows = Array.from(table.tBodies[0].rows).filter((tr) => tr.getClientRects().length > 0);
  const a = rows.length ? rows[0].querySelector('a.latest') : null;
  return {
    tags: rows.map((tr) => tr.dataset.tag),
    areas: rows.map((tr) => tr.dataset.area),
    benefit: rows.map((tr) => tr.cells[col].getAttribute('data-value')),
    count: (document.getElementById('count') || {}).textContent || '',
    header: col >= 0 ? heads[col].textContent : '',
    link: a ? a.href : '',
  };
})()"#;

const CLICK_BENEFIT: &str =
    "document.querySelector('#fleet thead th[data-key=\"benefit\"]').click(); true";

fn set_input(id: &str, value: &str, event: &str) -> String {
    format!(
        "(() => {{ const e = document.getElementById({id:?}); e.value = {value:?}; \
         e.dispatchEvent(new Event({event:?}, {{ bubbles: true }})); return e.value; }})()"
    )
}

/// What [`STATE_JS`] returns.
struct State {
    tags: Vec<String>,
    areas: Vec<String>,
    /// Benefit of each visible row, `None` when missing.
    benefit: Vec<Option<f64>>,
    count: String,
    header: String,
    link: String,
}

impl State {
    fn from_json(v: &Value) -> Result<State> {
        if let Some(e) = v["error"].as_str() {
            anyhow::bail!("{e}");
        }
        let strs = |k: &str| -> Vec<String> {
            v[k].as_array()
                .map(|a| {
                    a.iter()
                        .map(|x| x.as_str().unwrap_or_default().to_string())
                        .collect()
                })
                .unwrap_or_default()
        };
        Ok(State {
            tags: strs("tags"),
            areas: strs("areas"),
            benefit: strs("benefit")
                .iter()
                .map(|b| b.parse::<f64>().ok())
                .collect(),
            count: v["count"].as_str().unwrap_or_default().to_string(),
            header: v["header"].as_str().unwrap_or_default().to_string(),
            link: v["link"].as_str().unwrap_or_default().to_string(),
        })
    }

    /// The benefits are sorted (`descending` or not) with the missing ones last.
    fn sorted(&self, descending: bool) -> bool {
        let known: Vec<f64> = self.benefit.iter().map_while(|b| *b).collect();
        let rest_missing = self.benefit[known.len()..].iter().all(Option::is_none);
        rest_missing
            && known.windows(2).all(|w| {
                if descending {
                    w[0] >= w[1]
                } else {
                    w[0] <= w[1]
                }
            })
    }
}

impl Browser {
    /// Drives the fleet page; problems are prefixed `fleet:`. Screenshot after the first sort
    /// into `sorted.screenshot.png` beside the page.
    pub(super) fn check_fleet(&mut self, fleet: &FleetPage) -> Result<PageReport> {
        let started = Instant::now();
        let mut report = PageReport::default();
        let abs = std::fs::canonicalize(&fleet.index)
            .with_context(|| format!("{} does not exist", fleet.index.display()))?;
        let url = file_url(&abs)?;
        let shot = fleet.index.with_file_name("sorted.screenshot.png");
        self.in_new_tab(started + PAGE_TIMEOUT, |cdp, target_id, deadline| {
            drive(cdp, target_id, &url, fleet, &shot, deadline, &mut report)
        })?;
        report.elapsed = started.elapsed();
        Ok(report)
    }
}

fn drive(
    cdp: &mut Cdp,
    target_id: &str,
    url: &str,
    f: &FleetPage,
    shot: &Path,
    deadline: Instant,
    report: &mut PageReport,
) -> Result<()> {
    let mut events = Vec::new();
    let session = cdp.attach(target_id, deadline, &mut events)?;
    let s = session.as_str();
    if let Some(err) = cdp.navigate(s, url, deadline, &mut events)? {
        report
            .problems
            .push(format!("fleet: navigation failed: {err}"));
        return Ok(());
    }
    let state = |cdp: &mut Cdp, events: &mut Vec<Value>| -> Result<State> {
        State::from_json(&cdp.evaluate(s, STATE_JS, deadline, events)?)
            .context("reading the fleet table")
    };
    let mut problems: Vec<String> = Vec::new();
    let mut problem = |p: String| problems.push(format!("fleet: {p}"));
    let shows = |k: usize| format!("showing {k} of {} valves", f.n);
    let mut shot_report = PageReport::default();

    let st = state(cdp, &mut events)?;
    if st.tags.len() != f.n || st.count != shows(f.n) {
        problem(format!(
            "on load {} rows are visible and the count says {:?}; expected {} and {:?}",
            st.tags.len(),
            st.count,
            f.n,
            shows(f.n)
        ));
    }
    if st.tags.first() != Some(&f.first) {
        problem(format!(
            "the first row is {:?}, expected the first-ranked valve {:?}",
            st.tags.first(),
            f.first
        ));
    }

    // Sort by benefit: one click largest first, two clicks smallest first; missing last.
    for (clicks, descending, expect) in [(1, true, f.max_benefit), (2, false, f.min_benefit)] {
        cdp.evaluate(s, CLICK_BENEFIT, deadline, &mut events)
            .context("clicking the benefit header")?;
        let st = state(cdp, &mut events)?;
        let first = st.benefit.first().copied().flatten();
        let arrow = if descending { '\u{25BC}' } else { '\u{25B2}' };
        let what = if descending { "largest" } else { "smallest" };
        if first.is_none_or(|b| (b - expect).abs() > 1e-9) || !st.sorted(descending) {
            problem(format!(
                "sort: after {clicks} click(s) on the benefit header the first row's benefit is \
                 {first:?}, expected the {what} ({expect}); column {:?}",
                st.benefit
            ));
        }
        if !st.header.contains(arrow) {
            problem(format!(
                "sort: after {clicks} click(s) the benefit header reads {:?}, without {arrow}",
                st.header
            ));
        }
        if clicks == 1 {
            cdp.screenshot(s, shot, deadline, &mut events, &mut shot_report)?;
        }
    }

    // Tag filter, then the area select.
    cdp.evaluate(
        s,
        &set_input("filter", FILTER, "input"),
        deadline,
        &mut events,
    )?;
    let st = state(cdp, &mut events)?;
    if st.tags.len() != f.filtered
        || st.count != shows(f.filtered)
        || !st.tags.iter().all(|t| t.to_lowercase().contains(FILTER))
    {
        problem(format!(
            "filter {FILTER:?}: rows {:?}, count {:?}; expected {} rows and {:?}",
            st.tags,
            st.count,
            f.filtered,
            shows(f.filtered)
        ));
    }
    cdp.evaluate(s, &set_input("filter", "", "input"), deadline, &mut events)?;
    cdp.evaluate(s, &set_input("area", AREA, "change"), deadline, &mut events)?;
    let st = state(cdp, &mut events)?;
    if st.tags.len() != f.in_area
        || st.count != shows(f.in_area)
        || !st.areas.iter().all(|a| a == AREA)
    {
        problem(format!(
            "area {AREA}: rows {:?}, count {:?}; expected {} rows and {:?}",
            st.tags,
            st.count,
            f.in_area,
            shows(f.in_area)
        ));
    }
    cdp.evaluate(s, &set_input("area", "", "change"), deadline, &mut events)?;
    let st = state(cdp, &mut events)?;
    if st.tags.len() != f.n {
        problem(format!(
            "all areas again: {} rows visible, expected {}",
            st.tags.len(),
            f.n
        ));
    }

    // Follow the first row's `latest` link.
    if st.link.is_empty() {
        problem("the first row has no `latest` link".into());
    } else {
        let from = events.len();
        cdp.evaluate(
            s,
            "document.querySelector('#fleet tbody tr:not([hidden]) a.latest').click(); true",
            deadline,
            &mut events,
        )?;
        cdp.wait_event(s, "Page.loadEventFired", from, deadline, &mut events)
            .context("following the `latest` link")?;
        let at = cdp.evaluate(
            s,
            "({ href: location.href, ready: document.readyState, h1: (document.querySelector('h1') || {}).textContent || '' })",
            deadline,
            &mut events,
        )?;
        let href = at["href"].as_str().unwrap_or_default();
        let h1 = at["h1"].as_str().unwrap_or_default();
        if href != st.link || at["ready"].as_str() != Some("complete") || h1.is_empty() {
            problem(format!(
                "the `latest` link {:?} led to {href:?} (readyState {}, heading {h1:?})",
                st.link, at["ready"]
            ));
        }
    }
    report.problems.extend(problems);
    report.screenshot = shot_report.screenshot;
    report.screenshot_note = shot_report.screenshot_note;
    judge_events(&events, report);
    Ok(())
}
