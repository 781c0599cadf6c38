"""The Nile series (annual flow at Aswan, 1871–1970, 100 values, public domain) as stored by
statsmodels, with the local-level fit of Durbin & Koopman's table ("Time Series Analysis by
State Space Methods", ch. 2: σ²_ε = 15099, σ²_η = 1469.1 under the exact diffuse prior), and
statsmodels' exact diffuse log-likelihoods (`use_exact_diffuse=True`): of the local level at
D&K's values and at statsmodels' own optimum, and of a local linear trend on the series with
gaps (one inside the diffuse period) at fixed variances.

Run in the venv of make_statsmodels_ar2.py, from the repository root:
    /tmp/venv-fit/bin/python kalman/tests/golden/make_nile.py
Writes kalman/tests/golden/nile.json.
"""
import json
import os

import numpy as np

import statsmodels
import statsmodels.api as sm

y = sm.datasets.nile.load_pandas().data["volume"].values
assert len(y) == 100
out = {
    "statsmodels": statsmodels.__version__,
    "y": [float(v) for v in y],
    "durbin_koopman": {"sigma2_eps": 15099.0, "sigma2_eta": 1469.1},
}
level = sm.tsa.UnobservedComponents(y, "llevel", use_exact_diffuse=True)
fit = level.fit(disp=False)
out["exact_diffuse_level"] = {
    "loglike_at_durbin_koopman": float(level.loglike([15099.0, 1469.1])),
    "statsmodels_optimum": {"llf": float(fit.llf), "params": [float(v) for v in fit.params]},
}
missing = [1, 30, 31, 77]
yg = y.copy()
yg[missing] = np.nan
params = [15000.0, 1500.0, 20.0]
trend = sm.tsa.UnobservedComponents(yg, "lltrend", use_exact_diffuse=True)
out["exact_diffuse_trend_gaps"] = {
    "missing": missing,
    "param_names": list(trend.param_names),
    "params": params,
    "loglike": float(trend.loglike(params)),
}
path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "nile.json")
with open(path, "w") as f:
    json.dump(out, f, indent=1)
print(path)
