"""Golden data for the Riccati benchmark test: the CAREX and DAREX collections of Benner,
Laub and Mehrmann ("A collection of benchmark examples for the numerical solution of
algebraic Riccati equations", I: continuous-time, II: discrete-time) as SciPy's own tests
carry them, with SciPy's answers (an independent implementation: the Schur/QZ method of
solve_continuous_are / solve_discrete_are with balancing).

Run in a throwaway venv from the repository root:
    python3 -m venv /tmp/venv-ric && /tmp/venv-ric/bin/pip install scipy numpy pytest
    /tmp/venv-ric/bin/python kalman/tests/data/riccati/make_benchmarks.py
Writes kalman/tests/data/riccati/{carex,darex}.json. The problems are read from SciPy's
test module (scipy/linalg/tests/test_solvers.py, its TestSolveContinuousAre.cases and
TestSolveDiscreteAre.cases), so they are exactly the matrices SciPy tests, not retyped.
Only the real problems are kept (the first three DARE cases are complex). Each problem
stores, in the control form SciPy solves (CARE XA + AᵀX − XBR⁻¹BᵀX + Q = 0, DARE
X = AᵀXA − AᵀXB(R + BᵀXB)⁻¹BᵀXA + Q):
  a, b, q, r      sparse: {"rows", "cols", "entries": [[i, j, value], ...]}
  known_failure   SciPy's xfail reason, or null
  scipy_error     the exception SciPy raised, or null
  scipy_residual  ‖Res(X)‖_F / ‖X‖_F of SciPy's X (null if it raised)
  scipy_stable    whether SciPy's X stabilises the closed loop (A − BL)
  x               SciPy's X, dense row-major (only for n <= 100 and no known failure)
"""
import json
import os
import time

import numpy as np
import scipy
from scipy.linalg import solve, solve_continuous_are, solve_discrete_are
from scipy.linalg.tests import test_solvers

HERE = os.path.dirname(os.path.abspath(__file__))
MAX_STORED_X = 100


def sparse(m):
    m = np.atleast_2d(np.asarray(m, dtype=float))
    entries = [[int(i), int(j), float(m[i, j])] for i, j in zip(*np.nonzero(m))]
    return {"rows": m.shape[0], "cols": m.shape[1], "entries": entries}


def care_residual(a, b, q, r, x):
    xb = x @ b
    res = x @ a + a.T @ x + q - xb @ solve(r, xb.T)
    gain = solve(r, b.T @ x)
    stable = bool(np.max(np.linalg.eigvals(a - b @ gain).real) < 0)
    return res, stable


def dare_residual(a, b, q, r, x):
    xa, xb = x @ a, x @ b
    sigma = r + b.T @ xb
    res = a.T @ xa - x + q - a.T @ xb @ solve(sigma, xb.T @ a)
    gain = solve(sigma, b.T @ xa)
    stable = bool(np.max(np.abs(np.linalg.eigvals(a - b @ gain))) < 1)
    return res, stable


def collect(cases, solver, residual, first_label, offset):
    out = []
    for j, (a, b, q, r, known) in enumerate(cases):
        if any(np.iscomplexobj(np.asarray(m)) for m in (a, b, q, r)):
            continue
        a, b, q, r = (np.atleast_2d(np.asarray(m, dtype=float)) for m in (a, b, q, r))
        entry = {
            "case": j,
            "name": f"{first_label} #{j + 1 - offset}",
            "n": a.shape[0],
            "m": b.shape[1],
            "a": sparse(a),
            "b": sparse(b),
            "q": sparse(q),
            "r": sparse(r),
            "known_failure": known,
            "scipy_error": None,
            "scipy_residual": None,
            "scipy_stable": None,
            "x": None,
        }
        t0 = time.time()
        try:
            x = solver(a, b, q, r)
            res, stable = residual(a, b, q, r, x)
            entry["scipy_residual"] = float(np.linalg.norm(res) / np.linalg.norm(x))
            entry["scipy_stable"] = stable
            if known is None and a.shape[0] <= MAX_STORED_X:
                entry["x"] = [float(v) for v in x.ravel()]
        except Exception as e:  # noqa: BLE001 (SciPy's refusal is data here)
            entry["scipy_error"] = f"{type(e).__name__}: {e}"
        print(entry["name"], entry["n"], entry["scipy_residual"], entry["scipy_error"],
              f"{time.time() - t0:.2f} s")
        out.append(entry)
    return out


def write(name, problems):
    doc = {
        "source": "scipy " + scipy.__version__ + ", scipy/linalg/tests/test_solvers.py",
        "problems": problems,
    }
    with open(os.path.join(HERE, name), "w") as f:
        json.dump(doc, f, separators=(",", ":"))
        f.write("\n")


# SciPy's CARE cases are CAREX #1..#20 in order; its DARE cases 0–3 are its own (three
# complex ones and a user report), DAREX #1..#15 follow.
write("carex.json", collect(test_solvers.TestSolveContinuousAre.cases, solve_continuous_are,
                            care_residual, "CAREX", 0))
darex = collect(test_solvers.TestSolveDiscreteAre.cases, solve_discrete_are, dare_residual,
                "DAREX", 4)
for p in darex:
    if p["case"] == 3:
        p["name"] = "SciPy gh-2251"
write("darex.json", darex)
