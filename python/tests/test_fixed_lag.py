"""FixedLagSmoother: FilterPy's API over the crate's fixed-lag smoother.

What is checked, and against what:
- the filter it runs (x, P, y, S and smooth_batch's xhat) against FilterPy 2.0.0's
  FixedLagSmoother: the same predict and Joseph-form update, so 1e-10 relative;
- the smoothed estimates against two independent references: the full RTS smoother
  (KalmanFilter.rts_smoother) when the lag covers every step, the filter at lag 0, and at
  every lag the augmented-state form of the fixed-lag smoother (Simon, "Optimal State
  Estimation", 9.2), written below in NumPy with the cross-covariances carried from step to
  step. These agree to rounding (1e-9);
- FilterPy's own smoothed output is not these estimates (its lag 0 returns the predictions,
  a lag of at least the number of steps returns the filter, and between them it forms the
  gains from the updated covariance), so the smoothed outputs are compared with the
  references above and FilterPy's departures are pinned where they are exact.
"""

import functools

import numpy as np
import pytest

import compare
import launch_estimation as le

TOL = 1e-9


close = functools.partial(compare.close, tol=TOL)


def setup(f, column=True):
    """FilterPy's documented example: a constant-velocity track measured in position."""
    f.x = np.array([[0.0], [0.5]]) if column else np.array([0.0, 0.5])
    f.F = np.array([[1.0, 1.0], [0.0, 1.0]])
    f.H = np.array([[1.0, 0.0]])
    f.P *= 200.0
    f.R *= 5.0
    f.Q = np.array([[0.25, 0.5], [0.5, 1.0]]) * 0.01
    return f


def track(steps=40, seed=1):
    rng = np.random.default_rng(seed)
    return np.arange(steps) * 0.5 + rng.normal(scale=2.0, size=steps)


def simon(x, P, F, H, Q, R, zs, N, Fs=None, B=None, us=None):
    """The augmented-state fixed-lag smoother: with C_i = Cov(x_{k-i}, x_k | z_0..z_{k-1}),
    x_{k-i|k} = x_{k-i|k-1} + C_i Hᵀ S⁻¹ y_k for i = 0..N, and C_{i+1} at k + 1 is
    C_i (I - K H)ᵀ Fᵀ. Returns the estimates x_{j|min(j+N, last)}, shape (steps, n)."""
    x, P = np.asarray(x, float).reshape(-1), np.asarray(P, float)
    n, out, C = len(x), [], []
    for k, z in enumerate(zs):
        Fk = F if Fs is None else Fs[k]
        x, P = Fk @ x, Fk @ P @ Fk.T + Q
        if us is not None:
            x = x + B @ np.atleast_1d(us[k])
        C = [c @ Fk.T for c in C] + [None]  # the new step's C_0 is P_{k|k-1}
        C[-1] = P
        out.append(x.copy())
        S = H @ P @ H.T + R
        y = np.atleast_1d(z) - H @ x
        SI = np.linalg.inv(S)
        K = P @ H.T @ SI
        for i, c in enumerate(reversed(C)):
            out[k - i] = out[k - i] + c @ H.T @ SI @ y
        ikh = np.eye(n) - K @ H
        C = [c @ ikh.T for c in C][-N:] if N else []
        x, P = x + K @ y, ikh @ P @ ikh.T + K @ R @ K.T
    return np.array(out).reshape(len(zs), n)


def filter_and_rts(zs, column=True):
    kf = setup(le.KalmanFilter(2, 1), column)
    Xs, Ps, _, _ = kf.batch_filter(zs)
    xs, _, _, _ = kf.rts_smoother(Xs, Ps)
    return Xs, xs


@pytest.mark.parametrize("column", [True, False])
def test_lag_covering_every_step_is_the_rts_smoother(column):
    zs = track()
    Xs, rts = filter_and_rts(zs, column)
    for N in (len(zs) - 1, len(zs), 1000):
        smooth, xhat = setup(le.FixedLagSmoother(2, 1), column).smooth_batch(zs, N)
        close(smooth, rts, f"smooth_batch(N={N}) vs rts_smoother")
        close(xhat, Xs, f"smooth_batch(N={N}) xhat vs batch_filter")


