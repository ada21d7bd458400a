//! `stiction batch`: many loops in parallel, one result row per loop and combination, failures in
//! their rows, resumable.

use std::collections::HashSet;
use std::io::{BufRead, Write as _};
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context};
use datasets::format_epoch;
use rayon::prelude::*;
use serde_json::{json, Value};
use stiction_models::find_model;

use super::load::DataFlags;
use super::registrations::{evaluate, expand, roc, FitEvidence, IntegratingFlag, Plan};
use super::search_flags::{build_identifier, SearchFlags};
use super::trend::DEFAULT_MIN_FIT;
use crate::{data, usage, CmdResult, Streams};

pub(crate) const AFTER_HELP: &str = "\
Loops run in parallel (each grid search shares the same thread pool). Each file gets one row
per stiction x linear combination: file, valve, time, status ok/error, S, J with their
likelihood-ratio ranges, F_PV, the no-stiction fit, the reader's notes and, for a failure,
its one-line error. Without -o the rows are printed as a table.

With -o OUT, rows go to OUT.jsonl (one JSON object per line, appended as each loop finishes)
and OUT.csv (rewritten at the end from OUT.jsonl). The run is resumable: a file whose name,
size and modification time, and the run's settings, match a row already in OUT.jsonl is
skipped; change the file or the settings and it is done again.

--labels FILE (CSV with columns file,label; label stiction / no-stiction) adds the label to
each row and reports how well S separates the labels: ROC AUC and the threshold maximising
TPR - FPR (Youden), over the rows with status ok of the first combination.

Examples:
  stiction batch ../shared/data/plant -o plant --labels ../shared/data/plant/labels.csv
  stiction batch DIR --stiction kano,he --linear arx,ss -o results";

/// Arguments of `stiction batch`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Directories or files of registrations (.csv, .tsv, .txt, .mat).
    #[arg(required = true, value_name = "DIR")]
    paths: Vec<PathBuf>,
    /// Output prefix: writes OUT.jsonl and OUT.csv (resumable). Without it, a table on stdout.
    #[arg(short = 'o', long, value_name = "OUT")]
    out: Option<PathBuf>,
    /// Only the registrations of this valve (file-name prefix before `_`).
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
    /// Labels (CSV `file,label`, label `stiction` / `no-stiction`): report ROC AUC of S.
    #[arg(long, value_name = "FILE")]
    labels: Option<PathBuf>,
    /// Minimum validation F_PV (%) below which the evidence says "poor fit".
    #[arg(long, value_name = "PCT", default_value_t = DEFAULT_MIN_FIT)]
    min_fit: f64,
    /// Integrating loops are identified from MV to ΔPV; `auto` = level loops (tag letter L).
    #[arg(long, value_enum, default_value = "auto")]
    integrating: IntegratingFlag,
    #[command(flatten)]
    search: SearchFlags,
    #[command(flatten)]
    data: DataFlags,
}

/// `file -> label` from a labels CSV (columns `file`, `label`).
fn read_labels(path: &Path) -> anyhow::Result<std::collections::HashMap<String, bool>> {
    let mut r = csv::Reader::from_path(path).with_context(|| format!("{}", path.display()))?;
    let header = r.headers()?.clone();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h.trim().eq_ignore_ascii_case(name))
            .ok_or_else(|| anyhow!("{}: no column {name} in the header", path.display()))
    };
    let (fi, li) = (col("file")?, col("label")?);
    let mut out = std::collections::HashMap::new();
    for (k, rec) in r.records().enumerate() {
        let rec = rec?;
        let label = rec.get(li).unwrap_or("").trim().to_ascii_lowercase();
        let positive = match label.as_str() {
            "stiction" | "1" | "true" | "yes" => true,
            "no-stiction" | "nostiction" | "no_stiction" | "0" | "false" | "no" => false,
            other => anyhow::bail!(
                "{}: row {}, column label: {other:?} is not stiction / no-stiction",
                path.display(),
                k + 2
            ),
        };
        out.insert(rec.get(fi).unwrap_or("").trim().to_string(), positive);
    }
    Ok(out)
}

