"""Golden data for the nonlinear filters, from FilterPy (an independent implementation).

Run in a throwaway venv:
    python3 -m venv /tmp/venv-x && /tmp/venv-x/bin/pip install filterpy numpy scipy
    /tmp/venv-x/bin/python kalman/tests/golden/make_nonlinear.py
Writes, next to this script:
- merwe_sigma.csv: MerweScaledSigmaPoints for several (n, alpha, beta, kappa): long format
  `case,n,alpha,beta,kappa,what,i,j,value` with what in {x, P, sigma, Wm, Wc}
  (sigma is n x (2n+1), column j the j-th point, FilterPy's order).
- nl_<problem>_<filter>.csv for problem in {rangebearing, pendulum} and filter in {ekf,
  ukf_merwe, ukf_cubature}: the measurements (NaN = missing, FilterPy's `update(None)`) and
  the posterior after each update: `k,z1..zm,x1..xn,P1_1..Pn_n (column-major),nis`.

Conventions matched to the Rust filters (step k = update with z_k, then predict):
- FilterPy's UKF passes the *propagated* sigma points through h in `update`; the Rust UKF
  redraws the sigma points from the predicted mean and covariance (so that Q is seen by the
  update). The script does the same by setting `ukf.sigmas_f` to fresh sigma points of the
  prior before every update.
- The EKF's prediction uses f (FilterPy's `predict_x` overridden) and `F` set to the
  Jacobian of f at the posterior.
- The cubature set is MerweScaledSigmaPoints(alpha=1, beta=0, kappa=0) (zero-weight centre).
"""

import numpy as np
from filterpy.kalman import (ExtendedKalmanFilter, MerweScaledSigmaPoints,
                             UnscentedKalmanFilter)

from sigma_rows import r, random_mean_cov, sigma_rows, write_csv


def merwe_cases():
    rng = np.random.default_rng(20261127)
    rows = []
    cases = [(1, 0.3, 2.0, 2.0), (2, 0.1, 2.0, 1.0), (3, 1e-3, 2.0, 0.0),
             (4, 0.5, 2.0, -1.0), (5, 1.0, 0.0, -2.0), (6, 0.8, 1.5, 3.0)]
    for c, (n, alpha, beta, kappa) in enumerate(cases):
        x, P = random_mean_cov(rng, n)
        pts = MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=kappa)
        sig = pts.sigma_points(x, P)  # (2n+1) x n
        rows += sigma_rows([c, n, r(alpha), r(beta), r(kappa)], x, P, sig, pts)
    head = ["case", "n", "alpha", "beta", "kappa", "what", "i", "j", "value"]
    write_csv("merwe_sigma.csv", head, rows)


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


class RangeBearing:
    """Constant velocity in the plane, x = (px, vx, py, vy); range and bearing from the
    origin; the bearing residual is wrapped to [-pi, pi)."""
    n, m, dt, steps = 4, 2, 1.0, 60
    q, sr, sb = 0.05, 0.5, 0.01

    def __init__(self):
        dt, q = self.dt, self.q
        blk = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        self.Q = np.zeros((4, 4))
        self.Q[:2, :2] = blk
        self.Q[2:, 2:] = blk
        self.R = np.diag([self.sr**2, self.sb**2])
        self.F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1.0]])
        self.x0 = np.array([60.0, -1.0, -40.0, 1.5])
        self.P0 = np.diag([4.0, 0.25, 4.0, 0.25])

    def f(self, x):
        return self.F @ x

    def fjac(self, x):
        return self.F

    def h(self, x):
        return np.array([np.hypot(x[0], x[2]), np.arctan2(x[2], x[0])])

    def hjac(self, x):
        px, py = x[0], x[2]
        r2 = px * px + py * py
        rr = np.sqrt(r2)
        return np.array([[px / rr, 0, py / rr, 0], [-py / r2, 0, px / r2, 0]])

    def residual(self, a, b):
        d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
        d[1] = wrap(d[1])
        return d


