"""filter_continuous / smooth_continuous (a continuous model at a record's own time stamps) and
the wild-point gate of every whole-series function, against a numpy reference written here
from the closed forms of the constant-velocity model, and against the golden record of
`scenarios filter` (scenarios/tests/data/irregular, computed with scipy's expm)."""

import ast
import csv
import inspect
import json
import math
import os
from statistics import NormalDist

import numpy as np
import pytest

import launch_estimation as le

D = 2  # axes of the constant-velocity target: x = [px, py, vx, vy]
Q_INTENSITY = 0.5  # white acceleration, m²/s³
A = np.block([[np.zeros((D, D)), np.eye(D)], [np.zeros((D, D)), np.zeros((D, D))]])
W = np.block([[np.zeros((D, D)), np.zeros((D, D))], [np.zeros((D, D)), Q_INTENSITY * np.eye(D)]])
C = np.hstack([np.eye(D), np.zeros((D, D))])  # positions measured
R = np.diag([4.0, 9.0])
B = np.vstack([np.zeros((D, D)), np.eye(D)])  # acceleration commands
X0 = np.array([10.0, -20.0, 3.0, 1.0])
P0 = np.diag([25.0, 25.0, 4.0, 4.0])

# The engine's expm of the nilpotent Van Loan matrix is exact to rounding, and it and the
# reference below sum the same products in other orders: a few hundred ulps over 60 steps.
# 1e-10 of each array's own scale is far above that and far below any formula slip (a
# wrong Δt power or a missing ZOH term changes the estimates at the 1e-3 level).
REL = 1e-10


def cv_sampled(dt):
    """The exact discretisation of the constant-velocity model over dt, in closed form:
    F = [[I, Δt I], [0, I]], Q_d = q [[Δt³/3 I, Δt²/2 I], [Δt²/2 I, Δt I]], and the
    zero-order hold of the acceleration input B_d = [Δt²/2 I; Δt I]."""
    I, Z = np.eye(D), np.zeros((D, D))
    F = np.block([[I, dt * I], [Z, I]])
    Qd = Q_INTENSITY * np.block([[dt**3 / 3 * I, dt**2 / 2 * I], [dt**2 / 2 * I, dt * I]])
    Bd = np.vstack([dt**2 / 2 * I, dt * I])
    return F, Qd, Bd


def chi2_1_quantile(p):
    """The χ²(1) quantile of p: the square of the normal quantile of (1 + p)/2."""
    return NormalDist().inv_cdf(0.5 * (1.0 + p)) ** 2


def reference(t, zs, us=None, gate=None, Cm=C, Rm=R):
    """The filter of the time rule written out: (X0, P0) is the prior of row 0; step k
    updates with the present (and, with a gate, kept) entries of zs[k] in Joseph form,
    then predicts over t[k+1] − t[k] (the last row over 0). Returns the estimates, the
    rejections and the per-step models (for the smoother)."""
    n, N = len(X0), len(t)
    limit = None if gate is None else chi2_1_quantile(gate)
    x, P = X0.copy(), P0.copy()
    out = {k: [] for k in ("x", "P", "x_pred", "P_pred", "log_likelihood", "nis", "F")}
    rejected = []
    for k in range(N):
        present = [i for i in range(zs.shape[1]) if not np.isnan(zs[k, i])]
        kept = present
        if limit is not None and present:
            H = Cm[present]
            e = zs[k, present] - H @ x
            S = H @ P @ H.T + Rm[np.ix_(present, present)]
            kept = []
            for j, i in enumerate(present):
                r = e[j] ** 2 / S[j, j]
                if r > limit:
                    rejected.append((k, i, zs[k, i], r))
                else:
                    kept.append(i)
        nis, ll = np.nan, 0.0
        if kept:
            H, Rk = Cm[kept], Rm[np.ix_(kept, kept)]
            e = zs[k, kept] - H @ x
            S = H @ P @ H.T + Rk
            K = np.linalg.solve(S, H @ P).T
            nis = float(e @ np.linalg.solve(S, e))
            ll = -0.5 * (nis + np.linalg.slogdet(S)[1] + len(kept) * math.log(2 * math.pi))
            x = x + K @ e
            IKH = np.eye(n) - K @ H
            P = IKH @ P @ IKH.T + K @ Rk @ K.T
            P = 0.5 * (P + P.T)
        out["x"].append(x)
        out["P"].append(P)
        out["nis"].append(nis)
        out["log_likelihood"].append(ll)
        dt = t[k + 1] - t[k] if k + 1 < N else 0.0
        F, Qd, Bd = cv_sampled(dt)
        x = F @ x + (Bd @ us[k] if us is not None else 0.0)
        P = F @ P @ F.T + Qd
        out["x_pred"].append(x)
        out["P_pred"].append(P)
        out["F"].append(F)
    return {k: np.array(v) for k, v in out.items()}, rejected


