"""`stiction.audit.load` reads what `stiction audit` writes; `fleet.run(..., db=...)` appends
the same rows, each once."""

import sqlite3
from pathlib import Path

import pytest

import stiction
from stiction import audit

COLUMNS = [
    "content_hash", "valve", "start_time", "file", "path", "settings", "stiction_model",
    "linear_model", "status", "S", "S_lo", "S_hi", "J", "J_lo", "J_hi", "fit_pv_val",
    "fit_no_stiction", "integrating", "label", "detect_score", "detect_verdict", "why", "notes",
    "error", "reduction", "error_std_now", "error_std_repaired", "reversals_per_hour_now",
    "reversals_per_hour_repaired", "repair_reason", "repair", "quantify", "audited_at",
    "S_from", "S_unit", "S_one_step", "S_one_step_lo", "S_one_step_hi", "detect_reason",
]
KEY = ["file", "stiction_model", "linear_model"]
SAME = KEY + ["content_hash", "valve", "start_time", "settings", "status", "S", "S_lo", "S_hi",
              "J", "J_lo", "J_hi", "detect_verdict", "why", "error", "S_from", "S_one_step",
              "detect_reason"]
FLAGS = ("--step", "1", "--stiction", "kano,he")


@pytest.fixture(scope="module")
def loops(tmp_path_factory):
    d = tmp_path_factory.mktemp("audit")
    for i in range(5):
        s = 1.0 + i
        df = stiction.simulate(valve={"kind": "kano", "S": s, "J": s / 3}, samples=500, seed=200 + i)
        df[["t", "SP", "PV", "OP"]].to_csv(d / f"FIC{i % 2:03d}_2024010{i + 1}-0800.csv", index=False)
    (d / "broken_20240101-0000.csv").write_text("t,SP,PV,OP\n0,1,2,x\n")
    return d


@pytest.fixture
def audited(loops, cli, tmp_path):
    """The CLI's audit database of the loops (2 combinations)."""
    db = tmp_path / "audit.sqlite"
    out = cli("audit", str(loops), "--db", str(db), *FLAGS)
    assert out.startswith("audit: 6 registration(s): 6 computed, 0 already in audit.sqlite; 12 row(s)"), out
    return db


def test_load_reads_every_row_in_order(audited):
    before = audited.read_bytes()
    frame = audit.load(audited)
    assert list(frame.columns) == COLUMNS
    assert len(frame) == 6 * 2
    assert (frame.status == "error").sum() == 2  # the broken file, once per combination
    broken = frame[frame.file == "broken_20240101-0000.csv"]
    assert sorted(broken.stiction_model) == ["he", "kano"]
    assert broken.error.str.len().min() > 0
    ok = frame[frame.status == "ok"]
    assert ok.S.notna().all() and ok.quantify.notna().all()
    order = frame[["valve", "start_time", "stiction_model", "linear_model"]].values.tolist()
    assert order == sorted(order)
    assert set(frame.valve) == {"FIC000", "FIC001", "broken"}
    assert audited.read_bytes() == before  # read-only


def execute(db, statement):
    """Run one SQL statement on the SQLite file `db` and commit it."""
    con = sqlite3.connect(db)
    con.execute(statement)
    con.commit()
    con.close()


def test_load_refuses_what_is_not_an_audit_database(audited, loops, tmp_path):
    with pytest.raises(ValueError, match="not a stiction audit database"):
        audit.load(loops / "FIC000_20240101-0800.csv")
    other = tmp_path / "other.sqlite"
    execute(other, "CREATE TABLE results (x INTEGER)")
    with pytest.raises(ValueError, match="not a stiction audit database"):
        audit.load(other)
    newer = tmp_path / "newer.sqlite"
    newer.write_bytes(audited.read_bytes())
    execute(newer, "PRAGMA user_version = 3")
    with pytest.raises(ValueError, match="schema version 3 is newer"):
        audit.load(newer)
    with pytest.raises(FileNotFoundError):
        audit.load(tmp_path / "missing.sqlite")


def test_fleet_appends_the_rows_the_cli_audits(loops, audited, cluster, tmp_path):
    db = tmp_path / "fleet.sqlite"
    frame = fleet_run(loops, tmp_path / "rows", cluster, db)
    assert len(frame) == 6 * 2 - 1  # OUT.csv: the broken file's one error row
    got = audit.load(db)
    want = audit.load(audited)
    assert len(got) == len(want) == 12
    key = lambda f: f[SAME].sort_values(KEY).reset_index(drop=True)  # noqa: E731
    assert key(got).equals(key(want))

    # Into the CLI's database: every row is there already.
    fleet_run(loops, tmp_path / "again", cluster, audited)
    assert len(audit.load(audited)) == 12

    # A resumed run (nothing to compute) still fills a new database from OUT.jsonl.
    fresh = tmp_path / "fresh.sqlite"
    frame = fleet_run(loops, tmp_path / "rows", cluster, fresh)
    assert frame.attrs["summary"]["computed"] == 0
    assert key(audit.load(fresh)).equals(key(want))


def fleet_run(loops, out, client, db):
    from stiction import fleet

    return fleet.run([loops], out, client=client, step=1.0, stiction=["kano", "he"],
                     db=db, progress=False)
