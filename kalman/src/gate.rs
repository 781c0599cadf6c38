//! Wild-point gating: measurement entries that the filter's prior makes implausible are
//! rejected before the update, and every rejection is reported.
//!
//! With the prior `x⁻ = x_{k|k−1}`, `P⁻ = P_{k|k−1}` of the next step and the model that step
//! uses, the innovation of the present entries is `e = z − H x⁻` with covariance `Σ = H P⁻ Hᵀ
//! + R`. Two rules:
//!
//! - [`GateRule::Entries`]: entry i is rejected when its own normalised innovation `e_i² /
//!   Σ_ii` exceeds the χ²(1) quantile of the gate's probability; the update then uses the
//!   entries kept, its Σ recomputed over them by the filter.
//! - [`GateRule::Vector`]: the whole step is rejected when `eᵀ Σ⁺ e` exceeds the χ²(r)
//!   quantile, r the rank of Σ over the present entries (the engine's rule for a singular
//!   Σ, an exact channel).
//!
//! A rejected entry becomes a missing one (NaN) in the vector [`Gate::screen`] returns, which
//! the caller passes to the step: the gate works with every covariance form, the smoother
//! and the diagnostics, since they see the step as it was taken. A screen allocates nothing.
//!
//! [`Huber`] is the soft alternative: no entry is dropped, but an entry whose standardised
//! innovation `r_i = e_i/√Σ_ii` exceeds `c` enters the update with its measurement noise
//! inflated to the variance `R_ii·|r_i|/c` (the Huber weight `w_i = c/|r_i|` of an
//! iteratively re-weighted least-squares step), so its pull on the state grows like `√|r_i|`
//! instead of `|r_i|`.
//!
//! # Example
//! ```
//! use kalman::gate::{Gate, GateRule};
//! use kalman::{CovarianceForm, Filter, Model};
//!
//! let model = Model::from_matrices(&[[1.0]], &[[1.0], [1.0]], &[[0.01]], &[[1.0, 0.0], [0.0, 1.0]])?;
//! let mut kf = Filter::new(model.clone(), &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
//! let mut gate = Gate::new(GateRule::Entries, 0.999, &model)?;
//! // The second sensor reads 40 where the prior says 0 ± 1.4: rejected, the first kept.
//! let kept = gate.screen(&kf, &model, &[0.3, 40.0])?.to_vec();
//! assert!(kept[1].is_nan() && (kept[0] - 0.3).abs() < 1e-15);
//! assert_eq!(gate.rejected()[0].entry, 1);
//! kf.step(&kept, None)?;
//! # Ok::<(), kalman::Error>(())
//! ```
#![allow(non_snake_case)]

use crate::kernels::{RANK_TOL, cholesky, jacobi_eigen};
use crate::storage::{Buf, Dims};
use crate::{Error, Filter, Model, chi2_quantile};

/// Which statistic a [`Gate`] tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GateRule {
    /// Each present entry on its own: `e_i² / Σ_ii` against χ²(1).
    Entries,
    /// The present entries together: `eᵀ Σ⁺ e` against χ²(rank Σ).
    Vector,
}

/// One rejected measurement entry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rejection {
    /// The step (row) index k.
    pub step: usize,
    /// The entry (channel) index i, 0-based.
    pub entry: usize,
    /// The value rejected.
    pub value: f64,
    /// The statistic that rejected it: `e_i²/Σ_ii` ([`GateRule::Entries`]) or the step's
    /// `eᵀ Σ⁺ e` ([`GateRule::Vector`]).
    pub nis: f64,
}

/// A wild-point gate with its workspaces, sized for one model's m and n.
#[derive(Debug, Clone)]
pub struct Gate {
    rule: GateRule,
    probability: f64,
    /// The χ²(d) quantile of the probability, for d = 0…m.
    thresholds: Vec<f64>,
    n: usize,
    m: usize,
    kept: Vec<f64>,
    e: Vec<f64>,
    present: Vec<usize>,
    hp: Vec<f64>,
    sig: Vec<f64>,
    eigv: Vec<f64>,
    eigw: Vec<f64>,
    rejected: Vec<Rejection>,
}

