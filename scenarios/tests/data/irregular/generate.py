#!/usr/bin/env python3
"""Golden data for `scenarios filter` on an irregular, multi-rate record
with a CONTINUOUS model and a per-entry wild-point gate.

What it computes
----------------
* Simulates a 2-D constant-velocity target, x = [px, py, vx, vy] (m, m/s),
  dx/dt = A x + G w, G = I, white-acceleration intensity Qc = diag(0, 0, q, q),
  q = 0.5 m^2/s^3. The truth is propagated exactly between consecutive time
  stamps: x_{k+1} = F_k x_k + w_k, w_k ~ N(0, Q_d,k), with (F_k, Q_d,k) from
  Van Loan's method.
* Measurements z = C x + v, C = rows (px, py, vx), R = diag(4, 4, 0.04):
  a GNSS fix (z1 = gnss_x, z2 = gnss_y) at ~1 Hz (1.0 s +- 0.05 s jitter)
  and a velocity sensor (z3 = vel_x) at ~10 Hz (0.1 s +- 0.03 s jitter),
  stamps rounded to 1e-4 s, a 5 s dropout with no samples at all, three
  instants where both sensors report at the identical t (two CSV rows,
  Delta t = 0 between them), and six planted wild entries (listed in wild.csv).
* Runs the reference Kalman filter (prior (x0, P0) at the first row; update,
  then Van Loan predict to the next row; Joseph-form update; solves, never
  inverses) without a gate (filtered.csv) and with a per-entry gate
  e_i^2 / Sigma_ii > chi2.ppf(0.9999, 1) (gated.csv, rejected.csv), then the
  RTS smoother over the gated pass (smoothed_gated.csv).
* Checks itself and exits non-zero if: the gate does not reject exactly the
  planted wild entries; the ungated position error right after the wild
  points is not clearly larger than the gated one; the gated mean NIS is
  not near its expectation; or the record is not shaped as intended.

How to rerun
------------
From this directory, in a virtual environment that has numpy and scipy
(versions used are listed in README.md):

    python3 -m venv /tmp/golden-venv
    /tmp/golden-venv/bin/pip install numpy scipy
    /tmp/golden-venv/bin/python generate.py      # i.e. `python3 generate.py`

It is deterministic (fixed seed) and overwrites model.json, record.csv,
truth.csv, wild.csv, filtered.csv, gated.csv, rejected.csv and
smoothed_gated.csv in the directory that contains this script.
"""

import json
import math
import os
import sys

import numpy as np
import scipy.linalg
from scipy.stats import chi2

SEED = 20240611
OUT = os.path.dirname(os.path.abspath(__file__))

N_STATE = 4
A = np.array([[0.0, 0.0, 1.0, 0.0],
              [0.0, 0.0, 0.0, 1.0],
              [0.0, 0.0, 0.0, 0.0],
              [0.0, 0.0, 0.0, 0.0]])
G = np.eye(N_STATE)
Q_INTENSITY = 0.5
QC = np.diag([0.0, 0.0, Q_INTENSITY, Q_INTENSITY])
C = np.array([[1.0, 0.0, 0.0, 0.0],
              [0.0, 1.0, 0.0, 0.0],
              [0.0, 0.0, 1.0, 0.0]])
R = np.diag([4.0, 4.0, 0.04])
X0 = np.array([4990.0, -2990.0, 290.0, 10.0])
P0 = np.diag([100.0, 100.0, 400.0, 400.0])
X_TRUE0 = np.array([5000.0, -3000.0, 300.0, 20.0])

GATE_PROB = 0.9999
GATE = float(chi2.ppf(GATE_PROB, 1))

