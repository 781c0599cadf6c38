"""launch_estimation's UnscentedKalmanFilter and sigma-point classes side by side with
FilterPy 2.0.0's (the venv's pinned version), on the same inputs.

Tolerances: both run the same arithmetic (the same Cholesky algorithm for the sigma points,
the same sums); they differ in the order of a few sums and in K, which is solved here with a
factor of S where FilterPy multiplies by inv(S). Those differences are a few ulps of the
quantities times the condition numbers of S and P (below 1e4 in these problems), so 1e-9
relative (with an absolute floor of 1e-9 of each quantity's scale) bounds them with room;
a wrong weight, sign or point shows up at 1e-3 or more.
"""

import copy
import pickle

import numpy as np
import pytest
from filterpy.common import Saver
from filterpy.kalman import JulierSigmaPoints as FpJulier
from filterpy.kalman import MerweScaledSigmaPoints as FpMerwe
from filterpy.kalman import SimplexSigmaPoints as FpSimplex
from filterpy.kalman import UnscentedKalmanFilter as FpUKF
from scipy.linalg import sqrtm

import launch_estimation as le

RTOL = 1e-9


def close(a, b, rtol=RTOL):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, (a.shape, b.shape)
    scale = max(np.abs(b).max(initial=0.0), 1e-300)
    np.testing.assert_allclose(a, b, rtol=rtol, atol=rtol * scale)


# FilterPy's radar example (its test_ukf.py): position, velocity, altitude; one range.
def fx_radar(x, dt):
    return np.array([x[0] + dt * x[1], x[1], x[2]])


def hx_radar(x):
    return np.array([np.sqrt(x[0] ** 2 + x[2] ** 2)])


def fx_radar_v(s, dt):
    out = s.copy()
    out[:, 0] += dt * s[:, 1]
    return out


def hx_radar_v(s):
    return np.sqrt(s[:, 0] ** 2 + s[:, 2] ** 2)


def radar_ranges(steps=80, seed=3):
    rng = np.random.default_rng(seed)
    t = np.arange(steps) * 0.05
    pos = 100.0 * t
    return np.sqrt(pos**2 + 1000.0**2) + rng.normal(0, 5, steps)


POINTS = {
    "merwe": (lambda m: m.MerweScaledSigmaPoints(3, 0.1, 2.0, 0.0)),
    "julier": (lambda m: m.JulierSigmaPoints(3, kappa=0.0)),
    "simplex": (lambda m: m.SimplexSigmaPoints(3)),
}


class FP:
    UnscentedKalmanFilter = FpUKF
    MerweScaledSigmaPoints = FpMerwe
    JulierSigmaPoints = FpJulier
    SimplexSigmaPoints = FpSimplex


def radar_pair(points, vectorized=False):
    out = []
    for mod in (le, FP):
        kw = {"vectorized": True} if (vectorized and mod is le) else {}
        fx, hx = (fx_radar_v, hx_radar_v) if kw else (fx_radar, hx_radar)
        kf = mod.UnscentedKalmanFilter(3, 1, 0.05, hx, fx, POINTS[points](mod), **kw)
        kf.x = np.array([0.0, 90.0, 1100.0])
        kf.P *= 100.0
        kf.Q *= 0.01
        kf.R = 10
        out.append(kf)
    return out


STEP_ATTRS = ("x", "P", "x_prior", "P_prior", "x_post", "P_post", "K", "y", "S", "SI",
              "sigmas_f", "sigmas_h")


@pytest.mark.parametrize("points", sorted(POINTS))
@pytest.mark.parametrize("vectorized", [False, True])
def test_radar_step_by_step(points, vectorized):
    ours, theirs = radar_pair(points, vectorized)
    for z in radar_ranges():
        ours.predict()
        theirs.predict()
        close(ours.x, theirs.x)
        close(ours.sigmas_f, theirs.sigmas_f)
        ours.update([z])
        theirs.update([z])
        for a in STEP_ATTRS:
            close(getattr(ours, a), getattr(theirs, a))
        for a in ("log_likelihood", "likelihood", "mahalanobis"):
            close(getattr(ours, a), getattr(theirs, a), rtol=1e-7)


@pytest.mark.parametrize("points", sorted(POINTS))
def test_sigma_points_and_weights(points):
    x = np.array([1.0, -2.0, 0.5])
    a = np.array([[2.0, 0.3, 0.1], [0.3, 1.0, -0.2], [0.1, -0.2, 0.5]])
    ours, theirs = POINTS[points](le), POINTS[points](FP)
    close(ours.Wm, theirs.Wm)
    close(ours.Wc, theirs.Wc)
    assert ours.num_sigmas() == theirs.num_sigmas()
    close(ours.sigma_points(x, a), theirs.sigma_points(x, a))
    close(ours.sigma_points(x, 4.0), theirs.sigma_points(x, 4.0))


def wrap_sub(a, b):
    d = np.subtract(a, b)
    d[..., 1] = (d[..., 1] + np.pi) % (2 * np.pi) - np.pi
    return d


