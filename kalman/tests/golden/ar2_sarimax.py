"""Helpers shared by make_statsmodels_ar2.py and compare_speed_ar2.py: a simulated AR(2)
seen through measurement noise, and statsmodels' SARIMAX(2,0,0) with measurement error on
it under a known prior."""

import numpy as np
import statsmodels.api as sm


def simulate(rng, n, phi1, phi2, sigma2, meas):
    """n measurements y_k = x_k[0] + v_k of the SARIMAX state x = [y_t, phi2 y_{t-1}] from
    x = 0: x_{k+1} = [phi1 x[0] + x[1] + w_k, phi2 x[0]], Var v = meas, Var w = sigma2; the
    draws from rng alternate v_k, w_k."""
    x = np.zeros(2)
    y = np.empty(n)
    for k in range(n):
        y[k] = x[0] + rng.normal() * np.sqrt(meas)
        x = np.array([phi1 * x[0] + x[1] + rng.normal() * np.sqrt(sigma2), phi2 * x[0]])
    return y


def sarimax(y, x0, P0):
    """SARIMAX(2,0,0) with measurement error on y, no trend, stationarity not enforced, the
    prior known (x0, P0) and no observation burnt: its log-likelihood is the Kalman filter's
    with that prior for the first measurement."""
    mod = sm.tsa.SARIMAX(y, order=(2, 0, 0), trend="n", measurement_error=True,
                         enforce_stationarity=False)
    mod.ssm.initialize_known(x0, P0)
    mod.ssm.loglikelihood_burn = 0
    return mod
