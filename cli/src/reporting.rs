//! `--report DIR`: the HTML report of a run (crate `report`), shared by quantify, compare,
//! diagnose and trend.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::anyhow;
use datasets::LoopData;
use grid_search::{Quantification, Severity, HARMFUL_S, MAINTENANCE_S, NEGLIGIBLE_S};
use report::{figures, Block, Figure, LoopSignals, Report, Section, WriteOptions};

use crate::{data, Failure, Streams};
use discrepancy::Fitted;
use stiction_models::ModelEntry;

/// The report flags.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Report options")]
pub struct ReportFlags {
    /// Write a report to DIR: index.html (self-contained: numbers, plots inline, summary) and
    /// each plot as DIR/<name>.svg.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Also write each plot of the report as PNG.
    #[arg(long, requires = "report")]
    pub png: bool,
}

/// The loop's name for titles: the file stem, or the source as given.
pub(crate) fn loop_name(d: &LoopData) -> String {
    let src = d.source.as_str();
    if src.starts_with("example ") {
        return src
            .split(" (")
            .next()
            .unwrap_or(src)
            .trim_start_matches("example ")
            .to_string()
            + " (example)";
    }
    Path::new(src)
        .file_stem()
        .map_or_else(|| src.to_string(), |s| s.to_string_lossy().into_owned())
}

/// The signals of `d` for the figures (`None` without PV).
pub(crate) fn signals<'a>(d: &'a LoopData, name: &'a str) -> Option<LoopSignals<'a>> {
    Some(LoopSignals {
        name,
        t: d.t.as_deref(),
        sp: d.sp.as_deref(),
        pv: d.pv.as_deref()?,
        op: &d.op,
        mv: d.mv.as_deref(),
    })
}

/// `kano × arx`.
pub(crate) fn combo(r: &Fitted) -> String {
    format!("{} × {}", r.stiction.name, r.linear)
}

fn f2(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2}")
    } else {
        "-".into()
    }
}

fn opt2(x: Option<f64>) -> String {
    x.map_or_else(|| "-".into(), f2)
}

/// One sentence on what a quantification says about the valve, with how far to trust it. The
/// levels are [`grid_search::trust`]'s, the only place they are defined: "the valve sticks"
/// only for S >= [`HARMFUL_S`] with no doubt; a slight S or a doubtful estimate says so.
pub(crate) fn verdict(q: &Quantification, label: &str) -> String {
    let (_, val) = q.fits.rank(q.criterion);
    let fit = format!(
        "validation F_PV {:.1} % ({})",
        val,
        match q.criterion {
            grid_search::Criterion::Prediction => "one-step prediction",
            grid_search::Criterion::Simulation => "free-run simulation",
        }
    );
    let v = q.verdict();
    let region = format!(
        "S = {:.2} % of valve span (deadband + stickband; {:.0} % region {:.2}-{:.2}), J = {:.2} % (region {:.2}-{:.2})",
        q.s,
        100.0 * q.interval.confidence,
        q.interval.s[0],
        q.interval.s[1],
        q.j,
        q.interval.j[0],
        q.interval.j[1]
    );
    let doubts: Vec<String> = v.doubts.iter().map(grid_search::Doubt::short).collect();
    match v.severity {
        Severity::Negligible if doubts.is_empty() => format!(
            "{label}: no stiction found (S = {:.2} % of valve span, at most {NEGLIGIBLE_S} %); {fit}.",
            q.s
        ),
        Severity::Negligible => format!(
            "{label}: no stiction found (S = {:.2} % of valve span, at most {NEGLIGIBLE_S} %), but the evidence is weak: {}; {fit}.",
            q.s,
            doubts.join("; ")
        ),
        _ if !doubts.is_empty() => format!(
            "{label}: estimated {region}, but the evidence is weak: {}; {fit}. Do not act on this estimate alone: look at the figures, or repeat the registration.",
            doubts.join("; ")
        ),
        Severity::Slight => format!(
            "{label}: slight stiction, {region}; {fit}. Below the {HARMFUL_S} % at which stiction degrades control."
        ),
        Severity::Harmful => {
            let maintenance = if q.s >= MAINTENANCE_S {
                format!(
                    " It is at or above the {MAINTENANCE_S} % maintenance threshold of `stiction trend`."
                )
            } else {
                String::new()
            };
            format!(
                "{label}: the valve sticks, {region}; {fit}. Stiction of {HARMFUL_S} % or more degrades control.{maintenance}"
            )
        }
    }
}

