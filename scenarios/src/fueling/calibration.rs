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
//! **Stages.** The calibration depends on the parameters and the campaign seed alone (never
//! on the run records or the thread count). Its design is sharded like the runs: a shard
//! evaluates its slice of the sets ([`design`]) into the record file [`DESIGN_FILE`]. The
//! refinement needs every design set, so it runs in the campaign's closing stage ([`refine`],
//! after every shard; inside a whole run, after its design), and its numbers are a record too
//! ([`Refinement`]). The summary ([`assemble`]) only reads both: `merge` computes nothing.

use std::cell::{Cell, RefCell};

use super::calibration_records::{
    Best, Calibration, DesignRecord, Evaluation, Gap, Refined, Refinement, Rejection, Sensitivity,
    Verdict,
};
use super::parameters::{FuelingParams, Plan, Search, Swept, World};
use super::records::{DESIGN_FILE, Outcome};
use super::search::{BOX, get, latin_hypercube, params_at, unit_of};
use super::simulation::Point;
use super::statistics::{RatioCi, std_ratio};
use crate::error::{Error, Result};
use crate::montecarlo::{Shard, par_runs, run_rng, run_seed};
use argmin::core::{CostFunction, Executor};
use argmin::solver::neldermead::NelderMead;

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
    log: RefCell<Vec<Refined>>,
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
        Ok(self.evaluate_counted(units, corners, seed, runs)?.0)
    }

    /// [`Evaluator::evaluate`], with the Monte Carlo runs each set simulated.
    fn evaluate_counted(
        &self,
        units: &[Vec<f64>],
        corners: bool,
        seed: u64,
        runs: usize,
    ) -> Result<(Vec<Evaluation>, Vec<usize>)> {
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
        let mut runs_used = vec![0; sets.len()];
        for (w, _) in &jobs {
            runs_used[w / per_set] += 1;
        }
        let evaluations = sets
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
            .collect();
        Ok((evaluations, runs_used))
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
            .extend(units.iter().zip(&evals).map(|(u, e)| Refined {
                units: u.clone(),
                evaluation: e.clone(),
            }));
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

/// Stream offsets of the calibration's seeds (far from any campaign's run indices).
const SEARCH_STREAM: u64 = 1 << 62;
const FRESH_STREAM: u64 = (1 << 62) + 1;
const DESIGN_STREAM: u64 = (1 << 62) + 2;

/// Design sets evaluated at once (their worlds are built together).
const DESIGN_BATCH: usize = 32;

/// Relative step of the sensitivity, in unit coordinates.
const SENSITIVITY_STEP: f64 = 0.1;

/// The paper's "≈" read as ± this on its two-decimal ratios.
pub const TOLERANCE: f64 = 0.05;

/// The headline amplitude (the amplitude sweep's largest, degrees) and the invariance
/// corners (amplitude °, period s) the search scores a set at.
fn headline(params: &FuelingParams) -> (f64, Vec<(f64, f64)>) {
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
    (amplitude_deg, corners)
}

/// The evaluator of the search for a campaign with `params`, aiming at `target`.
fn evaluator(params: &FuelingParams, threads: Option<usize>, target: (f64, f64)) -> Evaluator<'_> {
    let (amplitude_deg, corners) = headline(params);
    Evaluator {
        base: params,
        amplitude_deg,
        corners,
        weight: params.calibration.invariance_weight,
        target,
        threads,
        error: RefCell::new(None),
        log: RefCell::new(Vec::new()),
        runs_used: Cell::new(0),
    }
}

/// The unit coordinates of every design set, the configured set first.
fn design_units(params: &FuelingParams, seed: u64, plan: Plan) -> Vec<Vec<f64>> {
    let mut units = vec![unit_of(params)];
    units.extend(latin_hypercube(
        plan.design_sets,
        BOX.len(),
        20,
        run_seed(seed, DESIGN_STREAM),
    ));
    units
}

