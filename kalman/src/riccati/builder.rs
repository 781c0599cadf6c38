//! The one builder behind every Riccati solver: [`Riccati`] holds the checked matrices and
//! the options, and its kind (a sealed [`Equation`]) names the matrices and picks the
//! driver and the read-out; [`Dare`], [`Dlqr`], [`Care`] and [`Clqr`] are its four aliases,
//! with each equation written out.
#![allow(non_snake_case)]

use std::marker::PhantomData;

use super::care::{continuous_dual, continuous_lqr, continuous_residual};
use super::dare::{discrete_dual, discrete_lqr, discrete_residual};
use super::problem::{Coupling, FilterForm, Finish, Inputs, Names, Solved, Time};
use super::{ContinuousSteadyState, Lqr, Pair, RiccatiOptions, SteadyState};
use crate::storage::Dims;
use crate::{Error, MatrixInput, Model};

/// A Riccati problem of kind `E`: its four matrices (copied and checked once), an optional
/// cross term and the [`RiccatiOptions`]. Use it through its aliases, which carry each
/// equation and the names of its matrices: [`Dare`](super::Dare) (filter DARE),
/// [`Dlqr`](super::Dlqr) (discrete LQR), [`Care`](super::Care) (filter CARE) and
/// [`Clqr`](super::Clqr) (continuous LQR). Every one is called the same way:
/// `new(…)?`, then optionally the cross term and `.options(…)`, then `.solve()` or
/// `.residual(…)`.
///
/// The LQR equations are solved as the filter equations of the dual problem (A → Aᵀ,
/// B → Bᵀ, N → S), so each time axis has one solver: the doubling with its PBH checks and
/// Newton polish for the discrete equations, the doubling after a Cayley transform for
/// the continuous ones.
///
/// # Example
/// ```
/// use kalman::riccati::{Dlqr, Riccati, LqrDare};
///
/// // The alias and the generic name are the same type.
/// let lqr: Riccati<LqrDare> = Dlqr::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])?;
/// let x = (1.0 + 5f64.sqrt()) / 2.0; // X² = X + 1
/// assert!((lqr.solve()?.cost[(0, 0)] - x).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Riccati<E> {
    pub(crate) inputs: Inputs,
    options: RiccatiOptions,
    equation: PhantomData<E>,
}

/// The kind of a [`Riccati`] problem: which equation it is and what [`Riccati::solve`]
/// returns. Sealed (its hidden `SPEC` has a type outside the public API): its
/// implementations are the four kinds [`FilterDare`](super::FilterDare),
/// [`LqrDare`](super::LqrDare), [`FilterCare`](super::FilterCare) and
/// [`LqrCare`](super::LqrCare).
///
/// # Example
/// ```
/// use kalman::riccati::{Care, ContinuousSteadyState, Equation, Riccati};
///
/// // Code generic over the equation still knows each solution's type.
/// fn solve<E: Equation>(problem: &Riccati<E>) -> Result<E::Solution, kalman::Error> {
///     problem.solve()
/// }
/// // ẋ = −x + w, z = x + v, q = r = 1: P = √2 − 1.
/// let ss: ContinuousSteadyState = solve(&Care::new([[-1.0]], [[1.0]], [[1.0]], [[1.0]])?)?;
/// assert!((ss.covariance[(0, 0)] - (2f64.sqrt() - 1.0)).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub trait Equation {
    /// The result of [`Riccati::solve`]: [`SteadyState`](super::SteadyState),
    /// [`Lqr`](super::Lqr) or [`ContinuousSteadyState`](super::ContinuousSteadyState).
    type Solution: Finish;
    /// All the builder needs to know of the equation.
    #[doc(hidden)]
    const SPEC: Spec;
}

/// What the builder needs to know of one equation: how its second matrix meets the state (a
/// measurement matrix for a filter equation; an input matrix for an LQR, solved as the dual
/// filter equation) and its time axis. The names of its matrices and its labels in errors
/// follow from the two.
#[derive(Debug, Clone, Copy)]
pub struct Spec {
    coupling: Coupling,
    time: Time,
}