/// The verdict in a few words, for the text output (`verdict: ...`).
pub(crate) fn verdict_line(q: &Quantification) -> String {
    let v = q.verdict();
    if !v.doubts.is_empty() && v.severity != Severity::Negligible {
        let doubts: Vec<String> = v.doubts.iter().map(grid_search::Doubt::short).collect();
        return format!(
            "S = {:.2} % is not to be trusted alone: {}",
            q.s,
            doubts.join("; ")
        );
    }
    match v.severity {
        Severity::Negligible => format!("no stiction found (S at most {NEGLIGIBLE_S} %)"),
        Severity::Slight => {
            format!("slight stiction (S between {NEGLIGIBLE_S} and {HARMFUL_S} %)")
        }
        Severity::Harmful if q.s >= MAINTENANCE_S => format!(
            "the valve sticks (S of {HARMFUL_S} % or more degrades control; at or above the {MAINTENANCE_S} % maintenance threshold)"
        ),
        Severity::Harmful => {
            format!("the valve sticks (S of {HARMFUL_S} % or more degrades control)")
        }
    }
}

/// The best model's own parameters and derived values, `name = value` (3 decimals).
pub(crate) fn own_params(entry: &ModelEntry, q: &Quantification) -> Vec<String> {
    entry
        .params
        .iter()
        .zip(q.stiction.param_values())
        .map(|(p, v)| format!("{} = {v:.3}", p.name))
        .chain(
            q.stiction
                .derived_values()
                .into_iter()
                .map(|(k, v)| format!("{k} = {v:.3}")),
        )
        .collect()
}

/// The numbers of one run as name/value pairs.
pub(crate) fn facts(r: &Fitted) -> Block {
    let q = &r.result;
    let (fid, fval) = q.fits.rank(q.criterion);
    let (oid, oval) = q.fits.rank(q.criterion.other());
    let own = own_params(r.stiction, q);
    let orders: Vec<String> = r
        .identifier
        .orders()
        .iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect();
    Block::Facts(vec![
        (
            "S (% of valve span)".into(),
            format!(
                "{:.2}  (region {:.2}-{:.2})",
                q.s, q.interval.s[0], q.interval.s[1]
            ),
        ),
        (
            "J (% of valve span)".into(),
            format!(
                "{:.2}  (region {:.2}-{:.2})",
                q.j, q.interval.j[0], q.interval.j[1]
            ),
        ),
        ("stiction parameters".into(), own.join(", ")),
        (
            "linear model".into(),
            format!(
                "{} ({}), dead time {} samples",
                r.linear,
                orders.join(", "),
                r.delay
            ),
        ),
        (
            format!("F_PV {} id / val (%)", q.criterion.label()),
            format!("{} / {}", f2(fid), f2(fval)),
        ),
        (
            format!("F_PV {} id / val (%)", q.criterion.other().label()),
            format!("{} / {}", f2(oid), f2(oval)),
        ),
        ("F_MV (%)".into(), opt2(q.fits.mv)),
        (
            "best fit without stiction (val, %)".into(),
            opt2(q.fit_no_stiction),
        ),
        (
            "grid".into(),
            format!(
                "{} nodes ({} skipped), finest step {}, OP span {:.2}",
                q.nodes_evaluated,
                q.nodes_skipped,
                (q.grid.step() * 1e6).round() / 1e6,
                q.span
            ),
        ),
        (
            "samples".into(),
            format!(
                "{} (valve state known from {}, validation from {})",
                q.mv_est.len(),
                q.fits.valid_from,
                q.split_index
            ),
        ),
        ("run time".into(), format!("{:.0} ms", r.elapsed_ms)),
    ])
}

/// The figures of one run: time trends, phase plots, fit surface. `prefix` keeps the file
/// names of several runs apart; `role` (e.g. `baseline`) is added to the model in the titles.
pub(crate) fn run_figures(
    sig: &LoopSignals<'_>,
    r: &Fitted,
    prefix: &str,
    role: &str,
) -> Result<Vec<Figure>, Failure> {
    let model = if role.is_empty() {
        combo(r)
    } else {
        format!("{}, {role}", combo(r))
    };
    let q = &r.result;
    let rep = |e: report::ReportError| data(anyhow!("report: {e}"));
    Ok(vec![
        figures::time_trends(sig, q, &model, &format!("{prefix}trends")).map_err(rep)?,
        figures::phase_plots(sig, q, &model, &format!("{prefix}phase")).map_err(rep)?,
        figures::fit_surface(q, sig.name, &model, &format!("{prefix}surface")).map_err(rep)?,
    ])
}

