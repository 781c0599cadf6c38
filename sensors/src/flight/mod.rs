//! A simulated flight-test record: the true flight of a manoeuvre sequence ([`Manoeuvres`])
//! and what its instruments record — an IMU (specific force and body rates with biases and
//! white noise), air data (true airspeed, angle of attack and sideslip, each with a scale
//! factor and a bias), an AHRS (Euler angles) and GNSS (position) — each at its own rate,
//! with jittered time stamps, dropouts and a few wild points.
//!
//! The instrument-error model is the one of flight-path reconstruction (Klein & Morelli,
//! *Aircraft System Identification*, 2006, ch. 10; Mulder et al., "Non-linear aircraft
//! flight path reconstruction review and new advances", Prog. Aerospace Sci. 35, 1999):
//!
//! - IMU: `a_m = a + b_a + n_a`, `ω_m = ω + b_ω + n_ω` (three axes each);
//! - air data: `V_m = (1 + λ_V) V + b_V + n_V`, `α_m = (1 + λ_α) α + b_α + n_α`,
//!   `β_m = (1 + λ_β) β + b_β + n_β`, with `V = |v_air|`, `α = atan2(w, u)`,
//!   `β = asin(v / V)` of the air-relative body velocity;
//! - AHRS: `(φ, θ, ψ) + n` (ψ wrapped to (−π, π]); GNSS: `(north, east, altitude) + n`.
//!
//! Sample i of a sensor of period T is taken at `(i + ½)T + j_i T` (the IMU at `iT + j_i T`,
//! its first sample at 0) with `j_i` uniform in `±jitter/2`, and stamped with that time.
//! A sensor's dropouts remove its samples over intervals of the configured length; a wild
//! point adds `±wild_sigma` noise standard deviations to every channel of one sample (not
//! for the IMU, which drives the integration as an input rather than being compared with a
//! prediction). Every sample draws the same normals whatever the options.

mod truth;

use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

use crate::error::{Error, finite, in_range, non_negative, positive};
use crate::process::normal;
use truth::Flight;
pub use truth::{GRAVITY, Manoeuvres, TruthPoint};

const D2R: f64 = std::f64::consts::PI / 180.0;

/// The instrument errors of a flight (degrees in this struct; SI inside).
///
/// ```
/// let e = sensors::flight::InstrumentErrors::default().si();
/// assert!((e[3] - 0.2_f64.to_radians()).abs() < 1e-15); // gyro p bias, rad/s
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InstrumentErrors {
    /// Accelerometer biases (x, y, z), m/s².
    pub accel_bias_mps2: [f64; 3],
    /// Gyro biases (p, q, r), deg/s.
    pub gyro_bias_dps: [f64; 3],
    /// Airspeed scale factor λ_V (dimensionless).
    pub airspeed_scale: f64,
    /// Airspeed bias b_V, m/s.
    pub airspeed_bias_mps: f64,
    /// Angle-of-attack scale factor λ_α.
    pub alpha_scale: f64,
    /// Angle-of-attack bias b_α, deg.
    pub alpha_bias_deg: f64,
    /// Sideslip scale factor λ_β.
    pub beta_scale: f64,
    /// Sideslip bias b_β, deg.
    pub beta_bias_deg: f64,
}

impl Default for InstrumentErrors {
    fn default() -> Self {
        Self {
            accel_bias_mps2: [0.05, -0.04, 0.08],
            gyro_bias_dps: [0.2, -0.15, 0.1],
            airspeed_scale: 0.03,
            airspeed_bias_mps: 0.5,
            alpha_scale: 0.08,
            alpha_bias_deg: 0.5,
            beta_scale: -0.05,
            beta_bias_deg: -0.3,
        }
    }
}

impl InstrumentErrors {
    /// The errors in SI units, in the order of the filter's augmented state: accelerometer
    /// biases (m/s²), gyro biases (rad/s), then (λ_V, b_V (m/s), λ_α, b_α (rad), λ_β,
    /// b_β (rad)).
    pub fn si(&self) -> [f64; 12] {
        let g = self.gyro_bias_dps;
        let a = self.accel_bias_mps2;
        [
            a[0],
            a[1],
            a[2],
            g[0] * D2R,
            g[1] * D2R,
            g[2] * D2R,
            self.airspeed_scale,
            self.airspeed_bias_mps,
            self.alpha_scale,
            self.alpha_bias_deg * D2R,
            self.beta_scale,
            self.beta_bias_deg * D2R,
        ]
    }
}