/// Evaluates the design sets of `shard` (the calibration's sharded stage: each set runs on
/// the same search streams in whichever shard holds it). Empty when the search is off.
///
/// # Errors
/// [`Error::Threads`] if the worker pool cannot start.
pub fn design(
    params: &FuelingParams,
    seed: u64,
    shard: Shard,
    threads: Option<usize>,
    paper: (f64, f64),
) -> Result<Vec<DesignRecord>> {
    let Some(plan) = params.calibration.plan() else {
        return Ok(Vec::new());
    };
    let units = design_units(params, seed, plan);
    let sets = shard.runs(units.len());
    let ev = evaluator(params, threads, paper);
    // A few sets at a time: each set's worlds hold their filters' gain schedules, so memory
    // grows with the sets evaluated at once (each set's numbers do not depend on its batch).
    let (mut evaluations, mut runs_used) = (Vec::new(), Vec::new());
    for chunk in units[sets.clone()].chunks(DESIGN_BATCH) {
        let (e, r) = ev.evaluate_counted(
            chunk,
            true,
            run_seed(seed, SEARCH_STREAM),
            plan.runs_per_set,
        )?;
        evaluations.extend(e);
        runs_used.extend(r);
    }
    Ok(sets
        .zip(evaluations.into_iter().zip(runs_used))
        .map(|(set, (mut evaluation, runs_used))| {
            // The record holds whether, not why: the closing stage finds the message again.
            if evaluation.rejected.is_some() {
                evaluation.rejected = Some(String::new());
            }
            DesignRecord {
                set,
                evaluation,
                runs_used,
            }
        })
        .collect())
}

/// The best evaluation of `log` (the first of the lowest cost).
fn best_of(log: &[Refined]) -> Result<&Refined> {
    log.iter()
        .fold(None::<&Refined>, |b, e| match b {
            Some(b) if b.evaluation.cost <= e.evaluation.cost => Some(b),
            _ => Some(e),
        })
        .ok_or(Error::NothingEvaluated {
            stage: "calibration",
        })
}

/// The search log of a finished calibration: the design's sets (without the configured
/// one) with their unit coordinates, then the refinement's evaluations.
fn search_log(units: &[Vec<f64>], design: &[DesignRecord], refined: &[Refined]) -> Vec<Refined> {
    units
        .iter()
        .zip(design)
        .skip(1)
        .map(|(u, d)| Refined {
            units: u.clone(),
            evaluation: d.evaluation.clone(),
        })
        .chain(refined.iter().cloned())
        .collect()
}

/// The units of the sensitivity's sets around `best`: each parameter a tenth of its range
/// below and above.
fn sensitivity_units(best: &[f64]) -> Vec<Vec<f64>> {
    let mut units = Vec::new();
    for k in 0..BOX.len() {
        for sign in [-1.0, 1.0] {
            let mut u = best.to_vec();
            u[k] = (u[k] + sign * SENSITIVITY_STEP).clamp(0.0, 1.0);
            units.push(u);
        }
    }
    units
}