def reference_rts(ref):
    """The RTS smoother over a reference pass: C_k = P_{k|k} F_kᵀ P_{k+1|k}⁻¹ by a solve."""
    xs, Ps = ref["x"].copy(), ref["P"].copy()
    for k in range(len(xs) - 2, -1, -1):
        Pp = ref["P_pred"][k]
        Ck = np.linalg.solve(Pp, ref["F"][k] @ ref["P"][k]).T
        xs[k] = ref["x"][k] + Ck @ (xs[k + 1] - ref["x_pred"][k])
        Ps[k] = ref["P"][k] + Ck @ (Ps[k + 1] - Pp) @ Ck.T
    return xs, Ps


def assert_close(actual, expected, rel=REL):
    """|actual − expected| ≤ rel · max|expected| entrywise (NaN where expected is NaN)."""
    actual, expected = np.asarray(actual), np.asarray(expected)
    assert actual.shape == expected.shape
    assert np.array_equal(np.isnan(actual), np.isnan(expected))
    ok = ~np.isnan(expected)
    scale = np.abs(expected[ok]).max() if ok.any() else 0.0
    np.testing.assert_allclose(actual[ok], expected[ok], rtol=0, atol=rel * scale)


def jittered(seed, N=60):
    """N stamps 0.1 s ± 0.03 s apart (rounded to 0.1 ms), with a 1.7 s gap after row 29 and
    rows 11 and 12 at one instant."""
    rng = np.random.default_rng(seed)
    t = np.round(0.1 * np.arange(N) + rng.uniform(-0.03, 0.03, N), 4)
    t[0] = 0.0
    t[30:] += 1.7
    t[12] = t[11]
    return t


def record(seed, t, wild=()):
    """A record simulated at the stamps t: positions with about 10 % of the entries missing
    (never a wild one), acceleration commands, and the wild entries `wild` ((row, channel,
    offset)) added to the measurements."""
    rng = np.random.default_rng(seed)
    N = len(t)
    us = rng.standard_normal((N, D))
    x = np.array([12.0, -18.0, 2.5, 1.5])
    zs = np.empty((N, D))
    for k in range(N):
        zs[k] = C @ x + np.sqrt(np.diag(R)) * rng.standard_normal(D)
        if k + 1 < N:
            F, Qd, Bd = cv_sampled(t[k + 1] - t[k])
            x = F @ x + Bd @ us[k] + rng.multivariate_normal(np.zeros(2 * D), Qd)
    missing = rng.random((N, D)) < 0.1
    for k, i, offset in wild:
        missing[k, i] = False
        zs[k, i] += offset
    zs[missing] = np.nan
    return zs, us


@pytest.mark.parametrize("form", ["joseph", "standard", "sqrt"])
def test_filter_matches_closed_form_reference(form):
    t = jittered(1)
    zs, us = record(1, t)
    assert np.any(np.diff(t) == 0.0) and np.diff(t).max() > 1.5
    out = le.filter_continuous(A, C, W, R, X0, P0, t, zs, us=us, B=B, form=form)
    ref, _ = reference(t, zs, us)
    for key in ("x", "P", "x_pred", "P_pred", "log_likelihood", "nis"):
        assert_close(out[key], ref[key])
    assert "rejected" not in out


def test_smoother_matches_closed_form_reference():
    t = jittered(2)
    zs, us = record(2, t)
    out = le.smooth_continuous(A, C, W, R, X0, P0, t, zs, us=us, B=B)
    xs, Ps = reference_rts(reference(t, zs, us)[0])
    assert_close(out["x"], xs)
    assert_close(out["P"], Ps)


# (row, channel, offset): 40σ and more, far outside the 0.9999 gate's 3.9σ.
WILD = ((5, 0, 80.0), (20, 1, -150.0), (21, 0, 120.0), (21, 1, 200.0), (47, 1, 300.0))


