//! `stiction trend`: one valve recorded again and again (paper §5.2): quantify every
//! registration, order them in time, follow S (and J), flag and explain outliers, and give a
//! maintenance verdict.

use std::path::PathBuf;

use anyhow::anyhow;
use datasets::format_epoch;
use stiction_models::find_model;

use super::batch::IntegratingFlag;
use super::load::DataFlags;
use super::search_flags::SearchFlags;
use crate::reporting::ReportFlags;
use crate::{data, usage, CmdResult, Streams};
use monitoring::batch::DEFAULT_MIN_FIT;
use monitoring::registration::{expand, Registration};
use monitoring::trend::{self, TrendOptions, ValveTrend, DEFAULT_HORIZON, DEFAULT_THRESHOLD};
use monitoring::{median, Flag};
use report::figures::TrendLine;
use report::{figures, Block, Report, Section, TrendPoint, TrendStatus};

pub(crate) const AFTER_HELP: &str = "\
Every registration (file) of one valve is quantified with every stiction x linear
combination; registrations are ordered by the time in the file name (<valve>_YYYYMMDD-HHMM)
or else their first time stamp. For each combination:
  weak      validation F_PV below --min-fit: not used for the trend, with the evidence why
  outlier   S outside median +- max(3 x 1.4826 x MAD, 0.1) of the other usable
            registrations (4 or more needed): not used for the trend, with the evidence why
  level     median S of the usable registrations; slope: Theil-Sen, % per 30 days
Verdict (on the mean over combinations of level, latest usable S and projected S):
  schedule maintenance   level >= threshold
  watch                  level < threshold, but the latest usable S or the level projected
                         --horizon days ahead >= threshold, or level >= threshold / 2
  healthy                otherwise; undetermined when no registration is usable

Examples:
  stiction trend ../shared/data/plant --valve 2411FIC20102
  stiction trend data/V1_*.csv --threshold 1.5 --json
  stiction trend DIR --valve LIC1 --stiction kano,he --linear arx,armax";

