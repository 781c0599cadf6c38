//! Continuous-time dynamics for the nonlinear filters: `ẋ = a(x, u, t)` integrated by
//! classical Runge–Kutta over each interval of a record's own time stamps (feature
//! `autodiff`).
//!
//! The model, the integration and the noise are documented on [`TimeStamped`].

use super::models::{default_hooks, forward_hooks};
use super::{GenericModel, Scalar};
use crate::Error;
use crate::storage::Dims;

/// The most states a [`TimeStamped`] model integrates (its Runge–Kutta stages are stack
/// arrays of this length, so a step allocates nothing).
pub const MAX_CONTINUOUS_STATES: usize = 32;

/// The default longest Runge–Kutta sub-step of [`TimeStamped`], in the units of the time
/// stamps (0.01 s for stamps in seconds). RK4's relative local error per sub-step is about
/// `(h/τ)⁵/120` for a time constant or period/2π `τ` of the dynamics, so the default keeps
/// it near 10⁻¹² for `τ ≥ 0.1` s; set [`TimeStamped::with_max_substep`] for faster or slower
/// dynamics.
pub const DEFAULT_MAX_SUBSTEP: f64 = 1e-2;

/// The most Runge–Kutta sub-steps one interval of a [`TimeStamped`] record may need; a
/// longest interval that would need more with the chosen `max_substep` is refused at
/// construction (a long gap in the record with a short sub-step would otherwise run for
/// minutes inside one filter step).
pub const MAX_SUBSTEPS: usize = 1_000_000;

/// Continuous-time dynamics `ẋ = a(x, u, t)` with a discrete measurement `h(x, k)`, generic
/// over the scalar like [`GenericModel`], for [`TimeStamped`].
///
/// Matrices are column-major (entry `(i, j)` at `out[i + j·rows]`).
///
/// ```
/// use kalman::nonlinear::{ContinuousDynamics, Scalar};
/// /// A pendulum, x = (θ, ω), with its angle measured.
/// struct Pendulum;
/// impl ContinuousDynamics for Pendulum {
///     fn a<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _t: f64, out: &mut [T]) {
///         out[0] = x[1];
///         out[1] = -x[0].sin() * 9.81;
///     }
///     fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
///         out[0] = x[0];
///     }
///     fn w(&self, _t: f64, out: &mut [f64]) { out.copy_from_slice(&[0.0, 0.0, 0.0, 1e-2]); }
///     fn r(&self, _k: usize, out: &mut [f64]) { out[0] = 1e-4; }
/// }
/// let mut xdot = [0.0_f64; 2];
/// Pendulum.a(&[0.0, 1.0], None, 0.0, &mut xdot);
/// assert!((xdot[0] - 1.0).abs() < 1e-15 && xdot[1].abs() < 1e-15);
/// ```
pub trait ContinuousDynamics {
    /// The drift `a(x, u, t)` into `out` (length n). `t` is the absolute time (the stamp
    /// at the start of the interval plus the offset of the Runge–Kutta stage), so
    /// time-varying dynamics work; `u` is the step's input, held over the interval.
    fn a<T: Scalar>(&self, x: &[T], u: Option<&[f64]>, t: f64, out: &mut [T]);
    /// The measurement function `h(x, k)` of row k into `out` (length m).
    fn h<T: Scalar>(&self, x: &[T], k: usize, out: &mut [T]);
    /// The process-noise intensity `W(t)` (n×n, symmetric PSD, as the noise enters the
    /// state: `G Qc Gᵀ` for a noise input matrix G), evaluated at the start of an interval.
    fn w(&self, t: f64, out: &mut [f64]);
    /// `R_k` (m×m, symmetric PSD), the covariance of row k's measurement noise.
    fn r(&self, k: usize, out: &mut [f64]);
    default_hooks!();
}

