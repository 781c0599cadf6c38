//! State-space models, shaping filters for random processes, discretisation and the paper's
//! 7-state fuel-level model, for stochastic estimation in launch and flight-test measurement.
//!
//! # Notation
//!
//! | symbol | meaning |
//! |---|---|
//! | n | number of states |
//! | m | number of outputs (measurements) |
//! | p | number of control (deterministic) inputs |
//! | q | number of white-noise inputs |
//! | `A`, `B`, `C`, `D` | continuous model `ẋ = Ax + Bu + Gw`, `y = Cx + Du` ([`ContinuousSs`]) |
//! | `G`, `W` | noise input matrix and white-noise intensity (spectral density) `E[w(t)w(s)ᵀ] = Wδ(t−s)` |
//! | `F`, `B`, `H`, `D` | discrete model `x_{k+1} = Fx_k + Bu_k + Gw_k`, `y_k = Hx_k + Du_k + Jw_k` ([`DiscreteSs`]) |
//! | `J`, `Q` | discrete noise feed-through and covariance `cov(w_k) = Q`; cross-covariance `GQJᵀ` |
//! | [`SYMMETRY_TOL`], [`PSD_TOL`] | the tolerance policy of every covariance check, relative to the matrix's own scale (a change of units never changes a verdict) |
//! | Δt (`dt`) | sampling interval in seconds |
//! | `N` | white-noise intensity of a scalar shaping filter; `D` its output variance |
//!
//! Transfer functions list coefficients in **ascending** powers: of s for [`ContinuousTf`]
//! (`1/(b s² + a s + 1)` is `num = [1]`, `den = [1, a, b]`), of z⁻¹ for [`DiscreteTf`].
//! All quantities are SI (seconds, metres, radians). The fuel model follows Mazurenko's paper
//! (see [References](#references)) and keeps its names (its `A`, `B`, `C`, `D`, `G`, `Q` are
//! [`FuelModel`]'s).
//!
//! # Discretisation methods
//!
//! [`discretize()`](fn@discretize) maps a [`ContinuousSs`] with a [`Discretization`] and a [`NoiseConvention`]:
//!
//! | method | map | use it when |
//! |---|---|---|
//! | [`Discretization::Zoh`] | `F = e^{AΔt}`, `B_d = ∫e^{Aτ}dτ·B` | inputs are held between samples (actuators, DAC), or you want the exact transition matrix of the continuous model; the default for simulation and Kalman filtering |
//! | [`Discretization::Tustin`] | `s = (2/Δt)(1−z⁻¹)/(1+z⁻¹)` | you need the frequency response preserved in shape and stability guaranteed (stable ↦ stable, DC gain kept), e.g. digital filters, or to match Mazurenko's fuel model |
//! | [`Discretization::TustinPrewarp`] | Tustin with Δt → `2tan(ωΔt/2)/ω` | as Tustin, but one frequency ω (a resonance, a notch, a crossover) must be exact |
//! | [`Discretization::ForwardEuler`] | `s = (z−1)/Δt` | Δt is far below every time constant and you want the simplest explicit update; can turn a stable model unstable |
//! | [`Discretization::BackwardEuler`] | `s = (z−1)/(zΔt)` | stiff models where robustness matters more than accuracy; always stable for stable models, but damps too much |
//! | paper variant ([`ContinuousTf::paper_tustin`], [`ShapingFilter::discretize_paper`]) | Tustin with one `(1+z⁻¹)` numerator factor replaced by `2z⁻¹` or `2` | reproducing the paper's fuel model ([`Realisation::Paper`]) |
//!
//! and the white noise either by [`NoiseConvention::VanLoan`] (the exact covariance of the
//! integrated noise: use it with ZOH for a faithful sampled model) or by
//! [`NoiseConvention::IntensityOverDt`] (the paper's "intensity N ↦ variance N/Δt", noise held
//! over the step, entering through the method's input map).
//!
//! # Example: the fuel-level model
//!
//! ```
//! use model::{Channels, FuelParams, Realisation};
//!
//! let params = FuelParams::default(); // assumed values: the paper's set is unavailable
//! let fuel = params.build(Channels::LevelAndTilt, Realisation::Paper)?;
//! println!("A = {}", fuel.a);
//! assert_eq!(fuel.a.shape(), (7, 7));
//! assert_eq!(fuel.c.shape(), (2, 7));
//! // The level state integrates the velocity: A[(1, 1)] = 1.
//! assert!((fuel.a[(1, 1)] - 1.0).abs() < 1e-15);
//! // R = D Q Dᵀ is singular (noise-free tilt channel) as in the paper.
//! assert!(fuel.r[(0, 0)].abs() < 1e-30);
//! # Ok::<(), model::Error>(())
//! ```
//!
//! # To a Kalman filter
//!
//! Matrices go in and come out as nalgebra `DMatrix<f64>`. A discretised model's noise in
//! the form a Kalman filter takes is [`DiscreteSs::filter_noise`] (`G Q Gᵀ`, `R_c + J Q Jᵀ`,
//! and the cross-covariance `G Q Jᵀ` that Tustin or held noise brings); with the feature
//! `kalman` (`stochest-model = { version = "0.1", features = ["kalman"] }`),
//! [`DiscreteSs::to_kalman`] builds the ready `kalman::Model` in one call:
//!
#![cfg_attr(
    feature = "kalman",
    doc = r##"