/// The rows of an OUT.jsonl and the line numbers of lines that are not a JSON object (a torn
/// last line is what an interrupted run leaves).
fn read_jsonl(f: std::fs::File) -> std::io::Result<(Vec<Value>, Vec<usize>)> {
    let (mut rows, mut torn) = (Vec::new(), Vec::new());
    for (i, line) in std::io::BufReader::new(f).lines().enumerate() {
        let line = line?;
        if line.trim().is_empty() {
            continue;
        }
        match serde_json::from_str::<Value>(&line) {
            Ok(v) if v.is_object() => rows.push(v),
            _ => torn.push(i + 1),
        }
    }
    Ok((rows, torn))
}

/// What resuming does about unreadable lines, in words.
fn torn_note(path: &Path, torn: &[usize]) -> Option<String> {
    match torn {
        [] => None,
        [line] => Some(format!(
            "{}: line {line} is torn (an interrupted run): its registration is computed again",
            path.display()
        )),
        lines => Some(format!(
            "{}: {} unreadable lines (first: line {}): their registrations are computed again",
            path.display(),
            lines.len(),
            lines[0]
        )),
    }
}

/// Identity of a file for resuming: name, size, modification time (s).
fn identity(p: &Path) -> (u64, Option<u64>) {
    let meta = std::fs::metadata(p).ok();
    let size = meta.as_ref().map_or(0, |m| m.len());
    let mtime = meta
        .and_then(|m| m.modified().ok())
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map(|d| d.as_secs());
    (size, mtime)
}

fn with_ext(out: &Path, ext: &str) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(ext);
    PathBuf::from(s)
}

const CSV_HEADER: [&str; 19] = [
    "file",
    "valve",
    "time",
    "status",
    "stiction_model",
    "linear_model",
    "S",
    "S_lo",
    "S_hi",
    "J",
    "J_lo",
    "J_hi",
    "fit_pv_val",
    "fit_no_stiction",
    "integrating",
    "label",
    "why",
    "notes",
    "error",
];

