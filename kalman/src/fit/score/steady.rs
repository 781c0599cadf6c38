//! The score recursion's data stage on a reused covariance stage.
//!
//! Once the covariance recursion stands still (see [`super::score`]), every fully observed
//! step has the same Σ, gain and derivative matrices, so their products can be formed once:
//! the state derivative's recursion `∂x' = F ∂x + ∂F x + ∂B u + ∂M α + G (∂e − ∂Σ α)` with
//! `∂e = −H ∂x − ∂H x` becomes `∂x' = A ∂x + C x + ∂B u + K α` with `A = F − G H`,
//! `C = ∂F − G ∂H` and `K = ∂M − G ∂Σ`. The `∂x` of the parameters are kept side by side
//! (n × k) while the stage is reused and handed back when it ends; the gradient's constant
//! term `tr(Σ⁻¹ ∂Σ)` is added once per run of reused steps.
#![allow(non_snake_case)]

use super::{Flat, FlatDeriv, Observation, Work, gemm};
use crate::fit::LN_2PI;

/// The reused stage's matrices and the parameters' `∂x`, side by side.
pub(super) struct Steady {
    n: usize,
    m: usize,
    k: usize,
    active: bool,
    /// Reused steps since [`Steady::enter`] (each owes the gradient its `tr` term).
    steps: usize,
    /// `F − G H`, n×n.
    A: Vec<f64>,
    /// The reciprocals of the diagonal of Σ's factor (the solves multiply).
    recip: Vec<f64>,
    /// Per parameter i, block i: `C = ∂F − G ∂H` (n×n), `K = ∂M − G ∂Σ` (n×m), `∂Σ` (m×m)
    /// and `∂H` (m×n); `has_c`/`has_dh` false where C or ∂H is zero.
    C: Vec<f64>,
    has_c: Vec<bool>,
    K: Vec<f64>,
    S: Vec<f64>,
    dH: Vec<f64>,
    has_dh: Vec<bool>,
    /// `tr(Σ⁻¹ ∂Σ)` per parameter.
    tr: Vec<f64>,
    /// The parameters' `∂x` now and next, n×k (column i is parameter i's).
    dx: Vec<f64>,
    dxn: Vec<f64>,
    // scratch
    e: Vec<f64>,
    alpha: Vec<f64>,
}

impl Steady {
    pub(super) fn new(n: usize, m: usize, k: usize) -> Self {
        Self {
            n,
            m,
            k,
            active: false,
            steps: 0,
            A: vec![0.0; n * n],
            recip: vec![0.0; m],
            C: vec![0.0; k * n * n],
            has_c: vec![false; k],
            K: vec![0.0; k * n * m],
            S: vec![0.0; k * m * m],
            dH: vec![0.0; k * m * n],
            has_dh: vec![false; k],
            tr: vec![0.0; k],
            dx: vec![0.0; n * k],
            dxn: vec![0.0; n * k],
            e: vec![0.0; m],
            alpha: vec![0.0; m],
        }
    }

    /// Whether the stage is in use (between [`Steady::enter`] and [`Steady::leave`]).
    pub(super) fn active(&self) -> bool {
        self.active
    }

