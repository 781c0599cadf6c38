//! One forward pass of the engine's filter over a whole series, as `filter`, `smooth`,
//! `filter_continuous` and `smooth_continuous` run it, in the order of `scenarios filter`:
//! each step's model (the filter's own, or the continuous model sampled over the interval to
//! the next time stamp), the wild-point gate screening the step's measurements against the
//! prior before the update (its rejections kept for the `"rejected"` output), the step, and
//! the smoother's record of the step with the model it used.
#![allow(non_snake_case)]

use kalman::gate::{Gate, GateRule, Rejection};
use kalman::sampling::Sampler;
use kalman::smoother::RtsSmoother;
use kalman::{CovarianceForm, Dims, DynDims, Filter, StepInfo};
use numpy::PyArray1;
use numpy::PyArray2;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{
    FilterRecord, array3_out, copy_mat, entries, memory_error, scalar, type_error, type_name,
    value_error, zeros,
};
use crate::series::read_series;

/// Maps an engine error to a `ValueError` naming the function.
pub(crate) fn engine(context: &str) -> impl Fn(kalman::Error) -> PyErr + '_ {
    move |e| value_error(format!("{context}: {e}"))
}

/// The covariance form of a `form=` argument.
pub(crate) fn covariance_form(form: &str) -> PyResult<CovarianceForm> {
    match form {
        "joseph" => Ok(CovarianceForm::Joseph),
        "standard" => Ok(CovarianceForm::Standard),
        "sqrt" => Ok(CovarianceForm::SquareRoot),
        other => Err(value_error(format!(
            "form = {other:?}; expected \"joseph\", \"standard\" or \"sqrt\""
        ))),
    }
}

/// The gate of the `gate=` (a probability, or None for no gate) and `gate_rule=` arguments.
/// The rule is checked even without a gate, so a misspelt one is never silently unused.
pub(crate) fn gate_option(
    gate: Option<&Bound<'_, PyAny>>,
    rule: &str,
) -> PyResult<Option<(GateRule, f64)>> {
    let rule = match rule {
        "entries" => GateRule::Entries,
        "vector" => GateRule::Vector,
        other => {
            return Err(value_error(format!(
                "gate_rule = {other:?}; expected \"entries\" (each entry's e_i²/Σ_ii against \
                 χ²(1)) or \"vector\" (the step's eᵀΣ⁺e against χ²(rank Σ))"
            )));
        }
    };
    let Some(gate) = gate.filter(|g| !g.is_none()) else {
        return Ok(None);
    };
    let Some(p) = scalar(gate) else {
        return Err(type_error(format!(
            "gate must be a probability (a float strictly between 0 and 1) or None, not {}",
            type_name(gate)
        )));
    };
    match p {
        p if p > 0.0 && p < 1.0 => Ok(Some((rule, p))),
        p => Err(value_error(format!(
            "gate = {p}: the gate is the probability that a consistent entry (or step) is kept, \
             strictly between 0 and 1 (e.g. 0.9999), or None for no gate"
        ))),
    }
}

/// Distinct intervals a continuous model's sampler keeps (as `scenarios filter`): a clock
/// quantised to a few hundred values pays one discretisation per value.
pub(crate) const SAMPLER_CAPACITY: usize = 256;

/// How each step's model is found.
pub(crate) enum Timing {
    /// The filter's own (discrete) model at every step.
    Own,
    /// A continuous model sampled over `t[k+1] − t[k]` at step k (the last step over 0);
    /// `t` is finite and non-decreasing ([`time_stamps`]).
    Sampled { sampler: Box<Sampler>, t: Vec<f64> },
}

/// Reads the time stamps `t`: N finite, non-decreasing numbers (a 1-d array or a
/// sequence), each refusal naming the index.
pub(crate) fn time_stamps(obj: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let (_, t) = read_series(obj, "t", 1, false)?;
    for k in 1..t.len() {
        if t[k] < t[k - 1] {
            return Err(value_error(format!(
                "t[{k}] = {} is before t[{}] = {}: time stamps must not go back (equal stamps \
                 are one instant)",
                t[k],
                k - 1,
                t[k - 1]
            )));
        }
    }
    Ok(t)
}

/// The wild-point gate of a pass and what it rejected: (step, entry, value, statistic).
struct Screen {
    gate: Gate,
    rejected: Vec<(usize, Rejection)>,
}

