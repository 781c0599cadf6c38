//! The linear filter as a mode of the IMM estimator: its update and prediction stages run
//! separately, with the posterior overwritten by the IMM's mixing between them.
#![allow(non_snake_case)]

use super::{CovarianceForm, Filter, StepInfo, check_diverged, check_inputs, dense};
use crate::Error;
use crate::imm::ops::ModeOps;
use crate::storage::{Buf, Dims};

impl<D: Dims> ModeOps for Filter<D> {
    fn mode_dims(&mut self) -> (usize, usize) {
        (self.model.dims.n(), self.model.dims.m())
    }

    fn mode_check(&self) -> Result<(), Error> {
        if self.st.form == CovarianceForm::SquareRoot {
            return Err(Error::InvalidOption {
                name: "form",
                value: 2.0,
                rule: "an IMM mode runs the Joseph or the standard form (the square-root \
                       form keeps a factor the mixing would have to refactor)",
            });
        }
        if self.model.S.is_some() {
            return Err(Error::InvalidOption {
                name: "S",
                value: 1.0,
                rule: "an IMM mode takes no cross-covariance S (the mixed prior is not \
                       the prior the correlated-noise prediction conditions on)",
            });
        }
        Ok(())
    }

    fn mode_update(&mut self, z: &[f64]) -> Result<StepInfo, Error> {
        let d = self.model.dims;
        let observed = check_inputs(&d, &mut self.st, z, None)?;
        let mut info = if observed == 0 {
            dense::no_update(d, &mut self.st);
            StepInfo::default()
        } else {
            dense::update(&self.model, &mut self.st, z, observed)
        };
        info.step = self.st.k;
        info.observed = observed;
        check_diverged(
            info.step,
            ("x_{k|k}", self.st.xf.as_slice()),
            ("P_{k|k}", self.st.pf.as_slice()),
            d.n(),
        )?;
        Ok(info)
    }

    fn mode_predict(&mut self, u: Option<&[f64]>) -> Result<(), Error> {
        let d = self.model.dims;
        if let Some(u) = u {
            crate::model::check_vec("u", u, d.p())?;
        }
        dense::predict(&self.model, &mut self.st, u, false);
        check_diverged(
            self.st.k,
            ("x_{k+1|k}", self.st.xp.as_slice()),
            ("P_{k+1|k}", self.st.pp.as_slice()),
            d.n(),
        )
    }

    fn mode_advance(&mut self, info: StepInfo) {
        self.st.info = info;
        self.st.k += 1;
    }

    fn mode_posterior(&self) -> (&[f64], &[f64]) {
        let n = self.model.dims.n();
        (&self.st.xf.as_slice()[..n], &self.st.pf.as_slice()[..n * n])
    }

    fn mode_posterior_mut(&mut self) -> (&mut [f64], &mut [f64]) {
        let n = self.model.dims.n();
        (
            &mut self.st.xf.as_mut_slice()[..n],
            &mut self.st.pf.as_mut_slice()[..n * n],
        )
    }

    fn mode_prior(&self) -> (&[f64], &[f64]) {
        let n = self.model.dims.n();
        (&self.st.xp.as_slice()[..n], &self.st.pp.as_slice()[..n * n])
    }

    /// `C_k = P_{k|k} Fᵀ`.
    fn mode_cross_covariance(&self, out: &mut [f64]) {
        let n = self.model.dims.n();
        let (P, F) = (self.st.pf.as_slice(), self.model.F.as_slice());
        for a in 0..n {
            for b in 0..n {
                out[a + b * n] = (0..n).map(|c| P[a + c * n] * F[b + c * n]).sum();
            }
        }
    }
}