def test_lag_zero_is_the_filter():
    zs = track()
    Xs, _ = filter_and_rts(zs)
    smooth, xhat = setup(le.FixedLagSmoother(2, 1)).smooth_batch(zs, 0)
    close(smooth, Xs, "smooth_batch(N=0) vs batch_filter")
    close(xhat, Xs, "xhat")


@pytest.mark.parametrize("N", [1, 2, 5, 17])
def test_every_lag_is_the_augmented_state_smoother(N):
    zs = track()
    f = setup(le.FixedLagSmoother(2, 1))
    smooth, _ = f.smooth_batch(zs, N)
    ref = simon(f.x, f.P, f.F, f.H, f.Q, f.R, zs, N)
    close(smooth.reshape(len(zs), 2), ref, f"lag {N} vs the augmented-state smoother")


@pytest.mark.parametrize("N", [0, 1, 3, 40])
def test_streaming_matches_batch_and_keeps_the_window(N):
    zs = track()
    batch, xhat = setup(le.FixedLagSmoother(2, 1)).smooth_batch(zs, N)
    f = setup(le.FixedLagSmoother(2, 1, N=N))
    ref = simon(f.x, f.P, f.F, f.H, f.Q, f.R, zs, N)
    for k, z in enumerate(zs):
        f.smooth(z)
        assert f.count == k + 1 and len(f.xSmooth) == k + 1
        # after step k the window holds x_{j|k}: the batch smoother over the data to k
        now = simon(setup(le.FixedLagSmoother(2, 1)).x, 200 * np.eye(2), f.F, f.H, f.Q, f.R,
                    zs[: k + 1], N)
        close(np.array(f.xSmooth).reshape(k + 1, 2), now, f"xSmooth after step {k}")
        close(f.x, xhat[k], f"x after step {k}")
        close(f.x_s.reshape(2), now[max(0, k - N)], f"x_s after step {k}")
    close(np.array(f.xSmooth), batch, "streamed xSmooth vs smooth_batch")
    close(np.array(f.xSmooth).reshape(len(zs), 2), ref, "streamed vs reference")


def test_time_varying_F_and_control_input():
    zs = track(25)
    dts = 0.5 + 0.05 * np.arange(25)
    Fs = [np.array([[1.0, dt], [0.0, 1.0]]) for dt in dts]
    f = setup(le.FixedLagSmoother(2, 1, N=4))
    x0, P0 = f.x.copy(), f.P.copy()
    for z, F in zip(zs, Fs):
        f.F = F
        f.smooth(z)
    ref = simon(x0, P0, None, f.H, f.Q, f.R, zs, 4, Fs=Fs)
    close(np.array(f.xSmooth).reshape(25, 2), ref, "time-varying F")
    # B u: the filter against the KalmanFilter's, the smoother against the reference (the
    # KalmanFilter's rts_smoother predicts with F x alone, as FilterPy's does, so it is not
    # the reference with a control input)
    B, us = np.array([[0.5], [1.0]]), np.sin(np.arange(25))[:, None]
    g = setup(le.FixedLagSmoother(2, 1))
    g.B = B
    kf = setup(le.KalmanFilter(2, 1, dim_u=1))
    kf.B = B
    Xs, _, _, _ = kf.batch_filter(zs, us=us)
    for N in (0, 3, 100):
        smooth, xhat = g.smooth_batch(zs, N, us=us)
        close(xhat, Xs, f"xhat with B u (N={N})")
        ref = simon(g.x, g.P, g.F, g.H, g.Q, g.R, zs, N, B=B, us=us)
        close(smooth.reshape(25, 2), ref, f"smoothed with B u (N={N})")
    s = setup(le.FixedLagSmoother(2, 1, N=3))
    s.B = B
    for z, u in zip(zs, us):
        s.smooth(z, u=u)
    close(np.array(s.xSmooth), g.smooth_batch(zs, 3, us=us)[0], "streamed with B u")


