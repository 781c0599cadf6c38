//! The true flight of the flight-path scenario: a manoeuvre sequence written as smooth
//! analytic functions of time (airspeed, angle of attack, sideslip and the three Euler
//! angles), from which the body rates and specific forces follow exactly, and the position
//! by Gauss–Legendre quadrature of the ground velocity.
//!
//! Kinematics (Klein & Morelli, *Aircraft System Identification*, 2006, §3.6; Mulder et al.,
//! "Non-linear aircraft flight path reconstruction review and new advances", Prog.
//! Aerospace Sci. 35, 1999): body velocity `v = (u, v, w)` relative to the air,
//! `u = V cos α cos β`, `v = V sin β`, `w = V sin α cos β`; body rates from the Euler rates,
//! `p = φ̇ − ψ̇ sin θ`, `q = θ̇ cos φ + ψ̇ cos θ sin φ`, `r = −θ̇ sin φ + ψ̇ cos θ cos φ`;
//! specific force `a = v̇ + ω × v − g_b` with `g_b = g (−sin θ, cos θ sin φ, cos θ cos φ)`;
//! ground velocity `C_nb v + w_wind` (north, east, down), altitude up.

use serde::{Deserialize, Serialize};

/// Standard gravity, m/s².
pub const GRAVITY: f64 = 9.806_65;

/// A smooth shape of time: its value and derivative at t.
#[derive(Debug, Clone, Copy)]
struct Jet {
    v: f64,
    d: f64,
}

/// Smooth pulse 0 → 1 → 0 over `[t0, t0 + len]`: `sin⁴(π s)`, `s = (t − t0)/len`. It and
/// its first three derivatives vanish at both ends, so the rates and specific forces it
/// drives (its first derivative enters them) are twice continuously differentiable, as a
/// real vehicle's are; a raised cosine would put a kink into them at every start and stop,
/// which no interpolation of the IMU samples can follow.
fn bump(t: f64, t0: f64, len: f64) -> Jet {
    let s = (t - t0) / len;
    if !(0.0..=1.0).contains(&s) {
        return Jet { v: 0.0, d: 0.0 };
    }
    let (sn, cs) = (std::f64::consts::PI * s).sin_cos();
    Jet {
        v: sn.powi(4),
        d: 4.0 * std::f64::consts::PI * sn.powi(3) * cs / len,
    }
}

/// Smooth ramp 0 → 1 over `[t0, t0 + len]`, 1 afterwards: the integral of the [`bump`]
/// shape scaled to end at 1, `s − (2/3π) sin 2πs + (1/12π) sin 4πs`, whose derivative
/// `(8/3) sin⁴(π s)` is as smooth at the ends as the pulse.
fn ramp(t: f64, t0: f64, len: f64) -> Jet {
    let s = (t - t0) / len;
    if s <= 0.0 {
        return Jet { v: 0.0, d: 0.0 };
    }
    if s >= 1.0 {
        return Jet { v: 1.0, d: 0.0 };
    }
    let pi = std::f64::consts::PI;
    Jet {
        v: s - 2.0 / (3.0 * pi) * (2.0 * pi * s).sin() + 1.0 / (12.0 * pi) * (4.0 * pi * s).sin(),
        d: 8.0 / 3.0 * (pi * s).sin().powi(4) / len,
    }
}

/// A doublet: a pulse up over `[t0, t0 + len/2]`, then one down.
fn doublet(t: f64, t0: f64, len: f64) -> Jet {
    let a = bump(t, t0, 0.5 * len);
    let b = bump(t, t0 + 0.5 * len, 0.5 * len);
    Jet {
        v: a.v - b.v,
        d: a.d - b.d,
    }
}

/// The manoeuvre sequence, scaled to the configured duration: pitch doublets, roll doublets
/// with a sideslip doublet, a level turn and a speed change (the sequence Klein & Morelli
/// and Mulder et al. use to excite every instrument error).
///
/// ```
/// let m = sensors::flight::Manoeuvres { turn_bank_deg: 20.0, ..Default::default() };
/// assert!((m.airspeed_mps - 100.0).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Manoeuvres {
    /// Trim true airspeed, m/s (100).
    pub airspeed_mps: f64,
    /// Trim angle of attack, deg (3).
    pub alpha_deg: f64,
    /// Initial heading, deg (20).
    pub heading_deg: f64,
    /// Amplitude of the pitch doublets in θ, deg (4; α moves by half of it).
    pub pitch_doublet_deg: f64,
    /// Amplitude of the roll doublets, deg (20).
    pub roll_doublet_deg: f64,
    /// Amplitude of the sideslip doublets that go with them, deg (2).
    pub sideslip_doublet_deg: f64,
    /// Bank angle of the level turn, deg (30).
    pub turn_bank_deg: f64,
    /// Heading change of the turn, deg (120).
    pub turn_heading_deg: f64,
    /// Airspeed change (negative: slowing down), m/s (−20).
    pub speed_change_mps: f64,
}

