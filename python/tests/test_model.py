"""c2d and fuel_model from Python, against SciPy's discretisation and a Van Loan integral
computed here from scipy.linalg.expm (an independent derivation of the same Q)."""

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

import launch_estimation as le


def system(seed, n=3, p=2, q=1):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) - 2 * np.eye(n)
    return A, rng.standard_normal((n, p)), rng.standard_normal((1, n)), np.zeros((1, p)), \
        rng.standard_normal((n, q))


@pytest.mark.parametrize("method,scipy_method", [("zoh", "zoh"), ("tustin", "bilinear")])
def test_c2d_matches_scipy(method, scipy_method):
    A, B, C, D, _ = system(1)
    dt = 0.05
    out = le.c2d(A, B, C, D, dt, method=method)
    F, Bd, Hd, Dd, _ = scipy.signal.cont2discrete((A, B, C, D), dt, method=scipy_method)
    # Both evaluate e^{A dt} (or the bilinear map) to near machine precision.
    for ours, theirs in [(out["F"], F), (out["B"], Bd), (out["H"], Hd), (out["D"], Dd)]:
        np.testing.assert_allclose(ours, theirs, rtol=1e-11, atol=1e-13)


def test_van_loan_q():
    A, B, C, D, G = system(2)
    W = np.array([[0.7]])
    dt = 0.1
    out = le.c2d(A, B, C, D, dt, G=G, W=W)
    n = A.shape[0]
    # Van Loan: expm([[-A, G W Gᵀ], [0, Aᵀ]] dt) = [[·, F⁻¹ Q], [0, Fᵀ]].
    M = np.block([[-A, G @ W @ G.T], [np.zeros((n, n)), A.T]]) * dt
    E = scipy.linalg.expm(M)
    F = E[n:, n:].T
    Q = F @ E[:n, n:]
    np.testing.assert_allclose(out["Q"], Q, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(out["Q"], out["Q"].T, atol=1e-15)


def test_fuel_model_runs_through_the_filter():
    fm = le.fuel_model()
    n, m = fm["F"].shape[0], fm["H"].shape[0]
    assert (n, m) == (7, 2)
    zs = np.zeros((20, m))
    res = le.filter(fm["F"], fm["H"], fm["Qw"], fm["R"], np.zeros(n), np.eye(n), zs, S=fm["S"])
    assert res["x"].shape == (20, n) and np.all(np.isfinite(res["P"]))


@pytest.mark.parametrize(
    "kwargs,name",
    [
        (dict(dt=-1.0), "dt"),
        (dict(dt=0.1, method="magic"), "method"),
        (dict(dt=0.1, method="tustin_prewarp"), "omega"),
        (dict(dt=0.1, noise="other"), "noise"),
        (dict(dt=0.1, G=np.ones((3, 1))), "W"),
    ],
)
def test_c2d_bad_input(kwargs, name):
    A, B, C, D, _ = system(3)
    with pytest.raises(ValueError) as info:
        le.c2d(A, B, C, D, **kwargs)
    assert name in str(info.value) and "\n" not in str(info.value)


def test_fuel_model_bad_input():
    with pytest.raises(ValueError, match="channels"):
        le.fuel_model(channels="three")
