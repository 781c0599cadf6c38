//! One closed-loop run of the uav scenario: the design that does not depend on the random
//! draws (ZOH/Van Loan plant, LQR, steady filter gain, reference feedforward) and the loop
//! itself on `kalman::FixedFilter<2, 1, 1>`, plus the campaign's slice of runs reduced to
//! their records.

use kalman::diagnostics as spectrum;
use kalman::{CovarianceForm, FixedDims, FixedFilter, Model, ToNalgebra};
use nalgebra::{DMatrix, Matrix3, Vector3};
use rand::RngExt;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use super::parameters::UavParams;
use super::records::RunRecord;
use crate::error::{Error, Result};
use crate::montecarlo::{Shard, par_runs, run_rng};

pub(super) fn arr22(m: &DMatrix<f64>) -> [[f64; 2]; 2] {
    [[m[(0, 0)], m[(0, 1)]], [m[(1, 0)], m[(1, 1)]]]
}

pub(super) fn model_err(context: &'static str) -> impl Fn(model::Error) -> Error {
    move |source| Error::Model { context, source }
}

pub(super) fn kalman_err(context: &'static str) -> impl Fn(kalman::Error) -> Error {
    move |source| Error::Kalman { context, source }
}

/// The continuous channel: ẋ = A x + B u + G w, z = H x + v with A = [[0, 1], [0, 0]],
/// B = G = (0, 1)ᵀ, H = (1, 0), W = q.
pub(super) fn continuous(p: &UavParams) -> Result<model::ContinuousSs> {
    let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
    let h = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
    model::ContinuousSs::new(a, b.clone(), h, DMatrix::zeros(1, 1))
        .and_then(|s| s.with_noise(b, DMatrix::from_element(1, 1, p.accel_noise_intensity)))
        .map_err(model_err("continuous model"))
}

/// Everything that does not depend on the random draws.
#[derive(Debug, Clone)]
pub(super) struct Design {
    pub(super) f: DMatrix<f64>,
    pub(super) b: DMatrix<f64>,
    pub(super) h: DMatrix<f64>,
    pub(super) q: DMatrix<f64>,
    /// Factor of Q_d for drawing w_k.
    pub(super) q_factor: DMatrix<f64>,
    pub(super) r: f64,
    /// LQR gain (1×2).
    pub(super) l: DMatrix<f64>,
    /// Steady-state filter gain K (2×1) and predictor gain K_p (2×1).
    pub(super) k: DMatrix<f64>,
    pub(super) k_pred: DMatrix<f64>,
    /// Steady prior covariance.
    pub(super) p_prior: DMatrix<f64>,
    pub(super) nx: [f64; 2],
    pub(super) nu: f64,
}

pub(super) fn design(p: &UavParams) -> Result<Design> {
    let sys = continuous(p)?;
    let d = model::discretize(
        &sys,
        p.dt_s,
        model::Discretization::Zoh,
        model::NoiseConvention::VanLoan,
    )
    .map_err(model_err("discretisation"))?;
    let (f, b, h, q) = (d.f().clone(), d.b().clone(), d.h().clone(), d.q().clone());
    let q_factor = model::psd_factor(&q).map_err(model_err("Q_d factor"))?;
    let r = p.measurement_variance;
    let [q1, q2] = p.lqr_state_weight;
    let lqr = kalman::riccati::Dlqr::new(&f, &b, [[q1, 0.0], [0.0, q2]], [[p.lqr_input_weight]])
        .and_then(|l| l.solve())
        .map_err(kalman_err("discrete LQR"))?;
    let ss = kalman::riccati::Dare::new(&f, &h, &q, [[r]])
        .and_then(|d| d.solve())
        .map_err(kalman_err("filter DARE"))?;
    // Reference feedforward: [[F − I, B], [H, 0]]·[N_x; N_u] = [0; 0; 1].
    let m = Matrix3::new(
        f[(0, 0)] - 1.0,
        f[(0, 1)],
        b[(0, 0)],
        f[(1, 0)],
        f[(1, 1)] - 1.0,
        b[(1, 0)],
        h[(0, 0)],
        h[(0, 1)],
        0.0,
    );
    let n = m
        .lu()
        .solve(&Vector3::new(0.0, 0.0, 1.0))
        .ok_or(Error::Degenerate(
            "uav: [[F − I, B], [H, 0]] is singular: the plant cannot hold a constant output",
        ))?;
    Ok(Design {
        l: lqr.gain.to_nalgebra(),
        k: ss.gain.to_nalgebra(),
        k_pred: ss.predictor_gain.to_nalgebra(),
        p_prior: ss.prior.to_nalgebra(),
        f,
        b,
        h,
        q,
        q_factor,
        r,
        nx: [n[0], n[1]],
        nu: n[2],
    })
}

