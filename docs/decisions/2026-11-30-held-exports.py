"""Exports of records with a held PV: does any flip between `stiction` and `no-stiction`?

usage: python3 2026-11-30-held-exports.py STICTION_BIN OUT FILE...

Each FILE (a CSV record whose PV is held between updates, e.g. the independent simulator's
loops with PV held: docs/decisions/2026-11-29-independent-simulator.py) is judged whole and as
its first half, its second half, its even rows and its odd rows (written to OUT).
"""
import json, os, subprocess, sys

import pandas as pd

binary, out, files = sys.argv[1], sys.argv[2], sys.argv[3:]
os.makedirs(out, exist_ok=True)


def verdict(path):
    r = subprocess.run([binary, "detect", path, "--json"], capture_output=True, text=True)
    try:
        return json.loads(r.stdout)["verdict"]
    except (ValueError, KeyError):
        return "error"


flips = runs = errors = 0
for f in files:
    whole = verdict(f)
    df = pd.read_csv(f)
    n = len(df)
    name = os.path.basename(f)[:-4]
    exports = {"first": df.iloc[: n // 2], "second": df.iloc[n // 2 :], "even": df.iloc[::2], "odd": df.iloc[1::2]}
    for what, part in exports.items():
        path = os.path.join(out, f"{name}_{what}.csv")
        part.to_csv(path, index=False)
        v = verdict(path)
        runs += 1
        errors += v == "error"
        if {whole, v} == {"stiction", "no-stiction"}:
            flips += 1
            print("flip", name, what, whole, v)
print(f"runs {runs}, flips {flips}, errors {errors}")
