"""The Dask fleet gives the rows of `stiction batch` and resumes the same way."""

import json
from pathlib import Path

import pytest

import stiction
from stiction import fleet

pytest.importorskip("distributed")  # the whole module needs a Dask cluster

VOLATILE = {"elapsed_ms", "path"}


def strip(row):
    row = {k: v for k, v in row.items() if k not in VOLATILE}
    if isinstance(row.get("quantify"), dict):
        row["quantify"] = {k: v for k, v in row["quantify"].items() if k not in VOLATILE}
    return row


def rows(jsonl: Path):
    out = [strip(json.loads(line)) for line in jsonl.read_text().splitlines() if line.strip()]
    return sorted(out, key=lambda r: (r["file"], r.get("stiction_model") or "", r.get("linear_model") or ""))


@pytest.fixture(scope="module")
def loops(tmp_path_factory):
    d = tmp_path_factory.mktemp("fleet")
    for i in range(24):
        s = 1.0 + 0.25 * i
        df = stiction.simulate(valve={"kind": "kano", "S": s, "J": s / 3}, samples=500, seed=100 + i)
        df[["t", "SP", "PV", "OP"]].to_csv(d / f"FIC{i:03d}_20240101-{i:02d}00.csv", index=False)
    (d / "broken_20240101-0000.csv").write_text("t,SP,PV,OP\n0,1,2,x\n")
    return d


def test_fleet_rows_equal_the_batch_rows(loops, cluster, cli, tmp_path):
    cli("batch", str(loops), "-o", str(tmp_path / "cli"), "--step", "0.5",
        "--linear", "arx,armax")
    frame = fleet.run([loops], tmp_path / "py", client=cluster, step=0.5,
                      linear=["arx", "armax"], progress=False)
    expected = rows(tmp_path / "cli.jsonl")
    got = rows(tmp_path / "py.jsonl")
    assert len(got) == 25 * 2 - 1  # 24 loops x 2 combinations, the broken file's one error row
    assert got == expected
    assert (tmp_path / "py.csv").read_text().splitlines()[0] == (tmp_path / "cli.csv").read_text().splitlines()[0]
    assert len(frame) == len(got)
    assert frame.attrs["summary"]["errors"] == 1


def test_a_fleet_run_resumes_a_cli_run_and_recomputes_a_torn_line(loops, cluster, cli, tmp_path):
    out = tmp_path / "run"
    cli("batch", str(loops), "-o", str(out), "--step", "0.5")
    jsonl = Path(f"{out}.jsonl")
    lines = jsonl.read_text().splitlines()
    jsonl.write_text("\n".join(lines[:-1]) + "\n" + lines[-1][: len(lines[-1]) // 2])
    frame = fleet.run([loops], out, client=cluster, step=0.5, progress=False)
    s = frame.attrs["summary"]
    assert s["computed"] == 1 and s["skipped"] == 24, s
    assert rows(jsonl) == rows(jsonl)  # readable again
    assert len(rows(jsonl)) == 25


def test_fleet_options_are_checked_before_any_task(loops):
    with pytest.raises(stiction.UsageError, match="unknown option"):
        fleet.run([loops], stepp=1.0)
    with pytest.raises(stiction.UsageError, match="^orders "):
        fleet.options(orders="1,2,3,4,5")
    with pytest.raises(stiction.UsageError):
        fleet.options(stiction="nope")


def test_a_second_run_on_the_same_output_is_refused(loops, cluster, tmp_path):
    # the lock `stiction batch -o OUT` takes, held here as a running batch would hold it
    out = tmp_path / "busy"
    held = stiction._native.lock_output(f"{out}.jsonl")
    try:
        with pytest.raises(stiction.DataError, match="another batch run is writing this output"):
            fleet.run([loops], out, client=cluster, step=0.5, progress=False)
    finally:
        held.release()
    frame = fleet.run([loops], out, client=cluster, step=0.5, progress=False)
    assert len(frame) == 25
