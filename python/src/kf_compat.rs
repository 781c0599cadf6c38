//! FilterPy's conveniences around `KalmanFilter`'s state: copies and pickles (every attribute
//! round-trips), the `__dict__` view FilterPy's `Saver` deep-copies, `update_sequential`,
//! `test_matrix_dimensions` and `batch_filter(saver=…)`, which runs FilterPy's own loop
//! (predict, update, `saver.save()`) step by step.
#![allow(non_snake_case)]

use pyo3::exceptions::PyAssertionError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

use crate::batch::PerStepArgs;
use crate::convert::{
    check_covariance, read_matrix, read_vector, scalar, type_error, value_error, zeros,
};
use crate::kf_attrs::{A, KalmanFilter, UPDATED};
use crate::kf_core::UpdateError;

/// The buffers a pickle holds, with their attribute: the inputs, then what the last
/// predict and update left.
const STATE: [A; 16] = [
    A::X,
    A::P,
    A::F,
    A::Q,
    A::H,
    A::R,
    A::B,
    A::M,
    A::K,
    A::Y,
    A::S,
    A::Z,
    A::XPrior,
    A::PPrior,
    A::XPost,
    A::PPost,
];

/// An independent copy of `kf`, of its class (a subclass such as ExtendedKalmanFilter
/// included), in-place edits of handed-out arrays adopted first: what `copy.copy`,
/// `copy.deepcopy` and a pickle round trip all give.
pub(crate) fn copy_of<'py>(kf: &Bound<'py, KalmanFilter>) -> PyResult<Bound<'py, PyAny>> {
    let py = kf.py();
    let (core, dim_u, x_col) = {
        let mut me = kf.try_borrow_mut()?;
        me.sync(py)?;
        (me.core.clone(), me.dim_u, me.x_col)
    };
    let new = kf.get_type().call1((core.n, core.m, dim_u))?;
    {
        let mut other = new.cast::<KalmanFilter>()?.try_borrow_mut()?;
        other.core = core;
        other.x_col = x_col;
        other.cache = Default::default();
    }
    Ok(new)
}

