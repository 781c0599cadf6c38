"""fit(free=[...]) and fit_callable from Python: statsmodels' SARIMAX(2,0,0) with
measurement error on a gappy record (the stored numbers of
kalman/tests/golden/make_statsmodels_ar2.py) reached by the command line's names, the
callable form agreeing with the named form, the named form of whole matrices equal to
fit(q=..., r=...), and every bad name, conflict and misbehaving callable a Python
exception naming it."""

import json
import pathlib

import numpy as np
import pytest

import launch_estimation as le

GOLDEN = json.loads(
    (pathlib.Path(__file__).resolve().parents[2] / "kalman/tests/golden/statsmodels_ar2.json")
    .read_text()
)
NAMES = {"F[0,0]": "ar.L1", "F[1,0]": "ar.L2", "Q[0,0]": "sigma2",
         "R[0,0]": "var.measurement_error"}
FREE = list(NAMES)


def ar2_start():
    s = GOLDEN["start"]
    return dict(
        F=np.array([[s["ar.L1"], 1.0], [s["ar.L2"], 0.0]]),
        H=np.array([[1.0, 0.0]]),
        Q=np.array([[s["sigma2"], 0.0], [0.0, 0.0]]),
        R=np.array([[s["var.measurement_error"]]]),
        x0=np.array(GOLDEN["x0"], dtype=float),
        P0=np.diag(GOLDEN["P0_diag"]),
    )


def ar2_data():
    return np.array([np.nan if v is None else v for v in GOLDEN["y"]])[:, None]


def test_named_entries_reach_statsmodels_sarimax():
    res = le.fit(zs=ar2_data(), free=FREE, **ar2_start())
    assert res["converged"], res["message"]
    # Both optimisers stop on a gradient tolerance, where ln L is flat to second order:
    # the optima agree far inside 1e-3 (the Rust test of the same case asserts the same).
    assert abs(res["loglik"] - GOLDEN["llf"]) <= 1e-3, (res["loglik"], GOLDEN["llf"])
    assert list(res["estimates"]) == FREE
    for ours, theirs in NAMES.items():
        est, sm = res["estimates"][ours], GOLDEN["params"][theirs]
        oim = GOLDEN["bse_oim"][theirs]
        # the same optimum: within 2 % of a standard error
        assert abs(est - sm) <= 0.02 * oim, (ours, est, sm)
        # statsmodels' numerical Hessian of ln L is our information itself, up to both
        # finite-difference steps: 2 %
        se = res["std_errors"][ours]
        assert abs(se - GOLDEN["bse_approx"][theirs]) <= 0.02 * GOLDEN["bse_approx"][theirs]
    corr = res["correlation"]
    assert corr["names"] == FREE
    c = np.asarray(corr["matrix"])
    assert c.shape == (4, 4) and np.allclose(np.diag(c), 1.0, atol=1e-12)
    # every entry not named keeps its value exactly
    assert res["F"][0, 1] == 1.0 and res["F"][1, 1] == 0.0 and res["Q"][1, 1] == 0.0
    # the reported ln L is the engine filter's at the fitted model (1e-8 relative: two
    # exact evaluations, 800 steps of round-off)
    run = le.filter(res["F"], res["H"], res["Q"], res["R"], res["x0"], res["P0"], ar2_data())
    assert abs(np.nansum(run["log_likelihood"]) - res["loglik"]) < 1e-8 * abs(res["loglik"])


def ar2_model(theta):
    phi1, phi2, lq, lr = theta
    return {
        "F": np.array([[phi1, 1.0], [phi2, 0.0]]),
        "Q": np.array([[np.exp(lq), 0.0], [0.0, 0.0]]),
        "R": np.array([[np.exp(lr)]]),
    }


