"""Golden indices for the particle filters' resampling schemes, from FilterPy 1.4.5's
`filterpy.monte_carlo` (an independent implementation), fed the same uniforms.

Run in a throwaway venv:
    python3 -m venv /tmp/venv-pf && /tmp/venv-pf/bin/pip install filterpy==1.4.5 numpy
    /tmp/venv-pf/bin/python kalman/tests/golden/make_resampling.py
Writes `filterpy_resampling.json` next to this script: a list of cases, each with
- `weights` (normalised, some cases with exact zeros and one dominant particle),
- for each scheme in {multinomial, stratified, systematic, residual}: the `uniforms` handed
  to FilterPy (its module-level `random` replaced by a function returning them) and the
  `indices` it returned.

FilterPy draws its uniforms with `numpy.random.random`: N of them for multinomial and
stratified, one for systematic, N - k for residual (k = the deterministic copies). The
uniforms are drawn here and stored, so the Rust tests hand the same numbers to
`kalman::particle::Resampling::resample`.

Residual resampling: FilterPy 1.4.5 computes the fractional part as `weights - num_copies`,
where the definition (Liu and Chen, 1998) is `N*weights - num_copies`. Its deterministic copies
are right; its random part draws from the wrong residual distribution. The script stores
FilterPy's own output (`residual`) and that of FilterPy's function with the one line
corrected (`residual_corrected`); the Rust tests compare the deterministic copies with the
former and every index with the latter.
"""

import json
import os

import numpy as np
import filterpy
from filterpy.monte_carlo import resampling

HERE = os.path.dirname(os.path.abspath(__file__))
assert filterpy.__version__ == "1.4.5", filterpy.__version__


def with_uniforms(func, weights, uniforms):
    """Runs a FilterPy resampling function with its `random` returning `uniforms`."""
    saved = resampling.random
    calls = []

    def fake(size=None):
        calls.append(size)
        if size is None:
            assert len(uniforms) == 1
            return float(uniforms[0])
        assert size == len(uniforms), (size, len(uniforms))
        return np.array(uniforms, dtype=float)

    resampling.random = fake
    try:
        out = func(np.array(weights, dtype=float))
    finally:
        resampling.random = saved
    assert len(calls) == 1
    return [int(i) for i in out]


def residual_corrected(weights):
    """FilterPy 1.4.5's residual_resample with the fractional part N*w - floor(N*w)."""
    N = len(weights)
    indexes = np.zeros(N, "i")
    num_copies = (np.floor(N * np.asarray(weights))).astype(int)
    k = 0
    for i in range(N):
        for _ in range(num_copies[i]):
            indexes[k] = i
            k += 1
    residual = N * np.asarray(weights) - num_copies  # the one corrected line
    residual /= sum(residual)
    cumulative_sum = np.cumsum(residual)
    cumulative_sum[-1] = 1.0
    indexes[k:N] = np.searchsorted(cumulative_sum, resampling.random(N - k))
    return indexes


def case(rng, weights):
    w = np.asarray(weights, dtype=float)
    w = w / w.sum()
    n = len(w)
    k = int(np.floor(n * w).sum())
    out = {"weights": [float(v) for v in w]}
    for name, func, count in [
        ("multinomial", resampling.multinomial_resample, n),
        ("stratified", resampling.stratified_resample, n),
        ("systematic", resampling.systematic_resample, 1),
        ("residual", resampling.residual_resample, n - k),
    ]:
        u = [float(v) for v in rng.random(count)]
        out[name] = {"uniforms": u, "indices": with_uniforms(func, w, u)}
        if name == "residual":
            out["residual_corrected"] = {
                "uniforms": u,
                "indices": with_uniforms(residual_corrected, w, u),
            }
    return out


def main():
    rng = np.random.default_rng(20261202)
    cases = []
    for n in [5, 10, 50, 200, 1000]:
        cases.append(case(rng, rng.random(n)))  # mild spread
        cases.append(case(rng, np.exp(3.0 * rng.standard_normal(n))))  # log-normal, skewed
    # Exact zeros and one dominant particle.
    w = rng.random(40)
    w[::3] = 0.0
    w[7] = 25.0
    cases.append(case(rng, w))
    with open(os.path.join(HERE, "filterpy_resampling.json"), "w") as f:
        json.dump({"filterpy": filterpy.__version__, "cases": cases}, f)
        f.write("\n")


if __name__ == "__main__":
    main()
