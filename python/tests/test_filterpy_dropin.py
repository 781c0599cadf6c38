"""KalmanFilter as a drop-in for FilterPy's beyond predict/update: copies and pickles, the
`__dict__` view FilterPy's Saver reads, batch_filter(saver=…), every z form FilterPy takes,
update_sequential, test_matrix_dimensions, NumPy integer scalars and 0-d arrays, and integer
or float32 arrays (assigned, then edited in place) — each side by side with FilterPy.

Tolerances: the same formulas in the same order up to the solve (FilterPy forms inv(S), we
factor S), on well-conditioned problems, so 1e-10 relative (as in test_filterpy_compat.py);
a copy or a pickle must give the same bits."""

import copy
import functools
import pickle

import numpy as np
import pytest
from filterpy.common import Saver
from filterpy.kalman import KalmanFilter as FpKalmanFilter

import compare
import launch_estimation as le
from problems import problem, setup

TOL = 1e-10
ATTRS = ["x", "P", "F", "Q", "H", "R", "B", "M", "K", "y", "S", "SI", "z",
         "x_prior", "P_prior", "x_post", "P_post"]


close = functools.partial(compare.close, tol=TOL)


def same_bits(a, b, what):
    if a is None or b is None:
        assert a is None and b is None, what
        return
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype, what
    assert a.tobytes() == b.tobytes(), what


def ran_filter(missing_row=True):
    """A 3-state, 2-measurement filter with a control, after a few steps; the last update
    has a missing entry (so the rows it used must travel with a copy)."""
    pr = problem(5, 3, 2, 1)
    kf = setup(le.KalmanFilter, pr, 1)
    kf.alpha = 1.01
    for k in range(6):
        kf.predict(u=pr["us"][k])
        z = pr["zs"][k].copy()
        if missing_row and k == 5:
            z[1] = np.nan
        kf.update(z)
    return kf, pr


COPIES = {
    "copy": copy.copy,
    "deepcopy": copy.deepcopy,
    "pickle": lambda kf: pickle.loads(pickle.dumps(kf)),
    "pickle protocol 0": lambda kf: pickle.loads(pickle.dumps(kf, protocol=0)),
}


@pytest.mark.parametrize("how", list(COPIES))
def test_copies_round_trip_every_attribute(how):
    kf, pr = ran_filter()
    kf.P[0, 0] += 0.5  # an in-place edit not yet used by a call must travel too
    dup = COPIES[how](kf)
    assert type(dup) is le.KalmanFilter and dup is not kf
    for name in ATTRS:
        same_bits(getattr(dup, name), getattr(kf, name), f"{how}: {name}")
    for name in ["dim_x", "dim_z", "dim_u", "alpha", "log_likelihood", "likelihood",
                 "mahalanobis"]:
        assert getattr(dup, name) == getattr(kf, name), f"{how}: {name}"
    # Independent, and the same filter from here on.
    dup.x[0, 0] += 1.0
    assert kf.x[0, 0] != dup.x[0, 0]
    dup.x[0, 0] -= 1.0
    for k in range(6, 10):
        for f in (kf, dup):
            f.predict(u=pr["us"][k])
            f.update(pr["zs"][k])
        for name in ATTRS:
            same_bits(getattr(dup, name), getattr(kf, name), f"{how}, step {k}: {name}")


def test_pickle_of_a_fresh_filter_and_a_1d_state():
    kf = le.KalmanFilter(2, 1)
    kf.x = np.array([1.0, 2.0])
    dup = pickle.loads(pickle.dumps(kf))
    assert dup.x.shape == (2,) and dup.B is None and dup.log_likelihood == kf.log_likelihood


def test_dict_view_and_saver_match_filterpy():
    pr = problem(11, 2, 1)
    ours, theirs = setup(le.KalmanFilter, pr), setup(FpKalmanFilter, pr)
    view = ours.__dict__
    for key in ["dim_x", "dim_z", "dim_u", "x", "P", "F", "Q", "H", "R", "B", "M", "K", "y",
                "S", "SI", "z", "x_prior", "P_prior", "x_post", "P_post"]:
        assert key in view and key in theirs.__dict__, key
    s_ours, s_theirs = Saver(ours), Saver(theirs)
    for z in pr["zs"]:
        for f, s in ((ours, s_ours), (theirs, s_theirs)):
            f.predict()
            f.update(z)
            s.save()
    s_ours.to_array()
    s_theirs.to_array()
    assert len(s_ours) == len(s_theirs) == len(pr["zs"])
    for key in ["x", "P", "K", "y", "S", "x_prior", "P_post"]:
        close(s_ours[key], s_theirs[key], f"Saver {key}")
    close(s_ours["log_likelihood"], [f for f in s_theirs["log_likelihood"]], "Saver ll")


