"""Many series at once: `filter_batch` against simdkalman and against `filter` series by
series, on the same data (constant-velocity models, m = 1, 10 % of the entries missing).

Run it in a throwaway venv with simdkalman and a release build of this module:

    python -m venv /tmp/venv-batch && /tmp/venv-batch/bin/pip install simdkalman numpy
    VIRTUAL_ENV=/tmp/venv-batch python -m maturin develop --release   # from python/
    /tmp/venv-batch/bin/python bench/bench_batch.py --series 10000 --steps 1000

It first checks that the three compute the same filtered means (simdkalman's filter is the
textbook one: its initial value is the prior of the first observation, as here), then prints
the best wall-clock time of each and the ratios. The scalar `filter` is timed on a sample of
the series and scaled to all of them.
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from timing import best_of  # noqa: E402

import launch_estimation as le  # noqa: E402


def cv_model(axes):
    """F, H, Q, R of `axes` constant-velocity axes (n = 2·axes), the first position measured."""
    dt, q = 0.1, 0.5
    f = np.array([[1.0, dt], [0.0, 1.0]])
    qb = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    F, Q = np.kron(np.eye(axes), f), np.kron(np.eye(axes), qb)
    H = np.zeros((1, 2 * axes))
    H[0, 0] = 1.0
    return F, H, Q, np.array([[0.25]])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--series", type=int, default=10000)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scalar-sample", type=int, default=200)
    args = ap.parse_args()
    import simdkalman

    rng = np.random.default_rng(1)
    for axes in (1, 2):
        F, H, Q, R = cv_model(axes)
        n = F.shape[0]
        x0, P0 = np.zeros(n), np.eye(n) * 10.0
        zs = np.cumsum(rng.standard_normal((args.series, args.steps)), axis=1)
        zs[rng.random(zs.shape) < 0.1] = np.nan
        kf = simdkalman.KalmanFilter(
            state_transition=F, process_noise=Q, observation_model=H, observation_noise=R
        )

        def ours():
            return le.filter_batch(F, H, Q, R, x0, P0, zs)["x"]

        def theirs():
            r = kf.compute(zs, 0, initial_value=x0, initial_covariance=P0, filtered=True)
            return r.filtered.states.mean

        sample = zs[: args.scalar_sample]

        def scalar():
            return [le.filter(F, H, Q, R, x0, P0, z)["x"] for z in sample]

        a, b, c = ours(), theirs(), np.array(scalar())
        diff_simd = float(np.max(np.abs(a - b)))
        diff_scalar = float(np.max(np.abs(a[: len(sample)] - c)))
        w_ours, _ = best_of(ours, args.repeats)
        w_simd, _ = best_of(theirs, args.repeats)
        w_scalar, _ = best_of(scalar, args.repeats)
        w_scalar *= args.series / len(sample)
        print(
            f"n = {n}: {args.series} series × {args.steps} steps: filter_batch {w_ours:.3f} s, "
            f"simdkalman {w_simd:.3f} s ({w_simd / w_ours:.1f}×), filter series by series "
            f"{w_scalar:.3f} s ({w_scalar / w_ours:.1f}×); max |Δx| vs simdkalman "
            f"{diff_simd:.1e}, vs filter {diff_scalar:.1e}"
        )


if __name__ == "__main__":
    main()
