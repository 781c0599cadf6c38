"""Golden data for the output-error estimator (`kalman::fit::output_error`), from SciPy's
MINPACK Levenberg–Marquardt (`scipy.optimize.least_squares(method="lm")`), an independent
implementation, with the Jacobian by complex-step differentiation (exact to round-off, and
not automatic differentiation).

Run in a throwaway venv:
    python3 -m venv /tmp/venv-oe && /tmp/venv-oe/bin/pip install numpy scipy
    /tmp/venv-oe/bin/python kalman/tests/golden/make_output_error.py
Writes output_error_pendulum.json next to this script: the record (torque u, measurements z,
NaN never), the starting guess, and SciPy's estimate, its covariance (JᵀJ)⁻¹ of the whitened
residuals (the Cramér–Rao bound) and the cost ½ Σ e_kᵀ R⁻¹ e_k.

The model is the one of `kalman/tests/fit/output_error.rs` (`Pendulum`): x = (φ, ω, b, s), a
damped pendulum under a known torque by symplectic Euler, Δt = 0.05 s, step k compares z_k
with h(x_k) and then predicts with f(x_k, u_k):
    ω⁺ = ω + (−9.81 sin φ − 0.1 ω + u) Δt,  φ⁺ = φ + ω⁺ Δt,  b⁺ = b,  s⁺ = s,
    h(x) = (sin φ + b, (1 + s) ω),  R = diag(4e-4, 2.5e-3).
"""

import json
import os

import numpy as np
from scipy.optimize import least_squares

DT = 0.05
STEPS = 200
R = np.array([4e-4, 2.5e-3])
TRUTH = np.array([0.5, 0.0, 0.05, 0.02])
START = np.array([0.3, 0.2, 0.0, 0.0])


def outputs(x0, u):
    """The outputs y_k (STEPS×2) from x0 (real or complex)."""
    phi, w, b, s = x0
    y = []
    for k in range(len(u)):
        y.append([np.sin(phi) + b, (1.0 + s) * w])
        w = w + (np.sin(phi) * -9.81 - w * 0.1 + u[k]) * DT
        phi = phi + w * DT
    return np.array(y)


def main():
    u = 0.3 * np.sin(0.5 * np.arange(STEPS) * DT)
    rng = np.random.default_rng(20261202)
    z = outputs(TRUTH, u) + rng.standard_normal((STEPS, 2)) * np.sqrt(R)
    sd = np.sqrt(R)

    def residuals(theta):
        return ((z - outputs(theta, u)) / sd).ravel()

    def jacobian(theta):
        h = 1e-30
        cols = []
        for j in range(len(theta)):
            t = theta.astype(complex)
            t[j] += 1j * h
            cols.append(-(outputs(t, u).imag / h / sd).ravel())
        return np.array(cols).T

    res = least_squares(residuals, START, jac=jacobian, method="lm",
                        xtol=1e-15, ftol=1e-15, gtol=1e-15)
    J = jacobian(res.x)
    cov = np.linalg.inv(J.T @ J)
    out = {
        "source": f"scipy {__import__('scipy').__version__} least_squares(method='lm'), complex-step Jacobian",
        "dt": DT,
        "r": R.tolist(),
        "start": START.tolist(),
        "truth": TRUTH.tolist(),
        "u": u.tolist(),
        "z": z.tolist(),
        "estimate": res.x.tolist(),
        "covariance": cov.tolist(),
        "cost": 0.5 * float(res.fun @ res.fun),
        "status": int(res.status),
    }
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "output_error_pendulum.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    print(res.status, res.x, np.sqrt(np.diag(cov)), out["cost"])


if __name__ == "__main__":
    main()