/// Write `rep` to the flags' directory and say so on stderr.
pub(crate) fn write(
    rep: &Report,
    flags: &ReportFlags,
    started: Instant,
    s: &mut Streams<'_>,
) -> Result<(), Failure> {
    let Some(dir) = &flags.report else {
        return Ok(());
    };
    let w = rep
        .write(dir, WriteOptions { png: flags.png })
        .map_err(|e| data(anyhow!("report: {e}")))?;
    let _ = writeln!(
        s.stderr,
        "report: {} ({} figure files, {:.0} kB, {:.0} ms)",
        w.index.display(),
        w.files.len(),
        w.bytes as f64 / 1e3,
        started.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}

/// The numeric columns of a delimited text file, read leniently (non-numbers become NaN), for
/// showing data the reader refused. At most six columns, the loop's own first.
pub(crate) fn raw_columns(path: &Path) -> Option<Vec<(String, Vec<f64>)>> {
    let text = std::fs::read_to_string(path).ok()?;
    let first = text.lines().next()?;
    let delim = [b',', b';', b'\t']
        .into_iter()
        .max_by_key(|d| first.bytes().filter(|b| b == d).count())?;
    let mut rdr = csv::ReaderBuilder::new()
        .delimiter(delim)
        .flexible(true)
        .from_reader(text.as_bytes());
    let header: Vec<String> = rdr.headers().ok()?.iter().map(str::to_string).collect();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
    for rec in rdr.records().flatten() {
        for (i, c) in cols.iter_mut().enumerate() {
            c.push(
                rec.get(i)
                    .and_then(|v| v.trim().parse::<f64>().ok())
                    .unwrap_or(f64::NAN),
            );
        }
    }
    let order = ["SP", "PV", "OP", "MV"];
    let mut named: Vec<(String, Vec<f64>)> = header
        .into_iter()
        .zip(cols)
        .filter(|(_, v)| v.iter().any(|x| x.is_finite()))
        .filter(|(h, _)| !matches!(h.to_ascii_lowercase().as_str(), "t" | "time"))
        .collect();
    named.sort_by_key(|(h, _)| {
        order
            .iter()
            .position(|o| o.eq_ignore_ascii_case(h))
            .unwrap_or(order.len())
    });
    named.truncate(6);
    (!named.is_empty()).then_some(named)
}

/// When a loop could not be read: write a report that says why (with the raw columns when the
/// file is delimited text), then hand the failure back.
pub(crate) fn refused(
    file: Option<&Path>,
    failure: Failure,
    flags: &ReportFlags,
    command: &str,
    s: &mut Streams<'_>,
) -> Failure {
    let (Some(_), Some(path)) = (&flags.report, file) else {
        return failure;
    };
    // A file that is not there (or not a file) has nothing to show: no page, only the error.
    if path.as_os_str() != "-" && !path.is_file() {
        return failure;
    }
    let started = Instant::now();
    let stem = path.file_stem().map_or_else(
        || path.display().to_string(),
        |s| s.to_string_lossy().into(),
    );
    let msg = crate::one_line(failure.error());
    let mut sec = Section::new("Why the data were refused");
    sec.push(Block::Note(msg.clone()));
    let mut figure = None;
    if path.as_os_str() != "-" {
        if let Some(cols) = raw_columns(path) {
            match figures::raw_signals(&stem, &cols, "raw") {
                Ok(f) => figure = Some(f),
                Err(e) => {
                    sec.push(Block::Note(format!("the raw data could not be drawn: {e}")));
                }
            }
        }
    }
    sec.push(Block::Paragraph(if figure.is_some() {
        "The data were not analysed: the estimate would not be trustworthy. The figure shows \
         the columns as logged so the problem can be seen; see `stiction --help` for the \
         column and gap options."
            .into()
    } else {
        "The data were not analysed: the estimate would not be trustworthy. No column of the \
         file could be read as numbers to draw; see `stiction --help` for the column and gap \
         options."
            .into()
    }));
    if let Some(f) = figure {
        sec.push(Block::Figure(f));
    }
    let rep = Report {
        title: format!("{command}: loop {stem} refused"),
        subtitle: format!("{} · stiction {command}", path.display()),
        summary: vec![format!("No estimate: {msg}")],
        sections: vec![sec],
    };
    if let Err(e) = write(&rep, flags, started, s) {
        let _ = writeln!(s.stderr, "warning: {:#}", e.error());
    }
    failure
}
