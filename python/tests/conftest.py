"""Shared helpers: the CLI binary the Python results are compared with."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def binary() -> str:
    """The `stiction` binary: $STICTION_BIN, else the workspace's release or test build."""
    env = os.environ.get("STICTION_BIN")
    if env:
        return env
    for profile in ("release", "debug"):
        p = ROOT / "target" / profile / "stiction"
        if p.exists():
            return str(p)
    found = shutil.which("stiction")
    if found:
        return found
    pytest.skip("no stiction binary: build it with `cargo build --release -p stiction-cli` or set STICTION_BIN")


def run_cli(*args: str) -> str:
    """Run the CLI; its standard output (fails the test on a non-zero exit)."""
    r = subprocess.run([binary(), *args], capture_output=True, text=True)
    assert r.returncode == 0, f"stiction {' '.join(args)}: {r.stderr}"
    return r.stdout


@pytest.fixture
def cli():
    """`cli(*args)`: the CLI's standard output."""
    return run_cli


@pytest.fixture
def cli_json():
    """`cli_json(*args)`: the CLI's `--json` document."""
    return lambda *args: json.loads(run_cli(*args, "--json"))


@pytest.fixture(scope="session")
def stiction_bin():
    """The path of the `stiction` binary the tests run."""
    return binary()


@pytest.fixture(scope="module")
def cluster():
    """A local Dask cluster of two one-thread worker processes (skips without distributed)."""
    distributed = pytest.importorskip("distributed")
    c = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                 dashboard_address=None)
    client = distributed.Client(c)
    yield client
    client.close()
    c.close()
