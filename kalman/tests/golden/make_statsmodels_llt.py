"""Golden data for the fitting tests: a simulated local linear trend and statsmodels'
UnobservedComponents maximum-likelihood estimates on it (an independent implementation).

Run in a throwaway venv from the repository root:
    python3 -m venv /tmp/venv-fit && /tmp/venv-fit/bin/pip install statsmodels numpy
    /tmp/venv-fit/bin/python kalman/tests/golden/make_statsmodels_llt.py
Writes kalman/tests/golden/statsmodels_llt.json (data and answer together). The prior is
known (not diffuse) and no observation is burnt, so the log-likelihood is exactly the one
of `kalman::fit` (x0 = [z_0, 0], P0 = diag(10, 1)).
"""
import json
import os

import numpy as np
import statsmodels
import statsmodels.api as sm

N = 500
Q_LEVEL, Q_SLOPE, R = 0.5, 0.02, 4.0
X0 = None  # set from the data
P0 = np.diag([10.0, 1.0])

rng = np.random.default_rng(20261127)
level, slope = 0.0, 0.1
y = np.empty(N)
for k in range(N):
    y[k] = level + rng.normal() * np.sqrt(R)
    level, slope = level + slope + rng.normal() * np.sqrt(Q_LEVEL), slope + rng.normal() * np.sqrt(Q_SLOPE)

mod = sm.tsa.UnobservedComponents(y, level="local linear trend")
x0 = np.array([y[0], 0.0])
mod.ssm.initialize_known(x0, P0)
mod.ssm.loglikelihood_burn = 0
# Tight L-BFGS tolerances so that the stored optimum is the optimum; standard errors from the
# numerical Hessian of the log-likelihood ("approx": the observed information, as
# kalman::fit computes it; statsmodels' "oim" is Harvey's formula, which drops the terms
# of zero expectation).
res = mod.fit(start_params=[1.0, 1.0, 1.0], method="lbfgs", maxiter=2000, pgtol=1e-10, factr=10.0, disp=False, cov_type="approx")
names = list(mod.param_names)
assert names == ["sigma2.irregular", "sigma2.level", "sigma2.trend"], names
out = {
    "statsmodels": statsmodels.__version__,
    "truth": {"r": R, "q_level": Q_LEVEL, "q_slope": Q_SLOPE},
    "x0": x0.tolist(),
    "P0_diag": [10.0, 1.0],
    "y": y.tolist(),
    "params": dict(zip(names, res.params.tolist())),
    "bse_hessian": dict(zip(names, res.bse.tolist())),
    "llf": float(res.llf),
    # The log-likelihood at fixed parameters, to check the likelihood itself.
    "check_params": [1.5, 0.7, 0.05],
    "check_llf": float(mod.loglike(np.array([1.5, 0.7, 0.05]))),
}
path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "statsmodels_llt.json")
with open(path, "w") as f:
    json.dump(out, f, indent=1)
print(path, out["params"], out["llf"])
