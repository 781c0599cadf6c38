"""ExtendedKalmanFilter side by side with FilterPy's on its radar example (range to an
aircraft at constant velocity and altitude): update with HJacobian/Hx and their extra
arguments, a residual function and an R override, predict_update, predict_x, and copies.

Tolerance 1e-10 relative, as for KalmanFilter: the same formulas in the same order up to the
solve (FilterPy forms inv(S), we factor S)."""

import copy
import functools
import pickle

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter as FpEKF

import compare
import launch_estimation as le

TOL = 1e-10
DT = 0.05


close = functools.partial(compare.close, tol=TOL)


def HJacobian(x, scale=1.0):
    horiz, alt = x[0, 0], x[2, 0]
    d = np.hypot(horiz, alt)
    return scale * np.array([[horiz / d, 0.0, alt / d]])


def Hx(x, offset=0.0):
    return np.array([[np.hypot(x[0, 0], x[2, 0]) + offset]])


def radar(cls):
    f = cls(3, 1)
    f.x = np.array([[-10.0, 90.0, 1100.0]]).T
    f.F = np.eye(3) + np.array([[0, 1, 0], [0, 0, 0], [0, 0, 0]]) * DT
    f.R = np.array([[25.0]])
    f.Q = np.diag([0.1, 0.1, 0.01]) * DT
    f.P = f.P * 50
    return f


def ranges(steps=60, seed=3):
    rng = np.random.default_rng(seed)
    pos, vel, alt = 0.0, 100.0, 1000.0
    out = []
    for _ in range(steps):
        pos += vel * DT
        out.append(np.hypot(pos, alt) + 5 * rng.standard_normal())
    return out


ATTRS = ["x", "P", "K", "y", "S", "x_prior", "P_prior", "x_post", "P_post"]


@pytest.mark.parametrize("form", ["update", "update with args", "predict_update"])
def test_radar_as_filterpy(form):
    ours, theirs = radar(le.ExtendedKalmanFilter), radar(FpEKF)
    for k, r in enumerate(ranges()):
        for f in (ours, theirs):
            if form == "update":
                f.predict()
                f.update(np.array([r]), HJacobian, Hx)
            elif form == "update with args":
                f.predict()
                f.update(np.array([[r]]), HJacobian, Hx, R=30.0, args=(1.0,),
                         hx_args=0.5, residual=np.subtract)
            else:
                f.predict_update(np.array([r]), HJacobian, Hx)
        for name in ATTRS:
            close(getattr(ours, name), getattr(theirs, name), f"{form}: {name} at {k}")
        close(ours.log_likelihood, theirs.log_likelihood, f"{form}: log_likelihood at {k}")


def test_predict_x_and_skipped_update():
    ours, theirs = radar(le.ExtendedKalmanFilter), radar(FpEKF)
    for f in (ours, theirs):
        f.predict_x()
        f.update(None, HJacobian, Hx)
    close(ours.x, theirs.x, "x after predict_x")
    close(ours.P, theirs.P, "P after predict_x (unchanged)")
    close(ours.x_post, theirs.x_post, "x_post after a skipped update")


def test_copies_keep_the_class():
    f = radar(le.ExtendedKalmanFilter)
    f.predict()
    f.update(np.array([1100.0]), HJacobian, Hx)
    for dup in (copy.copy(f), copy.deepcopy(f), pickle.loads(pickle.dumps(f))):
        assert type(dup) is le.ExtendedKalmanFilter
        assert dup.x.tobytes() == f.x.tobytes() and dup.P.tobytes() == f.P.tobytes()
        assert dup.log_likelihood == f.log_likelihood


def test_bad_callables_are_named():
    f = radar(le.ExtendedKalmanFilter)
    with pytest.raises(TypeError, match="HJacobian"):
        f.update(np.array([1.0]), None, Hx)
    with pytest.raises(ValueError, match="HJacobian"):
        f.update(np.array([1.0]), lambda x: np.ones((2, 3)), Hx)
    with pytest.raises(ValueError, match="residual"):
        f.update(np.array([1.0]), HJacobian, Hx, residual=lambda a, b: np.ones(3))
    with pytest.raises(ZeroDivisionError):
        f.update(np.array([1.0]), HJacobian, lambda x: 1 / 0)