def test_the_callable_agrees_with_the_named_form():
    start, zs = ar2_start(), ar2_data()
    named = le.fit(zs=zs, free=FREE, **start)
    s = GOLDEN["start"]
    theta0 = [s["ar.L1"], s["ar.L2"], np.log(s["sigma2"]), np.log(s["var.measurement_error"])]
    res = le.fit_callable(ar2_model, theta0, zs, H=start["H"], x0=start["x0"], P0=start["P0"],
                          log_variances=[2, 3])
    assert res["converged"], res["message"]
    # The same likelihood maximised by the exact score and by central differences: the
    # optima agree to the gradient tolerance's flatness (1e-3 in ln L) and the parameters
    # to 2 % of a standard error.
    assert abs(res["loglik"] - named["loglik"]) <= 1e-3
    est = [res["theta"][0], res["theta"][1], np.exp(res["theta"][2]), np.exp(res["theta"][3])]
    for (name, theirs), v in zip(NAMES.items(), est):
        assert abs(v - named["estimates"][name]) <= 0.02 * GOLDEN["bse_oim"][theirs], name
    assert list(res["estimates"]) == ["θ[0]", "θ[1]", "θ[2]", "θ[3]"]
    assert res["correlation"]["names"] == list(res["estimates"])


def ar1():
    rng = np.random.default_rng(11)
    x, xs = 0.0, []
    for _ in range(300):
        x = 0.8 * x + rng.normal()
        xs.append(x + rng.normal(0.0, 0.5))
    start = dict(F=np.zeros((1, 1)), H=np.eye(1), Q=np.eye(1), R=np.eye(1), x0=np.zeros(1),
                 P0=np.eye(1))
    return start, np.array(xs)[:, None]


def test_ar1_entries_and_whole_matrices_by_name():
    start, zs = ar1()
    res = le.fit(zs=zs, free=["F[0,0]", "Q[0,0]", "R[0,0]"], **start)
    assert res["converged"], res["message"]
    call = le.fit_callable(
        lambda t: {"F": [[t[0]]], "Q": [[np.exp(t[1])]], "R": [[np.exp(t[2])]]},
        [0.0, 0.0, 0.0], zs, H=start["H"], P0=start["P0"])
    assert abs(call["loglik"] - res["loglik"]) <= 1e-3
    assert abs(call["theta"][0] - res["estimates"]["F[0,0]"]) <= 0.02 * res["std_errors"]["F[0,0]"]
    # 300 steps of φ = 0.8: the estimate within 3 standard errors (about 0.1) of the truth
    assert abs(res["estimates"]["F[0,0]"] - 0.8) <= 3 * res["std_errors"]["F[0,0]"]
    # Whole matrices by name are the keyword form exactly (one map, one optimiser).
    start["F"] = np.array([[0.8]])
    a = le.fit(zs=zs, free=["Q:diag", "R:diag"], method="mle", **start)
    b = le.fit(zs=zs, method="mle", q="diag", r="diag", **start)
    assert a["loglik"] == b["loglik"]
    assert np.array_equal(a["Q"], b["Q"]) and np.array_equal(a["R"], b["R"])
    assert a["std_errors"]["Q"].shape == (1, 1)