/// A forward pass: the filter, the series it runs over (zs (N, m), us (N, p), row-major),
/// each step's model, and the gate.
pub(crate) struct Pass {
    filter: Filter<DynDims>,
    timing: Timing,
    screen: Option<Screen>,
    n: usize,
    m: usize,
    p: usize,
    steps: usize,
    z: Vec<f64>,
    u: Option<Vec<f64>>,
    context: &'static str,
}

impl Pass {
    /// The pass of `filter` over `zs` and the optional `us`, with the models of `timing`
    /// (its `t` must have one stamp per row of zs) and the gate (rule, probability).
    pub(crate) fn new(
        filter: Filter<DynDims>,
        timing: Timing,
        zs: &Bound<'_, PyAny>,
        us: Option<&Bound<'_, PyAny>>,
        gate: Option<(GateRule, f64)>,
        context: &'static str,
    ) -> PyResult<Self> {
        let dims = filter.model().dims();
        let (n, m, p) = (dims.n(), dims.m(), dims.p());
        let (steps, z, u) = series(zs, us, m, p)?;
        if let Timing::Sampled { t, .. } = &timing
            && t.len() != steps
        {
            return Err(value_error(format!(
                "t has {} time stamps but zs has {steps} rows: give one stamp per row",
                t.len()
            )));
        }
        let screen = match gate {
            Some((rule, probability)) => Some(Screen {
                gate: Gate::new(rule, probability, filter.model()).map_err(engine(context))?,
                rejected: Vec::new(),
            }),
            None => None,
        };
        Ok(Self {
            filter,
            timing,
            screen,
            n,
            m,
            p,
            steps,
            z,
            u,
            context,
        })
    }

    /// Step k: its model, the gate, the update with zs[k] (the entries kept), the
    /// prediction with us[k], and the smoother's record of the step.
    fn step(&mut self, k: usize, rts: Option<&mut RtsSmoother>) -> PyResult<StepInfo> {
        let (m, p, context) = (self.m, self.p, self.context);
        let err = engine(context);
        let model = match &mut self.timing {
            Timing::Own => None,
            Timing::Sampled { sampler, t } => {
                let dt = t.get(k + 1).map_or(0.0, |next| next - t[k]);
                let model = sampler.at(dt).map_err(|e| {
                    value_error(format!(
                        "{context}: the interval t[{}] − t[{k}] = {dt} s that step {k} predicts \
                         over cannot be sampled: {e}",
                        k + 1
                    ))
                })?;
                Some(model)
            }
        };
        let kf = &mut self.filter;
        let mut z = &self.z[k * m..(k + 1) * m];
        let u = self.u.as_ref().map(|u| &u[k * p..(k + 1) * p]);
        if let Some(screen) = &mut self.screen {
            screen
                .gate
                .screen(kf, model.unwrap_or(kf.model()), z)
                .map_err(&err)?;
            let found = screen.gate.rejected().iter().map(|r| (k, *r));
            screen.rejected.extend(found);
            z = screen.gate.kept();
        }
        let info = match model {
            Some(model) => kf.step_with(model, z, u),
            None => kf.step(z, u),
        }
        .map_err(&err)?;
        if let Some(rts) = rts {
            rts.record_with(kf, model.unwrap_or(kf.model()))
                .map_err(&err)?;
        }
        Ok(info)
    }

    /// `filter`'s dict: x_{k|k}, P_{k|k}, x_{k+1|k}, P_{k+1|k}, the log-likelihood, the NIS,
    /// and with a gate the rejections.
    pub(crate) fn filtered(mut self, py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        let mut rec = FilterRecord::new(self.steps, self.n)?;
        for k in 0..self.steps {
            if k % 4096 == 4095 {
                py.check_signals()?; // Ctrl-C raises KeyboardInterrupt
            }
            let info = self.step(k, None)?;
            let f = &self.filter;
            rec.set(
                k,
                f.state(),
                f.covariance(),
                f.predicted_state(),
                f.predicted_covariance(),
                info.log_likelihood,
                info.nis,
            );
        }
        let out = rec.into_dict(py)?;
        self.add_rejected(&out)?;
        Ok(out)
    }

