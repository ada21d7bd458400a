"""stiction: how sticky is a control valve, from the data the plant already logs.

The functions take what historian clients and notebooks hold — a pandas DataFrame with the
reader's column names (`SP`, `PV`, `OP`, optionally `MV` and a time column `t`/`time`, any
case; a DatetimeIndex becomes the time column), or a dict of numpy arrays — and return plain
dicts with the keys of the CLI's JSON output (docs/CLI.md). The computation runs in Rust with
the interpreter released. Errors are exceptions carrying the CLI's one-line messages:
`DataError` for refused data, `UsageError` for options that cannot work; both derive from
`StictionError`.

Example:
    >>> import stiction
    >>> loop = stiction.simulate(valve={"kind": "kano", "S": 4.0, "J": 1.0}, samples=1500)
    >>> r = stiction.quantify(loop[["t", "SP", "PV", "OP"]])
    >>> round(r["S"], 1), round(r["J"], 1)   # doctest: +SKIP
    (4.0, 1.0)
"""

from __future__ import annotations

import json
from typing import Any, Dict, Mapping, Optional, Tuple

import numpy as np
import pandas as pd

from . import _data
from ._native import DataError, StictionError, UsageError
from . import _native

__all__ = [
    "DataError",
    "StictionError",
    "UsageError",
    "compare",
    "detect",
    "diagnose",
    "identify",
    "quantify",
    "quantify_file",
    "read",
    "simulate",
    "trend",
    "valve",
]

#: Search options, with the names of the CLI's flags (`stiction quantify --help`).
SEARCH_OPTIONS = ("orders", "delay", "step", "init", "criterion", "split", "max_nodes", "max_work")


def _number(key: str, value: Any, *, above: Optional[float] = None, at_least: Optional[float] = None,
            below: Optional[float] = None, at_most: Optional[float] = None, whole: bool = False) -> None:
    """Check one numeric keyword: a real number (an int when `whole`), finite, in range; the
    UsageError names the keyword and what it takes."""
    kind = "a whole number" if whole else "a finite number"
    bounds = []
    if above is not None:
        bounds.append(f"> {above:g}")
    if at_least is not None:
        bounds.append(f">= {at_least:g}")
    if below is not None:
        bounds.append(f"< {below:g}")
    if at_most is not None:
        bounds.append(f"<= {at_most:g}")
    wanted = kind + (" " + " and ".join(bounds) if bounds else "")
    if isinstance(value, bool) or isinstance(value, complex) or np.iscomplexobj(value):
        raise UsageError(f"{key}={value!r}: expected {wanted}")
    if whole and not isinstance(value, (int, np.integer)):
        raise UsageError(f"{key}={value!r}: expected {wanted}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{key}={value!r}: expected {wanted}") from None
    if not np.isfinite(v) or (above is not None and not v > above) or (
        at_least is not None and not v >= at_least) or (below is not None and not v < below) or (
        at_most is not None and not v <= at_most):
        raise UsageError(f"{key}={value!r}: expected {wanted}")


def _choice(key: str, value: Any, allowed: Tuple[str, ...]) -> None:
    if not isinstance(value, str) or value not in allowed:
        raise UsageError(f"{key}={value!r}: expected one of {', '.join(repr(a) for a in allowed)}")


def _check_options(options: Dict[str, Any]) -> Dict[str, Any]:
    """Check the search and run keywords before they cross to the library, so that an error
    names the keyword and the values it takes (not a JSON parser's position or a CLI flag)."""
    out = dict(options)
    for key, value in options.items():
        if key == "orders":
            if isinstance(value, (list, tuple)):
                for v in value:
                    _number("orders", v, at_least=0, whole=True)
                out[key] = ",".join(str(int(v)) for v in value)
            elif not isinstance(value, str):
                raise UsageError(f"orders={value!r}: expected text such as \"2,2\" or \"n=2,m=2\", or a list of whole numbers")
        elif key == "delay":
            if not (isinstance(value, str) and value == "auto"):
                if isinstance(value, str):
                    raise UsageError(f"delay={value!r}: expected a whole number of samples >= 0 or \"auto\"")
                _number("delay", value, at_least=0, whole=True)
        elif key == "step":
            _number("step", value, above=0)
        elif key == "init":
            _choice("init", value, ("In.1", "In.2", "In.3"))
        elif key == "criterion":
            _choice("criterion", value, ("prediction", "simulation"))
        elif key == "split":
            _number("split", value, above=0, below=1)
        elif key == "max_nodes":
            _number("max_nodes", value, at_least=1, whole=True)
        elif key == "max_work":
            _number("max_work", value, above=0)
        elif key in ("threshold",):
            _number(key, value, at_least=0)
        elif key == "horizon":
            _number(key, value, above=0)
        elif key == "min_fit":
            _number(key, value, at_most=100)
        elif key == "integrating":
            if value not in ("auto", "yes", "no"):
                raise UsageError(f"integrating={value!r}: expected one of 'auto', 'yes', 'no'")
        elif key in ("stiction", "linear", "without"):
            names = value if isinstance(value, (list, tuple)) else [value]
            for n in names:
                if not isinstance(n, str):
                    raise UsageError(f"{key}={value!r}: expected a model name or a list of names (see stiction.models())")
    return out


