"""Golden data for Julier's and the simplex sigma-point sets and for the fixed-lag smoother,
from FilterPy 1.4.5 (an independent implementation).

Run in a throwaway venv:
    python3 -m venv /tmp/venv-x && /tmp/venv-x/bin/pip install filterpy==1.4.5 numpy scipy
    /tmp/venv-x/bin/python kalman/tests/golden/make_sigma_fixed_lag.py
Writes, next to this script:
- sigma_sets.csv: JulierSigmaPoints and SimplexSigmaPoints points and weights, long format
  `case,set,n,kappa,what,i,j,value` with what in {x, P, sigma, Wm, Wc} (sigma is n x N,
  column j the j-th point in FilterPy's order). FilterPy's simplex multiplies its unit
  simplex by the *upper* Cholesky factor U (U^T U = P), so its points have covariance U U^T,
  not P, unless P is diagonal; the simplex cases here pass `sqrt_method` returning the lower
  factor L (L L^T = P), with which FilterPy's points have covariance P. One case with a
  diagonal P uses FilterPy's default square root (where U = L).
- fixed_lag.csv: a constant-velocity model measured in position (and, with missing
  entries, nothing), filtered and smoothed with lag L: `k,z,what,i,value` with what in
  {xf (x_{k|k}), lag (x_{k-L|k}, from step L on), rts (x_{k|N-1}), filterpy (FilterPy's
  xSmooth[k] after the last step)}.

The fixed-lag reference is the augmented-state smoother FilterPy's FixedLagSmoother
implements (Simon, "Optimal State Estimation", section 9.2) with the cross-covariances
cov(x_{k-i}, x_k | z_0..z_{k-1}) carried from step to step. FilterPy 1.4.5 recomputes them
within each step from the current posterior P, which is not the same recursion: its
estimates differ from the RTS smoother's (printed below), so they are kept in the file for
the record and the Rust test compares with the carried recursion, which the script checks
against a Rauch-Tung-Striebel smoother over each prefix of the data (to 1e-12).

Conventions matched to the Rust filters: FilterPy's `smooth(z)` predicts first, so its
prior is x_{-1}; the Rust prior of the first measurement is x0 = F x_{-1},
P0 = F P_{-1} F^T + Q, written into the file as `x0`/`P0` rows (k = -1).
"""

import numpy as np
from filterpy.kalman import FixedLagSmoother, JulierSigmaPoints, SimplexSigmaPoints
from scipy.linalg import cholesky

from sigma_rows import r, random_mean_cov, sigma_rows, write_csv


def sigma_cases():
    rng = np.random.default_rng(20261202)
    rows = []
    cases = [("julier", 1, 2.0), ("julier", 3, 0.0), ("julier", 4, -1.0), ("julier", 6, 0.5),
             ("simplex", 1, 0.0), ("simplex", 2, 0.0), ("simplex", 4, 0.0),
             ("simplex", 7, 0.0), ("simplex_diag", 3, 0.0)]
    for c, (name, n, kappa) in enumerate(cases):
        x, P = random_mean_cov(rng, n)
        if name == "julier":
            pts = JulierSigmaPoints(n, kappa=kappa)
        elif name == "simplex":
            pts = SimplexSigmaPoints(n, sqrt_method=lambda a: cholesky(a, lower=True))
        else:
            P = np.diag(np.diag(P))
            pts = SimplexSigmaPoints(n)
        sig = pts.sigma_points(x, P)  # N x n
        d = sig - x
        assert np.allclose(d.T @ np.diag(pts.Wc) @ d, P, atol=1e-12)
        rows += sigma_rows([c, name.split("_")[0], n, r(kappa)], x, P, sig, pts)
    write_csv("sigma_sets.csv", ["case", "set", "n", "kappa", "what", "i", "j", "value"], rows)


