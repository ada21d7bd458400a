//! `stiction diagnose`: what the baseline model gets wrong, its cause, the extended model and
//! its gain (the `discrepancy` crate).

use std::path::PathBuf;

use anyhow::anyhow;
use discrepancy::{diagnose_with_progress, DiagnoseOptions};
use grid_search::Problem;
use serde_json::{json, Value};

use super::load::DataFlags;
use super::quantify::{loop_data, quantify_json, Example};
use super::search_flags::{DelayFlag, SearchFlags};
use crate::reporting::{self, ReportFlags};
use crate::{data, usage, CmdResult, Failure, Streams};
use datasets::LoopData;
use discrepancy::Diagnosis;
use report::{figures, Block, Report, Section};

pub(crate) const AFTER_HELP: &str = "\
Fits the baseline (default kano + arx with the paper's orders), characterises its residuals on
the validation data (whiteness, dependence on past MV, low-frequency content and trend,
direction of valve motion, stuck versus moving), then fits one extension per registered cause
and keeps a cause only when its validation gain passes a likelihood-ratio test that grows with
the extension's extra parameters (docs/DIAGNOSE.md):
  disturbance          external nonstationary disturbance -> EARX / EARMAX
  asymmetric-stiction  friction differs by direction      -> kano-asym
  time-delay           unmodelled dead time               -> the delay estimated
  no-stiction          the oscillation is not the valve's -> S <= 0.2 % (negligible)
Otherwise the cause is `none` and the baseline stands.

Examples:
  stiction diagnose loop.csv
  stiction diagnose --example paper --json
  stiction diagnose loop.csv --linear armax --orders 2,2,2";

/// Arguments of `stiction diagnose`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// CSV file with PV and OP columns (`-` for standard input).
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    file: Option<PathBuf>,
    /// Use an embedded example loop instead of a file.
    #[arg(long, value_enum)]
    example: Option<Example>,
    /// Stiction model of the baseline.
    #[arg(long, value_name = "NAME", default_value = "kano")]
    stiction: String,
    /// Linear identifier of the baseline.
    #[arg(long, value_name = "NAME", default_value = "arx")]
    linear: String,
    #[command(flatten)]
    search: SearchFlags,
    #[command(flatten)]
    data: DataFlags,
    /// Skip a cause (repeatable; for comparisons).
    #[arg(long, value_name = "CAUSE")]
    without: Vec<String>,
    #[command(flatten)]
    report: ReportFlags,
    /// Print one JSON document.
    #[arg(long)]
    json: bool,
}

