//! Calibration of the parameters the paper does not state: a search over a box of plausible
//! values for the set whose random-error ratios to relay logic at the headline amplitude come
//! closest to the paper's (one-channel 0.40, two-channel 0.25), with the two-channel filter's
//! sensitivity to amplitude and period as a secondary term.
//!
//! **Objective.** For a set θ, J(θ) = ‖(r₁ − 0.40, r₂ − 0.25)‖ + w·s(θ) + 10·f(θ), where r₁, r₂
//! are std(one-/two-channel KF)/std(relay) over `runs_per_set` runs at the amplitude sweep's
//! largest amplitude, s is the two-channel filter's invariance spread (max − min)/max of its
//! random error over the corners of the campaign's invariance table (smallest and largest
//! amplitude × shortest and longest period), w the `invariance_weight`, and f the fraction of
//! runs in which a strategy never stopped. Every set is run on the same streams (run i draws
//! from `run_rng(search seed, i)`: common random numbers), so J is a deterministic function
//! of θ and the differences between sets are due to the parameters, not to sampling luck.
//!
//! **Search.** The box is mapped to the unit cube (log scale for the parameters spanning
//! more than a decade of plausible values); a maximin Latin hypercube of `design_sets` sets
//! covers it, then argmin's Nelder–Mead refines from the best `refine_starts` of them (points
//! outside the cube are evaluated at the nearest face plus their L1 distance to it). The best
//! set is then evaluated on a fresh seed (`runs_per_point` runs: the ratios and their 95 %
//! delta-method intervals the verdict uses) and a one-at-a-time sensitivity of both ratios
//! is taken around it (± a tenth of each range, on the search streams).
//!
//! **Sharding.** The calibration is not sharded: it depends on the parameters and the campaign
//! seed alone (never on the run records or the thread count), a shard skips it, and `merge`
//! computes it exactly as a whole run does, so the merge rule holds byte for byte.

use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;

use argmin::core::{CostFunction, Executor};
use argmin::solver::neldermead::NelderMead;
use serde::Serialize;

use super::parameters::{FuelingParams, Plan, Search, Swept, World};
use super::records::Outcome;
use super::search::{BOX, Dim, get, latin_hypercube, params_at, unit_of};
use super::simulation::Point;
use super::statistics::{RatioCi, std_ratio};
use crate::error::{Error, Result};
use crate::montecarlo::{par_runs, run_rng, run_seed};

/// One evaluated set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evaluation {
    /// The searched parameters' values, in [`BOX`] order.
    pub values: Vec<f64>,
    /// std(one-channel KF)/std(relay) at the headline amplitude.
    pub kf1: RatioCi,
    /// std(two-channel KF)/std(relay) at the headline amplitude.
    pub kf2: RatioCi,
    /// Relay logic's random error at the headline amplitude, mm.
    pub relay_std_mm: f64,
    /// Two-channel invariance spread (max − min)/max over the corners (NaN if not computed).
    pub spread: f64,
    /// Fraction of runs in which relay logic or a filter never stopped.
    pub no_stop: f64,
    /// The objective J.
    pub cost: f64,
    /// Why the set could not be run (the model or a filter rejected it), if so.
    pub rejected: Option<String>,
}

/// The cost of a set that cannot be run: far above any reachable J.
const REJECTED: f64 = 1e3;

/// The evaluator shared by the design, the refinement, the sensitivity and the fresh check.
struct Evaluator<'a> {
    base: &'a FuelingParams,
    amplitude_deg: f64,
    corners: Vec<(f64, f64)>,
    weight: f64,
    /// The ratios aimed at (one-channel, two-channel).
    target: (f64, f64),
    threads: Option<usize>,
    /// The first error met inside the optimiser (which cannot carry it out).
    error: RefCell<Option<Error>>,
    /// Every evaluation on the search streams with its unit coordinates (design, refinement).
    log: RefCell<Vec<(Vec<f64>, Evaluation)>>,
    runs_used: Cell<usize>,
}

