//! `stiction quantify` and `stiction compare`: the grid search on one loop.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, Context};
use datasets::simulate::Scenario;
use datasets::LoopData;
use grid_search::Problem;
use report::{Block, Report, Section};
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
) -> Result<Run, Failure> {
    let combination = flags.combination(stiction, linear)?;
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

fn fmt_fit(f: Option<f64>) -> String {
    match f {
        Some(v) if v.is_finite() => format!("{v:.2}"),
        _ => "-".into(),
    }
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
    ) {
        Ok(r) => r,
        Err(f) => return Err(refused(f, s)),
    };
    if let Some(path) = &args.surface {
        write_surface(path, &r).map_err(data)?;
    }
    if args.report.report.is_some() {
        let started = Instant::now();
        let name = reporting::loop_name(&d);
        let view = &r;
        let mut result = Section::new("Result");
        result.push(reporting::facts(view));
        result.push(Block::Paragraph(format!(
            "Verdict: {}.",
            reporting::verdict_line(&r.result)
        )));
        for w in &r.result.warnings {
            result.push(Block::Note(w.clone()));
        }
        let mut figs = Section::new("Figures");
        if let Some(sig) = reporting::signals(&d, &name) {
            for f in reporting::run_figures(&sig, view, "", "")? {
                figs.push(Block::Figure(f));
            }
        }
        let rep = Report {
            title: format!("quantify: loop {name}, {}", reporting::combo(view)),
            subtitle: format!("{} · {} samples · stiction quantify", d.source, d.len()),
            summary: vec![reporting::verdict(&r.result, &reporting::combo(view))],
            sections: vec![result, figs],
        };
        reporting::write(&rep, &args.report, started, s)?;
    }
    if args.json {
        let mut v = quantify_json(&r, &args.search.init);
        v["source"] = json!(d.source);
        serde_json::to_writer_pretty(&mut *s.stdout, &v).map_err(data)?;
        writeln!(s.stdout).map_err(data)?;
        return Ok(());
    }
    let q = &r.result;
    let out = &mut *s.stdout;
    let orders: Vec<String> = r
        .identifier
        .orders()
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    let delay_note = match &r.delay_scan {
        Some(_) => format!("dead time {} samples (estimated)", r.delay),
        None => format!("dead time {} samples", r.delay),
    };
    writeln!(
        out,
        "{}: {} + {} ({}), {}, {delay_note}, ranked by one-step {}",
        d.source,
        r.stiction.name,
        r.linear,
        orders.join(", "),
        args.search.init.label(),
        q.criterion.label()
    )
    .map_err(data)?;
    let own = reporting::own_params(r.stiction, q);
    writeln!(
        out,
        "  S = {:.2} %  [{:.2}, {:.2}]    J = {:.2} %  [{:.2}, {:.2}]    ({})",
        q.s,
        q.interval.s[0],
        q.interval.s[1],
        q.j,
        q.interval.j[0],
        q.interval.j[1],
        own.join(", ")
    )
    .map_err(data)?;
    let (fid, fval) = q.fits.rank(q.criterion);
    let (oid, oval) = q.fits.rank(q.criterion.other());
    writeln!(
        out,
        "  F_PV id {:.2} %, val {:.2} %   (other fit: id {}, val {})   F_MV {}   no stiction: val {}",
        fid,
        fval,
        fmt_fit(Some(oid)),
        fmt_fit(Some(oval)),
        fmt_fit(q.fits.mv),
        fmt_fit(q.fit_no_stiction)
    )
    .map_err(data)?;
    writeln!(
        out,
        "  [S, J] ranges: {} nodes within the {:.0} % likelihood-ratio region; grid {} nodes ({} skipped), step {}, OP span {:.2}; {:.0} ms",
        q.interval.nodes,
        100.0 * q.interval.confidence,
        q.nodes_evaluated,
        q.nodes_skipped,
        (q.grid.step() * 1e6).round() / 1e6,
        q.span,
        r.elapsed_ms
    )
    .map_err(data)?;
    writeln!(out, "  verdict: {}", reporting::verdict_line(q)).map_err(data)?;
    for (i, w) in q.warnings.iter().enumerate() {
        let kind = if i < q.doubts.len() {
            "warning"
        } else {
            "note"
        };
        writeln!(out, "  {kind}: {w}").map_err(data)?;
    }
    Ok(())
}