impl Gate {
    /// A gate of rule `rule` at `probability` (in (0, 1): the fraction of consistent
    /// entries or steps it keeps) for the dimensions of `model`.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] naming `probability` outside (0, 1).
    pub fn new<D: Dims>(rule: GateRule, probability: f64, model: &Model<D>) -> Result<Self, Error> {
        if !(probability > 0.0 && probability < 1.0) {
            return Err(Error::InvalidOption {
                name: "probability",
                value: probability,
                rule: "a gate's probability must lie strictly between 0 and 1",
            });
        }
        let (n, m) = (model.dims().n(), model.dims().m());
        let thresholds = (0..=m).map(|d| chi2_quantile(probability, d)).collect();
        Ok(Gate {
            rule,
            probability,
            thresholds,
            n,
            m,
            kept: vec![0.0; m],
            e: vec![0.0; m],
            present: Vec::with_capacity(m),
            hp: vec![0.0; m * n],
            sig: vec![0.0; m * m],
            eigv: vec![0.0; m * m],
            eigw: vec![0.0; m],
            rejected: Vec::with_capacity(m),
        })
    }

    /// The rule.
    pub fn rule(&self) -> GateRule {
        self.rule
    }
    /// The probability.
    pub fn probability(&self) -> f64 {
        self.probability
    }
    /// The threshold of `dof` degrees of freedom (for [`GateRule::Entries`], `dof` = 1).
    pub fn threshold(&self, dof: usize) -> f64 {
        self.thresholds.get(dof).copied().unwrap_or(f64::INFINITY)
    }

    /// The measurement vector of the last [`Gate::screen`], rejected entries NaN.
    pub fn kept(&self) -> &[f64] {
        &self.kept
    }

    /// The rejections of the last [`Gate::screen`].
    pub fn rejected(&self) -> &[Rejection] {
        &self.rejected
    }

    /// Screens `z` (NaN entries missing) against the prior of `filter`'s next step under
    /// `model` (the model that step will use): returns `z` with every rejected entry set to
    /// NaN, and records the rejections ([`Gate::rejected`]).
    ///
    /// # Errors
    /// [`Error::Dimension`] if `model` or `z` does not have the gate's m and n.
    pub fn screen<D: Dims>(
        &mut self,
        filter: &Filter<D>,
        model: &Model<D>,
        z: &[f64],
    ) -> Result<&[f64], Error> {
        let (n, m) = (self.n, self.m);
        if model.dims().n() != n || model.dims().m() != m || z.len() != m {
            return Err(Error::Dimension {
                name: "m",
                value: z.len(),
                rule: "a gate screens the measurements of the model it was built for",
            });
        }
        self.rejected.clear();
        self.kept.copy_from_slice(z);
        self.present.clear();
        self.present.extend((0..m).filter(|&i| !z[i].is_nan()));
        let r = self.present.len();
        if r == 0 {
            return Ok(&self.kept);
        }
        self.innovations(filter, model, z, self.rule == GateRule::Vector);
        let step = filter.steps();
        let rejection = |i: usize, nis: f64| Rejection {
            step,
            entry: i,
            value: z[i],
            nis,
        };
        match self.rule {
            GateRule::Entries => {
                let limit = self.thresholds[1];
                for (a, &i) in self.present.iter().enumerate() {
                    let nis = self.e[a] * self.e[a] / self.sig[a + a * r];
                    if nis > limit {
                        self.rejected.push(rejection(i, nis));
                    }
                }
            }
            GateRule::Vector => {
                let (nis, rank) = self.vector_nis(r);
                if nis > self.thresholds[rank] {
                    let all = self.present.iter().map(|&i| rejection(i, nis));
                    self.rejected.extend(all);
                }
            }
        }
        for rej in &self.rejected {
            self.kept[rej.entry] = f64::NAN;
        }
        Ok(&self.kept)
    }

