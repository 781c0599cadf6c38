//! Shumway–Stoffer EM for the standard parameterisation: E-step by the Kalman filter and
//! the RTS smoother with lag-one cross-covariances, M-step in closed form under the
//! `Scalar`/`Diag`/`Full`/`Fixed` constraints.

use faer::Mat;

use super::dense::{gemm, lower_factor, solve_each_column, symmetrise};
use super::info::{Fit, Method, finish};
use super::score::Flat;
use super::score::log_likelihood_gradient;
use super::{FitError, LN_2PI, ParamMap, Series, StandardMap, Structure};

/// Options of [`em`].
///
/// # Example
/// ```
/// use kalman::CovarianceForm;
/// use kalman::fit::{EmOptions, Free, Series, StandardMap, Structure, System, em, log_likelihood};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // A local level: learn the scalar Q and R from ten samples.
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[10.0]])?;
/// let free = Free { q: Structure::Scalar, r: Structure::Scalar, ..Free::default() };
/// let map = StandardMap::new(base.clone(), free)?;
/// let z = [0.3, 1.1, 0.8, 1.9, 2.4, 2.2, 3.1, 3.9, 3.5, 4.2];
/// let data = Series::new(&z, 1)?;
/// let fit = em(&map, &data, &EmOptions { tol: 1e-9, max_iter: 2000, ..EmOptions::default() })?;
/// // EM never lowers the likelihood: the optimum is at least as likely as the start.
/// assert!(fit.loglik >= log_likelihood(&base, &data, CovarianceForm::Joseph)? - 1e-9);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmOptions {
    /// Stop when an iteration raises the log-likelihood by less than `tol·(1 + |ln L|)`.
    pub tol: f64,
    /// Iteration cap (the fit is flagged unconverged when it is reached).
    pub max_iter: usize,
    /// Called before every iteration; `true` stops the fit with [`FitError::Interrupted`]
    /// (a user's Ctrl-C, a deadline). `None` never stops it.
    pub interrupt: Option<super::Interrupt>,
}

impl Default for EmOptions {
    fn default() -> Self {
        Self {
            tol: 1e-10,
            max_iter: 10_000,
            interrupt: None,
        }
    }
}

/// Sums of one E-step: the M-step's expected sufficient statistics.
pub(crate) struct EStep {
    /// Log-likelihood at the current parameters.
    pub ll: f64,
    /// `Σ_k E[w_k w_kᵀ | Z]` over the N−1 transitions (n×n).
    pub sq: Vec<f64>,
    /// `Σ_k E[v_k v_kᵀ | Z]` over the N steps (m×m).
    pub sr: Vec<f64>,
    /// Smoothed `x_{0|N−1}` and `P_{0|N−1}`.
    pub x0: Vec<f64>,
    pub P0: Vec<f64>,
}

