//! Continuous → discrete: ZOH (matrix exponential), Tustin (optionally pre-warped), forward
//! and backward Euler, with the process noise by Van Loan or by the paper's `W/Δt` rule.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::ss::{ContinuousSs, DiscreteSs};
use crate::tf::tustin_kappa;
use crate::validate;

/// How the deterministic part (`A`, `B`, `C`, `D`, and `G` when noise is held) is mapped.
///
/// See the table in the crate docs for when to use each.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
/// use model::{ContinuousSs, Discretization, NoiseConvention};
///
/// // 1/(s + 1) at Δt = 0.1: ZOH gives F = e^{−0.1}, Tustin (1 − 0.05)/(1 + 0.05).
/// let sys = ContinuousSs::new(dmatrix![-1.0], dmatrix![1.0], dmatrix![1.0], dmatrix![0.0])?;
/// let zoh = sys.discretize(0.1, Discretization::Zoh, NoiseConvention::VanLoan)?;
/// let tustin = sys.discretize(0.1, Discretization::Tustin, NoiseConvention::VanLoan)?;
/// assert!((zoh.f()[(0, 0)] - (-0.1f64).exp()).abs() < 1e-14);
/// assert!((tustin.f()[(0, 0)] - 0.95 / 1.05).abs() < 1e-14);
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Discretization {
    /// Zero-order hold: `F = e^{AΔt}`, `B_d = ∫₀^Δt e^{Aτ}dτ·B` (exact for inputs held
    /// constant over the step), `H = C`, `D_d = D`.
    Zoh,
    /// Bilinear / Tustin: `s = (2/Δt)(1 − z⁻¹)/(1 + z⁻¹)`. With `M = (I − AΔt/2)⁻¹`:
    /// `F = M(I + AΔt/2)`, `B_d = M·B·Δt`, `H = C·M`, `D_d = D + C·M·B·Δt/2`.
    Tustin,
    /// Tustin pre-warped at `omega` rad/s (0 < ω < π/Δt): Δt in the formulas above is
    /// replaced by `2·tan(ωΔt/2)/ω`, so the discrete response at ω equals the continuous one.
    TustinPrewarp {
        /// Pre-warp frequency in rad/s.
        omega: f64,
    },
    /// Forward Euler `s = (z − 1)/Δt`: `F = I + AΔt`, `B_d = BΔt`, `H = C`, `D_d = D`.
    ForwardEuler,
    /// Backward Euler `s = (z − 1)/(zΔt)`: with `M = (I − AΔt)⁻¹`: `F = M`, `B_d = M·B·Δt`,
    /// `H = C·M`, `D_d = D + C·M·B·Δt`.
    BackwardEuler,
}

/// How continuous white noise of intensity `W` becomes discrete noise.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
/// use model::{ContinuousSs, Discretization, NoiseConvention};
///
/// // Integrated white noise of intensity 2: Van Loan gives var = 2·Δt in the state;
/// // the paper's convention a held noise of variance 2/Δt through B_d = Δt.
/// let sys = ContinuousSs::autonomous(dmatrix![0.0], dmatrix![1.0])?
///     .with_noise(dmatrix![1.0], dmatrix![2.0])?;
/// let vl = sys.discretize(0.1, Discretization::Zoh, NoiseConvention::VanLoan)?;
/// let held = sys.discretize(0.1, Discretization::Zoh, NoiseConvention::IntensityOverDt)?;
/// assert!((vl.process_covariance()[(0, 0)] - 0.2).abs() < 1e-12);
/// assert!((held.q()[(0, 0)] - 20.0).abs() < 1e-12);
/// assert!((held.process_covariance()[(0, 0)] - 0.2).abs() < 1e-12); // Δt²·2/Δt
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum NoiseConvention {
    /// Van Loan: the exact covariance of `∫₀^Δt e^{Aτ}G w(τ)dτ`,
    /// `Q_d = ∫₀^Δt e^{Aτ}GWGᵀe^{Aᵀτ}dτ`, from one matrix exponential of
    /// `[[−A, GWGᵀ], [0, Aᵀ]]·Δt`. The discrete model gets `G = I_n`, `J = 0`, `Q = Q_d`
    /// (n×n). Exact with [`Discretization::Zoh`]; with other methods it pairs an exact noise
    /// covariance with an approximate `F`.
    VanLoan,
    /// Mazurenko's convention (fuel-level paper): the noise is held over the step as a white
    /// sequence of variance `W/Δt` and enters through the method's input map: `G_d` and `J` are
    /// what the method gives for an input matrix `G`, and `Q = W/Δt` (q×q).
    IntensityOverDt,
}

