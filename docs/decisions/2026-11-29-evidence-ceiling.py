"""How far a richer combination of the detection tests' statistics could go.

Reads the per-loop rows of `cargo xtask detect-calibrate --no-plant [--train N] --cases FILE`
and fits, on the training population's rows only, (1) the shipped score's logistic model on its
features with non-negative weights (it reproduces the shipped score), (2) the same with each
feature expanded into monotone hinges at its quartiles (non-negative weights keep every
feature's effect non-decreasing), (3) gradient-boosted trees on the score's features, and on
those plus the Hammerstein test's S, region top and delay, the oscillation's regularity and
the loop kind (unconstrained and with the evidence monotone). Each is measured on the
validation populations' rows (never fitted on): ROC AUC, sticky against free, over the loops
that can be judged (every sticky loop sticky).

Usage: python3 evidence-ceiling.py CASES.csv   (needs numpy, pandas, scipy, scikit-learn)
"""
import sys

import numpy as np
import pandas as pd
from scipy.optimize import minimize
from sklearn.ensemble import HistGradientBoostingClassifier
from sklearn.metrics import roc_auc_score
from sklearn.model_selection import StratifiedKFold

df = pd.read_csv(sys.argv[1])
df = df[df.judgeable == True].copy()  # noqa: E712
rows = df.what.str.extract(r"N=(\d+)")[0].astype(float) - 5
y = df.sticky.astype(int).values
train = (df.population == "training").values
valid = ~train

# The shipped score's features (detection::score::FEATURES; the two with weight 0 left out).
F = pd.DataFrame(index=df.index)
F["odd_share"] = (df["horch-xcorr"] - 0.5).fillna(0)
F["triangularity"] = (df["curve-fit"] - 0.5).fillna(0)
F["stuck_share"] = (df["stick-slip"] - 0.15).fillna(0)
F["log_area_ratio"] = np.log(df["area-ratio"]).clip(-1, 1).fillna(0)
lr500 = lambda lr: np.log1p(500 * lr.clip(lower=0) / rows) / np.log(100) - 0.5
F["hammerstein_oe"] = lr500(df.hammerstein).fillna(0)
F["hammerstein_arx"] = lr500(df.hammerstein_lr_arx).clip(lower=0).where(df.hammerstein.notna(), 0).fillna(0)


def expand(knots):
    cols = []
    for c in F.columns:
        x = F[c].values
        cols.append(x)
        for k in knots.get(c, []):
            cols += [np.maximum(0, x - k), np.minimum(0, x - k)]
    return np.column_stack(cols)


def fit_nonnegative(X, t, ridge=0.1):
    def f(w):
        z = w[0] + X @ w[1:]
        p = 1 / (1 + np.exp(-z))
        loss = np.sum(np.logaddexp(0, z) - t * z) + 0.5 * ridge * np.sum(w[1:] ** 2)
        return loss, np.concatenate([[np.sum(p - t)], X.T @ (p - t) + ridge * w[1:]])

    bounds = [(None, None)] + [(0, None)] * X.shape[1]
    return minimize(f, np.zeros(X.shape[1] + 1), jac=True, method="L-BFGS-B", bounds=bounds).x


def logistic(label, X):
    Xt, yt = X[train], y[train]
    cv = np.zeros(len(yt))
    for a, b in StratifiedKFold(5, shuffle=True, random_state=0).split(Xt, yt):
        w = fit_nonnegative(Xt[a], yt[a])
        cv[b] = w[0] + Xt[b] @ w[1:]
    w = fit_nonnegative(Xt, yt)
    report(label, w[0] + X[valid] @ w[1:], f"training CV {roc_auc_score(yt, cv):.3f}")


def report(label, p, extra=""):
    print(f"{label:58s} validation AUC {roc_auc_score(y[valid], p):.3f} {extra}")


logistic("score's features, linear, weights >= 0 (the shipped score)", expand({}))
quartiles = {c: list(np.quantile(F[c][F[c] != 0], [0.25, 0.5, 0.75])) for c in F.columns}
logistic("score's features, monotone hinges at quartiles", expand(quartiles))

X = df.copy()
X["oe500"] = F.hammerstein_oe
X["arx500"] = F.hammerstein_arx.where(df.hammerstein.notna())
X["integ"] = df.integrating.astype(int)
X["log_S"] = np.log(df.hammerstein_S)
X["log_S_upper"] = np.log1p(df.hammerstein_S_upper)
base = ["horch-xcorr", "curve-fit", "stick-slip", "area-ratio", "oe500", "arx500"]
more = base + ["horch-integrating", "bicoherence", "oscillation", "integ", "log_S", "log_S_upper", "hammerstein_delay"]
for label, feats, mono in [
    ("boosted trees, the score's tests' statistics", base, None),
    ("boosted trees, and S, region, delay, oscillation, kind", more, None),
    ("the same, each test's evidence monotone", more, [1] * 8 + [0] * 5),
]:
    m = HistGradientBoostingClassifier(
        random_state=0, max_depth=3, learning_rate=0.05, max_iter=200, monotonic_cst=mono
    )
    m.fit(X[feats].values[train], y[train])
    report(label, m.predict_proba(X[feats].values[valid])[:, 1])
