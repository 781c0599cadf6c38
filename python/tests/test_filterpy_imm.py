"""IMMEstimator: FilterPy's API, the mixing and moment matching in Rust.

What is checked, and against what:
- FilterPy 2.0.0's IMMEstimator over FilterPy's own KalmanFilters, side by side with this
  module's IMMEstimator over this module's KalmanFilters on the same data: x, P, the
  priors and posteriors, mu, cbar, omega and likelihood agree to 1e-9 relative (the two
  differ by the order of a few roundings: mu from logarithms here, from likelihoods there);
- the same estimator over FilterPy's filters (any object with FilterPy's interface is a
  mode), and mixing the two kinds;
- a tight covariance far from the origin (FilterPy's own IMM test: |x| ≈ 1e4, P = 1e-12 I):
  the combined P stays positive semi-definite and equals the two-pass moment formula
  written here in NumPy;
- copies and pickles, Saver, and every refusal (misshapen banks, bad M and mu, a failing
  filter, Ctrl-C) leaving the estimator and its filters as they were.
"""

import copy
import functools
import pickle

import numpy as np
import pytest
from filterpy.common import Saver
from filterpy.kalman import IMMEstimator as FpIMM
from filterpy.kalman import KalmanFilter as FpKF

import compare
import launch_estimation as le

TOL = 1e-9
TRANS = np.array([[0.97, 0.03], [0.03, 0.97]])


close = functools.partial(compare.close, tol=TOL)


def bank(cls, far=False):
    """A constant-velocity and a constant-acceleration mode in 2-D (FilterPy's IMM test,
    the CV mode as a CA model without acceleration noise)."""
    dt = 1.0
    F = np.array(
        [
            [1, dt, dt**2 / 2, 0, 0, 0],
            [0, 1, dt, 0, 0, 0],
            [0, 0, 1, 0, 0, 0],
            [0, 0, 0, 1, dt, dt**2 / 2],
            [0, 0, 0, 0, 1, dt],
            [0, 0, 0, 0, 0, 1],
        ],
        float,
    )
    q = np.array([[0.05, 0.125, 1 / 6], [0.125, 1 / 3, 0.5], [1 / 6, 0.5, 1.0]]) * 1e-3
    ca, cv = cls(6, 2), cls(6, 2)
    for f in (ca, cv):
        f.F = F.copy()
        f.H = np.array([[1.0, 0, 0, 0, 0, 0], [0, 0, 0, 1.0, 0, 0]])
        f.x = np.array([[2000.0, 0, 0, 10000, -15, 0]]).T
        f.P = np.eye(6) * (1e-12 if far else 100.0)
        f.R = np.eye(2) * 100.0**2
    Q = np.zeros((6, 6))
    Q[0:3, 0:3] = q
    Q[3:6, 3:6] = q
    ca.Q = Q
    cv.Q = np.zeros((6, 6))
    return [ca, cv]


def measurements(steps=120, seed=3):
    rng = np.random.default_rng(seed)
    x = np.array([2000.0, 0, 10000, -15])
    out = []
    for k in range(steps):
        x = np.array([x[0] + x[1], x[1], x[2] + x[3], x[3]])
        if k >= 60:
            x = x + np.array([0.25, 0.5, 0.25, 0.5])
        out.append(np.array([[x[0] + 100 * rng.normal()], [x[2] + 100 * rng.normal()]]))
    return out


ATTRS = ("x", "P", "x_prior", "P_prior", "x_post", "P_post", "mu", "cbar", "omega", "likelihood")


@pytest.mark.parametrize("far", [False, True])
def test_matches_filterpy_step_by_step(far):
    ours = le.IMMEstimator(bank(le.KalmanFilter, far), (0.5, 0.5), TRANS)
    theirs = FpIMM(bank(FpKF, far), (0.5, 0.5), TRANS)
    for a in ATTRS:
        close(getattr(ours, a), getattr(theirs, a), f"initial {a}")
    for k, z in enumerate(measurements()):
        ours.update(z)
        theirs.update(z)
        ours.predict()
        theirs.predict()
        for a in ATTRS:
            close(getattr(ours, a), getattr(theirs, a), f"step {k}: {a}", tol=1e-8)
        for i in range(2):
            close(ours.filters[i].x, theirs.filters[i].x, f"step {k}: filter {i} x", tol=1e-8)