@pytest.mark.parametrize("points", ["merwe", "simplex"])
def test_user_sqrt_and_subtract(points):
    x = np.array([1.0, 3.0, 0.5])
    a = np.diag([2.0, 1.0, 0.5]) + 0.1
    make = {
        "merwe": lambda m: m.MerweScaledSigmaPoints(3, 0.5, 2.0, 0.0, sqrt_method=sqrtm,
                                                    subtract=wrap_sub),
        "simplex": lambda m: m.SimplexSigmaPoints(3, sqrt_method=sqrtm, subtract=wrap_sub),
    }[points]
    close(make(le).sigma_points(x, a), make(FP).sigma_points(x, a))


# A bearing-range tracker whose second state and measurement are angles: the residual
# functions wrap them, the mean functions average them on the circle, state_add wraps.
def f_turn(x, dt):
    return np.array([x[0] + dt * x[2], x[1] + dt * 0.3, x[2]])


def h_turn(x):
    return np.array([x[0], x[1]])


def f_turn_v(s, dt):
    out = s.copy()
    out[:, 0] += dt * s[:, 2]
    out[:, 1] += dt * 0.3
    return out


def h_turn_v(s):
    return s[:, :2].copy()


def circ_mean(sigmas, Wm):
    x = np.dot(Wm, sigmas)
    x[1] = np.arctan2(np.dot(Wm, np.sin(sigmas[:, 1])), np.dot(Wm, np.cos(sigmas[:, 1])))
    return x


def circ_mean_z(sigmas, Wm):
    z = np.dot(Wm, sigmas)
    z[1] = np.arctan2(np.dot(Wm, np.sin(sigmas[:, 1])), np.dot(Wm, np.cos(sigmas[:, 1])))
    return z


def add_wrap(x, dx):
    s = np.add(x, dx)
    s[1] = (s[1] + np.pi) % (2 * np.pi) - np.pi
    return s


def turn_filters(vectorized):
    out = []
    for mod in (le, FP):
        kw = {"vectorized": True} if (vectorized and mod is le) else {}
        f, h = (f_turn_v, h_turn_v) if kw else (f_turn, h_turn)
        pts = mod.MerweScaledSigmaPoints(3, 0.3, 2.0, 0.0, subtract=wrap_sub)
        kf = mod.UnscentedKalmanFilter(3, 2, 0.5, h, f, pts, x_mean_fn=circ_mean,
                                       z_mean_fn=circ_mean_z, residual_x=wrap_sub,
                                       residual_z=wrap_sub, state_add=add_wrap, **kw)
        kf.x = np.array([0.0, 3.0, 1.0])
        kf.P = np.diag([1.0, 0.2, 0.5])
        kf.Q = np.diag([0.01, 0.001, 0.01])
        kf.R = np.diag([0.1, 0.01])
        out.append(kf)
    return out


@pytest.mark.parametrize("vectorized", [False, True])
def test_angles_with_user_functions(vectorized):
    ours, theirs = turn_filters(vectorized)
    rng = np.random.default_rng(5)
    for k in range(40):
        z = np.array([0.5 * k + rng.normal(0, 0.3), (3.0 + 0.15 * k + np.pi) % (2 * np.pi) - np.pi])
        ours.predict()
        theirs.predict()
        ours.update(z)
        theirs.update(z)
        for a in ("x", "P", "K", "y", "S"):
            close(getattr(ours, a), getattr(theirs, a))
    assert abs(ours.x[1]) <= np.pi  # the angle stayed wrapped across ±π


def linear_pair(points_of):
    dt = 0.1

    def fx(x, dt):
        F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1]], float)
        return F @ x

    def hx(x):
        return np.array([x[0], x[2]])

    out = []
    for mod in (le, FP):
        kf = mod.UnscentedKalmanFilter(4, 2, dt, hx, fx, points_of(mod))
        kf.x = np.array([-1.0, 1.0, -1.0, 1.0])
        kf.P *= 0.2
        kf.R *= 0.09
        kf.Q *= 0.001
        out.append(kf)
    return out


@pytest.mark.parametrize("points", ["merwe", "simplex"])
def test_batch_filter_and_rts_smoother(points):
    make = {"merwe": lambda m: m.MerweScaledSigmaPoints(4, 0.1, 2.0, -1.0),
            "simplex": lambda m: m.SimplexSigmaPoints(4)}[points]
    ours, theirs = linear_pair(make)
    rng = np.random.default_rng(7)
    zs = [np.array([0.1 * i, 0.1 * i]) + rng.normal(0, 0.3, 2) for i in range(60)]
    zs[5] = None  # a missing measurement
    Rs = [None] * 60
    Rs[9] = 0.5  # one step's R (a scalar: 0.5·I)
    Rs[10] = np.eye(2) * 2.0
    dts = [0.1] * 60
    dts[20] = 0.3
    m1, p1 = ours.batch_filter(zs, Rs=Rs, dts=dts)
    m2, p2 = theirs.batch_filter(zs, Rs=Rs, dts=dts)
    close(m1, m2)
    close(p1, p2)
    for a in STEP_ATTRS:
        close(getattr(ours, a), getattr(theirs, a))
    s1 = ours.rts_smoother(m1, p1)
    s2 = theirs.rts_smoother(m2, p2)
    for a, b in zip(s1, s2):
        close(a, b)
    # dts as one number for every step, as FilterPy takes it.
    for a, b in zip(ours.rts_smoother(m1, p1, dts=0.1), theirs.rts_smoother(m2, p2, dts=0.1)):
        close(a, b)