/// Declares the kinds of equation: for each, a marker type (never constructed) with its
/// [`Equation`] implementation, its solution type, its coupling and its time axis.
macro_rules! kinds {
    ($($(#[$doc:meta])* $kind:ident -> $solution:ty = ($coupling:ident, $time:ident);)*) => {$(
        $(#[$doc])*
        #[derive(Debug, Clone, Copy)]
        pub enum $kind {}

        impl Equation for $kind {
            type Solution = $solution;
            const SPEC: Spec = Spec {
                coupling: Coupling::$coupling,
                time: Time::$time,
            };
        }
    )*};
}

kinds! {
    /// The kind of [`Dare`](super::Dare): the filter DARE, solved as written.
    FilterDare -> SteadyState = (Measurement, Discrete);
    /// The kind of [`Dlqr`](super::Dlqr): the discrete LQR, solved as its dual filter DARE.
    LqrDare -> Lqr = (Input, Discrete);
    /// The kind of [`Care`](super::Care): the filter CARE, solved as written.
    FilterCare -> ContinuousSteadyState = (Measurement, Continuous);
    /// The kind of [`Clqr`](super::Clqr): the continuous LQR, solved as its dual filter
    /// CARE.
    LqrCare -> Lqr = (Input, Continuous);
}

impl Spec {
    /// Names of (a, c, q, r) as the equation writes them, as errors name them.
    fn matrices(self) -> [&'static str; 4] {
        match (self.coupling, self.time) {
            (Coupling::Measurement, Time::Discrete) => ["F", "H", "Q", "R"],
            (Coupling::Measurement, Time::Continuous) => ["A", "H", "Q", "R"],
            (Coupling::Input, _) => ["A", "B", "Q", "R"],
        }
    }

    /// The equation and its pairs in the solver's errors (`cross`: a cross term was given).
    /// The LQR's pairs are those of its dual read back: detectability of (Aᵀ, Bᵀ) is
    /// stabilisability of (A, B), and stabilisability of (Aᵀ, Q^{1/2}) is detectability of
    /// (Q^{1/2}, A).
    fn names(self, cross: bool) -> Names {
        use {Coupling::*, Time::*};
        let (equation, detect, stab) = match (self.coupling, self.time, cross) {
            (Measurement, Discrete, false) => ("filter DARE", "(F, H)", "(F, Q^{1/2})"),
            (Measurement, Discrete, true) => (
                "filter DARE",
                "(F, H)",
                "(F - S R^-1 H, (Q - S R^-1 S^T)^{1/2})",
            ),
            (Input, Discrete, false) => ("LQR DARE", "(A, B)", "(Q^{1/2}, A)"),
            (Input, Discrete, true) => (
                "LQR DARE",
                "(A, B)",
                "((Q - N R^-1 N^T)^{1/2}, A - B R^-1 N^T)",
            ),
            (Measurement, Continuous, _) => ("filter CARE", "(A, H)", "(A, Q^{1/2})"),
            (Input, Continuous, _) => ("LQR CARE", "(A, B)", "(Q^{1/2}, A)"),
        };
        let (detect, stab) = match self.coupling {
            Measurement => (Pair::Detect(detect), Pair::Stab(stab)),
            Input => (Pair::Stab(detect), Pair::Detect(stab)),
        };
        Names {
            equation,
            detect,
            stab,
        }
    }
}

impl Finish for Lqr {
    fn finish(inputs: &Inputs, time: Time, solved: Solved) -> Result<Self, Error> {
        match time {
            Time::Discrete => discrete_lqr(inputs, solved),
            Time::Continuous => continuous_lqr(inputs, solved),
        }
    }
}

impl<E: Equation> Riccati<E> {
    /// The problem of the four matrices (a, c, q, r) in the order and under the names of the
    /// equation: (F, H, Q, R) for [`Dare`](super::Dare), (A, B, Q, R) for
    /// [`Dlqr`](super::Dlqr) and [`Clqr`](super::Clqr), (A, H, Q, R) for
    /// [`Care`](super::Care); a and q are n×n, r is m×m, a measurement matrix H is m×n and
    /// an input matrix B n×m. No cross term and default options.
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming the first bad matrix.
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::Dare;
    ///
    /// // H must be m×n: a 1×2 H for one state is refused, naming H.
    /// let e = Dare::new([[1.0]], [[1.0, 0.0]], [[1.0]], [[1.0]]).expect_err("bad H");
    /// assert!(matches!(e, kalman::Error::Shape { name: "H", .. }));
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn new(
        a: impl MatrixInput,
        c: impl MatrixInput,
        q: impl MatrixInput,
        r: impl MatrixInput,
    ) -> Result<Self, Error> {
        Ok(Self {
            inputs: Inputs::new(E::SPEC.matrices(), E::SPEC.coupling, [&a, &c, &q, &r])?,
            options: RiccatiOptions::default(),
            equation: PhantomData,
        })
    }

    /// Adds the cross term (n×m) under `name`: the builders' `cross_covariance` and
    /// `cross_weight`.
    pub(crate) fn cross(self, name: &'static str, cross: &dyn MatrixInput) -> Result<Self, Error> {
        Ok(Self {
            inputs: self.inputs.with_cross(name, cross)?,
            ..self
        })
    }

    /// Replaces the default [`RiccatiOptions`].
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::{Dare, RiccatiOptions};
    ///
    /// // A stricter residual check still accepts the scalar random walk, P = (1 + √5)/2.
    /// let opts = RiccatiOptions { residual_tolerance: 1e-13, ..RiccatiOptions::default() };
    /// let ss = Dare::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])?.options(opts).solve()?;
    /// assert!((ss.prior[(0, 0)] - (1.0 + 5f64.sqrt()) / 2.0).abs() < 1e-12);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    #[must_use]
    pub fn options(self, options: RiccatiOptions) -> Self {
        Self { options, ..self }
    }

    /// The stabilising solution and its gains.
    ///
    /// # Errors
    /// As listed on each alias ([`Dare`](super::Dare), [`Dlqr`](super::Dlqr),
    /// [`Care`](super::Care), [`Clqr`](super::Clqr)).
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::Dare;
    ///
    /// // Random walk observed in unit noise, q = 1: P = (1 + √5)/2, K = P/(P + 1).
    /// let ss = Dare::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])?.solve()?;
    /// let p = (1.0 + 5f64.sqrt()) / 2.0;
    /// assert!((ss.gain[(0, 0)] - p / (p + 1.0)).abs() < 1e-12);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn solve(&self) -> Result<E::Solution, Error> {
        let form = self.filter_form();
        let names = E::SPEC.names(form.S.is_some());
        let solved = match E::SPEC.time {
            Time::Discrete => discrete_dual(&form, &self.options, &names)?,
            Time::Continuous => continuous_dual(&form, &self.options, &names)?,
        };
        E::Solution::finish(&self.inputs, E::SPEC.time, solved)
    }

    /// Relative residual ‖Res(X)‖_F / ‖X‖_F of a candidate solution X (P for the filter
    /// equations, the cost X for the LQR; each alias writes its equation out): 0 when both
    /// vanish, +∞ when the matrix the equation inverts (H P Hᵀ + R, R + BᵀXB or R) is not
    /// positive definite. The solver's own acceptance check, open for tests.
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming P (X for the LQR) unless it is n×n and
    /// finite.
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::Dare;
    ///
    /// // The golden ratio solves the scalar random walk's DARE p = p + 1 − p²/(p + 1); 2 does not.
    /// let dare = Dare::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])?;
    /// assert!(dare.residual([[(1.0 + 5f64.sqrt()) / 2.0]])? < 1e-15);
    /// // At P = 2: residual 2 + 1 − 4/3 − 2 = −1/3, relative to ‖P‖ = 2.
    /// assert!((dare.residual([[2.0]])? - 1.0 / 6.0).abs() < 1e-15);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn residual(&self, candidate: impl MatrixInput) -> Result<f64, Error> {
        let unknown = match E::SPEC.coupling {
            Coupling::Measurement => "P",
            Coupling::Input => "X",
        };
        let candidate = self.inputs.candidate(unknown, &candidate)?;
        let form = self.filter_form();
        Ok(match E::SPEC.time {
            Time::Discrete => discrete_residual(&form, candidate.as_ref()),
            Time::Continuous => continuous_residual(&form, candidate.as_ref()),
        })
    }

    /// The problem in filter form: the inputs themselves for a filter equation, those of
    /// the dual for an LQR.
    fn filter_form(&self) -> FilterForm<'_> {
        let ([a, c, q, r], cross) = self.inputs.views();
        let (F, H) = match E::SPEC.coupling {
            Coupling::Measurement => (a, c),
            Coupling::Input => (a.transpose(), c.transpose()),
        };
        FilterForm {
            F,
            H,
            Q: q,
            R: r,
            S: cross,
        }
    }
}