/// One E-step: forward filter (storing priors and posteriors), RTS backward pass with
/// `C_{k+1,k} = P_{k+1|N} J_kᵀ` (de Jong), and the expected sufficient statistics.
#[allow(clippy::too_many_lines)]
pub(crate) fn e_step(s: &Flat, data: &Series<'_>) -> Result<EStep, FitError> {
    let (n, m, N) = (s.n, s.m, data.len());
    let nn = n * n;
    let mut xp = vec![0.0; N * n];
    let mut Pp = vec![0.0; N * nn];
    let mut xf = vec![0.0; N * n];
    let mut Pf = vec![0.0; N * nn];
    xp[..n].copy_from_slice(&s.x0);
    Pp[..nn].copy_from_slice(&s.P0);
    symmetrise(&mut Pp[..nn], n);
    let mut obs = Vec::with_capacity(m);
    let mut Ho = vec![0.0; m * n];
    let mut e = vec![0.0; m];
    let mut L = vec![0.0; m * m];
    let mut PHt = vec![0.0; n * m];
    let mut Kt = vec![0.0; m * n];
    let mut tn = vec![0.0; nn];
    let mut ll = 0.0;
    for k in 0..N {
        let z = data.z(k);
        obs.clear();
        obs.extend((0..m).filter(|&i| !z[i].is_nan()));
        let mo = obs.len();
        let (x, P) = (&xp[k * n..(k + 1) * n], &Pp[k * nn..(k + 1) * nn]);
        let mut xk = x.to_vec();
        let mut Pk = P.to_vec();
        if mo > 0 {
            for (r, &i) in obs.iter().enumerate() {
                for c in 0..n {
                    Ho[r + c * mo] = s.H[i + c * m];
                }
                e[r] = z[i] - (0..n).map(|c| s.H[i + c * m] * x[c]).sum::<f64>();
            }
            gemm(
                &mut PHt[..n * mo],
                n,
                mo,
                n,
                1.0,
                P,
                n,
                false,
                &Ho[..mo * n],
                mo,
                true,
                0.0,
            );
            gemm(
                &mut L[..mo * mo],
                mo,
                mo,
                n,
                1.0,
                &Ho[..mo * n],
                mo,
                false,
                &PHt[..n * mo],
                n,
                false,
                0.0,
            );
            for (c, &j) in obs.iter().enumerate() {
                for (r, &i) in obs.iter().enumerate() {
                    L[r + c * mo] += s.R[i + j * m];
                }
            }
            symmetrise(&mut L[..mo * mo], mo);
            if !lower_factor(&mut L[..mo * mo], mo) {
                return Err(FitError::NotPositiveDefinite {
                    name: "innovation covariance",
                    step: k,
                });
            }
            let logdet: f64 = (0..mo).map(|i| 2.0 * L[i + i * mo].ln()).sum();
            // Kᵀ = Σ⁻¹ Ho P
            for r in 0..mo {
                for c in 0..n {
                    Kt[r + c * mo] = PHt[c + r * n];
                }
            }
            solve_each_column(&L[..mo * mo], mo, &mut Kt[..mo * n], n);
            let mut a = e[..mo].to_vec();
            solve_each_column(&L[..mo * mo], mo, &mut a, 1);
            ll -= 0.5 * ((0..mo).map(|i| e[i] * a[i]).sum::<f64>() + logdet + mo as f64 * LN_2PI);
            gemm(
                &mut xk,
                n,
                1,
                mo,
                1.0,
                &Kt[..mo * n],
                mo,
                true,
                &e[..mo],
                mo,
                false,
                1.0,
            );
            gemm(
                &mut Pk,
                n,
                n,
                mo,
                -1.0,
                &PHt[..n * mo],
                n,
                false,
                &Kt[..mo * n],
                mo,
                false,
                1.0,
            );
            symmetrise(&mut Pk, n);
        }
        xf[k * n..(k + 1) * n].copy_from_slice(&xk);
        Pf[k * nn..(k + 1) * nn].copy_from_slice(&Pk);
        if k + 1 < N {
            let (xn, Pn) = (
                &mut xp[(k + 1) * n..(k + 2) * n],
                &mut Pp[(k + 1) * nn..(k + 2) * nn],
            );
            s.predict_mean(xn, &xk, data.u(k));
            gemm(&mut tn, n, n, n, 1.0, &s.F, n, false, &Pk, n, false, 0.0);
            gemm(Pn, n, n, n, 1.0, &tn, n, false, &s.F, n, true, 0.0);
            for (a, q) in Pn.iter_mut().zip(&s.Q) {
                *a += q;
            }
            symmetrise(Pn, n);
        }
    }
    // Backward pass.
    let mut xs = xf[(N - 1) * n..].to_vec();
    let mut Ps = Pf[(N - 1) * nn..].to_vec();
    let mut sq = vec![0.0; nn];
    let mut sr = vec![0.0; m * m];
    let mut Jt = vec![0.0; nn];
    let mut Lp = vec![0.0; nn];
    let mut C = vec![0.0; nn];
    let mut FC = vec![0.0; nn];
    let mut w = vec![0.0; n];
    let mut xs_prev = vec![0.0; n];
    let mut Ps_prev = vec![0.0; nn];
    let mut dP = vec![0.0; nn];
    let mut tmp = vec![0.0; nn];
    add_r_term(s, data, N - 1, &xs, &Ps, &mut sr)?;
    for k in (0..N.saturating_sub(1)).rev() {
        let (xfk, Pfk) = (&xf[k * n..(k + 1) * n], &Pf[k * nn..(k + 1) * nn]);
        let (xpk, Ppk) = (
            &xp[(k + 1) * n..(k + 2) * n],
            &Pp[(k + 1) * nn..(k + 2) * nn],
        );
        // Jᵀ = P_{k+1|k}⁻¹ F P_{k|k}
        Lp.copy_from_slice(Ppk);
        if !lower_factor(&mut Lp, n) {
            return Err(FitError::NotPositiveDefinite {
                name: "predicted covariance",
                step: k + 1,
            });
        }
        gemm(&mut Jt, n, n, n, 1.0, &s.F, n, false, Pfk, n, false, 0.0);
        solve_each_column(&Lp, n, &mut Jt, n);
        // C_{k+1,k} = P_{k+1|N} Jᵀ
        gemm(&mut C, n, n, n, 1.0, &Ps, n, false, &Jt, n, false, 0.0);
        // x_{k|N} = x_{k|k} + J (x_{k+1|N} − x_{k+1|k}); P_{k|N} = P_{k|k} + J (P_{k+1|N} − P_{k+1|k}) Jᵀ
        for i in 0..n {
            w[i] = xs[i] - xpk[i];
        }
        xs_prev.copy_from_slice(xfk);
        gemm(&mut xs_prev, n, 1, n, 1.0, &Jt, n, true, &w, n, false, 1.0);
        for i in 0..nn {
            dP[i] = Ps[i] - Ppk[i];
        }
        gemm(&mut tmp, n, n, n, 1.0, &Jt, n, true, &dP, n, false, 0.0);
        Ps_prev.copy_from_slice(Pfk);
        gemm(
            &mut Ps_prev,
            n,
            n,
            n,
            1.0,
            &tmp,
            n,
            false,
            &Jt,
            n,
            false,
            1.0,
        );
        symmetrise(&mut Ps_prev, n);
        // E[w wᵀ] with w = x_{k+1} − F x_k − B u_k:
        // r rᵀ + P_{k+1|N} − F Cᵀ − C Fᵀ + F P_{k|N} Fᵀ, r the smoothed residual.
        s.predict_mean(&mut w, &xs_prev, data.u(k));
        for i in 0..n {
            w[i] = xs[i] - w[i];
        }
        gemm(&mut sq, n, n, 1, 1.0, &w, n, false, &w, n, true, 1.0);
        for i in 0..nn {
            sq[i] += Ps[i];
        }
        gemm(&mut FC, n, n, n, 1.0, &s.F, n, false, &C, n, true, 0.0);
        for r in 0..n {
            for c in 0..n {
                sq[r + c * n] -= FC[r + c * n] + FC[c + r * n];
            }
        }
        gemm(
            &mut tmp, n, n, n, 1.0, &s.F, n, false, &Ps_prev, n, false, 0.0,
        );
        gemm(&mut sq, n, n, n, 1.0, &tmp, n, false, &s.F, n, true, 1.0);
        std::mem::swap(&mut xs, &mut xs_prev);
        std::mem::swap(&mut Ps, &mut Ps_prev);
        add_r_term(s, data, k, &xs, &Ps, &mut sr)?;
    }
    symmetrise(&mut sq, n);
    symmetrise(&mut sr, m);
    Ok(EStep {
        ll,
        sq,
        sr,
        x0: xs,
        P0: Ps,
    })
}

