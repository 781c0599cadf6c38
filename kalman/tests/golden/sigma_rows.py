"""Helpers shared by make_nonlinear.py and make_sigma_fixed_lag.py: the number format of
the CSV files, a random mean and covariance, the long-format rows of a sigma-point set, and
the CSV writer (files land next to this script)."""

import csv
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def r(v):
    return repr(float(v))


def random_mean_cov(rng, n):
    """A mean x ~ N(0, I) and a covariance A A^T + 0.5 I (A standard normal), drawn from rng
    in that order."""
    x = rng.normal(size=n)
    A = rng.normal(size=(n, n))
    return x, A @ A.T + 0.5 * np.eye(n)


def sigma_rows(head, x, P, sig, pts):
    """The rows `head + [what, i, j, value]` of a sigma-point set: x, P, the points sig
    (one a row, FilterPy's order; written as column j the j-th point), then Wm and Wc."""
    rows = []
    n = len(x)
    for i in range(n):
        rows.append(head + ["x", i, 0, r(x[i])])
        for j in range(n):
            rows.append(head + ["P", i, j, r(P[i, j])])
        for j in range(sig.shape[0]):
            rows.append(head + ["sigma", i, j, r(sig[j, i])])
    for j in range(sig.shape[0]):
        rows.append(head + ["Wm", j, 0, r(pts.Wm[j])])
        rows.append(head + ["Wc", j, 0, r(pts.Wc[j])])
    return rows


def write_csv(name, header, rows):
    """Writes the header and the rows to the CSV file `name` next to this script."""
    with open(os.path.join(HERE, name), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)
