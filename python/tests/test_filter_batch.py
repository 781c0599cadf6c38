"""filter_batch: many series of one model at once, against `filter` run series by series.

The batch path (eight series per vector register, groups on threads, chunks of series) does
the same arithmetic per series as the scalar filter in a different order, so the two agree
to round-off: 1e-12 relative to each quantity's scale, on random stable models with random
missing entries, in both covariance forms, for state sizes with a compiled fixed path
(1, 2, 3, 4, 6) and without (5).
"""

import numpy as np
import pytest

import compare
import launch_estimation as le
from problems import spd

TOL = 1e-12


def model(seed, n, m):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    F = 0.95 * a / max(abs(np.linalg.eigvals(a)))
    return dict(
        F=F,
        H=rng.standard_normal((m, n)),
        Q=spd(rng, n, 0.1),
        R=spd(rng, m, 0.5),
        x0=rng.standard_normal(n),
        P0=spd(rng, n, 2.0),
    )


def data(seed, series, steps, m, missing=0.2):
    rng = np.random.default_rng(seed + 1000)
    zs = rng.standard_normal((series, steps, m)) * 3.0
    zs[rng.random(zs.shape) < missing] = np.nan
    return zs


def reference(md, z, form):
    out = le.filter(md["F"], md["H"], md["Q"], md["R"], md["x0"], md["P0"], z, form=form)
    return out["x"], out["P"], np.nansum(out["log_likelihood"])


@pytest.mark.parametrize("form", ["joseph", "standard"])
@pytest.mark.parametrize("n, m", [(1, 1), (2, 1), (2, 2), (3, 1), (4, 2), (5, 2), (6, 3)])
def test_equals_the_scalar_filter_series_by_series(n, m, form):
    md = model(n * 10 + m, n, m)
    zs = data(n, 13, 40, m)  # 13 series: one full group of eight and a partial one
    out = le.filter_batch(**md, zs=zs, form=form, covariances=True)
    assert out["x"].shape == (13, 40, n) and out["P"].shape == (13, 40, n, n)
    for s in range(13):
        x, P, ll = reference(md, zs[s], form)
        compare.close(out["x"][s], x, f"series {s}: x", tol=TOL)
        compare.close(out["P"][s], P, f"series {s}: P", tol=TOL)
        compare.close(out["P_last"][s], P[-1], f"series {s}: P_last", tol=TOL)
        compare.close(out["log_likelihood"][s], ll, f"series {s}: ln L", tol=TOL)


def test_many_chunks_of_series_and_a_2d_zs():
    """300 series of 4000 steps are filtered in several chunks (about 88 series each); the
    series at the chunks' edges equal the scalar filter's, and a (series, steps) zs is the
    m = 1 form."""
    md = model(3, 2, 1)
    zs = data(3, 300, 4000, 1)
    out = le.filter_batch(**md, zs=zs[:, :, 0])
    assert "P" not in out and out["x"].shape == (300, 4000, 2)
    for s in (0, 87, 88, 175, 176, 299):
        x, P, ll = reference(md, zs[s], "joseph")
        compare.close(out["x"][s], x, f"series {s}: x", tol=TOL)
        compare.close(out["log_likelihood"][s], ll, f"series {s}: ln L", tol=TOL)


def test_bad_input_names_what_is_wrong():
    md = model(1, 2, 1)
    zs = data(1, 100, 20, 1)
    with pytest.raises(ValueError, match=r"zs has shape \(100, 20, 2\)"):
        le.filter_batch(**md, zs=np.zeros((100, 20, 2)))
    with pytest.raises(ValueError, match="zs has shape"):
        le.filter_batch(**md, zs=np.zeros(20))
    bad = zs.copy()
    bad[95, 7, 0] = np.inf
    with pytest.raises(ValueError, match="series 95"):
        le.filter_batch(**md, zs=bad)
    with pytest.raises(ValueError, match="form"):
        le.filter_batch(**md, zs=zs, form="sqrt")
    with pytest.raises(ValueError, match="P0"):
        le.filter_batch(**dict(md, P0=-np.eye(2)), zs=zs)
    with pytest.raises((TypeError, ValueError)):
        le.filter_batch(**md, zs="nope")
    # Nested lists are read as the array they spell.
    listed = le.filter_batch(**md, zs=zs[:3, :, 0].tolist())
    np.testing.assert_array_equal(listed["x"], le.filter_batch(**md, zs=zs[:3])["x"])
    empty = le.filter_batch(**md, zs=np.zeros((0, 5, 1)))
    assert empty["x"].shape == (0, 5, 2) and empty["log_likelihood"].shape == (0,)


def test_outputs_beyond_memory_are_a_memory_error():
    md = model(1, 2, 1)
    zs = np.broadcast_to(np.zeros((1, 1, 1)), (10**7, 10**5, 1))
    with pytest.raises(MemoryError):
        le.filter_batch(**md, zs=zs, covariances=True)
