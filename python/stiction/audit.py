"""The results history of `stiction audit`: an SQLite database with one row per registration
and stiction x linear combination (docs/CLI.md lists the columns of its table `results`).

`load(path)` reads it, read-only, into a DataFrame. The database is written by the CLI
(`stiction audit DIR --db FILE`) or by `stiction.fleet.run(..., db=FILE)`, never by this module.

Example:
    >>> from stiction import audit
    >>> rows = audit.load("audit.sqlite")                                  # doctest: +SKIP
    >>> rows[rows.status == "ok"].groupby("valve").S.last()                # doctest: +SKIP
"""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path
from typing import Union

import pandas as pd

PathLike = Union[str, "os.PathLike[str]"]

#: `PRAGMA application_id` of an audit database (the `audit` crate's APPLICATION_ID, "STIC").
APPLICATION_ID = 0x53544943
#: The newest schema version (`PRAGMA user_version`) this module reads.
SCHEMA_VERSION = 2

_QUERY = "SELECT * FROM results ORDER BY valve, start_time, stiction_model, linear_model"


def load(path: PathLike) -> pd.DataFrame:
    """Every row of the audit database at `path`, ordered by valve, start time and combination.

    The file is opened read-only (an SQLite `mode=ro` URI): loading never changes it, and a
    run writing to it at the same time is not disturbed. `why`, `notes`, `repair` and
    `quantify` are JSON text (`json.loads` them when needed); numbers that could not be
    computed are NaN. `S` is the registration's one answer, the S that explains the
    detector's verdict (`S_from`: `one-step` or `output-error`; `S_one_step` the combination's
    own fit beside it); a database of schema version 1 must be opened once by `stiction audit`
    (which migrates it) before this module reads it.

    Raises FileNotFoundError when there is no such file, ValueError when the file is not a
    stiction audit database (not SQLite, another application's database) or was written by a
    newer version of stiction.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    uri = p.resolve().as_uri() + "?mode=ro"
    try:
        con = sqlite3.connect(uri, uri=True)
    except sqlite3.Error as e:
        raise ValueError(f"{path}: cannot open it read-only ({e})") from e
    try:
        try:
            app = con.execute("PRAGMA application_id").fetchone()[0]
            version = con.execute("PRAGMA user_version").fetchone()[0]
        except sqlite3.DatabaseError as e:
            raise ValueError(f"{path}: not a stiction audit database ({e})") from e
        if app != APPLICATION_ID:
            raise ValueError(
                f"{path}: not a stiction audit database (application id {app:#x}, "
                f"expected {APPLICATION_ID:#x})"
            )
        if version > SCHEMA_VERSION:
            raise ValueError(
                f"{path}: audit database schema version {version} is newer than this "
                f"package's ({SCHEMA_VERSION}): use a newer stiction"
            )
        return pd.read_sql_query(_QUERY, con)
    finally:
        con.close()
