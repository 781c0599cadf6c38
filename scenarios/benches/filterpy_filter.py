#!/usr/bin/env python3
"""`scenarios filter` against FilterPy on the same model and data (not run by CI).

    pip install filterpy numpy
    python3 scenarios/benches/filterpy_filter.py gen DIR [--rows 1000000] [--seed 7]
    /usr/bin/time -v target/release/scenarios filter --model DIR/model.json \
        --data DIR/data.csv --out DIR/est.csv
    python3 scenarios/benches/filterpy_filter.py filterpy DIR

`gen` writes a seeded 7-state, 2-measurement model (DIR/model.json) and a simulated data
CSV (DIR/data.csv). `filterpy` loads the CSV, runs FilterPy's KalmanFilter over it (predict
for k > 0, then update, the same step order as `scenarios filter`), prints its rows/s for
the filter loop alone (CSV reading excluded, which favours FilterPy), and, if DIR/est.csv
exists, the largest difference between the two programs' state estimates.
"""

import argparse
import json
import sys
import time

import numpy as np


def model(seed):
    """A stable, observable 7-state model: two damped oscillators, a random walk, two
    first-order lags and a bias pair, measured by two mixed channels."""
    dt = 0.01
    F = np.zeros((7, 7))
    for b, (w, z) in enumerate([(2.0, 0.1), (5.0, 0.05)]):
        i = 2 * b
        F[i, i], F[i, i + 1] = 1.0, dt
        F[i + 1, i], F[i + 1, i + 1] = -w * w * dt, 1.0 - 2.0 * z * w * dt
    F[4, 4] = 1.0
    F[5, 5] = np.exp(-dt / 0.5)
    F[6, 6] = np.exp(-dt / 2.0)
    H = np.array(
        [
            [1.0, 0.0, 0.5, 0.0, 1.0, 1.0, 0.0],
            [0.0, 0.2, 1.0, 0.0, 0.0, 0.0, 1.0],
        ]
    )
    Q = np.diag([1e-6, 1e-3, 1e-6, 2e-3, 1e-5, 1e-4, 1e-4])
    R = np.array([[0.04, 0.01], [0.01, 0.09]])
    P0 = np.eye(7)
    x0 = np.zeros(7)
    return dt, F, H, Q, R, x0, P0


def gen(args):
    dt, F, H, Q, R, x0, P0 = model(args.seed)
    rng = np.random.default_rng(args.seed)
    with open(f"{args.dir}/model.json", "w") as f:
        json.dump(
            {
                "dt": dt,
                "F": F.tolist(),
                "H": H.tolist(),
                "Q": Q.tolist(),
                "R": R.tolist(),
                "x0": x0.tolist(),
                "P0": P0.tolist(),
            },
            f,
        )
    n = args.rows
    x = rng.multivariate_normal(x0, P0)
    Lq = np.linalg.cholesky(Q)
    Lr = np.linalg.cholesky(R)
    zs = np.empty((n, 2))
    for k in range(n):
        zs[k] = H @ x + Lr @ rng.standard_normal(2)
        x = F @ x + Lq @ rng.standard_normal(7)
    t = np.arange(n) * dt
    np.savetxt(
        f"{args.dir}/data.csv",
        np.column_stack([t, zs]),
        delimiter=",",
        header="t,z1,z2",
        comments="",
        fmt="%.9g",
    )
    print(f"wrote {args.dir}/model.json and {args.dir}/data.csv ({n} rows)")


def run_filterpy(args):
    from filterpy.kalman import KalmanFilter

    with open(f"{args.dir}/model.json") as f:
        m = json.load(f)
    data = np.loadtxt(f"{args.dir}/data.csv", delimiter=",", skiprows=1)
    n = len(m["F"])
    kf = KalmanFilter(dim_x=n, dim_z=len(m["H"]))
    kf.F = np.array(m["F"])
    kf.H = np.array(m["H"])
    kf.Q = np.array(m["Q"])
    kf.R = np.array(m["R"])
    kf.x = np.array(m["x0"]).reshape(n, 1)
    kf.P = np.array(m["P0"])
    xs = np.empty((len(data), n))
    start = time.perf_counter()
    for k, row in enumerate(data):
        if k > 0:
            kf.predict()
        kf.update(row[1:].reshape(-1, 1))
        xs[k] = kf.x[:, 0]
    elapsed = time.perf_counter() - start
    print(f"FilterPy: {len(data)} rows in {elapsed:.2f} s = {len(data) / elapsed:.0f} rows/s")
    try:
        est = np.loadtxt(f"{args.dir}/est.csv", delimiter=",", skiprows=1, usecols=range(1, n + 1))
    except OSError:
        return
    diff = np.max(np.abs(est - xs))
    print(f"max |x_scenarios - x_filterpy| = {diff:.3e}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("gen")
    g.add_argument("dir")
    g.add_argument("--rows", type=int, default=1_000_000)
    g.add_argument("--seed", type=int, default=7)
    f = sub.add_parser("filterpy")
    f.add_argument("dir")
    args = p.parse_args()
    {"gen": gen, "filterpy": run_filterpy}[args.cmd](args)


if __name__ == "__main__":
    sys.exit(main())
