//! The results history (`audit` crate) for `stiction.fleet.run(..., db=...)`: the driver
//! appends each file's rows as they arrive.

use pyo3::prelude::*;

use super::{data_err, usage_err};

/// Append one registration's rows (the JSON lines a fleet task returns, from
/// `monitoring::batch::run_file`) to the audit database `db` (created when missing), keyed by
/// the SHA-256 of the file at `path`; one transaction, `INSERT OR IGNORE`. Returns how many
/// rows were new. A line that is not a batch row is a [`UsageError`](super::UsageError); a
/// database that cannot be opened or written (or is newer than this package) a
/// [`DataError`](super::DataError).
#[pyfunction]
pub(crate) fn audit_append(
    py: Python<'_>,
    db: std::path::PathBuf,
    path: std::path::PathBuf,
    lines: Vec<String>,
) -> PyResult<usize> {
    let rows = lines
        .iter()
        .enumerate()
        .map(|(k, line)| {
            serde_json::from_str::<monitoring::batch::Row>(line)
                .map_err(|e| usage_err(format!("line {}: not a batch row: {e}", k + 1)))
        })
        .collect::<PyResult<Vec<_>>>()?;
    py.detach(|| {
        let hash = ::audit::content_hash(&path);
        let mut store = ::audit::Store::open(&db)?;
        store.append(&rows, &hash)
    })
    .map_err(|e| data_err(run::error_line(&e)))
}
