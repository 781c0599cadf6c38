"""batch_filter and rts_smoother with per-step matrices, against FilterPy's.

The model is a 2-d constant-velocity target, state (px, vx, py, vy), sampled at jittered
intervals: every step has its own dt, hence its own F, Q and (with an acceleration input) B.
The measurement switches at random between two forms of the same size: the two positions
with independent noise, or a projected position and the x-velocity with correlated noise.
Some measurements are missing (None), as FilterPy skips them.

Tolerance: 1e-10 relative to the largest entry of each compared array (FilterPy's value),
not entry by entry. Both implementations evaluate the same formulas; they differ in rounding
only (FilterPy forms inv(S) and inv(Pp), we solve with a factorisation; the products are
summed in other orders), and rounding error is relative to the scale of the quantity, not of
each entry: an off-diagonal covariance that nearly cancels, or a gain of the last smoother
step (zero), would fail an entry-wise relative test for no fault, and an absolute 1e-10 would
depend on the units (positions here are O(10), the position-velocity covariances O(1e-3)).
A formula difference (a wrong step index of Fs or Qs, the filter's own Q instead of Qs[k],
B u dropped) shows at 1e-3 or more of the scale.
"""

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter as FpKalmanFilter

import launch_estimation as le

TOL = 1e-10
STEPS = 60


def close(ours, theirs, what):
    a, b = np.asarray(ours, float), np.asarray(theirs, float)
    assert a.shape == b.shape, f"{what}: shape {a.shape} vs FilterPy's {b.shape}"
    scale = float(np.max(np.abs(b))) if b.size else 0.0
    diff = float(np.max(np.abs(a - b))) if b.size else 0.0
    assert diff <= TOL * scale, f"{what}: differs by {diff:.3e}, scale {scale:.3e}"


def cv_block(dt):
    """One axis of the constant-velocity model: F, the white-acceleration Q, the B of u."""
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    B = np.array([[dt**2 / 2], [dt]])
    return F, Q, B


def blockdiag(a, b):
    out = np.zeros((a.shape[0] + b.shape[0], a.shape[1] + b.shape[1]))
    out[: a.shape[0], : a.shape[1]] = a
    out[a.shape[0] :, a.shape[1] :] = b
    return out


H_POS = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
R_POS = np.diag([0.5**2, 0.4**2])
H_MIX = np.array([[0.6, 0.0, 0.8, 0.0], [0.0, 1.0, 0.0, 0.0]])
R_MIX = np.array([[0.3, 0.05], [0.05, 0.1]])


def time_varying(seed, steps=STEPS, missing=0.15):
    """Per-step Fs, Qs, Bs, Hs, Rs of a jittered-dt 2-d constant-velocity target, with the
    simulated measurements zs (None where missing) and acceleration inputs us (steps, 2, 1)."""
    rng = np.random.default_rng(seed)
    q = 0.2
    Fs, Qs, Bs, Hs, Rs, zs = [], [], [], [], [], []
    us = 0.3 * rng.standard_normal((steps, 2, 1))
    x = np.array([[0.0], [1.0], [5.0], [-0.5]])
    for k in range(steps):
        dt = 0.1 * (0.5 + rng.random())  # 0.05 .. 0.15
        F1, Q1, B1 = cv_block(dt)
        F, Q, B = blockdiag(F1, F1), q * blockdiag(Q1, Q1), blockdiag(B1, B1)
        H, R = (H_POS, R_POS) if rng.random() < 0.5 else (H_MIX, R_MIX)
        x = F @ x + B @ us[k] + rng.multivariate_normal(np.zeros(4), Q)[:, None]
        z = H @ x + rng.multivariate_normal(np.zeros(2), R)[:, None]
        Fs.append(F)
        Qs.append(Q)
        Bs.append(B)
        Hs.append(H)
        Rs.append(R)
        zs.append(None if rng.random() < missing else z)
    return dict(Fs=Fs, Qs=Qs, Bs=Bs, Hs=Hs, Rs=Rs, zs=zs, us=us)


def filters(dim_u=0, x_column=True):
    """Ours and FilterPy's, set up alike; their own F, Q, H, R differ from every step's
    (a step that used them by mistake would show)."""
    out = []
    for cls in (le.KalmanFilter, FpKalmanFilter):
        kf = cls(4, 2, dim_u)
        x0 = np.array([[0.2], [0.8], [4.5], [-0.3]])
        kf.x = x0 if x_column else x0.ravel()
        kf.P = np.diag([1.0, 0.5, 1.0, 0.5])
        kf.F = np.eye(4)
        kf.Q = 0.01 * np.eye(4)
        kf.H = H_POS.copy()
        kf.R = 2.0 * np.eye(2)
        out.append(kf)
    return out