/// Arguments of `stiction trend`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Registration files, or directories of them (.csv, .tsv, .txt, .mat).
    #[arg(required = true, value_name = "FILES|DIR")]
    paths: Vec<PathBuf>,
    /// The valve to follow (file-name prefix before `_`); required when the files hold several.
    #[arg(long, value_name = "TAG")]
    valve: Option<String>,
    /// Stiction models, comma-separated.
    #[arg(
        long,
        value_name = "A,B",
        value_delimiter = ',',
        default_value = "kano"
    )]
    stiction: Vec<String>,
    /// Linear identifiers, comma-separated.
    #[arg(long, value_name = "X,Y", value_delimiter = ',', default_value = "arx")]
    linear: Vec<String>,
    /// Maintenance threshold on S, % of valve span.
    #[arg(long, value_name = "S%", default_value_t = DEFAULT_THRESHOLD)]
    threshold: f64,
    /// Minimum validation F_PV (%) for a registration to count in the trend.
    #[arg(long, value_name = "PCT", default_value_t = DEFAULT_MIN_FIT)]
    min_fit: f64,
    /// How far ahead (days) the trend is projected for the `watch` verdict.
    #[arg(long, value_name = "DAYS", default_value_t = DEFAULT_HORIZON)]
    horizon: f64,
    /// Integrating loops are identified from MV to ΔPV; `auto` = level loops (tag letter L).
    #[arg(long, value_enum, default_value = "auto")]
    integrating: IntegratingFlag,
    #[command(flatten)]
    search: SearchFlags,
    #[command(flatten)]
    data: DataFlags,
    /// Do not diagnose the weak and outlying registrations (faster; `why` then lists only the
    /// evidence from the quantification itself).
    #[arg(long)]
    no_diagnose: bool,
    #[command(flatten)]
    report: ReportFlags,
    /// Print one JSON document.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    for name in &args.stiction {
        find_model(name).map_err(usage)?;
    }
    let settings = args.search.settings(&args.linear)?;
    if !(args.threshold.is_finite() && args.threshold >= 0.0) {
        return Err(usage(anyhow!(
            "--threshold {}: expected a non-negative S in % of valve span",
            args.threshold
        )));
    }
    let (files, not_loops) = expand(&args.paths, &[], args.data.op_column()).map_err(usage)?;
    for n in &not_loops {
        let _ = writeln!(s.stderr, "note: skipped {}: {n}", n.path.display());
    }
    let mut by_valve = trend::by_valve(files);
    let (valve, files) = match &args.valve {
        Some(v) => match by_valve.remove(v) {
            Some(f) => (v.clone(), f),
            None => {
                return Err(data(anyhow!(
                    "no registration of valve {v} (found: {})",
                    by_valve.keys().cloned().collect::<Vec<_>>().join(", ")
                )))
            }
        },
        None if by_valve.len() == 1 => by_valve.pop_first().unwrap_or_default(),
        None if by_valve.is_empty() => return Err(data(anyhow!("no registration files found"))),
        None => {
            let list: Vec<String> = by_valve
                .iter()
                .map(|(k, v)| format!("{k} ({})", v.len()))
                .collect();
            return Err(usage(anyhow!(
                "trend follows one valve; the files hold {}: choose one with --valve",
                list.join(", ")
            )));
        }
    };
    let options = TrendOptions {
        stiction: args.stiction.clone(),
        linear: args.linear.clone(),
        settings,
        read: args.data.read_options(true, monitoring::batch::MIN_ROWS),
        integrating: args.integrating.into(),
        min_fit: args.min_fit,
        threshold: args.threshold,
        horizon: args.horizon,
    };
    let bar = crate::progress::Progress::new(s.progress, &format!("trend {valve}"));
    let tick = |done: usize, total: usize| bar.update(done, total);
    let diagnoser = discrepancy::registration::RegistrationDiagnosis;
    let vt = trend::follow(
        &valve,
        &files,
        &options,
        (!args.no_diagnose).then_some(&diagnoser as _),
        Some(&tick),
    );
    bar.finish();
    let vt = vt.map_err(usage)?;

    if args.report.report.is_some() {
        trend_report(&args, &vt, s)?;
    }
    if args.json {
        let doc = serde_json::to_value(vt.record()).map_err(data)?;
        serde_json::to_writer_pretty(&mut *s.stdout, &doc).map_err(data)?;
        writeln!(s.stdout).map_err(data)?;
        return Ok(());
    }

    let out = &mut *s.stdout;
    let regs = &vt.registrations;
    let first = regs.iter().find_map(|r| r.start).map(format_epoch);
    let last = regs.iter().rev().find_map(|r| r.start).map(format_epoch);
    writeln!(
        out,
        "valve {valve}: {} registration(s), {} .. {}{}",
        regs.len(),
        first.unwrap_or_else(|| "?".into()),
        last.unwrap_or_else(|| "?".into()),
        if regs.iter().any(|r| r.integrating) {
            "; integrating loop: identified from MV to ΔPV"
        } else {
            ""
        }
    )
    .map_err(data)?;
    for (c, ct) in vt.combinations.iter().enumerate() {
        let t = &ct.trend;
        writeln!(out, "\n{} + {}", ct.stiction, ct.linear).map_err(data)?;
        writeln!(
            out,
            "{:>3}  {:<16}  {:>6} {:>13}  {:>5} {:>11}  {:>8}  {:<7}  why",
            "#", "time", "S", "S range", "J", "J range", "F_PV val", "flag"
        )
        .map_err(data)?;
        for (k, (r, flag)) in regs.iter().zip(&t.flags).enumerate() {
            let time = r.start.map(format_epoch).unwrap_or_else(|| r.file.clone());
            match (r.fit(c), r.error(c)) {
                (Some(f), _) => {
                    let why = if *flag == Flag::Used {
                        String::new()
                    } else if f.evidence.is_empty() {
                        "no evidence of a disturbance in this registration: the valve itself \
                         may have changed (maintenance, operating range)"
                            .to_string()
                    } else {
                        join(&f.evidence)
                    };
                    writeln!(
                        out,
                        "{:>3}  {time:<16}  {:>6.2} {:>13}  {:>5.2} {:>11}  {:>8.1}  {:<7}  {why}",
                        k + 1,
                        f.s,
                        format!("{:.2}-{:.2}", f.s_range[0], f.s_range[1]),
                        f.j,
                        format!("{:.2}-{:.2}", f.j_range[0], f.j_range[1]),
                        f.fit_val,
                        flag.label()
                    )
                    .map_err(data)?;
                }
                (None, e) => {
                    let e = e.map(ToString::to_string).unwrap_or_default();
                    writeln!(out, "{:>3}  {time:<16}  error: {}: {e}", k + 1, r.file)
                        .map_err(data)?;
                }
            }
        }
        let count = |x: Flag| t.flags.iter().filter(|f| **f == x).count();
        writeln!(
            out,
            "  usable {}, weak {}, outliers {}, errors {}{}",
            count(Flag::Used),
            count(Flag::Weak),
            count(Flag::Outlier),
            count(Flag::Error),
            t.band
                .map(|b| format!("; outlier band S in [{:.2}, {:.2}]", b[0], b[1]))
                .unwrap_or_default()
        )
        .map_err(data)?;
        writeln!(out, "  {}", level_line(t)).map_err(data)?;
    }
    writeln!(out, "\nverdict: {}: {}", vt.verdict, vt.reason).map_err(data)?;
    writeln!(out, "rule: {}", vt.rule()).map_err(data)?;
    Ok(())
}

