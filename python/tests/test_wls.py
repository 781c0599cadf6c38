"""The WLS solver from Python, against NumPy's least squares on the whitened problem."""

import numpy as np
import pytest

import launch_estimation as le


def test_wls_matches_numpy():
    rng = np.random.default_rng(3)
    H = rng.standard_normal((12, 3))
    z = rng.standard_normal(12)
    w = rng.uniform(0.5, 4.0, 12)
    out = le.wls(H, z, weights=w)
    sw = np.sqrt(w)
    x, *_ = np.linalg.lstsq(H * sw[:, None], z * sw, rcond=None)
    # Both solve a well-conditioned (κ ≈ 3) problem by orthogonal factorisations.
    np.testing.assert_allclose(out["x"], x, rtol=1e-12, atol=1e-13)
    N = H.T @ (w[:, None] * H)
    np.testing.assert_allclose(out["covariance"] @ N, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(out["residuals"], z - H @ x, atol=1e-12)
    sv = np.linalg.svd(H * sw[:, None], compute_uv=False)
    np.testing.assert_allclose(out["singular_values"], sv, rtol=1e-12)
    assert out["rank"] == 3
    np.testing.assert_allclose(out["condition_weighted"], sv[0] / sv[-1], rtol=1e-10)
    full = le.wls(H, z, weights=np.diag(w))
    np.testing.assert_allclose(full["x"], out["x"], rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize(
    "kwargs,name",
    [
        (dict(H=np.ones((3, 2)), z=np.ones(3)), "rank"),
        (dict(H=np.eye(2), z=np.ones(3)), "z"),
        (dict(H=np.eye(2), z=np.ones(2), weights=np.array([1.0, -1.0])), "weight"),
        (dict(H=np.eye(2), z=np.ones(2), method="svd"), "method"),
        (dict(H=np.eye(2), z=np.array([1.0, np.nan])), "z"),
        (dict(H=[[1.0]], z=np.ones(1)), "H"),
    ],
)
def test_wls_bad_input(kwargs, name):
    with pytest.raises((ValueError, TypeError)) as info:
        le.wls(**kwargs)
    msg = str(info.value)
    assert name.lower() in msg.lower() and "\n" not in msg, msg