impl Evaluator<'_> {
    /// Evaluates the sets at unit coordinates `units` with `runs` runs each on the streams of
    /// `seed`; with `corners` also the invariance corners (else `spread` is NaN).
    fn evaluate(
        &self,
        units: &[Vec<f64>],
        corners: bool,
        seed: u64,
        runs: usize,
    ) -> Result<Vec<Evaluation>> {
        let sets: Vec<FuelingParams> = units.iter().map(|u| params_at(self.base, u)).collect();
        let mut worlds: Vec<World> = Vec::new();
        let per_set = 1 + if corners { self.corners.len() } else { 0 };
        for p in &sets {
            worlds.push(p.world(self.amplitude_deg, Swept::Nothing));
            if corners {
                for &(a, t) in &self.corners {
                    worlds.push(p.world(a, Swept::Period(t)));
                }
            }
        }
        let points = par_runs(0..worlds.len(), self.threads, "calibration", |w| {
            Point::new(worlds[w])
        })?;
        let jobs: Vec<(usize, usize)> = points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.is_ok())
            .flat_map(|(w, _)| (0..runs).map(move |r| (w, r)))
            .collect();
        self.runs_used.set(self.runs_used.get() + jobs.len());
        let outcomes = par_runs(0..jobs.len(), self.threads, "calibration", |j| {
            let (w, r) = jobs[j];
            // Only points that were built have jobs.
            points[w]
                .as_ref()
                .ok()
                .map(|p| p.run(&mut run_rng(seed, r as u64)))
        })?;
        let mut by_world: Vec<Vec<Outcome>> = vec![Vec::new(); worlds.len()];
        let mut failure: Vec<Option<String>> = points
            .iter()
            .map(|p| p.as_ref().err().map(ToString::to_string))
            .collect();
        for ((w, _), o) in jobs.iter().zip(outcomes) {
            match o {
                Some(Ok(o)) => by_world[*w].push(o),
                Some(Err(e)) => failure[*w] = Some(e.to_string()),
                None => {}
            }
        }
        Ok(sets
            .iter()
            .enumerate()
            .map(|(s, p)| {
                let ws = s * per_set..(s + 1) * per_set;
                let values = (0..BOX.len()).map(|k| get(p, k)).collect();
                self.score(
                    values,
                    &by_world[ws.clone()],
                    failure[ws].iter().flatten().next(),
                )
            })
            .collect())
    }

    /// The evaluation of one set from its worlds' outcomes (headline first, then corners).
    fn score(
        &self,
        values: Vec<f64>,
        worlds: &[Vec<Outcome>],
        failure: Option<&String>,
    ) -> Evaluation {
        let nan = RatioCi {
            ratio: f64::NAN,
            se: f64::NAN,
            lo: f64::NAN,
            hi: f64::NAN,
            runs: 0,
        };
        if let Some(e) = failure {
            return Evaluation {
                values,
                kf1: nan,
                kf2: nan,
                relay_std_mm: f64::NAN,
                spread: f64::NAN,
                no_stop: f64::NAN,
                cost: REJECTED,
                rejected: Some(e.clone()),
            };
        }
        let column = |w: &[Outcome], i: usize| w.iter().map(|o| o[i]).collect::<Vec<f64>>();
        let head = &worlds[0];
        let relay = column(head, 0);
        let kf1 = std_ratio(&column(head, 1), &relay);
        let kf2 = std_ratio(&column(head, 2), &relay);
        let relay_std_mm = sample_std(&relay) * 1e3;
        let spread = if worlds.len() > 1 {
            let stds: Vec<f64> = worlds[1..]
                .iter()
                .map(|w| sample_std(&column(w, 2)))
                .collect();
            let (lo, hi) = stds
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
                    (l.min(*x), h.max(*x))
                });
            (hi - lo) / hi
        } else {
            f64::NAN
        };
        let total: usize = worlds.iter().map(Vec::len).sum();
        let stuck = worlds
            .iter()
            .flatten()
            .filter(|o| o[..3].iter().any(|x| !x.is_finite()))
            .count();
        let no_stop = stuck as f64 / total.max(1) as f64;
        let distance = (kf1.ratio - self.target.0).hypot(kf2.ratio - self.target.1);
        let invariance = if spread.is_finite() {
            self.weight * spread
        } else {
            0.0
        };
        let cost = distance + invariance + 10.0 * no_stop;
        Evaluation {
            values,
            kf1,
            kf2,
            relay_std_mm,
            spread,
            no_stop,
            cost: if cost.is_finite() { cost } else { REJECTED },
            rejected: None,
        }
    }

    /// Evaluates on the search streams and logs each evaluation.
    fn search(&self, units: &[Vec<f64>], seed: u64, runs: usize) -> Result<Vec<Evaluation>> {
        let evals = self.evaluate(units, true, seed, runs)?;
        self.log
            .borrow_mut()
            .extend(units.iter().cloned().zip(evals.iter().cloned()));
        Ok(evals)
    }
}

