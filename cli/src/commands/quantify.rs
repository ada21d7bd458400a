//! `stiction quantify` and `stiction compare`: the grid search on one loop.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::anyhow;
use datasets::LoopData;
use run::Fitted;
use stiction_models::find_model;

use super::batch::Combos;
use super::load::{load, DataFlags};
use super::search_flags::{KindFlags, SearchFlags};
use crate::progress::Progress;
use crate::reporting::{self, Output};
use crate::{usage, CmdResult, Failure, Streams};

/// Which embedded example to use instead of a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Example {
    /// The paper's benchmark loop (eq. 10, PI 0.5/0.5, σ = 0.1) with a Kano valve S = 9, J = 3,
    /// 3000 samples, seed 1 (paper §3.2, Tables 1-2).
    Paper,
}

/// The loop to analyse: a file or an embedded example, how it is read and what kind of loop it
/// is (`quantify`, `compare`, `diagnose`).
#[derive(Debug, clap::Args)]
pub(crate) struct LoopFlags {
    /// CSV or MAT file with PV and OP columns (`-` for standard input, CSV).
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    pub file: Option<PathBuf>,
    /// Use an embedded example loop instead of a file.
    #[arg(long, value_enum)]
    example: Option<Example>,
    #[command(flatten)]
    kind: KindFlags,
    #[command(flatten)]
    data: DataFlags,
}

impl LoopFlags {
    /// Read the file (notes on stderr), or simulate the example.
    fn load(&self, s: &mut Streams<'_>) -> Result<LoopData, Failure> {
        match (&self.file, self.example) {
            (_, Some(Example::Paper)) => Ok(run::paper_example()?),
            (Some(f), None) => load(f, &self.data, true, 30, s),
            (None, None) => Err(usage(anyhow!("give a FILE or --example"))),
        }
    }

    /// The loop read and analysed once ([`monitoring::analyse`]): the loop kind decided and the
    /// record as searched. A record that cannot be read gets the refused page of `command`
    /// with `--report`.
    pub(crate) fn analysed(
        &self,
        out: &Output,
        command: &str,
        s: &mut Streams<'_>,
    ) -> Result<(LoopData, monitoring::Analysis), Failure> {
        let file = self.file.as_deref();
        let d = (self.load(s)).map_err(|f| reporting::refused(file, f, &out.report, command, s))?;
        let a = monitoring::analyse(&d, file, self.kind.integrating());
        Ok((d, a))
    }
}

/// One stiction × linear combination and its search (`quantify`; the baseline of
/// `diagnose`).
#[derive(Debug, clap::Args)]
pub(crate) struct ModelFlags {
    /// Registered stiction model searched over (see `stiction models`).
    #[arg(long, value_name = "NAME", default_value = "kano")]
    pub stiction: String,
    /// Registered linear identifier.
    #[arg(long, value_name = "NAME", default_value = "arx")]
    pub linear: String,
    #[command(flatten)]
    pub search: SearchFlags,
}

/// Arguments of `stiction quantify`.
#[derive(Debug, clap::Args)]
pub struct QuantifyArgs {
    #[command(flatten)]
    source: LoopFlags,
    #[command(flatten)]
    model: ModelFlags,
    /// Write the fit over the whole grid as CSV (for plotting).
    #[arg(long, value_name = "FILE")]
    surface: Option<PathBuf>,
    #[command(flatten)]
    out: Output,
}

/// Arguments of `stiction compare`.
#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    #[command(flatten)]
    source: LoopFlags,
    #[command(flatten)]
    combos: Combos,
    #[command(flatten)]
    search: SearchFlags,
    #[command(flatten)]
    out: Output,
}

/// The combinations of `compare` when none are named.
const COMPARE_COMBOS: (&[&str], &[&str]) =
    (&["kano", "he"], &["arx", "armax", "ss", "earx", "earmax"]);

/// Run one stiction × linear combination on `d`. The progress bar (on a terminal) appears once
/// `since` is a second old and its label starts with `step` (e.g. `compare 3/10: `).
pub(crate) fn run_one(
    (stiction, linear): (&str, &str),
    flags: &SearchFlags,
    d: &LoopData,
    s: &mut Streams<'_>,
    (since, step): (Instant, &str),
    node_fits: grid_search::NodeFits,
) -> Result<Fitted, Failure> {
    let mut combination = flags.combination(stiction, linear)?;
    combination.search.node_fits = node_fits;
    let problem = run::problem(d)?;
    let label = format!(
        "{step}{} + {}",
        combination.stiction.name, combination.linear.name
    );
    let bar = Progress::since(s.progress, &label, "nodes", since);
    let run = combination.run(problem, Some(&bar.tick()));
    bar.finish();
    // Keep the error's type (a node budget breach is bad usage, see `crate::run_from`).
    let fitted = run.map_err(|e| anyhow::Error::new(e).context(d.source.clone()))?;
    // A given step so coarse that the region is one node returns the grid as the estimate,
    // with a "95 % region" that may exclude the truth (`--step 2.3` against S = 2.35).
    if let Some(step) = flags.step {
        if fitted.result.interval.nodes <= 1 {
            let _ = writeln!(
                s.stderr,
                "warning: --step {step}: the {:.0} % region is a single grid node, so S and J are known only to the step and the region says nothing: give a finer --step, or none for the default plan",
                100.0 * fitted.result.interval.confidence
            );
        }
    }
    Ok(fitted)
}

