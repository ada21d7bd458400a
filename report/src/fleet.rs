//! The fleet page: every valve of a plant once, one row each, ranked by what a repair would
//! buy. One self-contained `index.html` (inline CSS, inline SVG sparklines and a small inline
//! script; nothing fetched) for a maintenance planner with thousands of loops.
//!
//! The input is this module's own plain data ([`FleetValve`], [`FleetRegistration`]): whoever
//! keeps the registrations' history (the CLI, from its store) maps its records to these.
//!
//! # Ranking
//!
//! A row's key is the **expected repair benefit**, [`priority`]:
//!
//! ```text
//! priority = reduction × w        (0 when reduction is unknown)
//! w        = score                the detector's probability-like score in [0, 1]
//!          = 1 / 0.5 / 0          without a score: verdict stiction / inconclusive or unknown / no-stiction
//! ```
//!
//! `reduction` is the fraction of the control error's standard deviation a repair removes,
//! *if* the valve sticks; `w` is how likely the detector finds that it does. Their product is
//! the benefit to expect from opening the valve, so a large benefit on a doubtful verdict ranks
//! with a moderate one on a certain verdict. Both are clamped to [0, 1]; a non-finite value
//! counts as missing. Rows are ordered by priority (descending); on equal priority a valve with
//! a known reduction comes before one without (so a valve whose benefit is unknown ranks after
//! every valve with one, even a zero benefit), then by S (descending, unknown last), then by
//! tag. The rank column is that order, 1..n; re-sorting the table in the browser does not
//! renumber it.
//!
//! # Area
//!
//! A valve's plant area is the tag's prefix: its leading digits (`2411FIC20102` → `2411`), or,
//! when the tag does not start with a digit, its leading letters (`FIC101` → `FIC`); `-` when
//! the tag starts with neither.
//!
//! # The page
//!
//! Columns: rank, valve, area, latest date, verdict (coloured badge), score, S with its range,
//! repair benefit (with a bar; the reason it is missing as a tooltip), causes (collapsed in a
//! `<details>` when long), a sparkline of S over the valve's registrations (only with two or
//! more), and a `latest` link to the latest registration's page (relative links only). The
//! script sorts by a column header click (numbers numerically; first click descending for
//! numbers, ascending for text; a second click reverses; missing values stay last), filters by
//! a tag substring and by area, and says how many rows are shown. All text is escaped.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::html::escape;
use crate::ReportError;

/// One registration of a valve, for its sparkline.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FleetRegistration {
    /// When it was recorded, `YYYY-MM-DD HH:MM`.
    pub date: Option<String>,
    /// The estimated S (% of valve span).
    pub s: Option<f64>,
    /// Lower end of S's range.
    pub s_lo: Option<f64>,
    /// Upper end of S's range.
    pub s_hi: Option<f64>,
    /// The registration's file, for the tooltip.
    pub file: String,
}

/// One valve: its latest state and its history.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FleetValve {
    /// The tag, e.g. `2411FIC20102`.
    pub valve: String,
    /// Its registrations, oldest first.
    pub registrations: Vec<FleetRegistration>,
    /// The latest detector verdict: `stiction`, `no-stiction`, `inconclusive`, or empty when
    /// unknown.
    pub verdict: String,
    /// The detector's reason for the latest verdict (the verdict's tooltip).
    pub verdict_reason: Option<String>,
    /// The latest detector score in [0, 1].
    pub score: Option<f64>,
    /// The latest S reported: the S that explains the verdict, % of valve span (of the OP
    /// range seen with `span_unknown`).
    pub s: Option<f64>,
    /// OP's valve span is unknown in the latest registration: S is in % of the OP range that
    /// record shows, printed without `%`.
    pub span_unknown: bool,
    /// Lower end of the latest S's range.
    pub s_lo: Option<f64>,
    /// Upper end of the latest S's range.
    pub s_hi: Option<f64>,
    /// The latest registration's causes / evidence lines.
    pub causes: Vec<String>,
    /// The latest repair benefit: the fraction of the control error's standard deviation a
    /// repair removes, 0-1.
    pub reduction: Option<f64>,
    /// Why `reduction` is missing.
    pub repair_reason: Option<String>,
    /// Set when the latest registration could not be analysed.
    pub error: Option<String>,
    /// Relative href of the latest registration's page, e.g.
    /// `valves/2411FIC20102/index.html`.
    pub link: Option<String>,
}

/// A finite value clamped to [0, 1], or `None`.
fn unit(x: Option<f64>) -> Option<f64> {
    x.filter(|v| v.is_finite()).map(|v| v.clamp(0.0, 1.0))
}

fn finite(x: Option<f64>) -> Option<f64> {
    x.filter(|v| v.is_finite())
}

