//! `launch_estimation.particle_filter`: the bootstrap particle filter of `kalman::particle`
//! over Python callables vectorised over the particles (each called once per step with all
//! of them, as NumPy code wants), with the crate's resampling schemes, effective-sample-size
//! trigger, log-weights and likelihood estimate.
//!
//! The callables draw from a `numpy.random.Generator` the filter hands them, seeded from the
//! filter's own random stream for that step, so a seed gives the same run every time.
#![allow(non_snake_case)]

use kalman::particle::rand::RngExt;
use kalman::particle::{
    ParticleFilter, ParticleOptions, ParticleRng, PopulationModel, Resampling, Trigger, Vectorised,
};
use numpy::{PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{
    array3_out, ensure_callable, entries, float_array, matrix_out, memory_error, shape_str,
    type_name, value_error, vector_out, zeros,
};
use crate::guard;
use crate::series::read_series;

/// The Python callables as a [`PopulationModel`]. The first error a callable raises (or a
/// value of the wrong shape) is kept and NaN written in its place, which the filter refuses
/// at once; the caller then raises the kept error.
struct Callables<'py> {
    py: Python<'py>,
    n: usize,
    initial: Option<Vec<f64>>,
    transition: Bound<'py, PyAny>,
    log_likelihood: Bound<'py, PyAny>,
    error: Option<PyErr>,
}

impl<'py> Callables<'py> {
    /// A NumPy generator seeded from `rng`.
    fn generator(&self, rng: &mut ParticleRng) -> PyResult<Bound<'py, PyAny>> {
        let seed: u64 = rng.random();
        self.py
            .import("numpy")?
            .getattr("random")?
            .call_method1("default_rng", (seed,))
    }

    /// Runs `f`, keeping its error (the first one) and filling `out` with NaN on failure.
    fn run(&mut self, out: &mut [f64], f: impl FnOnce(&Self, &mut [f64]) -> PyResult<()>) {
        if self.error.is_some() {
            out.fill(f64::NAN);
            return;
        }
        if let Err(e) = f(self, out) {
            self.error = Some(e);
            out.fill(f64::NAN);
        }
    }
}

/// `r` read into `out` as `rows` values of `cols` entries: an array of shape (rows, cols), or
/// (rows,) when cols is 1.
fn read_rows(
    r: &Bound<'_, PyAny>,
    what: &str,
    rows: usize,
    cols: usize,
    out: &mut [f64],
) -> PyResult<()> {
    let arr = float_array(r, what)?;
    let ro = arr.readonly();
    let view = ro.as_array();
    let ok = view.shape() == [rows, cols] || (cols == 1 && view.shape() == [rows]);
    if !ok {
        return Err(value_error(format!(
            "{what} has shape {}, expected ({rows}, {cols}){}",
            shape_str(view.shape()),
            if cols == 1 {
                format!(" or ({rows},)")
            } else {
                String::new()
            }
        )));
    }
    for (o, v) in out.iter_mut().zip(view.iter()) {
        *o = *v;
    }
    Ok(())
}

impl PopulationModel for Callables<'_> {
    fn state_dim(&self) -> usize {
        self.n
    }

    fn sample_initial_all(&mut self, _rng: &mut ParticleRng, xs: &mut [f64]) {
        match &self.initial {
            Some(init) => xs.copy_from_slice(init),
            None => xs.fill(f64::NAN),
        }
    }

    fn sample_transition_all(&mut self, k: usize, rng: &mut ParticleRng, xs: &mut [f64]) {
        let n = self.n;
        let count = xs.len() / n;
        let generator = self.generator(rng);
        let input = matrix_out(self.py, xs, count, n);
        self.run(xs, |me, out| {
            let r = me.transition.call1((input, k, generator?))?;
            read_rows(&r, "the value of transition(X, k, rng)", count, n, out)
        });
    }

    fn log_likelihood_all(&mut self, k: usize, xs: &[f64], z: &[f64], out: &mut [f64]) {
        let count = out.len();
        let (x, zv) = (
            matrix_out(self.py, xs, count, self.n),
            vector_out(self.py, z, false),
        );
        self.run(out, |me, out| {
            let r = me.log_likelihood.call1((x, zv, k))?;
            read_rows(&r, "the value of log_likelihood(X, z, k)", count, 1, out)
        });
    }
}

