//! `stiction._native`: the workspace's library crates seen from Python.
//!
//! This module is the thin, typed layer; the friendly signatures (pandas DataFrames, keyword
//! arguments, docstrings) are in `stiction/__init__.py`. Conventions:
//! - Records cross as CSV text read by `datasets::read_csv`, the reader the CLI uses, so column
//!   names, units detection, gap handling, notes and error messages are the CLI's own.
//! - Results cross as JSON text built by the library (the CLI prints the same documents), which
//!   the Python side turns into plain dicts, or as numpy arrays for series.
//! - Every long computation runs with the interpreter released (`Python::detach`), so Python
//!   threads (and Dask's threaded workers) run beside it.
//! - Errors are exceptions carrying the library's one-line message: `DataError` for input the
//!   reader or the search refuses, `UsageError` for options that cannot work.

use std::collections::BTreeMap;

/// The CLI's allocator for the extension's own allocations (Python's stay with Python): the
/// grid's surface, freed after every search, would otherwise go back to the kernel and be
/// faulted in again (`docs/decisions/2026-11-29-allocator.md`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

mod audit;
mod fleet;

use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use datasets::{LoopData, OpRange, ReadOptions};
use run::RunError;
use run::{SearchArgs, Settings};
use stiction_models::{find_model, run_valve, Initialization};

create_exception!(
    _native,
    StictionError,
    PyException,
    "Base class of the errors raised by stiction."
);
create_exception!(
    _native,
    DataError,
    StictionError,
    "The data were refused (the message names file, row and column where it can)."
);
create_exception!(
    _native,
    UsageError,
    StictionError,
    "An option or argument cannot work (unknown model, bad parameter, ...)."
);

fn data_err(e: impl std::fmt::Display) -> PyErr {
    DataError::new_err(keywords(&e.to_string()))
}

fn usage_err(e: impl std::fmt::Display) -> PyErr {
    UsageError::new_err(keywords(&e.to_string()))
}

/// Run `f` with the interpreter released, on a worker thread, while this thread asks the
/// interpreter every 100 ms whether a signal arrived (Ctrl-C): if so, the library's
/// computations are asked to stop ([`stiction_models::cancel`]: the grid search between nodes,
/// the detector between stiction bands), the worker's answer is discarded and the signal's
/// exception (`KeyboardInterrupt`) is raised, within about a second. Before, Ctrl-C was
/// honoured only when the call returned (an 18 s `detect` of 60 000 rows).
fn interruptible<T: Send>(py: Python<'_>, f: impl FnOnce() -> PyResult<T> + Send) -> PyResult<T> {
    use std::sync::mpsc::{channel, RecvTimeoutError};
    py.detach(|| {
        std::thread::scope(|scope| {
            let (tx, rx) = channel::<()>();
            let worker = scope.spawn(move || {
                let r = f();
                let _ = tx.send(());
                r
            });
            loop {
                match rx.recv_timeout(std::time::Duration::from_millis(100)) {
                    Ok(()) | Err(RecvTimeoutError::Disconnected) => break,
                    Err(RecvTimeoutError::Timeout) => {
                        if let Err(signal) = Python::attach(|py| py.check_signals()) {
                            stiction_models::cancel::request();
                            let _ = worker.join();
                            stiction_models::cancel::clear();
                            return Err(signal);
                        }
                    }
                }
            }
            worker.join().unwrap_or_else(|_| {
                Err(StictionError::new_err(
                    "internal error (a bug, please report it): the computation panicked",
                ))
            })
        })
    })
}