/// One sensor's timing and record defects.
///
/// ```
/// let gnss = sensors::flight::FlightConfig::default().gnss;
/// assert_eq!((gnss.dropouts, gnss.wild_points), (2, 3));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorTiming {
    /// Nominal sample rate, Hz.
    pub rate_hz: f64,
    /// Dropouts (gaps with no sample) over the flight.
    pub dropouts: usize,
    /// Length of each dropout, s.
    pub dropout_s: f64,
    /// Wild points over the flight (ignored for the IMU).
    pub wild_points: usize,
}

/// The configuration of a simulated flight (defaults: a 120 s sequence, IMU at 100 Hz, air
/// data and AHRS at 25 Hz, GNSS at 5 Hz).
///
/// ```
/// let c = sensors::flight::FlightConfig { duration_s: 60.0, ..Default::default() };
/// assert!((c.imu.rate_hz - 100.0).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlightConfig {
    /// Length of the flight, s; the manoeuvre sequence is stretched to it (120).
    pub duration_s: f64,
    /// The manoeuvres.
    pub manoeuvres: Manoeuvres,
    /// Constant wind (north, east), m/s ((0, 0)).
    pub wind_mps: [f64; 2],
    /// The true instrument errors.
    pub errors: InstrumentErrors,
    /// Stamp jitter as a fraction of each sensor's period (uniform in ±jitter/2; 0.2).
    pub jitter: f64,
    /// Size of a wild point, noise standard deviations (15).
    pub wild_sigma: f64,
    /// IMU timing (100 Hz, one 0.05 s dropout, no wild points).
    pub imu: SensorTiming,
    /// Accelerometer white noise per sample, m/s² (0.002).
    pub accel_noise_mps2: f64,
    /// Gyro white noise per sample, deg/s (0.002).
    pub gyro_noise_dps: f64,
    /// Air-data timing (25 Hz, two 0.5 s dropouts, three wild points).
    pub air_data: SensorTiming,
    /// Airspeed noise, m/s (0.2).
    pub airspeed_noise_mps: f64,
    /// Angle-of-attack and sideslip noise, deg (0.1).
    pub flow_angle_noise_deg: f64,
    /// AHRS timing (25 Hz, two 0.5 s dropouts, three wild points).
    pub ahrs: SensorTiming,
    /// AHRS angle noise, deg (0.2).
    pub attitude_noise_deg: f64,
    /// GNSS timing (5 Hz, two 1 s dropouts, three wild points).
    pub gnss: SensorTiming,
    /// GNSS horizontal noise, m (0.5).
    pub horizontal_noise_m: f64,
    /// GNSS vertical noise, m (1).
    pub vertical_noise_m: f64,
}

impl Default for FlightConfig {
    fn default() -> Self {
        let timing = |rate_hz, dropouts, dropout_s, wild_points| SensorTiming {
            rate_hz,
            dropouts,
            dropout_s,
            wild_points,
        };
        Self {
            duration_s: 120.0,
            manoeuvres: Manoeuvres::default(),
            wind_mps: [0.0, 0.0],
            errors: InstrumentErrors::default(),
            jitter: 0.2,
            wild_sigma: 15.0,
            imu: timing(100.0, 1, 0.05, 0),
            accel_noise_mps2: 0.002,
            gyro_noise_dps: 0.002,
            air_data: timing(25.0, 2, 0.5, 3),
            airspeed_noise_mps: 0.2,
            flow_angle_noise_deg: 0.1,
            ahrs: timing(25.0, 2, 0.5, 3),
            attitude_noise_deg: 0.2,
            gnss: timing(5.0, 2, 1.0, 3),
            horizontal_noise_m: 0.5,
            vertical_noise_m: 1.0,
        }
    }
}

impl FlightConfig {
    /// The noise standard deviations in SI, per channel: IMU (a_x, a_y, a_z in m/s²; p, q, r
    /// in rad/s), air data (V m/s, α, β rad), AHRS (rad), GNSS (m).
    pub fn noise_si(&self) -> NoiseLevels {
        let (a, g) = (self.accel_noise_mps2, self.gyro_noise_dps * D2R);
        let f = self.flow_angle_noise_deg * D2R;
        let e = self.attitude_noise_deg * D2R;
        let (h, v) = (self.horizontal_noise_m, self.vertical_noise_m);
        NoiseLevels {
            imu: [a, a, a, g, g, g],
            air: [self.airspeed_noise_mps, f, f],
            ahrs: [e; 3],
            gnss: [h, h, v],
        }
    }

