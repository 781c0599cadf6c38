"""Speed of launch_estimation.UnscentedKalmanFilter against FilterPy's on FilterPy's radar
example (its test_ukf.py: position, velocity, altitude; one range; Merwe's points, α = 0.1).

    python bench/bench_filterpy_ukf.py [--steps N]

Prints the time the callables alone take per step (the floor of any implementation), then,
for predict + update called from a Python loop and for batch_filter, the time per
step of FilterPy and of launch_estimation with ordinary callables (called once per sigma
point, as FilterPy calls them) and with vectorised ones (vectorized=True: called once with all
sigma points), and the ratios (FilterPy time / ours) on wall-clock and on CPU time (the
steadier one on a shared machine). Both filters run the same callables of each kind:
FilterPy's own fx and hx from its test file, and the same maps written with plain
arithmetic (no matrix built per call). The filters' results are checked to agree first.
Build the package in release mode for this (`pip install ./python`, or
`maturin develop --release`).
"""

import argparse

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints as FpMerwe
from filterpy.kalman import UnscentedKalmanFilter as FpUKF

import launch_estimation as le
from timing import best_of

DT = 0.05


# FilterPy's test_radar callables, as written there.
def fx_filterpy(x, dt):
    A = np.eye(3) + dt * np.array([[0, 1, 0], [0, 0, 0], [0, 0, 0]])
    return A.dot(x)


def hx_filterpy(x):
    return [np.sqrt(x[0] ** 2 + x[2] ** 2)]


# The same maps without building a matrix per call.
def fx_plain(x, dt):
    return np.array([x[0] + dt * x[1], x[1], x[2]])


def hx_plain(x):
    return np.array([np.sqrt(x[0] ** 2 + x[2] ** 2)])


# The same maps over all sigma points at once (rows).
def fx_vec(s, dt):
    out = s.copy()
    out[:, 0] += dt * s[:, 1]
    return out


def hx_vec(s):
    return np.sqrt(s[:, 0] ** 2 + s[:, 2] ** 2)


def ranges(steps, seed=200):
    rng = np.random.default_rng(seed)
    t = np.arange(steps) * DT
    return np.sqrt((100.0 * t) ** 2 + 1000.0**2) + rng.normal(0, 5, steps)


def make(cls, points, fx, hx, **kw):
    kf = cls(3, 1, DT, hx, fx, points(3, 0.1, 2.0, 0.0), **kw)
    kf.x = np.array([0.0, 90.0, 1100.0])
    kf.P *= 100.0
    kf.Q *= 0.01
    kf.R = 10.0
    return kf


def loop(kf, zs):
    for z in zs:
        kf.predict()
        kf.update([z])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    zs = ranges(args.steps)

    fp = lambda fx, hx: make(FpUKF, FpMerwe, fx, hx)
    ours = lambda fx, hx, **kw: make(le.UnscentedKalmanFilter, le.MerweScaledSigmaPoints, fx, hx, **kw)

    # The three kinds of filter agree before they are timed.
    ref, _ = fp(fx_filterpy, hx_filterpy).batch_filter(zs[:200])
    for kf in (ours(fx_filterpy, hx_filterpy), ours(fx_vec, hx_vec, vectorized=True)):
        got, _ = kf.batch_filter(zs[:200])
        assert np.allclose(got, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max()), "results differ"

    n = len(zs)
    # The callables alone, as often as a step calls them (7 points: fx and hx 7 times each,
    # or once each vectorised): the time no implementation of the filter can go below.
    pts = FpMerwe(3, 0.1, 2.0, 0.0).sigma_points(np.array([0.0, 90.0, 1100.0]), np.eye(3))

    def alone(fx, hx, vectorised):
        for _ in range(n):
            if vectorised:
                hx(fx(pts, DT))
            else:
                for p in pts:
                    hx(fx(p, DT))

    for cname, fx, hx, vec in (("FilterPy's callables", fx_filterpy, hx_filterpy, False),
                               ("plain callables", fx_plain, hx_plain, False),
                               ("vectorised callables", fx_vec, hx_vec, True)):
        t, _ = best_of(lambda: alone(fx, hx, vec), args.repeats)
        print(f"{cname} alone: {1e6 * t / n:.2f} µs/step")
    for label, run in (("predict + update loop", lambda kf: loop(kf, zs)),
                       ("batch_filter", lambda kf: kf.batch_filter(zs))):
        for cname, fx, hx in (("FilterPy's callables", fx_filterpy, hx_filterpy),
                              ("plain callables", fx_plain, hx_plain)):
            t_fp, c_fp = best_of(lambda: run(fp(fx, hx)), args.repeats)
            t_o, c_o = best_of(lambda: run(ours(fx, hx)), args.repeats)
            t_v, c_v = best_of(lambda: run(ours(fx_vec, hx_vec, vectorized=True)), args.repeats)
            print(f"{label}, {cname}, {n} steps: FilterPy {1e6 * t_fp / n:.1f} µs/step; "
                  f"ours {1e6 * t_o / n:.2f} µs/step ({t_fp / t_o:.1f}x, CPU {c_fp / c_o:.1f}x); "
                  f"ours vectorised {1e6 * t_v / n:.2f} µs/step ({t_fp / t_v:.1f}x, "
                  f"CPU {c_fp / c_v:.1f}x)")


if __name__ == "__main__":
    main()
