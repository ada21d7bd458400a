"""Verdict flips between `stiction` and `no-stiction` under exports the parts' rule does not cover.

Every second row from the second, every third row, the means of each two rows from the second
and (records with regular time stamps) the record interpolated to half its interval and
resampled (linear interpolation) to 0.75, 1.5 and 2.5 times its interval, each
judged by `stiction detect --json` against the whole record's verdict; on the labelled plant
registrations of ../shared/data/plant and the simulated loops of
`cargo xtask detect-calibrate --no-plant --dump DUMP_DIR`. Needs numpy and pandas, and a
release build (`cargo build --release`).
Usage: python3 2026-11-30-exports.py DUMP_DIR [STICTION_BIN]   (scratch files go to DUMP_DIR/exports)
"""
import glob, json, os, subprocess, sys
import numpy as np, pandas as pd
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..')
DUMP = sys.argv[1]
B = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, 'target', 'release', 'stiction')
SCRATCH = os.path.join(DUMP, 'exports')
os.makedirs(SCRATCH, exist_ok=True)
def verdict(path):
    r = subprocess.run([B, 'detect', path, '--json'], capture_output=True, text=True)
    if r.returncode != 0:
        return 'error'
    return json.loads(r.stdout)['verdict']
plant = sorted(glob.glob(os.path.join(ROOT, '..', 'shared', 'data', 'plant', '*.csv')))
lab = pd.read_csv(os.path.join(ROOT, '..', 'shared', 'data', 'plant', 'labels.csv'))
labelled = set(lab[lab.label.isin(['stiction', 'no-stiction'])].file)
plant = [p for p in plant if os.path.basename(p) in labelled]
sims = sorted(glob.glob(os.path.join(DUMP, 'sim-*.csv')))
def tcol(df):
    for c in df.columns:
        if c.lower() in ('t', 'time', 'timestamp'):
            return c
    return None
def variants(df):
    out = {}
    out['every second from the second'] = df.iloc[1::2]
    out['every third'] = df.iloc[::3]
    num = df.select_dtypes('number').columns
    d2 = df.iloc[1:].reset_index(drop=True)
    m = len(d2) // 2 * 2
    g = d2.iloc[:m].copy()
    means = g[num].groupby(np.arange(m) // 2).mean()
    first = g.iloc[::2].reset_index(drop=True)
    for c in num:
        if c != tcol(df):
            first[c] = means[c].values
    out['means of two from the second'] = first
    t = tcol(df)
    if t is not None and np.issubdtype(df[t].dtype, np.number):
        dt = np.diff(df[t].values)
        if np.allclose(dt, dt[0]):
            x = np.arange(len(df)); xi = np.arange(0, len(df) - 1 + 1e-9, 0.5)
            it = pd.DataFrame({c: np.interp(xi, x, df[c].values) for c in num})
            out['interpolated to half the interval'] = it[df.columns.intersection(it.columns)]
            for f in (0.75, 1.5, 2.5):
                ti = np.arange(df[t].values[0], df[t].values[-1] + 1e-9, dt[0] * f)
                rs = pd.DataFrame({c: np.interp(ti, df[t].values, df[c].values) for c in num})
                if 'MODE' in rs:
                    rs['MODE'] = np.round(rs['MODE'])
                out[f'resampled to {f} times the interval'] = rs[df.columns.intersection(rs.columns)]
    return out
flips = {}; runs = {}
for path in plant + sims:
    base = verdict(path)
    df = pd.read_csv(path)
    for name, v in variants(df).items():
        out = os.path.join(SCRATCH, os.path.basename(path))
        v.to_csv(out, index=False)
        w = verdict(out)
        runs[name] = runs.get(name, 0) + 1
        if {base, w} == {'stiction', 'no-stiction'}:
            flips.setdefault(name, []).append(os.path.basename(path))
print(len(plant), 'plant,', len(sims), 'simulated records')
for name in runs:
    print(f'{name}: {len(flips.get(name, []))} flips of {runs[name]}', flips.get(name, []))
