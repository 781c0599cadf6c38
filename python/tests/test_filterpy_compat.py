"""launch_estimation.KalmanFilter against FilterPy's KalmanFilter on random stable problems.

Both compute the same formulas in the same order up to the solve (FilterPy forms inv(S); we
solve with a Cholesky factor of S), so on these well-conditioned problems (cond(S) below
~1e4) they agree to a few hundred ulps over 40 steps: 1e-10 leaves a wide margin while still
catching any formula difference, which shows at 1e-3 or more.
"""

import functools

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter as FpKalmanFilter

import compare
import launch_estimation as le
from problems import problem, setup

TOL = 1e-10
SIZES = [(1, 1, 0), (2, 1, 1), (3, 2, 0), (4, 3, 2), (7, 2, 1), (5, 5, 0), (9, 2, 0), (10, 4, 1)]


close = functools.partial(compare.close, tol=TOL)


@pytest.mark.parametrize("n,m,p", SIZES)
@pytest.mark.parametrize("missing", [0.0, 0.25])
def test_batch_filter_and_smoother(n, m, p, missing):
    pr = problem(10 * n + m + p, n, m, p, missing=missing)
    ours, theirs = setup(le.KalmanFilter, pr, p), setup(FpKalmanFilter, pr, p)
    us = None if pr["us"] is None else pr["us"]
    a = ours.batch_filter(pr["zs"], us=us)
    b = theirs.batch_filter(pr["zs"], us=None if us is None else list(us))
    for x, y, what in zip(a, b, ["means", "covariances", "means_p", "covariances_p"]):
        close(x, y, what)
    close(ours.x, theirs.x, "x after batch_filter")
    close(ours.P, theirs.P, "P after batch_filter")
    sa = ours.rts_smoother(a[0], a[1])
    sb = theirs.rts_smoother(b[0], b[1])
    for x, y, what in zip(sa, sb, ["x", "P", "K", "Pp"]):
        close(x, y, f"rts_smoother {what}")


@pytest.mark.parametrize("n,m,p", SIZES)
def test_per_step_predict_update(n, m, p):
    pr = problem(100 + n + m + p, n, m, p, missing=0.2)
    ours, theirs = setup(le.KalmanFilter, pr, p), setup(FpKalmanFilter, pr, p)
    for k, z in enumerate(pr["zs"]):
        u = None if pr["us"] is None else pr["us"][k]
        ours.predict(u)
        theirs.predict(u)
        close(ours.x, theirs.x, f"prior x at {k}")
        close(ours.P, theirs.P, f"prior P at {k}")
        close(ours.x_prior, theirs.x_prior, f"x_prior at {k}")
        ours.update(z)
        theirs.update(z)
        for name in ["x", "P", "K", "y", "S", "SI", "x_post", "P_post"]:
            close(getattr(ours, name), getattr(theirs, name), f"{name} at {k}")
        close(ours.log_likelihood, theirs.log_likelihood, f"log_likelihood at {k}")
        close(ours.likelihood, theirs.likelihood, f"likelihood at {k}")
        close(ours.mahalanobis, theirs.mahalanobis, f"mahalanobis at {k}")


@pytest.mark.parametrize("n,m", [(2, 1), (4, 2), (6, 3)])
def test_update_correlated(n, m):
    pr = problem(200 + n, n, m)
    rng = np.random.default_rng(n)
    ours, theirs = setup(le.KalmanFilter, pr), setup(FpKalmanFilter, pr)
    lr = np.linalg.cholesky(pr["R"])
    for k, z in enumerate(pr["zs"]):
        ours.predict()
        theirs.predict()
        # A valid cross-covariance: M = 0.5 Lp W Lrᵀ with ‖W‖₂ ≤ 1 keeps [[P, M], [Mᵀ, R]]
        # positive semi-definite, so S stays positive definite.
        w = rng.standard_normal((n, m))
        w /= np.linalg.norm(w, 2)
        M = 0.5 * np.linalg.cholesky(theirs.P) @ w @ lr.T
        ours.M, theirs.M = M.copy(), M.copy()
        ours.update_correlated(z)
        theirs.update_correlated(z)
        for name in ["x", "P", "K", "y", "S"]:
            close(getattr(ours, name), getattr(theirs, name), f"{name} at {k}")
        close(ours.log_likelihood, theirs.log_likelihood, f"log_likelihood at {k}")