pub(crate) fn run_quantify(args: QuantifyArgs, s: &mut Streams<'_>) -> CmdResult {
    let file = args.source.file.as_deref();
    let refused =
        |f, s: &mut Streams<'_>| reporting::refused(file, f, &args.out.report, "quantify", s);
    let (d, a) = args.source.analysed(&args.out, "quantify", s)?;
    let m = &args.model;
    let combination = (m.stiction.as_str(), m.linear.as_str());
    // a surface written out carries both criteria's fits at every node
    let node_fits = if args.surface.is_some() {
        grid_search::NodeFits::Both
    } else {
        grid_search::NodeFits::Criterion
    };
    let r = run_one(
        combination,
        &m.search,
        &a.searched,
        s,
        (Instant::now(), ""),
        node_fits,
    )
    .map_err(|f| refused(f, s))?;
    if let Some(path) = &args.surface {
        r.write_surface(path)?;
    }
    let det = a.detect(&d);
    let answer = monitoring::Answer::new(&a, &det.detected, Some(&r.result));
    let repair = answer.repair(r.repair(&d, a.kind.integrating));
    reporting::write(&args.out.report, s, || {
        report::pages::quantify_page(&d, &r, &det, &repair, &answer)
    })?;
    if args.out.json {
        let mut record = r.record(&m.search.init);
        record.set_repair(repair);
        return s.json(&monitoring::document::quantify(
            &d.source,
            &record,
            &det.detected,
            &answer,
        )?);
    }
    let text = report::text::quantify(&d.source, &r, m.search.init.label(), &answer)?;
    s.text(format!(
        "{text}{}\n{}\n",
        report::text::repair_line(&repair),
        report::text::detection_line(&det.detected)
    ))
}

/// `names` without repeats (first occurrence kept), with a note on stderr naming the repeats
/// (`--stiction kano,kano` ran Kano twice).
fn once(names: Vec<String>, flag: &str, s: &mut Streams<'_>) -> Vec<String> {
    let mut kept: Vec<String> = Vec::new();
    let mut repeated: Vec<String> = Vec::new();
    for n in names {
        if kept.contains(&n) {
            if !repeated.contains(&n) {
                repeated.push(n);
            }
        } else {
            kept.push(n);
        }
    }
    if !repeated.is_empty() {
        let _ = writeln!(
            s.stderr,
            "note: {flag} names {} more than once: each runs once",
            repeated.join(", ")
        );
    }
    kept
}

pub(crate) fn run_compare(args: CompareArgs, s: &mut Streams<'_>) -> CmdResult {
    let combos = args.combos.or(COMPARE_COMBOS);
    let stiction = once(combos.stiction, "--stiction", s);
    let linear = once(combos.linear, "--linear", s);
    // Validate every name first: a typo is bad usage, not a row error.
    for name in &stiction {
        find_model(name).map_err(usage)?;
    }
    for name in &linear {
        run::identifier_for(name, "", 0).map_err(usage)?;
    }
    let (d, a) = args.source.analysed(&args.out, "compare", s)?;
    let (started, total) = (Instant::now(), stiction.len() * linear.len());
    let mut rows = Vec::new();
    for st in &stiction {
        for li in &linear {
            let step = format!("compare {}/{total}: ", rows.len() + 1);
            let r = run_one(
                (st, li),
                &args.search,
                &a.searched,
                s,
                (started, &step),
                grid_search::NodeFits::Criterion,
            );
            rows.push((st.as_str(), li.as_str(), r.map_err(|f| f.line())));
        }
    }
    let view: Vec<report::text::CompareRow<'_>> = rows
        .iter()
        .map(|(st, li, r)| (*st, *li, r.as_ref().map_err(Clone::clone)))
        .collect();
    let criterion = args.search.criterion.into();
    reporting::write(&args.out.report, s, || {
        report::pages::compare_page(&d, &view, criterion, a.span_unknown)
    })?;
    if args.out.json {
        let mut doc = run::CompareRecord::new(&d.source);
        for (st, li, r) in &view {
            doc.push(
                st,
                li,
                r.clone().map(|r| {
                    let mut record = r.record(&args.search.init);
                    record.set_repair(r.repair(&d, a.kind.integrating));
                    record
                }),
            );
        }
        return s.json(&monitoring::document::compare(&doc, &a.kind)?);
    }
    let o = args.search.settings(&[])?.options(1.0);
    let text = report::text::compare(&d, o.split, o.init.label(), o.criterion, &view)?;
    s.text(format!("{text}loop: {}\n", a.kind.note()))
}