/// Evidence joined with `; `.
fn join(evidence: &[monitoring::Evidence]) -> String {
    let v: Vec<String> = evidence.iter().map(ToString::to_string).collect();
    v.join("; ")
}

/// `level (median S) ...; trend ...; latest usable S ...`.
fn level_line(t: &monitoring::Trend) -> String {
    format!(
        "level (median S) {}; trend {}; latest usable S {}",
        t.level.map_or("-".into(), |v| format!("{v:.2} %")),
        t.slope_30d
            .map_or("-".into(), |v| format!("{v:+.3} % per 30 days (Theil-Sen)")),
        t.latest.map_or("-".into(), |v| format!("{v:.2} %")),
    )
}

/// The report of `trend`: the verdict, then per combination S over the registrations and
/// the table behind it.
fn trend_report(args: &Args, vt: &ValveTrend, s: &mut Streams<'_>) -> Result<(), crate::Failure> {
    let started = std::time::Instant::now();
    let (valve, regs) = (vt.valve.as_str(), vt.registrations.as_slice());
    let (verdict, reason, rule) = (vt.verdict.label(), vt.reason.as_str(), vt.rule());
    let dated = regs.iter().all(|r| r.start.is_some());
    let day = |k: usize, r: &Registration| match (dated, r.start) {
        (true, Some(t)) => t / 86400.0,
        _ => (k + 1) as f64,
    };
    let mut sections = Vec::new();
    for (c, ct) in vt.combinations.iter().enumerate() {
        let t = &ct.trend;
        let model = format!("{} × {}", ct.stiction, ct.linear);
        let mut sec = Section::new(model.clone());
        let mut points = Vec::new();
        let mut rows = Vec::new();
        for (k, (r, flag)) in regs.iter().zip(&t.flags).enumerate() {
            let time = r.start.map(format_epoch).unwrap_or_else(|| r.file.clone());
            match (r.fit(c), r.error(c)) {
                (None, e) => rows.push(vec![
                    (k + 1).to_string(),
                    time,
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "error".into(),
                    format!(
                        "{}: {}",
                        r.file,
                        e.map(ToString::to_string).unwrap_or_default()
                    ),
                ]),
                (Some(f), _) => {
                    let status = match flag {
                        Flag::Used => TrendStatus::Used,
                        Flag::Weak | Flag::Error => TrendStatus::Weak,
                        Flag::Outlier => TrendStatus::Outlier,
                    };
                    points.push(TrendPoint {
                        day: day(k, r),
                        s: f.s,
                        interval: Some(f.s_range),
                        status,
                    });
                    rows.push(vec![
                        (k + 1).to_string(),
                        time,
                        format!("{:.2}", f.s),
                        format!("{:.2}-{:.2}", f.s_range[0], f.s_range[1]),
                        format!("{:.2}", f.j),
                        format!("{:.1}", f.fit_val),
                        flag.label().into(),
                        if *flag == Flag::Used {
                            String::new()
                        } else {
                            join(&f.evidence)
                        },
                    ]);
                }
            }
        }
        // The Theil-Sen line through the used points: slope, and the median intercept.
        let line = t.slope_30d.filter(|_| dated).and_then(|m30| {
            let slope = m30 / 30.0;
            let used: Vec<&TrendPoint> = points
                .iter()
                .filter(|p| p.status == TrendStatus::Used)
                .collect();
            let day0 = used.first()?.day;
            let icpt: Vec<f64> = used.iter().map(|p| p.s - slope * (p.day - day0)).collect();
            Some(TrendLine {
                day0,
                s0: median(&icpt),
                slope,
            })
        });
        sec.push(Block::Paragraph(format!(
            "Level (median S of the usable registrations) {}; trend {}; latest usable S {}.",
            t.level.map_or("-".into(), |v| format!("{v:.2} %")),
            t.slope_30d
                .map_or("-".into(), |v| format!("{v:+.3} % per 30 days (Theil-Sen)")),
            t.latest.map_or("-".into(), |v| format!("{v:.2} %")),
        )));
        if !points.is_empty() {
            let fig = figures::s_trend(
                valve,
                &model,
                &points,
                args.threshold,
                line,
                dated,
                &format!("{}-{}-s-trend", ct.stiction, ct.linear),
            )
            .map_err(|e| data(anyhow!("report: {e}")))?;
            sec.push(Block::Figure(fig));
        }
        sec.push(Block::Table {
            header: ["#", "time", "S", "S range", "J", "F_PV val", "flag", "why"]
                .map(String::from)
                .to_vec(),
            rows,
        });
        sections.push(sec);
    }
    // Registrations the reader refused: the reason and the raw columns (the first few).
    let refused: Vec<(&Registration, &monitoring::RegistrationError)> = regs
        .iter()
        .filter_map(|r| r.outcome.as_ref().err().map(|e| (r, e)))
        .collect();
    if !refused.is_empty() {
        let mut sec = Section::new(format!("Refused registrations ({})", refused.len()));
        for (k, (r, e)) in refused.iter().enumerate() {
            sec.push(Block::Note(format!("{}: {e}", r.file)));
            if k >= 4 {
                continue;
            }
            let stem = r
                .path
                .file_stem()
                .map_or_else(|| r.file.clone(), |s| s.to_string_lossy().into_owned());
            if let Some(cols) = crate::reporting::raw_columns(&r.path) {
                let fig = figures::raw_signals(&stem, &cols, &format!("raw-{}", k + 1))
                    .map_err(|e| data(anyhow!("report: {e}")))?;
                sec.push(Block::Figure(fig));
            }
        }
        sections.push(sec);
    }
    let mut rules = Section::new("How the verdict is reached");
    rules.push(Block::Paragraph(rule));
    sections.push(rules);
    // The verdict first, in its own box, then why.
    let mut first = Section::new("Verdict");
    first.push(Block::Verdict(format!("Verdict: {verdict}.")));
    first.push(Block::Paragraph(reason.to_string()));
    sections.insert(0, first);
    let rep = Report {
        title: format!("trend: valve {valve}"),
        subtitle: format!(
            "{} registration(s) · stiction trend · threshold {} % of valve span",
            regs.len(),
            args.threshold
        ),
        summary: Vec::new(),
        sections,
    };
    crate::reporting::write(&rep, &args.report, started, s)
}
