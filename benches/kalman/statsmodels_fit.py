"""Times statsmodels' UnobservedComponents MLE (local linear trend) on the 3000-sample
series of benches/kalman/fit.rs (rebuilt bit for bit: same LCG, same Box-Muller), with the same
known prior and the same start (all three variances 1), so that both reach the same
optimum; both times include the standard errors (ours: the observed information in the
returned Fit; statsmodels': `bse`, forced inside the timed region). Compare with
`cargo bench -p stochest-benches --bench fit` (group fit_llt3000).

    python3 -m venv /tmp/venv-fit && /tmp/venv-fit/bin/pip install statsmodels numpy
    /tmp/venv-fit/bin/python benches/kalman/statsmodels_fit.py   -> median and best of 10, ms
"""
import math
import time

import numpy as np
import statsmodels.api as sm

MASK = (1 << 64) - 1


def llt_series(n):
    s = 20261127

    def uniform():
        nonlocal s
        s = (s * 6364136223846793005 + 1442695040888963407) & MASK
        return ((s >> 11) + 0.5) * (1.0 / 9007199254740992.0)

    def normal():
        a, b = uniform(), uniform()
        return math.sqrt(-2.0 * math.log(a)) * math.cos(2.0 * math.pi * b)

    level, slope = 0.0, 0.1
    z = []
    for _ in range(n):
        z.append(level + 2.0 * normal())
        level += slope + math.sqrt(0.5) * normal()
        slope += 0.1 * normal()
    return np.array(z)


def fit(y):
    mod = sm.tsa.UnobservedComponents(y, level="local linear trend")
    mod.ssm.initialize_known(np.array([y[0], 0.0]), np.diag([10.0, 1.0]))
    mod.ssm.loglikelihood_burn = 0
    return mod.fit(start_params=[1.0, 1.0, 1.0], disp=False)


def main():
    y = llt_series(3000)
    times = []
    for _ in range(10):
        t0 = time.perf_counter()
        res = fit(y)
        res.bse  # noqa: B018 (the standard errors, as ours are part of the fit)
        times.append(time.perf_counter() - t0)
    p = dict(zip(res.model.param_names, res.params))
    print(f"statsmodels {sm.__version__}: ln L = {res.llf:.6f}, R = {p['sigma2.irregular']:.6f}, "
          f"Q = diag({p['sigma2.level']:.6f}, {p['sigma2.trend']:.6f})")
    times.sort()
    median = 0.5 * (times[4] + times[5])
    print(f"fit: 10 runs, median {median * 1e3:.1f} ms, best {times[0] * 1e3:.1f} ms "
          f"(criterion's fit_llt3000 also takes 10 samples)")


if __name__ == "__main__":
    main()
