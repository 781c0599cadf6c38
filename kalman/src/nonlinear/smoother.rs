//! The extended and unscented Rauch–Tung–Striebel smoothers over a recorded forward pass.
#![allow(non_snake_case)]

use crate::Error;
use crate::smoother::{Recorded, Smoothed};

/// A filter whose steps a [`NonlinearRts`] can record: after step k it holds
/// `(x_{k|k}, P_{k|k})`, `(x_{k+1|k}, P_{k+1|k})` and the cross-covariance
/// `C_k = Cov(x_k, x_{k+1} | z_0..z_k)`. Matrices are column-major slices.
pub trait ForwardPass {
    /// `(x_{k|k}, P_{k|k})`.
    fn filtered(&self) -> (&[f64], &[f64]);
    /// `(x_{k+1|k}, P_{k+1|k})`.
    fn predicted(&self) -> (&[f64], &[f64]);
    /// `C_k` into `out` (n×n): `P_{k|k} F_kᵀ` for the [`super::Ekf`] (F_k the Jacobian of f
    /// at `x_{k|k}`), `Σ Wc_i (χ_i − x_{k|k})(f(χ_i) − x_{k+1|k})ᵀ` for the [`super::Ukf`].
    fn cross_covariance(&self, out: &mut [f64]);
}

/// The nonlinear Rauch–Tung–Striebel smoother: recorded from an [`super::Ekf`] it is the
/// extended RTS smoother, from a [`super::Ukf`] the unscented RTS smoother (Särkkä,
/// "Unscented Rauch–Tung–Striebel smoother"): both run the backward pass
///
/// `J_k = C_k P_{k+1|k}⁻¹`,  `x_{k|N} = x_{k|k} + J_k (x_{k+1|N} − x_{k+1|k})`,
/// `P_{k|N} = P_{k|k} + J_k (P_{k+1|N} − P_{k+1|k}) J_kᵀ`
///
/// with `J_k` from a Cholesky solve (the minimum-norm solution when `P_{k+1|k}` is
/// singular), and differ only in how the filter formed `C_k` ([`ForwardPass`]). Differences
/// are plain subtractions (the smoother does not hold the model's angle wrapping).
///
/// ```
/// use kalman::DynDims;
/// use kalman::nonlinear::{FnModel, NonlinearRts, SigmaPoints, Ukf};
/// # fn main() -> Result<(), kalman::Error> {
/// let d = DynDims::new(1, 1, 0)?;
/// let model = FnModel::new(
///     d,
///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = x[0],
///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0],
///     &[[1.0]],
///     &[[1.0]],
/// )?;
/// let mut ukf = Ukf::new(d, model, &[0.0], &[[1.0]], SigmaPoints::merwe(1.0, 2.0, 0.0))?;
/// let mut rts = NonlinearRts::new();
/// for z in [1.0, 3.0] {
///     ukf.step(&[z], None)?;
///     rts.record(&ukf)?;
/// }
/// let s = rts.smooth()?;
/// // The batch solution of this random walk (see the linear smoother): x = (1, 2).
/// assert!((s.means[(0, 0)] - 1.0).abs() < 1e-14 && (s.means[(0, 1)] - 2.0).abs() < 1e-14);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, Default)]
pub struct NonlinearRts {
    n: usize,
    xf: Vec<f64>,
    pf: Vec<f64>,
    xp: Vec<f64>,
    pp: Vec<f64>,
    ct: Vec<f64>,
    c: Vec<f64>,
    steps: usize,
}

impl NonlinearRts {
    /// An empty recorder; the number of states is fixed by the first recorded step.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of recorded steps.
    pub fn len(&self) -> usize {
        self.steps
    }

    /// Whether nothing is recorded.
    pub fn is_empty(&self) -> bool {
        self.steps == 0
    }

    /// Records the step the filter has just taken.
    ///
    /// # Errors
    /// [`Error::Dimension`] if the filter's n differs from that of the steps recorded before.
    pub fn record(&mut self, filter: &impl ForwardPass) -> Result<(), Error> {
        let (xf, pf) = filter.filtered();
        if self.steps == 0 {
            self.n = xf.len();
            self.c = vec![0.0; self.n * self.n];
        }
        let n = self.n;
        let (xp, pp) = filter.predicted();
        if xf.len() != n {
            return Err(Error::Dimension {
                name: "n",
                value: xf.len(),
                rule: "the smoother's n must match the filter's",
            });
        }
        filter.cross_covariance(&mut self.c);
        self.xf.extend_from_slice(xf);
        self.pf.extend_from_slice(pf);
        self.xp.extend_from_slice(xp);
        self.pp.extend_from_slice(pp);
        self.ct.extend_from_slice(&self.c);
        self.steps += 1;
        Ok(())
    }

    /// The backward pass over all recorded steps.
    ///
    /// # Errors
    /// [`Error::Dimension`] if nothing was recorded; [`Error::Factorisation`] if the eigen
    /// fallback for a singular `P_{k+1|k}` fails.
    pub fn smooth(&self) -> Result<Smoothed, Error> {
        Recorded {
            n: self.n,
            steps: self.steps,
            xf: &self.xf,
            pf: &self.pf,
            xp: &self.xp,
            pp: &self.pp,
            ct: &self.ct,
        }
        .backward(|_, _, _| Ok(()))
    }
}
