"""Write the small MATLAB v5 fixtures read by datasets/tests/mat.rs.

Run once (needs numpy and scipy, e.g. in a venv); the .mat files are committed, so the tests
need no Python:

    python3 datasets/scripts/make_mat_fixtures.py

* loop_flat.mat: top-level vectors OP, PV, SP (60 samples) and a scalar Ts = 10, as a user
  who saved a loop's fields with save('-struct') writes them. The values are closed-form
  (below) so the test checks them exactly.
* loop_struct.mat: the International Stiction Database's layout with one loop,
  cdata.chemicals.loop1 with fields OP, PV, SP, Ts (compressed).
* loop_isdb.mat / loop_isdb_z.mat: the same layout with two loops, cdata.chemicals.loop1
  and cdata.chemicals.loop2 (50 samples each, fields OP, PV, SP, Ts), uncompressed and
  compressed (miCOMPRESSED elements). loop1's values are closed-form in sin/cos of k, loop2
  stores OP as int16 and PV as single to exercise the storage-type conversions.
"""
import os

import numpy as np
from scipy.io import savemat

here = os.path.dirname(os.path.abspath(__file__))
out = os.path.join(here, "..", "tests", "fixtures")
os.makedirs(out, exist_ok=True)

k = np.arange(60, dtype=float)
op = 50.0 + 2.0 * np.sin(2 * np.pi * k / 20.0)
pv = 10.0 + np.round(op - 50.0)  # a sticky-looking staircase
sp = np.full(60, 10.0)
flat = {"OP": op.reshape(-1, 1), "PV": pv.reshape(-1, 1), "SP": sp.reshape(-1, 1), "Ts": 10.0}
savemat(os.path.join(out, "loop_flat.mat"), flat, format="5", do_compression=False)

loop = {"OP": op.reshape(-1, 1), "PV": pv.reshape(-1, 1), "SP": sp.reshape(-1, 1), "Ts": 10.0}
savemat(
    os.path.join(out, "loop_struct.mat"),
    {"cdata": {"chemicals": {"loop1": loop}}},
    format="5",
    do_compression=True,
)

# Two loops, 50 samples each.
k = np.arange(50, dtype=float)
loop1 = {
    "OP": (50.0 + 3.0 * np.sin(k)).reshape(-1, 1),  # OP[k] = 50 + 3 sin(k)
    "PV": (20.0 + np.cos(k)).reshape(-1, 1),  # PV[k] = 20 + cos(k)
    "SP": np.full((50, 1), 20.0),
    "Ts": 1.0,
}
loop2 = {
    "OP": (40 + (np.arange(50) % 7)).astype(np.int16).reshape(-1, 1),  # OP[k] = 40 + k mod 7
    "PV": (5.0 + 0.5 * np.sin(0.3 * k)).astype(np.float32).reshape(1, -1),  # row vector
    "SP": np.full((50, 1), 5.0),
    "Ts": 2.5,
}
isdb = {"cdata": {"chemicals": {"loop1": loop1, "loop2": loop2}}}
savemat(os.path.join(out, "loop_isdb.mat"), isdb, format="5", do_compression=False)
savemat(os.path.join(out, "loop_isdb_z.mat"), isdb, format="5", do_compression=True)
print("wrote", out)
