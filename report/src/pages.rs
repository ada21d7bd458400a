//! The HTML page of each command, from the typed results: `quantify`, `compare`, `diagnose`,
//! `trend`, `detect`, and the page of a loop the reader refused. Also the numbers of one run
//! ([`facts`]) and the detection tests' section of `quantify`, `diagnose` and `detect`
//! ([`detection_section`]). The verdict sentences they share with the text output are
//! [`crate::verdict`]'s.

use std::path::Path;

use datasets::LoopData;
use detection::Detection;
use discrepancy::Diagnosis;
use grid_search::Criterion;
use monitoring::{Answer, Detected, DetectionFigures, DetectionView};
use run::Fitted;

use crate::figures::{self, Figure, LoopSignals};
use crate::verdict::{f2, opt2, own_params, verdict};
use crate::{Block, Report, ReportError, Section};

mod trend;
pub use trend::trend_page;

/// The loop's name for titles: the file stem, or the source as given.
pub fn loop_name(d: &LoopData) -> String {
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

/// The signals of `d` for the figures (`None` without PV), OP's valve span unknown or not
/// (`span_unknown`, the record's answer's).
pub fn signals<'a>(d: &'a LoopData, name: &'a str, span_unknown: bool) -> Option<LoopSignals<'a>> {
    Some(LoopSignals {
        name,
        t: d.t.as_deref(),
        sp: d.sp.as_deref(),
        pv: d.pv.as_deref()?,
        op: &d.op,
        mv: d.mv.as_deref(),
        span_unknown,
    })
}

/// `kano × arx`.
pub fn combo(r: &Fitted) -> String {
    format!("{} × {}", r.stiction.name, r.linear)
}

/// The numbers of one run as name/value pairs; S and J in % of valve span, or in % of the OP
/// range seen when OP's valve span is unknown (`span_unknown`).
pub fn facts(r: &Fitted, span_unknown: bool) -> Block {
    let unit = figures::op_unit(span_unknown);
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
            format!("S ({unit})"),
            format!(
                "{:.2}  (region {:.2}-{:.2})",
                q.s, q.interval.s[0], q.interval.s[1]
            ),
        ),
        (
            format!("J ({unit})"),
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
pub fn run_figures(
    sig: &LoopSignals<'_>,
    r: &Fitted,
    prefix: &str,
    role: &str,
) -> Result<Vec<Figure>, ReportError> {
    let model = if role.is_empty() {
        combo(r)
    } else {
        format!("{}, {role}", combo(r))
    };
    let q = &r.result;
    Ok(vec![
        figures::time_trends(sig, q, &model, &format!("{prefix}trends"))?,
        figures::phase_plots(sig, q, &model, &format!("{prefix}phase"))?,
        figures::fit_surface(
            q,
            (sig.name, sig.span_unknown),
            &model,
            &format!("{prefix}surface"),
        )?,
    ])
}

/// The record's one answer as the pages show it (`Verdict: ...`, as the text output's
/// `verdict:` line): the verdict, the S reported, its range and the evidence it rests on.
fn answer_block(answer: &Answer) -> Block {
    Block::Verdict(format!("Verdict: {}.", answer.line()))
}

/// The page of `quantify`: the record's one answer (`answer`, computed once by the command),
/// the numbers, the figures, then what the detection tests say on the same record (`det`,
/// [`monitoring::detect_file`]).
pub fn quantify_page(
    d: &LoopData,
    r: &Fitted,
    det: &DetectionView,
    repair: &Result<repair::Repair, repair::NoRepair>,
    answer: &Answer,
) -> Result<Report, ReportError> {
    let name = loop_name(d);
    let span_unknown = answer.span_unknown();
    let mut result = Section::new("Result");
    result.push(facts(r, span_unknown));
    // what this combination's fit says alone; the record's verdict is the answer's (summary)
    result.push(Block::Paragraph(verdict(
        &r.result,
        &combo(r),
        span_unknown,
    )));
    result.push(repair_paragraph(repair));
    for w in &r.result.warnings {
        result.push(Block::Note(w.clone()));
    }
    let mut figs = Section::new("Figures");
    if let Some(sig) = signals(d, &name, span_unknown) {
        for f in run_figures(&sig, r, "", "")? {
            figs.push(Block::Figure(f));
        }
    }
    Ok(Report {
        title: format!("quantify: loop {name}, {}", combo(r)),
        subtitle: format!("{} · {} samples · stiction quantify", d.source, d.len()),
        summary: vec![format!("Verdict: {}.", answer.line())],
        sections: vec![result, figs, detection_section(d, det, span_unknown)?],
    })
}

/// The report of `compare`: the table, then each combination's numbers and figures; S and J
/// without `%` and judged against no threshold when OP's valve span is unknown
/// (`span_unknown`).
pub fn compare_page(
    d: &LoopData,
    rows: &[(&str, &str, Result<&Fitted, String>)],
    criterion: Criterion,
    span_unknown: bool,
) -> Result<Report, ReportError> {
    let u = |x: f64| discrepancy::in_unit(x, span_unknown);
    let name = loop_name(d);
    let header = [
        "stiction", "linear", "S", "S range", "J", "J range", "F_PV id", "F_PV val", "F_MV",
        "time (s)",
    ]
    .map(String::from)
    .to_vec();
    let mut table = Vec::new();
    let mut ok: Vec<&Fitted> = Vec::new();
    for (st, li, r) in rows {
        match r {
            Ok(r) => {
                let q = &r.result;
                let (fid, fval) = q.fits.rank(q.criterion);
                table.push(vec![
                    st.to_string(),
                    li.to_string(),
                    format!("{:.2}", q.s),
                    format!("{:.2}-{:.2}", q.interval.s[0], q.interval.s[1]),
                    format!("{:.2}", q.j),
                    format!("{:.2}-{:.2}", q.interval.j[0], q.interval.j[1]),
                    format!("{fid:.2}"),
                    format!("{fval:.2}"),
                    opt2(q.fits.mv),
                    format!("{:.2}", r.elapsed_ms / 1e3),
                ]);
                ok.push(r);
            }
            Err(msg) => {
                let mut row = vec![st.to_string(), li.to_string(), format!("error: {msg}")];
                row.resize(header.len(), String::new());
                table.push(row);
            }
        }
    }
    let mut summary = Vec::new();
    let best = ok.iter().max_by(|a, b| {
        a.result
            .fits_score(a.result.criterion)
            .total_cmp(&b.result.fits_score(b.result.criterion))
    });
    if let Some(b) = best {
        summary.push(format!(
            "Best validation fit: {}",
            verdict(&b.result, &combo(b), span_unknown)
        ));
        let mut ss: Vec<f64> = ok.iter().map(|r| r.result.s).collect();
        ss.sort_by(f64::total_cmp);
        summary.push(format!(
            "Across the {} combinations that ran, S ranges {:.2} to {} (median {}) and \
             J {:.2} to {}; {} failed.",
            ok.len(),
            ss[0],
            u(ss[ss.len() - 1]),
            u(ss[ss.len() / 2]),
            ok.iter().map(|r| r.result.j).fold(f64::INFINITY, f64::min),
            u(ok.iter()
                .map(|r| r.result.j)
                .fold(f64::NEG_INFINITY, f64::max)),
            rows.len() - ok.len()
        ));
    } else {
        summary.push("No combination could be fitted; the table gives each one's reason.".into());
    }
    let mut overview = Section::new("All combinations");
    overview.push(Block::Paragraph(format!(
        "S and J in {} with their likelihood-ratio ranges; F_PV in % ({}), \
         identification and validation; F_MV when MV is logged.",
        if span_unknown {
            discrepancy::RANGE_SEEN_UNIT
        } else {
            "% of valve span"
        },
        criterion.describe()
    )));
    overview.push(Block::Table {
        header,
        rows: table,
    });
    let mut sections = vec![overview];
    let sig = signals(d, &name, span_unknown);
    for r in &ok {
        let view = r;
        let mut sec = Section::new(combo(view));
        sec.push(Block::Paragraph(verdict(
            &r.result,
            &combo(view),
            span_unknown,
        )));
        sec.push(facts(view, span_unknown));
        for w in &r.result.warnings {
            sec.push(Block::Note(w.clone()));
        }
        if let Some(sig) = &sig {
            let prefix = format!("{}-{}-", r.stiction.name, r.linear);
            for f in run_figures(sig, view, &prefix, "")? {
                sec.push(Block::Figure(f));
            }
        }
        sections.push(sec);
    }
    Ok(Report {
        title: format!("compare: loop {name}"),
        subtitle: format!(
            "{} · {} samples · stiction compare ({} combinations)",
            d.source,
            d.len(),
            rows.len()
        ),
        summary,
        sections,
    })
}

/// The head of a reason (the words before its first colon), for a table cell; the whole
/// reason when it has no colon or a long head.
pub(crate) fn short_reason(reason: &str) -> String {
    match reason.split_once(':') {
        Some((head, _)) if head.chars().count() <= 40 => head.trim().to_string(),
        _ => reason.to_string(),
    }
}

/// `s` with its first letter upper-case.
fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

/// What a repair would buy, as a paragraph of the `quantify` and `diagnose` pages.
fn repair_paragraph(repair: &Result<repair::Repair, repair::NoRepair>) -> Block {
    Block::Paragraph(match repair {
        Ok(r) => format!(
            "Repair: a free valve would remove {:.0} % of the control error's spread \
             (standard deviation {:.3} now, {:.3} repaired; the record's {:.3}) in the identified \
             loop, replayed with the same set point and disturbance; the valve would reverse \
             {:.0} times an hour instead of {:.0}.{}",
            100.0 * r.reduction,
            r.error_std_now,
            r.error_std_repaired,
            r.error_std_measured,
            r.reversals_per_hour_repaired,
            r.reversals_per_hour_now,
            r.note
                .as_ref()
                .map_or(String::new(), |n| format!(" Note: {n}."))
        ),
        Err(e) => format!("Repair: not estimated: {e}."),
    })
}

/// The report of `diagnose`: the action and the record's one answer (`answer`, computed once
/// by the command), the findings, the baseline's and the extended model's figures, what the
/// residuals show, and what the detection tests say on the same record (`det`,
/// [`monitoring::detect_file`]), with what a repair would buy in the final model.
pub fn diagnose_page(
    d: &LoopData,
    dg: &Diagnosis,
    det: &DetectionView,
    repair: &Result<repair::Repair, repair::NoRepair>,
    answer: &Answer,
) -> Result<Report, ReportError> {
    let name = loop_name(d);
    let span_unknown = answer.span_unknown();
    let base = &dg.baseline_fit;
    let base_label = combo(base);
    let head = dg.headline_in(span_unknown);
    let final_fit = dg.final_fit();
    let findings = causes_section(dg, &base_label);
    let mut first = Section::new("Verdict");
    first.push(Block::Verdict(format!(
        "{}.",
        capitalise(&head.action_line())
    )));
    first.push(answer_block(answer));
    first.push(Block::Paragraph(format!(
        "Causes held in the final model: {}.",
        head.causes_line()
    )));
    first.push(Block::Details {
        summary: "How the diagnosis reached this, step by step".into(),
        paragraphs: vec![dg.summary.clone()],
    });
    let mut sections = vec![first];
    let mut later = vec![findings];
    let sig = signals(d, &name, span_unknown);
    // The model to use, figures first: the final model (or the baseline when no cause holds).
    let use_fit = final_fit.unwrap_or(base);
    let use_label = combo(use_fit);
    let mut model = Section::new(format!(
        "The model to use: {use_label}, dead time {}",
        use_fit.delay
    ));
    if let Some(sig) = &sig {
        if final_fit.is_some() {
            if let Some(fig) =
                figures::disturbance(sig, &use_fit.result, &use_label, "disturbance")?
            {
                model.push(Block::Figure(fig));
            }
        }
        let (prefix, role) = if final_fit.is_some() {
            ("final-", "final model")
        } else {
            ("baseline-", "baseline")
        };
        for fig in run_figures(sig, use_fit, prefix, role)? {
            model.push(Block::Figure(fig));
        }
    }
    model.push(Block::Paragraph(match final_fit {
        Some(_) => format!(
            "{} Against the baseline {base_label} (S = {}, J = {}), the final model \
             changes the validation F_PV by {:+.2} points.",
            verdict(&use_fit.result, &use_label, span_unknown),
            discrepancy::in_unit(dg.baseline.s, span_unknown),
            discrepancy::in_unit(dg.baseline.j, span_unknown),
            dg.gain_fit_pv_val
        ),
        None => verdict(&use_fit.result, &use_label, span_unknown),
    }));
    model.push(facts(use_fit, span_unknown));
    model.push(repair_paragraph(repair));
    sections.push(model);
    if final_fit.is_some() {
        let mut baseline = Section::new(format!("Baseline: {base_label}"));
        baseline.push(Block::Paragraph(verdict(
            &base.result,
            &format!("Before the diagnosis, the baseline {base_label}"),
            span_unknown,
        )));
        baseline.push(facts(base, span_unknown));
        if let Some(sig) = &sig {
            for f in run_figures(sig, base, "baseline-", "baseline")? {
                baseline.push(Block::Figure(f));
            }
        }
        later.push(baseline);
    }
    if let Some(sig) = &sig {
        later.push(residuals_section(sig, dg, &base_label)?);
    }
    later.push(detection_section(d, det, span_unknown)?);
    // The verdict and the model to use first; then how it was reached.
    sections.extend(later);
    Ok(Report {
        title: format!("diagnose: loop {name}, {base_label}"),
        subtitle: format!(
            "{} · {} samples · stiction diagnose · {}",
            d.source,
            d.len(),
            head.action
        ),
        summary: Vec::new(),
        sections,
    })
}

/// The causes section of the `diagnose` page: each cause's test against the model before it
/// (the table) and its evidence.
fn causes_section(dg: &Diagnosis, base_label: &str) -> Section {
    let mut findings = Section::new("Causes tested");
    findings.push(Block::Paragraph(format!(
        "Each cause is tested by fitting the model extended for it and comparing its \
         validation fit by a likelihood ratio (LR) that must pass the threshold: in step 1 \
         against the baseline {base_label}, in step k on top of the causes added before it. A \
         cause is held when a step added it to the final model; its row shows that step's test."
    )));
    let cause_rows = crate::text::cause_rows(dg);
    let rows = cause_rows
        .iter()
        .map(|row| {
            let f = row.finding;
            let (ext, s_, j_) = match &f.extended {
                Some(e) => (
                    format!("{} × {} d={}", e.stiction_model, e.linear_model, e.delay),
                    format!("{:.2}", e.s),
                    format!("{:.2}", e.j),
                ),
                None => (
                    f.error.clone().unwrap_or_else(|| "-".into()),
                    "-".into(),
                    "-".into(),
                ),
            };
            vec![
                f.cause.to_string(),
                crate::text::held_cell(row),
                crate::text::finite_or_dash(f.statistic, 2, false),
                crate::text::finite_or_dash(f.lr, 1, false),
                crate::text::finite_or_dash(f.threshold.abs(), 1, false),
                ext,
                s_,
                j_,
                crate::text::finite_or_dash(f.gain_fit_pv_val, 2, true),
            ]
        })
        .collect();
    findings.push(Block::Table {
        header: [
            "cause",
            "held",
            "statistic",
            "LR",
            "needed",
            "extension",
            "S",
            "J",
            "ΔF_PV val",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    });
    findings.push(Block::Details {
        summary: "The evidence for each cause".into(),
        paragraphs: cause_rows
            .iter()
            .map(|r| format!("{}: {}", r.finding.cause, r.finding.evidence))
            .collect(),
    });
    findings
}

/// The residuals section of the `diagnose` page: the baseline's (and the final model's)
/// residuals over time and their spectrum, with the residual statistics.
fn residuals_section(
    sig: &LoopSignals<'_>,
    dg: &Diagnosis,
    base_label: &str,
) -> Result<Section, ReportError> {
    let base = &dg.baseline_fit;
    let final_fit = dg.final_fit();
    let mut res = Section::new("Residuals");
    let r = &dg.residuals;
    let ext = final_fit.map(|x| (x, format!("{} (final model)", combo(x))));
    let ext_ref = ext.as_ref().map(|(v, l)| (&v.result, l.as_str()));
    res.push(Block::Figure(figures::residual_trends(
        sig,
        (&base.result, base_label),
        ext_ref,
        "residuals",
    )?));
    res.push(Block::Figure(figures::residual_spectrum(
        sig,
        (&base.result, base_label),
        ext_ref,
        "spectrum",
    )?));
    res.push(Block::Facts(vec![
        (
            "Ljung-Box Q (limit)".into(),
            format!("{:.1} ({:.1})", r.ljung_box_q, r.ljung_box_limit),
        ),
        (
            "cross-correlation with past MV".into(),
            format!("z = {:.2} at lag {}", r.cross_mv_z, r.cross_mv_lag),
        ),
        (
            "low-frequency share of the simulation residual".into(),
            format!("{:.2}", r.low_frequency_ratio),
        ),
        (
            "mean residual moving up / down".into(),
            format!(
                "{:.3} / {:.3} (t = {:.2})",
                r.mean_up, r.mean_down, r.direction_t
            ),
        ),
    ]));
    Ok(res)
}

/// The detection tests' section of the `quantify` and `diagnose` pages: the detector's line
/// (verdict, score, reason, as the text output ends), then what [`detection_blocks`] shows, or
/// why the detector could not run; OP in % of the range seen when its valve span is unknown
/// (`span_unknown`).
pub fn detection_section(
    d: &LoopData,
    view: &DetectionView,
    span_unknown: bool,
) -> Result<Section, ReportError> {
    let mut sec = Section::new("Detection: is it the valve?");
    let line = crate::text::detection_line(&view.detected);
    let mut chars = line.chars();
    let line: String = chars
        .next()
        .map(|c| c.to_uppercase().chain(chars).collect())
        .unwrap_or_default();
    sec.push(Block::Paragraph(format!(
        "{line}. The detection tests judge the time series alone, independently of the model \
         fitted above."
    )));
    match &view.detected {
        Detected::Ran(x) => sec
            .blocks
            .extend(detection_blocks(d, x, &view.figures, span_unknown)?),
        Detected::Failed(_) => {
            sec.push(Block::Note(
                "No test ran, so there is nothing to draw.".into(),
            ));
        }
    }
    Ok(sec)
}

/// What the detection tests saw and said on `d`: the loop in one sentence, the table of the
/// tests (name, statistic, verdict, evidence), the PV-OP plot with the fitted ellipse and the
/// OP-PV cross-correlation (figures `detection-pv-op` and `detection-xcorr`), drawn from what
/// the detector computed on the registration the tests judged (`figures`,
/// [`monitoring::detect_view`]); OP in % of the range seen when its valve span is unknown
/// (`span_unknown`).
pub fn detection_blocks(
    d: &LoopData,
    det: &Detection,
    figures: &Result<DetectionFigures, String>,
    span_unknown: bool,
) -> Result<Vec<Block>, ReportError> {
    let mut blocks = Vec::new();
    let ts = run::sample_time(d);
    blocks.push(Block::Paragraph(format!(
        "The loop: {}; {} loop; {} samples every {ts} s.",
        match det.period_s {
            Some(p) => format!("a regular oscillation of the control error, period {p:.0} s"),
            None => "no regular oscillation of the control error".to_string(),
        },
        if det.integrating {
            "integrating (a level)"
        } else {
            "self-regulating"
        },
        d.op.len()
    )));
    blocks.push(Block::Table {
        header: ["test", "statistic", "verdict", "evidence"]
            .map(String::from)
            .to_vec(),
        rows: det
            .tests
            .iter()
            .map(|t| {
                vec![
                    t.name.to_string(),
                    t.statistic
                        .filter(|v| v.is_finite())
                        .map_or("-".to_string(), |v| format!("{v:.3}")),
                    t.verdict.to_string(),
                    t.evidence.clone(),
                ]
            })
            .collect(),
    });
    let name = loop_name(d);
    let Some(sig) = signals(d, &name, span_unknown) else {
        return Ok(blocks);
    };
    let drawn = match figures {
        Ok(drawn) => drawn,
        Err(e) => {
            blocks.push(Block::Note(format!("No detection figures: {e}.")));
            return Ok(blocks);
        }
    };
    blocks.push(Block::Figure(figures::pv_op_plot(
        &sig,
        drawn.ellipse.as_ref(),
        "detection-pv-op",
    )?));
    match &drawn.cross_correlation {
        Ok(cc) => blocks.push(Block::Figure(figures::cross_correlation(
            &sig,
            cc,
            "detection-xcorr",
        )?)),
        Err(why) => blocks.push(Block::Note(format!("No cross-correlation: {why}."))),
    }
    Ok(blocks)
}

/// The report of `detect`: the verdict with its score and reason, the record's one answer
/// (`answer`, computed once by the command: the S that explains the verdict), then the tests'
/// table and figures ([`detection_blocks`]) drawn from `figures`.
pub fn detect_page(
    d: &LoopData,
    det: &Detection,
    figures: &Result<DetectionFigures, String>,
    answer: &Answer,
) -> Result<Report, ReportError> {
    let name = loop_name(d);
    let mut first = Section::new("Verdict");
    first.push(Block::Verdict(format!(
        "Detection: {} ({}).",
        det.verdict,
        crate::text::score_and_tests(det)
    )));
    first.push(Block::Paragraph(format!(
        "Why: {}. The score, in [0, 1], is what a logistic model fitted on simulated loops \
         makes of the tests' statistics: a ranking of the evidence, not a probability for \
         this valve, and the verdict needs more than a high score (a loop that neither \
         oscillates regularly, nor shows stick-slip, nor is explained by a sticky valve is \
         never called sticky, and a record that cannot show stiction is inconclusive).",
        det.reason
    )));
    first.push(Block::Paragraph(format!("Answer: {}.", answer.line())));
    let mut tests = Section::new("The tests");
    tests.blocks = detection_blocks(d, det, figures, answer.span_unknown())?;
    Ok(Report {
        title: format!("detect: loop {name}"),
        subtitle: format!("{} · {} samples · stiction detect", d.source, d.len()),
        summary: Vec::new(),
        sections: vec![first, tests],
    })
}

/// The page of a loop that could not be read: the reason and, when the file is delimited text
/// (not `-`), its columns as logged.
pub fn refused_page(path: &Path, message: &str, command: &str) -> Report {
    let stem = path.file_stem().map_or_else(
        || path.display().to_string(),
        |s| s.to_string_lossy().into(),
    );
    let mut sec = Section::new("Why the data were refused");
    sec.push(Block::Note(message.to_string()));
    let mut figure = None;
    if path.as_os_str() != "-" {
        if let Some(cols) = datasets::raw_columns(path) {
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
    Report {
        title: format!("{command}: loop {stem} refused"),
        subtitle: format!("{} · stiction {command}", path.display()),
        summary: vec![format!("No estimate: {message}")],
        sections: vec![sec],
    }
}
