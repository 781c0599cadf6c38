# The DARE + LQR program with SciPy (FilterPy has no Riccati solver), for the length comparison
# (not run by the tests): the same problems, output and checks as `src/bin/lqr.rs`.
import numpy as np
from scipy.linalg import solve_discrete_are

def rho(m):
    return max(abs(np.linalg.eigvals(m)))

dt = 0.25
a = np.array([[1.0, dt], [0.0, 1.0]])
b = np.array([[dt * dt / 2], [dt]])
h = np.array([[1.0, 0.0]])
q, r = np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]), np.array([[0.5]])
qx, ru = np.diag([1.0, 0.1]), np.eye(1)
p = solve_discrete_are(a.T, h.T, q, r)
k = p @ h.T @ np.linalg.inv(h @ p @ h.T + r)
x = solve_discrete_are(a, b, qx, ru)
l = np.linalg.solve(ru + b.T @ x @ b, b.T @ x @ a)
print("Kalman gain K =", k, "LQR gain L =", l)
# Independent checks: both Riccati residuals, both closed loops stable.
dare_res = a @ p @ a.T + q - a @ p @ h.T @ np.linalg.solve(h @ p @ h.T + r, h @ p @ a.T) - p
lqr_res = a.T @ x @ a + qx - a.T @ x @ b @ np.linalg.solve(ru + b.T @ x @ b, b.T @ x @ a) - x
assert np.linalg.norm(dare_res) < 1e-10 * np.linalg.norm(p)
assert np.linalg.norm(lqr_res) < 1e-10 * np.linalg.norm(x)
assert rho((np.eye(2) - k @ h) @ a) < 1 and rho(a - b @ l) < 1
