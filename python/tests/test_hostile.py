"""Hostile inputs, each in its own child interpreter (so an abort or a segfault fails the case
instead of the run): allocations sized by the user that cannot be made raise MemoryError,
Ctrl-C inside a long call or a Python callable raises KeyboardInterrupt (and leaves the
filter as it was), and inputs FilterPy takes give FilterPy's result or a typed error, never
a silently different one.

The memory cases run under a 4 GiB address-space limit (RLIMIT_AS), so they fail the same
way on any machine; without it a broadcast view of 10¹⁰ rows would be copied into an 80 GB
buffer. The Ctrl-C cases send SIGINT once the child reports it is inside the call; the
call alone would run for many seconds (a 400-state batch), so the KeyboardInterrupt shows
the signal was acted on inside it."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
LIMIT = 4 << 30


def limited():
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (LIMIT, LIMIT))


def child(code, limit=False, interrupt_after_line=None, timeout=120):
    """Runs `code` in a child interpreter; returns (returncode, stdout, stderr). With
    `interrupt_after_line`, sends SIGINT once that line appears on the child's stdout."""
    # Ctrl-C raises KeyboardInterrupt in the child even where the parent runs with SIGINT
    # ignored (a job started in the background by a non-interactive shell), which Python
    # would otherwise inherit and keep.
    prefix = (
        "import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "import numpy as np\nimport launch_estimation as le\n"
    )
    code = prefix + textwrap.dedent(code)
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    proc = subprocess.Popen(
        [sys.executable, "-c", code],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=HERE,
        env=env,
        preexec_fn=limited if limit else None,
    )
    out = []
    if interrupt_after_line is not None:
        for line in proc.stdout:
            out.append(line)
            if line.strip() == interrupt_after_line:
                time.sleep(0.5)  # well inside the call, past its argument checks
                proc.send_signal(signal.SIGINT)
                break
    try:
        rest, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        rest, err = proc.communicate()
        pytest.fail(f"the child did not finish within {timeout} s: {err[-2000:]}")
    return proc.returncode, "".join(out) + rest, err


def raises_in_child(code, exc, limit=False):
    rc, out, err = child(code, limit=limit)
    assert rc == 0, f"the child died ({rc}): {err[-2000:]}"
    assert out.strip().splitlines()[-1] == exc, (out, err[-2000:])


def memory_error_in_child(code, setup=""):
    """Runs `setup` then `code` in a child under the address-space limit: `code` must raise
    MemoryError."""
    raises_in_child(
        setup
        + f"""
try:
{textwrap.indent(textwrap.dedent(code), "    ")}
    print("no error")
except MemoryError:
    print("MemoryError")
""",
        "MemoryError",
        limit=True,
    )


MEMORY = {
    "KalmanFilter(10000, 1)": "le.KalmanFilter(10000, 1)",
    "KalmanFilter(1, 10000) then update": """
        kf = le.KalmanFilter(1, 10000)
        kf.update(np.zeros(10000))
    """,
    "batch_filter on a broadcast view of 10**10 rows": """
        kf = le.KalmanFilter(2, 1)
        kf.batch_filter(np.broadcast_to(np.zeros(1), (10**10, 1)))
    """,
    "filter on zeros(10**8)": """
        I = np.eye(2)
        le.filter(I, np.ones((1, 2)), I, np.eye(1), np.zeros(2), I, np.zeros(10**8))
    """,
    "smooth on zeros(10**8)": """
        I = np.eye(2)
        le.smooth(I, np.ones((1, 2)), I, np.eye(1), np.zeros(2), I, np.zeros(10**8))
    """,
    "rts_smoother on broadcast views": """
        kf = le.KalmanFilter(2, 1)
        Xs = np.broadcast_to(np.zeros((1, 2)), (10**9, 2))
        Ps = np.broadcast_to(np.eye(2), (10**9, 2, 2))
        kf.rts_smoother(Xs, Ps)
    """,
    "batch_filter with a per-step Fs view of 6.4 GB": """
        kf = le.KalmanFilter(20, 1)
        zs = np.zeros((2 * 10**6, 1))
        kf.batch_filter(zs, Fs=np.broadcast_to(np.eye(20), (2 * 10**6, 20, 20)))
    """,
}