/// One closed-loop run's time series: run 0's are the report's signals and spectra, and the
/// scenario's closing stage (`finish.toml`), so that a merge replays nothing.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Trace {
    pub(super) t: Vec<f64>,
    pub(super) reference: Vec<f64>,
    pub(super) x: Vec<[f64; 2]>,
    pub(super) w: Vec<[f64; 2]>,
    pub(super) z: Vec<f64>,
    pub(super) xhat: Vec<[f64; 2]>,
    pub(super) u: Vec<f64>,
    pub(super) innovation: Vec<f64>,
    pub(super) innovation_var: Vec<f64>,
    pub(super) gain: Vec<[f64; 2]>,
}

/// Simulates one closed-loop run from the stream of run `run`.
pub(super) fn simulate(p: &UavParams, d: &Design, seed: u64, run: usize) -> Result<Trace> {
    crate::montecarlo::count_simulation();
    let mut rng = run_rng(seed, run as u64);
    let mut normal = || -> f64 { rng.sample(StandardNormal) };
    let model = Model::new(
        FixedDims::<2, 1, 1>::new(),
        &arr22(&d.f),
        &[[d.h[(0, 0)], d.h[(0, 1)]]],
        &arr22(&d.q),
        &[[d.r]],
    )
    .and_then(|m| m.with_control(&[[d.b[(0, 0)]], [d.b[(1, 0)]]]))
    .map_err(kalman_err("filter model"))?;
    let [p0, p1] = p.initial_covariance;
    let mut filter: FixedFilter<2, 1, 1> = kalman::Filter::new(
        model,
        &[0.0, 0.0],
        &[[p0, 0.0], [0.0, p1]],
        CovarianceForm::Joseph,
    )
    .map_err(kalman_err("filter"))?;
    let mut x = [p0.sqrt() * normal(), p1.sqrt() * normal()];
    let (f, b, l, lq) = (&d.f, &d.b, &d.l, &d.q_factor);
    let mut tr = Trace::default();
    let sr = d.r.sqrt();
    for k in 0..p.steps {
        let t = k as f64 * p.dt_s;
        let r = if t >= p.step_time_s {
            p.step_amplitude
        } else {
            0.0
        };
        let xp = filter.predicted_state();
        let u = -(l[(0, 0)] * (xp[0] - d.nx[0] * r) + l[(0, 1)] * (xp[1] - d.nx[1] * r)) + d.nu * r;
        let z = d.h[(0, 0)] * x[0] + d.h[(0, 1)] * x[1] + sr * normal();
        filter
            .step(&[z], Some(&[u]))
            .map_err(kalman_err("filter step"))?;
        let xf = filter.state();
        let g = filter.gain();
        let (n0, n1) = (normal(), normal());
        let w = [
            lq[(0, 0)] * n0 + lq[(0, 1)] * n1,
            lq[(1, 0)] * n0 + lq[(1, 1)] * n1,
        ];
        tr.t.push(t);
        tr.reference.push(r);
        tr.x.push(x);
        tr.w.push(w);
        tr.z.push(z);
        tr.xhat.push([xf[0], xf[1]]);
        tr.u.push(u);
        tr.innovation.push(filter.innovation()[0]);
        tr.innovation_var
            .push(filter.innovation_covariance()[(0, 0)]);
        tr.gain.push([g[(0, 0)], g[(1, 0)]]);
        x = [
            f[(0, 0)] * x[0] + f[(0, 1)] * x[1] + b[(0, 0)] * u + w[0],
            f[(1, 0)] * x[0] + f[(1, 1)] * x[1] + b[(1, 0)] * u + w[1],
        ];
    }
    Ok(tr)
}