/// The resampling scheme of a `resampling=` argument.
fn scheme(name: &str) -> PyResult<Resampling> {
    match name {
        "systematic" => Ok(Resampling::Systematic),
        "stratified" => Ok(Resampling::Stratified),
        "residual" => Ok(Resampling::Residual),
        "multinomial" => Ok(Resampling::Multinomial),
        other => Err(value_error(format!(
            "resampling = {other:?}; expected \"systematic\", \"stratified\", \"residual\" or \
             \"multinomial\""
        ))),
    }
}

/// particle_filter(zs, initial, transition, log_likelihood, particles=1000,
/// resampling="systematic", ess_threshold=0.5, seed=0) → dict with "x" (steps, n): the
/// weighted mean after each step, "P" (steps, n, n) the weighted covariance, "ess"
/// (steps,), "resampled" (steps,) booleans, "log_likelihood": ln p̂(z_0..z_{N−1}) (its
/// exponential an unbiased estimate of the likelihood), and the last step's "particles"
/// (particles, n) and "log_weights" (particles,).
///
/// The bootstrap filter: `initial(N, rng)` returns the N draws of the prior of the first
/// measurement as an (N, n) array; step k (after the first) resamples when the effective
/// sample size is below ess_threshold · N (1 resamples at every step), replaces the
/// particles by `transition(X, k − 1, rng)` (X the (N, n) particles of step k − 1, the value
/// their successors), and weights them by `log_likelihood(X, z, k)` (N values of
/// ln g_k(z | x), −inf where z is impossible). A row of zs that is all NaN only propagates.
/// rng is a numpy.random.Generator seeded from the filter's stream for the step.
#[pyfunction]
#[pyo3(signature = (zs, initial, transition, log_likelihood, particles = 1000, resampling = "systematic", ess_threshold = 0.5, seed = 0))]
pub(crate) fn particle_filter<'py>(
    py: Python<'py>,
    zs: &Bound<'py, PyAny>,
    initial: &Bound<'py, PyAny>,
    transition: &Bound<'py, PyAny>,
    log_likelihood: &Bound<'py, PyAny>,
    particles: usize,
    resampling: &str,
    ess_threshold: f64,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        run_particles(
            py,
            [zs, initial, transition, log_likelihood],
            particles,
            resampling,
            ess_threshold,
            seed,
        )
    })
}