/// The library's messages name the CLI's flags (`--max-rows`, `--op-range LO,HI`); Python
/// users pass keywords: `--max-rows` becomes `max_rows`, `--op-range LO,HI` `op_range=(lo, hi)`.
fn keywords(message: &str) -> String {
    let message = message.replace("--op-range LO,HI", "op_range=(lo, hi)");
    let mut out = String::with_capacity(message.len());
    let mut rest = message.as_str();
    while let Some(at) = rest.find("--") {
        let (before, flag) = rest.split_at(at);
        out.push_str(before);
        let name_len = flag[2..]
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
            .unwrap_or(flag.len() - 2);
        let name = &flag[2..2 + name_len];
        if name.is_empty() || !name.starts_with(|c: char| c.is_ascii_lowercase()) {
            out.push_str("--");
            rest = &flag[2..];
            continue;
        }
        out.push_str(&name.replace('-', "_"));
        rest = &flag[2 + name_len..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn flags_become_keywords() {
        assert_eq!(
            super::keywords("x: more than 10 data rows (the limit; raise it with --max-rows)"),
            "x: more than 10 data rows (the limit; raise it with max_rows)"
        );
        assert_eq!(
            super::keywords("give --op-range LO,HI to state it; --criterion: expected"),
            "give op_range=(lo, hi) to state it; criterion: expected"
        );
        assert_eq!(super::keywords("a -- b"), "a -- b");
    }
}

/// The reader's options from a dict with the CLI's flag names (`pv`, `op`, `sp`, `mv`,
/// `time`, `mode`, `gaps` = "refuse" | "hold" | "drop", `op_range` = (lo, hi) or None,
/// `max_rows`, `window`).
#[derive(Debug, Default)]
struct ReadArgs {
    pv: Option<String>,
    op: Option<String>,
    sp: Option<String>,
    mv: Option<String>,
    time: Option<String>,
    mode: Option<String>,
    gaps: Option<String>,
    op_range: Option<(f64, f64)>,
    max_rows: Option<usize>,
    window: Option<usize>,
}

/// [`ReadArgs`] from a dict; an unknown key is a [`UsageError`] (a misspelt option must not be
/// ignored).
fn read_args(d: Option<&Bound<'_, PyDict>>) -> PyResult<ReadArgs> {
    let mut a = ReadArgs::default();
    let Some(d) = d else { return Ok(a) };
    for (k, v) in d.iter() {
        let key: String = k.extract()?;
        if v.is_none() {
            continue;
        }
        let bad = |e: PyErr| usage_err(format!("reader option {key}: {e}"));
        match key.as_str() {
            "pv" => a.pv = Some(v.extract().map_err(bad)?),
            "op" => a.op = Some(v.extract().map_err(bad)?),
            "sp" => a.sp = Some(v.extract().map_err(bad)?),
            "mv" => a.mv = Some(v.extract().map_err(bad)?),
            "time" => a.time = Some(v.extract().map_err(bad)?),
            "mode" => a.mode = Some(v.extract().map_err(bad)?),
            "gaps" => a.gaps = Some(v.extract().map_err(bad)?),
            "op_range" => a.op_range = Some(v.extract().map_err(bad)?),
            "max_rows" => a.max_rows = Some(v.extract().map_err(bad)?),
            "window" => a.window = Some(v.extract().map_err(bad)?),
            other => {
                return Err(usage_err(format!(
                    "unknown reader option {other:?}; known: pv, op, sp, mv, time, mode, gaps, op_range, max_rows, window"
                )))
            }
        }
    }
    Ok(a)
}

impl ReadArgs {
    fn options(&self, require_pv: bool, min_rows: usize) -> PyResult<ReadOptions> {
        let gaps = self
            .gaps
            .as_deref()
            .unwrap_or("refuse")
            .parse()
            .map_err(usage_err)?;
        let op_range = match self.op_range {
            None => OpRange::Detect,
            Some((lo, hi)) => OpRange::given(lo, hi)
                .map_err(|e| usage_err(format!("op_range=({lo}, {hi}): {e}")))?,
        };
        let mut limits = datasets::Limits::default();
        if let Some(n) = self.max_rows {
            limits.max_rows = n;
        }
        Ok(ReadOptions {
            pv: self.pv.clone(),
            op: self.op.clone(),
            sp: self.sp.clone(),
            mv: self.mv.clone(),
            time: self.time.clone(),
            require_pv,
            gaps,
            min_rows,
            mode: self.mode.clone(),
            mat_loop: None,
            op_range,
            limits,
            accept_constant: false,
            window: self.window.unwrap_or(datasets::DEFAULT_WINDOW),
        })
    }
}

fn read_text(text: &str, source: &str, args: &ReadArgs, require_pv: bool) -> PyResult<LoopData> {
    let opts = args.options(require_pv, 3)?;
    datasets::read_csv(text.as_bytes(), source, &opts).map_err(data_err)
}

fn series<'py>(py: Python<'py>, v: &Option<Vec<f64>>) -> Option<Bound<'py, PyArray1<f64>>> {
    v.as_ref().map(|v| v.clone().into_pyarray(py))
}

