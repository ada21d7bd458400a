"""The free valve's explained share as a candidate feature of the detection score.

Reads the per-loop rows of `cargo xtask detect-calibrate --no-plant [--train-seed N] --cases
FILE` (column `hammerstein_free_share`: 1 - RSS_free / RSS_y of the Hammerstein test's
output-error fit) and fits, on the training rows only, the shipped score's logistic model on
its features (non-negative weights; it reproduces the shipped score) with and without the new
feature, whose weight is free in sign. Prints the training population's 5-fold cross-validated
AUC (mean over three fold seeds) and the validation AUC overall and per decided loop kind
(validation rows never fitted on), over the loops that can be judged, every sticky loop sticky.

Usage: python3 2026-11-30-free-share.py CASES.csv   (needs numpy, pandas, scipy, scikit-learn)

Since the feature is in the score (`free_explains`), the column is empty on integrating loops
and on an optimum at the grid's edge, where the score does not read it: the "every record"
variant needs a cases file written by commit 75a2a60, and the shipped features here then leave
out `free_explains` (they are the features before it).
"""
import sys

import numpy as np
import pandas as pd
from scipy.optimize import minimize
from sklearn.metrics import roc_auc_score
from sklearn.model_selection import StratifiedKFold

df = pd.read_csv(sys.argv[1])
df = df[df.judgeable == True].copy()  # noqa: E712
rows = df.what.str.extract(r"N=(\d+)")[0].astype(float) - 5
y = df.sticky.astype(int).values
train = (df.population == "training").values
valid = ~train
integrating = (df.integrating == True).values  # noqa: E712  (the kind the detector decided)

# The shipped score's features (detection::score::FEATURES; the two with weight 0 left out).
F = pd.DataFrame(index=df.index)
F["odd_share"] = (df["horch-xcorr"] - 0.5).fillna(0)
F["triangularity"] = (df["curve-fit"] - 0.5).fillna(0)
F["stuck_share"] = (df["stick-slip"] - 0.15).fillna(0)
F["log_area_ratio"] = np.log(df["area-ratio"]).clip(-1, 1).fillna(0)
lr500 = lambda lr: np.log1p(500 * lr.clip(lower=0) / rows) / np.log(100) - 0.5
F["hammerstein_oe"] = lr500(df.hammerstein).fillna(0)
F["hammerstein_arx"] = (
    lr500(df.hammerstein_lr_arx).clip(lower=0).where(df.hammerstein.notna(), 0).fillna(0)
)


def fit(X, t, signs, ridge=0.1):
    def f(w):
        z = w[0] + X @ w[1:]
        p = 1 / (1 + np.exp(-z))
        loss = np.sum(np.logaddexp(0, z) - t * z) + 0.5 * ridge * np.sum(w[1:] ** 2)
        return loss, np.concatenate([[np.sum(p - t)], X.T @ (p - t) + ridge * w[1:]])

    bounds = [(None, None)] + [(0, None) if s > 0 else (None, None) for s in signs]
    return minimize(f, np.zeros(X.shape[1] + 1), jac=True, method="L-BFGS-B", bounds=bounds).x


def evaluate(G, signs, name):
    X = G.values
    Xt, yt = X[train], y[train]
    cv = []
    for seed in range(3):
        pred = np.zeros(len(yt))
        for a, b in StratifiedKFold(5, shuffle=True, random_state=seed).split(Xt, yt):
            w = fit(Xt[a], yt[a], signs)
            pred[b] = w[0] + Xt[b] @ w[1:]
        cv.append(roc_auc_score(yt, pred))
    w = fit(Xt, yt, signs)
    z = w[0] + X[valid] @ w[1:]
    yv, iv = y[valid], integrating[valid]
    print(
        f"{name:44s} CV {np.mean(cv):.4f}  validation {roc_auc_score(yv, z):.4f}"
        f" (self-regulating {roc_auc_score(yv[~iv], z[~iv]):.4f},"
        f" integrating {roc_auc_score(yv[iv], z[iv]):.4f})  weights {np.round(w[1:], 3)}"
    )


share = df.hammerstein_free_share.clip(lower=0).fillna(0)
evaluate(F, [1] * 6, "shipped features")
G = F.copy()
G["free_share"] = share
evaluate(G, [1] * 6 + [0], "+ free_share (every record)")
G["free_share"] = np.where(integrating, 0, share)
evaluate(G, [1] * 6 + [0], "+ free_share (self-regulating reading only)")
