//! The extended and unscented filters as modes of the IMM estimator: their update and
//! prediction stages ([`Stages`]) run separately, with the posterior overwritten by the
//! IMM's mixing between them.
#![allow(non_snake_case)]

use super::{Ekf, ForwardPass, Jacobians, NlDims, NonlinearModel, Stages, StepInfo, Ukf};
use crate::Error;
use crate::imm::ops::ModeOps;
use crate::storage::Buf;

/// The [`ModeOps`] of a nonlinear filter, over its [`Stages`] and [`ForwardPass`].
macro_rules! nonlinear_mode {
    () => {
        fn mode_dims(&mut self) -> (usize, usize) {
            let d = self.core().dims;
            (d.n(), d.m())
        }
        fn mode_check(&self) -> Result<(), Error> {
            let (x, p) = self.filtered();
            if x.len() * x.len() != p.len() {
                // The IMM mixes means and covariances as vectors and matrices.
                return Err(Error::Dimension {
                    name: "modes",
                    value: x.len(),
                    rule: "an IMM mode's state is a vector: stored length = n (no manifold)",
                });
            }
            Ok(())
        }
        fn mode_update(&mut self, z: &[f64]) -> Result<StepInfo, Error> {
            self.core().check_z(z)?;
            self.update_stage(z)
        }
        fn mode_predict(&mut self, u: Option<&[f64]>) -> Result<(), Error> {
            self.predict_stage(u)
        }
        fn mode_advance(&mut self, info: StepInfo) {
            let c = self.core();
            c.info = info;
            c.k += 1;
        }
        fn mode_posterior(&self) -> (&[f64], &[f64]) {
            self.filtered()
        }
        fn mode_posterior_mut(&mut self) -> (&mut [f64], &mut [f64]) {
            let c = self.core();
            let n = c.dims.n();
            (
                &mut c.xf.as_mut_slice()[..n],
                &mut c.pf.as_mut_slice()[..n * n],
            )
        }
        fn mode_prior(&self) -> (&[f64], &[f64]) {
            self.predicted()
        }
        fn mode_cross_covariance(&self, out: &mut [f64]) {
            self.cross_covariance(out);
        }
    };
}

impl<D: NlDims, M: Jacobians> ModeOps for Ekf<D, M> {
    nonlinear_mode!();
}

impl<D: NlDims, M: NonlinearModel> ModeOps for Ukf<D, M> {
    nonlinear_mode!();
}