DURATION = 120.0
VEL_PERIOD, VEL_JITTER = 0.1, 0.03
GNSS_PERIOD, GNSS_JITTER = 1.0, 0.05
DROPOUT = (70.0, 75.0)  # no sample with DROPOUT[0] < t < DROPOUT[1]
# GNSS fixes whose stamp is snapped onto a velocity stamp (same-t pairs), and
# which of the two rows comes first in the file at that instant.
PAIRS = {0: "gnss_first", 30: "gnss_first", 90: "vel_first"}
VEL_SIGMA = math.sqrt(R[2, 2])
WILD_VEL_OFFSET = 50.0 * VEL_SIGMA
MULTIPATH = 400.0


def fail(msg):
    print("SELF-CHECK FAILED: " + msg, file=sys.stderr)
    sys.exit(1)


def van_loan(dt):
    """(F, Q_d) of the continuous model over dt; exactly (I, 0) for dt == 0."""
    n = N_STATE
    if dt == 0.0:
        return np.eye(n), np.zeros((n, n))
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n] = -A
    M[:n, n:] = G @ QC @ G.T
    M[n:, n:] = A.T
    E = scipy.linalg.expm(M * dt)
    F = E[n:, n:].T
    Qd = F @ E[:n, n:]
    return F, 0.5 * (Qd + Qd.T)


# ----------------------------------------------------------------- record
def make_stamps(rng):
    n_vel = int(round(DURATION / VEL_PERIOD))
    vel = np.round(np.arange(n_vel + 1) * VEL_PERIOD
                   + rng.uniform(-VEL_JITTER, VEL_JITTER, n_vel + 1), 4)
    vel[0] = 0.0
    n_gnss = int(round(DURATION / GNSS_PERIOD))
    gnss = np.round(np.arange(n_gnss + 1) * GNSS_PERIOD
                    + rng.uniform(-GNSS_JITTER, GNSS_JITTER, n_gnss + 1), 4)
    gnss[0] = 0.0
    for i in PAIRS:
        gnss[i] = vel[np.argmin(np.abs(vel - gnss[i]))]
    keep_v = ~((vel > DROPOUT[0]) & (vel < DROPOUT[1]))
    keep_g = ~((gnss > DROPOUT[0]) & (gnss < DROPOUT[1]))
    return vel[keep_v], gnss[keep_g]


