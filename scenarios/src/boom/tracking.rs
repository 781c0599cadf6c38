//! The boom turn as a tracking problem (beyond the paper): the state (α, ω, ε) carried
//! through time by a white-jerk kinematic model, the accelerometer of `sensors` as the
//! measurement function, and the extended and unscented Kalman filters and the unscented
//! Rauch–Tung–Striebel smoother of `kalman::nonlinear` run over the same readings as the WLS.
//!
//! # Model
//! ```text
//! α̇ = ω,  ω̇ = ε,  ε̇ = w(t)   (white jerk, E[w(t) w(s)] = q·δ(t − s))
//! z_k = (a_x, a_y) = h(α_k, ω_k, ε_k) + v_k,   cov(v_k) = R = (Δa² + σ²)·I₂
//! ```
//! discretised exactly over the cycle Δt (Van Loan, `model::van_loan`):
//! `Φ = [[1, Δt, Δt²/2], [0, 1, Δt], [0, 0, 1]]`,
//! `Q = q·[[Δt⁵/20, Δt⁴/8, Δt³/6], [Δt⁴/8, Δt³/3, Δt²/2], [Δt³/6, Δt²/2, Δt]]`.
//!
//! **Why white jerk, not a random walk on ε alone.** The two are the same process in
//! continuous time (ε is the integral of white jerk); the difference is the discretisation.
//! The exact Q above also spreads the within-cycle jerk into α and ω, so Q is positive
//! definite and the model does not depend on the cycle length, whereas the discrete random
//! walk `Q = diag(0, 0, q·Δt)` claims that α and ω are perfectly predicted over a cycle.
//!
//! **The jerk intensity.** The nominal turn's ε is piecewise linear in α: two ramps (9°–12°
//! down from 0.4584 °/s² to 0, 77°–80° down to −ε_d ≈ −0.42 °/s²), each about 1 s long at
//! the cruise rate, constant in between. The ramps are the only jerk, |j| ≈ 0.45 °/s³. The
//! default q is chosen so that the model's one-sigma spread of ε over one second, √(q·1 s),
//! equals the largest change of ε the turn makes in one second (the first ramp's
//! 0.4584 °/s²): q = 0.4584²/1 s ≈ 0.21 (°/s²)²/s = 6.4e-5 rad²/s⁵. `jerk_psd` computes it
//! from the nominal turn, so a reconfigured profile gets its own, and `tracking.
//! jerk_psd_deg2_s5` overrides it. A smaller q (Bar-Shalom's per-cycle rule √(q·Δt) ≈ j·Δt
//! gives 100 times less) makes the filter lag each ramp; a larger one passes more noise
//! into ε. With this q and σ_z = Δa the filter's time constant on ε is
//! τ = √(r_ε/q) ≈ 0.01 s (r_ε = (σ_z/r)²·Δt), so on exact readings it lags a ramp by
//! j·τ ≈ 0.005 °/s², a hundredth of Δε (a unit test holds the filters to twice that).
//!
//! **The measurement.** h is `sensors::Accelerometer::clean` of the world's own sensor
//! configuration (γ, g, r, the centripetal flag, misalignment) without its bias: the gravity
//! projection at α − γ, ε·r and, when the world has it, −ω²·r, the same code that makes the
//! readings. The filters are not told the ±Δa bias: R counts it as noise of variance Δa²
//! (the sensor's limiting error), plus the white noise σ² when the world has noise. The
//! filters estimate α itself (γ is inside h), so nothing is added back.
//!
//! **Start.** The turn starts from rest: x₀ = (direct inversion of the first reading, ω = 0)
//! with P₀ from eq. (4) (σ_α = σ_z/(g cos β₀), σ_ε = σ_z·√(1 + tan²β₀)/r, β₀ the sensor
//! angle) and σ_ω = 1e-4 rad/s (a boom at rest, allowing a creep of 0.006 °/s). The first
//! step is predict-only, so the first reading is used once. Cycle 0 (the start-up cycle) is
//! excluded from the maxima as for the WLS.
//!
//! **Defined.** A filter never inverts h, so a_x > g (where arcsin is undefined) does not
//! stop it; it is *undefined* from the first cycle at which the library refuses a step
//! (singular innovation covariance, a sigma-point covariance that is not PSD, a non-finite
//! value), and stays undefined to the end of the turn. The smoother is undefined wherever
//! its filter was.