    fn validate(&self) -> Result<(), Error> {
        in_range("duration_s", self.duration_s, 10.0, 3600.0)?;
        in_range("jitter", self.jitter, 0.0, 0.8)?;
        non_negative("wild_sigma", self.wild_sigma)?;
        for (name, v) in [
            ("accel_noise_mps2", self.accel_noise_mps2),
            ("gyro_noise_dps", self.gyro_noise_dps),
            ("airspeed_noise_mps", self.airspeed_noise_mps),
            ("flow_angle_noise_deg", self.flow_angle_noise_deg),
            ("attitude_noise_deg", self.attitude_noise_deg),
            ("horizontal_noise_m", self.horizontal_noise_m),
            ("vertical_noise_m", self.vertical_noise_m),
        ] {
            positive(name, v)?;
        }
        for (name, t) in [
            ("imu.rate_hz", &self.imu),
            ("air_data.rate_hz", &self.air_data),
            ("ahrs.rate_hz", &self.ahrs),
            ("gnss.rate_hz", &self.gnss),
        ] {
            in_range(name, t.rate_hz, 0.5, 1000.0)?;
            in_range("dropout_s", t.dropout_s, 0.0, 0.1 * self.duration_s)?;
        }
        let m = &self.manoeuvres;
        in_range("manoeuvres.airspeed_mps", m.airspeed_mps, 20.0, 300.0)?;
        in_range(
            "manoeuvres.speed_change_mps",
            m.speed_change_mps,
            -0.5 * m.airspeed_mps,
            m.airspeed_mps,
        )?;
        for (name, v, lim) in [
            ("manoeuvres.alpha_deg", m.alpha_deg, 15.0),
            ("manoeuvres.pitch_doublet_deg", m.pitch_doublet_deg, 15.0),
            ("manoeuvres.roll_doublet_deg", m.roll_doublet_deg, 45.0),
            (
                "manoeuvres.sideslip_doublet_deg",
                m.sideslip_doublet_deg,
                10.0,
            ),
            ("manoeuvres.turn_bank_deg", m.turn_bank_deg, 60.0),
            ("manoeuvres.turn_heading_deg", m.turn_heading_deg, 170.0),
            ("manoeuvres.heading_deg", m.heading_deg, 180.0),
        ] {
            in_range(name, v, -lim, lim)?;
        }
        for v in self.wind_mps {
            in_range("wind_mps", v, -50.0, 50.0)?;
        }
        for v in self.errors.si() {
            finite("errors", v)?;
        }
        Ok(())
    }
}

/// Noise standard deviations per channel, SI.
///
/// ```
/// let n = sensors::flight::FlightConfig::default().noise_si();
/// assert!((n.gnss[2] - 1.0).abs() < 1e-12); // vertical, m
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseLevels {
    /// a_x, a_y, a_z (m/s²), p, q, r (rad/s).
    pub imu: [f64; 6],
    /// V (m/s), α, β (rad).
    pub air: [f64; 3],
    /// φ, θ, ψ (rad).
    pub ahrs: [f64; 3],
    /// north, east, altitude (m).
    pub gnss: [f64; 3],
}

/// One recorded sample: its stamp, the reading, the truth at the stamp, and whether it was
/// made a wild point.
///
/// ```
/// use sensors::flight::{FlightConfig, simulate};
/// let rec = simulate(&FlightConfig { duration_s: 10.0, ..Default::default() }, &mut sensors::seeded_rng(2))?;
/// let s = rec.ahrs[0];
/// assert!((s.value[1] - s.truth.euler[1]).abs() < 0.1); // θ within 0.1 rad of the truth
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample<const K: usize> {
    /// Time stamp, s.
    pub t: f64,
    /// The reading, SI.
    pub value: [f64; K],
    /// The truth at `t`.
    pub truth: TruthPoint,
    /// Whether a wild point was added to this sample.
    pub wild: bool,
}

/// A simulated flight's record, one list per sensor in stamp order.
///
/// ```
/// use sensors::flight::{FlightConfig, simulate};
/// let rec = simulate(&FlightConfig { duration_s: 10.0, ..Default::default() }, &mut sensors::seeded_rng(2))?;
/// assert!(rec.air.len() > 200 && rec.gnss.len() > 30);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct FlightRecord {
    /// IMU: (a_x, a_y, a_z, p, q, r).
    pub imu: Vec<Sample<6>>,
    /// Air data: (V, α, β).
    pub air: Vec<Sample<3>>,
    /// AHRS: (φ, θ, ψ).
    pub ahrs: Vec<Sample<3>>,
    /// GNSS: (north, east, altitude).
    pub gnss: Vec<Sample<3>>,
}

