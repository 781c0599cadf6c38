"""Bad inputs for launch_estimation, each with the exception type and the argument its
one-line message must name. Run by test_bad_input.py in a child interpreter, so a crash
(rather than an exception) fails the test instead of killing the test run."""

import json
import sys

import numpy as np

import launch_estimation as le


def kf(n=2, m=1, p=0):
    f = le.KalmanFilter(n, m, p)
    f.H = np.ones((m, n))
    return f


def setattr_(name, value, n=2, m=1, p=0):
    return lambda: setattr(kf(n, m, p), name, value)


I2 = np.eye(2)


def batch(m=1, p=0, **kwargs):
    """batch_filter over three steps of a 2-state filter, with the per-step arguments given."""
    return kf(m=m, p=p).batch_filter(np.zeros((3, m)), **kwargs)


def rts(**kwargs):
    """rts_smoother over four steps of a 2-state filter, with the per-step arguments given."""
    return kf().rts_smoother(np.zeros((4, 2)), np.stack([I2] * 4), **kwargs)


def steps_with(matrix, k, index, value, steps=3):
    """An array of `steps` copies of `matrix` whose step k has `value` at `index`."""
    out = np.stack([matrix] * steps).astype(float)
    out[(k,) + index] = value
    return out


def continuous(function="filter_continuous", **kwargs):
    """filter_continuous (or another whole-series function of the continuous model) of a
    constant-velocity model over three rows at t = 0, 0.5, 1, with the arguments given
    replacing the defaults."""
    args = dict(
        A=np.array([[0.0, 1.0], [0.0, 0.0]]),
        C=np.array([[1.0, 0.0]]),
        W=np.diag([0.0, 0.5]),
        R=np.array([[4.0]]),
        x0=np.zeros(2),
        P0=np.eye(2),
        t=np.array([0.0, 0.5, 1.0]),
        zs=np.zeros((3, 1)),
    )
    args.update(kwargs)
    return getattr(le, function)(**args)


def discrete(function="filter", **kwargs):
    """filter (or smooth) of a 2-state model over three rows, with the arguments given."""
    args = dict(F=I2, H=np.ones((1, 2)), Q=I2, R=np.eye(1), x0=np.zeros(2), P0=I2,
                zs=np.zeros((3, 1)))
    args.update(kwargs)
    return getattr(le, function)(**args)