```
use model::nalgebra::dmatrix;
use model::{ContinuousSs, Discretization, NoiseConvention};
use kalman::{CovarianceForm, Filter, ToNalgebra};

// Constant velocity driven by white acceleration (intensity 0.1), position measured.
let sys = ContinuousSs::autonomous(dmatrix![0.0, 1.0; 0.0, 0.0], dmatrix![1.0, 0.0])?
    .with_noise(dmatrix![0.0; 1.0], dmatrix![0.1])?;
let dt = 0.5;
let disc = sys.discretize(dt, Discretization::Zoh, NoiseConvention::VanLoan)?;
let mut filter = Filter::new(disc.to_kalman(Some(&dmatrix![0.25]))?, &[0.0, 0.0],
    &dmatrix![1.0, 0.0; 0.0, 1.0], CovarianceForm::Joseph)?;
filter.step(&[0.3], None)?;
// nalgebra out; the model's Q is Van Loan's q·[[Δt³/3, Δt²/2], [Δt²/2, Δt]].
let q = filter.model().q().to_nalgebra();
assert!((q - dmatrix![dt.powi(3) / 3.0, dt * dt / 2.0; dt * dt / 2.0, dt] * 0.1).norm() < 1e-15);
# Ok::<(), model::Error>(())
```
"##
)]
//!
//! # Modules
//!
//! - [`ss`]: the model types; [`tf`]: transfer functions and realisations;
//! - [`discretize`](mod@discretize): methods and noise conventions; [`compose`]: series, parallel, feedback,
//!   `connect`; [`analysis`]: rank, stability, gains, responses, Lyapunov;
//! - [`shaping`]: shaping filters; [`fuel`]: the paper's model; [`bridge`]: to a Kalman
//!   filter's noise form and model;
//! - `strategies` (feature `proptest`): proptest strategies for users' property tests.
//!
//! # References
//! - V. B. Mazurenko, *Using information on the platform tilt angles when processing
//!   liquid-fuel level measurements with a discrete Kalman filter* (in Russian) — the fuel
//!   model ([`fuel`]), its Tustin variant ([`PaperVariant`]) and the `W/Δt` noise rule
//!   ([`NoiseConvention::IntensityOverDt`]).
//! - C. F. Van Loan, *Computing integrals involving the matrix exponential*, IEEE Trans.
//!   Automatic Control 23(3), 1978 — [`van_loan`].
//!
//! # Versions of the types in this API
//! Matrices and vectors are [`nalgebra`] 0.35 types (`DMatrix<f64>`, `DVector<f64>`),
//! re-exported as [`model::nalgebra`](nalgebra) so a user can name exactly the version this
//! crate is built against.
#![deny(missing_docs)]
// Links to the items of feature `kalman` resolve in the all-features build (docs.rs, CI),
// which checks every link; without the feature they have no target.
#![cfg_attr(not(feature = "kalman"), allow(rustdoc::broken_intra_doc_links))]
#![deny(clippy::float_cmp)]

// First: its `deserialize_via!` serves the modules below.
#[macro_use]
mod validate;

pub mod analysis;
pub mod bridge;
pub mod compose;
pub mod discretize;
pub mod error;
pub mod fuel;
pub mod shaping;
pub mod ss;
#[cfg(feature = "proptest")]
pub mod strategies;
pub mod tf;

pub use analysis::{
    discrete_lyapunov, eigenvalues, is_controllable, is_observable, markov_parameters, psd_factor,
    rank, spectral_abscissa, spectral_radius,
};
pub use bridge::FilterNoise;
pub use compose::{
    append, connect, connect_continuous, feedback, parallel, select_outputs, series, stack,
};
pub use discretize::{Discretization, NoiseConvention, discretize, expm, van_loan, zoh};
pub use error::{Error, Result};
pub use fuel::{
    Channels, FuelModel, FuelParams, FuelParamsStated, OUTPUT_NAMES, PaperCoefficients, Realisation,
};
pub use shaping::{
    DampedCosineShaping, ExponentialShaping, IrregularRollingShaping, ShapingFilter, noise_driven,
};
pub use ss::{ContinuousSs, DiscreteSs};
pub use tf::{ContinuousTf, DiscreteTf, PaperVariant};

/// Re-export of the linear-algebra crate whose types appear in this API.
pub use nalgebra;
pub use validate::{PSD_TOL, SYMMETRY_TOL};

/// The README's examples, compiled and run as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