fn record(p: &UavParams, run: usize, tr: &Trace) -> RunRecord {
    let k0 = p.burn_in_steps;
    let n = (tr.t.len() - k0) as f64;
    let rms =
        |f: &dyn Fn(usize) -> f64| ((k0..tr.t.len()).map(|k| f(k).powi(2)).sum::<f64>() / n).sqrt();
    let nu: Vec<f64> = (k0..tr.t.len())
        .map(|k| tr.innovation[k] / tr.innovation_var[k].sqrt())
        .collect();
    RunRecord {
        run,
        rms_estimation_error: rms(&|k| tr.x[k][0] - tr.xhat[k][0]),
        rms_measurement_error: rms(&|k| tr.z[k] - tr.x[k][0]),
        ljung_box_q: spectrum::ljung_box(&nu, p.whiteness_lags),
        mean_nis: nu.iter().map(|v| v * v).sum::<f64>() / n,
    }
}

/// The records of the runs of `shard`.
///
/// # Errors
/// A library error on valid parameters, or the worker pool failing to start.
pub fn simulate_runs(
    p: &UavParams,
    seed: u64,
    shard: Shard,
    threads: Option<usize>,
) -> Result<Vec<RunRecord>> {
    let d = design(p)?;
    let results = par_runs(shard.runs(p.runs), threads, "uav", |i| {
        simulate(p, &d, seed, i).map(|tr| record(p, i, &tr))
    })?;
    results.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn design_matches_the_paper_plant() {
        let d = design(&UavParams::default()).expect("design");
        // ZOH of the double integrator is exact: F = [[1, Δt], [0, 1]], B = (Δt²/2, Δt).
        assert!((d.f[(0, 1)] - 0.25).abs() < 1e-12 && (d.f[(1, 1)] - 1.0).abs() < 1e-12);
        assert!((d.b[(0, 0)] - 0.03125).abs() < 1e-12 && (d.b[(1, 0)] - 0.25).abs() < 1e-12);
        // Van Loan for white acceleration: Q_d = q[[Δt³/3, Δt²/2], [Δt²/2, Δt]].
        let q = 0.1;
        assert!((d.q[(0, 0)] - q * 0.25f64.powi(3) / 3.0).abs() < 1e-14);
        assert!((d.q[(0, 1)] - q * 0.25f64.powi(2) / 2.0).abs() < 1e-14);
        // The double integrator holds a constant position with zero input.
        assert!((d.nx[0] - 1.0).abs() < 1e-12 && d.nx[1].abs() < 1e-12 && d.nu.abs() < 1e-12);
    }

    #[test]
    fn shards_hold_the_runs_of_one_campaign() {
        let p = UavParams {
            steps: 400,
            runs: 6,
            ..UavParams::default()
        };
        let whole = simulate_runs(&p, 5, Shard::ALL, Some(1)).expect("whole");
        let a = simulate_runs(&p, 5, Shard { index: 1, count: 2 }, Some(1)).expect("a");
        let b = simulate_runs(&p, 5, Shard { index: 2, count: 2 }, Some(2)).expect("b");
        assert_eq!([a, b].concat(), whole);
        assert_eq!(
            whole.iter().map(|r| r.run).collect::<Vec<_>>(),
            (0..6).collect::<Vec<_>>()
        );
    }
}