class Pendulum:
    """x = (theta, omega), Euler step of theta'' = -(g/L) sin theta; z = L sin theta."""
    n, m, dt, steps = 2, 1, 0.05, 100
    g, L = 9.81, 2.0

    def __init__(self):
        self.Q = np.diag([1e-6, 1e-3])
        self.R = np.array([[0.01**2]])
        self.x0 = np.array([1.2, 0.0])
        self.P0 = np.diag([0.05, 0.1])

    def f(self, x):
        th, om = x
        return np.array([th + self.dt * om, om - self.dt * self.g / self.L * np.sin(th)])

    def fjac(self, x):
        th = x[0]
        return np.array([[1.0, self.dt], [-self.dt * self.g / self.L * np.cos(th), 1.0]])

    def h(self, x):
        return np.array([self.L * np.sin(x[0])])

    def hjac(self, x):
        return np.array([[self.L * np.cos(x[0]), 0.0]])

    def residual(self, a, b):
        return np.asarray(a, dtype=float) - np.asarray(b, dtype=float)


def simulate(p, seed):
    rng = np.random.default_rng(seed)
    x = p.x0 + rng.multivariate_normal(np.zeros(p.n), p.P0)
    zs = []
    for k in range(p.steps):
        z = p.h(x) + rng.multivariate_normal(np.zeros(p.m), p.R)
        if k % 13 == 7:
            z = None
        zs.append(z)
        x = p.f(x) + rng.multivariate_normal(np.zeros(p.n), p.Q)
    return zs


def record(rows, k, z, x, P, nis, m):
    zc = [r(v) for v in z] if z is not None else ["NaN"] * m
    rows.append([k] + zc + [r(v) for v in x] + [r(v) for v in P.flatten(order="F")] + [r(nis)])


def write(name, p, rows):
    head = (["k"] + [f"z{i+1}" for i in range(p.m)] + [f"x{i+1}" for i in range(p.n)]
            + [f"P{i+1}_{j+1}" for j in range(p.n) for i in range(p.n)] + ["nis"])
    write_csv(name, head, rows)


def with_prior(filt, p):
    """Sets a FilterPy filter's prior (x0, P0) and noise covariances (Q, R) from problem p."""
    filt.x = p.x0.copy()
    filt.P = p.P0.copy()
    filt.Q = p.Q.copy()
    filt.R = p.R.copy()
    return filt


def record_update(rows, k, z, filt, m):
    """Records step k after the filter's update, with its NIS (NaN without a measurement)."""
    nis = float(filt.y @ np.linalg.solve(filt.S, filt.y)) if z is not None else float("nan")
    record(rows, k, z, filt.x, filt.P, nis, m)


def run_ekf(p, zs):
    class Ekf(ExtendedKalmanFilter):
        def predict_x(self, u=0):
            self.x = p.f(self.x)

    ekf = with_prior(Ekf(dim_x=p.n, dim_z=p.m), p)
    rows = []
    for k, z in enumerate(zs):
        ekf.update(z, HJacobian=p.hjac, Hx=p.h, residual=p.residual)
        record_update(rows, k, z, ekf, p.m)
        ekf.F = p.fjac(ekf.x)
        ekf.predict()
    return rows


def run_ukf(p, zs, alpha, beta, kappa):
    pts = MerweScaledSigmaPoints(p.n, alpha=alpha, beta=beta, kappa=kappa)
    ukf = UnscentedKalmanFilter(dim_x=p.n, dim_z=p.m, dt=p.dt, hx=p.h,
                                fx=lambda x, dt: p.f(x), points=pts,
                                residual_z=p.residual)
    with_prior(ukf, p)
    rows = []
    for k, z in enumerate(zs):
        ukf.sigmas_f = pts.sigma_points(ukf.x, ukf.P)  # redraw from the prior
        ukf.update(z)
        record_update(rows, k, z, ukf, p.m)
        ukf.predict()
    return rows


def main():
    merwe_cases()
    for name, p, seed in [("rangebearing", RangeBearing(), 7), ("pendulum", Pendulum(), 8)]:
        zs = simulate(p, seed)
        write(f"nl_{name}_ekf.csv", p, run_ekf(p, zs))
        write(f"nl_{name}_ukf_merwe.csv", p, run_ukf(p, zs, 0.5, 2.0, 3.0 - p.n))
        write(f"nl_{name}_ukf_cubature.csv", p, run_ukf(p, zs, 1.0, 0.0, 0.0))


if __name__ == "__main__":
    main()