/// The verdict's weight: the detector's score, or without a score 1 for `stiction`, 0 for
/// `no-stiction` and 0.5 otherwise (see the module documentation).
pub fn confidence(v: &FleetValve) -> f64 {
    match unit(v.score) {
        Some(s) => s,
        None => match v.verdict.as_str() {
            "stiction" => 1.0,
            "no-stiction" => 0.0,
            _ => 0.5,
        },
    }
}

/// The ranking key: expected repair benefit, `reduction × w` (0 without a reduction); see
/// the module documentation.
pub fn priority(v: &FleetValve) -> f64 {
    match unit(v.reduction) {
        Some(r) => r * confidence(v),
        None => 0.0,
    }
}

/// The valves in rank order (first = most to gain from a repair); see the module
/// documentation for the order.
pub fn ranked(valves: &[FleetValve]) -> Vec<&FleetValve> {
    let mut out: Vec<&FleetValve> = valves.iter().collect();
    out.sort_by(|a, b| {
        priority(b)
            .total_cmp(&priority(a))
            .then_with(|| {
                unit(b.reduction)
                    .is_some()
                    .cmp(&unit(a.reduction).is_some())
            })
            .then_with(|| match (finite(a.s), finite(b.s)) {
                (Some(x), Some(y)) => y.total_cmp(&x),
                (Some(_), None) => std::cmp::Ordering::Less,
                (None, Some(_)) => std::cmp::Ordering::Greater,
                (None, None) => std::cmp::Ordering::Equal,
            })
            .then_with(|| a.valve.cmp(&b.valve))
    });
    out
}

/// The first `n` valves of the ranking as a text table (what `stiction audit --report`
/// prints): rank, valve, expected benefit, benefit, verdict and score, S with its range, latest
/// registration.
pub fn ranking_text(valves: &[FleetValve], n: usize) -> String {
    use std::fmt::Write as _;
    let mut out = format!(
        "{:>3}  {:<16} {:>8} {:>8}  {:<20} {:>20}  {}\n",
        "#", "valve", "expected", "benefit", "verdict (score)", "S % [range]", "latest"
    );
    let num = |x: Option<f64>, f: &dyn Fn(f64) -> String| finite(x).map_or("-".into(), f);
    for (k, v) in ranked(valves).into_iter().take(n).enumerate() {
        let verdict = match finite(v.score) {
            Some(s) if !v.verdict.is_empty() => format!("{} ({s:.2})", v.verdict),
            _ if v.error.is_some() => "error".into(),
            _ if v.verdict.is_empty() => "-".into(),
            _ => v.verdict.clone(),
        };
        let mark = if v.span_unknown { "*" } else { "" };
        let s_text = match (finite(v.s), finite(v.s_lo), finite(v.s_hi)) {
            (Some(s), Some(lo), Some(hi)) => format!("{s:.2} [{lo:.2}, {hi:.2}]{mark}"),
            (Some(s), _, _) => format!("{s:.2}{mark}"),
            _ => "-".into(),
        };
        let expected = if unit(v.reduction).is_some() {
            format!("{:.0} %", 100.0 * priority(v))
        } else {
            "-".into()
        };
        let _ = writeln!(
            out,
            "{:>3}  {:<16} {:>8} {:>8}  {:<20} {:>20}  {}",
            k + 1,
            v.valve,
            expected,
            num(v.reduction, &|r| format!("{:.0} %", 100.0 * r)),
            verdict,
            s_text,
            v.registrations
                .last()
                .and_then(|r| r.date.clone())
                .unwrap_or_else(|| "-".into())
        );
    }
    if valves.len() > n {
        let _ = writeln!(out, "     ... {} more valves on the page", valves.len() - n);
    }
    if ranked(valves)
        .into_iter()
        .take(n)
        .any(|v| v.span_unknown && finite(v.s).is_some())
    {
        let _ = writeln!(out, "  {RANGE_SEEN_MARK}");
    }
    out
}

/// What `*` after S means in the ranking.
pub const RANGE_SEEN_MARK: &str =
    "*: OP's valve span unknown: S in % of the OP range the record shows, not % of valve span";

/// The plant area of a tag: its leading digits, else its leading letters, else `-`.
pub fn area(tag: &str) -> String {
    let t = tag.trim();
    let digits: String = t.chars().take_while(char::is_ascii_digit).collect();
    if !digits.is_empty() {
        return digits;
    }
    let letters: String = t.chars().take_while(char::is_ascii_alphabetic).collect();
    if !letters.is_empty() {
        return letters;
    }
    "-".to_string()
}

