"""Every bad input raises ValueError/TypeError with a one-line message naming the argument.

The cases run in a child interpreter (bad_cases.py), so a crash — a segfault or an abort —
fails these tests rather than the whole run."""

import json
import os
import subprocess
import sys

import pytest

from bad_cases import CASES

HERE = os.path.dirname(__file__)


@pytest.fixture(scope="module")
def outcomes():
    proc = subprocess.run(
        [sys.executable, os.path.join(HERE, "bad_cases.py")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, f"the child interpreter died ({proc.returncode}): {proc.stderr}"
    return json.loads(proc.stdout)


def test_enough_cases():
    assert len(CASES) >= 30


@pytest.mark.parametrize("name", list(CASES))
def test_bad_input(outcomes, name):
    _, exc, argument = CASES[name]
    kind, message = outcomes[name]
    assert kind == exc.__name__, f"{name}: raised {kind} ({message}), expected {exc.__name__}"
    assert "\n" not in message, f"{name}: message is not one line: {message!r}"
    assert argument in message, f"{name}: message does not name {argument}: {message!r}"


def test_an_assigned_covariance_meets_the_workspace_rule():
    """The module judges an assigned covariance by the Rust crates' one rule: symmetric within
    1e-10 of its largest entry, no eigenvalue below −1e-10 of its largest. Each matrix sits at
    2× or 0.5× a tolerance (the factor 2 leaves room for the eigen-decomposition's round-off)."""
    import launch_estimation as le
    import numpy as np

    tol, scale = 1e-10, 3.0
    for factor, ok in [(2.0, False), (0.5, True)]:
        d = factor * tol * scale
        for q in (
            np.array([[scale, 1.0 + d], [1.0, 2.0]]),
            np.diag([scale, -d]),
        ):
            kf = le.KalmanFilter(2, 1)
            if ok:
                kf.Q = q
            else:
                with pytest.raises(ValueError, match="Q"):
                    kf.Q = q