@pytest.mark.parametrize("name", list(MEMORY))
def test_memory_error_not_abort(name):
    memory_error_in_child(MEMORY[name])


def test_ctrl_c_in_a_long_batch_filter_raises_and_keeps_the_filter():
    rc, out, err = child(
        """
        n = 400
        kf = le.KalmanFilter(n, 1)
        kf.H = np.ones((1, n))
        kf.F = np.eye(n) * 0.999
        x0, P0 = kf.x.copy(), kf.P.copy()
        zs = np.zeros((300, 1))
        print("calling", flush=True)
        try:
            kf.batch_filter(zs)
            print("finished")
        except KeyboardInterrupt:
            same = np.array_equal(kf.x, x0) and np.array_equal(kf.P, P0)
            print("KeyboardInterrupt", "unchanged" if same else "changed")
        """,
        interrupt_after_line="calling",
        timeout=60,
    )
    assert rc == 0, err[-2000:]
    assert out.strip().splitlines()[-1] == "KeyboardInterrupt unchanged", (out, err[-2000:])


def assert_interrupted(setup, call):
    """Runs `setup`, then `call` (one line, seconds or more uninterrupted) in a child
    interpreter, Ctrl-C sent once the call has begun: the call raises KeyboardInterrupt."""
    code = (
        textwrap.dedent(setup)
        + 'print("calling", flush=True)\n'
        + f"try:\n    {call}\n    print('finished')\n"
        + "except KeyboardInterrupt:\n    print('KeyboardInterrupt')\n"
    )
    rc, out, err = child(code, interrupt_after_line="calling", timeout=60)
    assert rc == 0, err[-2000:]
    assert out.strip().splitlines()[-1] == "KeyboardInterrupt", (out, err[-2000:])


@pytest.mark.parametrize("method", ["em", "mle"])
def test_ctrl_c_in_a_long_fit_raises(method):
    """A fit of minutes (a long record, a tight tolerance) stops at its next iteration or
    likelihood evaluation."""
    assert_interrupted(
        """
        rng = np.random.default_rng(1)
        zs = np.cumsum(rng.standard_normal(400000)) + rng.standard_normal(400000)
        one = np.eye(1)
        """,
        f"le.fit(one, one, one, one, np.zeros(1), one * 10, zs, method='{method}', "
        "max_iter=100000)",
    )


def test_ctrl_c_in_a_long_filter_batch_raises():
    """A filter_batch of many chunks (seconds uninterrupted) stops at the next chunk."""
    assert_interrupted(
        """
        n = 6
        F, H = np.eye(n) * 0.999, np.ones((1, n))
        zs = np.broadcast_to(np.zeros((1, 1, 1)), (40000, 2000, 1))
        """,
        "le.filter_batch(F, H, np.eye(n), np.eye(1), np.zeros(n), np.eye(n), zs)",
    )


@pytest.mark.parametrize("which", ["ukf", "ekf"])
def test_ctrl_c_inside_a_callable_raises(which):
    rc, out, err = child(
        f"""
        import time
        calls = [0]
        def f(x, u, k):
            calls[0] += 1
            if calls[0] == 5:
                print("inside", flush=True)
                time.sleep(30)  # interrupted: KeyboardInterrupt from here
            return x
        def h(x, k):
            return x[:1]
        try:
            le.{which}(f, h, np.eye(2), np.eye(1), np.zeros(2), np.eye(2), np.zeros(100))
            print("finished")
        except KeyboardInterrupt:
            print("KeyboardInterrupt")
        """,
        interrupt_after_line="inside",
        timeout=25,
    )
    assert rc == 0, err[-2000:]
    assert out.strip().splitlines()[-1] == "KeyboardInterrupt", (out, err[-2000:])
    assert "Exception ignored" not in err, err[-2000:]