def test_a_bank_of_filterpy_filters_and_a_mixed_bank():
    zs = measurements(60)
    ref = FpIMM(bank(FpKF), (0.5, 0.5), TRANS)
    fp = le.IMMEstimator(bank(FpKF), (0.5, 0.5), TRANS)
    mine, theirs = bank(le.KalmanFilter), bank(FpKF)
    mixed = le.IMMEstimator([mine[0], theirs[1]], (0.5, 0.5), TRANS)
    for z in zs:
        for imm in (ref, fp, mixed):
            imm.predict()
            imm.update(z)
        close(fp.x, ref.x, "FilterPy filters: x", tol=1e-8)
        close(mixed.x, ref.x, "mixed bank: x", tol=1e-8)
        close(mixed.P, ref.P, "mixed bank: P", tol=1e-8)


def test_the_combined_covariance_is_the_two_pass_mixture():
    """Far from the origin with a tight P: the combined P against the two-pass formula in
    NumPy, and positive semi-definite (a one-pass second-moment form loses P ~ 1e-12
    under |x|² ~ 1e8)."""
    filters = bank(le.KalmanFilter, far=True)
    filters[1].x = filters[1].x + 1e-6
    imm = le.IMMEstimator(filters, (0.3, 0.7), TRANS)
    mu = np.array([0.3, 0.7])
    xs = [f.x for f in imm.filters]
    x = sum(m * xi for m, xi in zip(mu, xs))
    P = sum(m * ((xi - x) @ (xi - x).T + f.P) for m, xi, f in zip(mu, xs, imm.filters))
    close(imm.x, x, "x", tol=1e-15)
    np.testing.assert_allclose(imm.P, P, rtol=1e-12, atol=1e-27)
    assert np.linalg.eigvalsh(imm.P).min() > 0


def test_saver_copy_and_pickle():
    imm = le.IMMEstimator(bank(le.KalmanFilter), (0.5, 0.5), TRANS)
    s = Saver(imm)
    zs = measurements(10)
    for z in zs[:5]:
        imm.update(z)
        imm.predict()
        s.save()
    s.to_array()
    assert s.mu.shape == (5, 2) and s.x.shape == (5, 6, 1)
    deep, pick = copy.deepcopy(imm), pickle.loads(pickle.dumps(imm))
    shallow = copy.copy(imm)
    assert shallow.filters is imm.filters and deep.filters is not imm.filters
    for z in zs[5:]:
        for f in (imm, deep, pick):
            f.update(z)
            f.predict()
    for a in ATTRS:
        np.testing.assert_array_equal(getattr(deep, a), getattr(imm, a), err_msg=a)
        np.testing.assert_array_equal(getattr(pick, a), getattr(imm, a), err_msg=a)
    assert "IMMEstimator" in repr(imm) and "omega" in repr(imm)


def snapshot(imm):
    return {a: np.array(getattr(imm, a), copy=True) for a in ATTRS}, [
        (f.x.copy(), f.P.copy()) for f in imm.filters
    ]


def assert_unchanged(imm, before):
    attrs, filters = before
    for a in ATTRS:
        np.testing.assert_array_equal(getattr(imm, a), attrs[a], err_msg=a)
    for f, (x, P) in zip(imm.filters, filters):
        np.testing.assert_array_equal(f.x, x)
        np.testing.assert_array_equal(f.P, P)


