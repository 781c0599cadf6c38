//! The sigma-point stages the plain and the square-root unscented filters share: the
//! points' images under h and f, their weighted means through the model's residual and
//! state addition, and the deviations both covariance forms are built from.

use super::linalg::{mul, rank1};
use super::sigma::{SigmaPoints, SigmaSet};
use super::{NlDims, NonlinearModel, compact_vec, finite};
use crate::Error;
use crate::storage::Buf;

/// A sigma-point set with the workspaces of its points: `chi` (stored × s: points of a
/// state on a manifold are stored points, see [`crate::Dims::stored`]), their images under f
/// (`y`, stored × s) and h (`zs`, m × s), the deviations from the means (`dchi`, `dy`, `dz`), `ẑ` and an
/// m-vector of scratch. The deviations `dchi` and `dy` of the last prediction are kept until
/// the next one for [`Unscented::cross_covariance`].
#[derive(Clone, Debug)]
pub(super) struct Unscented<D: NlDims> {
    pub(super) set: SigmaSet<D>,
    pub(super) chi: D::SSig,
    y: D::SSig,
    pub(super) dchi: D::Sig,
    pub(super) dy: D::Sig,
    zs: D::ZSig,
    pub(super) dz: D::ZSig,
    zbar: D::Mv,
    col: D::Mv,
}

impl<D: NlDims> Unscented<D> {
    /// The set `points` for n (tangent) states stored in `ns` numbers and m measurements,
    /// with its workspaces.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] from [`SigmaPoints::weights`].
    pub(super) fn new(points: SigmaPoints, n: usize, m: usize, ns: usize) -> Result<Self, Error> {
        let set = SigmaSet::new(points, n)?;
        let s = set.count;
        Ok(Self {
            set,
            chi: D::SSig::zeros(ns * s),
            y: D::SSig::zeros(ns * s),
            dchi: D::Sig::zeros(n * s),
            dy: D::Sig::zeros(n * s),
            zs: D::ZSig::zeros(m * s),
            dz: D::ZSig::zeros(m * s),
            zbar: D::Mv::zeros(m),
            col: D::Mv::zeros(m),
        })
    }

    /// The points `χ_i = x ⊕ L ξ_i` into `chi` (`x` stored in `x.len()` numbers, `L` lower
    /// n×n; `dx` an n-vector workspace).
    #[inline(always)]
    pub(super) fn draw<M: NonlinearModel + ?Sized>(
        &mut self,
        model: &M,
        x: &[f64],
        L: &[f64],
        n: usize,
        dx: &mut [f64],
    ) {
        let chi = &mut self.chi.as_mut_slice()[..x.len() * self.set.count];
        self.set.draw(model, x, L, n, dx, chi);
    }

    /// `Z_i = h(χ_i)` (checked finite; `n` is the points' stored length), `ẑ = Z_0 + Σ_{i≥1} Wm_i (Z_i ⊖ Z_0)` and the
    /// deviations `dz_i = Z_i ⊖ ẑ` on the `mo` observed rows of z (mo × s). Centring the
    /// mean on `Z_0` leaves no cancellation between a large negative `Wm_0` and the other
    /// weights, and averages wrapped components around `Z_0`.
    #[inline(always)]
    pub(super) fn measure<M: NonlinearModel + ?Sized>(
        &mut self,
        model: &mut M,
        z: &[f64],
        n: usize,
        m: usize,
        mo: usize,
        k: usize,
    ) -> Result<(), Error> {
        let s = self.set.count;
        let wm = &self.set.wm.as_slice()[..s];
        let chi = &self.chi.as_slice()[..n * s];
        let zs = &mut self.zs.as_mut_slice()[..m * s];
        for i in 0..s {
            let zi = &mut zs[i * m..(i + 1) * m];
            model.h(&chi[i * n..(i + 1) * n], k, zi);
            finite("h", k, zi)?;
        }
        // The Z_i ⊖ Z_0 go to the deviations' workspace first (all of them before the sum
        // reads them back), which the deviations from ẑ overwrite below.
        let zbar = &mut self.zbar.as_mut_slice()[..m];
        let col = &mut self.col.as_mut_slice()[..m];
        let d0 = &mut self.dz.as_mut_slice()[..m * s];
        for i in 1..s {
            model.residual(
                &zs[i * m..(i + 1) * m],
                &zs[..m],
                &mut d0[i * m..(i + 1) * m],
            );
        }
        mul(zbar, &d0[m..], &wm[1..], m, s - 1, 1, false);
        for (a, b) in zbar.iter_mut().zip(&zs[..m]) {
            *a += b;
        }
        // With every row observed (mo = m: no NaN in z) the compaction is a copy: the
        // residuals go straight to their places.
        let all = mo == m;
        let dz = &mut self.dz.as_mut_slice()[..mo * s];
        for i in 0..s {
            let zi = &zs[i * m..(i + 1) * m];
            let di = &mut dz[i * mo..(i + 1) * mo];
            if all {
                model.residual(zi, zbar, di);
            } else {
                model.residual(zi, zbar, col);
                compact_vec(col, z, di);
            }
        }
        Ok(())
    }