OUTPUTS = ["means", "covariances", "means_p", "covariances_p"]
SMOOTHED = ["x", "P", "K", "Pp"]


def compare_batch(a, b, what):
    for x, y, name in zip(a, b, OUTPUTS):
        close(x, y, f"{what} {name}")


def compare_last_step(ours, theirs, what):
    for name in ["x", "P", "K", "y", "S", "x_prior", "P_prior", "x_post", "P_post"]:
        close(getattr(ours, name), getattr(theirs, name), f"{what} {name}")
    close(ours.log_likelihood, theirs.log_likelihood, f"{what} log_likelihood")


@pytest.mark.parametrize("update_first", [False, True])
@pytest.mark.parametrize("as_array", [False, True])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_time_varying_batch_filter_and_smoother(seed, as_array, update_first):
    tv = time_varying(seed)
    ours, theirs = filters()
    per_step = {k: tv[k] for k in ["Fs", "Qs", "Hs", "Rs", "Bs"]}
    ours_args = {k: np.array(v) for k, v in per_step.items()} if as_array else per_step
    a = ours.batch_filter(tv["zs"], us=tv["us"], update_first=update_first, **ours_args)
    b = theirs.batch_filter(tv["zs"], us=list(tv["us"]), update_first=update_first, **per_step)
    compare_batch(a, b, "batch_filter")
    compare_last_step(ours, theirs, "after batch_filter")
    # The filter's own matrices are untouched (FilterPy's predict/update take the per-step
    # ones as arguments only).
    for name in ["F", "Q", "H", "R"]:
        assert np.array_equal(getattr(ours, name), getattr(theirs, name)), name
    assert ours.B is None
    Fs, Qs = ours_args["Fs"], ours_args["Qs"]
    # The smoother over each one's own filter output, and over the same input.
    sa = ours.rts_smoother(a[0], a[1], Fs=Fs, Qs=Qs)
    sb = theirs.rts_smoother(b[0], b[1], Fs=tv["Fs"], Qs=tv["Qs"])
    for x, y, name in zip(sa, sb, SMOOTHED):
        close(x, y, f"rts_smoother {name}")
    same = ours.rts_smoother(b[0], b[1], Fs=Fs, Qs=Qs, inv=np.linalg.inv)
    for x, y, name in zip(same, sb, SMOOTHED):
        close(x, y, f"rts_smoother on FilterPy's input {name}")


def test_smoother_honours_qs_and_the_index_of_fs():
    """Qs, or Fs alone, against FilterPy; and each one changes the result (so the test would
    see it ignored, or indexed Fs[k] instead of Fs[k + 1])."""
    tv = time_varying(4)
    ours, theirs = filters()
    means, covs, _, _ = theirs.batch_filter(tv["zs"], Fs=tv["Fs"], Qs=tv["Qs"], Hs=tv["Hs"], Rs=tv["Rs"])
    results = {}
    for label, kwargs in {
        "Fs and Qs": dict(Fs=tv["Fs"], Qs=tv["Qs"]),
        "Fs only": dict(Fs=tv["Fs"]),
        "Qs only": dict(Qs=tv["Qs"]),
        "neither": {},
    }.items():
        sa = ours.rts_smoother(means, covs, **kwargs)
        sb = theirs.rts_smoother(means, covs, **kwargs)
        for x, y, name in zip(sa, sb, SMOOTHED):
            close(x, y, f"rts_smoother ({label}) {name}")
        results[label] = sa
    for label in ["Fs only", "Qs only", "neither"]:
        assert not np.allclose(results[label][1], results["Fs and Qs"][1], rtol=1e-3), label
    shifted = ours.rts_smoother(means, covs, Fs=tv["Fs"][1:] + tv["Fs"][:1], Qs=tv["Qs"])
    assert not np.allclose(shifted[0], results["Fs and Qs"][0], rtol=1e-6)


