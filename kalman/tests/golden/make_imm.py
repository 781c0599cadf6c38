"""Golden data for the IMM estimator, from FilterPy 1.4.5's IMMEstimator (an independent
implementation of the same cycle).

Run in a throwaway venv:
    python3 -m venv /tmp/venv-imm && /tmp/venv-imm/bin/pip install filterpy==1.4.5 numpy
    /tmp/venv-imm/bin/python kalman/tests/golden/make_imm.py
Writes imm_two_mode.json next to this script: the two modes' matrices, the transition
matrix, the prior, the measurements and, after each update, the combined x, P (row-major)
and the mode probabilities mu.

Conventions matched to the Rust IMM (step k = update with z_k, then mix and predict):
- FilterPy's IMMEstimator computes cbar = mu @ M at construction, so its first update would
  weigh the likelihoods by the *predicted* probabilities of mu0; the Rust IMM takes mu0 as
  the probabilities of the first step. The script sets `imm.cbar = mu0` before the first
  update, so both start from the same prior.
- Each step is `imm.update(z)` (recorded) and then `imm.predict()`.
"""

import json
import os

import numpy as np
from filterpy.kalman import IMMEstimator, KalmanFilter

HERE = os.path.dirname(os.path.abspath(__file__))

dt = 0.5
modes = [
    # quiet constant velocity
    dict(F=[[1.0, dt], [0.0, 1.0]], Q=[[1e-4, 2e-4], [2e-4, 4e-4]]),
    # manoeuvring: velocity decays, large process noise
    dict(F=[[1.0, dt], [0.0, 0.8]], Q=[[0.05, 0.02], [0.02, 0.5]]),
]
H = [[1.0, 0.0]]
R = [[0.25]]
x0 = [0.0, 1.0]
P0 = [[1.0, 0.0], [0.0, 0.5]]
M = [[0.97, 0.03], [0.10, 0.90]]
mu0 = [0.6, 0.4]

rng = np.random.default_rng(20261202)
truth = np.array([0.0, 1.0])
zs = []
for k in range(40):
    Fk = np.array(modes[1 if 15 <= k < 25 else 0]["F"])
    truth = Fk @ truth + (np.array([0.0, rng.normal(0.0, 3.0)]) if 15 <= k < 25 else 0.0)
    zs.append(float(truth[0] + rng.normal(0.0, 0.5)))

filters = []
for m in modes:
    kf = KalmanFilter(dim_x=2, dim_z=1)
    kf.x = np.array(x0, dtype=float)
    kf.P = np.array(P0, dtype=float)
    kf.F = np.array(m["F"])
    kf.Q = np.array(m["Q"])
    kf.H = np.array(H)
    kf.R = np.array(R)
    filters.append(kf)
imm = IMMEstimator(filters, np.array(mu0), np.array(M))
imm.cbar = np.array(mu0, dtype=float)

steps = []
for z in zs:
    imm.update(np.array([z]))
    steps.append(dict(x=[float(v) for v in imm.x],
                      P=[float(v) for v in imm.P.ravel()],
                      mu=[float(v) for v in imm.mu]))
    imm.predict()

out = dict(source="FilterPy 1.4.5 IMMEstimator", dt=dt, modes=modes, H=H, R=R, x0=x0,
           P0=P0, transition=M, mu0=mu0, z=zs, steps=steps)
with open(os.path.join(HERE, "imm_two_mode.json"), "w") as f:
    json.dump(out, f)