/// Read a registration from CSV text as the CLI reads a file: a dict with `t`, `sp`, `pv`,
/// `op`, `mv` (numpy arrays or None), `start` (seconds since the epoch or None), `source` and
/// `notes` (what the reader did: filled gaps, rescaled OP, ...).
#[pyfunction]
#[pyo3(signature = (text, source, options = None, require_pv = true))]
fn read_csv<'py>(
    py: Python<'py>,
    text: &str,
    source: &str,
    options: Option<&Bound<'py, PyDict>>,
    require_pv: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let options = read_args(options)?;
    let d = py.detach(|| read_text(text, source, &options, require_pv))?;
    loop_dict(py, &d)
}

/// What a quantify or compare call asks for: the combination(s) and the search settings.
struct Request {
    stiction: Vec<String>,
    linear: Vec<String>,
    args: SearchArgs,
    settings: Settings,
    /// diagnose: causes left out (`--without`).
    without: Vec<String>,
    /// Whether the loop is integrating (`--integrating`).
    integrating: monitoring::Integrating,
}

/// `integrating` of a settings JSON: `auto` (the default), `yes` or `no`.
fn integrating(v: Option<serde_json::Value>) -> PyResult<monitoring::Integrating> {
    match v {
        None => Ok(monitoring::Integrating::Auto),
        Some(x) => serde_json::from_value(x).map_err(|e| {
            usage_err(format!(
                "integrating: {e} (expected \"auto\", \"yes\" or \"no\")"
            ))
        }),
    }
}

fn names(v: Option<serde_json::Value>, key: &str, default: &str) -> PyResult<Vec<String>> {
    match v {
        None => Ok(vec![default.to_string()]),
        Some(serde_json::Value::String(s)) => Ok(vec![s]),
        Some(serde_json::Value::Array(a)) if !a.is_empty() => a
            .into_iter()
            .map(|x| match x {
                serde_json::Value::String(s) => Ok(s),
                other => Err(usage_err(format!("{key}: expected names, got {other}"))),
            })
            .collect(),
        Some(other) => Err(usage_err(format!(
            "{key}: expected a name or a list of names, got {other}"
        ))),
    }
}

/// The request of a settings JSON (`stiction`, `linear` and the [`SearchArgs`]); settings that
/// cannot work are a [`UsageError`] before any search, as in the CLI.
fn request(settings_json: &str) -> PyResult<Request> {
    let mut v: serde_json::Map<String, serde_json::Value> =
        serde_json::from_str(settings_json).map_err(usage_err)?;
    let stiction = names(v.remove("stiction"), "stiction", "kano")?;
    let linear = names(v.remove("linear"), "linear", "arx")?;
    let without = match v.remove("without") {
        None => Vec::new(),
        x => names(x, "without", "")?,
    };
    let integrating = integrating(v.remove("integrating"))?;
    let (args, settings) = search_settings(v, &stiction, &linear)?;
    Ok(Request {
        stiction,
        linear,
        args,
        settings,
        without,
        integrating,
    })
}

/// The search settings among a call's options (the rest of `v`, which must all be
/// [`SearchArgs`] fields), checked against the models and identifiers of the call.
fn search_settings(
    v: serde_json::Map<String, serde_json::Value>,
    stiction: &[String],
    linear: &[String],
) -> PyResult<(SearchArgs, Settings)> {
    let args: SearchArgs =
        serde_json::from_value(serde_json::Value::Object(v)).map_err(usage_err)?;
    for name in stiction {
        find_model(name).map_err(usage_err)?;
    }
    let refs: Vec<&str> = linear.iter().map(String::as_str).collect();
    let settings = args.settings(&refs).map_err(usage_err)?;
    Ok((args, settings))
}

/// A failed search: bad usage (node budget, invalid option) or refused data, with the source.
fn search_err(source: &str, e: RunError) -> PyErr {
    match &e {
        RunError::Search(s) if s.is_usage() => usage_err(format!("{source}: {e}")),
        RunError::Setting { .. } => usage_err(format!("{source}: {e}")),
        _ => data_err(format!("{source}: {e}")),
    }
}

