//! Building blocks shared by the sensors: an exactly integrated first-order lag, a quantizer
//! and a fixed-length dead-time line.

use serde::{Deserialize, Serialize};

use crate::error::{Error, non_negative, positive};

/// How the input of a [`FirstOrderLag`] is assumed to behave between two samples.
///
/// # Example
/// ```
/// use sensors::{FirstOrderLag, LagInput};
///
/// // With a zero-order hold the output at k+1 depends only on inputs up to k.
/// let mut lag = FirstOrderLag::new(1.0, 0.1, LagInput::ZeroOrderHold)?;
/// lag.reset_to(0.0, 0.0);
/// assert!(lag.step(1.0).abs() < 1e-15);
/// assert!(lag.step(1.0) > 0.0);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum LagInput {
    /// The input varies linearly between consecutive samples (first-order hold). Exact for
    /// any piecewise-linear input, e.g. a level rising at a constant rate; the right model
    /// for a physical signal known only at the samples. Default.
    #[default]
    PiecewiseLinear,
    /// The input is held at its sample value until the next sample (zero-order hold): the
    /// output at step k+1 depends on inputs up to step k only.
    ZeroOrderHold,
}

/// First-order lag 1/(T s + 1) integrated exactly over each step Δt.
///
/// With a = e^{−Δt/T} and r = T(1 − a)/Δt:
/// - [`LagInput::PiecewiseLinear`]: y_{k+1} = a·y_k + (1 − r)·u_{k+1} + (r − a)·u_k;
/// - [`LagInput::ZeroOrderHold`]: y_{k+1} = a·y_k + (1 − a)·u_k.
///
/// T = 0 is allowed: pass-through (piecewise-linear) or a one-sample hold (zero-order hold).
///
/// # Example
/// ```
/// use sensors::{FirstOrderLag, LagInput};
///
/// // A unit step through 1/(2 s + 1), sampled every 0.1 s: y(t) = 1 − e^{−t/2} exactly.
/// let mut lag = FirstOrderLag::new(2.0, 0.1, LagInput::ZeroOrderHold)?;
/// lag.reset_to(0.0, 1.0);
/// let mut y = 0.0;
/// for _ in 0..20 {
///     y = lag.step(1.0);
/// }
/// assert!((y - (1.0 - (-1.0f64).exp())).abs() < 1e-12);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct FirstOrderLag {
    time: f64,
    dt: f64,
    mode: LagInput,
    a: f64,
    c_now: f64,
    c_prev: f64,
    y: f64,
    u_prev: f64,
    started: bool,
}

impl FirstOrderLag {
    /// A lag with time constant `time_constant_s` ≥ 0 stepped every `dt` s.
    ///
    /// # Errors
    /// [`Error`] if T is negative, Δt not positive, or either is not finite.
    pub fn new(time_constant_s: f64, dt: f64, mode: LagInput) -> Result<Self, Error> {
        let time = non_negative("time_constant_s", time_constant_s)?;
        let dt = positive("dt_s", dt)?;
        let (a, r) = if time > 0.0 {
            let em1 = (-dt / time).exp_m1(); // a − 1, accurate for Δt ≪ T
            (1.0 + em1, -time * em1 / dt)
        } else {
            (0.0, 0.0)
        };
        let (c_now, c_prev) = match mode {
            LagInput::PiecewiseLinear => (1.0 - r, r - a),
            LagInput::ZeroOrderHold => (0.0, 1.0 - a),
        };
        Ok(Self {
            time,
            dt,
            mode,
            a,
            c_now,
            c_prev,
            y: 0.0,
            u_prev: 0.0,
            started: false,
        })
    }
    /// Sets the state: output `y0` at the current sample, where the input is `u0`.
    pub fn reset_to(&mut self, y0: f64, u0: f64) {
        self.y = y0;
        self.u_prev = u0;
        self.started = true;
    }
    /// Forgets the state: the next [`FirstOrderLag::step`] starts in equilibrium with its
    /// input and returns it unchanged.
    pub fn reset(&mut self) {
        self.started = false;
    }
    /// Advances one step to the sample where the input is `u`; returns the output there.
    #[inline]
    pub fn step(&mut self, u: f64) -> f64 {
        if self.started {
            self.y = self.a * self.y + self.c_now * u + self.c_prev * self.u_prev;
        } else {
            self.y = u;
            self.started = true;
        }
        self.u_prev = u;
        self.y
    }
    /// Output at the last sample.
    pub fn output(&self) -> f64 {
        self.y
    }
    /// Time constant T, s.
    pub fn time_constant(&self) -> f64 {
        self.time
    }
    /// Step Δt, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }
    /// Inter-sample input model.
    pub fn mode(&self) -> LagInput {
        self.mode
    }
}

