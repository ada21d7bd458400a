"""Write the small MATLAB v5 fixtures read by datasets/tests/mat.rs.

Run once (needs numpy and scipy, e.g. in a venv); the .mat files are committed, so the tests
need no Python:

    python3 datasets/scripts/make_mat_fixtures.py

* loop_flat.mat: top-level vectors OP, PV, SP (60 samples) and a scalar Ts = 10, as a user
  who saved a loop's fields with save('-struct') writes them. The values are closed-form
  (below) so the test checks them exactly.
* loop_struct.mat: the International Stiction Database's layout, cdata.chemicals.loop1 with
  fields OP, PV, SP, Ts. The matfile crate skips structs: the test checks the clear error.
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
print("wrote", out)