/// Matrix exponential `e^{M}`, 0×0-safe: `numerics::Expm`, the workspace's one exponential
/// (scaling and squaring with the Padé approximant of the degree M's 1-norm needs, Higham
/// 2005).
///
/// # Errors
/// [`Error::NotSquare`], [`Error::NonFiniteMatrix`] for a bad `M` or an overflowing result.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// let e = model::expm(&dmatrix![0.0, 1.0; 0.0, 0.0])?; // nilpotent: e^A = I + A
/// assert!((e - dmatrix![1.0, 1.0; 0.0, 1.0]).norm() < 1e-14);
/// # Ok::<(), model::Error>(())
/// ```
pub fn expm(m: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = validate::square("M", m)?;
    if n == 0 {
        return Ok(DMatrix::zeros(0, 0));
    }
    validate::finite("M", m)?;
    let mut work = numerics::Expm::new(n);
    work.input(n).copy_from_slice(m.as_slice());
    let mut e = DMatrix::zeros(n, n);
    if !work.run(n, e.as_mut_slice()) {
        e.fill(f64::NAN);
    }
    validate::finite("exp(M)", &e)?;
    Ok(e)
}

/// `e^{M}` for the exponential of one step of `A` (`what` names it): an overflow is the step's
/// fault, reported as [`Error::StepTooLarge`] naming `dt`.
fn expm_step(
    m: &DMatrix<f64>,
    a: &DMatrix<f64>,
    dt: f64,
    what: &'static str,
) -> Result<DMatrix<f64>> {
    expm(m).or_else(|_| step_too_large(a, dt, what))
}

/// [`Error::StepTooLarge`] for an exponential of `A·dt` (`what`) that overflows.
fn step_too_large<T>(a: &DMatrix<f64>, dt: f64, what: &'static str) -> Result<T> {
    let norm1 = (0..a.ncols())
        .map(|j| a.column(j).iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    Err(Error::StepTooLarge {
        dt,
        what,
        growth: norm1 * dt,
    })
}

/// Zero-order hold of `(A, B)` over `dt`: returns `(e^{A·dt}, ∫₀^dt e^{Aτ}dτ·B)`, from one
/// exponential of `[[A, B], [0, 0]]·dt`.
///
/// # Errors
/// [`Error::InvalidParameter`] for `dt` ≤ 0; shape and finiteness errors for `A`, `B`;
/// [`Error::StepTooLarge`] when the exponential overflows.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// // Double integrator over Δt = 2: F = [[1, 2], [0, 1]], B_d = [Δt²/2, Δt] = [2, 2].
/// let (f, bd) = model::zoh(&dmatrix![0.0, 1.0; 0.0, 0.0], &dmatrix![0.0; 1.0], 2.0)?;
/// assert!((f - dmatrix![1.0, 2.0; 0.0, 1.0]).norm() < 1e-13);
/// assert!((bd - dmatrix![2.0; 2.0]).norm() < 1e-13);
/// # Ok::<(), model::Error>(())
/// ```
pub fn zoh(a: &DMatrix<f64>, b: &DMatrix<f64>, dt: f64) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    validate::positive("dt", dt)?;
    let n = validate::square("A", a)?;
    validate::shape("B", b, n, b.ncols(), "B must have as many rows as A")?;
    let l = b.ncols();
    let mut m = DMatrix::zeros(n + l, n + l);
    m.view_mut((0, 0), (n, n)).copy_from(&(a * dt));
    m.view_mut((0, n), (n, l)).copy_from(&(b * dt));
    let e = expm_step(&m, a, dt, "e^{[[A, B], [0, 0]]·dt}")?;
    Ok((
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, l)).into_owned(),
    ))
}

