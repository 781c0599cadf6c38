//! The fueling report's sections on margins and calibration, formatted from the summary: the
//! tail quantiles and 3σ band of every strategy, how the ratio intervals are computed, and
//! the calibration's box, best set, sensitivity and verdict (every number comes from
//! `statistics` and `calibration`; nothing is computed here but differences for display), and
//! the sections on learning the model back from one record (`learned`) and on the
//! exact-likelihood particle filter (`particle`).

use std::fmt::Write as _;
use std::path::Path;

use super::calibration_records::{Calibration, Evaluation, Gap};
use super::learned::{Learned, LearnedBack};
use super::parameters::FuelingParams;
use super::records::{STRATEGIES, STRATEGY_LABELS};
use super::search::{BOX, Scale, get};
use super::statistics::RatioCi;
use super::summary::{ParticleComparison, Summary};
use crate::error::{Error, Result};

fn f2(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2}")
    } else {
        "—".into()
    }
}

/// Three significant digits for parameter values of any size.
fn g3(x: f64) -> String {
    if !x.is_finite() {
        "—".into()
    } else if x.abs() >= 100.0 {
        format!("{x:.0}")
    } else if x.abs() >= 10.0 {
        format!("{x:.1}")
    } else if x.abs() >= 1.0 {
        format!("{x:.2}")
    } else {
        format!("{x:.3}")
    }
}

fn with_ci(r: &RatioCi) -> String {
    format!("{} [{}, {}]", f2(r.ratio), f2(r.lo), f2(r.hi))
}

fn with_se(r: &RatioCi) -> String {
    format!("{} ± {}", f2(r.ratio), f2(r.se))
}

/// Why each bound of the box is where it is.
fn why(key: &str) -> &'static str {
    match key {
        "rolling_period_s" => "roll periods of moored platforms and ships",
        "irregularity_per_s" => "narrow-band swell (0.02) to a short wind sea (0.3)",
        "velocity_std_mm_s" => "pump-rate fluctuation of 1–60 % of the fill rate",
        "velocity_time_s" => "pump and line transients to slow supply-pressure drift",
        "damper_time_s" => "hydro-damper of a float or stilling-well sensor",
        "step_mm" => "discrete level sensors (reed chains, capacitive steps)",
        "sensor_radius_m" => "sensor inside a tank of a few metres' radius",
        "sensor_angle_deg" => "roll and pitch are alike, so 0–90° covers every azimuth",
        "fill_rate_mm_s" => "the campaign's fill-rate sweep",
        "gyro_noise_deg" => "the paper gives no gyro accuracy: ideal to a poor MEMS unit",
        _ => "",
    }
}