    /// Forms the matrices from the last covariance stage of `w` (every row observed, so
    /// `Ho = H`) and takes over the parameters' `∂x`.
    pub(super) fn enter(&mut self, w: &Work, s: &Flat, d: &[FlatDeriv]) {
        let (n, m) = (self.n, self.m);
        let G = &w.G[..n * m];
        self.A.copy_from_slice(&s.F);
        gemm(&mut self.A, n, n, m, -1.0, G, n, false, &s.H, m, false, 1.0);
        for (i, r) in self.recip.iter_mut().enumerate() {
            *r = 1.0 / w.L[i + i * m];
        }
        for (i, (p, di)) in w.par.iter().zip(d).enumerate() {
            let dsig = &p.dsig[..m * m];
            let K = &mut self.K[i * n * m..(i + 1) * n * m];
            K.copy_from_slice(&p.dM[..n * m]);
            gemm(K, n, m, m, -1.0, G, n, false, dsig, m, false, 1.0);
            let C = &mut self.C[i * n * n..(i + 1) * n * n];
            match &di.F {
                Some(df) => C.copy_from_slice(df),
                None => C.fill(0.0),
            }
            let dH = &mut self.dH[i * m * n..(i + 1) * m * n];
            match &di.H {
                Some(dh) => {
                    gemm(C, n, n, m, -1.0, G, n, false, dh, m, false, 1.0);
                    dH.copy_from_slice(dh);
                }
                None => dH.fill(0.0),
            }
            self.has_c[i] = di.F.is_some() || di.H.is_some();
            self.has_dh[i] = di.H.is_some();
            self.S[i * m * m..(i + 1) * m * m].copy_from_slice(dsig);
            self.tr[i] = p.tr;
            self.dx[i * n..(i + 1) * n].copy_from_slice(&p.dx);
        }
        self.steps = 0;
        self.active = true;
    }

    /// Hands the parameters' `∂x` back to `w` and adds the reused steps' `tr` terms to
    /// `grad`.
    pub(super) fn leave(&mut self, w: &mut Work, grad: &mut [f64]) {
        let n = self.n;
        for (i, (p, g)) in w.par.iter_mut().zip(grad.iter_mut()).enumerate() {
            p.dx.copy_from_slice(&self.dx[i * n..(i + 1) * n]);
            *g -= 0.5 * self.tr[i] * self.steps as f64;
        }
        self.active = false;
    }

    /// One fully observed step: the step's log-likelihood term (returned), the gradient's
    /// data terms (added to `grad`), `w.xn` and the next `∂x`. Dispatches to
    /// [`Steady::step_in`] with the state and measurement dimensions as constants for the
    /// small models most fits have (the loops unroll), else as run-time values.
    pub(super) fn step(&mut self, w: &mut Work, at: &Observation<'_>, grad: &mut [f64]) -> f64 {
        let a = Step { w, at: *at, grad };
        match (self.n, self.m) {
            (1, 1) => self.step_in(Fixed::<1>, Fixed::<1>, a),
            (2, 1) => self.step_in(Fixed::<2>, Fixed::<1>, a),
            (3, 1) => self.step_in(Fixed::<3>, Fixed::<1>, a),
            (4, 1) => self.step_in(Fixed::<4>, Fixed::<1>, a),
            (2, 2) => self.step_in(Fixed::<2>, Fixed::<2>, a),
            (3, 2) => self.step_in(Fixed::<3>, Fixed::<2>, a),
            (4, 2) => self.step_in(Fixed::<4>, Fixed::<2>, a),
            (n, m) => self.step_in(Runtime(n), Runtime(m), a),
        }
    }