/// The filter DARE of (F, H, Q, R) with an optional cross-covariance S (n×m): for
/// x_{k+1} = F x_k + w_k, z_k = H x_k + v_k with cov(w) = Q (n×n), cov(v) = R (m×m) and
/// E[w_k v_kᵀ] = S, the steady-state prior covariance P solves
///
/// P = F P Fᵀ + Q − (F P Hᵀ + S)(H P Hᵀ + R)⁻¹(F P Hᵀ + S)ᵀ.
///
/// [`Dare::new(F, H, Q, R)?`](Riccati::new) (F n×n, H m×n, Q n×n, R m×m), then optionally
/// [`.cross_covariance(S)?`](Riccati::cross_covariance) and
/// [`.options(…)`](Riccati::options); [`.solve()`](Riccati::solve) gives the
/// [`SteadyState`], [`.residual(P)`](Riccati::residual) the relative residual of a
/// candidate P.
///
/// R may be singular (an exact channel) as long as H P Hᵀ + R is positive definite at the
/// solution (see the shift in the crate's `riccati` module docs).
///
/// Errors of `solve`: [`Error::NotPositiveDefinite`] for H P Hᵀ + R when no noise reaches
/// an exact channel; [`Error::NotDetectable`]
/// for (F, H); [`Error::NotStabilisable`] for a mode of (F̃, Q̃^{1/2}) on the unit circle
/// that the noise does not reach (F̃ = F − S R⁻¹ H, Q̃ = Q − S R⁻¹ Sᵀ; plain (F, Q^{1/2})
/// when S = 0); [`Error::RiccatiNoConvergence`] / [`Error::RiccatiCheck`] if the result
/// fails. Shape and finiteness errors naming the matrix come from the builder's own calls.
///
/// # Example
/// ```
/// use faer::mat;
/// use kalman::riccati::Dare;
///
/// // Random walk observed in unit noise, q = 1: P = (1 + √5)/2, K = P/(P + 1).
/// let one = mat![[1.0]];
/// let ss = Dare::new(&one, &one, &one, &one)?.solve()?;
/// let p = (1.0 + 5f64.sqrt()) / 2.0;
/// assert!((ss.prior[(0, 0)] - p).abs() < 1e-12);
/// assert!((ss.gain[(0, 0)] - p / (p + 1.0)).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub type Dare = Riccati<FilterDare>;

