//! Batches and fleets (`stiction.fleet`): the library's batch, one file per task, its resume
//! step and output lock, the trend of one valve.

use std::collections::BTreeMap;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use monitoring::MonitoringError;

use super::{data_err, integrating, interruptible, names, read_args, search_settings, usage_err};

/// The batch options of a settings JSON (`stiction`, `linear`, `integrating`, `min_fit` and
/// the [`run::SearchArgs`]) and the reader's options, as the JSON a worker gets
/// (`monitoring::batch::BatchOptions`); what cannot work is a [`UsageError`] here.
#[pyfunction]
#[pyo3(signature = (settings_json, reader = None))]
pub(crate) fn batch_options(
    settings_json: &str,
    reader: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    use monitoring::batch::{BatchOptions, DEFAULT_MIN_FIT, MIN_ROWS};
    let mut v: serde_json::Map<String, serde_json::Value> =
        serde_json::from_str(settings_json).map_err(usage_err)?;
    let stiction = names(v.remove("stiction"), "stiction", "kano")?;
    let linear = names(v.remove("linear"), "linear", "arx")?;
    let integrating = integrating(v.remove("integrating"))?;
    let min_fit = match v.remove("min_fit") {
        None => DEFAULT_MIN_FIT,
        Some(x) => x
            .as_f64()
            .filter(|f| f.is_finite())
            .ok_or_else(|| usage_err(format!("min_fit: expected a number, got {x}")))?,
    };
    let (_, settings) = search_settings(v, &stiction, &linear)?;
    let opts = BatchOptions {
        stiction,
        linear,
        settings,
        read: read_args(reader)?.options(true, MIN_ROWS)?,
        integrating,
        min_fit,
    };
    serde_json::to_string(&opts).map_err(usage_err)
}

fn batch_opts(opts_json: &str) -> PyResult<monitoring::batch::BatchOptions> {
    serde_json::from_str(opts_json).map_err(usage_err)
}

/// The registration files under `paths` as `stiction batch` finds them (a folder's files with
/// an OP column, sorted; `exclude` left out; only valve `valve` when given): `(files, notes)`,
/// the notes saying which files were skipped as not being loops.
#[pyfunction]
#[pyo3(signature = (paths, exclude, opts_json, valve = None))]
pub(crate) fn batch_files(
    paths: Vec<std::path::PathBuf>,
    exclude: Vec<std::path::PathBuf>,
    opts_json: &str,
    valve: Option<&str>,
) -> PyResult<(Vec<String>, Vec<String>)> {
    let opts = batch_opts(opts_json)?;
    let op = opts.read.op.clone().unwrap_or_else(|| "OP".into());
    let (mut files, skipped) =
        monitoring::registration::expand(&paths, &exclude, &op).map_err(usage_err)?;
    if let Some(v) = valve {
        files.retain(|f| {
            datasets::parse_registration_name(&monitoring::kind::file_name(f)).valve == v
        });
    }
    Ok((
        files.iter().map(|f| f.display().to_string()).collect(),
        skipped
            .iter()
            .map(|n| format!("skipped {}: {n}", n.path.display()))
            .collect(),
    ))
}

/// The resume step (`monitoring::batch::resume`): rewrites `jsonl` with the rows it keeps;
/// `(files to do, rows kept, torn line numbers)`.
#[pyfunction]
#[pyo3(signature = (files, opts_json, jsonl = None))]
pub(crate) fn batch_resume(
    py: Python<'_>,
    files: Vec<std::path::PathBuf>,
    opts_json: &str,
    jsonl: Option<std::path::PathBuf>,
) -> PyResult<(Vec<String>, usize, Vec<usize>)> {
    let opts = batch_opts(opts_json)?;
    let r = py
        .detach(|| monitoring::batch::resume(&files, &opts, jsonl.as_deref()))
        .map_err(data_err)?;
    Ok((
        r.todo.iter().map(|f| f.display().to_string()).collect(),
        r.kept.len(),
        r.torn,
    ))
}

/// The lock of a batch output (`monitoring::batch::lock_output`): held until `release()` or
/// until the object is dropped (the process's end releases it too).
#[pyclass(module = "stiction._native")]
pub(crate) struct OutputLock {
    file: Option<std::fs::File>,
}

#[pymethods]
impl OutputLock {
    /// Release the lock (idempotent).
    fn release(&mut self) {
        self.file = None;
    }
}

/// Hold the lock of the batch output `jsonl` (`OUT.jsonl.lock`, the one `stiction batch`
/// takes): a second run on the same output raises `DataError` naming it.
#[pyfunction]
pub(crate) fn lock_output(jsonl: std::path::PathBuf) -> PyResult<OutputLock> {
    let file = monitoring::batch::lock_output(&jsonl).map_err(data_err)?;
    Ok(OutputLock { file: Some(file) })
}