/// One combination on a record analysed as `a` (searched as `a.searched`): its fit and quantify
/// object, or the error.
fn quantify_record(
    d: &LoopData,
    a: &monitoring::Analysis,
    (stiction, linear): (&str, &str),
    req: &Request,
) -> Result<(run::Fitted, run::QuantifyRecord), PyErr> {
    let combination = req
        .settings
        .combination(stiction, linear)
        .map_err(|e| search_err(&d.source, e))?;
    let problem = run::problem(&a.searched).map_err(data_err)?;
    let fitted = combination
        .run(problem, None)
        .map_err(|e| search_err(&d.source, e))?;
    let mut record = fitted.record(&req.settings.search.init);
    record.set_repair(fitted.repair(d, a.kind.integrating));
    Ok((fitted, record))
}

/// The record analysed as the CLI analyses it: the loop kind decided by `integrating` from the
/// record and the file's valve tag (the record's source names the file).
fn analysed(d: &LoopData, req: &Request) -> monitoring::Analysis {
    monitoring::analyse(d, Some(std::path::Path::new(&d.source)), req.integrating)
}

/// The `diagnose --json` document (`discrepancy::baseline`, `options_for`, `diagnose`).
fn diagnose_doc(d: &LoopData, req: &Request) -> PyResult<serde_json::Value> {
    use discrepancy::DiagnoseError;
    let usage_of = |e: DiagnoseError| usage_err(e.to_string());
    let baseline =
        discrepancy::baseline(&req.args, &req.stiction[0], &req.linear[0]).map_err(usage_of)?;
    let a = analysed(d, req);
    let problem = run::problem(&a.searched).map_err(data_err)?;
    let span = run::span_of(&a.searched.op);
    let options = discrepancy::options_for(&req.args, span, &req.without).map_err(usage_of)?;
    let dg = discrepancy::diagnose(problem, &baseline, &options).map_err(|e| match e {
        e @ DiagnoseError::UnknownCause { .. } => usage_err(e.to_string()),
        DiagnoseError::Search(e) if e.is_usage() => usage_err(format!("{}: {e}", d.source)),
        other => data_err(format!("{}: {other}", d.source)),
    })?;
    // what a repair would buy, and the answer, in the final model (as `stiction diagnose
    // --json`)
    let fit = dg.final_fit().unwrap_or(&dg.baseline_fit);
    let det = a.detect(d).detected;
    let answer = monitoring::Answer::new(&a, &det, Some(&fit.result));
    let repair = answer.repair(fit.repair(d, a.kind.integrating));
    Ok(monitoring::document::diagnose(
        &d.source,
        &dg,
        &req.settings.search.init,
        &det,
        &repair,
        &answer,
    ))
}

/// The `identify --json` document: the identifier with its orders and dead time, from MV when
/// the record has it, else from OP, to PV.
fn identify_doc(d: &LoopData, req: &Request) -> PyResult<serde_json::Value> {
    let delay = match req.args.delay {
        run::DelayArg::Samples(n) => n,
        run::DelayArg::Auto => {
            return Err(usage_err("identify: delay must be a number of samples"))
        }
    };
    let orders = req.args.orders.as_deref().unwrap_or("");
    let (identifier, _) = run::identifier_for(&req.linear[0], orders, delay).map_err(usage_err)?;
    let input = run::identify::input_of(d, None);
    let y = d.require_pv().map_err(data_err)?;
    let id = run::identify::identify(
        identifier.as_ref(),
        &d.source,
        input,
        (y, "PV"),
        req.args.split,
    )
    .map_err(data_err)?;
    serde_json::to_value(id.record(delay)).map_err(data_err)
}