def test_two_measurements_and_1d_state():
    rng = np.random.default_rng(4)
    zs = rng.normal(size=(30, 2)) + np.arange(30)[:, None]
    f = le.FixedLagSmoother(2, 2)
    f.x = np.array([0.0, 1.0])
    f.F = np.array([[1.0, 1.0], [0.0, 1.0]])
    f.H = np.array([[1.0, 0.0], [1.0, 1.0]])
    f.Q = np.eye(2) * 0.1
    smooth, xhat = f.smooth_batch(zs, 3)
    assert smooth.shape == (30, 2) and xhat.shape == (30, 2)
    ref = simon(f.x, f.P, f.F, f.H, f.Q, f.R, zs, 3)
    close(smooth, ref, "dim_z = 2, 1-d x")
    assert f.count == 0 and f.xSmooth == [] and np.all(f.x == [0.0, 1.0])


def test_defaults_and_attributes():
    f = le.FixedLagSmoother(3, 2, N=2)
    assert (f.dim_x, f.dim_z, f.N, f.count) == (3, 2, 2, 0)
    assert f.x.shape == (3, 1) and f.x_s.shape == (3, 1) and f.K.shape == (3, 1)
    assert np.all(f.P == np.eye(3)) and np.all(f.F == np.eye(3)) and np.all(f.Q == np.eye(3))
    assert np.all(f.H == np.eye(2, 3)) and np.all(f.R == np.eye(2)) and f.B == 0.0
    assert f.y.shape == (2, 1) and f.S.shape == (2, 2) and f.xSmooth == []
    f.smooth(np.array([1.0, 2.0]))
    assert f.K.shape == (3, 2) and f.S.shape == (2, 2) and f.y.shape == (2, 1)
    assert le.FixedLagSmoother(2, 1).N is None


def test_filter_quantities_match_filterpy():
    fp = pytest.importorskip("filterpy.kalman", reason="FilterPy is not installed in this venv")
    zs = track()
    for N in (0, 1, 4, 40):
        ours, theirs = setup(le.FixedLagSmoother(2, 1)), setup(fp.FixedLagSmoother(2, 1))
        _, xa = ours.smooth_batch(zs, N)
        sb, xb = theirs.smooth_batch(zs, N)
        close(xa, xb, f"xhat vs FilterPy (N={N})", tol=1e-10)
        assert ours.smooth_batch(zs, N)[0].shape == sb.shape
    a, b = setup(le.FixedLagSmoother(2, 1, N=3)), setup(fp.FixedLagSmoother(2, 1, N=3))
    for z in zs:
        a.smooth(z)
        b.smooth(z)
        for name in ("x", "P", "y", "S"):
            close(getattr(a, name), getattr(b, name), f"{name} vs FilterPy", tol=1e-10)
    assert a.count == b.count and len(a.xSmooth) == len(b.xSmooth)
    assert a.xSmooth[0].shape == b.xSmooth[0].shape


def test_filterpy_smoothed_output_departures():
    """Where FilterPy's smoothed output is exactly something else, that is pinned here: its
    lag 0 is the prediction x_{k|k-1}; a lag of at least the number of steps is the filter."""
    fp = pytest.importorskip("filterpy.kalman", reason="FilterPy is not installed in this venv")
    zs = track()
    f = setup(fp.FixedLagSmoother(2, 1))
    s0, xhat = f.smooth_batch(zs, 0)
    pred = np.array([f.F @ x for x in np.vstack([f.x[None], xhat[:-1]])])
    close(s0, pred, "FilterPy's lag 0 vs the predictions")
    sT, xhat = f.smooth_batch(zs, len(zs))
    close(sT, xhat, "FilterPy's lag T vs its filter")
    _, rts = filter_and_rts(zs)
    assert np.max(np.abs(sT - rts)) > 0.1