@pytest.mark.parametrize("smooth", [False, True])
def test_gate_rejects_the_planted_wild_points_exactly(smooth):
    t = jittered(3)
    zs, us = record(3, t, wild=WILD)
    call = le.smooth_continuous if smooth else le.filter_continuous
    out = call(A, C, W, R, X0, P0, t, zs, us=us, B=B, gate=0.9999)
    rej = out["rejected"]
    assert rej["step"].dtype == np.int64 and rej["channel"].dtype == np.int64
    assert list(zip(rej["step"], rej["channel"])) == [(k, i) for k, i, _ in WILD]
    np.testing.assert_array_equal(rej["value"], [zs[k, i] for k, i, _ in WILD])
    ref, ref_rej = reference(t, zs, us, gate=0.9999)
    assert [(k, i) for k, i, _, _ in ref_rej] == [(k, i) for k, i, _ in WILD]
    assert_close(rej["nis"], [r for _, _, _, r in ref_rej])
    # The gate only turns the rejected entries into missing ones: the pass is the ungated
    # pass over the record with those entries NaN, bit for bit.
    masked = zs.copy()
    masked[rej["step"], rej["channel"]] = np.nan
    plain = call(A, C, W, R, X0, P0, t, masked, us=us, B=B)
    for key in plain:
        np.testing.assert_array_equal(out[key], plain[key])
    if not smooth:
        assert_close(out["x"], ref["x"])
        assert np.isnan(out["nis"][21])  # every entry of row 21 rejected: no update


def test_vector_gate_rejects_whole_steps_with_the_steps_statistic():
    t = jittered(4)
    zs, us = record(4, t, wild=((33, 0, 60.0),))
    out = le.filter_continuous(A, C, W, R, X0, P0, t, zs, us=us, B=B, gate=0.9999,
                               gate_rule="vector")
    rej = out["rejected"]
    present = np.flatnonzero(~np.isnan(zs[33]))
    assert list(rej["step"]) == [33] * len(present) and list(rej["channel"]) == list(present)
    assert np.isnan(out["nis"][33])
    # The statistic is the step's eᵀΣ⁻¹e over its present entries, from the prior.
    ungated = le.filter_continuous(A, C, W, R, X0, P0, t, zs, us=us, B=B)
    x, P = ungated["x_pred"][32], ungated["P_pred"][32]
    H = C[present]
    e = zs[33, present] - H @ x
    nis = e @ np.linalg.solve(H @ P @ H.T + R[np.ix_(present, present)], e)
    assert_close(rej["nis"], [nis] * len(present))


def test_discrete_filter_and_smoother_take_the_gate():
    dt = 0.1
    F, Qd, _ = cv_sampled(dt)
    t = dt * np.arange(50)
    zs, _ = record(5, t, wild=((10, 1, 100.0),))
    for call in (le.filter, le.smooth):
        out = call(F, C, Qd, R, X0, P0, zs, gate=0.9999)
        assert list(zip(out["rejected"]["step"], out["rejected"]["channel"])) == [(10, 1)]
        masked = zs.copy()
        masked[10, 1] = np.nan
        plain = call(F, C, Qd, R, X0, P0, masked)
        np.testing.assert_array_equal(out["x"], plain["x"])
        # A regular record through the continuous form is the same filter.
        cont = (le.filter_continuous if call is le.filter else le.smooth_continuous)(
            A, C, W, R, X0, P0, t, zs, gate=0.9999)
        assert_close(cont["x"], out["x"])
        assert_close(cont["P"], out["P"])


def test_equal_time_stamps_are_one_instant():
    """Two rows at one t, each with one sensor, are the one row with both (R diagonal, so a
    sequential update is the joint one); the first of them predicts nothing."""
    t = np.array([0.0, 0.4, 0.4, 1.0, 1.3])
    zs = np.array([[10.0, -20.0], [11.2, np.nan], [np.nan, -19.4], [12.9, -18.8],
                   [13.5, -18.5]])
    out = le.filter_continuous(A, C, W, R, X0, P0, t, zs)
    merged = le.filter_continuous(A, C, W, R, X0, P0, np.delete(t, 2),
                                  np.array([zs[0], [11.2, -19.4], zs[3], zs[4]]))
    assert_close(out["x_pred"][1], out["x"][1])
    assert_close(out["P_pred"][1], out["P"][1])
    assert_close(out["x"][2:], merged["x"][1:])
    assert_close(out["P"][2:], merged["P"][1:])
    # The last row predicts over 0 as well.
    assert_close(out["x_pred"][-1], out["x"][-1])
    sm = le.smooth_continuous(A, C, W, R, X0, P0, t, zs)
    assert_close(sm["x"][1], sm["x"][2])
    assert_close(sm["P"][1], sm["P"][2])
    # A record of one instant only is a sequence of updates.
    same = le.filter_continuous(A, C, W, R, X0, P0, np.full(3, 7.0), zs[:3])
    assert_close(same["P_pred"], same["P"])