/// Adds `E[v_k v_kᵀ | Z]` to `sr`: on the observed rows O, `A = r rᵀ + H_O P H_Oᵀ` with
/// `r = z_O − H_O x_{k|N}`; the missing rows U are `N(G v_O, R_UU − G R_OU)` given `v_O`
/// with `G = R_UO R_OO⁻¹`, so `E[v_U v_Oᵀ] = G A` and `E[v_U v_Uᵀ] = G A Gᵀ + R_UU − G R_OU`.
fn add_r_term(
    s: &Flat,
    data: &Series<'_>,
    k: usize,
    x: &[f64],
    P: &[f64],
    sr: &mut [f64],
) -> Result<(), FitError> {
    let (n, m) = (s.n, s.m);
    let z = data.z(k);
    let o: Vec<usize> = (0..m).filter(|&i| !z[i].is_nan()).collect();
    let u: Vec<usize> = (0..m).filter(|&i| z[i].is_nan()).collect();
    let (mo, mu) = (o.len(), u.len());
    let mut a = vec![0.0; mo * mo];
    let mut r = vec![0.0; mo];
    let mut Ho = vec![0.0; mo * n];
    for (ri, &i) in o.iter().enumerate() {
        for c in 0..n {
            Ho[ri + c * mo] = s.H[i + c * m];
        }
        r[ri] = z[i] - (0..n).map(|c| s.H[i + c * m] * x[c]).sum::<f64>();
    }
    let mut t = vec![0.0; n * mo];
    gemm(&mut t, n, mo, n, 1.0, P, n, false, &Ho, mo, true, 0.0);
    gemm(&mut a, mo, mo, n, 1.0, &Ho, mo, false, &t, n, false, 0.0);
    gemm(&mut a, mo, mo, 1, 1.0, &r, mo, false, &r, mo, true, 1.0);
    for (c, &j) in o.iter().enumerate() {
        for (ri, &i) in o.iter().enumerate() {
            sr[i + j * m] += a[ri + c * mo];
        }
    }
    if mu == 0 {
        return Ok(());
    }
    let r_at = |i: usize, j: usize| s.R[i + j * m];
    // Gᵀ = R_OO⁻¹ R_OU (mo×mu)
    let mut Gt = vec![0.0; mo * mu];
    if mo > 0 {
        let mut Loo = vec![0.0; mo * mo];
        for (c, &j) in o.iter().enumerate() {
            for (ri, &i) in o.iter().enumerate() {
                Loo[ri + c * mo] = r_at(i, j);
            }
        }
        if !lower_factor(&mut Loo, mo) {
            return Err(FitError::NotPositiveDefinite {
                name: "observed block of R",
                step: k,
            });
        }
        for (c, &j) in u.iter().enumerate() {
            for (ri, &i) in o.iter().enumerate() {
                Gt[ri + c * mo] = r_at(i, j);
            }
        }
        solve_each_column(&Loo, mo, &mut Gt, mu);
    }
    // E[v_U v_Oᵀ] = G A (mu×mo)
    let mut GA = vec![0.0; mu * mo];
    gemm(&mut GA, mu, mo, mo, 1.0, &Gt, mo, true, &a, mo, false, 0.0);
    for (c, &j) in o.iter().enumerate() {
        for (ri, &i) in u.iter().enumerate() {
            sr[i + j * m] += GA[ri + c * mu];
            sr[j + i * m] += GA[ri + c * mu];
        }
    }
    // E[v_U v_Uᵀ] = G A Gᵀ + R_UU − G R_OU
    let mut uu = vec![0.0; mu * mu];
    gemm(
        &mut uu, mu, mu, mo, 1.0, &GA, mu, false, &Gt, mo, false, 0.0,
    );
    for (c, &j) in u.iter().enumerate() {
        for (ri, &i) in u.iter().enumerate() {
            let gr: f64 = o
                .iter()
                .enumerate()
                .map(|(l, &ol)| Gt[l + ri * mo] * r_at(ol, j))
                .sum();
            sr[i + j * m] += uu[ri + c * mu] + r_at(i, j) - gr;
        }
    }
    Ok(())
}

