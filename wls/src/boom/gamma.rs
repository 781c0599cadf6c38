//! Running the estimator over a whole turn with constant measurement errors, and choosing the
//! sensor offset angle γ: sweep γ, record the worst errors per γ, report the feasible window
//! and the smallest feasible γ (see the equations in [`crate::boom`]).

use serde::{Deserialize, Serialize};

use super::config::BoomConfig;
use super::estimator::BoomEstimator;
use super::profile::TrajectoryPoint;
use crate::error::{Error, Result};

/// The sign of a constant error variant (serialised as the paper writes it: "+", "-").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Sign {
    /// The paper's "+" variant.
    #[serde(rename = "+")]
    Plus,
    /// The paper's "−" variant.
    #[serde(rename = "-")]
    Minus,
    /// No error.
    #[serde(rename = "nominal")]
    Nominal,
}

impl Sign {
    /// The label reports use: "+", "-" or "nominal".
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Sign::Plus => "+",
            Sign::Minus => "-",
            Sign::Nominal => "nominal",
        }
    }

    /// +1, −1 or 0.
    #[must_use]
    pub fn factor(self) -> f64 {
        match self {
            Sign::Plus => 1.0,
            Sign::Minus => -1.0,
            Sign::Nominal => 0.0,
        }
    }
}

/// A constant measurement error added to every reading of a turn: the paper's "+" and "−"
/// variants add ±Δa to a_x and a_y. The variant is its sign and its size; the bias vector
/// is derived from them, so a measurement model can never see one without the other.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorVariant {
    /// Which variant.
    pub sign: Sign,
    /// Δa, m/s² (≥ 0).
    pub size: f64,
}

impl ErrorVariant {
    /// The paper's "+" variant: +Δa on a_x and a_y.
    #[must_use]
    pub fn plus(delta_a: f64) -> Self {
        Self {
            sign: Sign::Plus,
            size: delta_a,
        }
    }

    /// The paper's "−" variant: −Δa on a_x and a_y.
    #[must_use]
    pub fn minus(delta_a: f64) -> Self {
        Self {
            sign: Sign::Minus,
            size: delta_a,
        }
    }

    /// No error.
    #[must_use]
    pub fn nominal() -> Self {
        Self {
            sign: Sign::Nominal,
            size: 0.0,
        }
    }

    /// The error added to (a_x, a_y, a_z), m/s².
    #[must_use]
    pub fn bias(&self) -> [f64; 3] {
        let b = self.sign.factor() * self.size;
        [b, b, 0.0]
    }

    /// The label reports use: "+", "-" or "nominal".
    #[must_use]
    pub fn label(&self) -> &'static str {
        self.sign.label()
    }
}

/// The ideal accelerometer of eq. (1) with the offset angle γ, plus the variant's bias:
/// a_x = g·sin(α − γ), a_y = g·cos(α − γ) + ε·r, a_z = 0 (no centripetal term, as the paper).
pub fn ideal_accelerometer(
    g: f64,
    sensor_radius: f64,
) -> impl Fn(&TrajectoryPoint, f64, &ErrorVariant) -> [f64; 3] {
    move |p, gamma, v| {
        let beta = p.alpha - gamma;
        let bias = v.bias();
        [
            g * beta.sin() + bias[0],
            g * beta.cos() + p.epsilon * sensor_radius + bias[1],
            bias[2],
        ]
    }
}

/// Allowed errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// Δα, rad.
    pub angle: f64,
    /// Δε, rad/s².
    pub angular_acceleration: f64,
}

impl Limits {
    /// The paper's Δα = 1°, Δε = 0.5 °/s².
    #[must_use]
    pub fn paper() -> Self {
        Self {
            angle: 1f64.to_radians(),
            angular_acceleration: 0.5f64.to_radians(),
        }
    }
}

/// One cycle of a turn compared with the nominal trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CycleError {
    /// Time, s.
    pub t: f64,
    /// Nominal α, rad.
    pub alpha: f64,
    /// |α̂ − α_n|, rad (∞ when undefined).
    pub angle_error: f64,
    /// |ε̂ − ε_n|, rad/s² (∞ when undefined).
    pub epsilon_error: f64,
    /// The estimator's flag.
    pub defined: bool,
    /// The estimator's condition number.
    pub condition_number: f64,
}

/// A whole turn under one error variant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TurnRun {
    /// The variant's sign.
    pub sign: Sign,
    /// Per-cycle errors; the first cycle (start-up) is included here but excluded from the
    /// maxima below.
    pub cycles: Vec<CycleError>,
    /// max |α̂ − α_n| over all cycles but the first, rad.
    pub max_angle_error: f64,
    /// max |ε̂ − ε_n| over all cycles but the first, rad/s².
    pub max_epsilon_error: f64,
    /// The first cycle (after start-up) whose angle or ε error exceeds the limits: (t, α_n).
    pub first_violation: Option<(f64, f64)>,
    /// The first cycle (after start-up) the estimate is undefined: (t, α_n).
    pub first_undefined: Option<(f64, f64)>,
}

impl TurnRun {
    /// A turn under the variant `sign` with no cycle yet, room for `capacity` cycles.
    pub fn new(sign: Sign, capacity: usize) -> Self {
        Self {
            sign,
            cycles: Vec::with_capacity(capacity),
            max_angle_error: 0.0,
            max_epsilon_error: 0.0,
            first_violation: None,
            first_undefined: None,
        }
    }

