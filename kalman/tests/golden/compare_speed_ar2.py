"""Speed of an AR(2)-plus-noise fit (4 parameters, 1500 samples): `scenarios fit --free
F[0,0] --free F[1,0] --free Q[0,0] --free R[0,0]` against statsmodels' SARIMAX(2,0,0) with
measurement error, on the same data, from the same start, under the same known prior.

Run from the repository root after `cargo build --release -p scenarios`, in the venv of
make_statsmodels_ar2.py:
    /tmp/venv-fit/bin/python kalman/tests/golden/compare_speed_ar2.py
The program's time is the whole process (start, CSV parse, fit, standard errors, writing
the model and the summary), the best of 7 runs; statsmodels' is `fit()` alone (L-BFGS with
its default tolerances, standard errors from its default OIM), the best of 7. It prints
both times, their ratio and the two log-likelihoods (which must agree).
"""
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np

from ar2_sarimax import sarimax, simulate

N = 1500
PHI1, PHI2, SIGMA2, MEAS = 0.6, 0.25, 1.0, 0.5
START = [0.3, 0.0, 1.0, 2.0]  # ar.L1, ar.L2, var.measurement_error, sigma2
P0 = np.diag([4.0, 1.0])
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
EXE = os.path.join(ROOT, "target", "release", "scenarios")

y = simulate(np.random.default_rng(7), N, PHI1, PHI2, SIGMA2, MEAS)

tmp = tempfile.mkdtemp()
with open(os.path.join(tmp, "z.csv"), "w") as f:
    f.write("t,z1\n" + "".join(f"{k},{float(v)!r}\n" for k, v in enumerate(y)))
model = {"dt": 1.0, "F": [[START[0], 1.0], [START[1], 0.0]], "H": [[1.0, 0.0]],
         "Q": [[START[3], 0.0], [0.0, 0.0]], "R": [[START[2]]], "x0": [0.0, 0.0],
         "P0": P0.tolist()}
with open(os.path.join(tmp, "m.json"), "w") as f:
    json.dump(model, f)
cmd = [EXE, "fit", "--model", "m.json", "--data", "z.csv", "--free", "F[0,0]", "--free",
       "F[1,0]", "--free", "Q[0,0]", "--free", "R[0,0]", "--out", "f.json", "--summary",
       "s.json"]
ours = []
for _ in range(7):
    t = time.perf_counter()
    subprocess.run(cmd, cwd=tmp, check=True)
    ours.append(time.perf_counter() - t)
with open(os.path.join(tmp, "s.json")) as f:
    ll_ours = json.load(f)["loglik"]

mod = sarimax(y, np.zeros(2), P0)
theirs = []
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    for _ in range(7):
        t = time.perf_counter()
        res = mod.fit(start_params=START, disp=False)
        theirs.append(time.perf_counter() - t)
a, b = min(ours), min(theirs)
print(f"scenarios fit: {a * 1e3:.1f} ms (ln L {ll_ours:.6f})")
print(f"statsmodels SARIMAX.fit: {b * 1e3:.1f} ms (ln L {res.llf:.6f})")
print(f"ratio {b / a:.1f}x")
sys.exit(0 if abs(ll_ours - res.llf) < 1e-3 else 1)
