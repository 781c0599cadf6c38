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
    "batch Fs unsupported": (lambda: kf().batch_filter(np.zeros(3), Fs=[np.eye(2)] * 3), TypeError, "Fs"),
    "rts Xs Ps lengths": (lambda: kf().rts_smoother(np.zeros((4, 2, 1)), np.zeros((3, 2, 2))), ValueError, "Ps"),
    "rts Xs wrong shape": (lambda: kf().rts_smoother(np.zeros((4, 3)), np.zeros((4, 2, 2))), ValueError, "Xs"),
    "rts Ps NaN": (lambda: kf().rts_smoother(np.zeros((2, 2)), np.full((2, 2, 2), NAN)), ValueError, "Ps"),
    "rts Xs list": (lambda: kf().rts_smoother([[0.0, 0.0]], np.zeros((1, 2, 2))), TypeError, "Xs"),
    "rts singular Pp": (
        lambda: (lambda f: (setattr(f, "Q", 0.0), f.rts_smoother(np.zeros((3, 2)), np.zeros((3, 2, 2)))))(kf()),
        ValueError,
        "singular",
    ),
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