def test_white_acceleration_needs_dt_and_an_integrator_chain():
    dt = 0.5
    rng = np.random.default_rng(3)
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q1 = np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    x, zs = np.zeros(2), []
    L = np.linalg.cholesky(0.2 * Q1)
    for _ in range(300):
        x = F @ x + L @ rng.normal(size=2)
        zs.append(x[0] + rng.normal(0.0, 0.3))
    start = dict(F=F, H=np.array([[1.0, 0.0]]), Q=np.eye(2), R=np.eye(1), x0=np.zeros(2),
                 P0=np.eye(2))
    res = le.fit(zs=np.array(zs)[:, None], free=["Q:white-acceleration", "R:diag"], dt=dt,
                 **start)
    assert res["converged"], res["message"]
    q = res["estimates"]["Q:white-acceleration"]
    # the fitted Q is q·Q₁ exactly, q within 3 standard errors of the simulated 0.2
    assert np.allclose(res["Q"], q * Q1, rtol=1e-12)
    assert abs(q - 0.2) <= 3 * res["std_errors"]["Q:white-acceleration"]
    with pytest.raises(ValueError, match="dt"):
        le.fit(zs=np.array(zs)[:, None], free=["Q:white-acceleration"], **start)
    start["F"] = np.array([[0.9, 0.0], [0.0, 0.5]])
    with pytest.raises(ValueError, match="chains of integrators"):
        le.fit(zs=np.array(zs)[:, None], free=["Q:white-acceleration"], dt=dt, **start)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(free=["G[0,0]"]), r"unknown matrix 'G' in G\[0,0\]"),
        (dict(free=["F[0]"]), r"F\[0\]: an entry takes two indices"),
        (dict(free=["F[0,0]", "F[0,0]"]), r"F\[0,0\] is listed twice"),
        (dict(free=["Q"]), "Q needs a structure"),
        (dict(free=["P0"]), "P0 can only be freed as a diagonal"),
        (dict(free=["F[3,0]"]), r"F\[3,0\]"),
        (dict(free=[]), "free is empty"),
        (dict(free=["R:diag"], q="full"), "leave q at the default"),
        (dict(free=["R:diag"], free_x0=True, r="scalar"), "leave r, free_x0 at the default"),
        (dict(dt=0.1), "needs free"),
        (dict(free=["R:diag"], dt=-1.0), "positive"),
        (dict(free=["R:diag"], method="newton"), "method"),
    ],
)
def test_bad_names_and_conflicts_are_value_errors(kwargs, match):
    start, zs = ar1()
    with pytest.raises(ValueError, match=match):
        le.fit(zs=zs, **start, **kwargs)


@pytest.mark.parametrize("free", ["F[0,0]", [1, 2], 3])
def test_free_must_be_a_list_of_names(free):
    start, zs = ar1()
    with pytest.raises(TypeError, match="free"):
        le.fit(zs=zs, free=free, **start)


def boom(theta):
    raise RuntimeError("no model here")


@pytest.mark.parametrize(
    "model,exc,match",
    [
        (boom, ValueError, "model\\(theta\\) raised.*no model here"),
        (lambda t: [[1.0]], TypeError, "must return a dict"),
        (lambda t: {"G": [[1.0]]}, ValueError, 'unknown key "G"'),
        # at theta0 the shapes are checked against one another, after it against theta0's
        (lambda t: {"F": np.eye(2)}, ValueError, "H is 1x1, expected 1x2"),
        (lambda t: {"F": np.eye(1 if t[0] == 0.5 else 2)}, ValueError,
         r'\["F"\] has shape \(2, 2\); expected \(1, 1\)'),
        (lambda t: {"F": [[t[0]]], "R": [[np.nan]]}, ValueError, "R"),
        (lambda t: {"F": "x"}, (TypeError, ValueError), "F"),
    ],
)
def test_a_misbehaving_callable_is_a_python_exception(model, exc, match):
    start, zs = ar1()
    with pytest.raises(exc, match=match):
        le.fit_callable(model, [0.5], zs, F=start["F"], H=start["H"], Q=start["Q"],
                        R=start["R"], P0=start["P0"])


def test_a_callable_failing_mid_fit_is_raised_not_swallowed():
    start, zs = ar1()
    calls = []

    def model(theta):
        calls.append(1)
        if len(calls) > 3:
            raise KeyError("late failure")
        return {"F": [[theta[0]]]}

    with pytest.raises(ValueError, match="late failure") as info:
        le.fit_callable(model, [0.5], zs, H=start["H"], Q=start["Q"], R=start["R"],
                        P0=start["P0"])
    assert isinstance(info.value.__cause__, KeyError)
    with pytest.raises(ValueError, match="neither returned"):
        le.fit_callable(lambda t: {"F": [[t[0]]]}, [0.5], zs, H=start["H"], Q=start["Q"],
                        R=start["R"])
    with pytest.raises(TypeError, match="callable"):
        le.fit_callable(3, [0.5], zs, **start)