def fixed_lag():
    rng = np.random.default_rng(20261203)
    dt, N, L = 0.5, 40, 5
    F = np.array([[1.0, dt], [0.0, 1.0]])
    H = np.array([[1.0, 0.0]])
    Q = 0.2 * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    R = np.array([[0.3]])
    xm1, Pm1 = np.array([0.0, 1.0]), np.diag([1.0, 0.5])
    truth = np.array([0.0, 1.0])
    zs = []
    for _ in range(N):
        truth = F @ truth + rng.multivariate_normal(np.zeros(2), Q)
        zs.append(np.array([truth[0] + np.sqrt(R[0, 0]) * rng.normal()]))

    fls = FixedLagSmoother(2, 1, N=L)
    fls.F, fls.H, fls.Q, fls.R = F.copy(), H.copy(), Q.copy(), R.copy()
    fls.x, fls.P = xm1.reshape(2, 1).copy(), Pm1.copy()
    for z in zs:
        fls.smooth(z.reshape(1, 1))
    filterpy = [v.ravel() for v in fls.xSmooth]

    # The filter (update, then predict) and the RTS smoother over a prefix.
    x, P = F @ xm1, F @ Pm1 @ F.T + Q
    x0, P0 = x.copy(), P.copy()
    xf, Pf, xp, Pp = [], [], [], []
    for z in zs:
        S = H @ P @ H.T + R
        K = np.linalg.solve(S, H @ P).T
        x = x + K @ (z - H @ x)
        P = (np.eye(2) - K @ H) @ P @ (np.eye(2) - K @ H).T + K @ R @ K.T
        xf.append(x), Pf.append(P)
        x, P = F @ x, F @ P @ F.T + Q
        xp.append(x), Pp.append(P)

    def rts(last):
        out = [None] * (last + 1)
        out[last] = xf[last]
        for k in range(last - 1, -1, -1):
            J = np.linalg.solve(Pp[k], F @ Pf[k]).T
            out[k] = xf[k] + J @ (out[k + 1] - xp[k])
        return out

    # The augmented-state fixed-lag smoother, cross-covariances carried across steps.
    x, P = x0.copy(), P0.copy()
    est, cross, lag = [], [], {}
    for k, z in enumerate(zs):
        S = H @ P @ H.T + R
        y = z - H @ x
        K = np.linalg.solve(S, H @ P).T
        est.append(x.copy())
        cross = [P.copy()] + cross[:L]
        for i, c in enumerate(cross):
            est[k - i] = est[k - i] + np.linalg.solve(S, H @ c.T).T @ y
        A = F - F @ K @ H
        cross = [c @ A.T for c in cross]
        if k >= L:
            lag[k] = est[k - L].copy()
        x = x + K @ y
        P = (np.eye(2) - K @ H) @ P @ (np.eye(2) - K @ H).T + K @ R @ K.T
        x, P = F @ x, F @ P @ F.T + Q
    for k in range(L, N):
        assert np.abs(lag[k] - rts(k)[k - L]).max() < 1e-12
    full = rts(N - 1)
    dev = max(np.abs(filterpy[k] - full[k]).max() for k in range(N - L))
    print(f"FilterPy 1.4.5 FixedLagSmoother vs RTS (steps settled at lag {L}): {dev:.3g}")

    rows = []
    for i in range(2):
        rows.append([-1, "", "x0", i, r(x0[i])])
        for j in range(2):
            rows.append([-1, "", "P0", i + 2 * j, r(P0[i, j])])
    for k in range(N):
        for i in range(2):
            rows.append([k, r(zs[k][0]), "xf", i, r(xf[k][i])])
            rows.append([k, r(zs[k][0]), "rts", i, r(full[k][i])])
            rows.append([k, r(zs[k][0]), "filterpy", i, r(filterpy[k][i])])
            if k in lag:
                rows.append([k, r(zs[k][0]), "lag", i, r(lag[k][i])])
    write_csv("fixed_lag.csv", ["k", "z", "what", "i", "value"], rows)


if __name__ == "__main__":
    sigma_cases()
    fixed_lag()