def test_hostile_inputs():
    f = setup(le.FixedLagSmoother(2, 1, N=2))
    with pytest.raises(ValueError, match="z has shape"):
        f.smooth(np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match="z has a non-finite entry"):
        f.smooth(np.nan)
    with pytest.raises(ValueError, match="zs"):
        f.smooth_batch(np.array([1.0, np.nan, 2.0]), 2)
    with pytest.raises(ValueError, match="zs has shape"):
        f.smooth_batch(np.ones((5, 3)), 2)
    for N in (-1, 2.5, 3.0):
        with pytest.raises(ValueError, match="N"):
            f.smooth_batch(track(5), N)
        with pytest.raises(ValueError, match="N"):
            le.FixedLagSmoother(2, 1, N=N)
    with pytest.raises(TypeError, match="N"):
        f.smooth_batch(track(5), "2")
    with pytest.raises(ValueError, match="N is None"):
        le.FixedLagSmoother(2, 1).smooth(1.0)
    with pytest.raises(ValueError, match="us has 3 steps"):
        f.smooth_batch(track(5), 2, us=np.zeros((3, 2)))
    g = setup(le.FixedLagSmoother(2, 1, N=2))
    g.F = np.eye(3)
    with pytest.raises(ValueError, match="F has shape"):
        g.smooth(1.0)
    g.F = np.eye(2)
    g.R = np.array([[0.0]])
    g.P = np.zeros((2, 2))
    g.Q = np.zeros((2, 2))
    with pytest.raises(ValueError, match="singular"):
        g.smooth(1.0)
    # a failed call changes nothing
    assert f.count == 0 and f.xSmooth == [] and g.count == 0
    f.smooth(1.0)
    f.N = 5
    with pytest.raises(ValueError, match="new FixedLagSmoother"):
        f.smooth(2.0)
    assert f.count == 1 and len(f.xSmooth) == 1


@pytest.mark.parametrize("how", ["copy", "deepcopy", "pickle"])
def test_copies_and_pickles_carry_the_window(how):
    """A smoother copied mid-run continues exactly as the original (bit for bit), before
    its first step and after several. A shallow copy shares the attribute arrays and the
    xSmooth list, as FilterPy's does (so it is continued alone here), never the window."""
    import copy
    import pickle

    zs = track(30)
    fresh = setup(le.FixedLagSmoother(2, 1, N=4))
    clone = {"copy": copy.copy, "deepcopy": copy.deepcopy}.get(
        how, lambda o: pickle.loads(pickle.dumps(o))
    )
    first = clone(fresh)
    if how == "copy":
        first.xSmooth = []
    for z in zs[:12]:
        fresh.smooth(z)
    second = clone(fresh)
    if how == "copy":
        assert second.xSmooth is fresh.xSmooth
        fresh = copy.deepcopy(fresh)
        second.xSmooth = list(second.xSmooth)
    for z in zs[12:]:
        fresh.smooth(z)
        second.smooth(z)
    np.testing.assert_array_equal(np.array(second.xSmooth), np.array(fresh.xSmooth))
    np.testing.assert_array_equal(second.P, fresh.P)
    assert second.count == fresh.count == 30
    for z in zs:
        first.smooth(z)
    np.testing.assert_array_equal(np.array(first.xSmooth), np.array(fresh.xSmooth))


def test_a_damaged_pickled_state_is_refused():
    import pickle

    f = setup(le.FixedLagSmoother(2, 1, N=3))
    for z in track(6):
        f.smooth(z)
    cls, args, (d, window) = f.__reduce__()
    for k, v, message in [
        ("pf", window["pf"][:-1], "pf is"),
        ("xs", [float("nan")] * len(window["xs"]), "non-finite"),
        ("n", 3, "3 states but dim_x is 2"),
        ("lag", "x", "lag must be an int"),
    ]:
        bad = dict(window, **{k: v})
        g = cls(*args)
        with pytest.raises((ValueError, TypeError), match=message):
            g.__setstate__((d, bad))
    g = cls(*args)
    with pytest.raises(TypeError, match="state must be"):
        g.__setstate__(d)
    # The undamaged state still round-trips.
    g.__setstate__((d, window))
    assert pickle.loads(pickle.dumps(g)).count == 6