impl Default for Manoeuvres {
    fn default() -> Self {
        Self {
            airspeed_mps: 100.0,
            alpha_deg: 3.0,
            heading_deg: 20.0,
            pitch_doublet_deg: 4.0,
            roll_doublet_deg: 20.0,
            sideslip_doublet_deg: 2.0,
            turn_bank_deg: 30.0,
            turn_heading_deg: 120.0,
            speed_change_mps: -20.0,
        }
    }
}

/// The true state at one instant: air-relative body velocity, attitude, body rates,
/// specific force, and (filled by the integration) position.
///
/// ```
/// let p = sensors::flight::TruthPoint::default();
/// assert_eq!(p.position, [0.0; 3]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TruthPoint {
    /// Time, s.
    pub t: f64,
    /// Body velocity relative to the ground (u, v, w), m/s.
    pub velocity: [f64; 3],
    /// Body velocity relative to the air, m/s.
    pub air_velocity: [f64; 3],
    /// Euler angles (φ, θ, ψ), rad.
    pub euler: [f64; 3],
    /// Body rates (p, q, r), rad/s.
    pub rates: [f64; 3],
    /// Specific force in body axes, m/s².
    pub specific_force: [f64; 3],
    /// Position (north, east, altitude), m.
    pub position: [f64; 3],
}

/// The analytic flight: `duration` seconds of the sequence of `m`, with a constant wind.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Flight {
    m: Manoeuvres,
    /// Time scale: the sequence is laid out on 120 s and stretched to the duration.
    k: f64,
    wind: [f64; 3],
}

/// `C_nb`, body to north-east-down, row-major.
pub(crate) fn dcm(e: [f64; 3]) -> [[f64; 3]; 3] {
    let (sf, cf) = e[0].sin_cos();
    let (st, ct) = e[1].sin_cos();
    let (sp, cp) = e[2].sin_cos();
    [
        [ct * cp, sf * st * cp - cf * sp, cf * st * cp + sf * sp],
        [ct * sp, sf * st * sp + cf * cp, cf * st * sp - sf * cp],
        [-st, sf * ct, cf * ct],
    ]
}

impl Flight {
    pub(crate) fn new(m: Manoeuvres, duration: f64, wind_ne: [f64; 2]) -> Self {
        Self {
            m,
            k: duration / 120.0,
            wind: [wind_ne[0], wind_ne[1], 0.0],
        }
    }