/// Stamps of one sensor with its dropouts applied.
fn stamps<R: Rng + ?Sized>(
    t: &SensorTiming,
    jitter: f64,
    duration: f64,
    first_at_zero: bool,
    rng: &mut R,
) -> Vec<f64> {
    let period = 1.0 / t.rate_hz;
    let count = (duration * t.rate_hz).ceil() as usize + 1;
    let offset = if first_at_zero { 0.0 } else { 0.5 };
    let mut gaps = Vec::with_capacity(t.dropouts);
    for _ in 0..t.dropouts {
        let u: f64 = rng.random();
        let start = 0.1 * duration + u * (0.8 * duration - t.dropout_s);
        gaps.push((start, start + t.dropout_s));
    }
    let mut out = Vec::with_capacity(count);
    for i in 0..count {
        let u: f64 = rng.random();
        let j = if first_at_zero && i == 0 {
            0.0
        } else {
            jitter * (u - 0.5)
        };
        let s = (i as f64 + offset + j) * period;
        if s > duration {
            // The IMU covers the whole flight: its last sample is at or after the end.
            if first_at_zero {
                out.push(s);
            }
            break;
        }
        if !gaps.iter().any(|&(a, b)| s >= a && s < b) {
            out.push(s);
        }
    }
    out
}

