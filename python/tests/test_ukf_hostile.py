"""Hostile inputs for UnscentedKalmanFilter and the sigma-point classes, each in its own child
interpreter (the helpers of test_hostile.py): user-sized allocations that cannot be made raise
MemoryError under a 4 GiB address-space limit, Ctrl-C inside a long call or inside fx raises
KeyboardInterrupt and leaves the filter as it was, an exception raised by fx or hx reaches the
caller unchanged (the same object), and bad input is a typed error naming what is wrong."""

import pytest

from test_hostile import child, memory_error_in_child, raises_in_child

SETUP = """
def fx(x, dt):
    return np.array([x[0] + dt * x[1], x[1], x[2]])
def hx(x):
    return np.array([np.sqrt(x[0] ** 2 + x[2] ** 2)])
def make(**kw):
    kf = le.UnscentedKalmanFilter(3, 1, 0.05, hx, fx, le.MerweScaledSigmaPoints(3, 0.1, 2.0, 0.0), **kw)
    kf.x = np.array([0.0, 90.0, 1100.0])
    kf.P *= 100.0
    kf.R = 10.0
    return kf
def snapshot(kf):
    return {k: np.array(v, copy=True) for k, v in kf.__dict__.items() if isinstance(v, np.ndarray)}
def same(kf, snap):
    now = snapshot(kf)
    return now.keys() == snap.keys() and all(
        now[k].shape == snap[k].shape and (now[k].dtype == object or np.array_equal(now[k], snap[k]))
        for k in now
    )
"""

MEMORY = {
    "UnscentedKalmanFilter(10**5, 1)": """
        le.UnscentedKalmanFilter(10**5, 1, 1.0, hx, fx, le.JulierSigmaPoints(2))
    """,
    "UnscentedKalmanFilter(3, 10**5)": """
        le.UnscentedKalmanFilter(3, 10**5, 1.0, hx, fx, le.JulierSigmaPoints(3))
    """,
    "batch_filter on a broadcast view of 10**10 rows": """
        make().batch_filter(np.broadcast_to(np.zeros(1), (10**10, 1)))
    """,
    "rts_smoother on broadcast views of 10**9 steps": """
        Xs = np.broadcast_to(np.zeros((1, 3)), (10**9, 3))
        Ps = np.broadcast_to(np.eye(3), (10**9, 3, 3))
        make().rts_smoother(Xs, Ps)
    """,
    "sigma points for n = 10**9": "le.MerweScaledSigmaPoints(10**9, 0.1, 2.0, 0.0)",
}


@pytest.mark.parametrize("name", list(MEMORY))
def test_memory_error_not_abort(name):
    memory_error_in_child(MEMORY[name], SETUP)


@pytest.mark.parametrize("vectorized", [False, True])
def test_ctrl_c_in_a_long_batch_filter_raises_and_keeps_the_filter(vectorized):
    fx, hx = ("fxv", "hxv") if vectorized else ("fx", "hx")
    rc, out, err = child(
        SETUP
        + f"""
def fxv(s, dt):
    out = s.copy()
    out[:, 0] += dt * s[:, 1]
    return out
def hxv(s):
    return np.sqrt(s[:, 0] ** 2 + s[:, 2] ** 2)
kf = make(vectorized={vectorized})
kf.fx, kf.hx = {fx}, {hx}
snap = snapshot(kf)
zs = np.full(2_000_000, 1100.0)  # many seconds of work
print("calling", flush=True)
try:
    kf.batch_filter(zs)
    print("finished")
except KeyboardInterrupt:
    print("KeyboardInterrupt", "unchanged" if same(kf, snap) else "changed")
""",
        interrupt_after_line="calling",
        timeout=60,
    )
    assert rc == 0, err[-2000:]
    assert out.strip().splitlines()[-1] == "KeyboardInterrupt unchanged", (out, err[-2000:])