/// Van Loan: returns `(e^{A·dt}, Q_d)` with `Q_d = ∫₀^dt e^{Aτ}GWGᵀe^{Aᵀτ}dτ` (symmetrised).
///
/// # Errors
/// [`Error::InvalidParameter`] for `dt` ≤ 0; shape, finiteness and PSD errors for the inputs;
/// [`Error::StepTooLarge`] when the exponential overflows. A zero `G W Gᵀ` gives `Q_d = 0`
/// without the `2n × 2n` exponential.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// // White acceleration of intensity q on a double integrator: the classic
/// // Q_d = q·[[Δt³/3, Δt²/2], [Δt²/2, Δt]].
/// let (q, dt) = (0.5, 0.2);
/// let (a, g) = (dmatrix![0.0, 1.0; 0.0, 0.0], dmatrix![0.0; 1.0]);
/// let (_, qd) = model::van_loan(&a, &g, &dmatrix![q], dt)?;
/// let exact = dmatrix![dt.powi(3) / 3.0, dt * dt / 2.0; dt * dt / 2.0, dt] * q;
/// assert!((qd - exact).norm() < 1e-14);
/// # Ok::<(), model::Error>(())
/// ```
pub fn van_loan(
    a: &DMatrix<f64>,
    g: &DMatrix<f64>,
    w: &DMatrix<f64>,
    dt: f64,
) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    validate::positive("dt", dt)?;
    let n = validate::square("A", a)?;
    validate::shape("G", g, n, g.ncols(), "G must have as many rows as A")?;
    validate::covariance("W", w, g.ncols(), "W must be q×q with q = columns of G")?;
    let gwg = g * w * g.transpose();
    let (mut phi, mut qd) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
    if !numerics::van_loan(
        a.as_slice(),
        gwg.as_slice(),
        n,
        dt,
        phi.as_mut_slice(),
        qd.as_mut_slice(),
    ) {
        let what = if gwg.iter().any(|v| v.abs() > 0.0) {
            "the Van Loan exponential e^{[[−A, GWGᵀ], [0, Aᵀ]]·dt}"
        } else {
            "e^{A·dt}"
        };
        return step_too_large(a, dt, what);
    }
    Ok((phi, qd))
}

/// The input part of a method: maps an input matrix `X` (n×k) to `(X_d, feed-through
/// addition Y_d)` such that the discrete model has `B_d = X_d`, `D_d = D + Y_d`.
struct Mapped {
    f: DMatrix<f64>,
    h: DMatrix<f64>,
    /// `(I − A·τ)` LU and scale factors for input mapping, or ZOH/Euler closed forms.
    kind: Kind,
}

enum Kind {
    Zoh {
        a: DMatrix<f64>,
        dt: f64,
    },
    Forward {
        dt: f64,
    },
    Implicit {
        lu: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
        c: DMatrix<f64>,
        in_scale: f64,
        ff_scale: f64,
    },
}

impl Mapped {
    fn new(sys: &ContinuousSs, dt: f64, method: Discretization) -> Result<Self> {
        let a = sys.a();
        let n = a.nrows();
        let eye = DMatrix::<f64>::identity(n, n);
        match method {
            Discretization::Zoh => {
                let f = expm_step(&(a * dt), a, dt, "e^{A·dt}")?;
                Ok(Self {
                    f,
                    h: sys.c().clone(),
                    kind: Kind::Zoh { a: a.clone(), dt },
                })
            }
            Discretization::ForwardEuler => Ok(Self {
                f: &eye + a * dt,
                h: sys.c().clone(),
                kind: Kind::Forward { dt },
            }),
            Discretization::Tustin
            | Discretization::TustinPrewarp { .. }
            | Discretization::BackwardEuler => {
                // Implicit maps: M = (I − A·τ)⁻¹ with τ = Δt/2 (Tustin, Δt pre-warped) or Δt.
                let (tau, name, plus) = match method {
                    Discretization::BackwardEuler => (dt, "I − A·dt", false),
                    Discretization::TustinPrewarp { omega } => {
                        (1.0 / tustin_kappa(dt, Some(omega))?, "I − A·dt/2", true)
                    }
                    _ => (1.0 / tustin_kappa(dt, None)?, "I − A·dt/2", true),
                };
                let m_inv = &eye - a * tau;
                let lu = m_inv.clone().lu();
                let rhs = if plus { &eye + a * tau } else { eye.clone() };
                let f = lu.solve(&rhs).ok_or(Error::Singular {
                    name,
                    context: "discretisation needs (I − A·τ)⁻¹",
                })?;
                // H = C·M  ⇔  Hᵀ = (I − A·τ)⁻ᵀ·Cᵀ.
                let ht =
                    m_inv
                        .transpose()
                        .lu()
                        .solve(&sys.c().transpose())
                        .ok_or(Error::Singular {
                            name,
                            context: "discretisation needs (I − A·τ)⁻ᵀ",
                        })?;
                let (in_scale, ff_scale) = if plus { (2.0 * tau, tau) } else { (tau, tau) };
                Ok(Self {
                    f,
                    h: ht.transpose(),
                    kind: Kind::Implicit {
                        lu,
                        c: sys.c().clone(),
                        in_scale,
                        ff_scale,
                    },
                })
            }
        }
    }