impl Riccati<FilterDare> {
    /// Adds the cross-covariance S = E[w_k v_kᵀ] (n×m).
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming S.
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::Dare;
    ///
    /// // F = H = Q = R = 1 and S = 1/2: P = P + 1 − (P + 1/2)²/(P + 1), so P² = 3/4.
    /// let ss = Dare::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])?.cross_covariance([[0.5]])?.solve()?;
    /// assert!((ss.prior[(0, 0)] - 0.75f64.sqrt()).abs() < 1e-12);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn cross_covariance(self, S: impl MatrixInput) -> Result<Self, Error> {
        self.cross("S", &S)
    }
}

impl SteadyState {
    /// The steady state of an engine [`Model`] (either storage path): [`Dare`] on its F, H,
    /// Q, R and S.
    ///
    /// # Errors
    /// As [`Dare`]'s `solve`.
    pub fn of<D: Dims>(model: &Model<D>) -> Result<Self, Error> {
        let mut dare = Dare::new(model.f(), model.h(), model.q(), model.r())?;
        if let Some(s) = model.s() {
            dare = dare.cross_covariance(s)?;
        }
        dare.solve()
    }
}

/// The discrete-time LQR for x_{k+1} = A x_k + B u_k with cost Σ xᵀQx + uᵀRu + 2xᵀN u (no
/// cross weight N unless given): the cost-to-go X solves
///
/// X = AᵀXA + Q − (AᵀXB + N)(R + BᵀXB)⁻¹(BᵀXA + Nᵀ),
///
/// solved as the dual filter DARE (F = Aᵀ, H = Bᵀ, S = N); the [`Lqr`] gain is
/// L = (R + BᵀXB)⁻¹(BᵀXA + Nᵀ) with u = −L x.
///
/// [`Dlqr::new(A, B, Q, R)?`](Riccati::new) (A n×n, B n×m, state weight Q n×n, input
/// weight R m×m), then optionally [`.cross_weight(N)?`](Riccati::cross_weight) and
/// [`.options(…)`](Riccati::options); [`.solve()`](Riccati::solve) gives the [`Lqr`],
/// [`.residual(X)`](Riccati::residual) the relative residual of a candidate cost matrix X
/// (the filter-form residual of the dual).
///
/// Errors of `solve`: [`Error::NotStabilisable`] for (A, B) (modes on or outside the
/// unit circle), [`Error::NotDetectable`] for (Q^{1/2}, A) (modes on the unit circle: an
/// unobserved unstable mode off the circle is stabilised by the gain), PD errors naming the
/// matrix. Shape and finiteness errors come from the builder's own calls.
///
/// The UAV loop of Gridnev, Rusetsky and Rak (state weight diag(1, 0.1), input weight 1,
/// Δt = 0.25):
/// ```
/// use faer::mat;
/// use kalman::riccati::Dlqr;
///
/// let dt = 0.25;
/// let a = mat![[1.0, dt], [0.0, 1.0]];
/// let b = mat![[dt * dt / 2.0], [dt]];
/// let lqr = Dlqr::new(&a, &b, mat![[1.0, 0.0], [0.0, 0.1]], mat![[1.0]])?.solve()?;
/// // The closed loop A − B L is stable.
/// let cl = &a - &b * &lqr.gain;
/// let rho = cl.eigenvalues().expect("must succeed").iter().map(|l| l.norm()).fold(0.0, f64::max);
/// assert!(rho < 1.0);
/// # Ok::<(), kalman::Error>(())
/// ```
///
/// With options:
/// ```
/// use kalman::riccati::{Dlqr, RiccatiOptions};
///
/// // x_{k+1} = 2 x_k + u_k, cost Σ x² + u²: X = 2 + √5 (from X² − 4X − 1 = 0), L = 2X/(1 + X).
/// let opts = RiccatiOptions { max_iterations: 50, ..RiccatiOptions::default() };
/// let lqr = Dlqr::new([[2.0]], [[1.0]], [[1.0]], [[1.0]])?.options(opts).solve()?;
/// let x = 2.0 + 5f64.sqrt();
/// assert!((lqr.cost[(0, 0)] - x).abs() < 1e-12 && (lqr.gain[(0, 0)] - 2.0 * x / (1.0 + x)).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub type Dlqr = Riccati<LqrDare>;

