//! The problem as the drivers take it: the checked inputs, their filter form, the error
//! labels, the solved unknown and its final check, and how a solution type is read out of
//! it. Below both the drivers (`dare.rs`, `care.rs`) and the builder that calls them.
#![allow(non_snake_case)]

use faer::{Mat, MatRef};

use super::{Pair, RiccatiOptions};
use crate::model::{check, owned};
use crate::{Error, MatrixInput};

/// How the second matrix of a Riccati problem meets the state: a measurement matrix (m×n,
/// the filter form's H) or an input matrix (n×m, the control form's B).
#[derive(Debug, Clone, Copy)]
pub enum Coupling {
    Measurement,
    Input,
}

/// Discrete or continuous time: which filter-form equation the dual problem is.
#[derive(Debug, Clone, Copy)]
pub enum Time {
    Discrete,
    Continuous,
}

/// Error labels: `detect` is reported when the (F, H)-like pair of the filter form fails,
/// `stab` when the (F, Q^{1/2})-like pair fails.
#[derive(Debug)]
pub struct Names {
    pub(super) equation: &'static str,
    pub(super) detect: Pair,
    pub(super) stab: Pair,
}

/// The matrices of a problem in filter form, as the solvers and residuals take them: F
/// (n×n), H (m×n), Q (n×n), R (m×m) and the cross-covariance S (n×m) for a filter equation
/// (A in the place of F for the CARE, which takes no S), those of the dual (Aᵀ, Bᵀ, Q, R,
/// N) for an LQR.
#[derive(Debug, Clone, Copy)]
pub struct FilterForm<'a> {
    pub(super) F: MatRef<'a, f64>,
    pub(super) H: MatRef<'a, f64>,
    pub(super) Q: MatRef<'a, f64>,
    pub(super) R: MatRef<'a, f64>,
    pub(super) S: Option<MatRef<'a, f64>>,
}

/// The solved unknown (P or X) with the doubling steps used, its relative residual and the
/// round-off floor of that residual (see [`RiccatiOptions::residual_floor_factor`]).
#[derive(Debug)]
pub struct Solved {
    pub(super) x: Mat<f64>,
    pub(super) iterations: usize,
    pub(super) relative_residual: f64,
    pub(super) floor: f64,
}

impl Solved {
    /// The solvers' last check: the relative residual within `residual_floor_factor` times
    /// its round-off floor (and within `residual_tolerance`) and the closed loop stable (`closed_loop` its spectral radius below 1 in discrete time, its
    /// spectral abscissa below 0 in continuous time), written so that a NaN residual or
    /// `closed_loop` fails it; [`Error::RiccatiCheck`] otherwise.
    pub(super) fn checked(
        self,
        closed_loop: f64,
        time: Time,
        opts: &RiccatiOptions,
        equation: &'static str,
    ) -> Result<Self, Error> {
        let stable = match time {
            Time::Discrete => closed_loop < 1.0,
            Time::Continuous => closed_loop < 0.0,
        };
        let gate = (opts.residual_floor_factor * self.floor).min(opts.residual_tolerance);
        if self.relative_residual <= gate && stable {
            Ok(self)
        } else {
            Err(Error::RiccatiCheck {
                equation,
                residual: self.relative_residual,
                tolerance: gate,
                closed_loop,
            })
        }
    }
}

/// How a solution type is read out of the solved unknown: the gains and checks, from the
/// inputs as given (not dualised).
pub trait Finish: Sized {
    fn finish(inputs: &Inputs, time: Time, solved: Solved) -> Result<Self, Error>;
}

/// The matrices of a Riccati problem, copied once from the caller's inputs and checked for
/// shape and finiteness: `a` (n×n), `c` (m×n or n×m by its [`Coupling`]), `q` (n×n), `r`
/// (m×m) and the optional cross term (n×m).
#[derive(Debug, Clone)]
pub struct Inputs {
    pub(crate) a: Mat<f64>,
    pub(crate) c: Mat<f64>,
    pub(crate) q: Mat<f64>,
    pub(crate) r: Mat<f64>,
    pub(crate) cross: Option<Mat<f64>>,
}

impl Inputs {
    /// Copies and checks the inputs; `names` are (a, c, q, r) as the caller's equation
    /// writes them. The first bad matrix is reported ([`Error::Shape`] /
    /// [`Error::NonFinite`]).
    pub(crate) fn new(
        names: [&'static str; 4],
        coupling: Coupling,
        [a, c, q, r]: [&dyn MatrixInput; 4],
    ) -> Result<Self, Error> {
        let (a, c, q, r) = (owned(a), owned(c), owned(q), owned(r));
        let n = a.nrows();
        let (m, c_shape) = match coupling {
            Coupling::Measurement => (c.nrows(), (c.nrows(), n)),
            Coupling::Input => (c.ncols(), (n, c.ncols())),
        };
        check(names[0], a.as_ref(), n, n)?;
        check(names[1], c.as_ref(), c_shape.0, c_shape.1)?;
        check(names[2], q.as_ref(), n, n)?;
        check(names[3], r.as_ref(), m, m)?;
        Ok(Self {
            a,
            c,
            q,
            r,
            cross: None,
        })
    }

    /// Adds the cross term (n×m) after checking it under `name`.
    pub(crate) fn with_cross(
        mut self,
        name: &'static str,
        s: &dyn MatrixInput,
    ) -> Result<Self, Error> {
        let s = owned(s);
        check(name, s.as_ref(), self.a.nrows(), self.r.nrows())?;
        self.cross = Some(s);
        Ok(self)
    }

    /// Views of (a, c, q, r) and of the cross term.
    pub(crate) fn views(&self) -> ([MatRef<'_, f64>; 4], Option<MatRef<'_, f64>>) {
        let [a, c, q, r] = [&self.a, &self.c, &self.q, &self.r].map(Mat::as_ref);
        ([a, c, q, r], self.cross.as_ref().map(Mat::as_ref))
    }

    /// The n×n candidate solution `x` of this problem, copied and checked under `name`.
    pub(crate) fn candidate(
        &self,
        name: &'static str,
        x: &dyn MatrixInput,
    ) -> Result<Mat<f64>, Error> {
        let x = owned(x);
        let n = self.a.nrows();
        check(name, x.as_ref(), n, n)?;
        Ok(x)
    }
}
