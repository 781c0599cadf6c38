"""Golden data for fitting model entries: an AR(2) seen through measurement noise, with gaps,
and statsmodels' SARIMAX(2,0,0) maximum-likelihood fit of it (an independent implementation).

Run in a throwaway venv from the repository root:
    python3 -m venv /tmp/venv-fit && /tmp/venv-fit/bin/pip install statsmodels numpy
    /tmp/venv-fit/bin/python kalman/tests/golden/make_statsmodels_ar2.py
Writes
  kalman/tests/golden/statsmodels_ar2.json       data and answer together (the library test)
  scenarios/tests/data/sarimax/record.csv        the same data as a CLI record (t, z1)
  scenarios/tests/data/sarimax/model.json        the start model for `scenarios fit`
  scenarios/tests/data/sarimax/statsmodels.json  the answer without the data (the CLI test)
SARIMAX's state is x = [y_t, φ2 y_{t−1}]: F = [[φ1, 1], [φ2, 0]], H = [1, 0],
Q = diag(σ², 0), R = σ²_ε. The prior is known (not diffuse) and no observation is burnt, so
statsmodels' log-likelihood is exactly the one of `kalman::fit` with x0 = 0, P0 = diag(4, 1)
as the prior of the first measurement. Missing values are NaN in statsmodels, null in JSON,
an empty cell in the CSV.
"""
import json
import os

import numpy as np
import statsmodels

from ar2_sarimax import sarimax, simulate

N = 800
PHI1, PHI2, SIGMA2, MEAS = 0.6, 0.25, 1.0, 0.5
X0 = np.zeros(2)
P0 = np.diag([4.0, 1.0])
# The start of both fits (statsmodels' and the CLI's model file).
START = {"ar.L1": 0.3, "ar.L2": 0.0, "var.measurement_error": 1.0, "sigma2": 2.0}

rng = np.random.default_rng(20261201)
y = simulate(rng, N, PHI1, PHI2, SIGMA2, MEAS)
# Gaps: one run of 25 and about 5 % scattered.
missing = np.zeros(N, dtype=bool)
missing[400:425] = True
missing |= rng.random(N) < 0.05
y[missing] = np.nan

mod = sarimax(y, X0, P0)
names = list(mod.param_names)
assert names == ["ar.L1", "ar.L2", "var.measurement_error", "sigma2"], names
start = np.array([START[n] for n in names])
# Tight tolerances so that the stored optimum is the optimum (the gradient of ln L/N there is
# about 1e-7); the standard errors at it from Harvey's observed information ("oim") and from
# the numerical Hessian of ln L ("approx", the observed information as kalman::fit takes it).
res = mod.fit(start_params=start, method="lbfgs", maxiter=5000, pgtol=1e-10, factr=10.0,
              disp=False, cov_type="oim")
assert res.mle_retvals["converged"], res.mle_retvals
approx = mod.smooth(res.params, cov_type="approx")
check = np.array([0.5, 0.1, 0.7, 1.3])
out = {
    "statsmodels": statsmodels.__version__,
    "truth": {"ar.L1": PHI1, "ar.L2": PHI2, "var.measurement_error": MEAS, "sigma2": SIGMA2},
    "start": START,
    "x0": X0.tolist(),
    "P0_diag": [4.0, 1.0],
    "y": [None if np.isnan(v) else float(v) for v in y],
    "params": dict(zip(names, res.params.tolist())),
    "bse_oim": dict(zip(names, res.bse.tolist())),
    "bse_approx": dict(zip(names, approx.bse.tolist())),
    "llf": float(res.llf),
    # The log-likelihood at fixed parameters, to check the likelihood itself.
    "check_params": dict(zip(names, check.tolist())),
    "check_llf": float(mod.loglike(check)),
}
here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "statsmodels_ar2.json"), "w") as f:
    json.dump(out, f, indent=1)
cli = os.path.join(here, "..", "..", "..", "scenarios", "tests", "data", "sarimax")
os.makedirs(cli, exist_ok=True)
with open(os.path.join(cli, "record.csv"), "w") as f:
    f.write("t,z1\n")
    for k, v in enumerate(y):
        f.write(f"{k},{'' if np.isnan(v) else repr(float(v))}\n")
model = {
    "dt": 1.0,
    "F": [[START["ar.L1"], 1.0], [START["ar.L2"], 0.0]],
    "H": [[1.0, 0.0]],
    "Q": [[START["sigma2"], 0.0], [0.0, 0.0]],
    "R": [[START["var.measurement_error"]]],
    "x0": X0.tolist(),
    "P0": P0.tolist(),
}
with open(os.path.join(cli, "model.json"), "w") as f:
    json.dump(model, f, indent=1)
with open(os.path.join(cli, "statsmodels.json"), "w") as f:
    json.dump({k: v for k, v in out.items() if k != "y"}, f, indent=1)
print(out["params"], out["bse_oim"], out["bse_approx"], out["llf"])
