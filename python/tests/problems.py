"""Random stable linear-Gaussian problems shared by the tests (seeded, several sizes)."""

import numpy as np


def spd(rng, k, scale=1.0):
    """A random symmetric positive-definite k×k matrix."""
    a = rng.standard_normal((k, k))
    return scale * (a @ a.T / k + 0.1 * np.eye(k))


def problem(seed, n, m, p=0, steps=40, missing=0.0):
    """A stable (F, B, H, Q, R, x0, P0) with simulated measurements zs (N, m) and inputs us.

    `missing` is the fraction of whole measurement vectors replaced by None (FilterPy's way
    to skip an update).
    """
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    F = 0.9 * a / max(abs(np.linalg.eigvals(a)))
    H = rng.standard_normal((m, n))
    Q = spd(rng, n, 0.1)
    R = spd(rng, m, 0.5)
    B = rng.standard_normal((n, p)) if p else None
    x0 = rng.standard_normal((n, 1))
    P0 = spd(rng, n, 2.0)
    us = rng.standard_normal((steps, p, 1)) if p else None
    x = x0.copy()
    zs = []
    for k in range(steps):
        x = F @ x + (B @ us[k] if p else 0) + rng.multivariate_normal(np.zeros(n), Q)[:, None]
        z = H @ x + rng.multivariate_normal(np.zeros(m), R)[:, None]
        zs.append(None if rng.random() < missing else z)
    return dict(F=F, B=B, H=H, Q=Q, R=R, x0=x0, P0=P0, zs=zs, us=us)


def setup(cls, pr, dim_u=0):
    """A filter of class `cls` (FilterPy's or ours) set up from problem `pr`."""
    n, m = pr["F"].shape[0], pr["H"].shape[0]
    kf = cls(n, m, dim_u)
    kf.x = pr["x0"].copy()
    kf.P = pr["P0"].copy()
    kf.F = pr["F"].copy()
    kf.H = pr["H"].copy()
    kf.Q = pr["Q"].copy()
    kf.R = pr["R"].copy()
    if pr["B"] is not None:
        kf.B = pr["B"].copy()
    return kf