SILENT = {
    # FilterPy takes these; ours must give FilterPy's numbers (compared in the child).
    "float32 F edited in place": ("F", np.float32),
    "int F edited in place": ("F", np.int64),
    "int H edited in place": ("H", np.int64),
    "float32 x edited in place": ("x", np.float32),
}


@pytest.mark.parametrize("name", list(SILENT))
def test_no_silent_difference_from_filterpy(name):
    attr, dtype = SILENT[name]
    rc, out, err = child(
        f"""
        from filterpy.kalman import KalmanFilter
        base = {{"F": [[1, 1], [0, 1]], "H": [[1, 0]], "x": [[1], [2]]}}
        results = []
        for cls in (le.KalmanFilter, KalmanFilter):
            kf = cls(2, 1)
            kf.H = np.array([[1.0, 0.0]])
            kf.F = np.array([[1.0, 1.0], [0.0, 1.0]])
            a = np.array(base["{attr}"], dtype=np.{dtype.__name__})
            kf.{attr} = a
            a[0, 0] = 3  # the edit FilterPy uses
            for z in [1.0, 2.5, 2.0, 4.0]:
                kf.predict()
                kf.update(z)
            results.append(np.concatenate([np.ravel(kf.x), np.ravel(kf.P)]))
        d = np.max(np.abs(results[0] - results[1]))
        print("same" if d < 1e-10 else f"differs by {{d}}")
        """
    )
    assert rc == 0, err[-2000:]
    assert out.strip().splitlines()[-1] == "same", (out, err[-2000:])


REFUSED = {
    "rts_smoother with an indefinite Ps[1]": (
        """
        kf = le.KalmanFilter(2, 1)
        Ps = np.stack([np.eye(2)] * 3)
        Ps[1] = [[1.0, 2.0], [2.0, 1.0]]
        kf.rts_smoother(np.zeros((3, 2)), Ps)
        """,
        "ValueError",
        "Ps[1]",
    ),
    "rts_smoother with a non-symmetric Ps[2]": (
        """
        kf = le.KalmanFilter(2, 1)
        Ps = np.stack([np.eye(2)] * 3)
        Ps[2, 0, 1] = 0.5
        kf.rts_smoother(np.zeros((3, 2)), Ps)
        """,
        "ValueError",
        "Ps[2]",
    ),
    "rts_smoother with a NaN in Xs": (
        """
        kf = le.KalmanFilter(2, 1)
        Xs = np.zeros((3, 2))
        Xs[1, 0] = np.nan
        kf.rts_smoother(Xs, np.stack([np.eye(2)] * 3))
        """,
        "ValueError",
        "Xs",
    ),
    "z of three dimensions": (
        "kf = le.KalmanFilter(2, 1)\nkf.update(np.array([[[3.0]]]))",
        "ValueError",
        "z",
    ),
    "a bool for dim_x": ("le.KalmanFilter(True, 1)", "TypeError", "dim_x"),
    "update_sequential past dim_z": (
        "kf = le.KalmanFilter(2, 2)\nkf.update_sequential(2, 1.0)",
        "ValueError",
        "dim_z",
    ),
    "a pickled state of another size": (
        """
        big, small = le.KalmanFilter(3, 1), le.KalmanFilter(2, 1)
        small.__setstate__(big.__getstate__())
        """,
        "ValueError",
        "pickled",
    ),
}


@pytest.mark.parametrize("name", list(REFUSED))
def test_refused_with_a_typed_error(name):
    code, exc, needle = REFUSED[name]
    rc, out, err = child(
        f"""
try:
{textwrap.indent(textwrap.dedent(code), "    ")}
    print("no error")
except Exception as e:
    print(type(e).__name__, "|", str(e).replace(chr(10), " "))
"""
    )
    assert rc == 0, f"the child died ({rc}): {err[-2000:]}"
    last = out.strip().splitlines()[-1]
    kind, _, message = last.partition(" | ")
    assert kind == exc, last
    assert needle in message, last
