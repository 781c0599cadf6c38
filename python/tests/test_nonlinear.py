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


@pytest.mark.parametrize("points", ["merwe", "cubature"])
def test_ukf_on_a_linear_model_is_the_linear_filter(points):
    pr = problem(700, 3, 2, missing=0.2)
    zs = np.array([np.full(2, np.nan) if z is None else z.ravel() for z in pr["zs"]])
    f, h = linear(pr)
    args = (pr["Q"], pr["R"], pr["x0"].ravel(), pr["P0"], zs)
    ref = le.filter(pr["F"], pr["H"], *args)
    out = le.ukf(f, h, *args, points=points, alpha=1.0)
    # Sigma points propagate a linear map exactly: only rounding separates the two.
    for key in ["x", "P", "x_pred", "P_pred"]:
        np.testing.assert_allclose(out[key], ref[key], rtol=1e-9, atol=1e-10, err_msg=key)


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
