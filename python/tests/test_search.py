"""quantify and compare through the Python package give the CLI's documents."""

import numpy as np
import pandas as pd
import pytest

import stiction

# keys whose values depend on the run, not on the data
VOLATILE = {"elapsed_ms"}


def same_document(a, b, path=""):
    """Equal JSON documents, numbers to 1e-9 relative, ignoring wall times."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), f"{path}: keys {set(a) ^ set(b)}"
        for k in a:
            if k not in VOLATILE:
                same_document(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            same_document(x, y, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert a == pytest.approx(b, rel=1e-9, abs=1e-12), f"{path}: {a} vs {b}"
    else:
        assert a == b, f"{path}: {a!r} vs {b!r}"


@pytest.fixture(scope="module")
def loop_csv(tmp_path_factory):
    df = stiction.simulate(valve={"kind": "kano", "S": 4.0, "J": 1.0}, samples=900, seed=5)
    path = tmp_path_factory.mktemp("loops") / "loop.csv"
    df[["t", "SP", "PV", "OP"]].to_csv(path, index=False)
    return path


def test_quantify_a_read_csv_frame_equals_the_cli(loop_csv, cli_json):
    # a grid step of 0.25 % keeps the CLI's test build quick; the default plan is the same code
    expected = cli_json("quantify", str(loop_csv), "--step", "0.25")
    got = stiction.quantify(pd.read_csv(loop_csv), source=str(loop_csv), step=0.25)
    assert abs(got["S"] - expected["S"]) <= 1e-9 and abs(got["J"] - expected["J"]) <= 1e-9
    same_document(got, expected)
    # the truth is found, so the comparison above compares real numbers
    assert got["S"] == pytest.approx(4.0, abs=0.3)


def test_quantify_file_and_options_equal_the_cli(loop_csv, cli_json):
    expected = cli_json("quantify", str(loop_csv), "--stiction", "he", "--linear", "armax",
                        "--orders", "2,2,1", "--step", "0.5", "--init", "In.2")
    got = stiction.quantify_file(loop_csv, stiction="he", linear="armax", orders="2,2,1",
                                 step=0.5, init="In.2")
    same_document(got, expected)


def test_compare_equals_the_cli(loop_csv, cli_json):
    expected = cli_json("compare", str(loop_csv), "--stiction", "kano,he",
                        "--linear", "arx,ss", "--step", "0.5")
    got = stiction.compare(loop_csv, stiction=["kano", "he"], linear=["arx", "ss"], step=0.5)
    same_document(got, expected)
    assert len(got["results"]) == 4


def test_search_errors_name_the_keywords(loop_csv):
    with pytest.raises(stiction.UsageError, match=r"^orders \"2,2,2,2,2\": arx takes at most 2"):
        stiction.quantify(loop_csv, orders="2,2,2,2,2")
    with pytest.raises(stiction.UsageError, match="unknown option"):
        stiction.quantify(loop_csv, stepp=0.1)
    with pytest.raises(stiction.UsageError, match="node budget|nodes"):
        stiction.quantify(loop_csv, step=0.01, max_nodes=1000)
    flat = {"OP": np.full(200, 50.0), "PV": np.linspace(0, 1, 200)}
    with pytest.raises(stiction.DataError):
        stiction.quantify(flat)


def test_diagnose_equals_the_cli(loop_csv, cli_json):
    expected = cli_json("diagnose", str(loop_csv), "--step", "0.5")
    got = stiction.diagnose(loop_csv, step=0.5)
    same_document(got, expected)
    assert got["cause"] == expected["cause"]


def test_diagnose_refuses_an_estimated_dead_time(loop_csv):
    with pytest.raises(stiction.UsageError, match="^delay auto: diagnose tests the dead time itself"):
        stiction.diagnose(loop_csv, delay="auto")
    with pytest.raises(stiction.UsageError, match="unknown cause"):
        stiction.diagnose(loop_csv, step=0.5, without=["gremlins"])


def test_identify_equals_the_cli(loop_csv, cli_json):
    expected = cli_json("identify", str(loop_csv), "--linear", "armax", "--orders", "2,2,1",
                        "--delay", "1")
    got = stiction.identify(pd.read_csv(loop_csv), source=str(loop_csv), linear="armax",
                            orders="2,2,1", delay=1)
    same_document(got, expected)


def test_trend_equals_the_cli(tmp_path, cli_json):
    for k, (s, day) in enumerate([(2.0, 1), (2.5, 9), (3.0, 17), (3.5, 25)]):
        df = stiction.simulate(valve={"kind": "kano", "S": s, "J": 0.5}, samples=600, seed=k)
        df[["t", "SP", "PV", "OP"]].to_csv(tmp_path / f"FIC7_202405{day:02d}-1000.csv", index=False)
    expected = cli_json("trend", str(tmp_path), "--step", "0.25")
    got = stiction.trend(tmp_path, step=0.25)
    same_document(got, expected)
    assert got["registrations"] == 4 and len(got["combinations"][0]["registrations"]) == 4
    with pytest.raises(stiction.DataError, match="no registration of valve"):
        stiction.trend(tmp_path, valve="LIC1", step=0.25)


def test_detect_equals_the_cli(loop_csv, cli_json):
    expected = cli_json("detect", str(loop_csv))
    got = stiction.detect(pd.read_csv(loop_csv), source=str(loop_csv))
    same_document(got, expected)
    assert got["verdict"] in ("stiction", "no-stiction", "inconclusive")
    assert len(got["tests"]) >= 5
