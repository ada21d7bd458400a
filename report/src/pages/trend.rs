//! The page of `stiction trend`: the verdict, each combination's S over the registrations,
//! the causes the registrations agree on, the registrations refused.

use datasets::format_epoch;
use monitoring::registration::{Registration, RegistrationError};
use monitoring::trend::{span_unknown, CombinationTrend, ValveTrend};
use monitoring::{median, Flag};

use super::short_reason;
use crate::figures::{self, TrendLine, TrendPoint, TrendStatus};
use crate::{Block, Report, ReportError, Section};

/// The report of `trend`: the verdict, then per combination S over the registrations and
/// the table behind it.
pub fn trend_page(vt: &ValveTrend) -> Result<Report, ReportError> {
    let threshold = vt.options.threshold;
    let (valve, regs) = (vt.valve.as_str(), vt.registrations.as_slice());
    let (verdict, reason, rule) = (vt.verdict.label(), vt.reason.as_str(), vt.rule());
    let dated = regs.iter().all(|r| r.start.is_some());
    let day = |k: usize, r: &Registration| match (dated, r.start) {
        (true, Some(t)) => t / 86400.0,
        _ => (k + 1) as f64,
    };
    let mut sections = Vec::new();
    for (c, ct) in vt.combinations.iter().enumerate() {
        sections.push(combination_section(vt, c, ct, dated, &day)?);
    }
    if let Some(c) = &vt.causes {
        sections.push(causes_section(vt, c));
    }
    if let Some(sec) = refused_section(regs)? {
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
    Ok(Report {
        title: format!("trend: valve {valve}"),
        subtitle: if regs.iter().any(span_unknown) {
            format!(
                "{} registration(s) · stiction trend · S in % of the OP range seen where OP's valve span is unknown",
                regs.len()
            )
        } else {
            format!(
                "{} registration(s) · stiction trend · threshold {} % of valve span",
                regs.len(),
                threshold
            )
        },
        summary: Vec::new(),
        sections,
    })
}

/// One combination's section: S over the registrations (figure), the table behind it and, in
/// full, why registrations were left out.
fn combination_section(
    vt: &ValveTrend,
    c: usize,
    ct: &CombinationTrend,
    dated: bool,
    day: &dyn Fn(usize, &Registration) -> f64,
) -> Result<Section, ReportError> {
    let (valve, regs, threshold) = (
        vt.valve.as_str(),
        vt.registrations.as_slice(),
        vt.options.threshold,
    );
    {
        let t = &ct.trend;
        let model = format!("{} × {}", ct.stiction, ct.linear);
        let mut sec = Section::new(model.clone());
        let mut points = Vec::new();
        let mut rows: Vec<Vec<String>> = Vec::new();
        let mut whys: Vec<String> = Vec::new();
        for (k, (r, flag)) in regs.iter().zip(&t.flags).enumerate() {
            let time = r.start.map(format_epoch).unwrap_or_else(|| r.file.clone());
            match (r.fit(c), r.error(c)) {
                (None, e) => rows.push(no_fit_row(k, time, *flag, r, e)),
                (Some(f), _) => {
                    // the S the registration reports: the one that explains the detector's
                    // verdict (the combination's one-step S, or the detector's)
                    let rep = r.reported(c).unwrap_or(monitoring::answer::Reported {
                        s: f.s,
                        range: f.s_range,
                        from: monitoring::SFrom::OneStep,
                    });
                    let status = match flag {
                        Flag::Used => TrendStatus::Used,
                        Flag::Weak | Flag::Error | Flag::Inconclusive => TrendStatus::Weak,
                        Flag::Outlier => TrendStatus::Outlier,
                    };
                    points.push(TrendPoint {
                        day: day(k, r),
                        s: rep.s,
                        interval: Some(rep.range),
                        status,
                    });
                    rows.push(vec![
                        (k + 1).to_string(),
                        time,
                        match rep.from {
                            monitoring::SFrom::OneStep => format!("{:.2}", rep.s),
                            monitoring::SFrom::OutputError => format!("{:.2} (detector)", rep.s),
                        },
                        format!("{:.2}-{:.2}", rep.range[0], rep.range[1]),
                        format!("{:.2}", f.j),
                        format!("{:.1}", f.fit_val),
                        flag.label().into(),
                        if *flag == Flag::Used {
                            String::new()
                        } else {
                            f.evidence
                                .iter()
                                .map(|e| short_reason(&e.to_string()))
                                .collect::<Vec<_>>()
                                .join("; ")
                        },
                    ]);
                    if *flag != Flag::Used && !f.evidence.is_empty() {
                        whys.push(format!(
                            "#{} ({}): {}",
                            k + 1,
                            rows.last().map_or("", |r| r[1].as_str()),
                            f.evidence
                                .iter()
                                .map(ToString::to_string)
                                .collect::<Vec<_>>()
                                .join("; ")
                        ));
                    }
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
        let unknown = regs.iter().any(span_unknown);
        let unit = if unknown { "" } else { " %" };
        sec.push(Block::Paragraph(format!(
            "Level (median S of the usable registrations) {}; trend {}; latest usable S {}.{}",
            t.level.map_or("-".into(), |v| format!("{v:.2}{unit}")),
            t.slope_30d.map_or("-".into(), |v| format!(
                "{v:+.3}{unit} per 30 days (Theil-Sen)"
            )),
            t.latest.map_or("-".into(), |v| format!("{v:.2}{unit}")),
            if unknown {
                format!(" {}", crate::text::RANGE_SEEN_NOTE)
            } else {
                String::new()
            }
        )));
        if !points.is_empty() {
            let fig = figures::s_trend(
                valve,
                &model,
                &points,
                threshold,
                line,
                dated,
                unknown,
                &format!("{}-{}-s-trend", ct.stiction, ct.linear),
            )?;
            sec.push(Block::Figure(fig));
        }
        sec.push(Block::Table {
            header: ["#", "time", "S", "S range", "J", "F_PV val", "flag", "why"]
                .map(String::from)
                .to_vec(),
            rows,
        });
        if !whys.is_empty() {
            sec.push(Block::Details {
                summary: format!(
                    "Why {} registration(s) were left out of the trend, in full",
                    whys.len()
                ),
                paragraphs: whys,
            });
        }
        Ok(sec)
    }
}

/// The table row of registration `k` without a fit: the detector's answer and why nothing
/// could be fitted (flag `inconclusive`), or the error.
fn no_fit_row(
    k: usize,
    time: String,
    flag: Flag,
    r: &Registration,
    e: Option<&RegistrationError>,
) -> Vec<String> {
    let e = e.map(ToString::to_string).unwrap_or_default();
    let why = if flag == Flag::Inconclusive {
        let reason = r
            .detection
            .as_ref()
            .map_or_else(String::new, |d| d.reason());
        format!("detector: {reason}; no fit: {e}")
    } else {
        format!("{}: {e}", r.file)
    };
    let mut row = vec![(k + 1).to_string(), time];
    row.extend(["-"; 4].map(String::from));
    row.extend([flag.label().to_string(), why]);
    row
}

/// What the registrations' diagnoses agree on, and the registrations that differ.
fn causes_section(vt: &ValveTrend, c: &run::Consensus) -> Section {
    {
        let lines = crate::text::causes_lines(c, &crate::text::baseline_of(vt));
        let mut sec = Section::new("Causes the registrations agree on".to_string());
        sec.push(Block::Paragraph(
            lines[0]
                .strip_prefix("causes: ")
                .unwrap_or(&lines[0])
                .to_string(),
        ));
        if !c.disagreeing.is_empty() {
            sec.push(Block::Table {
                header: ["registration", "causes", "why it differs"]
                    .map(String::from)
                    .to_vec(),
                rows: c
                    .disagreeing
                    .iter()
                    .map(|d| {
                        vec![
                            d.label.clone(),
                            if d.causes.is_empty() {
                                "none".to_string()
                            } else {
                                d.causes.join(", ")
                            },
                            d.why.join("; "),
                        ]
                    })
                    .collect(),
            });
        }
        sec
    }
}

/// Registrations the reader refused, and those read but with nothing to fit (a PV or OP
/// constant or flat over most of the record: the detector's answer only): the reason and the
/// raw columns (the first few).
fn refused_section(regs: &[Registration]) -> Result<Option<Section>, ReportError> {
    let refused: Vec<(&Registration, &RegistrationError)> = regs
        .iter()
        .filter_map(|r| match &r.outcome {
            Err(e) => Some((r, e)),
            Ok(_) if r.unfit() => r.error(0).map(|e| (r, e)),
            Ok(_) => None,
        })
        .collect();
    if !refused.is_empty() {
        let mut sec = Section::new(format!(
            "Registrations refused or without a fit ({})",
            refused.len()
        ));
        for (k, (r, e)) in refused.iter().enumerate() {
            let verdict = r
                .detect_verdict()
                .map_or(String::new(), |v| format!(" (detector: {v})"));
            sec.push(Block::Note(format!("{}: {e}{verdict}", r.file)));
            if k >= 4 {
                continue;
            }
            let stem = r
                .path
                .file_stem()
                .map_or_else(|| r.file.clone(), |s| s.to_string_lossy().into_owned());
            if let Some(cols) = datasets::raw_columns(&r.path) {
                let fig = figures::raw_signals(&stem, &cols, &format!("raw-{}", k + 1))?;
                sec.push(Block::Figure(fig));
            }
        }
        return Ok(Some(sec));
    }
    Ok(None)
}
