"""Fleets of registrations on Dask: the rows of `stiction batch`, on one machine or a cluster.

The work is split as `stiction batch` splits it: one task per registration file, giving that
file's rows (one per stiction x linear combination; a file that cannot be read gives its error
row). The driver takes the output's lock (`OUT.jsonl.lock`, the one `stiction batch` takes: a
second run on the same output, from either, is refused), lists the files and skips those whose
rows are already in `OUT.jsonl` (same full path, content hash and settings: the library's resume
step, the one the CLI uses),
sends the rest to Dask's distributed scheduler, appends each file's rows to `OUT.jsonl` as they
arrive (an interrupted run resumes where it stopped, with this module or with the CLI) and
writes `OUT.csv` at the end as the CLI does. With `db=`, each file's rows also go to the audit
database (`stiction audit`'s SQLite results history, `stiction.audit.load` reads it) as they
arrive.

Each task runs the Rust search with the interpreter released; the default `LocalCluster` has
one single-threaded worker process per core. Under another engine the same per-file function
applies: `stiction.fleet.rows_of_file(path, options)` (docs/FLEET.md shows Spark's
`mapInPandas` and Ray).

Example:
    >>> from stiction import fleet
    >>> rows = fleet.run(["../shared/data/plant"], out="plant")          # doctest: +SKIP
    >>> rows = fleet.run(["loops/"], scheduler="tcp://10.0.0.5:8786")   # doctest: +SKIP
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional, Sequence, Union

import pandas as pd

from . import _data, _native

PathLike = Union[str, "os.PathLike[str]"]

#: Batch settings besides the search options and the reader's (the flags of `stiction batch`).
BATCH_OPTIONS = ("stiction", "linear", "integrating", "min_fit")
SEARCH_OPTIONS = ("orders", "delay", "step", "init", "criterion", "split", "max_nodes", "max_work")


def options(
    *,
    stiction: Union[str, Sequence[str]] = "kano",
    linear: Union[str, Sequence[str]] = "arx",
    **kwargs: Any,
) -> str:
    """The batch options as the JSON each task gets, from the names of `stiction batch`'s flags:
    `stiction`, `linear` (a name or a list), `integrating` ("auto", "yes", "no"), `min_fit`, the
    search options (`orders`, `delay`, `step`, `init`, `criterion`, `split`, `max_nodes`, `max_work`) and the
    reader's (`pv`, `op`, ..., `gaps`, `op_range`). Checked by the library: an unknown name or a
    value that cannot work raises `UsageError` here, before any task is sent."""
    reader = {k: v for k, v in kwargs.items() if k in _data.READ_OPTIONS}
    rest = {k: v for k, v in kwargs.items() if k not in _data.READ_OPTIONS and v is not None}
    unknown = sorted(set(rest) - set(BATCH_OPTIONS) - set(SEARCH_OPTIONS))
    if unknown:
        raise _native.UsageError(
            f"unknown option(s) {unknown}; batch options are {', '.join(BATCH_OPTIONS + SEARCH_OPTIONS)} "
            f"and the reader's {', '.join(_data.READ_OPTIONS)}"
        )
    as_list = lambda v: [v] if isinstance(v, str) else list(v)  # noqa: E731
    rest.update(stiction=as_list(stiction), linear=as_list(linear))
    from . import _json

    return _native.batch_options(_json(rest), _data.options(reader))


def rows_of_file(path: PathLike, options_json: str, label: Optional[str] = None) -> List[Dict[str, Any]]:
    """One registration's rows as dicts (one per combination; a refused file gives its error
    row). Never raises for bad data. `options_json` comes from `options(...)`."""
    return [json.loads(line) for line in _native.batch_file(str(path), options_json, label)]


def lines_of_file(path: PathLike, options_json: str, label: Optional[str] = None) -> List[str]:
    """One registration's rows as the JSON lines of OUT.jsonl: what each task runs (here on
    Dask, or under Spark or Ray, docs/FLEET.md)."""
    return _native.batch_file(str(path), options_json, label)


def _task(path: str, label: Optional[str], options_json: str) -> List[str]:
    # runs on a worker; JSON lines travel back (small, and exactly what goes into OUT.jsonl)
    return lines_of_file(path, options_json, label)


def run(
    paths: Union[PathLike, Iterable[PathLike]],
    out: Optional[PathLike] = None,
    *,
    valve: Optional[str] = None,
    labels: Optional[PathLike] = None,
    scheduler: Optional[str] = None,
    client: Any = None,
    n_workers: Optional[int] = None,
    progress: bool = True,
    db: Optional[PathLike] = None,
    **batch_options: Any,
) -> pd.DataFrame:
    """`stiction batch` on Dask: the rows (the columns of OUT.csv) as a DataFrame.

    `paths`: directories or files of registrations (a manifest is a list of files). `out`: the output prefix (writes
    OUT.jsonl and OUT.csv, and resumes from them); without it the files go to a temporary
    directory. `valve`: only that valve's registrations. `labels`: a CSV `file,label` whose
    labels fill the rows (the summary then has the ROC AUC of S). `client`: a
    `distributed.Client`; else `scheduler`: a scheduler address ("tcp://host:8786"); else a
    `LocalCluster` of `n_workers` single-threaded worker processes (default: one per core) is
    started and closed. `db`: an audit database (SQLite, created when missing) to which the
    driver appends each file's rows as they arrive, one transaction per file, each row once
    (rows already there are left as they are); the rows an earlier run left in OUT.jsonl are
    appended too. Other keyword arguments are the batch options (see `options`).

    The summary (rows, ok, errors, and with labels the AUC) is in the frame's `attrs`. A run on
    an output another run (this module's or `stiction batch`) is writing raises `DataError`.
    """
    import distributed  # noqa: F401  (the fleet needs it: fail before taking the lock)

    if _data.is_path(paths):
        paths = [paths]
    opts = options(**batch_options)
    tmp = None
    if out is None:
        tmp = tempfile.TemporaryDirectory(prefix="stiction-fleet-")
        out = Path(tmp.name) / "rows"
    jsonl, csv = Path(f"{out}.jsonl"), Path(f"{out}.csv")
    exclude = [str(jsonl), str(csv)] + ([str(labels)] if labels is not None else [])
    exclude += [str(db)] if db is not None else []
    files, notes = _native.batch_files([str(p) for p in paths], exclude, opts, valve)
    for note in notes:
        sys.stderr.write(f"note: {note}\n")
    label_of = _native.batch_labels(str(labels)) if labels is not None else {}
    lock = _native.lock_output(str(jsonl))
    try:
        return _run_locked(files, opts, jsonl, csv, db, label_of, client, scheduler, n_workers,
                           progress, tmp)
    finally:
        lock.release()


def _run_locked(files, opts, jsonl, csv, db, label_of, client, scheduler, n_workers, progress, tmp):
    """`run` while it holds the output's lock."""
    from distributed import Client, LocalCluster, as_completed

    todo, kept, torn = _native.batch_resume(files, opts, str(jsonl))
    if db is not None and kept:
        _append_kept(db, jsonl, set(todo))
    if torn:
        sys.stderr.write(
            f"note: {jsonl}: {len(torn)} torn line(s) (first: line {torn[0]}): computed again\n"
        )
    own_cluster = None
    own_client = False
    if client is None:
        if scheduler is not None:
            client = Client(scheduler)
        else:
            own_cluster = LocalCluster(
                n_workers=n_workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
            )
            client = Client(own_cluster)
        own_client = True
    started = time.monotonic()
    try:
        futures = client.map(
            _task,
            todo,
            [label_of.get(Path(f).name) for f in todo],
            options_json=opts,
            pure=False,
        )
        path_of = {fut.key: path for fut, path in zip(futures, todo)}
        with open(jsonl, "a", encoding="utf-8") as sink:
            for done, fut in enumerate(as_completed(futures), start=1):
                lines = fut.result()
                sink.write("".join(line + "\n" for line in lines))
                sink.flush()
                if db is not None:
                    _native.audit_append(str(db), path_of[fut.key], lines)
                if progress:
                    _progress(done, len(todo), started)
    finally:
        if own_client:
            client.close()
        if own_cluster is not None:
            own_cluster.close()
    if progress and todo and sys.stderr.isatty():
        sys.stderr.write("\n")
    summary = _native.batch_finish(str(jsonl), str(csv), opts)
    summary.update(files=len(files), computed=len(todo), skipped=len(files) - len(todo))
    frame = pd.read_csv(csv)
    frame.attrs["summary"] = summary
    if tmp is not None:
        tmp.cleanup()
    return frame


def _append_kept(db: PathLike, jsonl: Path, todo: set) -> None:
    """Append to the audit database the rows OUT.jsonl keeps from an earlier run (after the
    resume step it holds only rows of these settings), one transaction per file."""
    by_path: Dict[str, List[str]] = {}
    with open(jsonl, encoding="utf-8") as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            path = json.loads(line).get("path")
            if path is not None and path not in todo:
                by_path.setdefault(path, []).append(line)
    for path, lines in by_path.items():
        _native.audit_append(str(db), path, lines)


def _progress(done: int, total: int, started: float) -> None:
    elapsed = time.monotonic() - started
    rate = done / elapsed if elapsed > 0 else 0.0
    left = (total - done) / rate if rate > 0 else 0.0
    text = f"fleet {done}/{total} registrations, {elapsed:.0f} s, ~{left:.0f} s left"
    if sys.stderr.isatty():
        sys.stderr.write(f"\r{text} ")
    elif done == total or done % max(1, total // 10) == 0:
        # a log file gets a line per tenth of the run, no carriage returns
        sys.stderr.write(text + "\n")
    sys.stderr.flush()
