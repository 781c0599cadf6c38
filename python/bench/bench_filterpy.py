"""Speed of launch_estimation.KalmanFilter against FilterPy's on a (7, 2) problem.

    python bench/bench_filterpy.py [--steps N] [--loop-steps N]

Prints two ratios (FilterPy time / ours): batch_filter over N steps (one call into Rust),
and per-step predict + update called from a Python loop, each on wall-clock time and on the
process's CPU time (the CPU-time ratio is the steadier one on a shared machine). Build the
package in release mode for this (`pip install ./python`, or `maturin develop --release`).
"""

import argparse

import numpy as np
from filterpy.kalman import KalmanFilter as FpKalmanFilter

import launch_estimation as le
from timing import best_of


def problem(n=7, m=2, steps=100_000, seed=1):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    F = 0.95 * a / max(abs(np.linalg.eigvals(a)))
    H = rng.standard_normal((m, n))
    Q = 0.01 * np.eye(n)
    R = 0.1 * np.eye(m)
    zs = rng.standard_normal((steps, m, 1))
    return F, H, Q, R, zs


def make(cls, F, H, Q, R):
    n, m = F.shape[0], H.shape[0]
    kf = cls(n, m)
    kf.F, kf.H, kf.Q, kf.R = F.copy(), H.copy(), Q.copy(), R.copy()
    kf.P = np.eye(n)
    return kf


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=100_000)
    ap.add_argument("--loop-steps", type=int, default=20_000)
    args = ap.parse_args()
    F, H, Q, R, zs = problem(steps=args.steps)

    ours = make(le.KalmanFilter, F, H, Q, R)
    theirs = make(FpKalmanFilter, F, H, Q, R)
    (t_ours, c_ours) = best_of(lambda: ours.batch_filter(zs), 3)
    (t_fp, c_fp) = best_of(lambda: theirs.batch_filter(zs), 1)
    print(f"batch_filter, (7, 2), {args.steps} steps: FilterPy {t_fp:.3f} s, "
          f"launch_estimation {t_ours:.4f} s, ratio {t_fp / t_ours:.0f}x "
          f"(CPU time: {c_fp:.3f} s against {c_ours:.4f} s, {c_fp / c_ours:.0f}x)")

    loop_zs = zs[: args.loop_steps]

    def loop(kf):
        for z in loop_zs:
            kf.predict()
            kf.update(z)

    ours = make(le.KalmanFilter, F, H, Q, R)
    theirs = make(FpKalmanFilter, F, H, Q, R)
    (t_ours, c_ours) = best_of(lambda: loop(ours), 3)
    (t_fp, c_fp) = best_of(lambda: loop(theirs), 1)
    n = len(loop_zs)
    print(f"predict + update from a Python loop, (7, 2): FilterPy {1e6 * t_fp / n:.1f} µs/step, "
          f"launch_estimation {1e6 * t_ours / n:.2f} µs/step, ratio {t_fp / t_ours:.1f}x "
          f"(CPU time: {c_fp / c_ours:.1f}x)")


if __name__ == "__main__":
    main()