/// Minutes since 1970-01-01 of `YYYY-MM-DD[ HH:MM]`, or `None`.
fn minutes(date: &str) -> Option<f64> {
    let d = date.trim();
    let (day, time) = match d.split_once([' ', 'T']) {
        Some((a, b)) => (a, Some(b)),
        None => (d, None),
    };
    let mut p = day.split('-');
    let y: i64 = p.next()?.parse().ok()?;
    let m: i64 = p.next()?.parse().ok()?;
    let dd: i64 = p.next()?.parse().ok()?;
    if !(1..=12).contains(&m) || !(1..=31).contains(&dd) {
        return None;
    }
    // Days from civil (Howard Hinnant).
    let y2 = if m <= 2 { y - 1 } else { y };
    let era = y2.div_euclid(400);
    let yoe = y2 - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + dd - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    let mins = match time {
        Some(t) => {
            let mut q = t.split(':');
            let h: i64 = q.next()?.trim().parse().ok()?;
            let mi: i64 = q.next().map_or(Some(0), |s| s.trim().parse().ok())?;
            h * 60 + mi
        }
        None => 0,
    };
    Some((days * 1440 + mins) as f64)
}

/// Sparkline size (CSS pixels).
const SPARK_W: f64 = 120.0;
const SPARK_H: f64 = 28.0;

/// The inline SVG of S over the valve's registrations, or `None` with fewer than two
/// registrations that have an S. Placed by date when every date reads, else evenly.
pub fn sparkline(v: &FleetValve) -> Option<String> {
    let pts: Vec<&FleetRegistration> = v
        .registrations
        .iter()
        .filter(|r| finite(r.s).is_some())
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let times: Option<Vec<f64>> = pts
        .iter()
        .map(|r| r.date.as_deref().and_then(minutes))
        .collect();
    let xs: Vec<f64> = match times {
        Some(t)
            if t.windows(2).all(|w| w[1] >= w[0]) && t.last().copied().unwrap_or(0.0) > t[0] =>
        {
            t
        }
        _ => (0..pts.len()).map(|i| i as f64).collect(),
    };
    let ys: Vec<f64> = pts.iter().map(|r| r.s.unwrap_or(0.0)).collect();
    let (x0, x1) = (xs[0], xs[xs.len() - 1]);
    let (mut y0, mut y1) = ys
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &y| {
            (a.min(y), b.max(y))
        });
    if y1 - y0 < 1e-9 {
        y0 -= 0.5;
        y1 += 0.5;
    }
    let pad = 4.0;
    let px = |x: f64| pad + (x - x0) / (x1 - x0) * (SPARK_W - 2.0 * pad);
    let py = |y: f64| SPARK_H - pad - (y - y0) / (y1 - y0) * (SPARK_H - 2.0 * pad);
    let line: Vec<String> = xs
        .iter()
        .zip(&ys)
        .map(|(&x, &y)| format!("{:.1},{:.1}", px(x), py(y)))
        .collect();
    let first = pts[0];
    let last = pts[pts.len() - 1];
    let label = format!(
        "S over {} registrations: {:.2} % ({}) to {:.2} % ({})",
        pts.len(),
        ys[0],
        first.date.as_deref().unwrap_or(&first.file),
        ys[ys.len() - 1],
        last.date.as_deref().unwrap_or(&last.file),
    );
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg class=\"spark\" width=\"{SPARK_W}\" height=\"{SPARK_H}\" viewBox=\"0 0 {SPARK_W} {SPARK_H}\" \
         role=\"img\" aria-label=\"{l}\"><title>{l}</title>\
         <polyline points=\"{}\" fill=\"none\" stroke=\"#5b7fa6\" stroke-width=\"1.5\"/>",
        line.join(" "),
        l = escape(&label)
    );
    for (i, ((&x, &y), r)) in xs.iter().zip(&ys).zip(&pts).enumerate() {
        let is_last = i + 1 == pts.len();
        let tip = format!("{}: S {:.2} %", r.date.as_deref().unwrap_or(&r.file), y);
        let _ = write!(
            s,
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"{}\" fill=\"{}\"><title>{}</title></circle>",
            px(x),
            py(y),
            if is_last { 3.2 } else { 2.0 },
            if is_last { "#c0392b" } else { "#5b7fa6" },
            escape(&tip)
        );
    }
    s.push_str("</svg>");
    Some(s)
}

/// A relative link is kept; anything with a scheme (`https:`, `javascript:`), a
/// protocol-relative `//host` or a backslash is dropped.
fn safe_link(link: &str) -> Option<&str> {
    let l = link.trim();
    let scheme = l
        .split(['/', '?', '#'])
        .next()
        .is_some_and(|first| first.contains(':'));
    (!l.is_empty() && !scheme && !l.starts_with("//") && !l.contains('\\')).then_some(l)
}

