//! `stiction trend`: one valve recorded again and again (paper §5.2): quantify every
//! registration, order them in time, follow S (and J), flag and explain outliers, and give a
//! maintenance verdict.

use std::path::PathBuf;

use anyhow::anyhow;
use datasets::format_epoch;
use rayon::prelude::*;
use serde_json::{json, Value};
use stiction_models::find_model;

use super::load::DataFlags;
use super::registrations::{
    diagnose_registration, evaluate, expand, median, ComboFit, FitEvidence, IntegratingFlag, Plan,
    Registration,
};
use super::search_flags::{build_identifier, SearchFlags};
use crate::reporting::ReportFlags;
use crate::{data, usage, CmdResult, Streams};
use monitoring::{maintenance, trend, Flag, Point, Trend};
use report::figures::TrendLine;
use report::{figures, Block, Report, Section, TrendPoint, TrendStatus};

/// Default maintenance threshold on S, % of valve span (see `docs/PLANT_DATA.md`).
pub(crate) const DEFAULT_THRESHOLD: f64 = grid_search::MAINTENANCE_S;
/// Default minimum validation fit for a registration to count, %.
pub(crate) const DEFAULT_MIN_FIT: f64 = grid_search::trust::WEAK_FIT;

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
    #[arg(long, value_name = "DAYS", default_value_t = 90.0)]
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

/// The trend of one combination (the workflow library's, with the combination's names).
struct ComboTrend {
    stiction: String,
    linear: String,
    trend: Trend,
}

impl std::ops::Deref for ComboTrend {
    type Target = Trend;
    fn deref(&self) -> &Trend {
        &self.trend
    }
}

fn fit_at(r: &Registration, c: usize) -> Option<&ComboFit> {
    r.outcome.as_ref().ok()?.get(c)?.result.as_ref().ok()
}

/// The stiction and linear names of combination `c` (stiction-major order).
fn combo_names(args: &Args, c: usize) -> (&str, &str) {
    let n = args.linear.len().max(1);
    (&args.stiction[c / n], &args.linear[c % n])
}