    /// (V, α, β, φ, θ, ψ) and their time derivatives.
    fn angles(&self, t: f64) -> ([f64; 6], [f64; 6]) {
        let d2r = std::f64::consts::PI / 180.0;
        let m = &self.m;
        let s = |t0: f64| t0 * self.k;
        let len = |l: f64| l * self.k;
        // Pitch doublets at 10 s and 92 s (4 s each), roll doublets at 20 s and 104 s.
        let pitch = [doublet(t, s(10.0), len(4.0)), doublet(t, s(92.0), len(4.0))];
        let roll = [
            doublet(t, s(20.0), len(4.0)),
            doublet(t, s(104.0), len(4.0)),
        ];
        let slip = [
            doublet(t, s(21.0), len(3.0)),
            doublet(t, s(105.0), len(3.0)),
        ];
        // Level turn: bank in over 30–34 s, out over 66–70 s; heading over 30–70 s.
        let bank = ramp(t, s(30.0), len(4.0));
        let unbank = ramp(t, s(66.0), len(4.0));
        let heading = ramp(t, s(30.0), len(40.0));
        // Speed change: slow down over 76–84 s, back over 110–118 s.
        let slow = ramp(t, s(76.0), len(8.0));
        let back = ramp(t, s(110.0), len(8.0));
        let dv = m.speed_change_mps;
        let v = m.airspeed_mps + dv * (slow.v - back.v);
        let vd = dv * (slow.d - back.d);
        // Trim α grows as 1/V² (lift); the pitch doublet moves α by half of θ's move.
        let a_trim = m.alpha_deg * d2r * (m.airspeed_mps / v).powi(2);
        let a_trim_d = -2.0 * a_trim * vd / v;
        let pd = m.pitch_doublet_deg * d2r;
        let pitch_v = pitch[0].v + pitch[1].v;
        let pitch_d = pitch[0].d + pitch[1].d;
        // Turn: α rises with the load factor 1/cos φ_turn.
        let turn = bank.v - unbank.v;
        let turn_d = bank.d - unbank.d;
        let n_extra = 1.0 / (m.turn_bank_deg * d2r).cos() - 1.0;
        let alpha = a_trim * (1.0 + n_extra * turn) + 0.5 * pd * pitch_v;
        let alpha_d =
            a_trim_d * (1.0 + n_extra * turn) + a_trim * n_extra * turn_d + 0.5 * pd * pitch_d;
        let beta = m.sideslip_doublet_deg * d2r * (slip[0].v + slip[1].v);
        let beta_d = m.sideslip_doublet_deg * d2r * (slip[0].d + slip[1].d);
        let phi = m.turn_bank_deg * d2r * turn + m.roll_doublet_deg * d2r * (roll[0].v + roll[1].v);
        let phi_d =
            m.turn_bank_deg * d2r * turn_d + m.roll_doublet_deg * d2r * (roll[0].d + roll[1].d);
        // Level flight: θ = α (flight-path angle zero) plus the doublet's extra half.
        let theta = alpha + 0.5 * pd * pitch_v;
        let theta_d = alpha_d + 0.5 * pd * pitch_d;
        let psi = m.heading_deg * d2r + m.turn_heading_deg * d2r * heading.v;
        let psi_d = m.turn_heading_deg * d2r * heading.d;
        (
            [v, alpha, beta, phi, theta, psi],
            [vd, alpha_d, beta_d, phi_d, theta_d, psi_d],
        )
    }

    /// Air-relative body velocity from (V, α, β) and its derivative.
    fn air_velocity(a: &[f64; 6], d: &[f64; 6]) -> ([f64; 3], [f64; 3]) {
        let (v, al, be) = (a[0], a[1], a[2]);
        let (sa, ca) = al.sin_cos();
        let (sb, cb) = be.sin_cos();
        let vel = [v * ca * cb, v * sb, v * sa * cb];
        let vel_d = [
            d[0] * ca * cb - v * sa * cb * d[1] - v * ca * sb * d[2],
            d[0] * sb + v * cb * d[2],
            d[0] * sa * cb + v * ca * cb * d[1] - v * sa * sb * d[2],
        ];
        (vel, vel_d)
    }

    /// Everything but the position at time t.
    pub(crate) fn at(&self, t: f64) -> TruthPoint {
        let (a, d) = self.angles(t);
        let (air, air_d) = Self::air_velocity(&a, &d);
        let euler = [a[3], a[4], a[5]];
        let (phid, thetad, psid) = (d[3], d[4], d[5]);
        let (sf, cf) = euler[0].sin_cos();
        let (st, ct) = euler[1].sin_cos();
        let rates = [
            phid - psid * st,
            thetad * cf + psid * ct * sf,
            -thetad * sf + psid * ct * cf,
        ];
        // Ground velocity in body axes: air velocity plus the constant wind rotated into the
        // body (its body-frame derivative is −ω × C_bn w).
        let c = dcm(euler);
        let wb = [
            c[0][0] * self.wind[0] + c[1][0] * self.wind[1] + c[2][0] * self.wind[2],
            c[0][1] * self.wind[0] + c[1][1] * self.wind[1] + c[2][1] * self.wind[2],
            c[0][2] * self.wind[0] + c[1][2] * self.wind[1] + c[2][2] * self.wind[2],
        ];
        let vel = [air[0] + wb[0], air[1] + wb[1], air[2] + wb[2]];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let wdot = cross(wb, rates); // d/dt (C_bn w) = −ω × C_bn w = C_bn w × ω
        let vel_d = [air_d[0] + wdot[0], air_d[1] + wdot[1], air_d[2] + wdot[2]];
        let wv = cross(rates, vel);
        let g = [-GRAVITY * st, GRAVITY * ct * sf, GRAVITY * ct * cf];
        let specific_force = [
            vel_d[0] + wv[0] - g[0],
            vel_d[1] + wv[1] - g[1],
            vel_d[2] + wv[2] - g[2],
        ];
        TruthPoint {
            t,
            velocity: vel,
            air_velocity: air,
            euler,
            rates,
            specific_force,
            position: [0.0; 3],
        }
    }