/// Checks that each free block of `map` can be identified from `data`: every channel with a
/// free `R` diagonal is observed at least once, every pair with a free `R` covariance is
/// observed together at least once, a free `Q` has a transition, and there are more
/// observed values than parameters. [`em`] runs it first; run it before `mle`.
///
/// # Errors
/// [`FitError::NotIdentifiable`] naming the block and the reason.
pub fn check_identifiable(map: &StandardMap, data: &Series<'_>) -> Result<(), FitError> {
    let m = data.m();
    let free = map.free();
    let observed: Vec<usize> = (0..m)
        .map(|c| (0..data.len()).filter(|&k| !data.z(k)[c].is_nan()).count())
        .collect();
    match free.r {
        Structure::Diag | Structure::Full => {
            if let Some(c) = observed.iter().position(|&v| v == 0) {
                return Err(FitError::NotIdentifiable {
                    what: "R".into(),
                    why: format!(
                        "measurement channel {c} is never observed, so its noise variance is free of the data"
                    ),
                });
            }
            if free.r == Structure::Full {
                for i in 0..m {
                    for j in 0..i {
                        if !(0..data.len())
                            .any(|k| !data.z(k)[i].is_nan() && !data.z(k)[j].is_nan())
                        {
                            return Err(FitError::NotIdentifiable {
                                what: "R".into(),
                                why: format!(
                                    "channels {j} and {i} are never observed together, so their covariance is free of the data"
                                ),
                            });
                        }
                    }
                }
            }
        }
        Structure::Scalar | Structure::Fixed => {}
    }
    if free.q != Structure::Fixed && data.len() < 2 {
        return Err(FitError::NotIdentifiable {
            what: "Q".into(),
            why: "one step has no transition".into(),
        });
    }
    let k = map.n_params();
    if data.observed() <= k {
        return Err(FitError::NotIdentifiable {
            what: "the free parameters".into(),
            why: format!("{k} parameters from {} observed values", data.observed()),
        });
    }
    Ok(())
}