impl Riccati<LqrDare> {
    /// Adds the cross weight N (n×m) of the cost term 2xᵀN u.
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming N.
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::Dlqr;
    ///
    /// // A = B = Q = R = 1 and N = 1/2: X = X + 1 − (X + 1/2)²/(1 + X), so X² = 3/4.
    /// let lqr = Dlqr::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])?.cross_weight([[0.5]])?.solve()?;
    /// assert!((lqr.cost[(0, 0)] - 0.75f64.sqrt()).abs() < 1e-12);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn cross_weight(self, N: impl MatrixInput) -> Result<Self, Error> {
        self.cross("N", &N)
    }
}

/// The filter CARE of the Kalman–Bucy filter for ẋ = A x + w, z = H x + v with
/// intensities Q (n×n) and R (m×m): the stabilising P solves
///
/// A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q = 0,
///
/// where `Q` is the n×n process-noise intensity as it enters the state (G Q_w Gᵀ for a
/// noise input matrix G and intensity Q_w). [`Care::new(A, H, Q, R)?`](Riccati::new) (A
/// n×n, H m×n, Q n×n, R m×m), then optionally [`.options(…)`](Riccati::options);
/// [`.solve()`](Riccati::solve) gives P and the gain K = P Hᵀ R⁻¹ as a
/// [`ContinuousSteadyState`], [`.residual(P)`](Riccati::residual) the relative residual
/// ‖A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q‖_F / ‖P‖_F of a candidate P (+∞ when R is not positive
/// definite).
///
/// Method: the dual control-form CARE X A_c + A_cᵀ X − X G X + Q = 0 (A_c = Aᵀ,
/// G = Hᵀ R⁻¹ H) has Hamiltonian ℋ = [[A_c, −G], [−Q, −A_cᵀ]]. With γ > ρ(ℋ) the Cayley
/// map (ℋ + γI)(ℋ − γI)⁻¹ sends its stable eigenvalues inside the unit circle, and the pencil
/// (ℋ + γI) − μ(ℋ − γI) is brought to the standard symplectic form of the SDA with
/// A_γ = A_c − γI, V = A_γ + G A_γ⁻ᵀ Q: A₀ = I + 2γV⁻¹, G₀ = 2γ V⁻¹ G A_γ⁻ᵀ,
/// H₀ = 2γ V⁻ᵀ Q A_γ⁻¹; the doubling then converges to X = P.
///
/// Errors of `solve` as [`Dare`](super::Dare) with the continuous stability boundary
/// (Re λ ≥ 0).
///
/// # Example
/// ```
/// use faer::mat;
/// use kalman::riccati::Care;
///
/// // ẋ = −x + w, z = x + v, q = r = 1: −2P − P² + 1 = 0, P = √2 − 1.
/// let one = mat![[1.0]];
/// let care = Care::new(mat![[-1.0]], &one, &one, &one)?;
/// let ss = care.solve()?;
/// assert!((ss.covariance[(0, 0)] - (2f64.sqrt() - 1.0)).abs() < 1e-12);
/// // The exact root has a residual at round-off.
/// assert!(care.residual([[2f64.sqrt() - 1.0]])? < 1e-15);
/// # Ok::<(), kalman::Error>(())
/// ```
///
/// With options:
/// ```
/// use kalman::riccati::{Care, RiccatiOptions};
///
/// // ẋ = w, z = x + v, q = 4, r = 1: −P² + 4 = 0, P = 2, K = 2.
/// let opts = RiccatiOptions { residual_tolerance: 1e-12, ..RiccatiOptions::default() };
/// let ss = Care::new([[0.0]], [[1.0]], [[4.0]], [[1.0]])?.options(opts).solve()?;
/// assert!((ss.covariance[(0, 0)] - 2.0).abs() < 1e-12 && (ss.gain[(0, 0)] - 2.0).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub type Care = Riccati<FilterCare>;

