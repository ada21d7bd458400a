//! `stiction diagnose`: what the baseline model gets wrong, its cause, the extended model and
//! its gain (the `discrepancy` crate).

use anyhow::anyhow;
use discrepancy::{diagnose_with_progress, DiagnoseError};

use super::quantify::{LoopFlags, ModelFlags};
use crate::reporting::{self, Output};
use crate::{usage, CmdResult, Streams};

/// Arguments of `stiction diagnose`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    source: LoopFlags,
    /// The baseline.
    #[command(flatten)]
    model: ModelFlags,
    /// Skip a cause (repeatable; for comparisons).
    #[arg(long, value_name = "CAUSE")]
    without: Vec<String>,
    #[command(flatten)]
    out: Output,
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    let m = &args.model;
    let search = m.search.args();
    let baseline = discrepancy::baseline(&search, &m.stiction, &m.linear).map_err(usage)?;
    let file = args.source.file.as_deref();
    let refused =
        |f, s: &mut Streams<'_>| reporting::refused(file, f, &args.out.report, "diagnose", s);
    // an integrating loop is diagnosed on MV → ΔPV, as quantify, batch and trend fit it
    let (d, a) = args.source.analysed(&args.out, "diagnose", s)?;
    let problem = run::problem(&a.searched)?;
    let options = discrepancy::options_for(&search, run::span_of(&a.searched.op), &args.without)
        .map_err(usage)?;
    let started = std::time::Instant::now();
    let bar = crate::progress::Progress::since(s.progress, "diagnose", "steps", started);
    let tick = |done: usize, total: usize, _what: &str| bar.update(done, total);
    let outcome = diagnose_with_progress(problem, &baseline, &options, Some(&tick));
    bar.finish();
    let dg = match outcome {
        Ok(dg) => dg,
        Err(e @ DiagnoseError::UnknownCause { .. }) => return Err(usage(e)),
        Err(DiagnoseError::Search(e)) if e.is_usage() => {
            return Err(usage(anyhow::Error::new(e).context(d.source.clone())))
        }
        Err(other) => return Err(refused(anyhow!("{}: {other}", d.source).into(), s)),
    };
    let det = a.detect(&d);
    // the final model (the baseline when no cause was found): what a repair would buy, and
    // the one-step fit of the answer
    let fit = dg.final_fit().unwrap_or(&dg.baseline_fit);
    let answer = monitoring::Answer::new(&a, &det.detected, Some(&fit.result));
    let repair = answer.repair(fit.repair(&d, a.kind.integrating));
    reporting::write(&args.out.report, s, || {
        report::pages::diagnose_page(&d, &dg, &det, &repair, &answer)
    })?;
    if args.out.json {
        return s.json(&monitoring::document::diagnose(
            &d.source,
            &dg,
            &m.search.init,
            &det.detected,
            &repair,
            &answer,
        ));
    }
    let text = report::text::diagnose(&d, &dg, &answer)?;
    s.text(format!(
        "{text}{}\n{}\n{}\n",
        report::text::repair_line(&repair),
        report::text::answer_line(&answer),
        report::text::detection_line(&det.detected)
    ))
}

/// The long help of `diagnose`: `help/diagnose.txt` with its `{causes}` line replaced by the
/// table of the causes a diagnosis can name (`discrepancy::cause_table`: name, role, meaning),
/// so that a registered cause is listed without editing the help.
pub(crate) fn help() -> String {
    const WIDTH: usize = 100;
    let mut table = String::new();
    for row in discrepancy::cause_table() {
        let head = format!(
            "  {:<21}{:<19}",
            row.name,
            format!("[{}]", row.role.label())
        );
        let indent = " ".repeat(head.len());
        let mut line = head;
        for word in row.description.split_whitespace() {
            if line.len() + 1 + word.len() > WIDTH && line.trim_end().len() > indent.len() {
                table.push_str(line.trim_end());
                table.push('\n');
                line = indent.clone();
            }
            if !line.ends_with(' ') {
                line.push(' ');
            }
            line.push_str(word);
        }
        table.push_str(line.trim_end());
        table.push('\n');
    }
    include_str!("../../help/diagnose.txt").replace("{causes}\n", &table)
}