@pytest.mark.parametrize("update_first", [False, True])
def test_batch_filter_with_saver(update_first):
    pr = problem(12, 3, 2, 1, missing=0.2)
    ours, theirs = setup(le.KalmanFilter, pr, 1), setup(FpKalmanFilter, pr, 1)
    s_ours, s_theirs = Saver(ours), Saver(theirs)
    us = list(pr["us"])
    a = ours.batch_filter(pr["zs"], us=us, update_first=update_first, saver=s_ours)
    b = theirs.batch_filter(pr["zs"], us=us, update_first=update_first, saver=s_theirs)
    for x, y, what in zip(a, b, ["means", "covariances", "means_p", "covariances_p"]):
        close(x, y, what)
    # Without a saver the one-call path gives the same outputs.
    fresh = setup(le.KalmanFilter, pr, 1)
    c = fresh.batch_filter(pr["zs"], us=us, update_first=update_first)
    for x, y, what in zip(a, c, ["means", "covariances", "means_p", "covariances_p"]):
        close(x, y, f"{what} without a saver")
    assert len(s_ours) == len(s_theirs) == len(pr["zs"])
    s_ours.to_array()
    s_theirs.to_array()
    close(s_ours.x, s_theirs.x, "saved x")
    close(s_ours.P, s_theirs.P, "saved P")


Z2 = {
    "(2,)": lambda v: v.ravel(),
    "(2, 1)": lambda v: v.reshape(2, 1),
    "(1, 2)": lambda v: v.reshape(1, 2),
    "list": lambda v: list(v.ravel()),
    "list of lists (column)": lambda v: [[a] for a in v.ravel()],
    "list of lists (row)": lambda v: [list(v.ravel())],
    "int array": lambda v: np.round(v).astype(np.int64).ravel(),
    "float32 (1, 2)": lambda v: v.astype(np.float32).reshape(1, 2),
}
Z1 = {
    "float": lambda v: float(v),
    "int": lambda v: int(round(float(v))),
    "np.float64": lambda v: np.float64(v),
    "np.int64": lambda v: np.int64(round(float(v))),
    "np.float32": lambda v: np.float32(v),
    "0-d": lambda v: np.array(float(v)),
    "[a]": lambda v: [float(v)],
    "[[a]]": lambda v: [[float(v)]],
    "(1, 1)": lambda v: np.array([[float(v)]]),
}


def check_z_form(pr, form, z_of, attrs):
    """Eight predict/update steps of both filters on problem `pr`, each z passed as
    `z_of(z)`; `attrs` agree with FilterPy's after each step."""
    ours, theirs = setup(le.KalmanFilter, pr), setup(FpKalmanFilter, pr)
    for z in pr["zs"][:8]:
        for f in (ours, theirs):
            f.predict()
            f.update(z_of(z))
        for a in attrs:
            close(getattr(ours, a), getattr(theirs, a), f"{a} with z as {form}")


@pytest.mark.parametrize("form", list(Z2))
def test_z_forms_dim_z_2(form):
    check_z_form(problem(13, 3, 2), form, Z2[form], ["x", "P"])


@pytest.mark.parametrize("form", list(Z1))
def test_z_forms_dim_z_1(form):
    check_z_form(problem(14, 2, 1), form, lambda z: Z1[form](z[0, 0]), ["x"])


@pytest.mark.parametrize("R_i", ["own", "scalar", "matrix"])
@pytest.mark.parametrize("H_i", ["own", "given"])
def test_update_sequential(R_i, H_i):
    pr = problem(15, 4, 3)
    ours, theirs = setup(le.KalmanFilter, pr), setup(FpKalmanFilter, pr)
    for k, z in enumerate(pr["zs"][:6]):
        for f in (ours, theirs):
            f.predict()
        for start, stop in [(0, 1), (1, 3)]:
            r = {"own": None, "scalar": 0.7,
                 "matrix": pr["R"][start:stop, start:stop] + 0.1 * np.eye(stop - start)}[R_i]
            h = None if H_i == "own" else pr["H"][start:stop] * 1.1
            zi = z[start:stop, 0] if stop - start > 1 else float(z[start, 0])
            ours.update_sequential(start, zi, R_i=r, H_i=h)
            theirs.update_sequential(start, zi, R_i=r, H_i=h)
        for name in ["x", "P", "K", "y", "x_post", "P_post"]:
            close(getattr(ours, name), getattr(theirs, name), f"{name} at step {k}")
        close(ours.z, np.asarray(theirs.z, float), f"z at step {k}")


def test_update_sequential_refuses_rows_past_dim_z():
    kf = le.KalmanFilter(2, 2)
    with pytest.raises(ValueError, match="dim_z"):
        kf.update_sequential(1, [1.0, 2.0])