/// [`particle_filter`]'s work.
fn run_particles<'py>(
    py: Python<'py>,
    [zs, initial, transition, log_likelihood]: [&Bound<'py, PyAny>; 4],
    particles: usize,
    resampling: &str,
    ess_threshold: f64,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    for (f, name) in [
        (initial, "initial"),
        (transition, "transition"),
        (log_likelihood, "log_likelihood"),
    ] {
        ensure_callable(f, name)?;
    }
    let resampling = scheme(resampling)?;
    if !(ess_threshold > 0.0 && ess_threshold <= 1.0) {
        return Err(value_error(format!(
            "ess_threshold = {ess_threshold}; it must be in (0, 1]"
        )));
    }
    if particles == 0 {
        return Err(value_error(
            "particles = 0; a particle filter needs at least one",
        ));
    }
    // The prior's draws, which also give n.
    let generator = py
        .import("numpy")?
        .getattr("random")?
        .call_method1("default_rng", (seed,))?;
    let r = initial.call1((particles, generator))?;
    let n = match r.cast::<PyUntypedArray>().map(|a| a.shape().to_vec()) {
        Ok(s) if s.len() == 2 && s[0] == particles && s[1] > 0 => s[1],
        Ok(s) if s.len() == 1 && s[0] == particles => 1,
        Ok(s) => {
            return Err(value_error(format!(
                "the value of initial(N, rng) has shape {}, expected ({particles}, n)",
                shape_str(&s)
            )));
        }
        Err(_) => {
            return Err(value_error(format!(
                "initial(N, rng) must return a numpy.ndarray, not {}",
                type_name(&r)
            )));
        }
    };
    // The filter's buffers (about a dozen of N and three of N·n), checked first.
    let what = "the particle filter's buffers";
    let need = entries(particles, 3 * n + 12, what)?;
    Vec::<f64>::new()
        .try_reserve_exact(need)
        .map_err(|_| memory_error(need, what))?;
    let mut init = zeros(entries(particles, n, "the prior's particles")?, "initial")?;
    read_rows(&r, "the value of initial(N, rng)", particles, n, &mut init)?;
    let (steps, z) = read_series(zs, "zs", zs_width(zs)?, true)?;
    let m = z.len().checked_div(steps).unwrap_or(0);
    let model = Callables {
        py,
        n,
        initial: Some(init),
        transition: transition.clone(),
        log_likelihood: log_likelihood.clone(),
        error: None,
    };
    let options = ParticleOptions {
        particles,
        resampling,
        trigger: if ess_threshold >= 1.0 {
            Trigger::Always
        } else {
            Trigger::EssBelow(ess_threshold)
        },
        seed,
        ..ParticleOptions::default()
    };
    let mut pf = ParticleFilter::new(Vectorised(model), options)
        .map_err(|e| value_error(format!("particle_filter: {e}")))?;
    let (mut means, mut covs) = (
        zeros(entries(steps, n, "x")?, "x")?,
        zeros(entries(steps, entries(n, n, "P")?, "P")?, "P")?,
    );
    let (mut ess, mut resampled) = (zeros(steps, "ess")?, Vec::with_capacity(steps));
    for k in 0..steps {
        py.check_signals()?;
        if let Err(e) = pf.step(&z[k * m..(k + 1) * m]) {
            return Err(pf_error(&mut pf.model_mut().0, e));
        }
        means[k * n..(k + 1) * n].copy_from_slice(pf.mean());
        let p = pf.covariance();
        for i in 0..n {
            for j in 0..n {
                covs[(k * n + i) * n + j] = p[(i, j)];
            }
        }
        ess[k] = pf.ess();
        resampled.push(pf.resampled());
    }
    let d = PyDict::new(py);
    d.set_item("x", matrix_out(py, &means, steps, n))?;
    d.set_item("P", array3_out(py, covs, steps, n, n))?;
    d.set_item("ess", vector_out(py, &ess, false))?;
    d.set_item("resampled", resampled)?;
    d.set_item("log_likelihood", pf.log_likelihood())?;
    d.set_item("particles", matrix_out(py, pf.particles(), particles, n))?;
    d.set_item("log_weights", vector_out(py, pf.log_weights(), false))?;
    Ok(d)
}

/// The number of entries per row of zs: its second axis, 1 for a 1-d series.
fn zs_width(zs: &Bound<'_, PyAny>) -> PyResult<usize> {
    match zs.cast::<PyUntypedArray>() {
        Ok(a) if a.ndim() == 2 => Ok(a.shape()[1]),
        Ok(a) if a.ndim() == 1 => Ok(1),
        Ok(a) => Err(value_error(format!(
            "zs has shape {}, expected (steps, m) or (steps,)",
            shape_str(a.shape())
        ))),
        Err(_) => Ok(1),
    }
}

/// The error of a failed step: the callable's own exception if one was kept, else the
/// filter's error as a `ValueError`.
fn pf_error(model: &mut Callables<'_>, e: kalman::Error) -> PyErr {
    model
        .error
        .take()
        .unwrap_or_else(|| value_error(format!("particle_filter: {e}")))
}