/// `command` ("quantify" or "compare") on a record: the CLI's JSON document as text.
fn run_command(command: &str, d: &LoopData, req: &Request) -> PyResult<String> {
    let doc = match command {
        "quantify" => {
            let a = analysed(d, req);
            let (fitted, mut r) = quantify_record(d, &a, (&req.stiction[0], &req.linear[0]), req)?;
            let det = a.detect(d).detected;
            let answer = monitoring::Answer::new(&a, &det, Some(&fitted.result));
            if let Some(refusal) = answer.repair_refusal() {
                r.set_repair(Err(refusal));
            }
            monitoring::document::quantify(&d.source, &r, &det, &answer).map_err(data_err)?
        }
        "detect" => {
            d.require_pv().map_err(data_err)?;
            let a = analysed(d, req);
            let detected = a.detect(d).detected;
            let answer = monitoring::Answer::new(&a, &detected, None);
            match detected {
                monitoring::Detected::Ran(det) => monitoring::document::detect(d, &det, &answer),
                monitoring::Detected::Failed(e) => {
                    return Err(data_err(format!("{}: {e}", d.source)))
                }
            }
        }
        "compare" => {
            let a = analysed(d, req);
            let mut doc = run::CompareRecord::new(&d.source);
            for st in &req.stiction {
                for li in &req.linear {
                    let r = quantify_record(d, &a, (st, li), req)
                        .map(|(_, r)| r)
                        .map_err(|e| Python::attach(|py| e.value(py).to_string()));
                    doc.push(st, li, r);
                }
            }
            monitoring::document::compare(&doc, &a.kind).map_err(data_err)?
        }
        "diagnose" => diagnose_doc(d, req)?,
        "identify" => identify_doc(d, req)?,
        other => return Err(usage_err(format!("unknown command {other:?}"))),
    };
    serde_json::to_string(&doc).map_err(data_err)
}

/// `quantify` / `compare` on CSV text: the JSON document.
#[pyfunction]
#[pyo3(signature = (command, text, source, options, settings_json))]
fn run_csv(
    py: Python<'_>,
    command: &str,
    text: &str,
    source: &str,
    options: Option<&Bound<'_, PyDict>>,
    settings_json: &str,
) -> PyResult<String> {
    let reader = read_args(options)?;
    run_read(py, command, settings_json, || {
        read_text(text, source, &reader, true)
    })
}

/// `command` with the settings of `settings_json` on the record `read` returns: the read (when
/// it does not need the GIL) and the command run without the GIL, interruptible.
fn run_read(
    py: Python<'_>,
    command: &str,
    settings_json: &str,
    read: impl FnOnce() -> PyResult<LoopData> + Send,
) -> PyResult<String> {
    let req = request(settings_json)?;
    interruptible(py, || run_command(command, &read()?, &req))
}

/// A command on named columns (a DataFrame's): the columns are read in place by the reader's
/// in-memory entry (`datasets::read_columns`, the CSV reader's conventions without a CSV text),
/// then the command runs without the GIL.
#[pyfunction]
#[pyo3(signature = (command, names, columns, source, options, settings_json))]
fn run_columns(
    py: Python<'_>,
    command: &str,
    names: Vec<String>,
    columns: Vec<Column<'_>>,
    source: &str,
    options: Option<&Bound<'_, PyDict>>,
    settings_json: &str,
) -> PyResult<String> {
    let reader = read_args(options)?;
    let d = read_frame(&names, &columns, source, &reader, true)?;
    run_read(py, command, settings_json, || Ok(d))
}

/// Named columns read by `datasets::read_columns` (with the GIL held: the arrays are Python's).
fn read_frame(
    names: &[String],
    columns: &[Column<'_>],
    source: &str,
    args: &ReadArgs,
    require_pv: bool,
) -> PyResult<LoopData> {
    let opts = args.options(require_pv, 3)?;
    if names.len() != columns.len() {
        return Err(usage_err(format!(
            "{} column names for {} columns",
            names.len(),
            columns.len()
        )));
    }
    let inputs = columns
        .iter()
        .map(|c| match c {
            Column::Numbers(a) => a
                .as_slice()
                .map(datasets::ColumnInput::Numbers)
                .map_err(|e| usage_err(e.to_string())),
            Column::Text(t) => Ok(datasets::ColumnInput::Text(t)),
        })
        .collect::<PyResult<Vec<_>>>()?;
    datasets::read_columns(source, names, &inputs, &opts).map_err(data_err)
}

/// `read` on named columns: the dict of `read_csv`.
#[pyfunction]
#[pyo3(signature = (names, columns, source, options = None, require_pv = true))]
fn read_columns<'py>(
    py: Python<'py>,
    names: Vec<String>,
    columns: Vec<Column<'py>>,
    source: &str,
    options: Option<&Bound<'py, PyDict>>,
    require_pv: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let args = read_args(options)?;
    let d = read_frame(&names, &columns, source, &args, require_pv)?;
    loop_dict(py, &d)
}

