"""The Dask fleet against `stiction batch` on the same generated loops, in one run.

    python python/benches/fleet.py [--loops 200] [--samples 3000] [--workers 2] [--bin PATH]

Generates the loops (kano valves, S from 1 to 8 %, the paper's plant, seeded), times
`stiction batch DIR -o OUT` (rayon over the cores) and `stiction.fleet.run(DIR, OUT2)` on a
LocalCluster of single-threaded worker processes, checks that the rows are the same and prints
both wall times, their ratio and the time per loop. The cluster's start-up is timed apart.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import stiction
from stiction import fleet


def rows(path):
    out = []
    for line in Path(path).read_text().splitlines():
        r = json.loads(line)
        r.pop("path", None)
        if isinstance(r.get("quantify"), dict):
            r["quantify"].pop("elapsed_ms", None)
        out.append(r)
    return sorted(out, key=lambda r: (r["file"], r.get("linear_model") or ""))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--loops", type=int, default=200)
    ap.add_argument("--samples", type=int, default=3000)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--bin", default=os.environ.get("STICTION_BIN", "target/release/stiction"))
    a = ap.parse_args()
    from distributed import Client, LocalCluster

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / "loops"
        d.mkdir()
        for i in range(a.loops):
            s = 1.0 + 7.0 * i / max(a.loops - 1, 1)
            df = stiction.simulate(valve={"kind": "kano", "S": s, "J": s / 3}, samples=a.samples, seed=i)
            df[["t", "SP", "PV", "OP"]].to_csv(d / f"FIC{i:04d}_20240101-0000.csv", index=False)
        t0 = time.perf_counter()
        subprocess.run([a.bin, "batch", str(d), "-o", f"{tmp}/cli"], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t_cli = time.perf_counter() - t0
        t0 = time.perf_counter()
        cluster = LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        client.run(lambda: __import__("stiction"))  # workers import the package once
        t_start = time.perf_counter() - t0
        t0 = time.perf_counter()
        fleet.run([d], f"{tmp}/py", client=client, progress=False)
        t_fleet = time.perf_counter() - t0
        client.close()
        cluster.close()
        same = rows(f"{tmp}/cli.jsonl") == rows(f"{tmp}/py.jsonl")
        print(f"{a.loops} loops x {a.samples} samples, kano + arx, {a.workers} workers")
        print(f"stiction batch: {t_cli:.2f} s ({1e3 * t_cli / a.loops:.1f} ms/loop)")
        print(f"fleet on Dask:  {t_fleet:.2f} s ({1e3 * t_fleet / a.loops:.1f} ms/loop), "
              f"cluster start {t_start:.2f} s")
        print(f"ratio fleet / batch: {t_fleet / t_cli:.2f}; same rows: {same}")
        sys.exit(0 if same else 1)


if __name__ == "__main__":
    main()