fn csv_cell(v: &Value) -> String {
    match v {
        Value::Null => String::new(),
        Value::String(s) => s.clone(),
        Value::Array(a) => a.iter().map(csv_cell).collect::<Vec<_>>().join(" | "),
        other => other.to_string(),
    }
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    for name in &args.stiction {
        find_model(name).map_err(usage)?;
    }
    for name in &args.linear {
        build_identifier(name, args.search.orders.as_deref(), 0)?;
    }
    let labels = match &args.labels {
        Some(p) => Some(read_labels(p).map_err(data)?),
        None => None,
    };
    let jsonl = args.out.as_deref().map(|o| with_ext(o, ".jsonl"));
    let csv_path = args.out.as_deref().map(|o| with_ext(o, ".csv"));
    let mut exclude: Vec<PathBuf> = args.labels.iter().cloned().collect();
    exclude.extend(jsonl.iter().cloned());
    exclude.extend(csv_path.iter().cloned());
    let (mut files, not_loops) =
        expand(&args.paths, &exclude, args.data.op_column()).map_err(usage)?;
    for (f, why) in &not_loops {
        let _ = writeln!(s.stderr, "note: skipped {}: {why}", f.display());
    }
    if let Some(v) = &args.valve {
        files.retain(|f| {
            datasets::parse_registration_name(&super::registrations::file_name(f)).valve == *v
        });
    }
    let settings = format!(
        "{:?}|{:?}|{:?}|{:?}|{:?}|{}",
        args.stiction, args.linear, args.search, args.data, args.integrating, args.min_fit
    );

    // Resume: keep the rows of files already done with these settings.
    let mut previous: Vec<Value> = Vec::new();
    if let Some(path) = &jsonl {
        if let Ok(f) = std::fs::File::open(path) {
            let (rows, torn) = read_jsonl(f).map_err(data)?;
            previous = rows;
            if let Some(note) = torn_note(path, &torn) {
                let _ = writeln!(s.stderr, "note: {note}");
            }
        }
    }
    let key = |file: &str, size: u64, mtime: Option<u64>| format!("{file}|{size}|{mtime:?}");
    let current: HashSet<String> = files
        .iter()
        .map(|f| {
            let (size, mtime) = identity(f);
            key(&super::registrations::file_name(f), size, mtime)
        })
        .collect();
    let row_key = |v: &Value| {
        key(
            v["file"].as_str().unwrap_or(""),
            v["size"].as_u64().unwrap_or(0),
            v["mtime"].as_u64(),
        )
    };
    previous.retain(|v| v["settings"].as_str() == Some(&settings) && current.contains(&row_key(v)));
    let done: HashSet<String> = previous.iter().map(row_key).collect();
    let todo: Vec<PathBuf> = files
        .iter()
        .filter(|f| {
            let (size, mtime) = identity(f);
            !done.contains(&key(&super::registrations::file_name(f), size, mtime))
        })
        .cloned()
        .collect();
    let skipped = files.len() - todo.len();

    // Rewrite OUT.jsonl with the rows kept (drops torn lines and stale rows), then append.
    let writer = match &jsonl {
        Some(path) => {
            let mut w = std::io::BufWriter::new(
                std::fs::File::create(path)
                    .with_context(|| format!("cannot create {}", path.display()))
                    .map_err(data)?,
            );
            for v in &previous {
                writeln!(w, "{v}").map_err(data)?;
            }
            w.flush().map_err(data)?;
            Some(std::sync::Mutex::new(w))
        }
        None => None,
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
    let bar = crate::progress::Progress::new(s.progress, "batch");
    let count = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<anyhow::Result<Vec<Value>>> = todo
        .par_iter()
        .map(|f| {
            let reg = evaluate(f, &plan);
            let (size, mtime) = identity(f);
            let label = labels.as_ref().and_then(|l| l.get(&reg.file)).map(|&p| {
                if p {
                    "stiction"
                } else {
                    "no-stiction"
                }
            });
            let base = json!({
                "file": reg.file, "path": reg.path.display().to_string(), "size": size,
                "mtime": mtime, "valve": reg.valve, "time": reg.start.map(format_epoch),
                "time_source": reg.time_source, "integrating": reg.integrating,
                "label": label, "notes": reg.notes, "settings": settings,
            });
            let mut rows = Vec::new();
            match &reg.outcome {
                Err(e) => {
                    let mut row = base.clone();
                    row["status"] = json!("error");
                    row["error"] = json!(e);
                    rows.push(row);
                }
                Ok(combos) => {
                    for c in combos {
                        let mut row = base.clone();
                        row["stiction_model"] = json!(c.stiction);
                        row["linear_model"] = json!(c.linear);
                        match &c.result {
                            Ok(fit) => {
                                row["status"] = json!("ok");
                                let g = |x: f64| crate::on_grid(x, fit.step);
                                row["S"] = json!(g(fit.s));
                                row["S_lo"] = json!(g(fit.s_range[0]));
                                row["S_hi"] = json!(g(fit.s_range[1]));
                                row["J"] = json!(g(fit.j));
                                row["J_lo"] = json!(g(fit.j_range[0]));
                                row["J_hi"] = json!(g(fit.j_range[1]));
                                row["fit_pv_val"] = json!(fit.fit_val);
                                row["fit_no_stiction"] = fit.json["fit_no_stiction"].clone();
                                row["why"] = json!(fit.evidence);
                                row["quantify"] = fit.json.clone();
                            }
                            Err(e) => {
                                row["status"] = json!("error");
                                row["error"] = json!(e);
                            }
                        }
                        rows.push(row);
                    }
                }
            }
            if let Some(w) = &writer {
                let mut w = w.lock().map_err(|_| anyhow!("output lock poisoned"))?;
                for r in &rows {
                    writeln!(w, "{r}")?;
                }
                w.flush()?;
            }
            let k = count.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            bar.update(k, todo.len());
            Ok(rows)
        })
        .collect();
    bar.finish();
    let mut rows = previous;
    for r in results {
        rows.extend(r.map_err(data)?);
    }
    rows.sort_by(|a, b| {
        let k = |v: &Value| {
            (
                v["file"].as_str().unwrap_or("").to_string(),
                v["stiction_model"].as_str().unwrap_or("").to_string(),
                v["linear_model"].as_str().unwrap_or("").to_string(),
            )
        };
        k(a).cmp(&k(b))
    });

    if let Some(path) = &csv_path {
        let mut w = csv::Writer::from_path(path)
            .with_context(|| format!("cannot create {}", path.display()))
            .map_err(data)?;
        w.write_record(CSV_HEADER).map_err(data)?;
        for r in &rows {
            let rec: Vec<String> = CSV_HEADER.iter().map(|k| csv_cell(&r[*k])).collect();
            w.write_record(&rec).map_err(data)?;
        }
        w.flush().map_err(data)?;
    }

    let out = &mut *s.stdout;
    let ok = rows.iter().filter(|r| r["status"] == "ok").count();
    let failed = rows.len() - ok;
    if args.out.is_none() {
        writeln!(
            out,
            "{:<34} {:<14} {:<16} {:<6} {:>6} {:>13} {:>5} {:>8}  error",
            "file", "valve", "time", "status", "S", "S range", "J", "F_PV val"
        )
        .map_err(data)?;
        for r in &rows {
            let num = |k: &str| r[k].as_f64().map_or("-".into(), |v| format!("{v:.2}"));
            writeln!(
                out,
                "{:<34} {:<14} {:<16} {:<6} {:>6} {:>13} {:>5} {:>8}  {}",
                r["file"].as_str().unwrap_or(""),
                r["valve"].as_str().unwrap_or(""),
                r["time"].as_str().unwrap_or("?"),
                r["status"].as_str().unwrap_or(""),
                num("S"),
                format!("{}-{}", num("S_lo"), num("S_hi")),
                num("J"),
                num("fit_pv_val"),
                r["error"].as_str().unwrap_or("")
            )
            .map_err(data)?;
        }
    }
    writeln!(
        out,
        "{} file(s): {} row(s) ok, {} error row(s); {} file(s) computed, {} skipped (already in {})",
        files.len(),
        ok,
        failed,
        todo.len(),
        skipped,
        jsonl
            .as_ref()
            .map_or("-".into(), |p| p.display().to_string())
    )
    .map_err(data)?;
    if labels.is_some() {
        let (st, li) = (&args.stiction[0], &args.linear[0]);
        let scores: Vec<(f64, bool)> = rows
            .iter()
            .filter(|r| {
                r["status"] == "ok" && r["stiction_model"] == **st && r["linear_model"] == **li
            })
            .filter_map(|r| {
                let s = r["S"].as_f64()?;
                let l = r["label"].as_str()?;
                Some((s, l == "stiction"))
            })
            .collect();
        let npos = scores.iter().filter(|x| x.1).count();
        match roc(&scores) {
            Some(monitoring::Roc {
                auc,
                threshold: thr,
                tpr,
                fpr,
            }) => writeln!(
                out,
                "labels ({st} + {li}, {} labelled rows: {npos} stiction, {} no-stiction): ROC AUC of S = {auc:.3}; best threshold S >= {thr:.2} % (Youden: TPR {tpr:.2}, FPR {fpr:.2})",
                scores.len(),
                scores.len() - npos
            ),
            None => writeln!(
                out,
                "labels: ROC needs ok rows of both labels ({} labelled ok rows, {npos} stiction)",
                scores.len()
            ),
        }
        .map_err(data)?;
    }
    Ok(())
}