/// [`ContinuousDynamics`] over a record's time stamps, as the discrete [`GenericModel`] of
/// the record's steps. The dynamics hold the model
///
/// ```text
/// ẋ = a(x, u, t) + w(t),   E[w(t) w(s)ᵀ] = W(t) δ(t − s),   z_k = h(x(t_k), k) + v_k,   cov(v_k) = R_k,
/// ```
///
/// and the time stamps `t_0 ≤ t_1 ≤ …` set the steps: step k (which updates with row k, then
/// predicts) integrates `a` from `t_k` to `t_{k+1}` with the input `u_k` held constant
/// (zero-order hold); the last row predicts over Δt = 0, as in [`crate::sampling`].
///
/// - The transition `f(x, u, k)` is the classical fourth-order Runge–Kutta map over
///   `s = ⌈Δt_k / max_substep⌉` equal sub-steps of length `h = Δt_k / s`. Its local error
///   is O(h⁵) per sub-step and its global error over the interval O(Δt h⁴).
/// - The map is written over the generic [`Scalar`], so [`AutoDiff`](super::AutoDiff) gives
///   its exact Jacobian (the derivative of the integrated map itself, not of a linearised
///   ODE): the [`Ekf`](super::Ekf) and its smoother linearise what the filter propagates.
///   Each Jacobian costs n more integrations.
/// - The process noise is the intensity integrated over the interval to first order,
///   `Q_k = W(t_k) Δt_k`. The exact covariance of a linear model `ẋ = A x + w` is
///   `∫₀^Δt e^{Aτ} W e^{Aᵀτ} dτ = W Δt + (A W + W Aᵀ) Δt²/2 + O(Δt³)`, so the first-order
///   form is accurate when `‖A‖ Δt ≪ 1` for the Jacobian A of `a` — intervals short against
///   the dynamics' time constants and periods — and misses, for instance, the `W Δt³/3`
///   position variance that white acceleration puts into a position state over one
///   interval. For a linear model the exact Van Loan form is in [`crate::sampling`]
///   (`ContinuousModel` and `Sampler`, which also sample the input exactly).
/// - Δt = 0 (two rows of one instant) is the identity transition with `Q_k = 0`.
///
/// The integration allocates nothing: its stages live in stack arrays of
/// [`MAX_CONTINUOUS_STATES`] entries, so n is limited to that many states.
///
/// Wrap it in [`AutoDiff`](super::AutoDiff) for the [`Ekf`](super::Ekf) (the exact
/// Jacobian of the integrated map) or the unscented filters; the filter's step k must be
/// the record's row k (a filter [`reset`](super::Ekf::reset) restarts at row 0).
///
/// ```
/// use kalman::DynDims;
/// use kalman::nonlinear::{AutoDiff, ContinuousDynamics, Ekf, EkfUpdate, Scalar, TimeStamped};
/// /// A pendulum, x = (θ, ω), with its angle measured.
/// struct Pendulum;
/// impl ContinuousDynamics for Pendulum {
///     fn a<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _t: f64, out: &mut [T]) {
///         out[0] = x[1];
///         out[1] = -x[0].sin() * 9.81;
///     }
///     fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
///         out[0] = x[0];
///     }
///     fn w(&self, _t: f64, out: &mut [f64]) { out.copy_from_slice(&[0.0, 0.0, 0.0, 1e-2]); }
///     fn r(&self, _k: usize, out: &mut [f64]) { out[0] = 1e-4; }
/// }
/// # fn main() -> Result<(), kalman::Error> {
/// // Rows at irregular stamps (two at one instant), angles in rad.
/// let t = [0.0, 0.07, 0.2, 0.2, 0.31, 0.5];
/// let z = [0.30, 0.293, 0.243, 0.244, 0.170, 0.001];
/// let d = DynDims::new(2, 1, 0)?;
/// let model = TimeStamped::new(Pendulum, d, &t)?.with_max_substep(0.005)?;
/// assert_eq!(model.substeps(1), 26); // ⌈0.13 / 0.005⌉
/// let mut ekf = Ekf::new(d, AutoDiff::new(d, model), &[0.3, 0.0],
///     &[[1e-2, 0.0], [0.0, 1e-1]], EkfUpdate::Extended)?;
/// for zk in z {
///     ekf.step(&[zk], None)?;
/// }
/// // Near 0.3 cos(√9.81 t) = 0.0014 at t = 0.5 (small swing).
/// assert!((ekf.state()[0] - 0.0014).abs() < 0.02);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct TimeStamped<D> {
    dynamics: D,
    t: Vec<f64>,
    max_substep: f64,
}

impl<D: ContinuousDynamics> TimeStamped<D> {
    /// `dynamics` (of the dimensions `dims`) over the time stamps `t`, with the sub-step
    /// [`DEFAULT_MAX_SUBSTEP`].
    ///
    /// # Errors
    /// [`Error::TimeStamp`] naming `t` and the index of a non-finite stamp or of one earlier
    /// than the stamp before it; [`Error::Dimension`] for more than
    /// [`MAX_CONTINUOUS_STATES`] states; [`Error::InvalidOption`] naming `max_substep` when
    /// the longest interval would need more than [`MAX_SUBSTEPS`] sub-steps.
    pub fn new(dynamics: D, dims: impl Dims, t: &[f64]) -> Result<Self, Error> {
        if dims.n() > MAX_CONTINUOUS_STATES {
            return Err(Error::Dimension {
                name: "n",
                value: dims.n(),
                rule: "continuous dynamics hold n <= 32 states (MAX_CONTINUOUS_STATES)",
            });
        }
        for (index, &value) in t.iter().enumerate() {
            if !value.is_finite() {
                return Err(Error::TimeStamp {
                    name: "t",
                    index,
                    value,
                    rule: "time stamps must be finite",
                });
            }
            if index > 0 && value < t[index - 1] {
                return Err(Error::TimeStamp {
                    name: "t",
                    index,
                    value,
                    rule: "time stamps must not go back",
                });
            }
        }
        Self {
            dynamics,
            t: t.to_vec(),
            max_substep: DEFAULT_MAX_SUBSTEP,
        }
        .with_max_substep(DEFAULT_MAX_SUBSTEP)
    }