def main():
    rng = np.random.default_rng(SEED)
    vel, gnss = make_stamps(rng)

    # Which GNSS stamps are deliberate pairs, and their order.
    gnss_all_idx = np.round(gnss / GNSS_PERIOD).astype(int)
    order_at = {}
    for t, i in zip(gnss, gnss_all_idx):
        if int(i) in PAIRS:
            order_at[float(t)] = PAIRS[int(i)]
    rank = {"gnss_first": {"gnss": 0, "vel": 1}, "vel_first": {"gnss": 1, "vel": 0}}
    rows = [(float(t), "vel") for t in vel] + [(float(t), "gnss") for t in gnss]
    rows.sort(key=lambda r: (r[0], rank[order_at.get(r[0], "gnss_first")][r[1]]))
    t_rows = np.array([r[0] for r in rows])
    kinds = [r[1] for r in rows]
    n_rows = len(rows)

    # ---- shape checks on the stamps
    dts = np.diff(t_rows)
    if np.any(dts < 0.0):
        fail("rows not ordered by t")
    zero_dt = [k for k in range(n_rows - 1) if dts[k] == 0.0]
    for k in zero_dt:
        if {kinds[k], kinds[k + 1]} != {"gnss", "vel"}:
            fail(f"same-t rows at t={t_rows[k]} are not one GNSS + one velocity row")
        if float(t_rows[k]) not in order_at:
            fail(f"accidental same-t pair at t={t_rows[k]}")
    if len(zero_dt) != len(PAIRS):
        fail(f"expected {len(PAIRS)} same-t pairs, found {len(zero_dt)}")
    if any(zero_dt[j + 1] - zero_dt[j] < 2 for j in range(len(zero_dt) - 1)):
        fail("three rows at one instant")
    gap = dts.max()
    if not (5.0 <= gap < 5.3):
        fail(f"largest gap {gap} is not the ~5 s dropout")
    if t_rows[0] != 0.0 or kinds[0] != "gnss":
        fail("first row should be the GNSS fix at t = 0")

    # ---- truth, exact between stamps
    truth = np.zeros((n_rows, N_STATE))
    truth[0] = X_TRUE0
    for k in range(n_rows - 1):
        F, Qd = van_loan(float(dts[k]))
        if dts[k] == 0.0:
            truth[k + 1] = truth[k]
        else:
            L = np.linalg.cholesky(Qd)
            truth[k + 1] = F @ truth[k] + L @ rng.standard_normal(N_STATE)

    # ---- clean measurements
    Z = np.full((n_rows, 3), np.nan)
    sd = np.sqrt(np.diag(R))
    for k in range(n_rows):
        y = C @ truth[k]
        if kinds[k] == "gnss":
            Z[k, 0:2] = y[0:2] + sd[0:2] * rng.standard_normal(2)
        else:
            Z[k, 2] = y[2] + sd[2] * rng.standard_normal()

    # ---- planted wild entries
    gnss_rows = [k for k in range(n_rows) if kinds[k] == "gnss"]
    vel_rows = [k for k in range(n_rows) if kinds[k] == "vel"]

    def gnss_row_near(t):
        return min(gnss_rows, key=lambda k: abs(t_rows[k] - t))

    def vel_row_near(t):
        return min(vel_rows, key=lambda k: abs(t_rows[k] - t))

    wild = []  # (row, channel index 0..2)
    k = gnss_row_near(20.0)            # GNSS dropout read as zero, both axes
    Z[k, 0] = 0.0
    Z[k, 1] = 0.0
    wild += [(k, 0), (k, 1)]
    k = min(kk for kk in gnss_rows if t_rows[kk] > DROPOUT[1])  # first fix after dropout
    Z[k, 1] = 0.0                      # y read as zero, x fine
    wild.append((k, 1))
    k = vel_row_near(40.55)            # velocity +50 sigma
    Z[k, 2] += WILD_VEL_OFFSET
    wild.append((k, 2))
    t90 = next(t for t, m in order_at.items() if m == "vel_first")
    k = next(kk for kk in vel_rows if t_rows[kk] == t90)  # -50 sigma, inside a same-t pair
    Z[k, 2] -= WILD_VEL_OFFSET
    wild.append((k, 2))
    k = gnss_row_near(105.0)           # multipath on y
    Z[k, 1] += MULTIPATH
    wild.append((k, 1))
    wild.sort()
    wild_set = {(float(t_rows[k]), i) for k, i in wild}
    if len(wild_set) != 6:
        fail("wild entries overlap")

    # ---- reference filter
    def run(gated):
        n = N_STATE
        xf = np.zeros((n_rows, n))
        Pf = np.zeros((n_rows, n, n))
        xp = np.zeros((n_rows, n))
        Pp = np.zeros((n_rows, n, n))
        Fs = [None] * n_rows
        nis = np.full(n_rows, np.nan)
        used = np.zeros(n_rows, dtype=int)
        rejected = []  # (row, channel, value, e^2/Sigma_ii)
        x, P = X0.copy(), P0.copy()
        for k in range(n_rows):
            xp[k], Pp[k] = x, P
            present = [i for i in range(3) if not np.isnan(Z[k, i])]
            kept = present
            if gated and present:
                H = C[present]
                e = Z[k, present] - H @ x
                S = H @ P @ H.T + R[np.ix_(present, present)]
                kept = []
                for j, i in enumerate(present):
                    r = e[j] * e[j] / S[j, j]
                    if r > GATE:
                        rejected.append((k, i, float(Z[k, i]), float(r)))
                    else:
                        kept.append(i)
            if kept:
                H = C[kept]
                Ro = R[np.ix_(kept, kept)]
                e = Z[k, kept] - H @ x
                S = H @ P @ H.T + Ro
                cho = scipy.linalg.cho_factor(S)
                K = scipy.linalg.cho_solve(cho, H @ P).T  # = P H^T S^-1 (S, P symmetric)
                nis[k] = float(e @ scipy.linalg.cho_solve(cho, e))
                x = x + K @ e
                IKH = np.eye(n) - K @ H
                P = IKH @ P @ IKH.T + K @ Ro @ K.T
                P = 0.5 * (P + P.T)
                used[k] = len(kept)
            xf[k], Pf[k] = x, P
            if k < n_rows - 1:
                F, Qd = van_loan(float(dts[k]))
                Fs[k] = F
                x = F @ x
                P = F @ P @ F.T + Qd
        return dict(xf=xf, Pf=Pf, xp=xp, Pp=Pp, F=Fs, nis=nis, used=used,
                    rejected=rejected)

    plain = run(gated=False)
    gated = run(gated=True)

    # ---- RTS smoother over the gated pass
    xs = gated["xf"].copy()
    Ps = gated["Pf"].copy()
    for k in range(n_rows - 2, -1, -1):
        if dts[k] == 0.0:  # F = I, Q_d = 0: P_p[k+1] = P_f[k], C_k = I
            xs[k] = xs[k + 1]
            Ps[k] = Ps[k + 1]
            continue
        F = gated["F"][k]
        Pp1 = gated["Pp"][k + 1]
        Ck = scipy.linalg.solve(Pp1, F @ gated["Pf"][k], assume_a="pos").T
        xs[k] = gated["xf"][k] + Ck @ (xs[k + 1] - gated["xp"][k + 1])
        P = gated["Pf"][k] + Ck @ (Ps[k + 1] - Pp1) @ Ck.T
        Ps[k] = 0.5 * (P + P.T)

    # ---- self-checks
    rej_set = {(float(t_rows[k]), i) for k, i, _, _ in gated["rejected"]}
    names = ["z1", "z2", "z3"]
    if rej_set != wild_set:
        extra = sorted(rej_set - wild_set)
        missed = sorted(wild_set - rej_set)
        fail(f"gate rejects {sorted(rej_set)}; false rejects {extra}, missed {missed}")

    wild_t = sorted({float(t_rows[k]) for k, _ in wild})
    win = np.zeros(n_rows, dtype=bool)
    for tw in wild_t:
        win |= (t_rows >= tw) & (t_rows <= tw + 3.0)

    def pos_rms(xf, mask):
        d = xf[mask, 0:2] - truth[mask, 0:2]
        return float(np.sqrt(np.mean(np.sum(d * d, axis=1))))

    rms_plain_win = pos_rms(plain["xf"], win)
    rms_gated_win = pos_rms(gated["xf"], win)
    rms_plain_all = pos_rms(plain["xf"], np.ones(n_rows, bool))
    rms_gated_all = pos_rms(gated["xf"], np.ones(n_rows, bool))
    rms_smooth_all = pos_rms(xs, np.ones(n_rows, bool))
    print(f"position RMS error, rows within 3 s after a wild point ({win.sum()} rows): "
          f"ungated {rms_plain_win!r} m, gated {rms_gated_win!r} m")
    print(f"position RMS error, all rows: ungated {rms_plain_all!r} m, "
          f"gated {rms_gated_all!r} m, gated+RTS {rms_smooth_all!r} m")
    if not rms_plain_win > 10.0 * rms_gated_win:
        fail("ungated error after wild points is not clearly larger than gated")

    ok = ~np.isnan(gated["nis"])
    mean_nis = float(np.mean(gated["nis"][ok]))
    expect = float(np.mean(gated["used"][ok]))
    se = math.sqrt(2.0 * gated["used"][ok].sum()) / ok.sum()
    print(f"gated mean NIS {mean_nis!r} over {ok.sum()} rows; expectation "
          f"{expect!r} (mean entries used), std. error {se:.4f}, "
          f"z = {(mean_nis - expect) / se:+.2f}")
    if abs(mean_nis - expect) > 4.0 * se:
        fail("gated mean NIS is not near its expectation")

    for k in range(n_rows - 1):  # smoothed estimates agree at same-t pairs
        if dts[k] == 0.0 and not np.array_equal(xs[k], xs[k + 1]):
            fail("smoothed states differ within a same-t pair")

    # ---- write
    def fmt(v):
        v = float(v)
        return "NaN" if math.isnan(v) else repr(v)

    def write_csv(name, header, rows_):
        with open(os.path.join(OUT, name), "w", newline="") as f:
            f.write(",".join(header) + "\n")
            for r in rows_:
                f.write(",".join(c if isinstance(c, str) else fmt(c) for c in r) + "\n")
        return len(rows_)

    model = {
        "A": A.tolist(), "G": G.tolist(), "Qc": QC.tolist(), "C": C.tolist(),
        "R": R.tolist(), "x0": X0.tolist(), "P0": P0.tolist(),
    }
    with open(os.path.join(OUT, "model.json"), "w") as f:
        items = []
        for key, val in model.items():
            if isinstance(val[0], list):  # matrix: one row per line
                body = ",\n    ".join(json.dumps(row) for row in val)
                items.append(f'  "{key}": [\n    {body}\n  ]')
            else:
                items.append(f'  "{key}": {json.dumps(val)}')
        f.write("{\n" + ",\n".join(items) + "\n}\n")
    with open(os.path.join(OUT, "model.json")) as f:
        if json.load(f) != model:
            fail("model.json does not read back")

    counts = {}
    counts["record.csv"] = write_csv(
        "record.csv", ["t", "z1", "z2", "z3"],
        [[t_rows[k]] + ["" if np.isnan(z) else z for z in Z[k]] for k in range(n_rows)])
    counts["truth.csv"] = write_csv(
        "truth.csv", ["t", "px", "py", "vx", "vy"],
        [[t_rows[k], *truth[k]] for k in range(n_rows)])
    counts["wild.csv"] = write_csv(
        "wild.csv", ["t", "channel", "value"],
        [[t_rows[k], names[i], Z[k, i]] for k, i in wild])
    head = ["t", "x1", "x2", "x3", "x4", "P1_1", "P2_2", "P3_3", "P4_4", "nis"]

    def est_rows(x, P, nis):
        return [[t_rows[k], *x[k], *np.diag(P[k]), nis[k]] for k in range(n_rows)]

    counts["filtered.csv"] = write_csv("filtered.csv", head,
                                       est_rows(plain["xf"], plain["Pf"], plain["nis"]))
    counts["gated.csv"] = write_csv("gated.csv", head,
                                    est_rows(gated["xf"], gated["Pf"], gated["nis"]))
    counts["rejected.csv"] = write_csv(
        "rejected.csv", ["t", "channel", "value", "nis"],
        [[t_rows[k], names[i], v, r] for k, i, v, r in gated["rejected"]])
    counts["smoothed_gated.csv"] = write_csv("smoothed_gated.csv", head,
                                             est_rows(xs, Ps, gated["nis"]))

    # ---- summary
    pos = dts[dts > 0.0]
    print(f"gate threshold chi2.ppf({GATE_PROB}, 1) = {GATE!r}")
    print(f"rows {n_rows} (GNSS {len(gnss_rows)}, velocity {len(vel_rows)}), "
          f"same-t pairs {len(zero_dt)} at t = {[float(t_rows[k]) for k in zero_dt]}")
    print(f"dt range: min {float(dts.min())!r}, min positive {float(pos.min())!r}, "
          f"max {float(dts.max())!r} (after t = {float(t_rows[int(np.argmax(dts))])!r})")
    print("rejected (gated):")
    for k, i, v, r in gated["rejected"]:
        print(f"  t={float(t_rows[k])!r} {names[i]} value={v!r} e^2/S={r!r}")
    for name, c in counts.items():
        print(f"  {name}: {c} data rows")


if __name__ == "__main__":
    main()