fn to_mat(v: &[f64], n: usize) -> Mat<f64> {
    Mat::from_fn(n, n, |i, j| v[i + j * n])
}

/// Shumway–Stoffer EM for a [`StandardMap`]: each iteration runs the filter and the RTS
/// smoother at the current parameters and replaces the free blocks by their closed-form
/// maximisers — `Q = (1/(N−1)) Σ E[w wᵀ]`, `R = (1/N) Σ E[v vᵀ]` (full), their diagonal
/// (`Diag`) or mean diagonal times I (`Scalar`), `x0 = x_{0|N−1}`, `P0` the diagonal of
/// `E[(x_0 − x0)(x_0 − x0)ᵀ]`. The log-likelihood never decreases; the iteration stops
/// when an increase falls below [`EmOptions::tol`] or at [`EmOptions::max_iter`] (flagged
/// unconverged). The starting point is the base system (non-positive free variances start
/// at a tenth of the data's variance).
///
/// A small increase is not yet an optimum (EM crawls along flat ridges), so the stop is
/// checked with the exact gradient `g` and the observed information `I`: if the Newton
/// decrement `gᵀI⁻¹g` (twice the gain of ln L a Newton step would still make) exceeds
/// [`EM_DECREMENT`], the fit is flagged unconverged, with that gain in the message.
///
/// # Errors
/// [`FitError::NotIdentifiable`] if a free block cannot be learned from the data, or if
/// `x0` is free while `P0` (fixed) has a zero variance: the smoothed `x_{0|N}` EM
/// replaces `x0` with then equals `x0` in that component, so EM could never move it;
/// [`FitError::NotPositiveDefinite`] if a covariance degenerates; model errors.
///
/// # Example
/// See the [module documentation](super).
///
/// # Example
/// ```
/// use kalman::CovarianceForm;
/// use kalman::fit::{EmOptions, Free, Series, StandardMap, Structure, System, em, log_likelihood};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // A local level: learn the scalar Q and R from ten samples.
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[10.0]])?;
/// let free = Free { q: Structure::Scalar, r: Structure::Scalar, ..Free::default() };
/// let map = StandardMap::new(base.clone(), free)?;
/// let z = [0.3, 1.1, 0.8, 1.9, 2.4, 2.2, 3.1, 3.9, 3.5, 4.2];
/// let data = Series::new(&z, 1)?;
/// let fit = em(&map, &data, &EmOptions { tol: 1e-9, max_iter: 2000, ..EmOptions::default() })?;
/// // EM never lowers the likelihood: the optimum is at least as likely as the start.
/// assert!(fit.loglik >= log_likelihood(&base, &data, CovarianceForm::Joseph)? - 1e-9);
/// # Ok(())
/// # }
/// ```
pub fn em(map: &StandardMap, data: &Series<'_>, opts: &EmOptions) -> Result<Fit, FitError> {
    em_with_progress(map, data, opts, &mut |_, _| {})
}