    /// Sets the longest Runge–Kutta sub-step (in the units of `t`; default
    /// [`DEFAULT_MAX_SUBSTEP`]).
    ///
    /// # Errors
    /// [`Error::InvalidOption`] naming `max_substep` if it is not finite and positive, or if
    /// the longest interval of `t` would need more than [`MAX_SUBSTEPS`] sub-steps.
    pub fn with_max_substep(mut self, max_substep: f64) -> Result<Self, Error> {
        if !(max_substep.is_finite() && max_substep > 0.0) {
            return Err(Error::InvalidOption {
                name: "max_substep",
                value: max_substep,
                rule: "the longest Runge-Kutta sub-step must be finite and positive",
            });
        }
        let longest = self.t.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
        // Non-finite when the longest interval overflows (stamps of opposite huge signs).
        let needed = (longest / max_substep).ceil();
        if needed.is_nan() || needed > MAX_SUBSTEPS as f64 {
            return Err(Error::InvalidOption {
                name: "max_substep",
                value: max_substep,
                rule: "the longest interval of t would need more than MAX_SUBSTEPS = 10^6 sub-steps",
            });
        }
        self.max_substep = max_substep;
        Ok(self)
    }

    /// The longest Runge–Kutta sub-step.
    pub fn max_substep(&self) -> f64 {
        self.max_substep
    }

    /// The time stamps.
    pub fn times(&self) -> &[f64] {
        &self.t
    }

    /// The interval `Δt_k = t[k + 1] − t[k]` step k predicts over (0 for the last row and
    /// beyond).
    pub fn interval(&self, k: usize) -> f64 {
        match (self.t.get(k), self.t.get(k + 1)) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// The number of Runge–Kutta sub-steps of step k, `⌈Δt_k / max_substep⌉` (0 for
    /// Δt_k = 0).
    pub fn substeps(&self, k: usize) -> usize {
        // At most MAX_SUBSTEPS (checked at construction), so the cast is exact.
        (self.interval(k) / self.max_substep).ceil() as usize
    }

    /// The dynamics.
    pub fn inner(&self) -> &D {
        &self.dynamics
    }

    /// The dynamics, mutable (e.g. to change a parameter between steps).
    pub fn inner_mut(&mut self) -> &mut D {
        &mut self.dynamics
    }
}

impl<D: ContinuousDynamics> GenericModel for TimeStamped<D> {
    /// The RK4 map of step k's interval (the identity for Δt_k = 0).
    fn f<T: Scalar>(&self, x: &[T], u: Option<&[f64]>, k: usize, out: &mut [T]) {
        let n = x.len().min(MAX_CONTINUOUS_STATES);
        let out = &mut out[..n];
        out.copy_from_slice(&x[..n]);
        let steps = self.substeps(k);
        if steps == 0 {
            return;
        }
        let h = self.interval(k) / steps as f64;
        let t0 = self.t[k];
        let zero = T::from(0.0);
        let mut slope = [zero; MAX_CONTINUOUS_STATES];
        let mut stage = [zero; MAX_CONTINUOUS_STATES];
        let mut acc = [zero; MAX_CONTINUOUS_STATES];
        let (slope, stage, acc) = (&mut slope[..n], &mut stage[..n], &mut acc[..n]);
        for i in 0..steps {
            let ti = t0 + i as f64 * h;
            // k1 at (t, x); k2, k3 at the midpoint; k4 at the end; acc = k1 + 2 k2 + 2 k3 + k4.
            self.dynamics.a(out, u, ti, slope);
            for j in 0..n {
                acc[j] = slope[j];
                stage[j] = out[j] + slope[j] * (0.5 * h);
            }
            self.dynamics.a(stage, u, ti + 0.5 * h, slope);
            for j in 0..n {
                acc[j] += slope[j] * 2.0;
                stage[j] = out[j] + slope[j] * (0.5 * h);
            }
            self.dynamics.a(stage, u, ti + 0.5 * h, slope);
            for j in 0..n {
                acc[j] += slope[j] * 2.0;
                stage[j] = out[j] + slope[j] * h;
            }
            self.dynamics.a(stage, u, ti + h, slope);
            for j in 0..n {
                acc[j] += slope[j];
                out[j] += acc[j] * (h / 6.0);
            }
        }
    }
    fn h<T: Scalar>(&self, x: &[T], k: usize, out: &mut [T]) {
        self.dynamics.h(x, k, out);
    }
    /// `W(t[k]) Δt_k` (0 for Δt_k = 0).
    fn q(&self, k: usize, out: &mut [f64]) {
        let dt = self.interval(k);
        if dt > 0.0 {
            self.dynamics.w(self.t[k], out);
            for v in out.iter_mut() {
                *v *= dt;
            }
        } else {
            out.fill(0.0);
        }
    }
    fn r(&self, k: usize, out: &mut [f64]) {
        self.dynamics.r(k, out);
    }
    forward_hooks!(dynamics);
}