    /// The prior innovation `e` of the present entries (`present`, `r` of them) and their
    /// innovation covariance `Σ = H P⁻ Hᵀ + R` in `sig` (r×r): all of it when `whole`, else
    /// its diagonal only. `present` must already hold the present entries of `z`.
    fn innovations<D: Dims>(
        &mut self,
        filter: &Filter<D>,
        model: &Model<D>,
        z: &[f64],
        whole: bool,
    ) {
        let (n, m, r) = (self.n, self.m, self.present.len());
        let (H, R) = (model.H.as_slice(), model.R.as_slice());
        let x = filter.predicted_state();
        let P = filter.predicted_covariance();
        // e and H P for the present rows (row a of hp is present entry a).
        for (a, &i) in self.present.iter().enumerate() {
            let mut hx = 0.0;
            for j in 0..n {
                hx += H[i + j * m] * x[j];
            }
            self.e[a] = z[i] - hx;
            for c in 0..n {
                let mut s = 0.0;
                for j in 0..n {
                    s += H[i + j * m] * P[(j, c)];
                }
                self.hp[a + c * r] = s;
            }
        }
        // Σ over the present entries (all of it for the vector rule, its diagonal for the
        // entries' rule).
        for (b, &ib) in self.present.iter().enumerate() {
            for (a, &ia) in self.present.iter().enumerate() {
                if !whole && a != b {
                    continue;
                }
                let mut s = R[ia + ib * m];
                for c in 0..n {
                    s += self.hp[a + c * r] * H[ib + c * m];
                }
                self.sig[a + b * r] = s;
            }
        }
    }

    /// `eᵀ Σ⁺ e` and the rank of the r×r Σ in `sig`: by Cholesky, or, when Σ is singular to
    /// the engine's [`RANK_TOL`], by its eigen-decomposition over the eigenvalues above it.
    fn vector_nis(&mut self, r: usize) -> (f64, usize) {
        let scale = (0..r).fold(0.0_f64, |s, a| s.max(self.sig[a + a * r]));
        let sig = &mut self.sig[..r * r];
        self.eigv[..r * r].copy_from_slice(sig);
        if cholesky(&mut self.eigv[..r * r], r, RANK_TOL * scale) {
            // Forward substitution L y = e; NIS = |y|².
            let L = &self.eigv;
            let mut nis = 0.0;
            for a in 0..r {
                let mut s = self.e[a];
                for b in 0..a {
                    s -= L[a + b * r] * self.eigw[b];
                }
                self.eigw[a] = s / L[a + a * r];
                nis += self.eigw[a] * self.eigw[a];
            }
            return (nis, r);
        }
        jacobi_eigen(sig, r, &mut self.eigv[..r * r], &mut self.eigw[..r]);
        let lmax = self.eigw[..r].iter().fold(0.0_f64, |s, &l| s.max(l));
        let (mut nis, mut rank) = (0.0, 0);
        for c in 0..r {
            let l = self.eigw[c];
            if l > RANK_TOL * lmax {
                let proj: f64 = (0..r).map(|a| self.eigv[a + c * r] * self.e[a]).sum();
                nis += proj * proj / l;
                rank += 1;
            }
        }
        (nis, rank)
    }
}

/// The Huber-weighted update (see the module docs): the model of the next step with the
/// measurement noise of its outlying entries inflated.
#[derive(Debug, Clone)]
pub struct Huber<D: Dims> {
    c: f64,
    /// Its workspaces compute the prior innovations.
    gate: Gate,
    scaled: Model<D>,
    d: Vec<f64>,
    weights: Vec<f64>,
}

impl<D: Dims> Huber<D> {
    /// A Huber weighting with threshold `c` (> 0, in standard deviations; 1.345 gives 95 %
    /// efficiency on Gaussian data) for models shaped like `model`.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] naming `c` if it is not finite and positive.
    pub fn new(c: f64, model: &Model<D>) -> Result<Self, Error> {
        if !(c.is_finite() && c > 0.0) {
            return Err(Error::InvalidOption {
                name: "c",
                value: c,
                rule: "the Huber threshold must be finite and > 0 (standard deviations)",
            });
        }
        let m = model.dims().m();
        Ok(Huber {
            c,
            gate: Gate::new(GateRule::Entries, 0.5, model)?,
            scaled: model.clone(),
            d: vec![1.0; m],
            weights: vec![1.0; m],
        })
    }