/// The wild-point indices of a sensor with `len` samples (distinct, sorted).
fn wild_indices<R: Rng + ?Sized>(count: usize, len: usize, rng: &mut R) -> Vec<usize> {
    let mut out: Vec<usize> = Vec::with_capacity(count);
    for _ in 0..count {
        let u: f64 = rng.random();
        out.push(((u * len as f64) as usize).min(len.saturating_sub(1)));
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// Simulates one flight of `config` from `rng`: its truth and every sensor's record.
///
/// ```
/// use sensors::flight::{FlightConfig, simulate};
/// let config = FlightConfig { duration_s: 20.0, ..FlightConfig::default() };
/// let record = simulate(&config, &mut sensors::seeded_rng(1))?;
/// // 100 Hz IMU over 20 s, less one 0.05 s dropout.
/// assert!(record.imu.len() > 1990 && record.imu.len() <= 2001);
/// assert!(record.gnss.iter().all(|s| s.t > 0.0 && s.t <= 20.0));
/// # Ok::<(), sensors::Error>(())
/// ```
///
/// # Errors
/// [`Error`] naming the first configuration value out of its range.
pub fn simulate<R: Rng + ?Sized>(
    config: &FlightConfig,
    rng: &mut R,
) -> Result<FlightRecord, Error> {
    config.validate()?;
    let flight = Flight::new(config.manoeuvres, config.duration_s, config.wind_mps);
    let (d, j) = (config.duration_s, config.jitter);
    let st = [
        stamps(&config.imu, j, d, true, rng),
        stamps(&config.air_data, j, d, false, rng),
        stamps(&config.ahrs, j, d, false, rng),
        stamps(&config.gnss, j, d, false, rng),
    ];
    // Truth at every stamp, the position integrated along the merged stamps.
    let mut events: Vec<(f64, usize, usize)> = st
        .iter()
        .enumerate()
        .flat_map(|(s, ts)| ts.iter().enumerate().map(move |(i, &t)| (t, s, i)))
        .collect();
    events.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut truths: [Vec<TruthPoint>; 4] =
        std::array::from_fn(|s| vec![TruthPoint::default(); st[s].len()]);
    let mut pos = [0.0, 0.0, 1000.0];
    let mut last = 0.0;
    for &(t, s, i) in &events {
        flight.advance(last, t, &mut pos);
        last = t;
        let mut p = flight.at(t);
        p.position = pos;
        truths[s][i] = p;
    }
    let e = config.errors.si();
    let n = config.noise_si();
    let wild = [
        Vec::new(),
        wild_indices(config.air_data.wild_points, st[1].len(), rng),
        wild_indices(config.ahrs.wild_points, st[2].len(), rng),
        wild_indices(config.gnss.wild_points, st[3].len(), rng),
    ];
    let ws = config.wild_sigma;
    let imu = readings(&truths[0], &wild[0], &n.imu, ws, rng, |tp| {
        [
            tp.specific_force[0] + e[0],
            tp.specific_force[1] + e[1],
            tp.specific_force[2] + e[2],
            tp.rates[0] + e[3],
            tp.rates[1] + e[4],
            tp.rates[2] + e[5],
        ]
    });
    let air = readings(&truths[1], &wild[1], &n.air, ws, rng, |tp| {
        let v = tp.air_velocity;
        let speed = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let (alpha, beta) = (v[2].atan2(v[0]), (v[1] / speed).asin());
        [
            (1.0 + e[6]) * speed + e[7],
            (1.0 + e[8]) * alpha + e[9],
            (1.0 + e[10]) * beta + e[11],
        ]
    });
    let mut ahrs = readings(&truths[2], &wild[2], &n.ahrs, ws, rng, |tp| tp.euler);
    for s in &mut ahrs {
        s.value[2] = wrap(s.value[2]);
    }
    let gnss = readings(&truths[3], &wild[3], &n.gnss, ws, rng, |tp| tp.position);
    Ok(FlightRecord {
        imu,
        air,
        ahrs,
        gnss,
    })
}

/// One sensor's samples at the truths' stamps: `clean` of each truth plus white noise of
/// standard deviations `sd`, and at the indices in `wild` (sorted) a wild point of
/// `wild_sigma`·σ with a random sign on every channel.
fn readings<R: Rng + ?Sized, const K: usize>(
    truths: &[TruthPoint],
    wild: &[usize],
    sd: &[f64; K],
    wild_sigma: f64,
    rng: &mut R,
    clean: impl Fn(&TruthPoint) -> [f64; K],
) -> Vec<Sample<K>> {
    truths
        .iter()
        .enumerate()
        .map(|(i, tp)| {
            let is_wild = wild.binary_search(&i).is_ok();
            let clean = clean(tp);
            let mut value = [0.0; K];
            for ((o, c), sd) in value.iter_mut().zip(&clean).zip(sd) {
                let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
                *o = c + sd * normal(rng) + if is_wild { sign * wild_sigma * sd } else { 0.0 };
            }
            Sample {
                t: tp.t,
                value,
                truth: *tp,
                wild: is_wild,
            }
        })
        .collect()
}

/// An angle wrapped to (−π, π].
///
/// ```
/// assert!((sensors::flight::wrap(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
/// ```
pub fn wrap(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let w = a - two_pi * (a / two_pi).round();
    if w <= -std::f64::consts::PI {
        w + two_pi
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without noise and errors, the air data read the truth's (V, α, β) exactly and GNSS the
    /// integrated position; the position's integral matches the velocity (dead reckoning by
    /// the trapezoid rule on the 100 Hz stamps agrees to 1 cm over 20 s).
    #[test]
    fn clean_record_reads_the_truth() {
        let config = FlightConfig {
            duration_s: 20.0,
            ..FlightConfig::default()
        };
        let rec = simulate(&config, &mut crate::seeded_rng(3)).expect("valid");
        let v0 = rec.air[0].truth.air_velocity;
        let speed = (v0[0] * v0[0] + v0[1] * v0[1] + v0[2] * v0[2]).sqrt();
        assert!((speed - 100.0).abs() < 1e-9);
        // Trapezoid dead reckoning of the north position from the IMU-stamp truths.
        let mut north = rec.imu[0].truth.position[0];
        for w in rec.imu.windows(2) {
            let rate = |p: &TruthPoint| {
                let c = truth::dcm(p.euler);
                c[0][0] * p.velocity[0] + c[0][1] * p.velocity[1] + c[0][2] * p.velocity[2]
            };
            north += 0.5 * (w[1].t - w[0].t) * (rate(&w[0].truth) + rate(&w[1].truth));
        }
        let last = rec.imu.last().expect("samples").truth.position[0];
        assert!((north - last).abs() < 0.01, "{north} vs {last}");
        assert_eq!(rec.gnss.iter().filter(|s| s.wild).count(), 3);
    }

    #[test]
    fn a_bad_value_is_named() {
        let config = FlightConfig {
            jitter: 2.0,
            ..FlightConfig::default()
        };
        let err = simulate(&config, &mut crate::seeded_rng(3)).expect_err("refused");
        assert!(matches!(err, Error::OutOfRange { name: "jitter", .. }));
    }

    #[test]
    fn wrap_is_in_range() {
        for a in [-7.0, -3.2, 0.0, 3.2, 7.0, std::f64::consts::PI] {
            let w = wrap(a);
            assert!(w > -std::f64::consts::PI - 1e-15 && w <= std::f64::consts::PI);
            assert!(((a - w) / (2.0 * std::f64::consts::PI)).fract().abs() < 1e-12);
        }
    }
}