    /// The innovation `z ⊖ ẑ` on the `mo` observed rows of z into `e` (after
    /// [`Unscented::measure`]).
    #[inline(always)]
    pub(super) fn innovation<M: NonlinearModel + ?Sized>(
        &mut self,
        model: &M,
        z: &[f64],
        m: usize,
        mo: usize,
        e: &mut [f64],
    ) {
        let zbar = &self.zbar.as_slice()[..m];
        if mo == m {
            model.residual(z, zbar, e);
        } else {
            let col = &mut self.col.as_mut_slice()[..m];
            model.residual(z, zbar, col);
            compact_vec(col, z, e);
        }
    }

    /// `y_i = f(χ_i)` (checked finite) of the points of `(x_{k|k}, ·)` drawn into `chi`,
    /// `x⁺ = y_0 ⊕ Σ_{i≥1} Wm_i (y_i ⊖ y_0)` into `xp` (centred on `y_0` as ẑ in
    /// [`Unscented::measure`]), and the deviations `dy_i = y_i ⊖ x⁺`,
    /// `dchi_i = χ_i ⊖ x_{k|k}` (`xf`), for n tangent dimensions stored in `ns` numbers.
    /// `dx` is an n-vector workspace. On a manifold the mean is one Gauss–Newton step of
    /// the weighted (Karcher) mean from `y_0`, exact for a vector state.
    #[inline(always)]
    pub(super) fn propagate<M: NonlinearModel + ?Sized>(
        &mut self,
        model: &mut M,
        u: Option<&[f64]>,
        (n, ns): (usize, usize),
        k: usize,
        xf: &[f64],
        xp: &mut [f64],
        dx: &mut [f64],
    ) -> Result<(), Error> {
        let s = self.set.count;
        let wm = &self.set.wm.as_slice()[..s];
        let chi = &self.chi.as_slice()[..ns * s];
        let y = &mut self.y.as_mut_slice()[..ns * s];
        for i in 0..s {
            let yi = &mut y[i * ns..(i + 1) * ns];
            model.f(&chi[i * ns..(i + 1) * ns], u, k, yi);
            finite("f", k, yi)?;
        }
        let dy = &mut self.dy.as_mut_slice()[..n * s];
        let dx = &mut dx[..n];
        for i in 1..s {
            model.state_residual(
                &y[i * ns..(i + 1) * ns],
                &y[..ns],
                &mut dy[i * n..(i + 1) * n],
            );
        }
        mul(dx, &dy[n..], &wm[1..], n, s - 1, 1, false);
        let xp = &mut xp[..ns];
        model.state_add(&y[..ns], dx, xp);
        let dchi = &mut self.dchi.as_mut_slice()[..n * s];
        for i in 0..s {
            model.state_residual(&y[i * ns..(i + 1) * ns], xp, &mut dy[i * n..(i + 1) * n]);
            model.state_residual(
                &chi[i * ns..(i + 1) * ns],
                xf,
                &mut dchi[i * n..(i + 1) * n],
            );
        }
        Ok(())
    }

    /// `C_k = Σ Wc_i dchi_i dy_iᵀ` (n×n) of the last [`Unscented::propagate`] into `out`.
    pub(super) fn cross_covariance(&self, n: usize, out: &mut [f64]) {
        let s = self.set.count;
        let (wc, dchi, dy) = (
            &self.set.wc.as_slice()[..s],
            &self.dchi.as_slice()[..n * s],
            &self.dy.as_slice()[..n * s],
        );
        let out = &mut out[..n * n];
        out.fill(0.0);
        for i in 0..s {
            rank1(
                out,
                wc[i],
                &dchi[i * n..(i + 1) * n],
                &dy[i * n..(i + 1) * n],
                n,
                n,
            );
        }
    }
}