impl KalmanFilter {
    /// The pickled state: a dict of every buffer (row-major lists) and the flags.
    pub(crate) fn state<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.sync(py)?;
        let out = PyDict::new(py);
        for a in STATE {
            match self.buffer(a) {
                Some(buf) => out.set_item(Self::name(a), PyList::new(py, buf)?)?,
                None => out.set_item(Self::name(a), py.None())?,
            }
        }
        out.set_item("p", self.core.p)?;
        out.set_item("alpha_sq", self.core.alpha_sq)?;
        out.set_item("x_col", self.x_col)?;
        out.set_item("rows", PyList::new(py, &self.core.rows)?)?;
        out.set_item("factored", self.core.factored)?;
        Ok(out)
    }

    /// Restores [`KalmanFilter::state`] into a filter of the same dimensions.
    pub(crate) fn restore(&mut self, state: &Bound<'_, PyAny>) -> PyResult<()> {
        let state = state
            .cast::<PyDict>()
            .map_err(|_| type_error("KalmanFilter.__setstate__ takes the dict of __getstate__"))?;
        let item = |key: &str| -> PyResult<Bound<'_, PyAny>> {
            state
                .get_item(key)?
                .ok_or_else(|| value_error(format!("the pickled state has no {key}")))
        };
        let p: usize = item("p")?.extract()?;
        let n = self.core.n;
        for a in STATE {
            let value = item(Self::name(a))?;
            if a == A::B && value.is_none() {
                self.core.B = None;
                continue;
            }
            let (r, c) = if a == A::B { (n, p) } else { self.shape(a) };
            let list: Vec<f64> = value.extract()?;
            if list.len() != r * c {
                return Err(value_error(format!(
                    "the pickled {} has {} entries, expected {}",
                    Self::name(a),
                    list.len(),
                    r * c
                )));
            }
            match a {
                A::B => {
                    self.core.B = Some(list);
                    self.core.p = p;
                }
                _ => self.buffer_mut(a).copy_from_slice(&list),
            }
        }
        self.core.alpha_sq = item("alpha_sq")?.extract()?;
        self.x_col = item("x_col")?.extract()?;
        let rows: Vec<usize> = item("rows")?.extract()?;
        if rows.iter().any(|&i| i >= self.core.m) {
            return Err(value_error("the pickled rows index past dim_z"));
        }
        self.core.rows = rows;
        self.core.factored = item("factored")?.extract::<bool>()? && self.core.refactor();
        self.cache = Default::default();
        Ok(())
    }

    /// The buffer of a stored quantity, to write (not B, which may be absent, nor SI).
    fn buffer_mut(&mut self, a: A) -> &mut Vec<f64> {
        let c = &mut self.core;
        match a {
            A::X => &mut c.x,
            A::P => &mut c.P,
            A::F => &mut c.F,
            A::Q => &mut c.Q,
            A::H => &mut c.H,
            A::R => &mut c.R,
            A::M => &mut c.M,
            A::K => &mut c.K,
            A::Y => &mut c.y,
            A::S => &mut c.S,
            A::Z => &mut c.z,
            A::XPrior => &mut c.x_prior,
            A::PPrior => &mut c.P_prior,
            A::XPost => &mut c.x_post,
            A::PPost | A::B | A::SI => &mut c.P_post,
        }
    }

    /// The `__dict__` view: FilterPy's instance attributes (dimensions, every array, B, alpha)
    /// and the values of its properties (log_likelihood, likelihood, mahalanobis), as a new
    /// dict of the arrays the attributes return. Writing into it changes nothing.
    pub(crate) fn dict_view<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.sync(py)?;
        let out = PyDict::new(py);
        out.set_item("dim_x", self.core.n)?;
        out.set_item("dim_z", self.core.m)?;
        out.set_item("dim_u", self.dim_u)?;
        for a in STATE.into_iter().chain([A::SI]) {
            out.set_item(Self::name(a), self.get(py, a))?;
        }
        out.set_item("alpha", self.core.alpha_sq.sqrt())?;
        let ll = self
            .core
            .log_likelihood()
            .unwrap_or_else(|| f64::MIN_POSITIVE.ln());
        out.set_item("log_likelihood", ll)?;
        out.set_item("likelihood", ll.exp().max(f64::MIN_POSITIVE))?;
        out.set_item("mahalanobis", self.core.mahalanobis().unwrap_or(0.0))?;
        Ok(out)
    }

    /// FilterPy's `update_sequential(start, z_i, R_i=None, H_i=None)`: z_i is a scalar or
    /// has r entries, R_i None (the rows' block of R), a scalar (times I) or r×r, H_i None
    /// (the rows of H) or r·n entries in H's row order.
    pub(crate) fn sequential(
        &mut self,
        py: Python<'_>,
        start: &Bound<'_, PyAny>,
        z_i: &Bound<'_, PyAny>,
        [R_i, H_i]: [Option<&Bound<'_, PyAny>>; 2],
    ) -> PyResult<()> {
        self.sync(py)?;
        let (n, m) = (self.core.n, self.core.m);
        let start = crate::kf_attrs::dim(start, "start", false)?;
        let r = match scalar(z_i) {
            Some(_) => 1,
            None => z_i
                .len()
                .map_err(|_| type_error("z_i must be a number or a sequence of numbers"))?,
        };
        if r == 0 || start + r > m {
            return Err(value_error(format!(
                "update_sequential: rows {start}..{} of z_i are outside dim_z = {m}",
                start + r
            )));
        }
        let mut z = zeros(r, "z_i")?;
        read_vector(z_i, "z_i", r, true, false, &mut z)?;
        let mut R = zeros(r * r, "R_i")?;
        match R_i.filter(|v| !v.is_none()) {
            None => {
                for a in 0..r {
                    for b in 0..r {
                        R[a * r + b] = self.core.R[(start + a) * m + start + b];
                    }
                }
            }
            Some(v) => read_matrix(v, "R_i", r, r, true, &mut R)?,
        }
        check_covariance("R_i", &R, r)?;
        let mut H = zeros(r * n, "H_i")?;
        match H_i.filter(|v| !v.is_none()) {
            None => H.copy_from_slice(&self.core.H[start * n..(start + r) * n]),
            Some(v) => {
                let flat = py
                    .import("numpy")?
                    .call_method1("reshape", (v, (r, n)))
                    .map_err(|e| value_error(format!("H_i cannot be read as ({r}, {n}): {e}")))?;
                read_matrix(&flat, "H_i", r, n, false, &mut H)?;
            }
        }
        self.core
            .update_sequential(start, &z, &R, &H)
            .map_err(|UpdateError::SingularS| {
                value_error("update_sequential: S_i = H_i P H_iᵀ + R_i is singular")
            })?;
        self.invalidate(&UPDATED);
        Ok(())
    }

    /// FilterPy's `test_matrix_dimensions(z, H, R, F, Q)`: the same assertions on the
    /// arrays as they are (the filter's own unless given), raising `AssertionError`.
    pub(crate) fn check_dimensions(
        &mut self,
        py: Python<'_>,
        [z, H, R, F, Q]: [Option<&Bound<'_, PyAny>>; 5],
    ) -> PyResult<()> {
        self.sync(py)?;
        let np = py.import("numpy")?;
        let shape = |o: &Bound<'_, PyAny>| -> PyResult<Vec<usize>> {
            np.call_method1("shape", (o,))?.extract()
        };
        let own = |o: Option<&Bound<'_, PyAny>>, a: A, me: &mut Self| match o {
            Some(v) if !v.is_none() => v.clone().unbind(),
            _ => me.get(py, a),
        };
        let (H, R) = (own(H, A::H, self), own(R, A::R, self));
        let (F, Q) = (own(F, A::F, self), own(Q, A::Q, self));
        let (x, P) = (self.get(py, A::X), self.get(py, A::P));
        let (H, R, F, Q, x, P) = (
            H.bind(py),
            R.bind(py),
            F.bind(py),
            Q.bind(py),
            x.bind(py),
            P.bind(py),
        );
        let (n, m) = (self.core.n, self.core.m);
        let fail = |msg: String| Err(PyAssertionError::new_err(msg));
        let xs = shape(x)?;
        if xs != [n] && xs != [n, 1] {
            return fail(format!("Shape of x must be ({n},1), but is {xs:?}"));
        }
        for (name, v) in [("P", P), ("Q", Q), ("F", F)] {
            let s = shape(v)?;
            if s != [n, n] {
                return fail(format!("Shape of {name} must be ({n},{n}), but is {s:?}"));
            }
        }
        let hs = shape(H)?;
        if hs.len() != 2 || hs[1] != n {
            return fail(format!("Shape of H must be (dim_z, {n}), but is {hs:?}"));
        }
        let rs = shape(R)?;
        let r_ok = if hs[0] == 1 {
            rs.is_empty() || rs == [1] || rs == [1, 1]
        } else {
            rs == [hs[0], hs[0]]
        };
        if !r_ok {
            return fail(format!(
                "shape of R should be ({0}, {0}) but it is {rs:?}",
                hs[0]
            ));
        }
        let zs = match z.filter(|v| !v.is_none()) {
            Some(v) => shape(v)?,
            None => vec![m, 1],
        };
        let hx = shape(&np.call_method1("dot", (H, x))?)?;
        let ok = if zs.is_empty() {
            hx.len() == 1 || hx == [1, 1]
        } else if hx == [1] {
            zs[0] == 1
        } else {
            zs == hx || (zs.len() == 1 && hx == [zs[0], 1])
        };
        if !ok || (hx.len() > 1 && hx != [1, 1] && hx != zs) {
            return fail(format!(
                "shape of z should be {hx:?}, not {zs:?} for the given H"
            ));
        }
        Ok(())
    }
}