/// `quantify` / `compare` on a file: the JSON document.
#[pyfunction]
#[pyo3(signature = (command, path, options, settings_json))]
fn run_path(
    py: Python<'_>,
    command: &str,
    path: std::path::PathBuf,
    options: Option<&Bound<'_, PyDict>>,
    settings_json: &str,
) -> PyResult<String> {
    let opts = read_args(options)?.options(true, 3)?;
    run_read(py, command, settings_json, || {
        datasets::read_path(path, &opts).map_err(data_err)
    })
}

/// Read a registration from a file (CSV or MATLAB) as the CLI does; the same dict as
/// [`read_csv`].
#[pyfunction]
#[pyo3(signature = (path, options = None, require_pv = true))]
fn read_path<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    options: Option<&Bound<'py, PyDict>>,
    require_pv: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let opts = read_args(options)?.options(require_pv, 3)?;
    let d = py
        .detach(|| datasets::read_path(path, &opts))
        .map_err(data_err)?;
    loop_dict(py, &d)
}

fn loop_dict<'py>(py: Python<'py>, d: &LoopData) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    out.set_item("source", &d.source)?;
    out.set_item("start", d.start)?;
    out.set_item("t", series(py, &d.t))?;
    out.set_item("sp", series(py, &d.sp))?;
    out.set_item("pv", series(py, &d.pv))?;
    out.set_item("op", d.op.clone().into_pyarray(py))?;
    out.set_item("mv", series(py, &d.mv))?;
    let notes: Vec<String> = d.notes.iter().map(|n| n.to_string()).collect();
    out.set_item("notes", notes)?;
    Ok(out)
}

/// Run a registered stiction model over OP: `(mv, valid_from, fell_back)`.
#[pyfunction]
#[pyo3(signature = (op, model, params, init = "In.1"))]
fn valve<'py>(
    py: Python<'py>,
    op: PyReadonlyArray1<'py, f64>,
    model: &str,
    params: BTreeMap<String, f64>,
    init: &str,
) -> PyResult<(Bound<'py, PyArray1<f64>>, usize, bool)> {
    let entry = find_model(model).map_err(usage_err)?;
    let pairs: Vec<(String, f64)> = params.into_iter().collect();
    let built = entry.build_named(&pairs).map_err(usage_err)?;
    let init = Initialization::parse(init).ok_or_else(|| {
        usage_err(format!(
            "init={init:?}: expected \"In.1\", \"In.2\" or \"In.3\""
        ))
    })?;
    let op = op.as_slice()?.to_vec();
    let run = py
        .detach(|| run_valve(built.as_ref(), &op, &init))
        .map_err(data_err)?;
    Ok((run.mv.into_pyarray(py), run.valid_from, run.fell_back))
}

/// Simulate the closed loop described by a scenario (the JSON of `stiction simulate
/// --print-config`): `(columns, summary)`, columns `t`, `SP`, `PV`, `OP`, `MV` as numpy arrays
/// (the CSV the CLI writes) and the summary line it prints.
#[pyfunction]
fn simulate<'py>(py: Python<'py>, scenario_json: &str) -> PyResult<(Bound<'py, PyDict>, String)> {
    let sc = datasets::simulate::Scenario::from_json(scenario_json).map_err(usage_err)?;
    sc.validate().map_err(usage_err)?;
    let sim = py.detach(|| sc.simulate()).map_err(data_err)?;
    let summary = sim.summary(&sc);
    let out = PyDict::new(py);
    out.set_item("t", sim.t.into_pyarray(py))?;
    out.set_item("SP", sim.sp.into_pyarray(py))?;
    out.set_item("PV", sim.pv.into_pyarray(py))?;
    out.set_item("OP", sim.op.into_pyarray(py))?;
    out.set_item("MV", sim.mv.into_pyarray(py))?;
    Ok((out, summary))
}

/// One column of a frame on its way to the reader: numbers, or text (time stamps, a mode).
enum Column<'py> {
    Numbers(PyReadonlyArray1<'py, f64>),
    Text(Vec<Option<String>>),
}