def _json(settings: Dict[str, Any]) -> str:
    return json.dumps(_check_options(settings), allow_nan=False)


def _split(kwargs: Dict[str, Any], allowed: Tuple[str, ...]) -> Tuple[dict, dict]:
    """Separate the reader's options from the command's; anything else is a UsageError."""
    reader = {k: v for k, v in kwargs.items() if k in _data.READ_OPTIONS}
    command = {k: v for k, v in kwargs.items() if k in allowed and v is not None}
    unknown = sorted(set(kwargs) - set(reader) - set(allowed))
    if unknown:
        raise UsageError(
            f"unknown option(s) {unknown}; this function takes {', '.join(allowed)} "
            f"and the reader's {', '.join(_data.READ_OPTIONS)}"
        )
    return _data.options(reader), command


def _run(command: str, data: Any, source: Optional[str], allowed: Tuple[str, ...], kwargs) -> Dict[str, Any]:
    reader, settings = _split(kwargs, allowed)
    if _data.is_path(data):
        doc = _native.run_path(command, str(data), reader, _json(settings))
    else:
        names, columns = _data.columns(data)
        doc = _native.run_columns(
            command, names, columns, _data.source_name(data, source), reader, _json(settings)
        )
    return json.loads(doc)


def quantify(
    data: Any,
    *,
    stiction: str = "kano",
    linear: str = "arx",
    source: Optional[str] = None,
    **options: Any,
) -> Dict[str, Any]:
    """Quantify stiction in one registration (the CLI's `stiction quantify --json`).

    `data`: a DataFrame or dict of columns (`OP`, `PV`, optionally `SP`, `MV`, time) or a
    path. `stiction`: a registered stiction model (kano, he, kano-asym, or one a plugin
    registered); `linear`: an identifier (arx, armax, earx, earmax, harx, larx, ss). Search
    options, as the CLI's flags: `orders` ("2,2" or "n=2,m=2"), `delay` (samples or
    "auto"), `step` (grid step, % of span), `init` ("In.1", "In.2", "In.3"), `criterion`
    ("prediction", "simulation"), `split` (identification fraction), `max_nodes`, `max_work`
    (work budget per grid stage); `integrating` ("auto", "yes", "no": whether the loop is
    identified from MV to ΔPV, decided as every command decides it); and the reader's options.

    Returns the quantify document: `S`, `J` (% of valve span), `interval`, `fit_pv_val`,
    `warnings`, `answer` (the record's one verdict and the S that explains it), ...
    (docs/CLI.md lists every key).

    >>> r = stiction.quantify(pd.read_csv("loop.csv"))                   # doctest: +SKIP
    >>> r["S"], r["J"], r["interval"]["S"]                               # doctest: +SKIP
    """
    options.update(stiction=stiction, linear=linear)
    return _run("quantify", data, source, ("stiction", "linear", "integrating") + SEARCH_OPTIONS, options)


def quantify_file(path: Any, **options: Any) -> Dict[str, Any]:
    """`quantify` on a file (CSV or MATLAB .mat, read by the library as the CLI reads it)."""
    if not _data.is_path(path):
        raise UsageError(f"quantify_file: expected a path, got {type(path).__name__}")
    return quantify(path, **options)


def compare(
    data: Any,
    *,
    stiction: Any = ("kano", "he"),
    linear: Any = ("arx", "armax", "earx", "earmax", "ss"),
    source: Optional[str] = None,
    **options: Any,
) -> Dict[str, Any]:
    """Every stiction x linear combination on one registration (`stiction compare --json`):
    `results` (quantify documents) and `errors`. Same options as `quantify`."""
    options.update(stiction=_names(stiction), linear=_names(linear))
    return _run("compare", data, source, ("stiction", "linear", "integrating") + SEARCH_OPTIONS, options)