def test_none_items_are_the_filters_own():
    """A None item of Fs/Qs/Hs/Rs/Bs/us is the filter's own at that step (FilterPy hands it to
    predict/update, which read None so), also with the filter's own B set."""
    tv = time_varying(5)
    rng = np.random.default_rng(5)
    ours, theirs = filters(dim_u=2)
    B_own = np.array([[0.0, 0.0], [0.1, 0.0], [0.0, 0.0], [0.0, 0.1]])
    ours.B, theirs.B = B_own.copy(), B_own.copy()
    args = {}
    for name in ["Fs", "Qs", "Hs", "Rs", "Bs"]:
        args[name] = [None if rng.random() < 0.3 else m for m in tv[name]]
    us = [None if rng.random() < 0.2 else u for u in tv["us"]]
    a = ours.batch_filter(tv["zs"], us=us, **args)
    b = theirs.batch_filter(tv["zs"], us=us, **args)
    compare_batch(a, b, "None items")
    compare_last_step(ours, theirs, "None items, after batch_filter")
    # FilterPy's rts_smoother has no None items (it multiplies by them): it gets the
    # filter's own in their place.
    filled = {
        "Fs": [theirs.F if F is None else F for F in args["Fs"]],
        "Qs": [theirs.Q if Q is None else Q for Q in args["Qs"]],
    }
    sa = ours.rts_smoother(a[0], a[1], Fs=args["Fs"], Qs=args["Qs"])
    sb = theirs.rts_smoother(b[0], b[1], **filled)
    for x, y, name in zip(sa, sb, SMOOTHED):
        close(x, y, f"None items rts_smoother {name}")


@pytest.mark.parametrize("with_bs", [False, True])
def test_controls(with_bs):
    """us with the filter's own B at every step, or with Bs and no B of the filter's."""
    tv = time_varying(6, missing=0.0)
    ours, theirs = filters(dim_u=2)
    if with_bs:
        kwargs = dict(Fs=tv["Fs"], Qs=tv["Qs"], Bs=tv["Bs"])
    else:
        B = tv["Bs"][0]
        ours.B, theirs.B = B.copy(), B.copy()
        kwargs = dict(Fs=tv["Fs"], Qs=tv["Qs"])
    a = ours.batch_filter(tv["zs"], us=tv["us"][:, :, 0], **kwargs)  # (N, p) for ours
    b = theirs.batch_filter(tv["zs"], us=list(tv["us"]), **kwargs)
    compare_batch(a, b, "controls")
    # Without us the controls are off (FilterPy's u = 0; its B·0 broadcasts x to (n, p)
    # when p > 1, so there is no FilterPy result to compare with): the means differ.
    fresh, _ = filters(dim_u=2)
    if not with_bs:
        fresh.B = tv["Bs"][0].copy()
    c = fresh.batch_filter(tv["zs"], **kwargs)
    assert not np.allclose(c[0], a[0], rtol=1e-3)


def test_one_dimensional_state_and_measurements():
    """x of shape (n,) and zs of shape (N, m): FilterPy's means are (N, n) then."""
    tv = time_varying(7)
    ours, theirs = filters(x_column=False)
    zs = [None if z is None else z.ravel() for z in tv["zs"]]
    us = [u.ravel() for u in tv["us"]]
    per_step = {k: tv[k] for k in ["Fs", "Qs", "Hs", "Rs", "Bs"]}
    a = ours.batch_filter(zs, us=us, **per_step)
    b = theirs.batch_filter(zs, us=us, **per_step)
    assert a[0].shape == (STEPS, 4)
    compare_batch(a, b, "1-d state")
    sa = ours.rts_smoother(a[0], a[1], Fs=tv["Fs"], Qs=tv["Qs"])
    sb = theirs.rts_smoother(b[0], b[1], Fs=tv["Fs"], Qs=tv["Qs"])
    for x, y, name in zip(sa, sb, SMOOTHED):
        close(x, y, f"1-d state rts_smoother {name}")


def test_scalar_items_and_integer_arrays():
    """Scalar Q and R items mean q·I and r·I, as in FilterPy's predict/update; integer arrays
    are converted."""
    tv = time_varying(8)
    ours, theirs = filters()
    Qs = [0.01 * (1 + k % 3) for k in range(STEPS)]
    Rs = [float(1 + k % 2) for k in range(STEPS)]
    Hs = [np.array([[1, 0, 0, 0], [0, 0, 1, 0]])] * STEPS  # integer dtype
    a = ours.batch_filter(tv["zs"], Fs=tv["Fs"], Qs=Qs, Hs=Hs, Rs=Rs)
    b = theirs.batch_filter(tv["zs"], Fs=tv["Fs"], Qs=Qs, Hs=Hs, Rs=Rs)
    compare_batch(a, b, "scalar items")