@pytest.mark.parametrize("n,m", [(3, 2), (5, 4)])
def test_missing_rows_equal_reduced_update(n, m):
    """A NaN entry drops its row: the same as FilterPy updating with the other rows' H, R."""
    pr = problem(300 + n, n, m)
    ours, theirs = setup(le.KalmanFilter, pr), setup(FpKalmanFilter, pr)
    rng = np.random.default_rng(m)
    for k, z in enumerate(pr["zs"]):
        ours.predict()
        theirs.predict()
        keep = rng.random(m) < 0.6
        keep[k % m] = True
        zn = z.copy()
        zn[~keep] = np.nan
        ours.update(zn)
        idx = np.flatnonzero(keep)
        theirs.update(z[idx], R=pr["R"][np.ix_(idx, idx)], H=pr["H"][idx])
        close(ours.x, theirs.x, f"x at {k}")
        close(ours.P, theirs.P, f"P at {k}")
        close(ours.log_likelihood, theirs.log_likelihood, f"log_likelihood at {k}")
        close(ours.K[:, idx], theirs.K, f"K at {k}")
        assert np.all(ours.K[:, ~keep] == 0.0)


def test_update_first_and_1d_state():
    pr = problem(7, 3, 1)
    ours, theirs = setup(le.KalmanFilter, pr), setup(FpKalmanFilter, pr)
    a = ours.batch_filter(pr["zs"], update_first=True)
    b = theirs.batch_filter(pr["zs"], update_first=True)
    for x, y in zip(a, b):
        close(x, y, "update_first")
    ours, theirs = setup(le.KalmanFilter, pr), setup(FpKalmanFilter, pr)
    ours.x, theirs.x = pr["x0"].ravel(), pr["x0"].ravel()
    zs = [None if z is None else float(z[0, 0]) for z in pr["zs"]]
    a, b = ours.batch_filter(zs), theirs.batch_filter(zs)
    for x, y in zip(a, b):
        close(x, y, "1-d state")


def test_attributes_behave_like_filterpy():
    pr = problem(9, 2, 1)
    kf = setup(le.KalmanFilter, pr)
    fp = setup(FpKalmanFilter, pr)
    # Shapes of the defaults.
    fresh = le.KalmanFilter(3, 2, 1)
    ref = FpKalmanFilter(3, 2, 1)
    for name in ["x", "P", "F", "H", "Q", "R", "M", "K", "y", "S"]:
        assert getattr(fresh, name).shape == getattr(ref, name).shape, name
    assert fresh.B is None and ref.B is None
    # The same object on repeated reads; in-place edits reach the filter.
    assert kf.x is kf.x
    kf.x[0] = 3.0
    fp.x[0] = 3.0
    kf.P *= 10.0
    fp.P *= 10.0
    kf.F[0, 1] = 0.25
    fp.F[0, 1] = 0.25
    xs, ps = [], []
    for z in pr["zs"][:5]:
        kf.predict()
        fp.predict()
        kf.update(z)
        fp.update(z)
        xs.append(kf.x)
        ps.append(fp.x)
    # Arrays handed out earlier are snapshots.
    close(np.array(xs), np.array(ps), "snapshots")
    kf.alpha = 1.02
    fp.alpha = 1.02
    kf.predict()
    fp.predict()
    close(kf.P, fp.P, "fading memory")
    kf.R = 5.0  # a scalar means 5·I (FilterPy broadcasts; the same for dim_z = 1)
    assert kf.R.shape == (1, 1) and kf.R[0, 0] == 5.0


def test_panic_becomes_runtime_error():
    with pytest.raises(RuntimeError, match="internal error"):
        le._panic_for_test()