def detect(data: Any, *, source: Optional[str] = None, **options: Any) -> Dict[str, Any]:
    """Is it the valve? The published detection tests and one verdict (`stiction detect
    --json`): `score` (0-1), `verdict` (stiction / no-stiction / inconclusive), `reason`,
    `oscillating`, `period_s`, `integrating`, `integrating_by`, `tests` ({name, statistic,
    verdict, evidence}), `answer` (the verdict and the S that explains it). `integrating`
    ("auto", "yes", "no") as for every command: "auto" decides from the record (whether PV's
    rate or level follows OP), the valve tag's letter L (from `source` or the file name)
    breaking a tie. Other options are the reader's.

    >>> stiction.detect(pd.read_csv("loop.csv"))["verdict"]               # doctest: +SKIP
    """
    return _run("detect", data, source, ("integrating",), options)


def diagnose(
    data: Any,
    *,
    stiction: str = "kano",
    linear: str = "arx",
    without: Any = None,
    source: Optional[str] = None,
    **options: Any,
) -> Dict[str, Any]:
    """What the Hammerstein model gets wrong and why (`stiction diagnose --json`): `cause`,
    `causes`, `findings`, `extended` (the final model: refitted after a change of the process,
    and with the orders n, m raised by one when that gains; `orders` says which),
    `gain_fit_pv_val`, `summary` (the actionable sentence first), `residuals`. `without` leaves causes out (names as `stiction models` lists them). Search
    options as for `quantify`; the dead time must be a number (the diagnosis tests it).

    >>> d = stiction.diagnose(pd.read_csv("loop.csv"))                  # doctest: +SKIP
    >>> d["cause"], d["summary"][0]                                     # doctest: +SKIP
    """
    options.update(stiction=stiction, linear=linear)
    if without is not None:
        options["without"] = _names(without)
    return _run(
        "diagnose", data, source, ("stiction", "linear", "without", "integrating") + SEARCH_OPTIONS, options
    )


def identify(
    data: Any,
    *,
    linear: str = "arx",
    source: Optional[str] = None,
    **options: Any,
) -> Dict[str, Any]:
    """Identify the linear model from MV (when logged, else OP) to PV (`stiction identify
    --json`): `model`, `poles`, `stable`, `static_gain`, fits. Options: `orders`, `delay`
    (samples), `split`.

    >>> m = stiction.identify(pd.read_csv("loop.csv"), linear="armax", orders="2,2,2")  # doctest: +SKIP
    """
    options.update(linear=linear)
    return _run("identify", data, source, ("linear", "orders", "delay", "split"), options)


def trend(
    paths: Any,
    *,
    valve: Optional[str] = None,
    stiction: Any = "kano",
    linear: Any = "arx",
    threshold: Optional[float] = None,
    horizon: Optional[float] = None,
    diagnose: bool = True,
    **options: Any,
) -> Dict[str, Any]:
    """One valve over repeated registrations (`stiction trend --json`): `verdict`, `reason`,
    `level`, `latest`, `slope_per_30_days`, `registrations`, ... `paths`: a directory, a file
    or a list of them (registration files named `<valve>_YYYYMMDD-HHMM`); `valve` is needed
    when they hold several valves. `threshold` (S, %) and `horizon` (days) of the maintenance
    rule; `causes` says which causes the registrations' diagnoses agree on; `diagnose=False`
    skips the diagnoses (then `causes` is None). Other options: the
    search options, `integrating`, `min_fit` and the reader's.

    >>> t = stiction.trend("../shared/data/plant", valve="2411FIC20102")  # doctest: +SKIP
    >>> t["verdict"], t["level"]                                          # doctest: +SKIP
    """
    if _data.is_path(paths):
        paths = [paths]
    reader, settings = _split(options, ("integrating", "min_fit") + SEARCH_OPTIONS)
    settings.update(stiction=_names(stiction), linear=_names(linear), diagnose=bool(diagnose))
    if threshold is not None:
        settings["threshold"] = threshold
    if horizon is not None:
        settings["horizon"] = horizon
    return json.loads(_native.trend([str(p) for p in paths], _json(settings), reader, valve))


def _names(v: Any) -> list:
    return [v] if isinstance(v, str) else list(v)