fn num(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    let delay = match args.search.delay {
        DelayFlag::Fixed(d) => d,
        DelayFlag::Auto => {
            return Err(usage(anyhow!(
                "--delay auto: diagnose tests the dead time itself (cause time-delay); give the baseline's fixed dead time"
            )))
        }
    };
    let mut baseline = args.search.combination(&args.stiction, &args.linear)?;
    // The baseline's orders in full (defaults filled in), so that an extension with another
    // identifier inherits the orders they share.
    baseline.orders = baseline
        .identifier(delay)
        .map_err(usage)?
        .orders()
        .into_iter()
        .filter(|(k, _)| *k != "delay")
        .map(|(k, v)| (k.to_string(), v))
        .collect();
    let file = args.file.as_deref();
    let refused = |f, s: &mut Streams<'_>| reporting::refused(file, f, &args.report, "diagnose", s);
    let d = match loop_data(file, args.example, &args.data, s) {
        Ok(d) => d,
        Err(f) => return Err(refused(f, s)),
    };
    let pv = d.require_pv().map_err(data)?;
    let mut options = DiagnoseOptions::for_span(monitoring::span_of(&d.op));
    options.search = args.search.options(monitoring::span_of(&d.op))?;
    options.disabled = args.without.clone();
    let problem = Problem {
        op: &d.op,
        pv,
        mv: d.mv.as_deref(),
    };
    let bar = crate::progress::Progress::since(
        s.progress,
        "diagnose",
        "steps",
        std::time::Instant::now(),
    );
    let tick = |done: usize, total: usize, _what: &str| bar.update(done, total);
    let outcome = diagnose_with_progress(problem, &baseline, &options, Some(&tick));
    bar.finish();
    let mut dg = match outcome {
        Ok(dg) => dg,
        Err(e @ discrepancy::DiagnoseError::UnknownCause { .. }) => return Err(usage(e)),
        Err(discrepancy::DiagnoseError::Search(
            e @ (grid_search::SearchError::Budget { .. }
            | grid_search::SearchError::InvalidOption { .. }),
        )) => return Err(usage(anyhow::Error::new(e).context(d.source.clone()))),
        Err(other) => return Err(refused(data(anyhow!("{}: {other}", d.source)), s)),
    };
    if args.report.report.is_some() {
        diagnose_report(&d, &dg, &args.report, s)?;
    }
    let init = &args.search.init;
    let findings: Vec<Value> = dg
        .findings
        .iter_mut()
        .map(|f| {
            let ext = f.fitted.take().map(|x| quantify_json(&x, init));
            json!({
                "cause": f.cause,
                "evidence": f.evidence,
                "statistic": num(f.statistic),
                "extended": ext,
                "gain_fit_pv_val": num(f.gain_fit_pv_val),
                "delta_S": num(f.delta_s),
                "delta_J": num(f.delta_j),
                "lr": num(f.lr),
                "threshold": num(f.threshold),
                "reference": f.reference,
                "significant": f.significant,
                "error": f.error,
            })
        })
        .collect();
    let extended = dg
        .chosen
        .and_then(|i| findings.get(i))
        .map_or(Value::Null, |f| f["extended"].clone());
    if args.json {
        let baseline_json = quantify_json(&dg.baseline_fit, init);
        let v = json!({
            "source": d.source,
            "baseline": baseline_json,
            "cause": dg.cause,
            "findings": findings,
            "extended": extended,
            "gain_fit_pv_val": dg.gain_fit_pv_val,
            "summary": dg.summary,
            "residuals": serde_json::to_value(&dg.residuals).map_err(data)?,
            "elapsed_ms": dg.elapsed_ms,
        });
        serde_json::to_writer_pretty(&mut *s.stdout, &v).map_err(data)?;
        writeln!(s.stdout).map_err(data)?;
        return Ok(());
    }
    let out = &mut *s.stdout;
    writeln!(
        out,
        "{}: diagnosis of {} + {} ({} samples, {:.1} s)",
        d.source,
        dg.baseline.stiction_model,
        dg.baseline.linear_model,
        d.len(),
        dg.elapsed_ms / 1e3
    )
    .map_err(data)?;
    writeln!(out, "cause: {}", action_line(&dg)).map_err(data)?;
    writeln!(out).map_err(data)?;
    writeln!(out, "{}", dg.summary).map_err(data)?;
    writeln!(out).map_err(data)?;
    writeln!(
        out,
        "{:<20} {:>9} {:>11} {:>8} {:>8}  {:<22} {:>7} {:>7} {:>9} {:>8}",
        "cause",
        "statistic",
        "LR",
        "needed",
        "signif.",
        "model fitted",
        "S",
        "J",
        "F_PV val",
        "ΔF_PV"
    )
    .map_err(data)?;
    let b = &dg.baseline;
    writeln!(
        out,
        "{:<20} {:>9} {:>11} {:>8} {:>8}  {:<22} {:>7.2} {:>7.2} {:>9.2} {:>8}",
        "(baseline)",
        "-",
        "-",
        "-",
        "-",
        format!("{} + {} d={}", b.stiction_model, b.linear_model, b.delay),
        b.s,
        b.j,
        b.fit_pv_val,
        "-"
    )
    .map_err(data)?;
    for f in &dg.findings {
        let (ext, s_, j_, fv) = match &f.extended {
            Some(e) => (
                format!("{} + {} d={}", e.stiction_model, e.linear_model, e.delay),
                format!("{:.2}", e.s),
                format!("{:.2}", e.j),
                format!("{:.2}", e.fit_pv_val),
            ),
            None => (
                f.error.clone().unwrap_or_else(|| "-".into()),
                "-".into(),
                "-".into(),
                "-".into(),
            ),
        };
        writeln!(
            out,
            "{:<20} {:>9.2} {:>11.1} {:>8.1} {:>8}  {:<22} {:>7} {:>7} {:>9} {:>+8.2}",
            f.cause,
            f.statistic,
            f.lr,
            f.threshold.abs(),
            if f.significant { "yes" } else { "no" },
            ext,
            s_,
            j_,
            fv,
            f.gain_fit_pv_val
        )
        .map_err(data)?;
    }
    writeln!(
        out,
        "S, J: the fitted model's (no-stiction: the best valve with S at most {} %); F_PV val: its validation fit; ΔF_PV: against the baseline.",
        grid_search::NEGLIGIBLE_S
    )
    .map_err(data)?;
    Ok(())
}

/// The one line to act on: the cause and the model to use, with its S and J.
fn action_line(dg: &Diagnosis) -> String {
    let chosen = dg.chosen.and_then(|i| dg.findings.get(i));
    match chosen {
        Some(f) if f.cause == "no-stiction" => format!(
            "no-stiction: the oscillation is not the valve's (a valve with negligible stiction, fitted S = {:.2} %, explains PV as well); look elsewhere",
            f.extended.as_ref().map_or(f64::NAN, |e| e.s)
        ),
        Some(f) => match &f.extended {
            Some(e) => format!(
                "{}: use {} + {} (dead time {}): S = {:.2} %, J = {:.2} % (validation F_PV {:+.2} points over the baseline)",
                f.cause, e.stiction_model, e.linear_model, e.delay, e.s, e.j, f.gain_fit_pv_val
            ),
            None => f.cause.to_string(),
        },
        None => format!(
            "none: the baseline stands, S = {:.2} %, J = {:.2} %",
            dg.baseline.s, dg.baseline.j
        ),
    }
}

