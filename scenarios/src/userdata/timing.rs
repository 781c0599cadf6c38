//! The time rule of a data CSV: how the `t` column turns into each step's model.
//!
//! Step k updates with row k and predicts over `Δt_k = t_{k+1} − t_k`; two rows with the same
//! `t` are one instant (Δt = 0: no motion, no process noise between them).
//!
//! - A **continuous** model file (`A`, `C`, …) is sampled exactly at each interval
//!   (`kalman::sampling`: `F = e^{AΔt}`, the input by zero-order hold, `Q` by Van Loan),
//!   caching each distinct interval, so an irregular, multi-rate or gappy record is filtered
//!   at its own time stamps.
//! - A **discrete** model file has one `dt`: a record whose spacing differs from it by more
//!   than round-off ([`regular_tolerance`]) is refused, naming the line, instead of being
//!   filtered as if it were regular.

use crate::error::{Error, Result};
use std::path::Path;

/// The largest difference between a row spacing and a discrete model's `dt` still taken as
/// round-off: `10⁻⁶·dt`, or 8 ulps of the larger time stamp if that is more (stamps far from
/// zero carry that much from their own rounding).
pub fn regular_tolerance(dt: f64, t: f64) -> f64 {
    (1e-6 * dt).max(8.0 * f64::EPSILON * t.abs())
}

/// The refusal of a discrete model on an irregular record: the spacing `t_next − t` between
/// the previous row and the one at `line` of `data` is not the model's `dt`.
pub fn check_regular(
    data: &Path,
    line: u64,
    model: &Path,
    dt: f64,
    t: f64,
    t_next: f64,
) -> Result<()> {
    let spacing = t_next - t;
    if (spacing - dt).abs() <= regular_tolerance(dt, t_next) {
        return Ok(());
    }
    Err(Error::invalid(
        data,
        format!(
            "line {line}: t = {t_next} is {spacing} s after the previous row, but {} is a \
             discrete model with dt = {dt}: a record with other intervals needs the continuous \
             form of the model (A, C, G, Qc, R, x0, P0 — no dt), which is sampled at the \
             record's own time stamps",
            model.display()
        ),
    ))
}

/// The continuous model's sampler for `filter`, its errors about an interval named by the
/// data line that ends it.
pub fn sample<'s>(
    sampler: &'s mut kalman::sampling::Sampler,
    data: &Path,
    line: u64,
    dt: f64,
) -> Result<&'s kalman::Model<kalman::DynDims>> {
    sampler.at(dt).map_err(|e| {
        Error::invalid(
            data,
            format!("line {line}: the interval of {dt} s to this row cannot be sampled: {e}"),
        )
    })
}
