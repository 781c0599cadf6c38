"""EKF and UKF over Python callables: on a linear model both must reproduce the linear
filter (the UKF exactly, the EKF up to its central-difference Jacobians), and errors raised
by the callables come back as they are."""

import numpy as np
import pytest

import launch_estimation as le
from problems import problem


def linear(pr):
    F, H = pr["F"], pr["H"]
    return (lambda x, u, k: F @ x), (lambda x, k: H @ x)


@pytest.mark.parametrize("form", ["plain", "sqrt"])
@pytest.mark.parametrize("points", ["merwe", "cubature"])
def test_ukf_on_a_linear_model_is_the_linear_filter(points, form):
    pr = problem(700, 3, 2, missing=0.2)
    zs = np.array([np.full(2, np.nan) if z is None else z.ravel() for z in pr["zs"]])
    f, h = linear(pr)
    args = (pr["Q"], pr["R"], pr["x0"].ravel(), pr["P0"], zs)
    ref = le.filter(pr["F"], pr["H"], *args)
    out = le.ukf(f, h, *args, points=points, alpha=1.0, form=form)
    # Sigma points propagate a linear map exactly: only rounding separates the two.
    for key in ["x", "P", "x_pred", "P_pred"]:
        np.testing.assert_allclose(out[key], ref[key], rtol=1e-9, atol=1e-10, err_msg=key)


@pytest.mark.parametrize("points", ["merwe", "cubature"])
def test_the_square_root_ukf_is_the_ukf_on_a_nonlinear_model(points):
    """A range-bearing tracker: the square-root filter carries factors instead of
    covariances and agrees with the plain one to rounding (1e-9 relative)."""
    rng = np.random.default_rng(5)
    dt = 1.0
    F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1.0]])
    truth = np.array([[100.0 + 5 * k, 5.0, 200.0 - 3 * k, -3.0] for k in range(40)])
    zs = np.array([[np.hypot(t[0], t[2]), np.arctan2(t[2], t[0])] for t in truth])
    zs += rng.standard_normal(zs.shape) * [1.0, 0.01]

    def f(x, u, k):
        return F @ x

    def h(x, k):
        return np.array([np.hypot(x[0], x[2]), np.arctan2(x[2], x[0])])

    args = (np.eye(4) * 0.01, np.diag([1.0, 1e-4]), truth[0] + 1.0, np.eye(4) * 4.0, zs)
    plain = le.ukf(f, h, *args, points=points, alpha=1.0)
    sqrt = le.ukf(f, h, *args, points=points, alpha=1.0, form="sqrt")
    for key in ["x", "P", "x_pred", "P_pred", "log_likelihood"]:
        np.testing.assert_allclose(sqrt[key], plain[key], rtol=1e-9, atol=1e-9, err_msg=key)
    with pytest.raises(ValueError, match="form"):
        le.ukf(f, h, *args, form="cholesky")


def test_ekf_on_a_linear_model_is_the_linear_filter():
    pr = problem(701, 4, 2)
    zs = np.array([z.ravel() for z in pr["zs"]])
    f, h = linear(pr)
    args = (pr["Q"], pr["R"], pr["x0"].ravel(), pr["P0"], zs)
    ref = le.filter(pr["F"], pr["H"], *args)
    out = le.ekf(f, h, *args)
    # Central differences of a linear map are exact up to rounding/step ≈ 1e-16/6e-6.
    for key in ["x", "P"]:
        np.testing.assert_allclose(out[key], ref[key], rtol=1e-7, atol=1e-8, err_msg=key)
    np.testing.assert_allclose(out["log_likelihood"], ref["log_likelihood"], rtol=1e-7)


def test_callable_errors():
    pr = problem(702, 2, 1)
    zs = np.array([z.ravel() for z in pr["zs"]])
    args = (pr["Q"], pr["R"], pr["x0"].ravel(), pr["P0"], zs)

    class Boom(Exception):
        pass

    def bad_f(x, u, k):
        raise Boom("f failed")

    with pytest.raises(Boom, match="f failed"):
        le.ukf(bad_f, lambda x, k: x[:1], *args)
    with pytest.raises(ValueError, match=r"h\(x, k\)"):
        le.ekf(lambda x, u, k: x, lambda x, k: np.zeros(3), *args)
    with pytest.raises(TypeError, match="f must be callable"):
        le.ukf(3, lambda x, k: x[:1], *args)
    with pytest.raises(ValueError, match="points"):
        le.ukf(lambda x, u, k: x, lambda x, k: x[:1], *args, points="julier")
