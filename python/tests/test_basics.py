"""Reading, the valve and the simulator through the Python package, against the CLI."""

import numpy as np
import pandas as pd
import pytest

import stiction


def test_simulate_matches_the_cli_csv(tmp_path, cli):
    df = stiction.simulate(valve={"kind": "kano", "S": 4.0, "J": 1.0}, samples=800, seed=3)
    assert list(df.columns) == ["t", "SP", "PV", "OP", "MV"]
    assert len(df) == 800
    out = tmp_path / "sim.csv"
    cli("simulate", "--valve", "kano", "--param", "S=4", "--param", "J=1",
        "--samples", "800", "--seed", "3", "-o", str(out))
    expected = pd.read_csv(out)
    np.testing.assert_array_equal(df.to_numpy(), expected.to_numpy())
    assert "valve kano (S = 4, J = 1)" in df.attrs["summary"]


def test_valve_reproduces_the_simulated_position():
    df = stiction.simulate(valve={"kind": "kano", "S": 6.0, "J": 2.0}, samples=600)
    mv, valid_from = stiction.valve(df["OP"].to_numpy(), "kano", {"S": 6.0, "J": 2.0})
    assert valid_from == 0
    np.testing.assert_array_equal(mv, df["MV"].to_numpy())
    # a different valve gives a different position: the comparison above can fail
    other, _ = stiction.valve(df["OP"].to_numpy(), "kano", {"S": 3.0, "J": 2.0})
    assert np.abs(other - df["MV"].to_numpy()).max() > 0.1


def test_read_a_dataframe_like_the_file(tmp_path):
    df = stiction.simulate(samples=300)
    path = tmp_path / "loop.csv"
    df[["t", "SP", "PV", "OP"]].to_csv(path, index=False)
    from_frame = stiction.read(df[["t", "SP", "PV", "OP"]])
    from_file = stiction.read(path)
    for key in ("t", "sp", "pv", "op"):
        np.testing.assert_array_equal(from_frame[key], from_file[key])
    assert from_frame["mv"] is None
    assert from_file["source"] == str(path)


def test_a_datetime_index_becomes_the_time_column():
    idx = pd.date_range("2024-12-06 21:55", periods=50, freq="10s", name="time")
    df = pd.DataFrame({"OP": np.linspace(40, 60, 50), "PV": np.linspace(1, 2, 50) ** 2}, index=idx)
    r = stiction.read(df)
    np.testing.assert_allclose(r["t"], np.arange(50) * 10.0)
    assert r["start"] == pd.Timestamp("2024-12-06 21:55", tz="UTC").timestamp()


def test_op_as_a_fraction_is_rescaled_with_a_note():
    r = stiction.read({"OP": [0.2, 0.4, 0.5, 0.3, 0.35], "PV": [1.0, 2.0, 2.5, 1.5, 1.7]})
    np.testing.assert_allclose(r["op"], [20, 40, 50, 30, 35])
    assert any("0-1" in n or "fraction" in n for n in r["notes"]), r["notes"]


def test_bad_input_raises_the_cli_message():
    with pytest.raises(stiction.DataError) as e:
        stiction.read({"OP": [1.0, 2.0, float("nan"), 3.0], "PV": [1.0, 2.0, 3.0, 4.0]})
    assert "row 4, column OP" in str(e.value)
    assert "\n" not in str(e.value)
    with pytest.raises(stiction.DataError, match="No such file|cannot|not found"):
        stiction.read("does-not-exist.csv")
    with pytest.raises(stiction.UsageError, match="registered models"):
        stiction.valve([1.0, 2.0, 3.0], "nope")
    with pytest.raises(stiction.UsageError, match="unknown option"):
        stiction.read({"OP": [1.0, 2.0, 3.0], "PV": [1.0, 2.0, 3.0]}, column_op="x")
    with pytest.raises(stiction.UsageError, match="unknown scenario key"):
        stiction.simulate(nosie_sigma=0.1)
    # the errors are also ValueError-free StictionErrors: one base to catch
    assert issubclass(stiction.DataError, stiction.StictionError)


def test_frame_text_is_exact_and_quoted():
    from stiction import _data

    rng = np.random.default_rng(1)
    x = rng.normal(size=2000) * 10.0 ** rng.integers(-30, 30, size=2000)
    text = _data.csv_text({"a,b": x, "mode": ["AUTO"] * 1999 + ['M"AN']})
    back = pd.read_csv(__import__("io").StringIO(text))
    assert list(back.columns) == ["a,b", "mode"]
    np.testing.assert_array_equal(back["a,b"].to_numpy(), x)
    assert back["mode"].iloc[-1] == 'M"AN'
    gap = _data.csv_text({"OP": [1.0, float("nan")]})
    assert gap.splitlines()[2] == ""


def test_a_frame_reads_as_its_csv_text():
    """The in-place reader and the CSV reader agree on a frame (time index, text mode, gaps)."""
    from stiction import _data, _native

    rng = np.random.default_rng(7)
    n = 500
    df = pd.DataFrame(
        {
            "PV": 50 + rng.normal(size=n).cumsum(),
            "OP": 0.5 + 0.01 * rng.normal(size=n).cumsum(),  # a fraction: rescaled with a note
            "mode": ["MAN"] * 20 + ["AUTO"] * (n - 20),
        },
        index=pd.date_range("2024-05-01", periods=n, freq="5s", name="time"),
    )
    df.iloc[100, 0] = np.nan
    for opts in ({"gaps": "hold"}, {"gaps": "drop"}, {}):
        try:
            a = stiction.read(df, **opts)
        except stiction.DataError as e:
            a = str(e)
        try:
            b = _native.read_csv(_data.csv_text(df), "DataFrame", _data.options(opts), True)
        except stiction.DataError as e:
            b = str(e)
        if isinstance(a, str):
            assert a == b
            continue
        assert a["notes"] == b["notes"] and a["start"] == b["start"]
        for k in ("t", "pv", "op"):
            np.testing.assert_array_equal(a[k], b[k])


def test_dir_lists_the_public_names_only():
    import stiction

    names = dir(stiction)
    for public in ("quantify", "diagnose", "fleet", "audit", "DataError"):
        assert public in names
    for private in ("np", "pd", "json", "Any", "Dict"):
        assert private not in names