/// How a [`Quantizer`] rounds.
///
/// # Example
/// ```
/// use sensors::{Quantizer, Rounding};
///
/// let floor = Quantizer::new("step", 0.01, Rounding::Floor, 0.0)?;
/// let nearest = Quantizer::new("step", 0.01, Rounding::Nearest, 0.0)?;
/// assert!((floor.quantize(0.0199) - 0.01).abs() < 1e-15);
/// assert!((nearest.quantize(0.0199) - 0.02).abs() < 1e-15);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Rounding {
    /// step·⌊x/step⌋: a point sensor that reports the last mark passed (error in [−step, 0)).
    Floor,
    /// step·round(x/step): a mid-tread converter (error in [−step/2, step/2]).
    Nearest,
}

/// Uniform quantizer with step q ≥ 0 (q = 0: no quantization) and an output offset.
///
/// # Example
/// ```
/// use sensors::{Quantizer, Rounding};
///
/// // A 10 mm floor quantizer whose reading is shifted by half a step (mid-step compensation).
/// let q = Quantizer::new("step_m", 0.01, Rounding::Floor, 0.005)?;
/// assert!((q.quantize(1.234) - 1.235).abs() < 1e-12);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantizer {
    step: Option<f64>,
    rounding: Rounding,
    offset: f64,
}

impl Quantizer {
    /// A quantizer of step `step` (0 = none) that adds `offset` to every output.
    ///
    /// # Errors
    /// [`Error`] if `step` is negative or either value is not finite.
    pub fn new(
        name: &'static str,
        step: f64,
        rounding: Rounding,
        offset: f64,
    ) -> Result<Self, Error> {
        let step = non_negative(name, step)?;
        Ok(Self {
            step: (step > 0.0).then_some(step),
            rounding,
            offset: crate::error::finite("quantizer offset", offset)?,
        })
    }
    /// Quantized value of `x`.
    #[inline]
    pub fn quantize(&self, x: f64) -> f64 {
        match self.step {
            None => x + self.offset,
            Some(q) => {
                let n = match self.rounding {
                    Rounding::Floor => (x / q).floor(),
                    Rounding::Nearest => (x / q).round(),
                };
                n * q + self.offset
            }
        }
    }
}

/// A transport delay of a whole number of samples, on a ring buffer allocated once.
#[derive(Debug, Clone)]
pub(crate) struct DelayLine {
    buf: Vec<f64>,
    head: usize,
    started: bool,
}

impl DelayLine {
    /// A delay of `samples` steps.
    pub(crate) fn new(samples: usize) -> Self {
        Self {
            buf: vec![0.0; samples],
            head: 0,
            started: false,
        }
    }
    /// Pushes `x` and returns the value from `samples` steps ago (before that: the first
    /// value pushed, i.e. the signal is assumed constant before the start).
    #[inline]
    pub(crate) fn push(&mut self, x: f64) -> f64 {
        if self.buf.is_empty() {
            return x;
        }
        if !self.started {
            self.buf.fill(x);
            self.started = true;
        }
        let out = self.buf[self.head];
        self.buf[self.head] = x;
        self.head = (self.head + 1) % self.buf.len();
        out
    }
    /// Forgets the content.
    pub(crate) fn reset(&mut self) {
        self.started = false;
        self.head = 0;
    }
}

/// Whole number of samples nearest to `time_s / dt`.
pub(crate) fn samples_in(name: &'static str, time_s: f64, dt: f64) -> Result<usize, Error> {
    let t = non_negative(name, time_s)?;
    let n = (t / dt).round();
    if n > 1e7 {
        return Err(Error::OutOfRange {
            name,
            value: t,
            min: 0.0,
            max: 1e7 * dt,
        });
    }
    // n is a non-negative whole number below 1e7: the cast is exact.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    Ok(n as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn delay_line_delays_by_n_samples() {
        let mut d = DelayLine::new(3);
        let out: Vec<f64> = (0..6).map(|k| d.push(f64::from(k))).collect();
        let want = [0.0, 0.0, 0.0, 0.0, 1.0, 2.0];
        for (o, w) in out.iter().zip(want) {
            assert_relative_eq!(*o, w);
        }
        let mut none = DelayLine::new(0);
        assert_relative_eq!(none.push(5.0), 5.0);
    }

    #[test]
    fn zero_time_constant_passes_through() {
        let mut lag = FirstOrderLag::new(0.0, 0.1, LagInput::PiecewiseLinear).expect("valid");
        for k in 0..5 {
            let u = f64::from(k).sin();
            assert_relative_eq!(lag.step(u), u);
        }
    }

    #[test]
    fn quantizer_modes() {
        let f = Quantizer::new("q", 0.5, Rounding::Floor, 0.0).expect("valid");
        assert_relative_eq!(f.quantize(1.24), 1.0);
        assert_relative_eq!(f.quantize(-0.1), -0.5);
        let n = Quantizer::new("q", 0.5, Rounding::Nearest, 0.0).expect("valid");
        assert_relative_eq!(n.quantize(1.24), 1.0);
        assert_relative_eq!(n.quantize(1.26), 1.5);
        let off = Quantizer::new("q", 0.0, Rounding::Floor, 0.25).expect("valid");
        assert_relative_eq!(off.quantize(1.0), 1.25);
        assert!(Quantizer::new("q", -1.0, Rounding::Floor, 0.0).is_err());
    }
}
