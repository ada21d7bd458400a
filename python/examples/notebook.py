# %% [markdown]
# # A sticky valve, from a historian export to a maintenance decision
#
# Notebook-style (Jupyter, VS Code or plain `python notebook.py`). The registrations here are
# simulated so the example runs anywhere; with a historian client, build the same DataFrame
# (a time index and the columns SP, PV, OP) from its query.

# %%
import tempfile
from pathlib import Path

import pandas as pd

import stiction

# %% Four registrations of one valve a week apart, its stiction growing from 2 % to 3.5 %
folder = Path(tempfile.mkdtemp(prefix="stiction-example-"))
for k, s in enumerate([2.0, 2.5, 3.0, 3.5]):
    loop = stiction.simulate(valve={"kind": "kano", "S": s, "J": 0.5}, samples=1500, seed=k)
    start = pd.Timestamp("2024-05-01 10:00") + pd.Timedelta(days=7 * k)
    loop.index = pd.date_range(start, periods=len(loop), freq="1s", name="time")
    loop[["SP", "PV", "OP"]].to_csv(folder / f"FIC7_{start:%Y%m%d-%H%M}.csv")

# %% The latest registration, as a historian client would hand it over (a DatetimeIndex)
latest = pd.read_csv(sorted(folder.glob("*.csv"))[-1], index_col="time", parse_dates=True)
r = stiction.quantify(latest)
print(f"S = {r['S']} %, J = {r['J']} %, region S {r['interval']['S']}, F_PV val {r['fit_pv_val']:.1f} %")

# %% What else is going on in the loop?
d = stiction.diagnose(latest)
print(d["cause"], "-", d["summary"].split(". ")[0])

# %% The trend over the four registrations and the maintenance verdict
t = stiction.trend(folder)
print(t["verdict"], "-", t["reason"])
