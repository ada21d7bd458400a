//! `stiction quantify` and `stiction compare`: the grid search on one loop.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::anyhow;
use datasets::simulate::Scenario;
use datasets::LoopData;
use grid_search::Problem;
use serde_json::{json, Value};
use stiction_models::{find_model, Kano};

use super::load::{load, DataFlags};
use super::search_flags::{check_identifier, SearchFlags};
use crate::progress::Progress;
use crate::reporting::{self, ReportFlags};
use crate::{data, usage, CmdResult, Failure, Streams};

pub(crate) const QUANTIFY_HELP: &str = "\
The grid covers the model's parameters from 0 to the OP span (the triangle J <= S for kano).
Each node simulates MV from OP, identifies the linear model on the first 2/3 of the record
(from the sample where MV no longer depends on the valve's initial state, In.3) and scores
the one-step prediction of PV on the last 1/3 (F_PV, paper eq. 9, in %). S and J are in OP
units (% of valve span); the region is the set of nodes not significantly worse than the best.

Examples:
  stiction quantify loop.csv
  stiction quantify loop.csv --stiction he --linear earx --delay auto
  stiction quantify loop.csv --linear armax --orders 2,2,2 --step 0.2 --surface fit.csv
  stiction quantify --example paper --json";

pub(crate) const COMPARE_HELP: &str = "\
Runs quantify for every stiction x linear combination and prints one table in the layout
of the paper's Tables 3-8 (S, J, F_PV id, F_PV val, F_MV). A combination that fails gets its
error in its row; the others still run.

Examples:
  stiction compare --example paper
  stiction compare loop.csv --stiction kano,he --linear arx,earx
  stiction compare loop.csv --json > results.json";

/// Which embedded example to use instead of a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Example {
    /// The paper's benchmark loop (eq. 10, PI 0.5/0.5, σ = 0.1) with a Kano valve S = 9, J = 3,
    /// 3000 samples, seed 1 (paper §3.2, Tables 1-2).
    Paper,
}

/// Arguments of `stiction quantify`.
#[derive(Debug, clap::Args)]
pub struct QuantifyArgs {
    /// CSV file with PV and OP columns (`-` for standard input).
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    file: Option<PathBuf>,
    /// Use an embedded example loop instead of a file.
    #[arg(long, value_enum)]
    example: Option<Example>,
    /// Registered stiction model searched over (see `stiction models`).
    #[arg(long, value_name = "NAME", default_value = "kano")]
    stiction: String,
    /// Registered linear identifier.
    #[arg(long, value_name = "NAME", default_value = "arx")]
    linear: String,
    #[command(flatten)]
    search: SearchFlags,
    #[command(flatten)]
    data: DataFlags,
    /// Write the fit over the whole grid as CSV (for plotting).
    #[arg(long, value_name = "FILE")]
    surface: Option<PathBuf>,
    #[command(flatten)]
    report: ReportFlags,
    /// Print one JSON document.
    #[arg(long)]
    json: bool,
}

/// Arguments of `stiction compare`.
#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    /// CSV file with PV and OP columns (`-` for standard input).
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    file: Option<PathBuf>,
    /// Use an embedded example loop instead of a file.
    #[arg(long, value_enum)]
    example: Option<Example>,
    /// Stiction models, comma-separated.
    #[arg(
        long,
        value_name = "A,B",
        value_delimiter = ',',
        default_value = "kano,he"
    )]
    stiction: Vec<String>,
    /// Linear identifiers, comma-separated.
    #[arg(
        long,
        value_name = "X,Y",
        value_delimiter = ',',
        default_value = "arx,armax,ss,earx,earmax"
    )]
    linear: Vec<String>,
    #[command(flatten)]
    search: SearchFlags,
    #[command(flatten)]
    data: DataFlags,
    #[command(flatten)]
    report: ReportFlags,
    /// Print one JSON document.
    #[arg(long)]
    json: bool,
}

/// The loop to analyse: a file or an embedded example.
pub(crate) fn loop_data(
    file: Option<&Path>,
    example: Option<Example>,
    flags: &DataFlags,
    s: &mut Streams<'_>,
) -> Result<LoopData, Failure> {
    match (file, example) {
        (_, Some(Example::Paper)) => {
            let scenario = Scenario {
                valve: Box::new(Kano::params().s(9.0).j(3.0).check().map_err(data)?),
                ..Scenario::default()
            };
            let sim = scenario.simulate().map_err(data)?;
            let mut d = sim.to_loop_data();
            d.source = "example paper (kano S = 9, J = 3, seed 1)".into();
            Ok(d)
        }
        (Some(f), None) => load(f, flags, true, 30, s),
        (None, None) => Err(usage(anyhow!("give a FILE or --example"))),
    }
}

/// Everything about one quantification run, for printing: the workflow library's result.
pub(crate) use monitoring::Fitted as Run;