fn write_surface(path: &Path, r: &Run) -> anyhow::Result<()> {
    let file =
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = csv::Writer::from_writer(std::io::BufWriter::new(file));
    let mut header: Vec<String> = r
        .stiction
        .params
        .iter()
        .map(|p| p.name.to_string())
        .collect();
    header.extend(
        [
            "S",
            "J",
            "fit_pred_id",
            "fit_pred_val",
            "fit_sim_id",
            "fit_sim_val",
            "fit_mv",
            "valid_from",
            "skipped",
        ]
        .map(String::from),
    );
    w.write_record(&header)?;
    for n in &r.result.surface {
        let mut row: Vec<String> = n.params.iter().map(|v| v.to_string()).collect();
        row.push(n.s.to_string());
        row.push(n.j.to_string());
        match &n.outcome {
            Ok(f) => {
                for v in [f.pred_id, f.pred_val, f.sim_id, f.sim_val] {
                    row.push(v.to_string());
                }
                row.push(f.mv.map(|v| v.to_string()).unwrap_or_default());
                row.push(f.valid_from.to_string());
                row.push(String::new());
            }
            Err(reason) => {
                row.extend(std::iter::repeat_n(String::new(), 6));
                row.push(reason.to_string());
            }
        }
        w.write_record(&row)?;
    }
    w.flush()
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
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
            let r = run_one(st, li, &args.search, &d, s, (started, &step));
            rows.push((st.clone(), li.clone(), r));
        }
    }
    if args.report.report.is_some() {
        compare_report(&args, &d, &rows, s)?;
    }
    if args.json {
        let mut results = Vec::new();
        let mut errors = Vec::new();
        for (st, li, r) in &rows {
            match r {
                Ok(r) => results.push(quantify_json(r, &args.search.init)),
                Err(f) => errors.push(json!({"stiction_model": st, "linear_model": li, "error": crate::one_line(f.error())})),
            }
        }
        let doc = json!({"source": d.source, "results": results, "errors": errors});
        serde_json::to_writer_pretty(&mut *s.stdout, &doc).map_err(data)?;
        writeln!(s.stdout).map_err(data)?;
        return Ok(());
    }
    let out = &mut *s.stdout;
    writeln!(
        out,
        "{}: {} samples, identification {} / validation {}, {}, ranked by one-step {}",
        d.source,
        d.len(),
        (d.len() as f64 * args.search.split).floor(),
        d.len() - (d.len() as f64 * args.search.split).floor() as usize,
        args.search.init.label(),
        match args.search.criterion {
            super::search_flags::CriterionFlag::Prediction => "prediction",
            super::search_flags::CriterionFlag::Simulation => "simulation",
        }
    )
    .map_err(data)?;
    writeln!(
        out,
        "{:<10} {:<7} {:>6} {:>13} {:>6} {:>13} {:>9} {:>9} {:>7} {:>8}",
        "stiction", "linear", "S", "S range", "J", "J range", "F_PV id", "F_PV val", "F_MV", "time"
    )
    .map_err(data)?;
    for (st, li, r) in &rows {
        match r {
            Ok(r) => {
                let q = &r.result;
                let (fid, fval) = q.fits.rank(q.criterion);
                writeln!(
                    out,
                    "{:<10} {:<7} {:>6.2} {:>13} {:>6.2} {:>13} {:>9.2} {:>9.2} {:>7} {:>7.1}s",
                    st,
                    li,
                    q.s,
                    format!("{:.2}-{:.2}", q.interval.s[0], q.interval.s[1]),
                    q.j,
                    format!("{:.2}-{:.2}", q.interval.j[0], q.interval.j[1]),
                    fid,
                    fval,
                    fmt_fit(q.fits.mv),
                    r.elapsed_ms / 1e3
                )
                .map_err(data)?;
            }
            Err(f) => {
                let msg = crate::one_line(f.error());
                writeln!(out, "{st:<10} {li:<7} error: {msg}").map_err(data)?;
            }
        }
    }
    Ok(())
}

