"""The engine's whole-series functions and Riccati solvers from Python, against FilterPy and
SciPy (independent implementations of the same equations)."""

import numpy as np
import pytest
import scipy.linalg
from filterpy.kalman import KalmanFilter as FpKalmanFilter

import launch_estimation as le
from problems import problem, setup

# The engine factors S by Cholesky with its own summation order; 1e-9 relative covers the
# rounding of 40 steps on these well-conditioned problems and still catches any formula slip.
TOL = 1e-9


def fp_update_first(pr):
    """FilterPy with the engine's step order: update with z_k, then predict with u_k."""
    kf = setup(FpKalmanFilter, pr, 0 if pr["B"] is None else pr["B"].shape[1])
    us = None if pr["us"] is None else list(pr["us"])
    return kf.batch_filter(pr["zs"], us=us, update_first=True)


@pytest.mark.parametrize("n,m,p", [(2, 1, 0), (4, 2, 1), (6, 3, 2)])
def test_filter_matches_filterpy(n, m, p):
    pr = problem(400 + n, n, m, p, missing=0.2)
    zs = np.array([np.full(m, np.nan) if z is None else z.ravel() for z in pr["zs"]])
    us = None if pr["us"] is None else pr["us"][:, :, 0]
    out = le.filter(pr["F"], pr["H"], pr["Q"], pr["R"], pr["x0"].ravel(), pr["P0"], zs,
                    us=us, B=pr["B"])
    means, covs, means_p, covs_p = fp_update_first(pr)
    np.testing.assert_allclose(out["x"], means[:, :, 0], rtol=TOL, atol=TOL)
    np.testing.assert_allclose(out["P"], covs, rtol=TOL, atol=TOL)
    np.testing.assert_allclose(out["x_pred"], means_p[:, :, 0], rtol=TOL, atol=TOL)
    np.testing.assert_allclose(out["P_pred"], covs_p, rtol=TOL, atol=TOL)
    missing = np.isnan(zs).all(axis=1)
    assert np.all(np.isnan(out["nis"][missing]))
    assert np.all(out["log_likelihood"][missing] == 0.0)


def test_smooth_matches_filterpy_rts():
    pr = problem(500, 3, 2)
    zs = np.array([z.ravel() for z in pr["zs"]])
    out = le.smooth(pr["F"], pr["H"], pr["Q"], pr["R"], pr["x0"].ravel(), pr["P0"], zs)
    means, covs, _, _ = fp_update_first(pr)
    kf = setup(FpKalmanFilter, pr)
    xs, ps, _, _ = kf.rts_smoother(means, covs)
    np.testing.assert_allclose(out["x"], xs[:, :, 0], rtol=TOL, atol=TOL)
    np.testing.assert_allclose(out["P"], ps, rtol=TOL, atol=TOL)


def test_square_root_smooth_matches_filterpy_rts():
    # form="sqrt": the square-root filter and the square-root backward pass (triangular
    # factors of the smoothed covariances); the same numbers as FilterPy's covariance-form
    # RTS smoother to round-off, and each P exactly symmetric.
    pr = problem(500, 3, 2)
    zs = np.array([z.ravel() for z in pr["zs"]])
    out = le.smooth(pr["F"], pr["H"], pr["Q"], pr["R"], pr["x0"].ravel(), pr["P0"], zs,
                    form="sqrt")
    means, covs, _, _ = fp_update_first(pr)
    kf = setup(FpKalmanFilter, pr)
    xs, ps, _, _ = kf.rts_smoother(means, covs)
    np.testing.assert_allclose(out["x"], xs[:, :, 0], rtol=TOL, atol=TOL)
    np.testing.assert_allclose(out["P"], ps, rtol=TOL, atol=TOL)
    assert np.array_equal(out["P"], np.transpose(out["P"], (0, 2, 1)))
    assert min(np.linalg.eigvalsh(P).min() for P in out["P"]) > 0.0


def test_dare_dlqr_care_match_scipy():
    pr = problem(600, 4, 2)
    F, H, Q, R = pr["F"], pr["H"], pr["Q"], pr["R"]
    ref = scipy.linalg.solve_discrete_are(F.T, H.T, Q, R)
    out = le.dare(F, H, Q, R)
    np.testing.assert_allclose(out["P"], ref, rtol=1e-9, atol=1e-12)
    K = ref @ H.T @ np.linalg.inv(H @ ref @ H.T + R)
    np.testing.assert_allclose(out["K"], K, rtol=1e-8, atol=1e-12)
    B = np.random.default_rng(1).standard_normal((4, 2))
    lqr = le.dlqr(F, B, Q, R)
    Pl = scipy.linalg.solve_discrete_are(F, B, Q, R)
    np.testing.assert_allclose(lqr["P"], Pl, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(lqr["K"], np.linalg.solve(R + B.T @ Pl @ B, B.T @ Pl @ F),
                               rtol=1e-8, atol=1e-12)
    A = F - np.eye(4)
    c = le.care(A, H, Q, R)
    Pc = scipy.linalg.solve_continuous_are(A.T, H.T, Q, R)
    np.testing.assert_allclose(c["P"], Pc, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize(
    "call,exc,name",
    [
        (lambda: le.filter(np.eye(2), np.ones((1, 2)), -np.eye(2), np.eye(1), np.zeros(2),
                           np.eye(2), np.zeros((3, 1))), ValueError, "Q"),
        (lambda: le.filter(np.eye(2), np.ones((2, 1)), np.eye(2), np.eye(1), np.zeros(2),
                           np.eye(2), np.zeros((3, 1))), ValueError, "H"),
        (lambda: le.filter(np.eye(2), np.ones((1, 2)), np.eye(2), np.eye(1), np.zeros(3),
                           np.eye(2), np.zeros((3, 1))), ValueError, "x0"),
        (lambda: le.filter(np.eye(2), np.ones((1, 2)), np.eye(2), np.eye(1), np.zeros(2),
                           np.eye(2), np.zeros((3, 1)), form="fast"), ValueError, "form"),
        (lambda: le.filter([[1.0]], np.ones((1, 1)), np.eye(1), np.eye(1), np.zeros(1),
                           np.eye(1), np.zeros(3)), TypeError, "F"),
        (lambda: le.smooth(np.eye(2), np.ones((1, 2)), np.eye(2), np.eye(1), np.zeros(2),
                           np.eye(2), np.zeros((0, 1))), ValueError, "smooth"),
        (lambda: le.dare(np.eye(2), np.ones((1, 2)), np.eye(2), np.array([[-1.0]])),
         ValueError, "R"),
        (lambda: le.dlqr(np.eye(2), np.ones((3, 1)), np.eye(2), np.eye(1)), ValueError, "B"),
        (lambda: le.care(np.eye(2), np.ones((1, 2)), np.eye(2), np.full((1, 1), np.inf)),
         ValueError, "R"),
    ],
)
def test_engine_bad_input(call, exc, name):
    with pytest.raises(exc) as info:
        call()
    msg = str(info.value)
    assert "\n" not in msg and name in msg, msg