def test_rts_smoother_uses_each_steps_Q():
    # FilterPy's rts_smoother takes Qs but adds self.Q at every step; here Qs[k] is used, as
    # FilterPy documents. With Qs all equal to Q both agree; with a larger Qs they differ.
    ours, theirs = linear_pair(lambda m: m.MerweScaledSigmaPoints(4, 0.1, 2.0, -1.0))
    zs = [np.array([0.1 * i, 0.2 * i]) for i in range(30)]
    m1, p1 = ours.batch_filter(zs)
    m2, p2 = theirs.batch_filter(zs)
    same = ours.rts_smoother(m1, p1, Qs=[ours.Q] * 30)
    close(same[0], theirs.rts_smoother(m2, p2)[0])
    bigger = ours.rts_smoother(m1, p1, Qs=[ours.Q * 100] * 30)
    assert np.abs(bigger[1] - same[1]).max() > 1e-4


def test_batch_filter_with_a_saver_matches_filterpy():
    ours, theirs = radar_pair("julier")
    zs = radar_ranges(30)
    s1, s2 = Saver(ours), Saver(theirs)
    ours.batch_filter(zs, saver=s1)
    theirs.batch_filter(zs, saver=s2)
    s1.to_array()
    s2.to_array()
    for a in ("x", "P", "K", "y", "x_prior", "sigmas_f"):
        close(getattr(s1, a), getattr(s2, a))
    assert len(s1) == 30


def test_predict_and_update_arguments():
    ours, theirs = radar_pair("merwe")

    def fx_w(x, dt, w):
        return fx_radar(x, dt) * w

    def hx_b(x, bias):
        return hx_radar(x) + bias

    for kf in (ours, theirs):
        kf.predict(dt=0.1, fx=fx_w, w=1.001)
        kf.update([1101.0], R=4.0, hx=hx_b, bias=0.5)
    for a in STEP_ATTRS:
        close(getattr(ours, a), getattr(theirs, a))
    for kf in (ours, theirs):
        kf.compute_process_sigmas(0.2)
    close(ours.sigmas_f, theirs.sigmas_f)
    args = (ours.x, [1000.0], ours.sigmas_f, ours.sigmas_h)
    close(ours.cross_variance(*args), theirs.cross_variance(*args))
    for kf in (ours, theirs):
        kf.update(None)
    np.testing.assert_array_equal(ours.z, theirs.z)
    close(ours.x_post, theirs.x_post)


def test_in_place_edits_are_seen():
    ours, theirs = radar_pair("merwe")
    for kf in (ours, theirs):
        kf.Q[1, 1] = 0.5  # edit of the attribute's array
        kf.x[0] += 3.0
        kf.predict()
    close(ours.P, theirs.P)
    close(ours.x, theirs.x)


def test_a_user_transform():
    from filterpy.kalman import unscented_transform

    ours, theirs = radar_pair("merwe")
    for kf in (ours, theirs):
        kf.predict(UT=unscented_transform)
        kf.update([1100.0], UT=unscented_transform)
    for a in STEP_ATTRS:
        close(getattr(ours, a), getattr(theirs, a))


def test_copies_and_pickles_keep_everything():
    kf, _ = radar_pair("julier")
    kf.predict()
    kf.update([1101.0])
    for other in (copy.copy(kf), copy.deepcopy(kf), pickle.loads(pickle.dumps(kf))):
        assert type(other) is le.UnscentedKalmanFilter
        for a in STEP_ATTRS + ("Q", "R", "Wm", "Wc"):
            np.testing.assert_array_equal(np.asarray(getattr(other, a)), np.asarray(getattr(kf, a)))
        assert other.log_likelihood == kf.log_likelihood
        other.predict()
        other.update([1102.0])
    deep = copy.deepcopy(kf)
    deep.x[0] = 123.0
    assert kf.x[0] != 123.0
    pts = pickle.loads(pickle.dumps(le.MerweScaledSigmaPoints(3, 0.1, 2.0, 0.0)))
    close(pts.Wc, FpMerwe(3, 0.1, 2.0, 0.0).Wc)


def test_repr_and_dict():
    kf, _ = radar_pair("simplex")
    text = repr(kf)
    assert text.startswith("UnscentedKalmanFilter object") and "sigmas_f" in text
    assert {"x", "P", "Q", "R", "fx", "hx", "points_fn", "Wm", "Wc"} <= set(kf.__dict__)
    assert repr(le.SimplexSigmaPoints(2)).startswith("SimplexSigmaPoints object")
