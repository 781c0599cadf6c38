# The DARE + LQR program with SciPy (FilterPy has no Riccati solver), for the length comparison
# (not run by the tests): the same problems, output and checks as `src/bin/lqr.rs`.
import numpy as np
from scipy.linalg import solve_discrete_are


def residual(a, b, q, r, x):
    # The control-form DARE residual; the filter DARE is its dual (A -> F^T, B -> H^T).
    gain = np.linalg.solve(r + b.T @ x @ b, b.T @ x @ a)
    return np.linalg.norm(a.T @ x @ (a - b @ gain) + q - x) / np.linalg.norm(x)


dt = 0.25
a = np.array([[1.0, dt], [0.0, 1.0]])
b, h = np.array([[dt * dt / 2], [dt]]), np.array([[1.0, 0.0]])
q = np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
r, qx, ru = np.array([[0.5]]), np.diag([1.0, 0.1]), np.eye(1)
p = solve_discrete_are(a.T, h.T, q, r)
k = p @ h.T @ np.linalg.inv(h @ p @ h.T + r)
x = solve_discrete_are(a, b, qx, ru)
l = np.linalg.solve(ru + b.T @ x @ b, b.T @ x @ a)
print("Kalman gain K =", k, "LQR gain L =", l)
# Independent checks: both Riccati residuals, both closed loops stable.
assert residual(a.T, h.T, q, r, p) < 1e-10
assert residual(a, b, qx, ru, x) < 1e-10


def stable(m):
    return all(abs(np.linalg.eigvals(m)) < 1)


assert stable((np.eye(2) - k @ h) @ a) and stable(a - b @ l)
