//! A flight record as the estimators see it: each sensor's time-stamped samples
//! ([`FlightData`], from the simulation or from a user's CSV), and the filter's time grid
//! built from them ([`Grid`]: the union of every stamp, the IMU input of each step, the
//! measurements with NaN where a sensor did not sample).

use crate::error::{Error, Result};

/// Measurements per step: air data (V, α, β), AHRS (φ, θ, ψ), GNSS (north, east, altitude).
pub const M: usize = 9;

/// One sensor's samples: (stamp, reading) in stamp order, SI units.
pub type Channel<const K: usize> = Vec<(f64, [f64; K])>;

/// A flight record, one channel per sensor.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FlightData {
    /// IMU: (a_x, a_y, a_z) m/s², (p, q, r) rad/s.
    pub imu: Channel<6>,
    /// Air data: V m/s, α rad, β rad.
    pub air: Channel<3>,
    /// AHRS: φ, θ, ψ rad.
    pub ahrs: Channel<3>,
    /// GNSS: north m, east m, altitude m.
    pub gnss: Channel<3>,
}

/// The IMU readings at the three stage times of one Runge–Kutta step (start, midpoint, end).
pub type Stages = [[f64; 6]; 3];

/// The filter's grid over a record.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Stamps t_k (strictly increasing), s.
    pub t: Vec<f64>,
    /// IMU readings for the step from t_k to t_{k+1} at its Runge–Kutta stage times
    /// (t_k, the midpoint, t_{k+1}), interpolated by [`FlightData::imu_at`].
    pub input: Vec<Stages>,
    /// Measurements z_k (NaN where not sampled), in the model's output order.
    pub z: Vec<[f64; M]>,
}

/// The distinct stamps of several sorted stamp lists, merged (equal stamps once).
pub fn union_of_stamps(lists: &[&[f64]]) -> Vec<f64> {
    let mut t: Vec<f64> = lists.iter().flat_map(|l| l.iter().copied()).collect();
    t.sort_by(f64::total_cmp);
    t.dedup_by(|a, b| a.to_bits() == b.to_bits());
    t
}

impl FlightData {
    /// Checks that every channel is in strictly increasing, finite stamp order and the IMU
    /// has at least two samples.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming `source` and the channel.
    pub fn check(&self, source: &str) -> Result<()> {
        fn sorted<const K: usize>(c: &Channel<K>, name: &str, source: &str) -> Result<()> {
            for w in c.windows(2) {
                if w[1].0.partial_cmp(&w[0].0) != Some(std::cmp::Ordering::Greater) {
                    return Err(Error::invalid(
                        source,
                        format!("{name} stamps must increase: {} then {}", w[0].0, w[1].0),
                    ));
                }
            }
            if c.iter()
                .any(|(t, v)| !t.is_finite() || v.iter().any(|x| !x.is_finite()))
            {
                return Err(Error::invalid(
                    source,
                    format!("{name}: a value is not finite"),
                ));
            }
            Ok(())
        }
        sorted(&self.imu, "IMU", source)?;
        sorted(&self.air, "air data", source)?;
        sorted(&self.ahrs, "AHRS", source)?;
        sorted(&self.gnss, "GNSS", source)?;
        if self.imu.len() < 2 {
            return Err(Error::invalid(
                source,
                "the IMU (ax, ay, az, p, q, r) needs at least two samples",
            ));
        }
        if self.air.is_empty() || self.ahrs.is_empty() || self.gnss.is_empty() {
            return Err(Error::invalid(
                source,
                "air data, AHRS and GNSS each need at least one sample",
            ));
        }
        Ok(())
    }

    /// The IMU reading at time t: the cubic through the four samples around t (Lagrange on
    /// their actual stamps; fewer at the ends of the record), held beyond the ends. `hint`
    /// is the index of the last sample at or before the previous t (the calls come in time
    /// order). A linear interpolant would leave a systematic error of `Δt³ ä / 12` per
    /// interval in the integrated input (trapezoid rule), which over a doublet's half
    /// period is ten times the angle and velocity random walk of the IMU's own noise and
    /// would act as process noise the filter does not model; the cubic's is `O(Δt⁵)`.
    pub fn imu_at(&self, t: f64, hint: &mut usize) -> [f64; 6] {
        let imu = &self.imu;
        while *hint + 1 < imu.len() && imu[*hint + 1].0 <= t {
            *hint += 1;
        }
        let i = *hint;
        // Before the first sample the hint is still 0; after the last it is the last.
        if t <= imu[0].0 || i + 1 == imu.len() {
            return imu[i].1;
        }
        let nodes = &imu[i.saturating_sub(1)..(i + 3).min(imu.len())];
        let mut out = [0.0; 6];
        for (j, (tj, vj)) in nodes.iter().enumerate() {
            let w: f64 = nodes
                .iter()
                .enumerate()
                .filter(|&(m, _)| m != j)
                .map(|(_, (tm, _))| (t - tm) / (tj - tm))
                .product();
            for (o, v) in out.iter_mut().zip(vj) {
                *o += w * v;
            }
        }
        out
    }

    /// The grid: every distinct stamp of every channel.
    pub fn grid(&self) -> Grid {
        let stamps = |c: &[(f64, [f64; 3])]| c.iter().map(|s| s.0).collect::<Vec<f64>>();
        let imu_t: Vec<f64> = self.imu.iter().map(|s| s.0).collect();
        let (a, e, g) = (stamps(&self.air), stamps(&self.ahrs), stamps(&self.gnss));
        let t = union_of_stamps(&[&imu_t, &a, &e, &g]);
        let mut z = vec![[f64::NAN; M]; t.len()];
        for (offset, channel) in [(0, &self.air), (3, &self.ahrs), (6, &self.gnss)] {
            let mut k = 0;
            for (ts, v) in channel {
                while t[k].to_bits() != ts.to_bits() {
                    k += 1;
                }
                z[k][offset..offset + 3].copy_from_slice(v);
            }
        }
        let mut hint = 0;
        let input = (0..t.len())
            .map(|k| {
                let end = t.get(k + 1).copied().unwrap_or(t[k]);
                [t[k], 0.5 * (t[k] + end), end].map(|ts| self.imu_at(ts, &mut hint))
            })
            .collect();
        Grid { t, input, z }
    }

    /// The initial kinematic state at the grid's first stamp from the first reading of each
    /// sensor (uncorrected): velocity from (V, α, β), attitude from the AHRS, position from
    /// GNSS carried back to `t0` along that velocity.
    pub fn initial_state(&self, t0: f64) -> [f64; 9] {
        let (_, [v, al, be]) = self.air[0];
        let (_, e) = self.ahrs[0];
        let (tg, p) = self.gnss[0];
        let vel = [
            v * al.cos() * be.cos(),
            v * be.sin(),
            v * al.sin() * be.cos(),
        ];
        let (sf, cf) = e[0].sin_cos();
        let (st, ct) = e[1].sin_cos();
        let (sp, cp) = e[2].sin_cos();
        let n = vel[0] * ct * cp
            + vel[1] * (sf * st * cp - cf * sp)
            + vel[2] * (cf * st * cp + sf * sp);
        let east = vel[0] * ct * sp
            + vel[1] * (sf * st * sp + cf * cp)
            + vel[2] * (cf * st * sp - sf * cp);
        let up = vel[0] * st - vel[1] * sf * ct - vel[2] * cf * ct;
        let back = tg - t0;
        [
            vel[0],
            vel[1],
            vel[2],
            e[0],
            e[1],
            e[2],
            p[0] - n * back,
            p[1] - east * back,
            p[2] - up * back,
        ]
    }
}