fn sample_std(v: &[f64]) -> f64 {
    let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    let n = f.len() as f64;
    let m = f.iter().sum::<f64>() / n;
    (f.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}

/// Nelder–Mead's view of the objective: unit coordinates, clamped to the cube.
struct Refine<'a, 'b> {
    ev: &'a Evaluator<'b>,
    seed: u64,
    runs: usize,
}

impl CostFunction for Refine<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, u: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        let clamped: Vec<f64> = u.iter().map(|x| x.clamp(0.0, 1.0)).collect();
        let outside: f64 = u.iter().zip(&clamped).map(|(a, b)| (a - b).abs()).sum();
        // Nelder–Mead unwraps the costs of its first simplex: keep the error for later.
        let cost = match self.ev.search(&[clamped], self.seed, self.runs) {
            Ok(e) => e.first().map_or(REJECTED, |e| e.cost),
            Err(e) => {
                self.ev.error.borrow_mut().get_or_insert(e);
                REJECTED
            }
        };
        Ok(cost + outside)
    }
}

/// How the two ratios move when one parameter moves by a tenth of its range either way.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sensitivity {
    /// The parameter.
    pub key: &'static str,
    /// Its value below and above the best set's.
    pub values: [f64; 2],
    /// One-channel ratio at those values.
    pub kf1: [f64; 2],
    /// Two-channel ratio at those values.
    pub kf2: [f64; 2],
}

/// The best set's ratio against the paper's figure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Gap {
    /// The paper's figure.
    pub paper: f64,
    /// The ratio on the fresh seed, with its 95 % interval.
    pub ours: RatioCi,
    /// Signed distance from the 95 % interval to the paper's figure ± `tolerance` (0 if they
    /// overlap; > 0: every value in the interval is above).
    pub gap: f64,
}

/// The verdict, from the fresh-seed numbers.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// The paper quotes "≈ 0.40" and "≈ 0.25": read as ± this.
    pub tolerance: f64,
    /// One-channel ratio.
    pub kf1: Gap,
    /// Two-channel ratio.
    pub kf2: Gap,
    /// Both ratios' intervals reach the paper's figures within the tolerance.
    pub reproduced: bool,
    /// Parameters of the best set within 2 % of their range from a bound of the box (where a
    /// wider box might help).
    pub at_bounds: Vec<&'static str>,
}

/// The best set found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Best {
    /// The searched parameters' values.
    pub params: BTreeMap<&'static str, f64>,
    /// Its evaluation on the search streams (ratios with their standard errors).
    pub search: Evaluation,
    /// Its evaluation on a fresh seed.
    pub fresh: Evaluation,
    /// Runs per point of the fresh evaluation.
    pub fresh_runs: usize,
}

/// `summary.json`'s `calibration`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Calibration {
    /// The search setting.
    pub search: Search,
    /// Sets evaluated on the search streams (design and refinement).
    pub searched: usize,
    /// Of which in the Latin hypercube.
    pub design_sets: usize,
    /// Runs per set during the search.
    pub runs_per_set: usize,
    /// Monte Carlo runs simulated by the calibration in all (search, sensitivity, fresh).
    pub runs_used: usize,
    /// Seed of the search streams.
    pub search_seed: u64,
    /// Seed of the fresh evaluation.
    pub fresh_seed: u64,
    /// The headline amplitude, degrees.
    pub amplitude_deg: f64,
    /// The invariance corners (amplitude °, period s).
    pub corners: Vec<(f64, f64)>,
    /// Weight of the invariance spread.
    pub invariance_weight: f64,
    /// The paper's ratios the search aims at.
    pub paper: (f64, f64),
    /// The box.
    #[serde(rename = "box")]
    pub bounds: Vec<Dim>,
    /// The configured parameters on the search streams.
    pub defaults: Evaluation,
    /// The best set.
    pub best: Best,
    /// One-at-a-time sensitivity around the best set.
    pub sensitivity: Vec<Sensitivity>,
    /// The verdict.
    pub verdict: Verdict,
    /// The configured parameters with the best set in place and the search off (the content
    /// of `calibration.toml`).
    #[serde(skip)]
    pub best_params: FuelingParams,
    /// Every evaluation of the search, in order (`calibration_sets.csv`).
    #[serde(skip)]
    pub evaluations: Vec<Evaluation>,
}

/// Stream offsets of the calibration's seeds (far from any campaign's run indices).
const SEARCH_STREAM: u64 = 1 << 62;
const FRESH_STREAM: u64 = (1 << 62) + 1;
const DESIGN_STREAM: u64 = (1 << 62) + 2;

/// Relative step of the sensitivity, in unit coordinates.
const SENSITIVITY_STEP: f64 = 0.1;