/// Run one stiction × linear combination on `d`. The progress bar (on a terminal) appears once
/// `since` is a second old and its label starts with `step` (e.g. `compare 3/10: `).
pub(crate) fn run_one(
    stiction: &str,
    linear: &str,
    flags: &SearchFlags,
    d: &LoopData,
    s: &mut Streams<'_>,
    (since, step): (Instant, &str),
    node_fits: grid_search::NodeFits,
) -> Result<Run, Failure> {
    let mut combination = flags.combination(stiction, linear)?;
    combination.search.node_fits = node_fits;
    let pv = d.require_pv().map_err(data)?;
    let problem = Problem {
        op: &d.op,
        pv,
        mv: d.mv.as_deref(),
    };
    let bar = Progress::since(
        s.progress,
        &format!(
            "{step}{} + {}",
            combination.stiction.name, combination.linear.name
        ),
        "nodes",
        since,
    );
    let tick = |done: usize, total: usize| bar.update(done, total);
    let run = combination.run(problem, Some(&tick));
    bar.finish();
    // Keep the error's type (a node budget breach is bad usage, see `crate::run_from`).
    run.map_err(|e| data(anyhow::Error::new(e).context(d.source.clone())))
}

/// The contract's quantify object as JSON.
pub(crate) fn quantify_json(r: &Run, init: &stiction_models::Initialization) -> Value {
    serde_json::to_value(r.record(init)).unwrap_or_default()
}

pub(crate) fn run_quantify(args: QuantifyArgs, s: &mut Streams<'_>) -> CmdResult {
    let file = args.file.as_deref();
    let refused = |f, s: &mut Streams<'_>| reporting::refused(file, f, &args.report, "quantify", s);
    let d = match loop_data(file, args.example, &args.data, s) {
        Ok(d) => d,
        Err(f) => return Err(refused(f, s)),
    };
    let r = match run_one(
        &args.stiction,
        &args.linear,
        &args.search,
        &d,
        s,
        (Instant::now(), ""),
        // a surface written out carries both criteria's fits at every node
        if args.surface.is_some() {
            grid_search::NodeFits::Both
        } else {
            grid_search::NodeFits::Criterion
        },
    ) {
        Ok(r) => r,
        Err(f) => return Err(refused(f, s)),
    };
    if let Some(path) = &args.surface {
        r.write_surface(path).map_err(data)?;
    }
    reporting::write(&args.report, s, || report::pages::quantify_page(&d, &r))?;
    let det = monitoring::detect_file(&d, file, monitoring::Integrating::Auto);
    if args.json {
        let mut v = quantify_json(&r, &args.search.init);
        v["source"] = json!(d.source);
        v["detection"] = json!(det.record());
        serde_json::to_writer_pretty(&mut *s.stdout, &v).map_err(data)?;
        writeln!(s.stdout).map_err(data)?;
        return Ok(());
    }
    let text = report::text::quantify(&d.source, &r, args.search.init.label()).map_err(data)?;
    write!(s.stdout, "{text}").map_err(data)?;
    writeln!(s.stdout, "{}", report::text::detection_line(&det)).map_err(data)
}

pub(crate) fn run_compare(args: CompareArgs, s: &mut Streams<'_>) -> CmdResult {
    // Validate every name first: a typo is bad usage, not a row error.
    for name in &args.stiction {
        find_model(name).map_err(usage)?;
    }
    for name in &args.linear {
        check_identifier(name, "", 0)?;
    }
    let d = match loop_data(args.file.as_deref(), args.example, &args.data, s) {
        Ok(d) => d,
        Err(f) => {
            return Err(reporting::refused(
                args.file.as_deref(),
                f,
                &args.report,
                "compare",
                s,
            ))
        }
    };
    let mut rows = Vec::new();
    let started = Instant::now();
    let total = args.stiction.len() * args.linear.len();
    for st in &args.stiction {
        for li in &args.linear {
            let step = format!("compare {}/{total}: ", rows.len() + 1);
            let r = run_one(
                st,
                li,
                &args.search,
                &d,
                s,
                (started, &step),
                grid_search::NodeFits::Criterion,
            );
            rows.push((st.clone(), li.clone(), r));
        }
    }
    let view: Vec<report::text::CompareRow<'_>> = rows
        .iter()
        .map(|(st, li, r)| {
            let r = r.as_ref().map_err(|f| crate::one_line(f.error()));
            (st.as_str(), li.as_str(), r)
        })
        .collect();
    let criterion = args.search.criterion_label();
    reporting::write(&args.report, s, || {
        report::pages::compare_page(&d, &view, criterion)
    })?;
    if args.json {
        let mut doc = monitoring::CompareRecord {
            source: d.source.clone(),
            results: Vec::new(),
            errors: Vec::new(),
        };
        for (st, li, r) in &rows {
            match r {
                Ok(r) => doc.results.push(r.record(&args.search.init)),
                Err(f) => doc.errors.push(monitoring::CompareError {
                    stiction_model: st.clone(),
                    linear_model: li.clone(),
                    error: crate::one_line(f.error()),
                }),
            }
        }
        // through a Value: keys in the sorted order every document is printed in
        let doc = serde_json::to_value(&doc).map_err(data)?;
        serde_json::to_writer_pretty(&mut *s.stdout, &doc).map_err(data)?;
        writeln!(s.stdout).map_err(data)?;
        return Ok(());
    }
    let options = args.search.options(1.0)?;
    let text = report::text::compare(
        &d,
        options.split,
        options.init.label(),
        options.criterion,
        &view,
    )
    .map_err(data)?;
    write!(s.stdout, "{text}").map_err(data)
}
