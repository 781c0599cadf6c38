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
p0 = np.eye(2) * 10.0
kf.x, kf.P = np.zeros(2), p0.copy()
zs = [1.1, 2.0, None, 3.9, 5.1, None, None, 8.0, 9.1, 9.9]
mu, cov, _, _ = kf.batch_filter(zs, update_first=True)
xs, Ps, _, _ = kf.rts_smoother(mu, cov)
# Independent check: the batch posterior from its information matrix
# Λ = DᵀWD + seen ⊗ HᵀR⁻¹H and vector η = z ⊗ HᵀR⁻¹ (missing z as 0).
n, inv = len(zs), np.linalg.inv
shift, first = np.eye(n, k=-1), np.diag([1.0] + [0.0] * (n - 1))
seen = np.diag([float(z is not None) for z in zs])
d = np.eye(2 * n) - np.kron(shift, kf.F)
w = np.kron(first, inv(p0)) + np.kron(np.eye(n) - first, inv(kf.Q))
info = d.T @ w @ d + np.kron(seen, kf.H.T @ inv(kf.R) @ kf.H)
z0 = np.array([0.0 if z is None else z for z in zs])
eta = np.kron(z0, (kf.H.T @ inv(kf.R))[:, 0])
batch_cov = inv(info)
batch_mean = batch_cov @ eta
for k in range(n):
    x, p = xs[k], Ps[k]
    print(k, zs[k], x, p[0, 0])
    assert np.linalg.norm(x - batch_mean[2 * k : 2 * k + 2]) < 1e-9 * (1 + np.linalg.norm(x))
    assert np.linalg.norm(
        p - batch_cov[2 * k : 2 * k + 2, 2 * k : 2 * k + 2]
    ) < 1e-9 * np.linalg.norm(p)
