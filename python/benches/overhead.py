"""What a Python call adds to the search, on one loop, in one run.

    python python/benches/overhead.py [--samples 3000] [--step X] [--repeat 30]

Times, as medians over the repeats: `stiction.quantify(frame)`; the same from the CSV file;
the extension alone on the CSV text (reading + search + JSON, what the CLI does in process);
the search alone (`elapsed_ms` of the result); the Python side alone (the extension's call
stubbed). A frame is read in place (its columns go to the
reader's in-memory entry), so it can cost less than the CSV text the CLI has to parse.
The Python overhead is the frame call minus the extension alone, per interleaved round.
"""

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import stiction
from stiction import _data, _native


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=3000)
    ap.add_argument("--step", type=float, default=None)
    ap.add_argument("--repeat", type=int, default=30)
    a = ap.parse_args()
    loop = stiction.simulate(valve={"kind": "kano", "S": 9.0, "J": 3.0}, samples=a.samples, seed=1)
    df = loop[["t", "SP", "PV", "OP"]]
    path = Path(tempfile.mkdtemp()) / "loop.csv"
    df.to_csv(path, index=False)
    opts = {} if a.step is None else {"step": a.step}
    settings = json.dumps({"stiction": "kano", "linear": "arx", **opts})
    text = _data.csv_text(df)
    stiction.quantify(df, **opts)  # warm
    # Interleaved: each round times the three calls back to back, so a slow moment of the
    # machine (the search's threads jitter by milliseconds) hits all three alike; the
    # overhead is the median of the per-round differences.
    names, cols = _data.columns(df)
    native, frame, from_path, search, nodes = [], [], [], [], 0

    def timed(f):
        t0 = time.perf_counter()
        r = f()
        return (time.perf_counter() - t0) * 1e3, r

    for _ in range(a.repeat):
        t, r = timed(lambda: json.loads(_native.run_csv("quantify", text, "x", {}, settings)))
        native.append(t)
        search.append(r["elapsed_ms"])
        nodes = r["grid"]["nodes"]
        frame.append(timed(lambda: stiction.quantify(df, **opts))[0])
        from_path.append(timed(lambda: stiction.quantify(path, **opts))[0])
    med = statistics.median
    d_frame = med(f - n for f, n in zip(frame, native))
    d_path = med(p - n for p, n in zip(from_path, native))
    s_med = med(search)
    print(f"{a.samples} samples, kano + arx, {'step ' + str(a.step) if a.step else 'default grid plan'}, "
          f"{nodes} nodes, {a.repeat} interleaved rounds (medians)")
    print(f"search alone            {s_med:8.2f} ms")
    print(f"extension on CSV text   {med(native):8.2f} ms (reading + search + JSON, as the CLI in process)")
    print(f"quantify(path)          {med(from_path):8.2f} ms")
    print(f"quantify(DataFrame)     {med(frame):8.2f} ms")
    print(f"Python overhead: {d_frame:.2f} ms = {100 * d_frame / s_med:.1f} % of the search "
          f"(from a path: {d_path:.2f} ms = {100 * d_path / s_med:.1f} %)")
    # The same layer timed directly: the extension's call replaced by one that returns the
    # document at once, so what is left is the Python side (options, the frame's columns, the
    # JSON to dict), without the search's jitter in the difference.
    doc = _native.run_columns("quantify", names, cols, "x", {}, settings)
    real = _native.run_columns
    _native.run_columns = lambda *args: doc
    try:
        stubbed = []
        for _ in range(max(a.repeat, 200)):
            stubbed.append(timed(lambda: stiction.quantify(df, **opts))[0])
    finally:
        _native.run_columns = real
    t_stub = med(stubbed)
    print(f"the Python layer timed directly (the extension's call stubbed): {t_stub:.3f} ms = "
          f"{100 * t_stub / s_med:.1f} % of the search")

if __name__ == "__main__":
    main()