    /// `smooth`'s dict: the RTS-smoothed "x" (N, n) and "P" (N, n, n) over the pass, and
    /// with a gate the rejections of the forward pass.
    pub(crate) fn smoothed(mut self, py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        let (steps, n) = (self.steps, self.n);
        // The smoother records the forward pass step by step (kalman's RtsSmoother, which
        // grows its record infallibly): the record and the smoothed output must fit, so
        // their size is checked here, before the pass, by reserving it once.
        let per_step = 8 * (3 * n + 5 * n.next_multiple_of(8) * n) + 5 * 64;
        let bytes = steps.saturating_mul(per_step);
        let mut probe: Vec<u8> = Vec::new();
        probe
            .try_reserve_exact(bytes)
            .map_err(|_| memory_error(bytes / 8, "the smoother's record"))?;
        drop(probe);
        let mut rts = RtsSmoother::new();
        for k in 0..steps {
            if k % 4096 == 4095 {
                py.check_signals()?;
            }
            self.step(k, Some(&mut rts))?;
        }
        let nn = n * n;
        let mut ps = zeros(
            entries(steps, nn, "the smoothed record")?,
            "the smoothed record",
        )?;
        // The square-root filter's pass is smoothed in square-root form too (its covariances
        // formed from the smoothed factors at the end, PSD by construction).
        let means = if self.filter.form() == CovarianceForm::SquareRoot {
            let sm = rts.smooth_sqrt().map_err(engine(self.context))?;
            for (k, out) in ps.chunks_exact_mut(nn).enumerate() {
                if let Some(P) = sm.covariance(k) {
                    copy_mat(out, P.as_ref());
                }
            }
            sm.means
        } else {
            let sm = rts.smooth().map_err(engine(self.context))?;
            for (out, c) in ps.chunks_exact_mut(nn).zip(&sm.covariances) {
                copy_mat(out, c.as_ref());
            }
            sm.means
        };
        let xs = Array2::from_shape_fn((steps, n), |(k, i)| means[(i, k)]);
        let out = PyDict::new(py);
        out.set_item("x", PyArray2::from_owned_array(py, xs))?;
        out.set_item("P", array3_out(py, ps, steps, n, n))?;
        self.add_rejected(&out)?;
        Ok(out)
    }

    /// With a gate, `out["rejected"]`: a dict of 1-d arrays "step", "channel" (int64, the
    /// row of zs and the 0-based entry), "value" and "nis" (the statistic that rejected it),
    /// one element per rejected entry in step then channel order.
    fn add_rejected(&self, out: &Bound<'_, PyDict>) -> PyResult<()> {
        let Some(screen) = &self.screen else {
            return Ok(());
        };
        let py = out.py();
        let rej = &screen.rejected;
        let ints = |f: fn(&(usize, Rejection)) -> usize| {
            let v: Vec<i64> = rej
                .iter()
                .map(|r| i64::try_from(f(r)).unwrap_or(i64::MAX))
                .collect();
            PyArray1::from_vec(py, v)
        };
        let floats = |f: fn(&(usize, Rejection)) -> f64| {
            PyArray1::from_vec(py, rej.iter().map(f).collect::<Vec<f64>>())
        };
        let d = PyDict::new(py);
        d.set_item("step", ints(|r| r.0))?;
        d.set_item("channel", ints(|r| r.1.entry))?;
        d.set_item("value", floats(|r| r.1.value))?;
        d.set_item("nis", floats(|r| r.1.nis))?;
        out.set_item("rejected", d)
    }
}

/// Reads `zs` (N, m) and `us` (N, p) for a model with m measurements and p inputs.
fn series(
    zs: &Bound<'_, PyAny>,
    us: Option<&Bound<'_, PyAny>>,
    m: usize,
    p: usize,
) -> PyResult<(usize, Vec<f64>, Option<Vec<f64>>)> {
    let (steps, z) = read_series(zs, "zs", m, true)?;
    let u = match us {
        Some(us) if !us.is_none() => {
            if p == 0 {
                return Err(value_error(
                    "us is given but there is no B (no control input)",
                ));
            }
            let (k, u) = read_series(us, "us", p, false)?;
            if k != steps {
                return Err(value_error(format!("us has {k} steps but zs has {steps}")));
            }
            Some(u)
        }
        _ => None,
    };
    Ok((steps, z, u))
}