/// `## Tails and intervals`: the margins at the headline point.
pub fn tails_section(sm: &Summary) -> String {
    let m = &sm.margins;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Tails and intervals: what a safety margin needs (A_max = {}°, {} runs)\n\n\
         An ullage sized on the standard deviation alone assumes a normal error; the table \
         gives the tail itself. Quantiles: linear interpolation between order statistics \
         (Hyndman–Fan type 7). The 1 %–99 % width of a normal error is 4.65σ; a wider one \
         means heavier tails than the standard deviation suggests. A ratio std(strategy)/\
         std(relay) over the same runs has a 95 % interval by the delta method: \
         log r = ½(log s_a² − log s_b²), SE(log r) = √(Var(u_a − u_b)/(4n)) with \
         u = (x − x̄)²/s² estimated from the runs themselves (heavy tails and the correlation \
         of two strategies that see the same world are both in it), interval r·exp(±1.96·SE). \
         A range over a sweep (max − min of the per-point random errors: growth with \
         amplitude, variation with period, the invariance spread) and a ratio of two ranges \
         are not smooth in the runs; their 95 % intervals are percentile-bootstrap ones: {} \
         resamples of the run indices, one draw for every point of the sweep (run i of every \
         point shares a random stream), the 2.5 % and 97.5 % quantiles of the recomputed \
         statistic. A range of noisy estimates is biased upward by each point's own noise; \
         its interval describes the range as estimated from these runs.\n",
        m.amplitude_deg,
        sm.runs_per_point,
        super::statistics::RESAMPLES
    );
    s.push_str(
        "| strategy | std / relay [95 % CI] | 1 % | 5 % | 95 % | 99 % | mean ± 3σ | outside ± 3σ | 1–99 % width / σ |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    let top = sm
        .amplitude_sweep
        .iter()
        .find(|e| (e.at["amplitude_deg"] - m.amplitude_deg).abs() < 1e-12)
        .map(|e| e.stats);
    for (i, label) in STRATEGY_LABELS.iter().enumerate() {
        let t = m.tails.get(i);
        let std = top.map_or(f64::NAN, |st| st.get(i).std_mm);
        let _ = writeln!(
            s,
            "| {label} | {} | {} | {} | {} | {} | {} … {} | {:.2} % | {} |",
            with_ci(m.ratios.get(i)),
            f2(t.q01_mm),
            f2(t.q05_mm),
            f2(t.q95_mm),
            f2(t.q99_mm),
            f2(t.band_lo_mm),
            f2(t.band_hi_mm),
            100.0 * t.outside_band,
            f2((t.q99_mm - t.q01_mm) / std),
        );
    }
    let width = |i: usize| m.tails.get(i).q99_mm - m.tails.get(i).q01_mm;
    let narrowest = (0..STRATEGIES.len())
        .filter(|&i| width(i).is_finite())
        .min_by(|a, b| width(*a).total_cmp(&width(*b)));
    if let Some(i) = narrowest {
        let _ = writeln!(
            s,
            "\nErrors in mm. The narrowest 1 %–99 % range is the {}'s: {} mm, against relay \
             logic's {} mm.\n",
            STRATEGY_LABELS[i],
            f2(width(i)),
            f2(width(0))
        );
    }
    s
}

fn evaluation_row(s: &mut String, label: &str, e: &Evaluation, interval: bool) {
    let fmt = if interval { with_ci } else { with_se };
    let _ = writeln!(
        s,
        "| {label} | {} | {} | {} mm | {} | {} |",
        fmt(&e.kf1),
        fmt(&e.kf2),
        f2(e.relay_std_mm),
        if e.spread.is_finite() {
            format!("{:.0} %", 100.0 * e.spread)
        } else {
            "—".into()
        },
        f2(e.cost)
    );
}

fn gap_sentence(name: &str, g: &Gap, tol: f64) -> String {
    let o = &g.ours;
    if g.gap > 0.0 {
        format!(
            "the {name} ratio's interval [{}, {}] lies {} above the paper's {} ± {tol}",
            f2(o.lo),
            f2(o.hi),
            f2(g.gap),
            f2(g.paper)
        )
    } else if g.gap < 0.0 {
        format!(
            "the {name} ratio's interval [{}, {}] lies {} below the paper's {} ± {tol}",
            f2(o.lo),
            f2(o.hi),
            f2(-g.gap),
            f2(g.paper)
        )
    } else if g.gap.is_nan() {
        format!("the {name} ratio could not be computed")
    } else {
        format!(
            "the {name} ratio {} reaches the paper's {} ± {tol}",
            with_ci(o),
            f2(g.paper)
        )
    }
}

