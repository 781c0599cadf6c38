"""The radar tracker of `kalman/examples/radar.rs` written with FilterPy (for comparison
with the Rust `track`: the same model, prior, sigma points and smoother). Needs FilterPy.

    python examples/radar_filterpy.py
"""

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

DT, Q, SR, SB = 1.0, 0.05, 5.0, np.radians(0.5)


def track(zs):
    qa, qb, qc = Q * DT**3 / 3, Q * DT**2 / 2, Q * DT

    def fx(x, dt):
        return np.array([x[0] + dt * x[1], x[1], x[2] + dt * x[3], x[3]])

    def hx(x):
        return np.array([np.hypot(x[0], x[2]), np.arctan2(x[2], x[0])])

    def residual(a, b):
        d = a - b
        d[1] = (d[1] + np.pi) % (2 * np.pi) - np.pi
        return d

    points = MerweScaledSigmaPoints(4, alpha=1e-3, beta=2.0, kappa=0.0)
    ukf = UnscentedKalmanFilter(4, 2, DT, hx, fx, points, residual_z=residual)
    ukf.Q = np.array([[qa, qb, 0, 0], [qb, qc, 0, 0], [0, 0, qa, qb], [0, 0, qb, qc]])
    ukf.R = np.diag([SR**2, SB**2])
    ukf.x = np.array([-290.0, 0.0, 590.0, -9.0])
    ukf.P = 100.0 * np.eye(4)
    xs, ps = ukf.batch_filter(zs)
    smoothed, _, _ = ukf.rts_smoother(xs, ps)
    return xs[:, [0, 2]], smoothed[:, [0, 2]]


if __name__ == "__main__":
    rng = np.random.default_rng(7)
    truth = np.array([[-300.0, 600.0 - 10.0 * k] for k in range(120)])
    zs = np.column_stack([np.hypot(truth[:, 0], truth[:, 1]), np.arctan2(truth[:, 1], truth[:, 0])])
    zs += rng.standard_normal(zs.shape) * [SR, SB]
    raw = np.column_stack([zs[:, 0] * np.cos(zs[:, 1]), zs[:, 0] * np.sin(zs[:, 1])])
    filtered, smoothed = track(zs)
    rms = lambda e: np.sqrt(np.mean(np.sum((e - truth) ** 2, axis=1)))
    print(f"RMS position error: measurements {rms(raw):.2f} m, "
          f"filter {rms(filtered):.2f} m, smoother {rms(smoothed):.2f} m")