/// The report of `diagnose`: the verdict, the findings, the baseline's and the extended
/// model's figures, and what the residuals show.
fn diagnose_report(
    d: &LoopData,
    dg: &Diagnosis,
    flags: &ReportFlags,
    s: &mut Streams<'_>,
) -> Result<(), Failure> {
    let started = std::time::Instant::now();
    let name = reporting::loop_name(d);
    let rep_err = |e: report::ReportError| data(anyhow!("report: {e}"));
    let base = &dg.baseline_fit;
    let base_label = reporting::combo(base);
    let chosen = dg
        .chosen
        .and_then(|i| dg.findings.get(i))
        .and_then(|f| f.fitted.as_ref().map(|x| (f, x)));
    let mut findings = Section::new("Causes tested");
    findings.push(Block::Paragraph(format!(
        "Each cause is tested by fitting the model extended for it and comparing the \
         validation fit with the baseline {base_label} by a likelihood ratio (LR) that must \
         pass the threshold. Chosen cause: {}.",
        dg.cause
    )));
    let rows = dg
        .findings
        .iter()
        .map(|f| {
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
                format!("{:.2}", f.statistic),
                format!("{:.1}", f.lr),
                format!("{:.1}", f.threshold.abs()),
                if f.significant { "yes" } else { "no" }.into(),
                ext,
                s_,
                j_,
                format!("{:+.2}", f.gain_fit_pv_val),
                f.evidence.clone(),
            ]
        })
        .collect();
    findings.push(Block::Table {
        header: [
            "cause",
            "statistic",
            "LR",
            "needed",
            "significant",
            "extension",
            "S",
            "J",
            "ΔF_PV val",
            "evidence",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    });
    let mut verdict = Section::new("Verdict");
    verdict.push(Block::Verdict(format!("Cause: {}.", action_line(dg))));
    verdict.push(Block::Paragraph(dg.summary.clone()));
    let mut sections = vec![verdict];
    let mut later = vec![findings];
    let sig = reporting::signals(d, &name);
    let mut baseline = Section::new(format!("Baseline: {base_label}"));
    baseline.push(Block::Paragraph(reporting::verdict(
        &base.result,
        &format!("Before the diagnosis, the baseline {base_label}"),
    )));
    baseline.push(reporting::facts(base));
    if let Some(sig) = &sig {
        for f in reporting::run_figures(sig, base, "baseline-", "baseline")? {
            baseline.push(Block::Figure(f));
        }
    }
    later.push(baseline);
    if let Some(sig) = &sig {
        let mut res = Section::new("Residuals");
        let r = &dg.residuals;
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
        let ext = chosen.map(|(f, x)| (x, format!("{} ({})", reporting::combo(x), f.cause)));
        let ext_ref = ext.as_ref().map(|(v, l)| (&v.result, l.as_str()));
        res.push(Block::Figure(
            figures::residual_trends(sig, (&base.result, &base_label), ext_ref, "residuals")
                .map_err(rep_err)?,
        ));
        res.push(Block::Figure(
            figures::residual_spectrum(sig, (&base.result, &base_label), ext_ref, "spectrum")
                .map_err(rep_err)?,
        ));
        later.push(res);
        if let Some((f, x)) = chosen {
            let view = x;
            let label = reporting::combo(view);
            let mut sec = Section::new(format!("Extended model for {}: {label}", f.cause));
            sec.push(Block::Paragraph(format!(
                "{} The extension changes the validation F_PV by {:+.2} points, S by {:+.2} and \
                 J by {:+.2} % of valve span.",
                reporting::verdict(&view.result, &label),
                f.gain_fit_pv_val,
                f.delta_s,
                f.delta_j
            )));
            sec.push(reporting::facts(view));
            if let Some(fig) =
                figures::disturbance(sig, &view.result, &label, "disturbance").map_err(rep_err)?
            {
                sec.push(Block::Figure(fig));
            }
            for fig in reporting::run_figures(
                sig,
                view,
                "extended-",
                &format!("extended for {}", f.cause),
            )? {
                sec.push(Block::Figure(fig));
            }
            sections.push(sec);
        }
    }
    // The verdict and the model to use first; then how it was reached.
    sections.extend(later);
    let rep = Report {
        title: format!("diagnose: loop {name}, {base_label}"),
        subtitle: format!(
            "{} · {} samples · stiction diagnose · cause: {}",
            d.source,
            d.len(),
            dg.cause
        ),
        summary: Vec::new(),
        sections,
    };
    reporting::write(&rep, flags, started, s)
}