impl<'py> FromPyObject<'_, 'py> for Column<'py> {
    type Error = PyErr;
    fn extract(ob: Borrowed<'_, 'py, PyAny>) -> PyResult<Self> {
        if let Ok(a) = ob.extract::<PyReadonlyArray1<'py, f64>>() {
            return Ok(Column::Numbers(a));
        }
        Ok(Column::Text(ob.extract()?))
    }
}

/// The CSV text of named columns (numbers written in their shortest round-trip form by ryu, NaN as
/// an empty cell, as pandas writes it): what `read_columns` reads, as a file would hold it (for
/// saving a frame the way the CLI would read it; the calls themselves no longer make it).
#[pyfunction]
fn csv_text(names: Vec<String>, columns: Vec<Column<'_>>) -> PyResult<String> {
    columns_text(&names, &columns)
}

fn columns_text(names: &[String], columns: &[Column<'_>]) -> PyResult<String> {
    if names.len() != columns.len() {
        return Err(usage_err(format!(
            "{} column names for {} columns",
            names.len(),
            columns.len()
        )));
    }
    let slices: Vec<Result<&[f64], &Vec<Option<String>>>> = columns
        .iter()
        .map(|c| match c {
            Column::Numbers(a) => a.as_slice().map_err(|e| usage_err(e.to_string())).map(Ok),
            Column::Text(t) => Ok(Err(t)),
        })
        .collect::<PyResult<_>>()?;
    let rows = slices
        .iter()
        .map(|c| match c {
            Ok(x) => x.len(),
            Err(t) => t.len(),
        })
        .max()
        .unwrap_or(0);
    if slices.iter().any(|c| match c {
        Ok(x) => x.len() != rows,
        Err(t) => t.len() != rows,
    }) {
        return Err(usage_err("the columns have different lengths"));
    }
    let mut buf = ryu::Buffer::new();
    let mut out = String::with_capacity((rows + 1) * names.len() * 20);
    for (j, name) in names.iter().enumerate() {
        if j > 0 {
            out.push(',');
        }
        push_text(&mut out, name);
    }
    out.push('\n');
    for k in 0..rows {
        for (j, c) in slices.iter().enumerate() {
            if j > 0 {
                out.push(',');
            }
            match c {
                Ok(x) if x[k].is_nan() => {}
                // finite or infinite: ryu's shortest round-trip form (`inf` for infinity,
                // which the reader refuses with its own message)
                Ok(x) if x[k].is_finite() => out.push_str(buf.format_finite(x[k])),
                Ok(x) => out.push_str(if x[k] > 0.0 { "inf" } else { "-inf" }),
                Err(t) => push_text(&mut out, t[k].as_deref().unwrap_or("")),
            }
        }
        out.push('\n');
    }
    Ok(out)
}

/// A CSV cell: quoted (quotes doubled) when it holds a separator, a quote or a line break.
fn push_text(out: &mut String, cell: &str) {
    if cell.contains([',', '"', '\n', '\r']) {
        out.push('"');
        out.push_str(&cell.replace('"', "\"\""));
        out.push('"');
    } else {
        out.push_str(cell);
    }
}

/// The default scenario (the paper's benchmark) as JSON.
#[pyfunction]
fn default_scenario() -> String {
    datasets::simulate::Scenario::default().to_json()
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("StictionError", py.get_type::<StictionError>())?;
    m.add("DataError", py.get_type::<DataError>())?;
    m.add("UsageError", py.get_type::<UsageError>())?;
    m.add_function(wrap_pyfunction!(read_csv, m)?)?;
    m.add_function(wrap_pyfunction!(read_path, m)?)?;
    m.add_function(wrap_pyfunction!(run_csv, m)?)?;
    m.add_function(wrap_pyfunction!(run_path, m)?)?;
    m.add_function(wrap_pyfunction!(run_columns, m)?)?;
    m.add_function(wrap_pyfunction!(read_columns, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::batch_options, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::batch_files, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::batch_resume, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::lock_output, m)?)?;
    m.add_class::<fleet::OutputLock>()?;
    m.add_function(wrap_pyfunction!(fleet::batch_file, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::batch_labels, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::batch_finish, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::trend, m)?)?;
    m.add_function(wrap_pyfunction!(valve, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(default_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(csv_text, m)?)?;
    m.add_function(wrap_pyfunction!(audit::audit_append, m)?)?;
    Ok(())
}