/// The continuous-time LQR for ẋ = A x + B u with cost ∫ xᵀQx + uᵀRu: the cost-to-go X
/// solves
///
/// X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q = 0,
///
/// solved as the dual filter CARE (A → Aᵀ, H = Bᵀ); the [`Lqr`] gain is L = R⁻¹ Bᵀ X
/// (u = −L x). [`Clqr::new(A, B, Q, R)?`](Riccati::new) (A n×n, B n×m, state weight Q
/// n×n, input weight R m×m), then optionally [`.options(…)`](Riccati::options);
/// [`.solve()`](Riccati::solve) gives the [`Lqr`], [`.residual(X)`](Riccati::residual) the relative residual
/// ‖X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q‖_F / ‖X‖_F of a candidate cost matrix X.
///
/// Errors of `solve`: [`Error::NotStabilisable`] for (A, B), [`Error::NotDetectable`]
/// for (Q^{1/2}, A) (modes with Re λ ≥ 0), PD errors naming the matrix.
///
/// # Example
/// ```
/// use kalman::riccati::Clqr;
///
/// // ẋ = u, cost ∫ x² + u²: X = 1, L = 1.
/// let lqr = Clqr::new([[0.0]], [[1.0]], [[1.0]], [[1.0]])?.solve()?;
/// assert!((lqr.gain[(0, 0)] - 1.0).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub type Clqr = Riccati<LqrCare>;