fn trend_of(regs: &[Registration], c: usize, min_fit: f64, names: (&str, &str)) -> ComboTrend {
    let points: Vec<Point> = regs
        .iter()
        .map(|r| Point {
            start: r.start,
            fit: fit_at(r, c).map(|f| (f.s, f.fit_val)),
        })
        .collect();
    ComboTrend {
        stiction: names.0.to_string(),
        linear: names.1.to_string(),
        trend: trend(&points, min_fit),
    }
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    for name in &args.stiction {
        find_model(name).map_err(usage)?;
    }
    for name in &args.linear {
        build_identifier(name, args.search.orders.as_deref(), 0)?;
    }
    if !(args.threshold.is_finite() && args.threshold >= 0.0) {
        return Err(usage(anyhow!(
            "--threshold {}: expected a non-negative S in % of valve span",
            args.threshold
        )));
    }
    let (files, not_loops) = expand(&args.paths, &[], args.data.op_column()).map_err(usage)?;
    for (f, why) in &not_loops {
        let _ = writeln!(s.stderr, "note: skipped {}: {why}", f.display());
    }
    let mut by_valve: std::collections::BTreeMap<String, Vec<PathBuf>> = Default::default();
    for f in files {
        let name = super::registrations::file_name(&f);
        let valve = datasets::parse_registration_name(&name).valve;
        by_valve.entry(valve).or_default().push(f);
    }
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
    let explainer = FitEvidence {
        min_fit: args.min_fit,
    };
    let plan = Plan {
        stiction: &args.stiction,
        linear: &args.linear,
        search: &args.search,
        data: &args.data,
        integrating: args.integrating,
        explainer: &explainer,
    };
    let bar = crate::progress::Progress::new(s.progress, &format!("trend {valve}"));
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut regs: Vec<Registration> = files
        .par_iter()
        .map(|f| {
            let r = evaluate(f, &plan);
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            bar.update(k, files.len());
            r
        })
        .collect();
    bar.finish();
    // In time; unknown times last, by name.
    regs.sort_by(|a, b| match (a.start, b.start) {
        (Some(x), Some(y)) => x.total_cmp(&y).then_with(|| a.file.cmp(&b.file)),
        (Some(_), None) => std::cmp::Ordering::Less,
        (None, Some(_)) => std::cmp::Ordering::Greater,
        (None, None) => a.file.cmp(&b.file),
    });
    let mut trends = Vec::new();
    let mut c = 0;
    for st in &args.stiction {
        for li in &args.linear {
            trends.push(trend_of(&regs, c, args.min_fit, (st, li)));
            c += 1;
        }
    }
    // Say why a registration is doubtful: the diagnosis of each weak or outlying one, first
    // in its evidence (in parallel; skipped with --no-diagnose).
    if !args.no_diagnose {
        let jobs: Vec<(usize, usize)> = trends
            .iter()
            .enumerate()
            .flat_map(|(c, t)| {
                t.flags
                    .iter()
                    .enumerate()
                    .filter(|(_, f)| **f != Flag::Used)
                    .map(move |(k, _)| (k, c))
            })
            .filter(|&(k, c)| fit_at(&regs[k], c).is_some())
            .collect();
        let found: Vec<((usize, usize), String)> = jobs
            .par_iter()
            .map(|&(k, c)| {
                let (st, li) = combo_names(&args, c);
                let why = diagnose_registration(&regs[k], st, li, &plan)
                    .unwrap_or_else(|e| format!("diagnosis failed: {e}"));
                ((k, c), why)
            })
            .collect();
        for ((k, c), why) in found {
            if let Ok(combos) = &mut regs[k].outcome {
                if let Ok(f) = &mut combos[c].result {
                    f.evidence.insert(0, why);
                }
            }
        }
    }
    let mean_of = |f: &dyn Fn(&ComboTrend) -> Option<f64>| {
        let v: Vec<f64> = trends.iter().filter_map(f).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let level = mean_of(&|t| t.level);
    let latest = mean_of(&|t| t.latest);
    let slope = mean_of(&|t| t.slope_30d);
    let (verdict, reason) = maintenance(level, latest, slope, args.threshold, args.horizon);
    let verdict = verdict.label();
    let rule = format!(
        "schedule maintenance when the level (median S of the usable registrations, mean over \
         combinations) >= {t} %; watch when it is below but the latest usable S or the \
         {h}-day projection of the Theil-Sen trend reaches {t} %, or the level >= {half} %; \
         healthy otherwise",
        t = args.threshold,
        h = args.horizon,
        half = args.threshold / 2.0
    );

    if args.report.report.is_some() {
        trend_report(&args, &valve, &regs, &trends, (verdict, &reason, &rule), s)?;
    }
    if args.json {
        let combos: Vec<Value> = trends
            .iter()
            .enumerate()
            .map(|(c, t)| {
                let rows: Vec<Value> = regs
                    .iter()
                    .zip(&t.flags)
                    .map(|(r, flag)| {
                        let mut row = json!({
                            "file": r.file,
                            "time": r.start.map(format_epoch),
                            "time_source": r.time_source,
                            "flag": flag.label(),
                            "integrating": r.integrating,
                            "notes": r.notes,
                        });
                        match r.outcome.as_ref().map(|o| &o[c].result) {
                            Err(e) | Ok(Err(e)) => row["error"] = json!(e),
                            Ok(Ok(f)) => {
                                let g = |x: f64| crate::on_grid(x, f.step);
                                row["S"] = json!(g(f.s));
                                row["S_range"] = json!(f.s_range.map(g));
                                row["J"] = json!(g(f.j));
                                row["J_range"] = json!(f.j_range.map(g));
                                row["fit_pv_val"] = json!(f.fit_val);
                                row["why"] = json!(f.evidence);
                                row["quantify"] = f.json.clone();
                            }
                        }
                        row
                    })
                    .collect();
                json!({
                    "stiction_model": t.stiction, "linear_model": t.linear,
                    "level": t.level, "slope_per_30_days": t.slope_30d, "latest": t.latest,
                    "outlier_band": t.band, "registrations": rows,
                })
            })
            .collect();
        let doc = json!({
            "valve": valve, "registrations": regs.len(), "threshold": args.threshold,
            "min_fit": args.min_fit, "horizon_days": args.horizon,
            "level": level, "latest": latest, "slope_per_30_days": slope,
            "verdict": verdict, "reason": reason, "rule": rule, "combinations": combos,
        });
        serde_json::to_writer_pretty(&mut *s.stdout, &doc).map_err(data)?;
        writeln!(s.stdout).map_err(data)?;
        return Ok(());
    }

    let out = &mut *s.stdout;
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
    for (c, t) in trends.iter().enumerate() {
        writeln!(out, "\n{} + {}", t.stiction, t.linear).map_err(data)?;
        writeln!(
            out,
            "{:>3}  {:<16}  {:>6} {:>13}  {:>5} {:>11}  {:>8}  {:<7}  why",
            "#", "time", "S", "S range", "J", "J range", "F_PV val", "flag"
        )
        .map_err(data)?;
        for (k, (r, flag)) in regs.iter().zip(&t.flags).enumerate() {
            let time = r.start.map(format_epoch).unwrap_or_else(|| r.file.clone());
            match r.outcome.as_ref().map(|o| &o[c].result) {
                Err(e) | Ok(Err(e)) => {
                    writeln!(out, "{:>3}  {time:<16}  error: {}: {e}", k + 1, r.file)
                        .map_err(data)?;
                }
                Ok(Ok(f)) => {
                    let why = if *flag == Flag::Used {
                        String::new()
                    } else if f.evidence.is_empty() {
                        "no evidence of a disturbance in this registration: the valve itself \
                         may have changed (maintenance, operating range)"
                            .to_string()
                    } else {
                        f.evidence.join("; ")
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
            }
        }
        let used = t.flags.iter().filter(|f| **f == Flag::Used).count();
        let count = |x: Flag| t.flags.iter().filter(|f| **f == x).count();
        writeln!(
            out,
            "  usable {used}, weak {}, outliers {}, errors {}{}",
            count(Flag::Weak),
            count(Flag::Outlier),
            count(Flag::Error),
            t.band
                .map(|b| format!("; outlier band S in [{:.2}, {:.2}]", b[0], b[1]))
                .unwrap_or_default()
        )
        .map_err(data)?;
        writeln!(
            out,
            "  level (median S) {}; trend {}; latest usable S {}",
            t.level.map_or("-".into(), |v| format!("{v:.2} %")),
            t.slope_30d
                .map_or("-".into(), |v| format!("{v:+.3} % per 30 days (Theil-Sen)")),
            t.latest.map_or("-".into(), |v| format!("{v:.2} %")),
        )
        .map_err(data)?;
    }
    writeln!(out, "\nverdict: {verdict}: {reason}").map_err(data)?;
    writeln!(out, "rule: {rule}").map_err(data)?;
    Ok(())
}

/// The report of `trend`: the verdict, then per combination S over the registrations and
/// the table behind it.
fn trend_report(
    args: &Args,
    valve: &str,
    regs: &[Registration],
    trends: &[ComboTrend],
    (verdict, reason, rule): (&str, &str, &str),
    s: &mut Streams<'_>,
) -> Result<(), crate::Failure> {
    let started = std::time::Instant::now();
    let dated = regs.iter().all(|r| r.start.is_some());
    let day = |k: usize, r: &Registration| match (dated, r.start) {
        (true, Some(t)) => t / 86400.0,
        _ => (k + 1) as f64,
    };
    let mut sections = Vec::new();
    for (c, t) in trends.iter().enumerate() {
        let model = format!("{} × {}", t.stiction, t.linear);
        let mut sec = Section::new(model.clone());
        let mut points = Vec::new();
        let mut rows = Vec::new();
        for (k, (r, flag)) in regs.iter().zip(&t.flags).enumerate() {
            let time = r.start.map(format_epoch).unwrap_or_else(|| r.file.clone());
            match r.outcome.as_ref().map(|o| &o[c].result) {
                Err(e) | Ok(Err(e)) => rows.push(vec![
                    (k + 1).to_string(),
                    time,
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "error".into(),
                    format!("{}: {e}", r.file),
                ]),
                Ok(Ok(f)) => {
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
                            f.evidence.join("; ")
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
                &format!("{}-{}-s-trend", t.stiction, t.linear),
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
    let refused: Vec<(&Registration, &String)> = regs
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
    rules.push(Block::Paragraph(rule.to_string()));
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