/// [`em`], calling `progress(iteration, ln L)` after every E-step (a long fit can show
/// where it is; the call must be cheap, e.g. print only every few seconds).
///
/// # Errors
/// As [`em`].
///
/// # Example
/// ```
/// use kalman::fit::{EmOptions, Free, Series, StandardMap, Structure, System, em_with_progress};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[10.0]])?;
/// let map = StandardMap::new(base, Free { q: Structure::Scalar, r: Structure::Scalar, ..Free::default() })?;
/// let z = [0.3, 1.1, 0.8, 1.9, 2.4, 2.2, 3.1, 3.9, 3.5, 4.2];
/// let mut seen = Vec::new();
/// let fit = em_with_progress(&map, &Series::new(&z, 1)?, &EmOptions::default(), &mut |k, ll| seen.push((k, ll)))?;
/// assert!(seen.windows(2).all(|w| w[1].1 >= w[0].1 - 1e-9)); // EM never lowers ln L
/// assert_eq!(seen.len(), fit.iterations + 1); // the last E-step is the stop's
/// # Ok(())
/// # }
/// ```
pub fn em_with_progress(
    map: &StandardMap,
    data: &Series<'_>,
    opts: &EmOptions,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<Fit, FitError> {
    data.check(map.base())?;
    super::info::check_prior_scale(map.base(), std::slice::from_ref(data))?;
    check_identifiable(map, data)?;
    let free = map.free();
    if free.x0 && !free.p0_diag {
        let p0 = &map.base().p0;
        let scale = (0..p0.nrows()).fold(0.0_f64, |a, i| a.max(p0[(i, i)].abs()));
        if let Some(i) = (0..p0.nrows()).find(|&i| p0[(i, i)] <= 1e-12 * scale) {
            return Err(FitError::NotIdentifiable {
                what: format!("x0[{i}] by EM"),
                why: format!(
                    "P0[{i},{i}] = {} makes the smoothed first state equal x0[{i}], so EM's update never moves it; free P0:diag too, give P0 a variance, or use the MLE",
                    p0[(i, i)]
                ),
            });
        }
    }
    let mut theta = map.theta_of(map.base(), Some(data));
    map.system(&theta)?.model()?;
    let mut prev = f64::NEG_INFINITY;
    let mut iterations = 0;
    let mut converged = false;
    while iterations < opts.max_iter {
        if opts.interrupt.is_some_and(|stop| stop.fired()) {
            return Err(FitError::Interrupted);
        }
        let (ll, next) = em_step(map, &theta, data)?;
        progress(iterations, ll);
        if ll - prev <= opts.tol * (1.0 + ll.abs()) {
            converged = true;
            break;
        }
        prev = ll;
        iterations += 1;
        theta = next;
    }
    let message = if converged {
        format!(
            "EM converged after {iterations} iterations (log-likelihood increase below {:e} relative)",
            opts.tol
        )
    } else {
        format!(
            "EM stopped at the iteration cap ({}) before the log-likelihood settled; raise the cap, or use the MLE (L-BFGS) method",
            opts.max_iter
        )
    };
    let mut fit = finish(map, theta, data, Method::Em, iterations, converged, message)?;
    if fit.converged
        && let Some(cov) = &fit.uncertainty.covariance
    {
        let (_, g) = log_likelihood_gradient(map, &fit.theta, data)?;
        let k = g.len();
        let dec: f64 = (0..k)
            .map(|i| (0..k).map(|j| g[i] * cov[(i, j)] * g[j]).sum::<f64>())
            .sum();
        if dec > EM_DECREMENT {
            fit.converged = false;
            fit.message = format!(
                "EM not converged: its increase fell below {:e} relative after {iterations} iterations, but the gradient says a Newton step would still raise ln L by about {:.2e}; raise the cap and lower the tolerance, or use the MLE (L-BFGS) method{}",
                opts.tol,
                0.5 * dec,
                fit.message
                    .split_once(';')
                    .map(|(_, rest)| format!(";{rest}"))
                    .unwrap_or_default()
            );
        }
    }
    Ok(fit)
}

/// The largest Newton decrement `gᵀI⁻¹g` at which [`em`] calls a stop converged: a Newton
/// step could still raise ln L by at most half of it, 5e-4 — below the 1e-3 to which the
/// MLE and EM are expected to agree, and far below a standard error's worth (½).
pub const EM_DECREMENT: f64 = 1e-3;

/// One EM iteration at θ: the log-likelihood at θ (from the E-step's filter pass) and the
/// θ of the M-step. Its cost is one filter pass and one RTS smoother pass with the lag-one
/// cross-covariances.
///
/// # Errors
/// As [`em`], without the identifiability check; [`FitError::Unsupported`] for a map with
/// free entry parameters ([`StandardMap::with_params`]), which have no closed-form M-step —
/// except one log-transformed intensity of all of Q (`Q = q·Q₁`, Q₁ positive definite:
/// `q = tr(Q₁⁻¹ S)/(n(N−1))`, e.g. a constant-velocity model's white acceleration).
///
/// # Example
/// ```
/// use kalman::fit::{Free, Series, StandardMap, Structure, System, em_step};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[10.0]])?;
/// let map = StandardMap::new(base.clone(), Free { r: Structure::Scalar, ..Free::default() })?;
/// let z = [0.3, 0.1, 0.9, 1.4, 1.2];
/// let data = Series::new(&z, 1)?;
/// let theta = map.theta_of(&base, None);
/// let (ll0, next) = em_step(&map, &theta, &data)?;
/// let (ll1, _) = em_step(&map, &next, &data)?;
/// assert!(ll1 >= ll0 - 1e-12); // EM never lowers the likelihood
/// # Ok(())
/// # }
/// ```
pub fn em_step(
    map: &StandardMap,
    theta: &[f64],
    data: &Series<'_>,
) -> Result<(f64, Vec<f64>), FitError> {
    let intensity = super::entries::q_intensity(map.params(), map.base());
    if !map.params().is_empty() && intensity.is_none() {
        let names: Vec<&str> = map.params().iter().map(|p| p.name()).collect();
        return Err(FitError::Unsupported(format!(
            "EM's M-step updates Q, R, x0 and P0 as whole blocks (or one intensity of all of Q); the free entries {} need the MLE",
            names.join(", ")
        )));
    }
    let (n, m, N) = (map.base().n(), map.base().m(), data.len());
    let free = map.free();
    let sys = map.system(theta)?;
    data.check(&sys)?;
    let es = e_step(&Flat::new(&sys), data)?;
    let mut next = sys.clone();
    if free.q != Structure::Fixed && N > 1 {
        next.q = to_mat(
            &es.sq.iter().map(|v| v / (N - 1) as f64).collect::<Vec<_>>(),
            n,
        );
    }
    if let Some(q1) = &intensity
        && N > 1
    {
        // Q = q·Q₁: the M-step maximises −½(N−1) ln det(q Q₁) − ½ tr((q Q₁)⁻¹ S) at
        // q = tr(Q₁⁻¹ S) / (n (N−1)), S = Σ E[w wᵀ] (a Q₁ that is not PD has no such step).
        let mut l = super::flat(q1);
        if !lower_factor(&mut l, n) {
            return Err(FitError::Unsupported(
                "EM updates an intensity q of Q = q·Q₁ only for a positive definite Q₁; use the MLE".into(),
            ));
        }
        let mut x = es.sq.clone();
        solve_each_column(&l, n, &mut x, n);
        let q = (0..n).map(|i| x[i + i * n]).sum::<f64>() / (n * (N - 1)) as f64;
        next.q = Mat::from_fn(n, n, |i, j| q * q1[(i, j)]);
    }
    if free.r != Structure::Fixed {
        next.r = to_mat(&es.sr.iter().map(|v| v / N as f64).collect::<Vec<_>>(), m);
    }
    if free.x0 {
        next.x0 = es.x0.clone();
    }
    if free.p0_diag {
        for i in 0..n {
            let d = es.x0[i] - next.x0[i];
            next.p0[(i, i)] = es.P0[i + i * n] + d * d;
        }
    }
    Ok((es.ll, map.theta_of(&next, Some(data))))
}