    /// [`Steady::step`] with the state dimension `n` and the measurement dimension `m`.
    #[inline(always)]
    fn step_in(&mut self, n: impl Size, m: impl Size, a: Step<'_>) -> f64 {
        let Step { w, at, grad } = a;
        let Observation { s, d, z, u } = at;
        let (n, m, k) = (n.get(), m.get(), self.k);
        let (F, H, L, x) = (&s.F[..n * n], &s.H[..m * n], &w.L[..m * m], &w.x[..n]);
        // x' = F x + B u (+ G e below)
        for (r, xn) in w.xn[..n].iter_mut().enumerate() {
            *xn = (0..n).map(|c| F[r + c * n] * x[c]).sum();
        }
        if !u.is_empty() {
            gemm(
                &mut w.xn, n, 1, s.p, 1.0, &s.B, n, false, u, s.p, false, 1.0,
            );
        }
        let (e, alpha) = (&mut self.e[..m], &mut self.alpha[..m]);
        for r in 0..m {
            e[r] = z[r] - (0..n).map(|c| H[r + c * m] * x[c]).sum::<f64>();
        }
        // α = Σ⁻¹ e by the two triangular solves with Σ's factor
        let recip = &self.recip[..m];
        for i in 0..m {
            let v: f64 = e[i] - (0..i).map(|j| L[i + j * m] * alpha[j]).sum::<f64>();
            alpha[i] = v * recip[i];
        }
        for i in (0..m).rev() {
            let v: f64 = alpha[i] - (i + 1..m).map(|j| L[j + i * m] * alpha[j]).sum::<f64>();
            alpha[i] = v * recip[i];
        }
        let quad: f64 = (0..m).map(|r| e[r] * alpha[r]).sum();
        let term = -0.5 * (quad + w.logdet + m as f64 * LN_2PI);
        let (A, alpha) = (&self.A[..n * n], &self.alpha[..m]);
        for i in 0..k {
            let dx = &self.dx[i * n..(i + 1) * n];
            let S = &self.S[i * m * m..(i + 1) * m * m];
            // α·∂Σα and α·∂e with ∂e = −H ∂x − ∂H x (tr added on leaving)
            let mut a_ds_a = 0.0;
            let mut a_de = 0.0;
            for r in 0..m {
                let dsa: f64 = (0..m).map(|c| S[r + c * m] * alpha[c]).sum();
                let mut de = -(0..n).map(|c| H[r + c * m] * dx[c]).sum::<f64>();
                if self.has_dh[i] {
                    let dH = &self.dH[i * m * n..(i + 1) * m * n];
                    de -= (0..n).map(|c| dH[r + c * m] * x[c]).sum::<f64>();
                }
                a_ds_a += alpha[r] * dsa;
                a_de += alpha[r] * de;
            }
            grad[i] -= 0.5 * (2.0 * a_de - a_ds_a);
            // ∂x' = A ∂x + C x + K α (+ ∂B u)
            let K = &self.K[i * n * m..(i + 1) * n * m];
            let C = &self.C[i * n * n..(i + 1) * n * n];
            let dxn = &mut self.dxn[i * n..(i + 1) * n];
            for r in 0..n {
                let mut v: f64 = (0..n).map(|c| A[r + c * n] * dx[c]).sum();
                if self.has_c[i] {
                    v += (0..n).map(|c| C[r + c * n] * x[c]).sum::<f64>();
                }
                v += (0..m).map(|c| K[r + c * n] * alpha[c]).sum::<f64>();
                dxn[r] = v;
            }
            if let Some(db) = &d[i].B
                && !u.is_empty()
            {
                gemm(dxn, n, 1, s.p, 1.0, db, n, false, u, s.p, false, 1.0);
            }
        }
        std::mem::swap(&mut self.dx, &mut self.dxn);
        self.steps += 1;
        let (G, e) = (&w.G[..n * m], &self.e[..m]);
        for (r, xn) in w.xn[..n].iter_mut().enumerate() {
            *xn += (0..m).map(|c| G[r + c * n] * e[c]).sum::<f64>();
        }
        term
    }
}

/// The arguments of one step of [`Steady::step`].
struct Step<'a> {
    w: &'a mut Work,
    at: Observation<'a>,
    grad: &'a mut [f64],
}

/// A matrix dimension known at compile time ([`Fixed`]) or only at run time ([`Runtime`]):
/// one step's code serves both, and the fixed sizes let the compiler unroll its loops.
trait Size: Copy {
    fn get(self) -> usize;
}

#[derive(Clone, Copy)]
struct Fixed<const N: usize>;

impl<const N: usize> Size for Fixed<N> {
    #[inline(always)]
    fn get(self) -> usize {
        N
    }
}

#[derive(Clone, Copy)]
struct Runtime(usize);

impl Size for Runtime {
    #[inline(always)]
    fn get(self) -> usize {
        self.0
    }
}