const STYLE: &str = "\
html{font-size:16px}\
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,'DejaVu Sans',sans-serif;\
margin:1em 1.2em;color:#1a1a1a;line-height:1.4}\
h1{font-size:1.7em;margin:0 0 .2em}.sub{color:#555;margin:0 0 .8em}\
.controls{display:flex;flex-wrap:wrap;gap:.6em 1.4em;align-items:center;margin:.6em 0}\
.controls input,.controls select{font:inherit;padding:.25em .5em;border:1px solid #aaa;border-radius:4px}\
.controls input{width:16em}#count{color:#333;font-weight:600}\
table{border-collapse:collapse;width:100%;font-size:1em}\
th,td{border:1px solid #ddd;padding:.3em .45em;vertical-align:middle;text-align:left}\
thead th{background:#f0f2f5;position:sticky;top:0;cursor:pointer;user-select:none;white-space:nowrap}\
thead th:hover{background:#e2e7ee}th .arrow{display:inline-block;width:1em;color:#1f5fa0}\
tbody tr:nth-child(even){background:#fafbfc}tbody tr:hover{background:#eef4fb}\
td.n,th.n{text-align:right;font-variant-numeric:tabular-nums}.nw{white-space:nowrap}\
td.tag{font-weight:600;white-space:nowrap}\
.badge{display:inline-block;padding:.1em .55em;border-radius:1em;font-size:.9em;font-weight:600;white-space:nowrap}\
.b-stiction{background:#fde2df;color:#9b1c10;border:1px solid #e8a39b}\
.b-inconclusive{background:#fff1d6;color:#7a4d00;border:1px solid #e9c27a}\
.b-no-stiction{background:#e1f3e4;color:#1d6b2c;border:1px solid #9fd1a8}\
.b-unknown{background:#eee;color:#555;border:1px solid #ccc}\
.b-error{background:#3a3a3a;color:#fff;border:1px solid #3a3a3a}\
.ben{display:flex;align-items:center;gap:.45em;justify-content:flex-end;white-space:nowrap}\
.bar{display:inline-block;width:56px;height:.7em;background:#e8ecf0;border-radius:2px;overflow:hidden}\
.bar i{display:block;height:100%;background:#2e7d4f}\
.missing{color:#888;cursor:help;border-bottom:1px dotted #888}\
.range{color:#666;white-space:nowrap;font-size:.93em}td.causes{min-width:14em;max-width:30em;font-size:.93em}\
td.causes ul{margin:.3em 0 0;padding-left:1.2em}summary{cursor:pointer}\
.err{color:#9b1c10}svg.spark{display:block}\
footer{margin-top:1.5em;color:#555;font-size:.92em;max-width:70em}";

/// The page's script: sort by header, filter by tag and area, count. Reads only `data-value`
/// attributes and `textContent`; writes only `textContent`, attributes and row order.
const SCRIPT: &str = r#"(() => {
  const table = document.getElementById('fleet');
  const tbody = table.tBodies[0];
  const rows = Array.from(tbody.rows);
  const heads = Array.from(table.tHead.rows[0].cells);
  const filter = document.getElementById('filter');
  const area = document.getElementById('area');
  const count = document.getElementById('count');
  const total = rows.length;
  const rank = (tr) => Number(tr.dataset.rank);
  const key = (tr, i) => {
    const c = tr.cells[i];
    return c.hasAttribute('data-value') ? c.getAttribute('data-value') : c.textContent.trim();
  };
  let col = -1;
  let dir = 0;
  const sortBy = (i) => {
    const th = heads[i];
    const num = th.dataset.type === 'num';
    if (col === i) {
      dir = -dir;
    } else {
      col = i;
      dir = th.dataset.first === 'asc' ? 1 : -1;
    }
    const sorted = rows.slice().sort((a, b) => {
      const x = key(a, i);
      const y = key(b, i);
      if (x === '' || y === '') {
        if (x === y) return rank(a) - rank(b);
        return x === '' ? 1 : -1;
      }
      const c = num ? Number(x) - Number(y) : x.localeCompare(y);
      return c !== 0 ? dir * c : rank(a) - rank(b);
    });
    for (const tr of sorted) tbody.appendChild(tr);
    for (const h of heads) {
      h.removeAttribute('aria-sort');
      h.querySelector('.arrow').textContent = '';
    }
    th.setAttribute('aria-sort', dir > 0 ? 'ascending' : 'descending');
    th.querySelector('.arrow').textContent = dir > 0 ? '\u25B2' : '\u25BC';
  };
  heads.forEach((th, i) => {
    th.addEventListener('click', () => sortBy(i));
    th.addEventListener('keydown', (e) => {
      if (e.key === 'Enter' || e.key === ' ') { e.preventDefault(); sortBy(i); }
    });
  });
  const apply = () => {
    const q = filter.value.trim().toLowerCase();
    const a = area.value;
    let shown = 0;
    for (const tr of rows) {
      const ok = (q === '' || tr.dataset.tag.toLowerCase().includes(q))
        && (a === '' || tr.dataset.area === a);
      tr.hidden = !ok;
      if (ok) shown++;
    }
    count.textContent = 'showing ' + shown + ' of ' + total + ' valves';
  };
  filter.addEventListener('input', apply);
  area.addEventListener('change', apply);
  apply();
})();"#;