/// One file's rows as JSON lines (`monitoring::batch::run_file`, then the file's label): what
/// each task of a fleet runs. Never raises for bad data: the error is in the rows.
#[pyfunction]
#[pyo3(signature = (path, opts_json, label = None))]
pub(crate) fn batch_file(
    py: Python<'_>,
    path: std::path::PathBuf,
    opts_json: &str,
    label: Option<&str>,
) -> PyResult<Vec<String>> {
    let opts = batch_opts(opts_json)?;
    let label: Option<monitoring::batch::Label> = match label {
        None => None,
        Some(l) => Some(
            serde_json::from_value(serde_json::json!(l))
                .map_err(|_| usage_err(format!("label {l:?}: expected stiction or no-stiction")))?,
        ),
    };
    let rows = py.detach(|| monitoring::batch::run_file(&path, &opts));
    Ok(rows
        .into_iter()
        .map(|mut r| {
            r.label = label;
            r.to_json_line()
        })
        .collect())
}

/// The `trend --json` document of one valve over registration files under `paths`.
#[pyfunction]
#[pyo3(signature = (paths, settings_json, reader = None, valve = None))]
pub(crate) fn trend(
    py: Python<'_>,
    paths: Vec<std::path::PathBuf>,
    settings_json: &str,
    reader: Option<&Bound<'_, PyDict>>,
    valve: Option<&str>,
) -> PyResult<String> {
    use monitoring::trend::TrendOptions;
    let mut v: serde_json::Map<String, serde_json::Value> =
        serde_json::from_str(settings_json).map_err(usage_err)?;
    let number = |v: Option<serde_json::Value>, key: &str, default: f64| -> PyResult<f64> {
        match v {
            None => Ok(default),
            Some(x) => x
                .as_f64()
                .filter(|f| f.is_finite() && *f >= 0.0)
                .ok_or_else(|| {
                    usage_err(format!("{key}: expected a non-negative number, got {x}"))
                }),
        }
    };
    let defaults = TrendOptions::default();
    let threshold = number(v.remove("threshold"), "threshold", defaults.threshold)?;
    let horizon = number(v.remove("horizon"), "horizon", defaults.horizon)?;
    let diagnose = v
        .remove("diagnose")
        .map(|x| {
            x.as_bool()
                .ok_or_else(|| usage_err("diagnose: expected True or False"))
        })
        .transpose()?
        .unwrap_or(true);
    let opts_json = batch_options(&serde_json::Value::Object(v).to_string(), reader)?;
    let run = batch_opts(&opts_json)?;
    let op = run.read.op.clone().unwrap_or_else(|| "OP".into());
    let options = TrendOptions {
        run,
        threshold,
        horizon,
    };
    interruptible(py, || {
        let (files, _skipped) =
            monitoring::registration::expand(&paths, &[], &op).map_err(usage_err)?;
        let (valve, files) = monitoring::trend::select(files, valve).map_err(|e| match e {
            MonitoringError::SeveralValves(_) => usage_err(e.to_string()),
            other => data_err(other.to_string()),
        })?;
        let vt = monitoring::trend::follow(&valve, &files, &options, diagnose, None)
            .map_err(usage_err)?;
        serde_json::to_string(&vt.record()).map_err(data_err)
    })
}

/// `file -> "stiction" | "no-stiction"` from a labels CSV (columns `file`, `label`).
#[pyfunction]
pub(crate) fn batch_labels(path: std::path::PathBuf) -> PyResult<BTreeMap<String, String>> {
    let labels = monitoring::batch::Labels::read(&path).map_err(data_err)?;
    Ok(labels
        .0
        .into_iter()
        .map(|(k, v)| {
            let l = match v {
                monitoring::batch::Label::Stiction => "stiction",
                monitoring::batch::Label::NoStiction => "no-stiction",
            };
            (k, l.to_string())
        })
        .collect())
}

/// The end of a batch: reads `jsonl`, writes `csv` (the rows sorted, as the CLI writes
/// OUT.csv) and returns a summary dict: `rows`, `ok`, `errors`, and with labels `labelled`,
/// `labelled_stiction`, `auc`, `threshold` (of S, first combination), `detect_scored`,
/// `detect_auc` (of the detector's score over the same rows).
#[pyfunction]
pub(crate) fn batch_finish<'py>(
    py: Python<'py>,
    jsonl: std::path::PathBuf,
    csv: std::path::PathBuf,
    opts_json: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let opts = batch_opts(opts_json)?;
    let (mut rows, _torn) = monitoring::batch::read_jsonl(&jsonl).map_err(data_err)?;
    rows.retain(|r| r.settings == opts.fingerprint());
    rows.sort_by(|a, b| (&a.file, a.combination()).cmp(&(&b.file, b.combination())));
    monitoring::batch::write_csv(&csv, &rows).map_err(data_err)?;
    let out = PyDict::new(py);
    let ok = rows.iter().filter(|r| r.is_ok()).count();
    out.set_item("rows", rows.len())?;
    out.set_item("ok", ok)?;
    out.set_item("errors", rows.len() - ok)?;
    if rows.iter().any(|r| r.label.is_some()) {
        let sum = monitoring::batch::label_summary(&rows, &opts.stiction[0], &opts.linear[0]);
        out.set_item("labelled", sum.rows)?;
        out.set_item("labelled_stiction", sum.stiction)?;
        out.set_item("auc", sum.roc.map(|r| r.auc))?;
        out.set_item("threshold", sum.roc.map(|r| r.threshold))?;
        let det =
            monitoring::batch::detect_label_summary(&rows, &opts.stiction[0], &opts.linear[0]);
        out.set_item("detect_scored", det.rows)?;
        out.set_item("detect_auc", det.roc.map(|r| r.auc))?;
    }
    Ok(out)
}
