"""The Nile series (annual flow at Aswan, 1871–1970, 100 values, public domain) as stored by
statsmodels, with the local-level fit of Durbin & Koopman's table ("Time Series Analysis by
State Space Methods", ch. 2: σ²_ε = 15099, σ²_η = 1469.1 under the exact diffuse prior).

Run in the venv of make_statsmodels_ar2.py, from the repository root:
    /tmp/venv-fit/bin/python kalman/tests/golden/make_nile.py
Writes kalman/tests/golden/nile.json.
"""
import json
import os

import statsmodels
import statsmodels.api as sm

y = sm.datasets.nile.load_pandas().data["volume"].values
assert len(y) == 100
out = {
    "statsmodels": statsmodels.__version__,
    "y": [float(v) for v in y],
    "durbin_koopman": {"sigma2_eps": 15099.0, "sigma2_eta": 1469.1},
}
path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "nile.json")
with open(path, "w") as f:
    json.dump(out, f, indent=1)
print(path)