/// The paper's "≈" read as ± this on its two-decimal ratios.
pub const TOLERANCE: f64 = 0.05;

/// Runs the calibration of `params` with the campaign `seed` towards the ratios `paper`
/// (one-channel, two-channel; `None` when the search is off).
///
/// # Errors
/// [`Error::Threads`] if the worker pool cannot start; [`Error::Optimiser`] if Nelder–Mead
/// fails; [`Error::NothingEvaluated`] if the search evaluated no parameter set.
pub fn calibrate(
    params: &FuelingParams,
    seed: u64,
    threads: Option<usize>,
    paper: (f64, f64),
) -> Result<Option<Calibration>> {
    let Some(plan) = params.calibration.plan() else {
        return Ok(None);
    };
    calibrate_with(params, seed, threads, plan, paper).map(Some)
}

/// [`calibrate`] with an explicit plan and target ratios (the planted-optimum test aims at
/// the defaults' own ratios).
fn calibrate_with(
    params: &FuelingParams,
    seed: u64,
    threads: Option<usize>,
    plan: Plan,
    target: (f64, f64),
) -> Result<Calibration> {
    let amplitude_deg = params
        .amplitudes_deg
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    let ends = |v: &[f64]| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if hi > lo { vec![lo, hi] } else { vec![lo] }
    };
    let mut corners = Vec::new();
    for a in ends(&params.invariance_amplitudes_deg) {
        for t in ends(&params.invariance_periods_s) {
            corners.push((a, t));
        }
    }
    let ev = Evaluator {
        base: params,
        amplitude_deg,
        corners: corners.clone(),
        weight: params.calibration.invariance_weight,
        target,
        threads,
        error: RefCell::new(None),
        log: RefCell::new(Vec::new()),
        runs_used: Cell::new(0),
    };
    let search_seed = run_seed(seed, SEARCH_STREAM);
    let fresh_seed = run_seed(seed, FRESH_STREAM);
    let runs = plan.runs_per_set;
    // The configured set, for reference: not a candidate (the planted-optimum test aims at
    // its ratios, and the search must find such a set by itself).
    let defaults = ev
        .evaluate(&[unit_of(params)], true, search_seed, runs)?
        .remove(0);
    let design = latin_hypercube(
        plan.design_sets,
        BOX.len(),
        20,
        run_seed(seed, DESIGN_STREAM),
    );
    let evals = ev.search(&design, search_seed, runs)?;
    let mut order: Vec<usize> = (0..evals.len()).collect();
    order.sort_by(|a, b| evals[*a].cost.total_cmp(&evals[*b].cost));
    for &start in order.iter().take(plan.refine_starts) {
        let u0 = &design[start];
        let mut simplex = vec![u0.clone()];
        for k in 0..u0.len() {
            let mut v = u0.clone();
            v[k] = if v[k] + SENSITIVITY_STEP <= 1.0 {
                v[k] + SENSITIVITY_STEP
            } else {
                v[k] - SENSITIVITY_STEP
            };
            simplex.push(v);
        }
        let solver = NelderMead::new(simplex)
            .with_sd_tolerance(1e-4)
            .map_err(|source| Error::Optimiser {
                stage: "Nelder–Mead",
                source,
            })?;
        Executor::new(
            Refine {
                ev: &ev,
                seed: search_seed,
                runs,
            },
            solver,
        )
        .configure(|s| s.max_iters(plan.refine_iterations))
        .run()
        .map_err(|source| Error::Optimiser {
            stage: "Nelder–Mead refinement",
            source,
        })?;
        if let Some(e) = ev.error.take() {
            return Err(e);
        }
    }
    let log = ev.log.take();
    let (best_u, best_eval) = log
        .iter()
        .fold(None::<&(Vec<f64>, Evaluation)>, |b, e| match b {
            Some(b) if b.1.cost <= e.1.cost => Some(b),
            _ => Some(e),
        })
        .cloned()
        .ok_or(Error::NothingEvaluated {
            stage: "calibration",
        })?;
    let mut sens_units = Vec::new();
    for k in 0..BOX.len() {
        for sign in [-1.0, 1.0] {
            let mut u = best_u.clone();
            u[k] = (u[k] + sign * SENSITIVITY_STEP).clamp(0.0, 1.0);
            sens_units.push(u);
        }
    }
    let sens = ev.evaluate(&sens_units, false, search_seed, runs)?;
    let sensitivity = BOX
        .iter()
        .zip(sens.chunks(2))
        .enumerate()
        .map(|(k, (d, pair))| Sensitivity {
            key: d.key,
            values: [pair[0].values[k], pair[1].values[k]],
            kf1: [pair[0].kf1.ratio, pair[1].kf1.ratio],
            kf2: [pair[0].kf2.ratio, pair[1].kf2.ratio],
        })
        .collect();
    let fresh_runs = params.runs_per_point;
    let fresh = ev
        .evaluate(std::slice::from_ref(&best_u), true, fresh_seed, fresh_runs)?
        .remove(0);
    let gap = |paper: f64, ours: RatioCi| {
        let gap = if ours.lo > paper + TOLERANCE {
            ours.lo - (paper + TOLERANCE)
        } else if ours.hi < paper - TOLERANCE {
            ours.hi - (paper - TOLERANCE)
        } else if ours.ratio.is_finite() {
            0.0
        } else {
            f64::NAN
        };
        Gap { paper, ours, gap }
    };
    let (g1, g2) = (gap(target.0, fresh.kf1), gap(target.1, fresh.kf2));
    let verdict = Verdict {
        tolerance: TOLERANCE,
        kf1: g1,
        kf2: g2,
        reproduced: g1.gap.abs() <= 0.0 && g2.gap.abs() <= 0.0,
        at_bounds: BOX
            .iter()
            .zip(&best_u)
            .filter(|(_, u)| **u < 0.02 || **u > 0.98)
            .map(|(d, _)| d.key)
            .collect(),
    };
    let mut best_params = params_at(params, &best_u);
    best_params.calibration.search = Search::Off;
    Ok(Calibration {
        search: params.calibration.search,
        searched: log.len(),
        design_sets: plan.design_sets,
        runs_per_set: runs,
        runs_used: ev.runs_used.get(),
        search_seed,
        fresh_seed,
        amplitude_deg,
        corners,
        invariance_weight: ev.weight,
        paper: target,
        bounds: BOX.to_vec(),
        defaults,
        best: Best {
            params: BOX
                .iter()
                .map(|d| d.key)
                .zip(best_eval.values.iter().copied())
                .collect(),
            search: best_eval,
            fresh,
            fresh_runs,
        },
        sensitivity,
        verdict,
        best_params,
        evaluations: log.into_iter().map(|(_, e)| e).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fueling::parameters::CalibrationConfig;

    #[test]
    fn search_finds_a_planted_optimum() {
        // Aim at the ratios the defaults themselves give on the search streams: a set with
        // exactly those ratios exists in the box (the defaults), so the search must return
        // one whose ratios match them within their standard errors.
        let params = FuelingParams {
            warmup_s: 30.0,
            invariance_amplitudes_deg: vec![1.0],
            invariance_periods_s: vec![10.0],
            calibration: CalibrationConfig {
                invariance_weight: 0.0,
                ..CalibrationConfig::default()
            },
            runs_per_point: 60,
            ..FuelingParams::default()
        };
        let plan = Plan {
            design_sets: 12,
            runs_per_set: 60,
            refine_starts: 1,
            refine_iterations: 40,
        };
        let seed = 4;
        let ev = Evaluator {
            base: &params,
            amplitude_deg: 1.0,
            corners: Vec::new(),
            weight: 0.0,
            target: (0.0, 0.0),
            threads: Some(2),
            error: RefCell::new(None),
            log: RefCell::new(Vec::new()),
            runs_used: Cell::new(0),
        };
        let planted = ev
            .evaluate(
                &[unit_of(&params)],
                false,
                run_seed(seed, SEARCH_STREAM),
                60,
            )
            .expect("defaults")
            .remove(0);
        let target = (planted.kf1.ratio, planted.kf2.ratio);
        let c = calibrate_with(&params, seed, Some(2), plan, target).expect("search");
        let b = &c.best.search;
        assert!(
            (b.kf1.ratio - target.0).abs() <= b.kf1.se,
            "{b:?} vs {target:?}"
        );
        assert!(
            (b.kf2.ratio - target.1).abs() <= b.kf2.se,
            "{b:?} vs {target:?}"
        );
        assert!(
            c.searched > plan.design_sets,
            "the refinement evaluated sets"
        );
        // The best design set alone is not that close: the refinement did the work, or the
        // test would not show that it works. (Logged for the reader, not asserted: whether
        // a 12-set design lands within one SE is luck.)
        let design_best = c.evaluations[..plan.design_sets]
            .iter()
            .map(|e| e.cost)
            .fold(f64::INFINITY, f64::min);
        eprintln!(
            "best design cost {design_best}, after refinement {}",
            b.cost
        );
    }
}