def test_bad_input_names_the_step():
    args = (A, C, W, R, X0, P0)
    zs = np.zeros((4, D))
    with pytest.raises(ValueError, match=r"t\[3\] = 0\.2 is before t\[2\] = 0\.3"):
        le.filter_continuous(*args, np.array([0.0, 0.1, 0.3, 0.2]), zs)
    with pytest.raises(ValueError, match=r"t\[2\] has a non-finite entry"):
        le.smooth_continuous(*args, np.array([0.0, 0.1, np.nan, 0.2]), zs)
    fast = np.diag([900.0, 0.0, 0.0, 0.0])  # e^{900 Δt} overflows for Δt ≥ 0.79
    with pytest.raises(ValueError, match=r"t\[2\] − t\[1\] = 2 s that step 1"):
        le.filter_continuous(fast, *args[1:], np.array([0.0, 0.0, 2.0, 2.5]), zs)


@pytest.mark.parametrize("name", ["filter", "smooth", "filter_continuous", "smooth_continuous"])
def test_stub_signature_is_the_functions(name):
    """launch_estimation.pyi spells each whole-series function as the module defines it:
    the same parameters, in the same order, with the same defaults."""
    with open(os.path.join(os.path.dirname(__file__), "..", "launch_estimation.pyi")) as f:
        tree = ast.parse(f.read())
    stub = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name)
    names = [a.arg for a in stub.args.args]
    defaults = [ast.literal_eval(d) for d in stub.args.defaults]
    params = list(inspect.signature(getattr(le, name)).parameters.values())
    assert names == [p.name for p in params]
    assert defaults == [p.default for p in params if p.default is not inspect.Parameter.empty]


# ---- the golden record of `scenarios filter` (generated by its generate.py with scipy)

GOLDEN = os.path.join(os.path.dirname(__file__), "..", "..", "scenarios", "tests", "data",
                      "irregular")
# The README's precision notes: the stored doubles agree with 50-digit arithmetic to 6e-11
# in x (|px| up to 4e4) and 3e-13 in P; nis reaches 3e7, hence the relative part.
GOLDEN_TOL = 1e-8


def golden_csv(name):
    """A CSV of the golden record as an array (empty cells and NaN: NaN)."""
    return np.genfromtxt(os.path.join(GOLDEN, name), delimiter=",", skip_header=1)


@pytest.fixture(scope="module")
def golden():
    with open(os.path.join(GOLDEN, "model.json")) as f:
        m = {k: np.array(v, dtype=float) for k, v in json.load(f).items()}
    rec = golden_csv("record.csv")
    args = (m["A"], m["C"], m["G"] @ m["Qc"] @ m["G"].T, m["R"], m["x0"], m["P0"],
            rec[:, 0], rec[:, 1:])
    return rec, args


def assert_estimates(out, name, t):
    ref = golden_csv(name)
    np.testing.assert_array_equal(ref[:, 0], t)
    n = out["x"].shape[1]
    diag = np.diagonal(out["P"], axis1=1, axis2=2)
    for got, want in ((out["x"], ref[:, 1:1 + n]), (diag, ref[:, 1 + n:1 + 2 * n])):
        np.testing.assert_allclose(got, want, rtol=GOLDEN_TOL, atol=GOLDEN_TOL)
    if "nis" in out:
        np.testing.assert_allclose(out["nis"], ref[:, -1], rtol=GOLDEN_TOL, atol=GOLDEN_TOL)


def test_golden_record_ungated(golden):
    rec, args = golden
    out = le.filter_continuous(*args)
    assert_estimates(out, "filtered.csv", rec[:, 0])


def test_golden_record_gated_and_smoothed(golden):
    rec, args = golden
    t = rec[:, 0]
    out = le.filter_continuous(*args, gate=0.9999)
    assert_estimates(out, "gated.csv", t)
    assert np.flatnonzero(np.isnan(out["nis"])).size == 3
    with open(os.path.join(GOLDEN, "rejected.csv")) as f:
        want = list(csv.DictReader(f))
    rej = out["rejected"]
    assert len(want) == len(rej["step"]) == 6
    for j, row in enumerate(want):
        assert t[rej["step"][j]] == float(row["t"])
        assert rej["channel"][j] == int(row["channel"][1:]) - 1  # "z2" is channel 1
        assert rej["value"][j] == float(row["value"])
        assert abs(rej["nis"][j] - float(row["nis"])) <= GOLDEN_TOL * (1 + float(row["nis"]))
    sm = le.smooth_continuous(*args, gate=0.9999)
    assert_estimates(sm, "smoothed_gated.csv", t)
    for key in rej:
        np.testing.assert_array_equal(sm["rejected"][key], rej[key])