use kalman::FixedDims;
use kalman::nonlinear::{
    CentralDiff, Ekf, EkfUpdate, FnModel, NonlinearModel, NonlinearRts, SigmaPoints, Ukf,
};
use model::nalgebra::DMatrix;
use wls::boom::{Limits, Sign, TrajectoryPoint, TurnRun};

use super::parameters::BoomParams;
use crate::error::{Error, Result};

/// n = 3 states (α, ω, ε), m = 2 readings (a_x, a_y).
const DIMS: FixedDims<3, 2> = FixedDims::new();

/// ω₀'s standard deviation at the start of the turn (rest), rad/s.
const OMEGA0_STD: f64 = 1e-4;

/// The default white-jerk intensity of `trajectory`, rad²/s⁵: the largest change of ε over
/// any window of 1 s, squared, per second (see the module documentation). Never below
/// 1e-12 (a turn at constant ε would otherwise give a model that never lets ε move).
pub(super) fn jerk_psd(trajectory: &[TrajectoryPoint]) -> f64 {
    const WINDOW_S: f64 = 1.0;
    let mut worst: f64 = 0.0;
    let mut j = 0;
    for (i, p) in trajectory.iter().enumerate() {
        while j < i && p.t - trajectory[j].t > WINDOW_S {
            j += 1;
        }
        for q in &trajectory[j..i] {
            worst = worst.max((p.epsilon - q.epsilon).abs());
        }
    }
    (worst * worst / WINDOW_S).max(1e-12)
}

/// The white-jerk intensity of the tracking model, rad²/s⁵: the configured one, or the one
/// derived from the nominal turn `points` (`jerk_psd`).
pub(super) fn jerk_intensity(p: &BoomParams, points: &[TrajectoryPoint]) -> f64 {
    p.tracking
        .jerk_psd_deg2_s5
        .map_or_else(|| jerk_psd(points), |q| q * 1f64.to_radians().powi(2))
}

/// The tracking model at one γ for one world (centripetal term, noise σ).
#[derive(Debug, Clone)]
pub(super) struct TrackingModel {
    phi: [[f64; 3]; 3],
    q: [[f64; 3]; 3],
    r: [[f64; 2]; 2],
    sigma_z: f64,
    sensor: sensors::Accelerometer,
    points: SigmaPoints,
}

/// One estimator's (α̂, ε̂) per cycle, rad and rad/s²; NaN where undefined.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Track {
    pub(super) alpha: Vec<f64>,
    pub(super) eps: Vec<f64>,
}

impl Track {
    fn with_capacity(n: usize) -> Self {
        Self {
            alpha: Vec::with_capacity(n),
            eps: Vec::with_capacity(n),
        }
    }
    fn push(&mut self, x: Option<&[f64]>) {
        let (a, e) = x.map_or((f64::NAN, f64::NAN), |x| (x[0], x[2]));
        self.alpha.push(a);
        self.eps.push(e);
    }
}

/// The three estimates over one turn.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Tracked {
    pub(super) ekf: Track,
    pub(super) ukf: Track,
    pub(super) urts: Track,
}

fn kalman_err(context: &'static str) -> impl Fn(kalman::Error) -> Error {
    move |source| Error::Kalman { context, source }
}

