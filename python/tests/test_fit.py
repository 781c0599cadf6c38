"""fit (EM and MLE) from Python: on a simulated local-level model both converge, MLE's
log-likelihood is at least EM's (EM climbs towards the same maximum), and the reported
log-likelihood equals the sum of the engine filter's per-step values at the fitted model
(an independent evaluation of the same quantity)."""

import numpy as np
import pytest

import launch_estimation as le


def data(seed=5, steps=400, q=0.05, r=0.5):
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(0.0, np.sqrt(q), steps))
    return (x + rng.normal(0.0, np.sqrt(r), steps))[:, None]


START = dict(F=np.eye(1), H=np.eye(1), Q=np.eye(1), R=np.eye(1), x0=np.zeros(1),
             P0=10.0 * np.eye(1))


def test_em_and_mle_agree_with_the_filter():
    zs = data()
    em = le.fit(zs=zs, method="em", max_iter=500, **START)
    mle = le.fit(zs=zs, method="mle", **START)
    assert em["converged"] and mle["converged"], (em["message"], mle["message"])
    # MLE stops at the maximum; EM approaches it from below (its tolerance: 1e-6 or so).
    assert mle["loglik"] >= em["loglik"] - 1e-6
    for res in (em, mle):
        run = le.filter(res["F"], res["H"], res["Q"], res["R"], res["x0"], res["P0"], zs)
        assert abs(run["log_likelihood"].sum() - res["loglik"]) < 1e-8 * abs(res["loglik"])
    # 400 steps pin q and r to within a factor of about 2 (their standard errors).
    assert 0.01 < mle["Q"][0, 0] < 0.25 and 0.2 < mle["R"][0, 0] < 1.0
    assert mle["std_errors"] is not None and np.all(mle["std_errors"] > 0)


@pytest.mark.parametrize(
    "kwargs,name",
    [
        (dict(method="newton"), "method"),
        (dict(q="banded"), "q"),
        (dict(zs=np.ones((10, 2))), "zs"),
        (dict(q="fixed", r="fixed"), "fit"),
    ],
)
def test_fit_bad_input(kwargs, name):
    args = dict(START, zs=data(steps=20))
    args.update(kwargs)
    with pytest.raises(ValueError) as info:
        le.fit(**args)
    assert name in str(info.value) and "\n" not in str(info.value), str(info.value)
