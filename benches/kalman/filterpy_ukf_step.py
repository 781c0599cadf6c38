"""Times FilterPy's UKF on the (4, 2) range-bearing problem of benches/nonlinear.rs (same
model, prior, sigma points and measurements).

One step = update + predict (FilterPy's own UKF loop; the Rust filter redraws its sigma
points before the update, which costs it one extra Cholesky factorisation, so the
comparison does not favour Rust), cycling through the same 64 measurements.
Usage: python3 benches/kalman/filterpy_ukf_step.py   -> prints us/step
"""
import math
import time

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

DT = 1.0


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def fx(x, dt):
    return np.array([x[0] + x[1] * dt, x[1], x[2] + x[3] * dt, x[3]])


def hx(x):
    return np.array([math.hypot(x[0], x[2]), math.atan2(x[2], x[0])])


def residual_z(a, b):
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    d[1] = wrap(d[1])
    return d


def measurements():
    zs = []
    for k in range(64):
        t = 2 * math.pi * k / 64
        px, py = 200 + 50 * math.cos(t), 50 * math.sin(t)
        zs.append(np.array([math.hypot(px, py) + 0.3 * math.sin(1.7 * k),
                            math.atan2(py, px) + 0.005 * math.cos(2.3 * k)]))
    return zs


def main():
    q = 0.5
    blk = q * np.array([[DT**3 / 3, DT**2 / 2], [DT**2 / 2, DT]])
    Q = np.zeros((4, 4))
    Q[:2, :2] = blk
    Q[2:, 2:] = blk
    pts = MerweScaledSigmaPoints(4, alpha=0.5, beta=2.0, kappa=-1.0)
    ukf = UnscentedKalmanFilter(dim_x=4, dim_z=2, dt=DT, hx=hx, fx=fx, points=pts,
                                residual_z=residual_z)
    ukf.x = np.array([250.0, 0.0, 0.0, 4.9])
    ukf.P = np.diag([10.0, 1.0, 10.0, 1.0])
    ukf.Q = Q
    ukf.R = np.diag([0.25, 1e-4])
    zs = measurements()
    ukf.predict()  # FilterPy's update needs propagated sigma points
    best = best_cpu = float("inf")
    steps = 5000
    for _ in range(5):
        t0, c0 = time.perf_counter(), time.process_time()
        for k in range(steps):
            ukf.update(zs[k % 64])
            ukf.predict()
        best = min(best, (time.perf_counter() - t0) / steps)
        best_cpu = min(best_cpu, (time.process_time() - c0) / steps)
    print(f"filterpy UKF (4,2): {best * 1e6:.1f} us/step (best of 5 x {steps} steps; "
          f"CPU time {best_cpu * 1e6:.1f} us/step)")


if __name__ == "__main__":
    main()
