//! The calibration's search space: the box of plausible values of the parameters the paper
//! does not state, its map to the unit cube (log scale for ranges spanning more than a
//! decade), and the space-filling design (a maximin Latin hypercube) the search starts from.

use serde::Serialize;

use super::parameters::FuelingParams;
use crate::montecarlo::run_rng;
use rand::seq::SliceRandom;

/// How a parameter's range is mapped to the unit interval.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Scale {
    /// Uniform in the value.
    Linear,
    /// Uniform in the logarithm (ranges spanning more than a decade).
    Log,
}

/// One searched parameter: its configuration key and plausible range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Dim {
    /// The `FuelingParams` key.
    pub key: &'static str,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// How the range is sampled.
    pub scale: Scale,
}

impl Dim {
    /// The value at `u` ∈ [0, 1].
    pub fn value(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        match self.scale {
            Scale::Linear => self.lo + u * (self.hi - self.lo),
            Scale::Log => (self.lo.ln() + u * (self.hi.ln() - self.lo.ln())).exp(),
        }
    }

    /// The unit coordinate of `x` (outside [0, 1] for a value outside the range).
    pub fn unit(&self, x: f64) -> f64 {
        match self.scale {
            Scale::Linear => (x - self.lo) / (self.hi - self.lo),
            Scale::Log => (x.ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln()),
        }
    }
}

/// The box searched: the ranges a sea platform, a fuelling pump and a float-type level
/// sensor plausibly span (see the report for why each bound is where it is).
pub const BOX: [Dim; 10] = [
    dim("rolling_period_s", 6.0, 20.0, Scale::Linear),
    dim("irregularity_per_s", 0.02, 0.3, Scale::Log),
    dim("velocity_std_mm_s", 0.2, 3.0, Scale::Log),
    dim("velocity_time_s", 5.0, 100.0, Scale::Log),
    dim("damper_time_s", 0.5, 4.0, Scale::Log),
    dim("step_mm", 1.0, 20.0, Scale::Log),
    dim("sensor_radius_m", 0.5, 3.0, Scale::Linear),
    dim("sensor_angle_deg", 0.0, 90.0, Scale::Linear),
    dim("fill_rate_mm_s", 5.0, 20.0, Scale::Linear),
    dim("gyro_noise_deg", 0.0, 0.5, Scale::Linear),
];

const fn dim(key: &'static str, lo: f64, hi: f64, scale: Scale) -> Dim {
    Dim { key, lo, hi, scale }
}

/// The value of searched parameter `k` (index into [`BOX`]) in `p`.
pub fn get(p: &FuelingParams, k: usize) -> f64 {
    match k {
        0 => p.rolling_period_s,
        1 => p.irregularity_per_s,
        2 => p.velocity_std_mm_s,
        3 => p.velocity_time_s,
        4 => p.damper_time_s,
        5 => p.step_mm,
        6 => p.sensor_radius_m,
        7 => p.sensor_angle_deg,
        8 => p.fill_rate_mm_s,
        _ => p.gyro_noise_deg,
    }
}

fn set(p: &mut FuelingParams, k: usize, v: f64) {
    let slot = match k {
        0 => &mut p.rolling_period_s,
        1 => &mut p.irregularity_per_s,
        2 => &mut p.velocity_std_mm_s,
        3 => &mut p.velocity_time_s,
        4 => &mut p.damper_time_s,
        5 => &mut p.step_mm,
        6 => &mut p.sensor_radius_m,
        7 => &mut p.sensor_angle_deg,
        8 => &mut p.fill_rate_mm_s,
        _ => &mut p.gyro_noise_deg,
    };
    *slot = v;
}

/// `base` with the searched parameters at unit coordinates `u`.
pub fn params_at(base: &FuelingParams, u: &[f64]) -> FuelingParams {
    let mut p = base.clone();
    for (k, (d, x)) in BOX.iter().zip(u).enumerate() {
        set(&mut p, k, d.value(*x));
    }
    p
}

/// The unit coordinates of `p`'s searched parameters.
pub fn unit_of(p: &FuelingParams) -> Vec<f64> {
    BOX.iter()
        .enumerate()
        .map(|(k, d)| d.unit(get(p, k)))
        .collect()
}

/// A maximin Latin hypercube: of `candidates` random Latin hypercubes of `n` points in
/// `dims` dimensions (cell centres, one point per cell in every coordinate), the one whose
/// closest pair is farthest apart.
pub fn latin_hypercube(n: usize, dims: usize, candidates: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = run_rng(seed, 0);
    let mut best: (f64, Vec<Vec<f64>>) = (f64::NEG_INFINITY, Vec::new());
    for _ in 0..candidates.max(1) {
        let cols: Vec<Vec<f64>> = (0..dims)
            .map(|_| {
                let mut perm: Vec<usize> = (0..n).collect();
                perm.shuffle(&mut rng);
                perm.into_iter()
                    .map(|k| (k as f64 + 0.5) / n as f64)
                    .collect()
            })
            .collect();
        let pts: Vec<Vec<f64>> = (0..n)
            .map(|i| cols.iter().map(|c| c[i]).collect())
            .collect();
        let mut closest = f64::INFINITY;
        for i in 0..n {
            for j in i + 1..n {
                let d: f64 = pts[i]
                    .iter()
                    .zip(&pts[j])
                    .map(|(a, b)| (a - b).powi(2))
                    .sum();
                closest = closest.min(d);
            }
        }
        if closest > best.0 || best.1.is_empty() {
            best = (closest, pts);
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_maps_to_the_unit_cube_and_back() {
        let p = FuelingParams::default();
        let u = unit_of(&p);
        for (k, x) in u.iter().enumerate() {
            assert!(
                (0.0..=1.0).contains(x),
                "{}: default outside the box",
                BOX[k].key
            );
        }
        let back = params_at(&p, &u);
        for k in 0..BOX.len() {
            // exp∘ln round trip: a few ulps.
            assert!((get(&back, k) - get(&p, k)).abs() <= 1e-12 * get(&p, k).abs().max(1.0));
        }
        for d in BOX {
            assert!((d.value(0.0) - d.lo).abs() < 1e-12 * d.hi.max(1.0));
            assert!((d.value(1.0) - d.hi).abs() < 1e-12 * d.hi.max(1.0));
        }
    }

    #[test]
    fn latin_hypercube_fills_every_stratum_once() {
        let n = 16;
        let pts = latin_hypercube(n, 4, 5, 3);
        assert_eq!(pts.len(), n);
        for d in 0..4 {
            let mut cells: Vec<usize> = pts.iter().map(|p| (p[d] * n as f64) as usize).collect();
            cells.sort_unstable();
            assert_eq!(cells, (0..n).collect::<Vec<_>>(), "dimension {d}");
        }
        // Maximin over more candidates cannot make the closest pair closer.
        let closest = |pts: &[Vec<f64>]| {
            let mut c = f64::INFINITY;
            for i in 0..pts.len() {
                for j in i + 1..pts.len() {
                    let d: f64 = pts[i]
                        .iter()
                        .zip(&pts[j])
                        .map(|(a, b)| (a - b).powi(2))
                        .sum();
                    c = c.min(d);
                }
            }
            c
        };
        assert!(closest(&latin_hypercube(n, 4, 30, 3)) >= closest(&latin_hypercube(n, 4, 1, 3)));
    }
}
