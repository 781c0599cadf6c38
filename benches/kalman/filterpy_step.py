"""Times FilterPy on the (7, 2) problem of benches/kalman/step.rs (same matrices and data).

Joseph form (FilterPy's KalmanFilter.update uses (I-KH)P(I-KH)' + KRK') plus predict,
one step per measurement, cycling through the same 64 measurement vectors.
Usage: python3 benches/kalman/filterpy_step.py [n m]   -> prints ns/step
"""
import math
import sys
import time

import numpy as np
from filterpy.kalman import KalmanFilter


def problem(n, m):
    s = 1.0 / math.sqrt(n)
    F = np.array([[(0.95 if i == j else 0.0) + 0.05 * s * math.sin(1.0 + i + 3.0 * j)
                   for j in range(n)] for i in range(n)])
    H = np.array([[math.cos(1.0 + 2.0 * i + j) for j in range(n)] for i in range(m)])
    Q = np.diag([0.01 * (1.0 + 0.1 * i) for i in range(n)])
    R = np.diag([0.1 * (1.0 + 0.1 * i) for i in range(m)])
    z = [np.array([math.sin(0.37 * k + 1.3 * i) for i in range(m)]) for k in range(64)]
    return F, H, Q, R, z


def main():
    n, m = (int(sys.argv[1]), int(sys.argv[2])) if len(sys.argv) == 3 else (7, 2)
    F, H, Q, R, zs = problem(n, m)
    kf = KalmanFilter(dim_x=n, dim_z=m)
    kf.F, kf.H, kf.Q, kf.R = F, H, Q, R
    kf.x = np.zeros((n, 1))
    kf.P = np.eye(n)
    best = float("inf")
    steps = 20000
    for _ in range(5):
        t0 = time.perf_counter()
        for k in range(steps):
            kf.update(zs[k % 64])
            kf.predict()
        best = min(best, (time.perf_counter() - t0) / steps)
    print(f"filterpy ({n},{m}): {best * 1e9:.0f} ns/step (best of 5 x {steps} steps)")


if __name__ == "__main__":
    main()