/// `batch_filter` with a `saver`: FilterPy's loop run through the filter's own methods —
/// `predict(u=us[k], B=Bs[k], F=Fs[k], Q=Qs[k])`, `update(zs[k], R=Rs[k], H=Hs[k])` (the
/// update first with `update_first`), the outputs written, then `saver.save()` — so the
/// saver sees the filter after every step. Ctrl-C between steps raises KeyboardInterrupt.
pub(crate) fn batch_with_saver<'py>(
    kf: &Bound<'py, KalmanFilter>,
    zs: &Bound<'py, PyAny>,
    per_step: PerStepArgs<'_, 'py>,
    us: Option<&Bound<'py, PyAny>>,
    update_first: bool,
    saver: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyTuple>> {
    let py = kf.py();
    let steps = zs.len()?;
    let PerStepArgs { Fs, Qs, Hs, Rs, Bs } = per_step;
    let given = |v: Option<&Bound<'py, PyAny>>| v.filter(|v| !v.is_none()).cloned();
    let lists = [
        ("Fs", given(Fs)),
        ("Qs", given(Qs)),
        ("Hs", given(Hs)),
        ("Rs", given(Rs)),
        ("Bs", given(Bs)),
        ("us", given(us)),
    ];
    for (name, list) in &lists {
        if let Some(list) = list
            && list.len()? != steps
        {
            return Err(value_error(format!(
                "{name} has {} steps but zs has {steps}",
                list.len()?
            )));
        }
    }
    let at = |i: usize, k: usize| -> PyResult<Bound<'py, PyAny>> {
        match &lists[i].1 {
            Some(list) => list.get_item(k),
            None => Ok(py.None().into_bound(py)),
        }
    };
    let (n, x_col) = {
        let me = kf.borrow();
        (me.core.n, me.x_col)
    };
    let np = py.import("numpy")?;
    let mean_shape = if x_col {
        PyTuple::new(py, [steps, n, 1])?
    } else {
        PyTuple::new(py, [steps, n])?
    };
    let cov_shape = PyTuple::new(py, [steps, n, n])?;
    let [means, covs, means_p, covs_p] =
        [&mean_shape, &cov_shape, &mean_shape, &cov_shape].map(|s| np.call_method1("zeros", (s,)));
    let (means, covs, means_p, covs_p) = (means?, covs?, means_p?, covs_p?);
    let record = |x: &Bound<'py, PyAny>, p: &Bound<'py, PyAny>, k: usize| -> PyResult<()> {
        x.set_item(k, kf.getattr("x")?)?;
        p.set_item(k, kf.getattr("P")?)
    };
    for k in 0..steps {
        py.check_signals()?;
        let z = zs.get_item(k)?;
        let update = || -> PyResult<()> {
            let kw = PyDict::new(py);
            kw.set_item("R", at(3, k)?)?;
            kw.set_item("H", at(2, k)?)?;
            kf.call_method("update", (&z,), Some(&kw))?;
            Ok(())
        };
        let predict = || -> PyResult<()> {
            let kw = PyDict::new(py);
            kw.set_item("u", at(5, k)?)?;
            kw.set_item("B", at(4, k)?)?;
            kw.set_item("F", at(0, k)?)?;
            kw.set_item("Q", at(1, k)?)?;
            kf.call_method("predict", (), Some(&kw))?;
            Ok(())
        };
        if update_first {
            update()?;
            record(&means, &covs, k)?;
            predict()?;
            record(&means_p, &covs_p, k)?;
        } else {
            predict()?;
            record(&means_p, &covs_p, k)?;
            update()?;
            record(&means, &covs, k)?;
        }
        saver.call_method0("save")?;
    }
    PyTuple::new(py, [means, covs, means_p, covs_p])
}