@pytest.mark.parametrize("method", ["predict", "batch_filter", "rts_smoother"])
def test_ctrl_c_inside_fx_raises_and_keeps_the_filter(method):
    call = {
        "predict": "kf.predict()",
        "batch_filter": "kf.batch_filter([1100.0] * 100)",
        "rts_smoother": "kf.rts_smoother(np.tile(kf.x, (50, 1)), np.tile(kf.P, (50, 1, 1)))",
    }[method]
    rc, out, err = child(
        SETUP
        + f"""
import time
calls = [0]
def slow(x, dt):
    calls[0] += 1
    if calls[0] == 5:
        print("inside", flush=True)
        time.sleep(30)  # interrupted: KeyboardInterrupt from here
    return fx(x, dt)
kf = make()
kf.fx = slow
snap = snapshot(kf)
try:
    {call}
    print("finished")
except KeyboardInterrupt:
    print("KeyboardInterrupt", "unchanged" if same(kf, snap) else "changed")
""",
        interrupt_after_line="inside",
        timeout=25,
    )
    assert rc == 0, err[-2000:]
    assert out.strip().splitlines()[-1] == "KeyboardInterrupt unchanged", (out, err[-2000:])
    assert "Exception ignored" not in err, err[-2000:]


@pytest.mark.parametrize("where", ["fx", "hx", "residual_z", "x_mean_fn"])
def test_an_exception_in_a_callable_reaches_the_caller_unchanged(where):
    rc, out, err = child(
        SETUP
        + f"""
class Mine(Exception):
    pass
boom = Mine("from the user's {where}")
def bad(*a, **k):
    raise boom
kf = make()
kf.predict()
kf.update([1100.0])
attr = {{"x_mean_fn": "x_mean"}}.get("{where}", "{where}")
setattr(kf, attr, bad)
snap = snapshot(kf)
try:
    kf.batch_filter([1100.0, 1101.0])
    print("finished")
except Mine as e:
    print("same object" if e is boom else "another object", "unchanged" if same(kf, snap) else "changed")
""",
    )
    assert rc == 0, err[-2000:]
    assert out.strip().splitlines()[-1] == "same object unchanged", (out, err[-2000:])


REFUSED = {
    "a P that is not positive definite": ("kf = make(); kf.P = -np.eye(3); kf.predict()", "LinAlgError"),
    "an indefinite Q": ("kf = make(); kf.Q = np.diag([1.0, -1.0, 1.0]); kf.predict()", "ValueError"),
    "an R with NaN": ("kf = make(); kf.predict(); kf.update([1.0], R=np.array([[1.0]]) * np.nan)", "ValueError"),
    "NaN in z": ("kf = make(); kf.predict(); kf.update([np.nan])", "ValueError"),
    "z of the wrong size": ("kf = make(); kf.predict(); kf.update([1.0, 2.0])", "ValueError"),
    "fx returning the wrong shape": ("kf = make(); kf.fx = lambda x, dt: x[:2]; kf.predict()", "ValueError"),
    "hx returning NaN": ("kf = make(); kf.hx = lambda x: [np.nan]; kf.predict(); kf.update([1.0])", "ValueError"),
    "a vectorised fx returning one point": (
        "kf = make(vectorized=True); kf.fx = lambda s, dt: s[0]; kf.predict()", "ValueError"),
    "fx that is not callable": ("le.UnscentedKalmanFilter(3, 1, 0.1, hx, 5, le.JulierSigmaPoints(3))", "TypeError"),
    "dim_x = 0": ("le.UnscentedKalmanFilter(0, 1, 0.1, hx, fx, le.JulierSigmaPoints(3))", "ValueError"),
    "dim_x = 2.5": ("le.UnscentedKalmanFilter(2.5, 1, 0.1, hx, fx, le.JulierSigmaPoints(3))", "ValueError"),
    "n = -1 sigma points": ("le.JulierSigmaPoints(-1)", "ValueError"),
    "a string alpha": ("le.MerweScaledSigmaPoints(3, 'a', 2.0, 0.0)", "TypeError"),
    "sigma_points with x of the wrong size": ("le.JulierSigmaPoints(3).sigma_points(np.zeros(2), np.eye(3))", "ValueError"),
    "Xs and Ps of different lengths": ("make().rts_smoother(np.zeros((5, 3)), np.tile(np.eye(3), (4, 1, 1)))", "ValueError"),
    "zs that is not list-like": ("make().batch_filter(5)", "TypeError"),
    "Rs shorter than zs": ("make().batch_filter([1.0, 2.0, 3.0], Rs=[1.0])", "ValueError"),
}


@pytest.mark.parametrize("name", list(REFUSED))
def test_refused_with_a_typed_error(name):
    code, exc = REFUSED[name]
    raises_in_child(
        SETUP
        + f"""
try:
    {code}
    print("no error")
except np.linalg.LinAlgError:
    print("LinAlgError")
except MemoryError:
    print("MemoryError")
except (ValueError, TypeError) as e:
    print(type(e).__name__)
""",
        exc,
    )
