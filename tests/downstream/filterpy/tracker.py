# The tracker program written with FilterPy and NumPy, for the length comparison (not run by
# the tests): the same model, data, output and batch check as `src/bin/tracker.rs`.
import numpy as np
from filterpy.kalman import KalmanFilter

dt = 1.0
kf = KalmanFilter(dim_x=2, dim_z=1)
kf.F = np.array([[1.0, dt], [0.0, 1.0]])
kf.H = np.array([[1.0, 0.0]])
kf.Q = np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]) * 0.01
kf.R = np.array([[0.25]])
kf.x = np.zeros(2)
kf.P = np.eye(2) * 10.0
zs = [1.1, 2.0, None, 3.9, 5.1, None, None, 8.0, 9.1, 9.9]
mu, cov, _, _ = kf.batch_filter(zs)
xs, Ps, _, _ = kf.rts_smoother(mu, cov)
for k, z in enumerate(zs):
    print(k, z, xs[k], Ps[k][0, 0])
# Independent check: the batch posterior from the information matrix.
n = len(zs)
qi, ri = np.linalg.inv(kf.Q), np.linalg.inv(kf.R)
info, eta = np.zeros((2 * n, 2 * n)), np.zeros(2 * n)
def add(i, j, m):
    info[2 * i:2 * i + 2, 2 * j:2 * j + 2] += m
add(0, 0, np.linalg.inv(np.eye(2) * 10.0))
for k in range(n - 1):
    add(k, k, kf.F.T @ qi @ kf.F)
    add(k, k + 1, -kf.F.T @ qi)
    add(k + 1, k, -qi @ kf.F)
    add(k + 1, k + 1, qi)
for k, z in enumerate(zs):
    if z is not None:
        add(k, k, kf.H.T @ ri @ kf.H)
        eta[2 * k:2 * k + 2] += (kf.H.T @ ri)[:, 0] * z
batch_cov = np.linalg.inv(info)
batch_mean = batch_cov @ eta
for k in range(n):
    assert np.linalg.norm(xs[k] - batch_mean[2 * k:2 * k + 2]) < 1e-9 * (1 + np.linalg.norm(xs[k]))
    assert np.linalg.norm(Ps[k] - batch_cov[2 * k:2 * k + 2, 2 * k:2 * k + 2]) < 1e-9 * np.linalg.norm(Ps[k])