def read(
    data: Any,
    *,
    source: Optional[str] = None,
    require_pv: bool = True,
    **reader: Any,
) -> Dict[str, Any]:
    """Read a registration as the CLI does, and say what the reader did.

    `data` is a DataFrame, a dict of columns or a path (CSV). Reader options, with the CLI's
    flag names: `pv`, `op`, `sp`, `mv`, `time` (column names), `mode` (controller-mode column),
    `gaps` ("refuse", "hold", "drop"), `op_range` ((lo, hi) in OP's units), `max_rows`,
    `window` (the most rows analysed: the latest of a longer record, default 50 000).

    Returns a dict: `t`, `sp`, `pv`, `op`, `mv` (numpy arrays, or None when absent), `start`
    (seconds since the epoch, or None), `source`, `notes` (list of sentences).

    >>> r = stiction.read({"OP": [0.2, 0.4, 0.5, 0.3], "PV": [1.0, 2.0, 2.5, 1.5]})
    >>> r["op"]            # rescaled from a 0-1 span to % # doctest: +SKIP
    array([20., 40., 50., 30.])
    """
    if _data.is_path(data):
        return _native.read_path(str(data), _data.options(reader), require_pv)
    names, columns = _data.columns(data)
    return _native.read_columns(
        names, columns, _data.source_name(data, source), _data.options(reader), require_pv
    )


def valve(
    op: Any,
    model: str = "kano",
    params: Optional[Mapping[str, float]] = None,
    init: str = "In.1",
) -> Tuple[np.ndarray, int]:
    """Run a registered stiction model over OP: `(mv, valid_from)`.

    `params` in OP's units, e.g. `{"S": 4, "J": 1}` for kano, `{"fs": 2.5, "fd": 1.5}` for he,
    `{"D": 3, "J_up": 0.5, "J_dn": 2}` for kano-asym; missing ones are 0. `init` is the paper's
    initialization "In.1" (valve at rest at OP(0)), "In.2" or "In.3"; `valid_from` is the first
    sample whose MV does not depend on the valve's unknown initial state (0 for In.1).

    >>> mv, k0 = stiction.valve(np.array([50, 52, 55, 53, 50.0]), "kano", {"S": 4, "J": 1})
    """
    if np.iscomplexobj(op):
        raise TypeError("op: complex numbers are not supported; pass the real part (op.real) if that is what was meant")
    arr = np.ascontiguousarray(np.asarray(op, dtype=np.float64))
    if arr.ndim != 1:
        raise UsageError(f"op: expected a 1-D series, got shape {arr.shape}")
    mv, valid_from, _fell_back = _native.valve(arr, model, dict(params or {}), init)
    return mv, valid_from


def simulate(config: Optional[Mapping[str, Any]] = None, **overrides: Any) -> pd.DataFrame:
    """Simulate a closed loop with a sticky valve (the CLI's `stiction simulate`).

    `config` is a scenario (the JSON of `stiction simulate --print-config`, as a dict or a JSON
    string); keyword arguments override its top-level keys, e.g.
    `valve={"kind": "kano", "S": 9, "J": 3}`, `noise_sigma=0.05`, `samples=3000`, `seed=7`,
    `plant="slow"`, `controller={"kc": 0.5, "ki": 0.5}`. Defaults: the paper's benchmark.

    Returns a DataFrame with the columns of the CLI's CSV: `t`, `SP`, `PV`, `OP`, `MV`; its
    `attrs["summary"]` is the line the CLI prints.

    >>> loop = stiction.simulate(valve={"kind": "kano", "S": 9, "J": 3}, seed=7)
    """
    scenario = json.loads(_native.default_scenario())
    if isinstance(config, str):
        config = json.loads(config)
    if config is not None:
        scenario.update(config)
    unknown = set(overrides) - set(scenario)
    if unknown:
        raise UsageError(
            f"unknown scenario key(s) {sorted(unknown)}; known: {sorted(scenario)}"
        )
    scenario.update(overrides)
    columns, summary = _native.simulate(json.dumps(scenario))
    df = pd.DataFrame(columns, columns=["t", "SP", "PV", "OP", "MV"])
    df.attrs["summary"] = summary
    return df


def __dir__() -> list:
    """What `dir(stiction)` lists: the public functions, errors and submodules, not the
    modules this one imports for itself (`json`, `np`, `pd`, `typing`'s names)."""
    return sorted(__all__ + ["SEARCH_OPTIONS", "audit", "fleet"])