/// `## Calibration`: the box, the search, the best set on the search and a fresh seed, the
/// sensitivity around it and the verdict.
pub fn section(c: &Calibration, p: &FuelingParams) -> String {
    let mut s = String::new();
    let b = &c.best;
    let _ = writeln!(
        s,
        "## Calibration: is there a set of the unstated parameters under which both ratios hold?\n\n\
         The paper does not state the parameters below. The search minimises \
         J = ‖(r₁ − {}, r₂ − {})‖ + {}·s + 10·f, where r₁ and r₂ are the one- and two-channel \
         filters' random error over relay logic's at {}°, s the two-channel filter's spread \
         (max − min)/max over the amplitude × period corners {} (0 = the paper's \"fully \
         invariant\") and f the fraction of runs without a stop. All sets run on the same \
         {} streams (common random numbers: J is deterministic and sets differ by their \
         parameters, not by luck): a maximin Latin hypercube of {} sets, then Nelder–Mead \
         (argmin) — {} sets in all, {} Monte Carlo runs including the sensitivity and the \
         fresh check (search `{:?}`; `[calibration] search = \"long\"` in a `--config` file \
         runs 2048 sets × 400 runs with four refinements). Every set: `calibration_sets.csv`.\n",
        f2(c.paper.0),
        f2(c.paper.1),
        c.invariance_weight,
        c.amplitude_deg,
        c.corners
            .iter()
            .map(|(a, t)| format!("({a}°, {t} s)"))
            .collect::<Vec<_>>()
            .join(", "),
        c.runs_per_set,
        c.design_sets,
        c.searched,
        c.runs_used,
        c.search,
    );
    s.push_str(
        "| parameter | box | scale | why the bounds | configured | best |\n|---|---|---|---|---|---|\n",
    );
    for (k, d) in BOX.iter().enumerate() {
        let best = b.params.get(d.key).copied().unwrap_or(f64::NAN);
        let at_bound = c.verdict.at_bounds.contains(&d.key);
        let _ = writeln!(
            s,
            "| `{}` | {}–{} | {} | {} | {} | {}{} |",
            d.key,
            d.lo,
            d.hi,
            match d.scale {
                Scale::Linear => "linear",
                Scale::Log => "log",
            },
            why(d.key),
            g3(get(p, k)),
            g3(best),
            if at_bound { " (at the bound)" } else { "" }
        );
    }
    let _ = writeln!(
        s,
        "\n| set | one-channel / relay | two-channel / relay | relay std | spread s | J |\n\
         |---|---|---|---|---|---|"
    );
    evaluation_row(
        &mut s,
        &format!("configured, search streams ({} runs, ± SE)", c.runs_per_set),
        &c.defaults,
        false,
    );
    evaluation_row(
        &mut s,
        &format!("best, search streams ({} runs, ± SE)", c.runs_per_set),
        &b.search,
        false,
    );
    evaluation_row(
        &mut s,
        &format!(
            "best, fresh seed {} ({} runs, [95 % CI])",
            c.fresh_seed, b.fresh_runs
        ),
        &b.fresh,
        true,
    );
    let _ = writeln!(
        s,
        "| the paper | ≈ {} | ≈ {} | — | \"fully invariant\" | — |\n",
        f2(c.paper.0),
        f2(c.paper.1)
    );

    // Sensitivity, most influential first.
    let swing = |x: &[f64; 2], at: f64| (x[0] - at).abs().max((x[1] - at).abs());
    let mut sens: Vec<_> = c.sensitivity.iter().collect();
    let (r1, r2) = (b.search.kf1.ratio, b.search.kf2.ratio);
    sens.sort_by(|a, z| {
        let key =
            |e: &&super::calibration_records::Sensitivity| swing(&e.kf1, r1).max(swing(&e.kf2, r2));
        key(z).total_cmp(&key(a))
    });
    let _ = writeln!(
        s,
        "One at a time around the best set (each parameter ± a tenth of its box, clipped to \
         it; search streams, so the differences are the parameter's alone):\n\n\
         | parameter | values | one-channel ratio | two-channel ratio |\n|---|---|---|---|"
    );
    for e in &sens {
        let _ = writeln!(
            s,
            "| `{}` | {} / {} | {} / {} | {} / {} |",
            e.key,
            g3(e.values[0]),
            g3(e.values[1]),
            f2(e.kf1[0]),
            f2(e.kf1[1]),
            f2(e.kf2[0]),
            f2(e.kf2[1])
        );
    }
    let top_of = |pick: fn(&super::calibration_records::Sensitivity) -> [f64; 2], at: f64| {
        let mut v: Vec<_> = c
            .sensitivity
            .iter()
            .map(|e| (e.key, swing(&pick(e), at)))
            .collect();
        v.sort_by(|a, b| b.1.total_cmp(&a.1));
        v.iter()
            .take(2)
            .map(|(k, d)| format!("`{k}` (± {})", f2(*d)))
            .collect::<Vec<_>>()
            .join(" and ")
    };
    let _ = writeln!(
        s,
        "\nThe one-channel ratio moves most with {}; the two-channel ratio with {}.\n",
        top_of(|e| e.kf1, r1),
        top_of(|e| e.kf2, r2)
    );

    // Verdict, from the fresh-seed intervals.
    let v = &c.verdict;
    let tol = v.tolerance;
    let _ = write!(s, "**Verdict.** ");
    if v.reproduced {
        let _ = write!(
            s,
            "Reproduced inside the box: on a fresh seed the best set gives one-channel {} and \
             two-channel {}, both reaching the paper's figures read as ± {tol}.",
            with_ci(&v.kf1.ours),
            with_ci(&v.kf2.ours)
        );
    } else {
        let misses: Vec<String> = [("one-channel", &v.kf1), ("two-channel", &v.kf2)]
            .iter()
            .map(|(n, g)| gap_sentence(n, g, tol))
            .collect();
        let _ = write!(
            s,
            "Not reached inside the box: at the closest set the search found (fresh seed), {}. \
             The distance ‖(r₁ − {}, r₂ − {})‖ there is {}, against {} at the configured \
             parameters.",
            misses.join("; "),
            f2(c.paper.0),
            f2(c.paper.1),
            f2((v.kf1.ours.ratio - c.paper.0).hypot(v.kf2.ours.ratio - c.paper.1)),
            f2((c.defaults.kf1.ratio - c.paper.0).hypot(c.defaults.kf2.ratio - c.paper.1)),
        );
    }
    if v.at_bounds.is_empty() {
        s.push_str(" No parameter of the best set is at a bound of the box.");
    } else {
        let _ = write!(
            s,
            " At a bound of the box: {} — the search pushes against these limits, so a wider \
             range there (if physically plausible) might come closer.",
            v.at_bounds
                .iter()
                .map(|k| format!("`{k}`"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let _ = writeln!(
        s,
        " The two-channel filter's spread over the corners is {} at the best set (fresh seed) \
         against {} at the configured parameters: {}.\n\n\
         `calibration.toml` beside this report is the best set as a `--config` file (search \
         off): `scenarios fueling --config calibration.toml` reruns the whole report under it.\n",
        pct(b.fresh.spread),
        pct(c.defaults.spread),
        if b.fresh.spread < 0.1 {
            "invariant within 10 %, as the paper says"
        } else {
            "not the paper's full invariance"
        }
    );
    s
}

fn pct(x: f64) -> String {
    if x.is_finite() {
        format!("{:.0} %", 100.0 * x)
    } else {
        "—".into()
    }
}

/// Writes `calibration.toml` (the best set as a `--config` file) and `calibration_sets.csv`
/// (every set the search evaluated) into `dir`.
///
/// # Errors
/// [`Error::Write`] naming the file; [`Error::SerialiseToml`] if the parameters do not
/// serialise.
pub fn write_files(c: &Calibration, dir: &Path) -> Result<()> {
    let body = toml::to_string(&c.best_params).map_err(|source| Error::SerialiseToml {
        dest: dir.join("calibration.toml").display().to_string(),
        source,
    })?;
    let text = format!(
        "# The calibration's best set (seed {}, {} sets searched): rerun the report under it\n\
         # with `scenarios fueling --config calibration.toml`.\n{body}",
        c.search_seed, c.searched
    );
    crate::output::write_atomic(&dir.join("calibration.toml"), text.as_bytes())?;
    let mut header: Vec<&str> = BOX.iter().map(|d| d.key).collect();
    header.extend([
        "kf1_ratio",
        "kf1_se",
        "kf2_ratio",
        "kf2_se",
        "relay_std_mm",
        "spread",
        "no_stop",
        "cost",
    ]);
    let rows: Vec<Vec<f64>> = c
        .evaluations
        .iter()
        .map(|e| {
            let mut row = e.values.clone();
            row.extend([
                e.kf1.ratio,
                e.kf1.se,
                e.kf2.ratio,
                e.kf2.se,
                e.relay_std_mm,
                e.spread,
                e.no_stop,
                e.cost,
            ]);
            row
        })
        .collect();
    crate::output::write_csv(&dir.join("calibration_sets.csv"), &header, &rows)
}

/// The "Paper F learned back" section: the fits of one simulated record beside the truth,
/// with their 95 % Wald intervals, and the verdict those intervals give.
pub fn learned_section(l: &LearnedBack) -> String {
    let mut s = format!(
        "## Paper F learned back: the model from the data it filters\n\n\
         One simulated record of {:.0} min ({} samples at Δt = {} s; its own random stream \
         of the campaign seed) of the gyro and the level sensor, and the paper's model \
         parameters fitted to it by maximum likelihood (`kalman::fit`, L-BFGS with the exact \
         score; standard errors from the observed information on the log scale the fit \
         works in, so each 95 % Wald interval is estimate·e^(±1.96·s.e. of its log)), next \
         to the values that simulated it. The rolling is fitted to the gyro's tilt toward \
         the sensor (an irregular rolling; `model`'s shaping filter discretised exactly at \
         Δt); the classical estimate beside it is least squares of the correlation function \
         on the sample autocovariance up to lag 3/μ. The fill-rate fluctuation is fitted to \
         the level sensor's reading through a three-state model (level, fluctuation, damper) \
         with the gyro's tilt as a known input and the quantizer's error taken as white \
         noise of variance δ²/12 — which it is not: the question is whether the fit \
         survives that.\n\n\
         | parameter | truth | MLE | s.e. | 95 % Wald interval | covers the truth | autocorrelation LS |\n\
         |---|---|---|---|---|---|---|\n",
        l.samples as f64 * l.dt_s / 60.0,
        l.samples,
        l.dt_s
    );
    let all = || l.rolling.iter().chain(&l.fill);
    for p in all() {
        let [lo, hi] = p.interval95;
        let _ = writeln!(
            s,
            "| {} | {:.4} | {:.4} | {} | {} | {} | {} |",
            p.name,
            p.truth,
            p.estimate,
            if p.std_error.is_finite() {
                format!("{:.4}", p.std_error)
            } else {
                "—".into()
            },
            if lo.is_finite() && hi.is_finite() {
                format!("[{lo:.4}, {hi:.4}]")
            } else {
                "none (information not positive definite)".into()
            },
            if p.covered() {
                format!("yes ({:+.2} s.e.)", p.z())
            } else if p.std_error.is_finite() {
                format!("**no** ({:+.2} s.e.)", p.z())
            } else {
                "—".into()
            },
            p.classical.map_or("—".to_string(), |c| format!("{c:.4}"))
        );
    }
    let missed = |ps: &[Learned]| -> Vec<String> {
        ps.iter()
            .filter(|p| !p.covered())
            .map(|p| {
                if p.std_error.is_finite() {
                    format!("{} ({:+.1} s.e.)", p.name, p.z())
                } else {
                    format!("{} (no standard error)", p.name)
                }
            })
            .collect()
    };
    let (rolling_missed, fill_missed) = (missed(&l.rolling), missed(&l.fill));
    s.push('\n');
    if !l.converged {
        let _ = write!(
            s,
            "A fit stopped before its convergence test (rolling: {}; fill: {}); read its rows \
             with care. ",
            l.messages[0], l.messages[1]
        );
    }
    s.push_str(&match (rolling_missed.is_empty(), fill_missed.is_empty()) {
        (true, true) => "**Yes:** every 95 % interval covers the value that simulated it — \
             the rolling from the gyro, and the fill-rate fluctuation through the quantizer \
             too, so the paper's model can be learned from the data it filters (one record: \
             one interval in twenty misses by chance).\n"
            .to_string(),
        (true, false) => format!(
            "**The rolling, yes; the fill-rate fluctuation, not through the quantizer:** the \
             rolling's intervals cover its truth, but not {} — the quantizer's correlated \
             error, taken as white, biases what the level sensor says about the fluctuation \
             (or this is the one interval in twenty that misses by chance).\n",
            fill_missed.join(", ")
        ),
        (false, true) => format!(
            "**The fill-rate fluctuation, yes; the rolling, not from this record:** the \
             intervals of {} miss the truth.\n",
            rolling_missed.join(", ")
        ),
        (false, false) => format!(
            "**No:** the intervals of {} miss the truth.\n",
            rolling_missed
                .iter()
                .chain(&fill_missed)
                .cloned()
                .collect::<Vec<_>>()
                .join(", ")
        ),
    });
    s.push('\n');
    s
}

/// `0.5°, 1°` for a list of amplitudes.
pub(super) fn list_deg(v: &[f64]) -> String {
    v.iter()
        .map(|a| format!("{a}°"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The "exact quantized likelihood" section: the particle filter beside the paper's
/// two-channel KF at every amplitude, on the same runs, and the verdict from the intervals.
pub fn particle_section(c: &ParticleComparison) -> String {
    let mut s = format!(
        "## Beyond the paper: the quantizer's exact likelihood\n\n\
         The Kalman filters read the level sensor as the level plus white noise of variance \
         δ²/12. A bootstrap particle filter ({} particles, systematic resampling when the \
         effective sample size falls below N/2) weights instead by what a reading says: the \
         damper's level lay in the reading's quantization interval. Its model is the world's \
         own (level, fill-velocity fluctuation, damper, and the tilt channel's reading as the \
         tilt), so the gap between it and the KF bounds what a better treatment of the \
         quantizer can gain. The first {} runs of each amplitude, the same worlds as the \
         sweep's; intervals are the delta-method 95 % intervals of the ratios on the paired \
         runs.\n\n\
         | A_max [°] | PF mean ± std, mm | KF mean ± std, mm | std PF/relay | std KF/relay | \
         std PF/KF | PF never stopped | PF restarted |\n\
         |---|---|---|---|---|---|---|---|\n",
        c.particles, c.runs
    );
    for e in &c.entries {
        let _ = writeln!(
            s,
            "| {} | {} ± {} | {} ± {} | {} | {} | {} | {} | {} |",
            e.amplitude_deg,
            f2(e.particle.mean_mm),
            f2(e.particle.std_mm),
            f2(e.kf2.mean_mm),
            f2(e.kf2.std_mm),
            with_ci(&e.particle_to_relay),
            with_ci(&e.kf2_to_relay),
            with_ci(&e.particle_to_kf2),
            e.runs_without_stop,
            e.runs_restarted
        );
    }
    let v = &c.verdict;
    s.push('\n');
    s.push_str(&match (v.better_deg.is_empty(), v.worse_deg.is_empty()) {
        (false, true) if v.undecided_deg.is_empty() => format!(
            "**The exact likelihood wins at every amplitude:** the particle filter's random \
             error is below the two-channel KF's beyond the 95 % interval at {}.\n",
            list_deg(&v.better_deg)
        ),
        (false, true) => format!(
            "**The exact likelihood wins at {}** (the whole interval of std PF/KF below 1); \
             at {} the intervals do not tell them apart.\n",
            list_deg(&v.better_deg),
            list_deg(&v.undecided_deg)
        ),
        (true, true) => format!(
            "**No difference shown:** at every amplitude ({}) the interval of std PF/KF \
             contains 1 — the white-noise reading costs the KF nothing these runs can see.\n",
            list_deg(&v.undecided_deg)
        ),
        (better, _) => format!(
            "**Mixed:** the particle filter is better at {}, worse at {}{}.\n",
            if better {
                "no amplitude".to_string()
            } else {
                list_deg(&v.better_deg)
            },
            list_deg(&v.worse_deg),
            if v.undecided_deg.is_empty() {
                String::new()
            } else {
                format!(", undecided at {}", list_deg(&v.undecided_deg))
            }
        ),
    });
    if let (Some(first), Some(last)) = (c.entries.first(), c.entries.last()) {
        let _ = writeln!(
            s,
            "\nstd PF/KF goes from {} at {}° to {} at {}°{}. The particle filter's mean \
             error ({} mm at {}°) is the stop's wait for the first step at or past H* (half \
             a step's rise, V_c·Δt/2); the KF's adds the floor quantizer's δ/2.",
            with_ci(&first.particle_to_kf2),
            first.amplitude_deg,
            with_ci(&last.particle_to_kf2),
            last.amplitude_deg,
            if last.particle_to_kf2.hi < first.particle_to_kf2.lo {
                ": the more the rolling moves the damper's level across the sensor's marks, \
                 the more each reading's interval says, and the more of it the white-noise \
                 reading leaves unused"
            } else {
                ""
            },
            f2(last.particle.mean_mm),
            last.amplitude_deg
        );
    }
    s.push('\n');
    s
}