    /// The Huber weight `w_i = min(1, c/|r_i|)` of each entry in the last [`Huber::weigh`]
    /// (1 for a missing entry).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// The model for the next step of `filter` with measurement `z` (NaN entries missing):
    /// `model` with the noise of each entry whose `|e_i|/√Σ_ii` exceeds c scaled by
    /// `√(|r_i|/c)` (variance `R_ii·|r_i|/c`; S and the square-root form's noise factor
    /// scaled alike). Pass it to [`Filter::step_with`] with `z` itself; that step's NIS and
    /// log-likelihood are then those of the inflated model. Allocates nothing.
    ///
    /// # Errors
    /// [`Error::Dimension`] if `model` or `z` is not of the shape the weighting was built for,
    /// or `model` and that shape differ in having a cross-covariance S.
    pub fn weigh(
        &mut self,
        filter: &Filter<D>,
        model: &Model<D>,
        z: &[f64],
    ) -> Result<&Model<D>, Error> {
        let (n, m) = (self.gate.n, self.gate.m);
        if model.dims().n() != n
            || model.dims().m() != m
            || z.len() != m
            || model.S.is_some() != self.scaled.S.is_some()
        {
            return Err(Error::Dimension {
                name: "m",
                value: z.len(),
                rule: "a Huber weighting applies to models of the shape it was built for",
            });
        }
        self.weights.iter_mut().for_each(|w| *w = 1.0);
        self.d.iter_mut().for_each(|d| *d = 1.0);
        let g = &mut self.gate;
        g.present.clear();
        g.present.extend((0..m).filter(|&i| !z[i].is_nan()));
        g.innovations(filter, model, z, false);
        let r = g.present.len();
        for (a, &i) in g.present.iter().enumerate() {
            let std = g.e[a].abs() / g.sig[a + a * r].sqrt();
            if std > self.c {
                self.weights[i] = self.c / std;
                self.d[i] = (std / self.c).sqrt();
            }
        }
        self.scaled.scaled_measurement_noise(model, &self.d);
        Ok(&self.scaled)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CovarianceForm;

    fn two_sensors() -> Model<crate::DynDims> {
        Model::from_matrices(
            &[[1.0, 0.1], [0.0, 1.0]],
            &[[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]],
            &[[0.01, 0.0], [0.0, 0.01]],
            &[[1.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, 0.0, 2.0]],
        )
        .expect("valid")
    }

    /// A Joseph-form filter on `model` at x = 0 with the prior covariance `p0`.
    fn filter_at(model: &Model<crate::DynDims>, p0: &[[f64; 2]; 2]) -> Filter<crate::DynDims> {
        Filter::new(model.clone(), &[0.0, 0.0], p0, CovarianceForm::Joseph).expect("valid")
    }

    /// The per-entry statistic is e_i²/Σ_ii with Σ = H P⁻ Hᵀ + R, computed here by hand on
    /// a prior P⁻ = diag(1, 1) ⇒ Σ_ii = 2, 5, 4.
    #[test]
    fn each_entry_is_tested_on_its_own_innovation_variance() {
        let model = two_sensors();
        let kf = filter_at(&model, &[[1.0, 0.0], [0.0, 1.0]]);
        let mut gate = Gate::new(GateRule::Entries, 0.99, &model).expect("valid");
        let limit = gate.threshold(1);
        // χ²(1) at 0.99 is 6.6349: sqrt(limit·Σ_ii) is each entry's bound.
        assert!((limit - 6.634_896_601_021_214).abs() < 1e-9);
        let bounds = [2.0_f64, 5.0, 4.0].map(|s| (limit * s).sqrt());
        let z = [bounds[0] * 0.99, bounds[1] * 1.01, f64::NAN];
        let kept = gate.screen(&kf, &model, &z).expect("screened").to_vec();
        assert!((kept[0] - z[0]).abs() < f64::MIN_POSITIVE);
        assert!(kept[1].is_nan() && kept[2].is_nan());
        let rej = gate.rejected();
        assert_eq!(rej.len(), 1);
        assert_eq!((rej[0].step, rej[0].entry), (0, 1));
        assert!((rej[0].nis - z[1] * z[1] / 5.0).abs() < 1e-12 * rej[0].nis);
    }

    /// The vector statistic is eᵀ Σ⁻¹ e: checked against a 2×2 inverse written out.
    #[test]
    fn the_vector_rule_tests_the_whole_step() {
        let model = two_sensors();
        let kf = filter_at(&model, &[[1.0, 0.5], [0.5, 1.0]]);
        let mut gate = Gate::new(GateRule::Vector, 0.95, &model).expect("valid");
        // Entries 0 and 2 present: Σ = [[2, 1.5], [1.5, 5]] (H rows [1,0], [1,1]).
        let (a, b, d) = (2.0, 1.5, 5.0);
        let det = a * d - b * b;
        let e = [2.0, f64::NAN, 4.5];
        let nis = (d * e[0] * e[0] - 2.0 * b * e[0] * e[2] + a * e[2] * e[2]) / det;
        let limit = gate.threshold(2);
        let kept = gate.screen(&kf, &model, &e).expect("screened").to_vec();
        assert_eq!(nis > limit, kept[0].is_nan());
        let scaled = e.map(|v| v * (1.01 * limit / nis).sqrt());
        gate.screen(&kf, &model, &scaled).expect("screened");
        assert_eq!(gate.rejected().len(), 2);
        assert!((gate.rejected()[0].nis - 1.01 * limit).abs() < 1e-9 * limit);
        let inside = e.map(|v| v * (0.99 * limit / nis).sqrt());
        gate.screen(&kf, &model, &inside).expect("screened");
        assert!(gate.rejected().is_empty());
    }

    #[test]
    fn bad_probabilities_and_sizes_are_named() {
        let model = two_sensors();
        for p in [0.0, 1.0, -0.5, f64::NAN] {
            assert!(matches!(
                Gate::new(GateRule::Entries, p, &model),
                Err(Error::InvalidOption {
                    name: "probability",
                    ..
                })
            ));
        }
        let kf = filter_at(&model, &[[1.0, 0.0], [0.0, 1.0]]);
        let mut gate = Gate::new(GateRule::Entries, 0.9, &model).expect("valid");
        assert!(gate.screen(&kf, &model, &[1.0]).is_err());
    }

    /// On a scalar random walk the Huber step is the closed form: r = e/√(P + R); beyond c
    /// the update uses R' = R·|r|/c, so x⁺ = x⁻ + P/(P + R') e; within c it is the plain step.
    #[test]
    fn the_huber_update_is_the_closed_form_on_a_scalar_model() {
        for form in [
            CovarianceForm::Joseph,
            CovarianceForm::Standard,
            CovarianceForm::SquareRoot,
        ] {
            let model =
                Model::from_matrices(&[[1.0]], &[[1.0]], &[[0.5]], &[[2.0]]).expect("valid");
            let (x0, p0) = (1.0, 3.0);
            let c = 1.5;
            for z in [1.5, 40.0, -30.0] {
                let mut kf = Filter::new(model.clone(), &[x0], &[[p0]], form).expect("valid");
                let mut huber = Huber::new(c, &model).expect("valid");
                let weighted = huber.weigh(&kf, &model, &[z]).expect("weighed").clone();
                kf.step_with(&weighted, &[z], None).expect("step");
                let e = z - x0;
                let r = e.abs() / (p0 + 2.0_f64).sqrt();
                let R = if r > c { 2.0 * r / c } else { 2.0 };
                let want = x0 + p0 / (p0 + R) * e;
                // Tolerance: a handful of flops on numbers of order 10.
                assert!(
                    (kf.state()[0] - want).abs() < 1e-12 * want.abs().max(1.0),
                    "{form:?} z {z}"
                );
                assert!((huber.weights()[0] - (c / r).min(1.0)).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn a_huber_threshold_must_be_positive() {
        let model = two_sensors();
        for c in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                Huber::new(c, &model),
                Err(Error::InvalidOption { name: "c", .. })
            ));
        }
    }
}