def test_matrix_dimensions_as_filterpy():
    pr = problem(16, 2, 1)
    for x in [pr["x0"], pr["x0"].ravel()]:
        ours, theirs = setup(le.KalmanFilter, pr), setup(FpKalmanFilter, pr)
        ours.x, theirs.x = x.copy(), x.copy()
        for z in [None, 3.0, [3.0], [[3.0]], np.array([[3.0]]), [3.0, 3.0], [[3.0], [3.0]]]:
            verdicts = []
            for f in (ours, theirs):
                try:
                    f.test_matrix_dimensions(z=z)
                    verdicts.append("ok")
                except AssertionError:
                    verdicts.append("AssertionError")
            assert verdicts[0] == verdicts[1], (x.shape, z, verdicts)
        # A wrong override is caught.
        with pytest.raises(AssertionError):
            ours.test_matrix_dimensions(H=np.ones((1, 3)))
        with pytest.raises(AssertionError):
            ours.test_matrix_dimensions(R=np.eye(2))


def test_numpy_integer_dimensions_and_0d_state():
    for dims in [(np.int64(2), np.int32(1)), (np.array(2), np.array(1)), (2, np.uint8(1))]:
        kf = le.KalmanFilter(*dims)
        assert (kf.dim_x, kf.dim_z) == (2, 1)
    with pytest.raises(TypeError, match="dim_x"):
        le.KalmanFilter(np.bool_(True), 1)
    with pytest.raises(TypeError, match="dim_x"):
        le.KalmanFilter(2.0, 1)
    ours, theirs = le.KalmanFilter(1, 1), FpKalmanFilter(1, 1)
    for f in (ours, theirs):
        f.x = np.array(2.0)
        f.H = np.array([[1.0]])
        f.F = np.array([[0.9]])
        f.predict()
        f.update(np.array(1.5))
    close(ours.x, theirs.x, "x from a 0-d x")
    close(ours.P, theirs.P, "P from a 0-d x")


@pytest.mark.parametrize("dtype", [np.float32, np.int64, np.int32, np.uint8])
@pytest.mark.parametrize("name", ["F", "H", "Q", "R", "P", "x"])
def test_assigned_array_of_another_dtype_edited_in_place(dtype, name):
    """An integer or float32 array assigned to an attribute and then edited in place: the
    edit is used, as FilterPy uses it."""
    pr = problem(17, 2, 1)
    ours, theirs = setup(le.KalmanFilter, pr), setup(FpKalmanFilter, pr)
    base = {"F": [[1, 1], [0, 1]], "H": [[1, 0]], "Q": [[2, 0], [0, 2]], "R": [[3]],
            "P": [[5, 1], [1, 4]], "x": [[1], [2]]}[name]
    edits = {"F": ((0, 1), 2), "H": ((0, 1), 1), "Q": ((1, 1), 3), "R": ((0, 0), 4),
             "P": ((0, 0), 7), "x": ((1, 0), 5)}[name]
    arrays = []
    for f in (ours, theirs):
        a = np.array(base, dtype=dtype)
        setattr(f, name, a)
        arrays.append(a)
    assert getattr(ours, name) is arrays[0]  # the array itself, as in FilterPy
    for a in arrays:
        a[edits[0]] = edits[1]
    for z in pr["zs"][:5]:
        for f in (ours, theirs):
            f.predict()
            f.update(z)
        close(ours.x, theirs.x, f"x after editing the {np.dtype(dtype)} {name}")
        close(ours.P, theirs.P, f"P after editing the {np.dtype(dtype)} {name}")


def test_riccati_take_integer_float32_arrays_and_a_number_for_R():
    F = np.array([[1, 1], [0, 1]])
    H = np.array([[1, 0]])
    Q = np.array([[1, 0], [0, 1]])
    ref = le.dare(F.astype(float), H.astype(float), Q.astype(float), np.array([[2.0]]))
    for args in [(F, H, Q, 2), (F, H, Q, 2.0), (F.astype(np.float32), H, Q, np.int64(2)),
                 (F, H, Q, np.array([[2]]))]:
        got = le.dare(*args)
        for key in ref:
            np.testing.assert_array_equal(got[key], ref[key], err_msg=key)
    lqr_ref = le.dlqr(F.astype(float), np.array([[0.0], [1.0]]), Q.astype(float),
                      np.array([[1.0]]))
    lqr = le.dlqr(F, np.array([[0], [1]]), Q, 1)
    np.testing.assert_array_equal(lqr["K"], lqr_ref["K"])
    A = np.array([[0, 1], [0, 0]])
    care_ref = le.care(A.astype(float), H.astype(float), Q.astype(float), np.array([[4.0]]))
    care = le.care(A, H, Q, 4)
    np.testing.assert_array_equal(care["P"], care_ref["P"])
    with pytest.raises(ValueError, match="R"):
        le.care(A, H, Q, float("nan"))