    /// (ṅ, ė, ḣ) at time t.
    fn position_rate(&self, t: f64) -> [f64; 3] {
        let p = self.at(t);
        let c = dcm(p.euler);
        let v = p.velocity;
        let ned: Vec<f64> = (0..3)
            .map(|i| c[i][0] * v[0] + c[i][1] * v[1] + c[i][2] * v[2])
            .collect();
        [ned[0], ned[1], -ned[2]]
    }

    /// Position increment over `[a, b]` by 5-point Gauss–Legendre quadrature (exact to
    /// round-off for the ≤ 10 ms intervals between samples of these smooth functions).
    pub(crate) fn advance(&self, a: f64, b: f64, pos: &mut [f64; 3]) {
        const X: [f64; 5] = [
            0.0,
            -0.538_469_310_105_683,
            0.538_469_310_105_683,
            -0.906_179_845_938_664,
            0.906_179_845_938_664,
        ];
        const W: [f64; 5] = [
            0.568_888_888_888_889,
            0.478_628_670_499_366,
            0.478_628_670_499_366,
            0.236_926_885_056_189,
            0.236_926_885_056_189,
        ];
        if b <= a {
            return;
        }
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        for (x, w) in X.iter().zip(W) {
            let r = self.position_rate(mid + half * x);
            for i in 0..3 {
                pos[i] += half * w * r[i];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each shape's derivative is the central difference of its value (step 1e-6 s, error
    /// ~1e-10), and the pulse's derivative vanishes to third order at its ends: at ε = 1e-3
    /// of its length from an end it is below 4π⁴ε³/len (the leading term) plus round-off,
    /// where a raised cosine's is ~2π²ε/len, six orders larger.
    #[test]
    fn shapes_are_smooth_and_their_derivatives_exact() {
        let (t0, len) = (3.0, 2.0);
        for shape in [bump, ramp] {
            for s in [0.1, 0.37, 0.5, 0.81] {
                let t = t0 + s * len;
                let h = 1e-6;
                let fd = (shape(t + h, t0, len).v - shape(t - h, t0, len).v) / (2.0 * h);
                assert!((fd - shape(t, t0, len).d).abs() < 1e-8, "s = {s}");
            }
        }
        let eps: f64 = 1e-3;
        let pi = std::f64::consts::PI;
        let bound = 4.0 * pi.powi(4) * eps.powi(3) / len + 1e-15;
        for t in [t0 + eps * len, t0 + (1.0 - eps) * len] {
            assert!(bump(t, t0, len).d.abs() < bound, "{}", bump(t, t0, len).d);
        }
        assert!((ramp(t0 + len, t0, len).v - 1.0).abs() < 1e-15);
    }

    /// The specific force and rates are the exact derivatives: a finite difference of the
    /// air velocity and Euler angles reproduces them (step 1e-5 s, error ~1e-9).
    #[test]
    fn rates_match_euler_kinematics() {
        let f = Flight::new(Manoeuvres::default(), 120.0, [0.0, 0.0]);
        for t in [11.3, 22.5, 40.0, 79.0, 93.1] {
            let h = 1e-5;
            let (a, b) = (f.at(t - h), f.at(t + h));
            let p = f.at(t);
            let ed: Vec<f64> = (0..3)
                .map(|i| (b.euler[i] - a.euler[i]) / (2.0 * h))
                .collect();
            let (sf, cf) = p.euler[0].sin_cos();
            let (st, ct) = p.euler[1].sin_cos();
            // Inverse relation: φ̇ = p + tan θ (q sin φ + r cos φ).
            let phid = p.rates[0] + st / ct * (p.rates[1] * sf + p.rates[2] * cf);
            assert!((phid - ed[0]).abs() < 1e-7, "t = {t}: {phid} vs {}", ed[0]);
            let psid = (p.rates[1] * sf + p.rates[2] * cf) / ct;
            assert!((psid - ed[2]).abs() < 1e-7, "t = {t}");
        }
    }
}
