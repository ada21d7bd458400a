"""Turning what Python users hold (DataFrames, dicts of arrays, files) into what the reader reads.

A frame reaches the Rust side as named columns (float64 arrays, or text for time stamps and
modes) and is read by the reader's in-memory entry (`datasets::read_columns`), which applies the
CSV reader's conventions to the columns as they are: the column names, OP units detection, gap
handling, notes and error messages are those of a file given to `stiction quantify`, and a test
on the Rust side checks the two entries agree on the same data.
"""

from __future__ import annotations

import os
from typing import Any, Mapping, Optional

import numpy as np
import pandas as pd

#: The reader's options, with the CLI's flag names.
READ_OPTIONS = ("pv", "op", "sp", "mv", "time", "mode", "gaps", "op_range", "max_rows", "window")


def frame(data: Any) -> pd.DataFrame:
    """A DataFrame from a DataFrame, a dict of columns, or a structured numpy array.

    A DatetimeIndex (or any named index) becomes a column, so the time stamps a historian
    client puts in the index reach the reader as its `time` column.
    """
    if isinstance(data, pd.DataFrame):
        df = data
    elif isinstance(data, Mapping):
        df = pd.DataFrame({k: np.asarray(v) for k, v in data.items() if v is not None})
    elif isinstance(data, np.ndarray) and data.dtype.names:
        df = pd.DataFrame(data)
    else:
        raise TypeError(
            "expected a pandas DataFrame, a dict of columns (e.g. {'OP': op, 'PV': pv}) "
            f"or a structured numpy array, got {type(data).__name__}"
        )
    index = df.index
    if isinstance(index, pd.DatetimeIndex) or index.name is not None:
        name = index.name if index.name is not None else "time"
        if isinstance(index, pd.DatetimeIndex):
            if index.tz is not None:
                index = index.tz_convert("UTC").tz_localize(None)
            values = index.strftime("%Y-%m-%dT%H:%M:%S.%f")
        else:
            values = index
        df = df.reset_index(drop=True)
        df.insert(0, str(name), values)
    return df


def csv_text(data: Any) -> str:
    """The CSV text the reader gets for `data` (see `columns`)."""
    from . import _native

    return _native.csv_text(*columns(data))


def columns(data: Any):
    """`(names, columns)` of `data` for the extension: numeric columns as float64 arrays, which
    it writes in their shortest exact form (NaN as an empty cell, as pandas writes it); other
    columns (time stamps, a controller mode) as text."""
    df = frame(data)
    names, cols = [], []
    for name, col in df.items():
        names.append(str(name))
        kind = getattr(col.dtype, "kind", None)
        if kind == "c" or (kind == "O" and any(isinstance(v, complex) for v in col.tolist())):
            raise TypeError(
                f"column {name!r}: complex numbers are not supported (dtype {col.dtype}); "
                f"pass the real part (e.g. df[{str(name)!r}].real) if that is what was meant"
            )
        if isinstance(col.dtype, np.dtype) and kind in "fiu":
            # plain numpy numbers: NaN is already NaN (the fast path, no masking)
            cols.append(np.ascontiguousarray(col.to_numpy(dtype=np.float64)))
        elif pd.api.types.is_bool_dtype(col.dtype):
            cols.append(col.map(lambda v: "" if pd.isna(v) else str(int(v))).tolist())
        elif pd.api.types.is_numeric_dtype(col.dtype):
            # nullable extension numbers (Float64, Int64): missing values become NaN
            cols.append(np.ascontiguousarray(col.to_numpy(dtype=np.float64, na_value=np.nan)))
        else:
            cols.append([None if pd.isna(v) else str(v) for v in col.tolist()])
    return names, cols


def options(kwargs: Mapping[str, Any]) -> dict:
    """The reader's options (None values dropped); an unknown name is an error, so a misspelt
    option is never ignored."""
    from ._native import UsageError

    unknown = sorted(set(kwargs) - set(READ_OPTIONS))
    if unknown:
        raise UsageError(
            f"unknown option(s) {unknown}; the reader's are {', '.join(READ_OPTIONS)}"
        )
    out = {k: v for k, v in kwargs.items() if v is not None}
    for key, value in out.items():
        if key in ("pv", "op", "sp", "mv", "time", "mode") and not isinstance(value, str):
            raise UsageError(f"{key}={value!r}: expected a column name (text)")
        if key == "gaps" and value not in ("refuse", "hold", "drop"):
            raise UsageError(f"gaps={value!r}: expected one of 'refuse', 'hold', 'drop'")
        if key in ("max_rows", "window") and (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1):
            raise UsageError(f"{key}={value!r}: expected a whole number >= 1")
        if key == "op_range":
            ok = isinstance(value, (tuple, list)) and len(value) == 2
            if ok:
                try:
                    lo, hi = float(value[0]), float(value[1])
                    ok = bool(np.isfinite(lo) and np.isfinite(hi) and lo < hi)
                except (TypeError, ValueError):
                    ok = False
            if not ok:
                raise UsageError(f"op_range={value!r}: expected (lo, hi), finite numbers with lo < hi (closed and fully open valve in OP's units)")
    return out


def is_path(data: Any) -> bool:
    return isinstance(data, (str, os.PathLike))


def source_name(data: Any, source: Optional[str]) -> str:
    if source is not None:
        return source
    if isinstance(data, pd.DataFrame):
        return "DataFrame"
    return "data"