@pytest.mark.parametrize(
    "filters, mu, M, message",
    [
        ("one", (0.5, 0.5), TRANS, "sequence of filters"),
        ("ints", (0.5, 0.5), TRANS, r"filters\[0\] is a int without an x"),
        ([], (0.5, 0.5), TRANS, "at least two"),
        (None, (0.5, 0.5), TRANS, "sequence of filters"),
        ("misshapen", (0.5, 0.5), TRANS, "same state dimension"),
        ("ok", (0.5,), TRANS, "mu has shape"),
        ("ok", (0.5, -0.5), TRANS, "non-negative"),
        ("ok", (0.0, 0.0), TRANS, "positive finite sum"),
        ("ok", (np.nan, 0.5), TRANS, "mu"),
        ("ok", (0.5, 0.5), np.eye(3), "M has shape"),
        ("ok", (0.5, 0.5), np.array([[0.9, 0.2], [0.1, 0.9]]), "row 0 of"),
        ("ok", (0.5, 0.5), np.array([[1.1, -0.1], [0.1, 0.9]]), "non-negative"),
        ("ok", (0.5, 0.5), np.array([[np.inf, 0.0], [0.1, 0.9]]), "M"),
        ("ok", (0.5, 0.5), "M", "M must be"),
    ],
)
def test_bad_construction_names_the_argument(filters, mu, M, message):
    if filters == "ok":
        filters = bank(le.KalmanFilter)
    elif filters == "misshapen":
        filters = [le.KalmanFilter(3, 1), le.KalmanFilter(2, 1)]
    elif filters == "one":
        filters = 1
    elif filters == "ints":
        filters = [1, 2]
    with pytest.raises((ValueError, TypeError), match=message):
        le.IMMEstimator(filters, mu, M)


class Failing(FpKF):
    """A FilterPy filter whose update or predict raises on demand."""

    fail = None

    def update(self, z, R=None, H=None):
        if self.fail == "update":
            raise self.error
        super().update(z, R, H)

    def predict(self, u=None, B=None, F=None, Q=None):
        if self.fail == "predict":
            raise self.error
        super().predict(u, B, F, Q)


@pytest.mark.parametrize("when", ["update", "predict"])
@pytest.mark.parametrize("error", [RuntimeError("boom"), KeyboardInterrupt()])
def test_a_failing_call_leaves_everything_as_it_was(when, error):
    """The first filter (the module's) steps, the second (a FilterPy subclass) raises: the
    error propagates and every filter and the estimator are as before the call."""
    mine = bank(le.KalmanFilter)[0]
    other = bank(Failing)[1]
    imm = le.IMMEstimator([mine, other], (0.5, 0.5), TRANS)
    zs = measurements(3)
    imm.update(zs[0])
    imm.predict()
    before = snapshot(imm)
    other.fail, other.error = when, error
    with pytest.raises(type(error)):
        if when == "update":
            imm.update(zs[1])
        else:
            imm.predict()
    assert_unchanged(imm, before)
    other.fail = None
    imm.update(zs[1])
    imm.predict()
    assert np.isfinite(imm.x).all()


class Zero(FpKF):
    """A filter that gives every measurement likelihood zero."""

    likelihood = property(lambda self: 0.0)
    log_likelihood = property(lambda self: -np.inf)


def test_no_positive_likelihood_is_refused():
    """Every filter gives z likelihood zero: a ValueError naming the likelihoods (FilterPy's
    μ becomes NaN), the estimator and the filters as they were."""
    imm = le.IMMEstimator(bank(Zero), (0.5, 0.5), TRANS)
    before = snapshot(imm)
    with pytest.raises(ValueError, match="positive finite likelihood"):
        imm.update(measurements(1)[0])
    assert_unchanged(imm, before)


def test_underflowing_likelihoods_still_separate_the_modes():
    """Both likelihoods underflow to 0 (FilterPy floors each at the smallest float, so its
    μ falls back to c̄); the log-likelihoods still tell the modes apart."""
    a, b = bank(le.KalmanFilter)
    b.R = b.R * 1e4
    imm = le.IMMEstimator([a, b], (0.5, 0.5), TRANS)
    imm.update(np.array([[2000.0 + 1e7], [10000.0]]))
    assert a.likelihood <= 1e-300 and b.likelihood <= 1e-300
    # The wide mode explains a 1e7 miss far better.
    assert imm.mu[1] > 1 - 1e-9