    /// Maps an input matrix: returns `(X_d, Y_d)` (feed-through addition).
    fn input(&self, x: &DMatrix<f64>) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
        let m = self.h.nrows();
        match &self.kind {
            Kind::Zoh { a, dt } => {
                let (_, xd) = zoh(a, x, *dt)?;
                Ok((xd, DMatrix::zeros(m, x.ncols())))
            }
            Kind::Forward { dt } => Ok((x * *dt, DMatrix::zeros(m, x.ncols()))),
            Kind::Implicit {
                lu,
                c,
                in_scale,
                ff_scale,
            } => {
                let mx = lu.solve(x).ok_or(Error::Singular {
                    name: "I − A·τ",
                    context: "discretisation of an input matrix",
                })?;
                let ff = c * &mx * *ff_scale;
                Ok((mx * *in_scale, ff))
            }
        }
    }
}

impl ContinuousSs {
    /// Discretises this model: shorthand for [`discretize`]`(self, dt, method, noise)`.
    ///
    /// # Errors
    /// As [`discretize`].
    pub fn discretize(
        &self,
        dt: f64,
        method: Discretization,
        noise: NoiseConvention,
    ) -> Result<DiscreteSs> {
        discretize(self, dt, method, noise)
    }
}

/// Discretises a continuous model with interval `dt`, `method` for the dynamics and `noise`
/// for the white-noise input (see [`NoiseConvention`]).
///
/// # Errors
/// [`Error::InvalidParameter`] for `dt` ≤ 0 or a bad pre-warp frequency,
/// [`Error::Singular`] when an implicit method meets `I − Aτ` singular,
/// [`Error::StepTooLarge`] when an exponential over the step overflows,
/// [`Error::NonFiniteMatrix`] when the result overflows. Only what the request needs is
/// computed: no exponential for Euler or Tustin dynamics, and no Van Loan exponential when
/// no noise enters (`G W Gᵀ = 0`, then `Q = 0`).
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
/// use model::{ContinuousSs, Discretization, NoiseConvention, discretize};
///
/// let sys = ContinuousSs::new(dmatrix![-2.0], dmatrix![1.0], dmatrix![1.0], dmatrix![0.0])?;
/// let d = discretize(&sys, 0.05, Discretization::Zoh, NoiseConvention::VanLoan)?;
/// // The DC gain 1/2 of the continuous model is kept by ZOH: H (1 − F)⁻¹ B_d = 1/2.
/// let dc = d.h()[(0, 0)] * d.b()[(0, 0)] / (1.0 - d.f()[(0, 0)]);
/// assert!((dc - 0.5).abs() < 1e-12);
/// assert!(discretize(&sys, 0.0, Discretization::Zoh, NoiseConvention::VanLoan).is_err());
/// # Ok::<(), model::Error>(())
/// ```
pub fn discretize(
    sys: &ContinuousSs,
    dt: f64,
    method: Discretization,
    noise: NoiseConvention,
) -> Result<DiscreteSs> {
    validate::positive("dt", dt)?;
    let mapped = Mapped::new(sys, dt, method)?;
    let (b, dff) = mapped.input(sys.b())?;
    let d = sys.d() + dff;
    let base = DiscreteSs::new(mapped.f.clone(), b, mapped.h.clone(), d, dt)?;
    let n = sys.n_states();
    let m = sys.n_outputs();
    match noise {
        NoiseConvention::VanLoan => {
            let gwg = sys.g() * sys.w() * sys.g().transpose();
            let q = if !gwg.iter().any(|v| v.abs() > 0.0) {
                // No noise enters: Q = 0 exactly, with no exponential to compute.
                DMatrix::zeros(n, n)
            } else {
                van_loan(sys.a(), sys.g(), sys.w(), dt)?.1
            };
            base.with_noise(DMatrix::identity(n, n), DMatrix::zeros(m, n), q)
        }
        NoiseConvention::IntensityOverDt => {
            let (g, j) = mapped.input(sys.g())?;
            base.with_noise(g, j, sys.w() / dt)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_van_loan_closed_form() {
        // ẋ = a x + w, intensity W: Q = W (e^{2aΔt} − 1)/(2a).
        let (a, w, dt) = (-0.7, 3.0, 0.4);
        let (phi, q) = van_loan(
            &DMatrix::from_element(1, 1, a),
            &DMatrix::from_element(1, 1, 1.0),
            &DMatrix::from_element(1, 1, w),
            dt,
        )
        .expect("ok");
        assert!((phi[(0, 0)] - (a * dt).exp()).abs() < 1e-15);
        let want = w * ((2.0 * a * dt).exp() - 1.0) / (2.0 * a);
        assert!((q[(0, 0)] - want).abs() < 1e-14 * want);
    }

    /// A scalar `ẋ = 1000 x`: `e^{1000·dt}` overflows `f64` for dt = 1 (e^{1000} > 1.8e308).
    fn fast_scalar(w: f64) -> ContinuousSs {
        ContinuousSs::autonomous(
            DMatrix::from_element(1, 1, 1000.0),
            DMatrix::from_element(1, 1, 1.0),
        )
        .and_then(|s| {
            s.with_noise(
                DMatrix::from_element(1, 1, 1.0),
                DMatrix::from_element(1, 1, w),
            )
        })
        .expect("valid")
    }

    #[test]
    fn euler_without_noise_computes_no_exponential() {
        // Forward Euler: F = 1 + A·dt = 1001 exactly; no noise, so Q = 0 without Van Loan.
        let d = discretize(
            &fast_scalar(0.0),
            1.0,
            Discretization::ForwardEuler,
            NoiseConvention::VanLoan,
        )
        .expect("Euler needs no exponential");
        assert!((d.f()[(0, 0)] - 1001.0).abs() < 1e-12);
        assert!(d.process_covariance()[(0, 0)].abs() < f64::MIN_POSITIVE);
    }

    #[test]
    fn overflowing_exponential_names_the_step() {
        for (method, w) in [
            (Discretization::Zoh, 0.0),
            (Discretization::ForwardEuler, 1.0),
            (Discretization::Zoh, 1.0),
        ] {
            let e = discretize(&fast_scalar(w), 1.0, method, NoiseConvention::VanLoan);
            match e {
                Err(Error::StepTooLarge { dt, growth, .. }) => {
                    assert!((dt - 1.0).abs() < f64::EPSILON);
                    assert!((growth - 1000.0).abs() < 1e-9, "{growth}");
                }
                other => panic!("{method:?}, W = {w}: expected StepTooLarge, got {other:?}"),
            }
        }
        // The growth is ‖A‖₁·Δt by definition: at Δt = 2 it is 2000.
        match discretize(
            &fast_scalar(0.0),
            2.0,
            Discretization::Zoh,
            NoiseConvention::VanLoan,
        ) {
            Err(Error::StepTooLarge { growth, .. }) => {
                assert!((growth - 2000.0).abs() < 1e-9, "{growth}");
            }
            other => panic!("Δt = 2: expected StepTooLarge, got {other:?}"),
        }
        // A step 100 times smaller is fine: e^{10} for ZOH, e^{20}-scale Van Loan.
        let d = discretize(
            &fast_scalar(1.0),
            0.01,
            Discretization::Zoh,
            NoiseConvention::VanLoan,
        )
        .expect("small step");
        assert!((d.f()[(0, 0)] / 10f64.exp() - 1.0).abs() < 1e-12);
        // Q = W (e^{2aΔt} − 1)/(2a).
        let want = (20f64.exp() - 1.0) / 2000.0;
        assert!((d.process_covariance()[(0, 0)] / want - 1.0).abs() < 1e-9);
    }

    #[test]
    fn van_loan_without_noise_needs_only_the_exponential_of_a() {
        // ẋ = −1000 x: e^{A·Δt} = e^{−1000} underflows harmlessly to 0, but the Van Loan
        // block e^{−A·Δt} = e^{1000} would overflow; with no noise (W = 0) Q_d = 0 exactly
        // and that block is never formed.
        let a = DMatrix::from_element(1, 1, -1000.0);
        let g = DMatrix::from_element(1, 1, 1.0);
        let (phi, q) = van_loan(&a, &g, &DMatrix::zeros(1, 1), 1.0).expect("no overflow");
        assert!(phi[(0, 0)].abs() < f64::MIN_POSITIVE && q[(0, 0)].abs() < f64::MIN_POSITIVE);
        // With noise the block is needed and overflows: a typed error naming the step.
        let e = van_loan(&a, &g, &DMatrix::from_element(1, 1, 1.0), 1.0);
        assert!(matches!(e, Err(Error::StepTooLarge { .. })), "{e:?}");
    }

    #[test]
    fn tustin_singular_when_pole_at_two_over_dt() {
        let sys = ContinuousSs::new(
            DMatrix::from_element(1, 1, 20.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
        )
        .expect("valid");
        let e = discretize(
            &sys,
            0.1,
            Discretization::Tustin,
            NoiseConvention::IntensityOverDt,
        );
        assert!(matches!(e, Err(Error::Singular { .. })), "{e:?}");
    }
}