NAN = float("nan")
INF = float("inf")
CASES = {
    # constructor
    "dim_x zero": (lambda: le.KalmanFilter(0, 1), ValueError, "dim_x"),
    "dim_x negative": (lambda: le.KalmanFilter(-3, 1), ValueError, "dim_x"),
    "dim_z float": (lambda: le.KalmanFilter(2, 1.5), TypeError, "dim_z"),
    "dim_u string": (lambda: le.KalmanFilter(2, 1, "1"), TypeError, "dim_u"),
    # attributes: types
    "x list": (setattr_("x", [0.0, 0.0]), TypeError, "x"),
    "x None": (setattr_("x", None), TypeError, "x"),
    "P list": (setattr_("P", [[1.0, 0.0], [0.0, 1.0]]), TypeError, "P"),
    "F complex dtype": (setattr_("F", np.eye(2, dtype=complex)), TypeError, "F"),
    "F string dtype": (setattr_("F", np.array([["a", "b"], ["c", "d"]])), TypeError, "F"),
    "F object dtype": (setattr_("F", np.array([[1, None], [0, 1]], dtype=object)), TypeError, "F"),
    "H bool dtype": (setattr_("H", np.array([[True, False]])), TypeError, "H"),
    "Q string": (setattr_("Q", "eye"), TypeError, "Q"),
    "R dict": (setattr_("R", {"a": 1}), TypeError, "R"),
    "alpha string": (setattr_("alpha", "1.0"), TypeError, "alpha"),
    # attributes: shapes
    "x wrong length": (setattr_("x", np.zeros((3, 1))), ValueError, "x"),
    "x row": (setattr_("x", np.zeros((1, 2))), ValueError, "x"),
    "F wrong shape": (setattr_("F", np.eye(3)), ValueError, "F"),
    "F 3-d": (setattr_("F", np.zeros((2, 2, 1))), ValueError, "F"),
    "H transposed": (setattr_("H", np.zeros((2, 1))), ValueError, "H"),
    "R wrong shape": (setattr_("R", np.eye(2)), ValueError, "R"),
    "B wrong rows": (setattr_("B", np.zeros((3, 1)), p=1), ValueError, "B"),
    "B wrong cols": (setattr_("B", np.zeros((2, 2)), p=1), ValueError, "B"),
    "M wrong shape": (setattr_("M", np.zeros((1, 2))), ValueError, "M"),
    # attributes: values
    "x NaN": (setattr_("x", np.array([[NAN], [0.0]])), ValueError, "x"),
    "P inf": (setattr_("P", np.array([[INF, 0.0], [0.0, 1.0]])), ValueError, "P"),
    "P not symmetric": (setattr_("P", np.array([[1.0, 0.5], [0.0, 1.0]])), ValueError, "P"),
    "P not PSD": (setattr_("P", np.array([[1.0, 2.0], [2.0, 1.0]])), ValueError, "P"),
    "Q negative": (setattr_("Q", -1.0), ValueError, "Q"),
    "R negative": (setattr_("R", np.array([[-0.1]])), ValueError, "R"),
    "R not PSD": (setattr_("R", np.array([[1.0, 3.0], [3.0, 1.0]]), m=2), ValueError, "R"),
    "F NaN": (setattr_("F", np.array([[1.0, NAN], [0.0, 1.0]])), ValueError, "F"),
    "M inf": (setattr_("M", np.array([[INF], [0.0]])), ValueError, "M"),
    "alpha below 1": (setattr_("alpha", 0.5), ValueError, "alpha"),
    # in-place edit that breaks a rule, noticed at the next call
    "P edited in place to non-PSD": (
        lambda: (lambda f: (f.P.__setitem__((0, 0), -5.0), f.predict()))(kf()),
        ValueError,
        "P",
    ),
    # calls
    "update z wrong length": (lambda: kf().update(np.zeros(3)), ValueError, "z"),
    "update z inf": (lambda: kf().update(INF), ValueError, "z"),
    "update z string": (lambda: kf().update("1.0"), TypeError, "z"),
    "update R override not PSD": (lambda: kf().update(1.0, R=-2.0), ValueError, "R"),
    "update H override wrong shape": (lambda: kf().update(1.0, H=np.ones((2, 2))), ValueError, "H"),
    "update singular S": (
        lambda: (lambda f: (setattr(f, "R", 0.0), setattr(f, "P", 0.0), f.update(1.0)))(kf()),
        ValueError,
        "S",
    ),
    "predict u wrong length": (
        lambda: (lambda f: (setattr(f, "B", np.ones((2, 1))), f.predict(np.zeros(3))))(kf(p=1)),
        ValueError,
        "u",
    ),
    "predict u NaN": (
        lambda: (lambda f: (setattr(f, "B", np.ones((2, 1))), f.predict(NAN)))(kf(p=1)),
        ValueError,
        "u",
    ),
    "predict F override NaN": (lambda: kf().predict(F=np.full((2, 2), NAN)), ValueError, "F"),
    "predict Q override list": (lambda: kf().predict(Q=[[1.0, 0.0], [0.0, 1.0]]), TypeError, "Q"),
    "batch zs wrong shape": (lambda: kf().batch_filter(np.zeros((5, 2))), ValueError, "zs"),
    "batch zs inf": (lambda: kf().batch_filter(np.array([1.0, INF])), ValueError, "zs"),
    "batch zs item wrong length": (lambda: kf().batch_filter([1.0, [1.0, 2.0]]), ValueError, "zs[1]"),
    "batch zs string": (lambda: kf().batch_filter("abc"), TypeError, "zs"),
    "batch zs int": (lambda: kf().batch_filter(5), TypeError, "zs"),
    "batch us wrong length": (
        lambda: (lambda f: (setattr(f, "B", np.ones((2, 1))), f.batch_filter(np.zeros(4), us=np.zeros(3))))(kf(p=1)),
        ValueError,
        "us",
    ),
    # per-step matrices of batch_filter (three steps): the argument and the step are named
    "batch Fs too short": (lambda: batch(Fs=[I2] * 2), ValueError, "Fs[2]"),
    "batch Fs too long": (lambda: batch(Fs=[I2] * 4), ValueError, "Fs[3]"),
    "batch Fs generator too long": (lambda: batch(Fs=(I2 for _ in range(4))), ValueError, "Fs[3]"),
    "batch Fs generator too short": (lambda: batch(Fs=(I2 for _ in range(2))), ValueError, "Fs[2]"),
    "batch Fs step wrong shape": (lambda: batch(Fs=[I2, np.eye(3), I2]), ValueError, "Fs[1]"),
    "batch Fs array wrong shape": (lambda: batch(Fs=np.zeros((3, 3, 3))), ValueError, "Fs[0]"),
    "batch Fs array wrong length": (lambda: batch(Fs=np.zeros((4, 2, 2))), ValueError, "Fs[3]"),
    "batch Fs one matrix": (lambda: batch(Fs=I2), ValueError, "Fs"),
    "batch Fs float": (lambda: batch(Fs=1.0), TypeError, "Fs"),
    "batch Fs string": (lambda: batch(Fs="eye"), TypeError, "Fs"),
    "batch Fs step list": (lambda: batch(Fs=[I2, [[1.0, 0.0], [0.0, 1.0]], I2]), TypeError, "Fs[1]"),
    "batch Fs step NaN": (lambda: batch(Fs=[I2, I2, np.array([[1.0, NAN], [0.0, 1.0]])]), ValueError, "Fs[2]"),
    "batch Fs step complex": (lambda: batch(Fs=[I2, I2 * 1j, I2]), TypeError, "Fs[1]"),
    "batch Qs step not symmetric": (lambda: batch(Qs=[I2, np.array([[1.0, 0.5], [0.0, 1.0]]), I2]), ValueError, "Qs[1]"),
    "batch Qs step not PSD": (lambda: batch(Qs=[-1.0, I2, I2]), ValueError, "Qs[0]"),
    "batch Qs array NaN": (lambda: batch(Qs=steps_with(I2, 2, (0, 0), NAN)), ValueError, "Qs[2]"),
    "batch Qs array not symmetric": (lambda: batch(Qs=steps_with(I2, 1, (0, 1), 0.3)), ValueError, "Qs[1]"),
    "batch Rs step not symmetric": (
        lambda: batch(Rs=[np.eye(2), np.array([[1.0, 0.2], [0.1, 1.0]]), np.eye(2)], m=2),
        ValueError,
        "Rs[1]",
    ),
    "batch Rs step inf": (lambda: batch(Rs=[1.0, 1.0, np.array([[INF]])]), ValueError, "Rs[2]"),
    "batch Rs too short": (lambda: batch(Rs=[1.0]), ValueError, "Rs[1]"),
    "batch Hs step wrong shape": (lambda: batch(Hs=[np.ones((1, 2)), np.ones((1, 2)), np.ones((2, 2))]), ValueError, "Hs[2]"),
    "batch Hs array inf": (lambda: batch(Hs=steps_with(np.ones((1, 2)), 1, (0, 1), INF)), ValueError, "Hs[1]"),
    "batch Bs step wrong shape": (
        lambda: batch(p=1, Bs=[np.ones((2, 1)), np.ones((2, 2)), np.ones((2, 1))], us=np.ones(3)),
        ValueError,
        "Bs[1]",
    ),
    "batch Bs too long": (lambda: batch(p=1, Bs=[np.ones((2, 1))] * 4, us=np.ones(3)), ValueError, "Bs[3]"),
    "batch Bs step scalar": (lambda: batch(p=1, Bs=[np.ones((2, 1)), 1.0, np.ones((2, 1))], us=np.ones(3)), TypeError, "Bs[1]"),
    "batch us step wrong length with Bs": (
        lambda: batch(Bs=[np.ones((2, 1))] * 3, us=[[1.0], [1.0, 2.0], [1.0]]),
        ValueError,
        "us[1]",
    ),
    "batch us NaN with Bs": (lambda: batch(Bs=[np.ones((2, 1))] * 3, us=np.array([1.0, 1.0, NAN])), ValueError, "us[2]"),
    "batch us too short with Bs": (lambda: batch(Bs=[np.ones((2, 1))] * 3, us=np.ones(2)), ValueError, "us[2]"),
    "rts Xs Ps lengths": (lambda: kf().rts_smoother(np.zeros((4, 2, 1)), np.zeros((3, 2, 2))), ValueError, "Ps"),
    "rts Xs wrong shape": (lambda: kf().rts_smoother(np.zeros((4, 3)), np.zeros((4, 2, 2))), ValueError, "Xs"),
    "rts Ps NaN": (lambda: kf().rts_smoother(np.zeros((2, 2)), np.full((2, 2, 2), NAN)), ValueError, "Ps"),
    "rts Xs list": (lambda: kf().rts_smoother([[0.0, 0.0]], np.zeros((1, 2, 2))), TypeError, "Xs"),
    # per-step matrices of rts_smoother (four steps)
    "rts Fs too short": (lambda: rts(Fs=[I2] * 3), ValueError, "Fs[3]"),
    "rts Fs step wrong shape": (lambda: rts(Fs=[I2, I2, np.eye(3), I2]), ValueError, "Fs[2]"),
    "rts Fs step inf": (lambda: rts(Fs=[I2, I2, I2, np.full((2, 2), INF)]), ValueError, "Fs[3]"),
    "rts Qs step not symmetric": (lambda: rts(Qs=[I2, np.array([[1.0, 0.0], [0.5, 1.0]]), I2, I2]), ValueError, "Qs[1]"),
    "rts Qs array NaN": (lambda: rts(Qs=steps_with(I2, 3, (1, 1), NAN, steps=4)), ValueError, "Qs[3]"),
    "rts Qs too long": (lambda: rts(Qs=np.stack([I2] * 5)), ValueError, "Qs[4]"),
    "rts Qs string": (lambda: rts(Qs="Q"), TypeError, "Qs"),
    "rts inv other": (lambda: rts(inv=np.linalg.pinv), TypeError, "inv"),
    "rts singular Pp per step": (
        lambda: kf().rts_smoother(np.zeros((3, 2)), np.zeros((3, 2, 2)), Qs=[I2, I2, 0.0]),
        ValueError,
        "Qs[2]",
    ),
    "rts singular Pp": (
        lambda: (lambda f: (setattr(f, "Q", 0.0), f.rts_smoother(np.zeros((3, 2)), np.zeros((3, 2, 2)))))(kf()),
        ValueError,
        "singular",
    ),
    # filter_continuous / smooth_continuous: the argument and the index are named
    "continuous t NaN": (lambda: continuous(t=np.array([0.0, NAN, 1.0])), ValueError, "t[1]"),
    "continuous t inf": (lambda: continuous(t=np.array([-INF, 0.0, 1.0])), ValueError, "t[0]"),
    "continuous t goes back": (lambda: continuous(t=np.array([0.0, 1.0, 0.5])), ValueError, "t[2]"),
    "smooth_continuous t goes back": (
        lambda: continuous("smooth_continuous", t=np.array([2.0, 1.0, 3.0])),
        ValueError,
        "t[1]",
    ),
    "continuous dt overflows e^{A dt}": (
        lambda: continuous(A=np.array([[800.0, 0.0], [0.0, 0.0]]), t=np.array([0.0, 0.0, 10.0])),
        ValueError,
        "t[2] − t[1]",
    ),
    "continuous dt overflows f64": (
        lambda: continuous(t=np.array([-1e308, 1e308, 1e308])), ValueError, "t[1] − t[0]",
    ),
    "continuous t too short": (lambda: continuous(t=np.array([0.0, 1.0])), ValueError, "t"),
    "continuous t 2-d": (lambda: continuous(t=np.zeros((3, 2))), ValueError, "t"),
    "continuous t string": (lambda: continuous(t="0 1 2"), TypeError, "t"),
    "continuous gate 1": (lambda: continuous(gate=1.0), ValueError, "gate"),
    "continuous gate 0": (lambda: continuous(gate=0.0), ValueError, "gate"),
    "continuous gate NaN": (lambda: continuous(gate=NAN), ValueError, "gate"),
    "continuous gate negative": (lambda: continuous(gate=-0.5), ValueError, "gate"),
    "continuous gate string": (lambda: continuous(gate="0.99"), TypeError, "gate"),
    "continuous gate_rule": (lambda: continuous(gate=0.99, gate_rule="chi2"), ValueError, "gate_rule"),
    "continuous form": (lambda: continuous(form="fast"), ValueError, "form"),
    "continuous A not square": (lambda: continuous(A=np.zeros((2, 3))), ValueError, "A"),
    "continuous A list": (lambda: continuous(A=[[0.0, 1.0], [0.0, 0.0]]), TypeError, "A"),
    "continuous C wrong columns": (lambda: continuous(C=np.ones((1, 3))), ValueError, "C"),
    "continuous C NaN": (lambda: continuous(C=np.array([[1.0, NAN]])), ValueError, "C"),
    "continuous W wrong shape": (lambda: continuous(W=np.eye(3)), ValueError, "W"),
    "continuous W not PSD": (lambda: continuous(W=np.diag([0.0, -0.5])), ValueError, "W"),
    "continuous W not symmetric": (lambda: continuous(W=np.array([[0.0, 0.1], [0.0, 0.5]])), ValueError, "W"),
    "continuous R wrong shape": (lambda: continuous(R=np.eye(2)), ValueError, "R"),
    "continuous R not PSD": (lambda: continuous(R=np.array([[-1.0]])), ValueError, "R"),
    "continuous B wrong rows": (lambda: continuous(B=np.ones((3, 1)), us=np.zeros(3)), ValueError, "B"),
    "continuous us without B": (lambda: continuous(us=np.zeros((3, 1))), ValueError, "us"),
    "continuous us wrong length": (lambda: continuous(B=np.ones((2, 1)), us=np.zeros(4)), ValueError, "us"),
    "continuous x0 wrong length": (lambda: continuous(x0=np.zeros(3)), ValueError, "x0"),
    "continuous P0 not PSD": (lambda: continuous(P0=-np.eye(2)), ValueError, "P0"),
    "continuous zs wrong columns": (lambda: continuous(zs=np.zeros((3, 2))), ValueError, "zs"),
    "continuous zs inf": (lambda: continuous(zs=np.array([0.0, INF, 0.0])), ValueError, "zs[1]"),
    "smooth_continuous no rows": (
        lambda: continuous("smooth_continuous", t=np.zeros(0), zs=np.zeros((0, 1))),
        ValueError,
        "smooth_continuous",
    ),
    # the gate of the discrete filter and smoother
    "filter gate above 1": (lambda: discrete(gate=1.5), ValueError, "gate"),
    "smooth gate 0": (lambda: discrete("smooth", gate=0.0), ValueError, "gate"),
    "smooth gate_rule": (lambda: discrete("smooth", gate=0.9, gate_rule="all"), ValueError, "gate_rule"),
    "smooth form": (lambda: discrete("smooth", form="fast"), ValueError, "form"),
}


def main():
    results = {}
    for name, (call, _, _) in CASES.items():
        try:
            call()
            results[name] = ["no exception", ""]
        except Exception as e:  # noqa: BLE001 - every outcome is reported to the parent
            results[name] = [type(e).__name__, str(e)]
    json.dump(results, sys.stdout)


if __name__ == "__main__":
    main()