fn pct(x: f64) -> String {
    format!("{:.0} %", x * 100.0)
}

/// `2.45 % [2.30, 2.60]` (range only when both ends are known); without `%` and with a
/// tooltip when OP's valve span is unknown.
fn s_text(v: &FleetValve) -> String {
    let (unit, open, close) = if v.span_unknown {
        (
            "",
            "<span title=\"% of the OP range the record shows (OP's valve span unknown), not % of valve span\">",
            "*</span>",
        )
    } else {
        (" %", "", "")
    };
    match finite(v.s) {
        None => "-".to_string(),
        Some(s) => match (finite(v.s_lo), finite(v.s_hi)) {
            (Some(lo), Some(hi)) => {
                format!("{open}<span class=\"nw\">{s:.2}{unit}</span> <span class=\"range\">[{lo:.2}, {hi:.2}]</span>{close}")
            }
            _ => format!("{open}{s:.2}{unit}{close}"),
        },
    }
}

/// Causes as one short line, or a `<details>` when there are more than two or they are long.
fn causes_html(v: &FleetValve) -> String {
    let mut h = String::new();
    if let Some(e) = &v.error {
        // a record the detector judged has a verdict; only its fit is missing
        let what = if v.verdict.is_empty() {
            "could not be analysed"
        } else {
            "no fit"
        };
        let _ = write!(h, "<span class=\"err\">{what}: {}</span>", escape(e));
    }
    let causes: Vec<&str> = v
        .causes
        .iter()
        .map(|c| c.trim())
        .filter(|c| !c.is_empty())
        .collect();
    if causes.is_empty() {
        return h;
    }
    if !h.is_empty() {
        h.push_str("<br>");
    }
    let total: usize = causes.iter().map(|c| c.chars().count()).sum();
    if causes.len() <= 2 && total <= 90 {
        let lines: Vec<String> = causes.iter().map(|c| escape(c)).collect();
        h.push_str(&lines.join("<br>"));
        return h;
    }
    let head: String = causes[0].chars().take(60).collect();
    let more = if causes[0].chars().count() > 60 {
        "…"
    } else {
        ""
    };
    let _ = write!(
        h,
        "<details><summary>{}{more} <span class=\"range\">({} lines)</span></summary><ul>",
        escape(&head),
        causes.len()
    );
    for c in &causes {
        let _ = write!(h, "<li>{}</li>", escape(c));
    }
    h.push_str("</ul></details>");
    h
}

/// The `data-value` attribute of a number (empty when missing, so it sorts last).
fn dv(x: Option<f64>) -> String {
    x.map_or_else(String::new, |v| format!("{v}"))
}

/// One valve's row of the fleet table, ranked `rank`.
fn valve_row(h: &mut String, rank: usize, v: &FleetValve) {
    let a = area(&v.valve);
    let date = v
        .registrations
        .last()
        .and_then(|r| r.date.clone())
        .unwrap_or_default();
    let (badge, verdict) = match v.verdict.as_str() {
        "stiction" => ("stiction", "stiction"),
        "no-stiction" => ("no-stiction", "no stiction"),
        "inconclusive" => ("inconclusive", "inconclusive"),
        "" if v.error.is_some() => ("error", "error"),
        "" => ("unknown", "unknown"),
        _ => ("unknown", v.verdict.as_str()),
    };
    let _ = write!(
        h,
        "<tr data-rank=\"{rank}\" data-tag=\"{tag}\" data-area=\"{ae}\" data-priority=\"{}\">\
         <td class=\"n\" data-value=\"{rank}\">{rank}</td>\
         <td class=\"tag\" data-value=\"{tag}\">{tag}</td>\
         <td data-value=\"{ae}\">{ae}</td>\
         <td data-value=\"{de}\">{dh}</td>\
         <td data-value=\"{ve}\"><span class=\"badge b-{badge}\"{why}>{ve}</span></td>\
         <td class=\"n\" data-value=\"{}\">{}</td>\
         <td class=\"n\" data-value=\"{}\">{}</td>",
        priority(v),
        dv(finite(v.score)),
        finite(v.score).map_or_else(|| "-".to_string(), |s| format!("{s:.2}")),
        dv(finite(v.s)),
        s_text(v),
        tag = escape(&v.valve),
        ae = escape(&a),
        de = escape(&date),
        // Wrap between the day and the time, never inside the day.
        dh = date
            .split(' ')
            .map(|p| format!("<span class=\"nw\">{}</span>", escape(p)))
            .collect::<Vec<_>>()
            .join(" "),
        ve = escape(verdict),
        why = v
            .verdict_reason
            .as_deref()
            .map_or_else(String::new, |r| format!(" title=\"{}\"", escape(r))),
    );
    match unit(v.reduction) {
        Some(r) => {
            let _ = write!(
                h,
                "<td class=\"n\" data-value=\"{r}\"><span class=\"ben\">{}\
                 <span class=\"bar\"><i style=\"width:{:.0}%\"></i></span></span></td>",
                pct(r),
                r * 100.0
            );
        }
        None => {
            let why = v
                .repair_reason
                .as_deref()
                .or(v.error.as_deref())
                .unwrap_or("no repair estimate");
            let _ = write!(
                h,
                "<td class=\"n\" data-value=\"\"><span class=\"missing\" title=\"{}\">n/a</span></td>",
                escape(why)
            );
        }
    }
    let _ = write!(h, "<td class=\"causes\">{}</td>", causes_html(v));
    let npts = v
        .registrations
        .iter()
        .filter(|r| finite(r.s).is_some())
        .count();
    match sparkline(v) {
        Some(svg) => {
            let _ = write!(h, "<td data-value=\"{npts}\">{svg}</td>");
        }
        None => {
            let text = if npts == 1 { "1 reg." } else { "no S" };
            let _ = write!(h, "<td class=\"range\" data-value=\"{npts}\">{text}</td>");
        }
    }
    match v.link.as_deref().and_then(safe_link) {
        Some(l) => {
            let _ = write!(
                h,
                "<td><a class=\"latest\" href=\"{}\">latest</a></td>",
                escape(l)
            );
        }
        None => h.push_str("<td></td>"),
    }
    h.push_str("</tr>\n");
}