    /// Appends the next cycle at the nominal point `p`: `estimate` is (α̂, ε̂), `None` when
    /// the estimator gives none that cycle (its errors count as ∞). From the second cycle on
    /// (the first is start-up) it updates the maxima, the first violation of `limits` and
    /// the first undefined cycle.
    pub fn push(
        &mut self,
        p: &TrajectoryPoint,
        estimate: Option<(f64, f64)>,
        condition_number: f64,
        limits: Limits,
    ) {
        let (da, de) = estimate.map_or((f64::INFINITY, f64::INFINITY), |(a, e)| {
            ((a - p.alpha).abs(), (e - p.epsilon).abs())
        });
        let startup = self.cycles.is_empty();
        self.cycles.push(CycleError {
            t: p.t,
            alpha: p.alpha,
            angle_error: da,
            epsilon_error: de,
            defined: estimate.is_some(),
            condition_number,
        });
        if startup {
            return;
        }
        self.max_angle_error = self.max_angle_error.max(da);
        self.max_epsilon_error = self.max_epsilon_error.max(de);
        if self.first_violation.is_none() && (da > limits.angle || de > limits.angular_acceleration)
        {
            self.first_violation = Some((p.t, p.alpha));
        }
        if self.first_undefined.is_none() && estimate.is_none() {
            self.first_undefined = Some((p.t, p.alpha));
        }
    }
}

/// Runs a fresh estimator over `trajectory` with readings from `measure(point, γ, variant)`
/// (`FnMut`: a measurement model may draw noise from its own generator).
///
/// # Errors
/// An invalid configuration or limit, or a non-finite reading from `measure`.
pub fn run_turn<M: FnMut(&TrajectoryPoint, f64, &ErrorVariant) -> [f64; 3]>(
    trajectory: &[TrajectoryPoint],
    config: &BoomConfig,
    mut measure: M,
    variant: &ErrorVariant,
    limits: Limits,
) -> Result<TurnRun> {
    for (name, value) in [
        ("limits.angle", limits.angle),
        ("limits.angular_acceleration", limits.angular_acceleration),
    ] {
        if !value.is_finite() || value <= 0.0 {
            return Err(Error::InvalidParameter {
                name,
                value,
                rule: "must be finite and > 0",
            });
        }
    }
    let mut est = BoomEstimator::new(config.clone())?;
    let gamma = config.sensor_offset_angle;
    let mut run = TurnRun::new(variant.sign, trajectory.len());
    for p in trajectory {
        let [ax, ay, az] = measure(p, gamma, variant);
        let e = est.update(ax, ay, az)?;
        let estimate = e.defined.then_some((e.angle, e.angular_acceleration));
        run.push(p, estimate, e.condition_number, limits);
    }
    Ok(run)
}

/// The worst errors at one γ over all variants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GammaRow {
    /// γ, rad.
    pub gamma: f64,
    /// max over variants of the max angle error, rad.
    pub max_angle_error: f64,
    /// max over variants of the max ε error, rad/s².
    pub max_epsilon_error: f64,
    /// Both within the limits.
    pub feasible: bool,
}

/// The result of [`sweep_gamma`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GammaSweepReport {
    /// One row per γ, in the order given.
    pub rows: Vec<GammaRow>,
    /// The smallest feasible γ, rad.
    pub smallest_feasible: Option<f64>,
    /// The contiguous run of feasible γ (in sweep order) that starts at the smallest feasible
    /// γ: (first, last), rad.
    pub window: Option<(f64, f64)>,
}

/// Sweeps γ over `gammas` (rad, increasing), running every variant at each γ.
///
/// # Errors
/// As [`run_turn`]; an empty or non-increasing γ list or empty variant list.
pub fn sweep_gamma<M: FnMut(&TrajectoryPoint, f64, &ErrorVariant) -> [f64; 3]>(
    trajectory: &[TrajectoryPoint],
    base: &BoomConfig,
    mut measure: M,
    variants: &[ErrorVariant],
    gammas: &[f64],
    limits: Limits,
) -> Result<GammaSweepReport> {
    if gammas.is_empty() || variants.is_empty() {
        return Err(Error::Shape {
            name: if gammas.is_empty() {
                "gammas"
            } else {
                "variants"
            },
            rows: 0,
            cols: 1,
            expected: "at least one entry".into(),
        });
    }
    for (i, &g) in gammas.iter().enumerate() {
        if !g.is_finite() {
            return Err(Error::NonFinite {
                name: "gammas",
                row: i,
                col: 0,
                value: g,
            });
        }
        if i > 0 && g <= gammas[i - 1] {
            return Err(Error::InvalidParameter {
                name: "gammas",
                value: g,
                rule: "γ values must increase strictly",
            });
        }
    }
    let mut rows = Vec::with_capacity(gammas.len());
    for &gamma in gammas {
        let config = BoomConfig {
            sensor_offset_angle: gamma,
            ..base.clone()
        };
        let (mut da, mut de) = (0.0_f64, 0.0_f64);
        for v in variants {
            let run = run_turn(trajectory, &config, &mut measure, v, limits)?;
            da = da.max(run.max_angle_error);
            de = de.max(run.max_epsilon_error);
        }
        rows.push(GammaRow {
            gamma,
            max_angle_error: da,
            max_epsilon_error: de,
            feasible: da <= limits.angle && de <= limits.angular_acceleration,
        });
    }
    let first = rows.iter().position(|r| r.feasible);
    let window = first.map(|i| {
        let last = rows[i..]
            .iter()
            .take_while(|r| r.feasible)
            .last()
            .map_or(rows[i].gamma, |r| r.gamma);
        (rows[i].gamma, last)
    });
    Ok(GammaSweepReport {
        smallest_feasible: first.map(|i| rows[i].gamma),
        window,
        rows,
    })
}