impl TrackingModel {
    /// The model for the sensor mounted γ lower, in a world with (`centripetal`, white noise
    /// σ = `noise_std_mps2`), with jerk intensity `q` (rad²/s⁵).
    ///
    /// # Errors
    /// A sensor configuration the `sensors` crate rejects, or a Van Loan failure.
    pub(super) fn new(
        p: &BoomParams,
        gamma_deg: f64,
        centripetal: bool,
        noise_std_mps2: f64,
        q: f64,
    ) -> Result<Self> {
        let sensor = sensors::Accelerometer::new(&sensors::AccelerometerConfig {
            sensor_radius_m: p.sensor_radius_m,
            sensor_offset_angle: gamma_deg.to_radians(),
            gravity_mps2: p.gravity_mps2,
            centripetal,
            bias: sensors::BiasVariant::None,
            range_mps2: p.range_mps2,
            ..sensors::AccelerometerConfig::default()
        })
        .map_err(|source| Error::Sensors {
            context: "boom tracking model",
            source,
        })?;
        let a = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
        let g = DMatrix::from_row_slice(3, 1, &[0.0, 0.0, 1.0]);
        let w = DMatrix::from_element(1, 1, q);
        let (phi_d, q_d) =
            model::van_loan(&a, &g, &w, p.cycle_s).map_err(|source| Error::Model {
                context: "boom tracking model (Van Loan)",
                source,
            })?;
        let mut phi = [[0.0; 3]; 3];
        let mut qm = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                phi[i][j] = phi_d[(i, j)];
                qm[i][j] = q_d[(i, j)];
            }
        }
        let var = p.limiting_error_mps2.powi(2) + noise_std_mps2.powi(2);
        Ok(Self {
            phi,
            q: qm,
            r: [[var, 0.0], [0.0, var]],
            sigma_z: var.sqrt(),
            sensor,
            points: p.tracking.sigma_points,
        })
    }

    /// The discrete transition matrix Φ.
    #[cfg(test)]
    pub(super) fn phi(&self) -> [[f64; 3]; 3] {
        self.phi
    }

    /// The discrete process-noise covariance Q.
    #[cfg(test)]
    pub(super) fn q(&self) -> [[f64; 3]; 3] {
        self.q
    }

    /// The `kalman::nonlinear` model: f = Φ·x, h = the sensor's clean (a_x, a_y).
    fn model(&self) -> Result<impl NonlinearModel + Clone + use<>> {
        let phi = self.phi;
        let sensor = self.sensor.clone();
        FnModel::new(
            DIMS,
            move |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| {
                for (i, row) in phi.iter().enumerate() {
                    out[i] = row[0] * x[0] + row[1] * x[1] + row[2] * x[2];
                }
            },
            move |x: &[f64], _k: usize, out: &mut [f64]| {
                let a = sensor.clean(sensors::BoomMotion {
                    angle: x[0],
                    rate: x[1],
                    acceleration: x[2],
                });
                out[0] = a.x;
                out[1] = a.y;
            },
            &self.q,
            &self.r,
        )
        .map_err(kalman_err("boom tracking model"))
    }

    /// The prior at cycle 0 from the first reading (module documentation, "Start").
    fn prior(&self, z0: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let (g, r, gamma) = (
            self.sensor.gravity(),
            self.sensor.radius(),
            self.sensor.sensor_offset_angle(),
        );
        let beta = (z0[0] / g).clamp(-1.0, 1.0).asin();
        let (s, c) = beta.sin_cos();
        let c = c.max(1e-3);
        let eps = (z0[1] - g * c) / r;
        let sa = self.sigma_z / (g * c);
        let se = self.sigma_z * (1.0 + (s / c).powi(2)).sqrt() / r;
        (
            [beta + gamma, 0.0, eps],
            [
                [sa * sa, 0.0, 0.0],
                [0.0, OMEGA0_STD * OMEGA0_STD, 0.0],
                [0.0, 0.0, se * se],
            ],
        )
    }

    /// Runs the EKF (Jacobians of h by central differences of the sensor code), the UKF and
    /// the unscented RTS smoother over `readings` (one per cycle, (a_x, a_y, a_z)).
    ///
    /// # Errors
    /// A filter that cannot be built (never on valid parameters); a filter that fails
    /// during the turn is not an error but an undefined estimate from that cycle on.
    pub(super) fn track(&self, readings: &[[f64; 3]]) -> Result<Tracked> {
        let n = readings.len();
        let Some(&z0) = readings.first() else {
            return Ok(Tracked {
                ekf: Track::with_capacity(0),
                ukf: Track::with_capacity(0),
                urts: Track::with_capacity(0),
            });
        };
        let (x0, p0) = self.prior(z0);
        let model = self.model()?;
        let mut ekf = Ekf::new(
            DIMS,
            CentralDiff::new(DIMS, model.clone()),
            &x0,
            &p0,
            EkfUpdate::Extended,
        )
        .map_err(kalman_err("boom EKF"))?;
        let mut ukf =
            Ukf::new(DIMS, model, &x0, &p0, self.points).map_err(kalman_err("boom UKF"))?;
        let mut rts = NonlinearRts::new();
        let mut out = Tracked {
            ekf: Track::with_capacity(n),
            ukf: Track::with_capacity(n),
            urts: Track::with_capacity(n),
        };
        let (mut ekf_ok, mut ukf_ok) = (true, true);
        for (k, z) in readings.iter().enumerate() {
            // The first reading made the prior: step 0 only predicts.
            let zk = if k == 0 {
                [f64::NAN, f64::NAN]
            } else {
                [z[0], z[1]]
            };
            ekf_ok = ekf_ok && ekf.step(&zk, None).is_ok() && finite(ekf.state());
            out.ekf.push(ekf_ok.then(|| ekf.state()));
            ukf_ok = ukf_ok && ukf.step(&zk, None).is_ok() && finite(ukf.state());
            if ukf_ok {
                rts.record(&ukf).map_err(kalman_err("boom unscented RTS"))?;
            }
            out.ukf.push(ukf_ok.then(|| ukf.state()));
        }
        if !rts.is_empty() {
            let s = rts.smooth().map_err(kalman_err("boom unscented RTS"))?;
            for k in 0..rts.len() {
                out.urts
                    .push(Some(&[s.means[(0, k)], s.means[(1, k)], s.means[(2, k)]]));
            }
        }
        while out.urts.alpha.len() < n {
            out.urts.push(None);
        }
        Ok(out)
    }
}

