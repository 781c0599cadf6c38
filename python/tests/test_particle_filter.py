"""particle_filter: the crate's bootstrap particle filter over vectorised Python callables.

Checked against the exact Kalman filter (`filter`) on a scalar linear-Gaussian model: the
particle mean's squared error in units of the filtered variance, times N, is of order one
(the Monte Carlo rate; a few for the bootstrap filter on this model, bound 5 as in the Rust
test), and the log-likelihood estimate is within a few of its standard errors of the
exact one. Then seeds, a quantized sensor (an impossible measurement has likelihood zero),
and every refusal.
"""

import numpy as np
import pytest

import launch_estimation as le

A, Q, R, P0 = 0.9, 0.5, 1.0, 1.0


def initial(N, rng):
    return np.sqrt(P0) * rng.standard_normal((N, 1))


def transition(X, k, rng):
    return A * X + np.sqrt(Q) * rng.standard_normal(X.shape)


def log_likelihood(X, z, k):
    e = z[0] - X[:, 0]
    return -0.5 * (np.log(2 * np.pi * R) + e * e / R)


def record(steps, seed):
    rng = np.random.default_rng(seed)
    x, zs = np.sqrt(P0) * rng.standard_normal(), []
    for _ in range(steps):
        zs.append(x + np.sqrt(R) * rng.standard_normal())
        x = A * x + np.sqrt(Q) * rng.standard_normal()
    return np.array(zs)


def exact(zs):
    m = lambda v: np.array([[v]])  # noqa: E731
    return le.filter(m(A), m(1.0), m(Q), m(R), np.zeros(1), m(P0), zs)


@pytest.mark.parametrize("resampling", ["systematic", "stratified", "residual", "multinomial"])
def test_converges_to_the_kalman_filter(resampling):
    zs = record(30, 5)
    kf = exact(zs)
    N = 4000
    errs, lls = [], []
    for seed in range(8):
        out = le.particle_filter(
            zs, initial, transition, log_likelihood, particles=N, resampling=resampling, seed=seed
        )
        assert out["x"].shape == (30, 1) and out["P"].shape == (30, 1, 1)
        errs.append(np.mean((out["x"][:, 0] - kf["x"][:, 0]) ** 2 / kf["P"][:, 0, 0]))
        lls.append(out["log_likelihood"])
    # N times the mean squared error, in units of P_{k|k}: of order one.
    assert N * np.mean(errs) < 5.0, N * np.mean(errs)
    # ln L: the estimate's spread over seeds is its standard error; the exact value lies
    # within four of them (and the spread is small: the estimate is good to ~0.1 nats).
    ll = float(np.sum(kf["log_likelihood"]))
    sd = max(np.std(lls), 1e-3)
    assert abs(np.mean(lls) - ll) < 4 * sd + 0.05, (np.mean(lls), ll, sd)
    assert sd < 0.2


def test_a_seed_gives_the_same_run():
    zs = record(10, 1)
    a = le.particle_filter(zs, initial, transition, log_likelihood, particles=500, seed=3)
    b = le.particle_filter(zs, initial, transition, log_likelihood, particles=500, seed=3)
    c = le.particle_filter(zs, initial, transition, log_likelihood, particles=500, seed=4)
    for k in ("x", "P", "ess", "particles", "log_weights"):
        np.testing.assert_array_equal(a[k], b[k])
    assert a["log_likelihood"] == b["log_likelihood"] != c["log_likelihood"]
    assert a["resampled"] == b["resampled"] and len(a["resampled"]) == 10
    # ess_threshold = 1 resamples at every step after the first.
    d = le.particle_filter(zs, initial, transition, log_likelihood, particles=500, ess_threshold=1)
    assert d["resampled"][1:] == [True] * 9


def test_a_quantized_sensor_and_a_missing_step():
    """z is the cell of width 0.5 the state fell in: every particle outside it has
    likelihood zero (−inf); the estimate lies in the cell. A NaN row only propagates."""
    delta = 0.5

    def cell(X, z, k):
        inside = (X[:, 0] >= z[0]) & (X[:, 0] < z[0] + delta)
        return np.where(inside, 0.0, -np.inf)

    zs = np.array([[0.0], [np.nan], [0.5], [0.5], [1.0]])
    out = le.particle_filter(zs, initial, transition, cell, particles=3000, seed=2)
    for k in (0, 2, 3, 4):
        assert zs[k, 0] <= out["x"][k, 0] < zs[k, 0] + delta
    assert np.isfinite(out["log_likelihood"])


def test_errors_name_what_is_wrong():
    zs = record(5, 2)

    class Boom(Exception):
        pass

    def failing(X, k, rng):
        if k == 2:
            raise Boom("at step 2")
        return transition(X, k, rng)

    with pytest.raises(Boom, match="at step 2"):
        le.particle_filter(zs, initial, failing, log_likelihood, particles=100)
    with pytest.raises(ValueError, match="transition"):
        le.particle_filter(zs, initial, lambda X, k, rng: X[:-1], log_likelihood, particles=100)
    with pytest.raises(ValueError, match="log_likelihood"):
        le.particle_filter(zs, initial, transition, lambda X, z, k: np.zeros(3), particles=100)
    with pytest.raises(ValueError, match="log_likelihood"):
        le.particle_filter(zs, initial, transition, lambda X, z, k: np.full(len(X), np.nan),
                           particles=100)
    with pytest.raises(ValueError, match="the likelihood"):
        le.particle_filter(zs, initial, transition, lambda X, z, k: np.full(len(X), -np.inf),
                           particles=100)
    with pytest.raises(ValueError, match="initial"):
        le.particle_filter(zs, lambda N, rng: np.zeros((N + 1, 1)), transition, log_likelihood)
    with pytest.raises(ValueError, match="initial"):
        le.particle_filter(zs, lambda N, rng: [0.0] * N, transition, log_likelihood)
    with pytest.raises(TypeError, match="transition must be callable"):
        le.particle_filter(zs, initial, 3, log_likelihood)
    with pytest.raises(ValueError, match="resampling"):
        le.particle_filter(zs, initial, transition, log_likelihood, resampling="roulette")
    with pytest.raises(ValueError, match="ess_threshold"):
        le.particle_filter(zs, initial, transition, log_likelihood, ess_threshold=0.0)
    with pytest.raises(ValueError, match="particles"):
        le.particle_filter(zs, initial, transition, log_likelihood, particles=0)
    with pytest.raises(MemoryError):
        le.particle_filter(zs, lambda N, rng: np.broadcast_to(np.zeros((1, 1)), (N, 1)),
                           transition, log_likelihood, particles=2**50)