/// The whole self-contained page, rows already ranked.
pub fn fleet_page(title: &str, valves: &[FleetValve]) -> String {
    let rows = ranked(valves);
    let n = rows.len();
    let with_benefit = rows.iter().filter(|v| unit(v.reduction).is_some()).count();
    let sticky = rows.iter().filter(|v| v.verdict == "stiction").count();
    let mut areas: std::collections::BTreeMap<String, usize> = Default::default();
    for v in &rows {
        *areas.entry(area(&v.valve)).or_default() += 1;
    }

    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>{t}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{t}</h1>\n\
         <p class=\"sub\">{n} valves in {} areas · {sticky} with a stiction verdict · {with_benefit} \
         with a repair benefit. Ranked by expected repair benefit (benefit × detector score).</p>\n",
        areas.len(),
        t = escape(title),
    );
    h.push_str(
        "<div class=\"controls\">\n<label>Tag <input id=\"filter\" type=\"search\" \
         placeholder=\"filter by tag\" autocomplete=\"off\"></label>\n\
         <label>Area <select id=\"area\">\n<option value=\"\">all areas</option>\n",
    );
    for (a, k) in &areas {
        let _ = writeln!(h, "<option value=\"{a}\">{a} ({k})</option>", a = escape(a));
    }
    let _ = write!(
        h,
        "</select></label>\n<span id=\"count\" role=\"status\">showing {n} of {n} valves</span>\n</div>\n"
    );

    // (key, label, numeric, tooltip)
    let cols: [(&str, &str, bool, &str); 11] = [
        ("rank", "#", true, "rank by expected repair benefit"),
        ("valve", "valve", false, "tag"),
        (
            "area",
            "area",
            false,
            "plant area: the tag's leading digits",
        ),
        ("date", "latest", false, "date of the latest registration"),
        ("verdict", "verdict", false, "latest detector verdict"),
        ("score", "score", true, "latest detector score, 0-1"),
        (
            "s",
            "S",
            true,
            "latest S, the one that explains the verdict (% of valve span; * of the OP range seen) [both fits' 95 % regions]",
        ),
        (
            "benefit",
            "benefit",
            true,
            "repair benefit: share of the control error's std a repair removes",
        ),
        ("causes", "causes", false, "latest causes / evidence"),
        (
            "trend",
            "S trend",
            true,
            "S over the registrations (sorted by count)",
        ),
        ("link", "page", false, "the latest registration's page"),
    ];
    h.push_str("<table id=\"fleet\">\n<thead><tr>");
    for (key, label, num, tip) in cols {
        let _ = write!(
            h,
            "<th data-key=\"{key}\" data-type=\"{}\" data-first=\"{}\"{} tabindex=\"0\" title=\"{}\">{}<span class=\"arrow\"></span></th>",
            if num { "num" } else { "text" },
            // rank: 1 first; numbers otherwise largest first; text A-Z.
            if num && key != "rank" { "desc" } else { "asc" },
            if num && key != "trend" { " class=\"n\"" } else { "" },
            escape(tip),
            escape(label)
        );
    }
    h.push_str("</tr></thead>\n<tbody>\n");

    for (i, v) in rows.iter().enumerate() {
        valve_row(&mut h, i + 1, v);
    }
    h.push_str("</tbody>\n</table>\n");
    let _ = write!(
        h,
        "<footer><p><b>Ranking.</b> Expected repair benefit = benefit × w, where benefit is the \
         share of the control error's standard deviation a valve repair removes (if the valve \
         sticks) and w the detector's score (without a score: 1 for stiction, 0.5 inconclusive \
         or unknown, 0 no stiction). Valves without a benefit estimate come last; ties by S. \
         Click a column header to re-sort; # keeps the ranking.</p>\
         <p>Written by stiction {}.</p></footer>\n<script>{SCRIPT}</script>\n</body>\n</html>\n",
        env!("CARGO_PKG_VERSION")
    );
    h
}

