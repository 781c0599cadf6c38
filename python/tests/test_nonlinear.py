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


def _qmul(a, b):
    """Hamilton product, scalar first (written here, independently of the module)."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])


def _qexp(v):
    t = np.linalg.norm(v)
    if t < 1e-12:
        return np.array([1.0, *(0.5 * v)])
    return np.array([np.cos(t / 2), *(np.sin(t / 2) * v / t)])


def _to_body(q, v):
    qc = q * np.array([1, -1, -1, -1])
    return _qmul(_qmul(qc, np.array([0.0, *v])), q)[1:]


def _attitude_flight(seed=3, steps=500, dt=0.02):
    """A constant tumble at 1.2 rad/s (past 180° several times), gyro with a bias, the
    vertical and an inclined field seen in the body frame every fifth step."""
    rng = np.random.default_rng(seed)
    w = np.array([0.4, -0.7, 0.9]) * 1.2 / np.linalg.norm([0.4, -0.7, 0.9])
    bias = np.array([0.01, -0.02, 0.005])
    refs = [np.array([0.0, 0.0, 1.0]), np.array([0.5, 0.0, np.sqrt(0.75)])]
    q = np.array([1.0, 0.0, 0.0, 0.0])
    truth, gyro, zs = [], [], []
    for k in range(steps):
        truth.append(q)
        if k % 5 == 0:
            z = np.concatenate([_to_body(q, r) for r in refs]) + 0.02 * rng.standard_normal(6)
        else:
            z = np.full(6, np.nan)
        zs.append(z)
        gyro.append(w + bias + 0.01 * rng.standard_normal(3))
        q = _qmul(q, _qexp(w * dt))
        q /= np.linalg.norm(q)

    def f(x, u, k):
        qn = _qmul(x[:4], _qexp((u - x[4:]) * dt))
        return np.concatenate([qn, x[4:]])

    def h(x, k):
        return np.concatenate([_to_body(x[:4], r) for r in refs])

    Q = np.diag([(0.01 * dt) ** 2] * 3 + [1e-10] * 3)
    R = 0.02 ** 2 * np.eye(6)
    x0 = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    P0 = np.diag([0.1 ** 2] * 3 + [0.03 ** 2] * 3)
    return np.array(truth), np.array(gyro), np.array(zs), f, h, Q, R, x0, P0, bias


@pytest.mark.parametrize("run", ["ukf", "sqrt", "ekf"])
def test_a_quaternion_state_stays_unit_and_tracks_a_tumble(run):
    truth, gyro, zs, f, h, Q, R, x0, P0, bias = _attitude_flight()
    args = (f, h, Q, R, x0, P0, zs)
    if run == "ekf":
        out = le.ekf(*args, us=gyro, manifold=["quaternion", 3])
    else:
        form = "sqrt" if run == "sqrt" else "plain"
        out = le.ukf(*args, us=gyro, points="merwe", alpha=0.5, form=form,
                     manifold=["quaternion", 3])
    x, P = out["x"], out["P"]
    assert x.shape == (len(zs), 7) and P.shape == (len(zs), 6, 6)
    # Every estimate is a unit quaternion (renormalised by ⊞ at each step).
    np.testing.assert_allclose(np.linalg.norm(x[:, :4], axis=1), 1.0, atol=1e-12)
    # Attitude error in the last second: the angle of q_true* ⊗ q̂, below 0.02 rad (the
    # fixes are 0.02 noisy unit vectors, two of them every 0.1 s).
    for k in range(len(zs) - 50, len(zs)):
        d = _qmul(truth[k] * np.array([1, -1, -1, -1]), x[k, :4])
        angle = 2 * np.arctan2(np.linalg.norm(d[1:]), abs(d[0]))
        assert angle < 0.02, (k, angle)
    # The bias is found within four of its posterior standard deviations.
    sd = np.sqrt(np.diag(P[-1])[3:])
    assert np.all(np.abs(x[-1, 4:] - bias) < 4 * sd), (x[-1, 4:], bias, sd)


def test_a_bad_manifold_is_a_value_error():
    truth, gyro, zs, f, h, Q, R, x0, P0, bias = _attitude_flight(steps=10)
    args = (f, h, Q, R, x0, P0, zs)
    for bad, what in [
        ("quaternion", "sequence"),
        (["quaternion", 0], "sequence"),
        (["quaternion", True], "sequence"),
        (["sphere", 3], "sequence"),
        ([], "sequence"),
        (["quaternion"], "tangent"),
    ]:
        with pytest.raises(ValueError, match=what):
            le.ukf(*args, us=gyro, manifold=bad)
    with pytest.raises(ValueError, match="x0"):
        le.ekf(f, h, Q, R, x0[:6], P0, zs, us=gyro, manifold=["quaternion", 3])