/// The report of `compare`: the table, then each combination's numbers and figures.
fn compare_report(
    args: &CompareArgs,
    d: &LoopData,
    rows: &[(String, String, Result<Run, Failure>)],
    s: &mut Streams<'_>,
) -> Result<(), Failure> {
    let started = Instant::now();
    let name = reporting::loop_name(d);
    let header = [
        "stiction", "linear", "S", "S range", "J", "J range", "F_PV id", "F_PV val", "F_MV",
        "time (s)",
    ]
    .map(String::from)
    .to_vec();
    let mut table = Vec::new();
    let mut ok: Vec<&Run> = Vec::new();
    for (st, li, r) in rows {
        match r {
            Ok(r) => {
                let q = &r.result;
                let (fid, fval) = q.fits.rank(q.criterion);
                table.push(vec![
                    st.clone(),
                    li.clone(),
                    format!("{:.2}", q.s),
                    format!("{:.2}-{:.2}", q.interval.s[0], q.interval.s[1]),
                    format!("{:.2}", q.j),
                    format!("{:.2}-{:.2}", q.interval.j[0], q.interval.j[1]),
                    format!("{fid:.2}"),
                    format!("{fval:.2}"),
                    fmt_fit(q.fits.mv),
                    format!("{:.2}", r.elapsed_ms / 1e3),
                ]);
                ok.push(r);
            }
            Err(f) => {
                let msg = crate::one_line(f.error());
                let mut row = vec![st.clone(), li.clone(), format!("error: {msg}")];
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
            reporting::verdict(&b.result, &reporting::combo(b))
        ));
        let mut ss: Vec<f64> = ok.iter().map(|r| r.result.s).collect();
        ss.sort_by(f64::total_cmp);
        summary.push(format!(
            "Across the {} combinations that ran, S ranges {:.2}-{:.2} % (median {:.2} %) and \
             J {:.2}-{:.2} %; {} failed.",
            ok.len(),
            ss[0],
            ss[ss.len() - 1],
            ss[ss.len() / 2],
            ok.iter().map(|r| r.result.j).fold(f64::INFINITY, f64::min),
            ok.iter()
                .map(|r| r.result.j)
                .fold(f64::NEG_INFINITY, f64::max),
            rows.len() - ok.len()
        ));
    } else {
        summary.push("No combination could be fitted; the table gives each one's reason.".into());
    }
    let mut overview = Section::new("All combinations");
    overview.push(Block::Paragraph(format!(
        "S and J in % of valve span with their likelihood-ratio ranges; F_PV in % ({}), \
         identification and validation; F_MV when MV is logged.",
        args.search.criterion_label()
    )));
    overview.push(Block::Table {
        header,
        rows: table,
    });
    let mut sections = vec![overview];
    let sig = reporting::signals(d, &name);
    for r in &ok {
        let view = r;
        let mut sec = Section::new(reporting::combo(view));
        sec.push(Block::Paragraph(reporting::verdict(
            &r.result,
            &reporting::combo(view),
        )));
        sec.push(reporting::facts(view));
        for w in &r.result.warnings {
            sec.push(Block::Note(w.clone()));
        }
        if let Some(sig) = &sig {
            let prefix = format!("{}-{}-", r.stiction.name, r.linear);
            for f in reporting::run_figures(sig, view, &prefix, "")? {
                sec.push(Block::Figure(f));
            }
        }
        sections.push(sec);
    }
    let rep = Report {
        title: format!("compare: loop {name}"),
        subtitle: format!(
            "{} · {} samples · stiction compare ({} combinations)",
            d.source,
            d.len(),
            rows.len()
        ),
        summary,
        sections,
    };
    reporting::write(&rep, &args.report, started, s)
}