/// Writes `dir/index.html` (creating `dir`); returns its path.
pub fn write(dir: &Path, title: &str, valves: &[FleetValve]) -> Result<PathBuf, ReportError> {
    let io = |p: &Path| {
        let path = p.display().to_string();
        move |source| ReportError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let index = dir.join("index.html");
    std::fs::write(&index, fleet_page(title, valves)).map_err(io(&index))?;
    Ok(index)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reg(date: &str, s: f64) -> FleetRegistration {
        FleetRegistration {
            date: Some(date.into()),
            s: Some(s),
            s_lo: Some(s - 0.1),
            s_hi: Some(s + 0.1),
            file: format!("{date}.csv"),
        }
    }

    fn valve(tag: &str, verdict: &str, score: f64, reduction: Option<f64>, s: f64) -> FleetValve {
        FleetValve {
            valve: tag.into(),
            registrations: vec![reg("2024-01-10 08:00", s - 0.5), reg("2024-03-02 14:30", s)],
            verdict: verdict.into(),
            verdict_reason: None,
            score: Some(score),
            s: Some(s),
            span_unknown: false,
            s_lo: Some(s - 0.1),
            s_hi: Some(s + 0.1),
            causes: vec!["stick-slip".into()],
            reduction,
            repair_reason: reduction
                .is_none()
                .then(|| "controller not identified".into()),
            error: None,
            link: Some(format!("valves/{tag}/index.html")),
        }
    }

    fn order(valves: &[FleetValve]) -> Vec<&str> {
        ranked(valves).iter().map(|v| v.valve.as_str()).collect()
    }

    /// Tags in the order the page lists them.
    fn page_order(html: &str) -> Vec<String> {
        html.match_indices("data-tag=\"")
            .map(|(i, m)| {
                let rest = &html[i + m.len()..];
                rest[..rest.find('"').unwrap_or(0)].to_string()
            })
            .collect()
    }

    #[test]
    fn ranking_is_benefit_times_score_then_s() {
        let vs = vec![
            valve("10A", "stiction", 0.9, Some(0.30), 2.0), // 0.27
            valve("10B", "inconclusive", 0.5, Some(0.60), 1.0), // 0.30
            valve("20C", "no-stiction", 0.1, Some(0.50), 5.0), // 0.05
            valve("20D", "stiction", 0.9, Some(0.30), 3.0), // 0.27, larger S
        ];
        assert!((priority(&vs[1]) - 0.30).abs() < 1e-12);
        assert_eq!(order(&vs), ["10B", "20D", "10A", "20C"]);
        let html = fleet_page("fleet", &vs);
        assert_eq!(page_order(&html), ["10B", "20D", "10A", "20C"]);
        assert!(html.contains(
            "<td class=\"n\" data-value=\"1\">1</td><td class=\"tag\" data-value=\"10B\">"
        ));
    }

    #[test]
    fn valve_without_reduction_ranks_last() {
        let mut none = valve("1A", "stiction", 1.0, None, 9.0);
        none.score = Some(1.0);
        let vs = vec![
            none,
            valve("1B", "no-stiction", 0.0, Some(0.0), 0.1), // priority 0, but known
            valve("1C", "stiction", 0.2, Some(0.1), 0.5),
        ];
        assert_eq!(priority(&vs[0]), 0.0);
        assert_eq!(order(&vs), ["1C", "1B", "1A"]);
        let html = fleet_page("fleet", &vs);
        assert!(html.contains("title=\"controller not identified\">n/a</span>"));
    }

    #[test]
    fn weight_without_score_follows_the_verdict() {
        let mut v = valve("1A", "stiction", 0.0, Some(0.4), 1.0);
        v.score = None;
        assert_eq!(priority(&v), 0.4);
        v.verdict = "inconclusive".into();
        assert_eq!(priority(&v), 0.2);
        v.verdict = "no-stiction".into();
        assert_eq!(priority(&v), 0.0);
        v.reduction = Some(f64::NAN);
        assert_eq!(priority(&v), 0.0);
    }

    #[test]
    fn areas_from_tag_prefix() {
        assert_eq!(area("2411FIC20102"), "2411");
        assert_eq!(area("FIC101"), "FIC");
        assert_eq!(area(" 77-PC-1"), "77");
        assert_eq!(area("_x"), "-");
    }

    #[test]
    fn text_is_escaped() {
        let mut v = valve("<script>alert(1)</script>", "stiction", 0.9, None, 1.0);
        v.causes = vec![
            "<img src=x onerror=alert(2)>".into(),
            "a \"quoted\" & 'single'".into(),
        ];
        v.repair_reason = Some("\"><b>bold</b>".into());
        v.error = Some("</td><script>".into());
        v.link = Some("x\"><script>alert(3)</script>".into());
        v.registrations[0].file = "<f>".into();
        v.registrations[0].date = Some("<d>".into());
        let html = fleet_page("<title>", &[v]);
        assert!(!html.contains("<script>alert"));
        assert!(!html.contains("<img"));
        assert!(!html.contains("<b>bold"));
        assert!(!html.contains("</td><script>"));
        assert!(!html.contains("<title><title>"));
        assert!(html.contains("&lt;script&gt;alert(1)&lt;/script&gt;"));
        assert!(html.contains("&lt;img src=x onerror=alert(2)&gt;"));
        assert!(html.contains("&quot;&gt;&lt;b&gt;bold&lt;/b&gt;"));
        // The only script element is the page's own.
        assert_eq!(html.matches("<script").count(), 1);
    }

    #[test]
    fn sparkline_only_with_two_points() {
        let mut v = valve("1A", "stiction", 0.9, Some(0.2), 1.0);
        let svg = sparkline(&v).expect("two registrations draw a line");
        assert_eq!(svg.matches("<circle").count(), 2);
        assert_eq!(
            svg.matches("#c0392b").count(),
            1,
            "the last point is highlighted"
        );
        assert!(fleet_page("f", std::slice::from_ref(&v)).contains("<svg class=\"spark\""));
        v.registrations.truncate(1);
        assert!(sparkline(&v).is_none());
        assert!(!fleet_page("f", std::slice::from_ref(&v)).contains("<svg"));
        // A registration without S is not a point.
        v.registrations.push(FleetRegistration {
            s: None,
            ..reg("2024-05-01 00:00", 1.0)
        });
        assert!(sparkline(&v).is_none());
    }

    #[test]
    fn sparkline_places_points_by_date() {
        let mut v = valve("1A", "stiction", 0.9, Some(0.2), 1.0);
        v.registrations = vec![
            reg("2024-01-01 00:00", 1.0),
            reg("2024-01-02 00:00", 2.0),
            reg("2024-01-11 00:00", 3.0),
        ];
        let svg = sparkline(&v).unwrap_or_default();
        // x from 4 to 116: day 1 of 10 sits at 4 + 11.2.
        assert!(
            svg.contains("points=\"4.0,24.0 15.2,14.0 116.0,4.0\""),
            "{svg}"
        );
    }

    #[test]
    fn no_network_reference() {
        let mut v = valve("1A", "stiction", 0.9, Some(0.2), 1.0);
        let mut w = valve("1B", "stiction", 0.9, Some(0.2), 1.0);
        v.link = Some("https://example.com/x.html".into());
        w.link = Some("//example.com/x.html".into());
        let mut j = valve("1C", "stiction", 0.9, Some(0.2), 1.0);
        j.link = Some("javascript:alert(1)".into());
        let html = fleet_page("fleet", &[v, w, j, valve("1D", "", 0.5, None, 2.0)]);
        for bad in [
            "http://",
            "https://",
            "//example",
            "javascript:",
            "@import",
            "url(",
        ] {
            assert!(!html.contains(bad), "the page contains {bad:?}");
        }
        assert!(html.contains("href=\"valves/1D/index.html\""));
        assert!(!html.contains(" src="));
    }

    #[test]
    fn long_causes_collapse() {
        let mut v = valve("1A", "stiction", 0.9, Some(0.2), 1.0);
        assert!(!fleet_page("f", std::slice::from_ref(&v)).contains("<details>"));
        v.causes = vec!["one".into(), "two".into(), "three".into()];
        let html = fleet_page("f", &[v]);
        assert!(html.contains("<details><summary>one"));
        assert!(html.contains("<li>three</li>"));
    }

    #[test]
    fn write_creates_index() {
        let dir = std::env::temp_dir().join(format!("fleet-write-{}", std::process::id()));
        let p = write(
            &dir,
            "fleet",
            &[valve("1A", "stiction", 0.9, Some(0.2), 1.0)],
        )
        .expect("written");
        assert_eq!(p, dir.join("index.html"));
        let text = std::fs::read_to_string(&p).unwrap_or_default();
        assert!(text.starts_with("<!DOCTYPE html>"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