/// The calibration's closing stage: from the whole design (every set, in set order), the
/// Nelder–Mead refinement from the best `refine_starts` design sets, then the sensitivity and
/// the fresh evaluation of the best set found. `None` when the search is off.
///
/// # Errors
/// [`Error::Invalid`] if `design` is not the whole design; [`Error::Threads`] if the worker
/// pool cannot start; [`Error::Optimiser`] if Nelder–Mead fails; as [`design`].
pub fn refine(
    params: &FuelingParams,
    seed: u64,
    design: &[DesignRecord],
    threads: Option<usize>,
    paper: (f64, f64),
) -> Result<Option<Refinement>> {
    let Some(plan) = params.calibration.plan() else {
        return Ok(None);
    };
    let units = design_units(params, seed, plan);
    if design.len() != units.len() || design.iter().enumerate().any(|(i, d)| d.set != i) {
        return Err(Error::invalid(
            DESIGN_FILE,
            format!(
                "{} sets, expected one for each of the {} sets of the design",
                design.len(),
                units.len()
            ),
        ));
    }
    let ev = evaluator(params, threads, paper);
    let search_seed = run_seed(seed, SEARCH_STREAM);
    let runs = plan.runs_per_set;
    // The message of a rejected set is found again by evaluating it alone (the same streams,
    // so the same failure); those runs are not the search's and are not counted.
    let mut rejections = Vec::new();
    for d in design.iter().filter(|d| d.evaluation.rejected.is_some()) {
        let again = ev.evaluate(&units[d.set..=d.set], true, search_seed, runs)?;
        rejections.push(Rejection {
            set: d.set,
            message: again
                .into_iter()
                .next()
                .and_then(|e| e.rejected)
                .unwrap_or_default(),
        });
    }
    ev.runs_used.set(0);
    let evals = &design[1..];
    let mut order: Vec<usize> = (0..evals.len()).collect();
    order.sort_by(|a, b| {
        evals[*a]
            .evaluation
            .cost
            .total_cmp(&evals[*b].evaluation.cost)
    });
    for &start in order.iter().take(plan.refine_starts) {
        let u0 = &units[start + 1];
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
    let refined = ev.log.take();
    let log = search_log(&units, design, &refined);
    let best_u = best_of(&log)?.units.clone();
    let sensitivity = ev.evaluate(&sensitivity_units(&best_u), false, search_seed, runs)?;
    let fresh = ev
        .evaluate(
            std::slice::from_ref(&best_u),
            true,
            run_seed(seed, FRESH_STREAM),
            params.runs_per_point,
        )?
        .remove(0);
    Ok(Some(Refinement {
        refined,
        sensitivity,
        fresh,
        runs_used: ev.runs_used.get(),
        rejections,
    }))
}

/// The calibration of `params` with the campaign `seed` towards the ratios `paper`
/// (one-channel, two-channel) from its records: the whole design and its refinement
/// (`None` when the search is off). Computes nothing but the summary of those numbers.
///
/// # Errors
/// [`Error::Invalid`] if the design or the refinement does not fit the parameters;
/// [`Error::NothingEvaluated`] if the search evaluated no parameter set.
pub fn assemble(
    params: &FuelingParams,
    seed: u64,
    design: &[DesignRecord],
    refinement: Option<&Refinement>,
    paper: (f64, f64),
) -> Result<Option<Calibration>> {
    let (Some(plan), Some(r)) = (params.calibration.plan(), refinement) else {
        return Ok(None);
    };
    let units = design_units(params, seed, plan);
    if design.len() != units.len() || r.sensitivity.len() != 2 * BOX.len() {
        return Err(Error::invalid(
            DESIGN_FILE,
            format!(
                "{} design sets and {} sensitivity sets, expected {} and {}",
                design.len(),
                r.sensitivity.len(),
                units.len(),
                2 * BOX.len()
            ),
        ));
    }
    let mut design = design.to_vec();
    for rejection in &r.rejections {
        if let Some(d) = design.get_mut(rejection.set) {
            d.evaluation.rejected = Some(rejection.message.clone());
        }
    }
    let (amplitude_deg, corners) = headline(params);
    let log = search_log(&units, &design, &r.refined);
    let Refined {
        units: best_u,
        evaluation: best_eval,
    } = best_of(&log)?.clone();
    let sensitivity = BOX
        .iter()
        .zip(r.sensitivity.chunks(2))
        .enumerate()
        .map(|(k, (d, pair))| Sensitivity {
            key: d.key,
            values: [pair[0].values[k], pair[1].values[k]],
            kf1: [pair[0].kf1.ratio, pair[1].kf1.ratio],
            kf2: [pair[0].kf2.ratio, pair[1].kf2.ratio],
        })
        .collect();
    let fresh = r.fresh.clone();
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
    let (g1, g2) = (gap(paper.0, fresh.kf1), gap(paper.1, fresh.kf2));
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
    Ok(Some(Calibration {
        search: params.calibration.search,
        searched: log.len(),
        design_sets: plan.design_sets,
        runs_per_set: plan.runs_per_set,
        runs_used: design.iter().map(|d| d.runs_used).sum::<usize>() + r.runs_used,
        search_seed: run_seed(seed, SEARCH_STREAM),
        fresh_seed: run_seed(seed, FRESH_STREAM),
        amplitude_deg,
        corners,
        invariance_weight: params.calibration.invariance_weight,
        paper,
        bounds: BOX.to_vec(),
        defaults: design[0].evaluation.clone(),
        best: Best {
            params: BOX
                .iter()
                .map(|d| d.key)
                .zip(best_eval.values.iter().copied())
                .collect(),
            search: best_eval,
            fresh,
            fresh_runs: params.runs_per_point,
        },
        sensitivity,
        verdict,
        best_params,
        evaluations: log.into_iter().map(|r| r.evaluation).collect(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fueling::parameters::CalibrationConfig;

    /// The calibration of `params` towards `target`, whole: the design, its refinement and
    /// the summary of both.
    fn calibrate(params: &FuelingParams, seed: u64, target: (f64, f64)) -> Calibration {
        let design = design(params, seed, Shard::ALL, Some(2), target).expect("design");
        let refinement = refine(params, seed, &design, Some(2), target).expect("refine");
        assemble(params, seed, &design, refinement.as_ref(), target)
            .expect("assemble")
            .expect("the search is on")
    }

    fn small() -> FuelingParams {
        FuelingParams {
            warmup_s: 30.0,
            invariance_amplitudes_deg: vec![1.0],
            invariance_periods_s: vec![10.0],
            calibration: CalibrationConfig {
                invariance_weight: 0.0,
                design_sets: Some(12),
                runs_per_set: Some(60),
                refine_starts: Some(1),
                refine_iterations: Some(40),
                ..CalibrationConfig::default()
            },
            runs_per_point: 60,
            ..FuelingParams::default()
        }
    }

    #[test]
    fn search_finds_a_planted_optimum() {
        // Aim at the ratios the defaults themselves give on the search streams: a set with
        // exactly those ratios exists in the box (the defaults), so the search must return
        // one whose ratios match them within their standard errors.
        let params = small();
        let seed = 4;
        let planted = evaluator(&params, Some(2), (0.0, 0.0))
            .evaluate(
                &[unit_of(&params)],
                false,
                run_seed(seed, SEARCH_STREAM),
                60,
            )
            .expect("defaults")
            .remove(0);
        let target = (planted.kf1.ratio, planted.kf2.ratio);
        let c = calibrate(&params, seed, target);
        let b = &c.best.search;
        assert!(
            (b.kf1.ratio - target.0).abs() <= b.kf1.se,
            "{b:?} vs {target:?}"
        );
        assert!(
            (b.kf2.ratio - target.1).abs() <= b.kf2.se,
            "{b:?} vs {target:?}"
        );
        assert!(c.searched > 12, "the refinement evaluated sets");
        // The best design set alone is not that close: the refinement did the work, or the
        // test would not show that it works. (Logged for the reader, not asserted: whether
        // a 12-set design lands within one SE is luck.)
        let design_best = c.evaluations[..12]
            .iter()
            .map(|e| e.cost)
            .fold(f64::INFINITY, f64::min);
        eprintln!(
            "best design cost {design_best}, after refinement {}",
            b.cost
        );
    }

    #[test]
    fn a_sharded_design_is_the_whole_design_and_its_records_round_trip() {
        let mut params = small();
        params.calibration.design_sets = Some(7);
        params.calibration.runs_per_set = Some(8);
        let paper = (0.4, 0.25);
        let whole = design(&params, 9, Shard::ALL, Some(2), paper).expect("whole");
        assert_eq!(whole.len(), 8, "the configured set and the 7 of the design");
        let mut pieces = Vec::new();
        for index in 1..=3 {
            pieces.extend(
                design(&params, 9, Shard { index, count: 3 }, Some(1), paper).expect("shard"),
            );
        }
        assert_eq!(pieces, whole, "each set is evaluated alike in any shard");
        assert!(
            whole.iter().all(|d| d.runs_used == 8 * 2),
            "headline + one corner, 8 runs each"
        );
        for d in &whole {
            let back = DesignRecord::from_row(&d.to_row()).expect("width");
            assert_eq!(
                back.to_row()
                    .iter()
                    .map(|x| x.to_bits())
                    .collect::<Vec<_>>(),
                d.to_row().iter().map(|x| x.to_bits()).collect::<Vec<_>>()
            );
        }
        // The refinement refuses a design with a set missing.
        let err = refine(&params, 9, &whole[1..], Some(1), paper).expect_err("short");
        assert!(err.to_string().contains(DESIGN_FILE), "{err}");
    }
}
