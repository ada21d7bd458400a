#!/usr/bin/env python3
"""Generate the golden fixtures of linear-id from SIPPY (an independent implementation).

Set-up (once, outside the repository):
    python3 -m venv /tmp/sippy-venv
    /tmp/sippy-venv/bin/pip install "numpy<=2.3" sippy_unipi
Run from the repository root:
    /tmp/sippy-venv/bin/python linear-id/scripts/make_goldens.py

Writes linear-id/tests/fixtures/{arx_sippy.json, parsim_k_sippy.json}. The data are generated
here with a seeded numpy RNG and stored in the fixtures, so the Rust tests need no Python.

Convention mapping (SIPPY -> linear-id):
* ARX: SIPPY's `ARX_id(y, u, na, nb, theta)` regresses y(k) on -y(k-1..k-na) and
  u(k-1-theta..k-nb-theta): theta = our `delay`, SIPPY's nk = 1 + delay. SIPPY's
  `centering="MeanVal"` subtracts the data means, then least squares without intercept
  (pinv): that is our `Centering::Mean`. We center here exactly as `system_identification`
  does and call `ARX_id` directly.
* PARSIM-K: `Parsim_methods.PARSIM_K(y, u, f, p, threshold, max_order, fixed_order)` on
  uncentered data (SIPPY's default `centering="None"`; it scales by np.std only): our
  `ParsimK` with `center(false)`. SIPPY's past blocks are only correct for p = f, so the
  fixtures use p = f. The state basis is arbitrary: compare Markov parameters, frequency
  response and eigenvalues, not matrices.
"""
import json
import os

import numpy as np
from sippy_unipi import Parsim_methods
from sippy_unipi.arx import ARX_id

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "tests", "fixtures")


def gbn(rng, n, p_switch):
    u = np.empty(n)
    v = 1.0
    for k in range(n):
        if rng.random() < p_switch:
            v = -v
        u[k] = v
    return u


def arx_golden():
    rng = np.random.default_rng(20240601)
    cases = []
    for (na, nb, theta, L) in [(2, 2, 0, 300), (3, 2, 2, 250), (2, 3, 1, 200)]:
        a = [1.0, -1.2, 0.5, -0.05][: na + 1]
        b = [0.6, 0.25, -0.1][:nb]
        u = 20.0 + 2.0 * gbn(rng, L, 0.15) + 0.3 * rng.standard_normal(L)
        e = 0.1 * rng.standard_normal(L)
        y = np.zeros(L)
        for k in range(L):
            v = e[k] + 5.0
            for i in range(1, na + 1):
                if k - i >= 0:
                    v -= a[i] * y[k - i]
            for j in range(nb):
                lag = theta + 1 + j
                if k - lag >= 0:
                    v += b[j] * u[k - lag]
            y[k] = v
        yc = y - y.mean()
        uc = u - u.mean()
        NUM, DEN, _, Vn, _ = ARX_id(yc.copy(), uc.copy(), na, nb, theta)
        cases.append({
            "n": na, "m": nb, "delay": theta,
            "u": u.tolist(), "y": y.tolist(),
            "a": [float(v) for v in DEN[: na + 1]],
            "b": [float(v) for v in NUM[theta: theta + nb]],
            "vn": float(Vn),
        })
    return {"source": "sippy_unipi 1.0.1 arx.ARX_id on MeanVal-centered data", "cases": cases}


def parsim_golden():
    rng = np.random.default_rng(424242)
    cases = []
    w = np.linspace(0.0, np.pi, 16)
    for (L, sigma, f, p) in [(400, 0.1, 10, 10), (500, 0.3, 20, 20), (400, 0.0, 10, 10)]:
        u = gbn(rng, L, 0.05)
        noise = sigma * rng.standard_normal(L)
        x = np.zeros(2)
        y = np.zeros(L)
        for k in range(L):
            y[k] = 0.7 * x[0] + 1.0 * x[1] + noise[k]
            x = np.array([0.89 * x[0] + 0.3 * u[k], 0.45 * x[1] + 2.5 * u[k]])
        A_K, C, B_K, D, K, A, B, x0, Vn = Parsim_methods.PARSIM_K(
            y.reshape(1, -1).copy(), u.reshape(1, -1).copy(), f, p, 0.1, np.nan, 2)
        markov = [float(D[0, 0])] + [float((C @ np.linalg.matrix_power(A, i) @ B)[0, 0]) for i in range(15)]
        markov_k = [float((C @ np.linalg.matrix_power(A, i) @ K)[0, 0]) for i in range(10)]
        fr = []
        for om in w:
            z = np.exp(1j * om)
            g = (C @ np.linalg.solve(z * np.eye(2) - A, B))[0, 0] + D[0, 0]
            fr.append([float(g.real), float(g.imag)])
        eig = sorted(np.linalg.eigvals(A).real.tolist(), reverse=True)
        cases.append({
            "f": f, "p": p, "n": 2, "sigma": sigma,
            "u": u.tolist(), "y": y.tolist(),
            "markov": markov, "markov_k": markov_k,
            "omegas": w.tolist(), "freq": fr, "eig": eig, "vn": float(Vn),
        })
    return {"source": "sippy_unipi 1.0.1 Parsim_methods.PARSIM_K (fixed order 2, uncentered data)",
            "cases": cases}


def main():
    os.makedirs(OUT, exist_ok=True)
    for name, data in [("arx_sippy.json", arx_golden()), ("parsim_k_sippy.json", parsim_golden())]:
        with open(os.path.join(OUT, name), "w") as fh:
            json.dump(data, fh, indent=0)
            fh.write("\n")
        print("wrote", name)


if __name__ == "__main__":
    main()