fn finite(x: &[f64]) -> bool {
    x.iter().all(|v| v.is_finite())
}

/// A filter's per-cycle errors against the nominal turn, with the WLS's bookkeeping
/// ([`TurnRun::push`]): a cycle whose α̂ or ε̂ is not finite is undefined.
pub(super) fn turn_run(
    points: &[TrajectoryPoint],
    track: &Track,
    sign: Sign,
    limits: Limits,
) -> TurnRun {
    let mut run = TurnRun::new(sign, points.len());
    for ((p, &a), &e) in points.iter().zip(&track.alpha).zip(&track.eps) {
        let estimate = (a.is_finite() && e.is_finite()).then_some((a, e));
        run.push(p, estimate, f64::NAN, limits);
    }
    run
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boom::simulation::{Meter, readings, tracked_runs};
    use crate::montecarlo::run_rng;
    use wls::boom::ErrorVariant;

    #[test]
    fn van_loan_gives_the_white_jerk_closed_form() {
        let p = BoomParams::default();
        let q = 0.3;
        let m = TrackingModel::new(&p, 0.0, false, 0.0, q).expect("model");
        let dt = p.cycle_s;
        let phi = [[1.0, dt, dt * dt / 2.0], [0.0, 1.0, dt], [0.0, 0.0, 1.0]];
        let (d2, d3, d4, d5) = (dt.powi(2), dt.powi(3), dt.powi(4), dt.powi(5));
        let exact = [
            [d5 / 20.0, d4 / 8.0, d3 / 6.0],
            [d4 / 8.0, d3 / 3.0, d2 / 2.0],
            [d3 / 6.0, d2 / 2.0, dt],
        ];
        for i in 0..3 {
            for j in 0..3 {
                assert!((m.phi()[i][j] - phi[i][j]).abs() < 1e-14, "Φ[{i}][{j}]");
                // Relative to each entry: they span Δt⁵ … Δt (1e-10 … 1e-2).
                let e = q * exact[i][j];
                assert!((m.q()[i][j] - e).abs() < 1e-9 * e, "Q[{i}][{j}]");
            }
        }
    }

    #[test]
    fn jerk_intensity_of_a_ramp_is_its_slope_squared() {
        // ε ramps at j = 0.01 rad/s³ for 3 s: the largest change over 1 s is j·1 s, so
        // q = j²·(1 s)²/1 s = j².
        let j = 0.01;
        let pts: Vec<TrajectoryPoint> = (0..=300)
            .map(|i| {
                let t = f64::from(i) * 0.01;
                TrajectoryPoint {
                    t,
                    alpha: 0.0,
                    omega: 0.0,
                    epsilon: j * t,
                }
            })
            .collect();
        let q = jerk_psd(&pts);
        assert!((q - j * j).abs() < 1e-9 * j * j, "{q}");
    }

    /// On exact readings (no bias, no noise) the only error is the white-jerk model's lag
    /// behind the profile's ramps. For ε read through a_y with noise σ_z, the steady-state
    /// random-walk filter has the time constant τ = √(r_ε/q), r_ε = (σ_z/r)²·Δt the noise
    /// intensity of ε per reading, and lags a ramp of slope j by j·τ. The filter's α then
    /// absorbs at most that much a_y residual, r·j·τ, through g: δα ≲ r·j·τ/g. Both bounds
    /// are taken with a factor 2 for the coupling of the three states.
    #[test]
    fn filters_on_exact_readings_lag_the_ramps_by_no_more_than_the_model_says() {
        let p = BoomParams::default();
        let points = p.rotation_profile().trajectory().expect("profile").points;
        let q = jerk_intensity(&p, &points);
        let j = q.sqrt(); // the profile's jerk over a 1 s window, rad/s³
        let sigma_z = p.limiting_error_mps2;
        let r_eps = (sigma_z / p.sensor_radius_m).powi(2) * p.cycle_s;
        let tau = (r_eps / q).sqrt();
        let eps_bound = 2.0 * j * tau;
        let alpha_bound = 2.0 * p.sensor_radius_m * j * tau / p.gravity_mps2;
        let nominal = ErrorVariant {
            sign: Sign::Nominal,
            size: 0.0,
        };
        let limits = p.limits();
        for gamma_deg in [10.0, 0.0] {
            let model = TrackingModel::new(&p, gamma_deg, false, 0.0, q).expect("model");
            let mut meter = Meter::new(&p, false, 0.0, run_rng(1, 0));
            let z = readings(&points, &mut meter, gamma_deg.to_radians(), &nominal);
            let [ekf, ukf, urts] = tracked_runs(
                &points,
                &model.track(&z).expect("track"),
                Sign::Nominal,
                limits,
            );
            // At γ = 0 the end of the turn sits on the fold of a_x = g·sin α at 90°, where
            // the sigma points straddle the fold; the bound is the EKF's there, and every
            // method's at γ = 10°.
            let checked: &[(&str, &TurnRun)] = if gamma_deg > 0.0 {
                &[("ekf", &ekf), ("ukf", &ukf), ("urts", &urts)]
            } else {
                &[("ekf", &ekf)]
            };
            for &(name, run) in checked {
                assert!(run.first_undefined.is_none(), "{name} γ={gamma_deg}");
                let a_bound = alpha_bound;
                assert!(
                    run.max_angle_error <= a_bound,
                    "{name} γ={gamma_deg}: δα {} > {a_bound}",
                    run.max_angle_error
                );
                assert!(
                    run.max_epsilon_error <= eps_bound,
                    "{name} γ={gamma_deg}: δε {} > {eps_bound}",
                    run.max_epsilon_error
                );
            }
        }
    }
}
