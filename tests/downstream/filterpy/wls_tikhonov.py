# The ill-conditioned WLS program with NumPy, for the length comparison (not run by the tests):
# the same fit, output and check as `src/bin/wls_tikhonov.rs`.
import numpy as np

t = np.arange(40) / 39.0
h = np.vander(t, 8, increasing=True)
truth = 1.0 / (1.0 + np.arange(8))
z = h @ truth + 1e-4 * ((7 * np.arange(40)) % 11) - 5e-4
plain, *_ = np.linalg.lstsq(h, z, rcond=None)
lam = 1e-6
h_reg = np.vstack([h, np.sqrt(lam) * np.eye(8)])
z_reg = np.concatenate([z, np.zeros(8)])
regularised, *_ = np.linalg.lstsq(h_reg, z_reg, rcond=None)
cond_plain, cond_reg = np.linalg.cond(h), np.linalg.cond(h_reg)
e_plain, e_reg = np.linalg.norm(plain - truth), np.linalg.norm(regularised - truth)
print(f"condition {cond_plain:.2e} -> {cond_reg:.2e}")
print(f"coefficient error {e_plain:.2e} -> {e_reg:.2e}")
# Independent check: the regularised normal equations.
closed_form = np.linalg.solve(h.T @ h + lam * np.eye(8), h.T @ z)
assert np.linalg.norm(regularised - closed_form) < 1e-6 * np.linalg.norm(closed_form)
assert cond_reg < cond_plain and e_reg < e_plain
