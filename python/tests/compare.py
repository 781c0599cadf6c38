"""The comparison the side-by-side tests share: arrays equal in shape and within `tol`
relative to the larger of one and the reference's largest magnitude."""

import numpy as np


def close(a, b, what, tol=1e-10):
    """Asserts `a` (ours) matches `b` (the reference) in shape and to `tol`, naming `what`."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, f"{what}: shape {a.shape} vs the reference's {b.shape}"
    scale = max(1.0, float(np.max(np.abs(b))) if b.size else 1.0)
    np.testing.assert_allclose(a, b, rtol=tol, atol=tol * scale, err_msg=what)
