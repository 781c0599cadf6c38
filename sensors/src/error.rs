//! The crate's typed error and the validation helpers every constructor uses.

/// Everything that can go wrong in this crate: a configuration parameter that breaks its rule,
/// or a failed mounting check. Each variant names the offending parameter (by its
/// configuration field name, units included) and its value.
///
/// # Example
/// ```
/// use sensors::{Error, WhiteNoise};
///
/// let err = WhiteNoise::new(-1.0, 0.1).unwrap_err();
/// assert!(matches!(err, Error::Negative { name: "std_dev", .. }));
/// println!("{err}"); // parameter `std_dev` = -1 must be >= 0
/// ```
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// A parameter is NaN or infinite.
    #[error("parameter `{name}` = {value} must be finite (not NaN or infinite)")]
    NotFinite {
        /// Configuration field name, with units.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A parameter that must be strictly positive is zero or negative.
    #[error("parameter `{name}` = {value} must be > 0")]
    NotPositive {
        /// Configuration field name, with units.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A parameter that must be non-negative is negative.
    #[error("parameter `{name}` = {value} must be >= 0")]
    Negative {
        /// Configuration field name, with units.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A parameter lies outside its allowed closed interval.
    #[error("parameter `{name}` = {value} must lie in [{min}, {max}]")]
    OutOfRange {
        /// Configuration field name, with units.
        name: &'static str,
        /// The value given.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// The accelerometer's out-of-plane axis reads more than the mounting tolerance: the
    /// sensor is misaligned (in the boom paper a_z ≈ 0 only checks the mounting).
    #[error("mounting check failed: |a_z| = {a_z} m/s² exceeds the tolerance {tolerance} m/s²")]
    MountingCheck {
        /// The out-of-plane reading a_z, m/s².
        a_z: f64,
        /// The configured tolerance, m/s².
        tolerance: f64,
    },
}

/// Checks that `value` is finite.
pub(crate) fn finite(name: &'static str, value: f64) -> Result<f64, Error> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(Error::NotFinite { name, value })
    }
}

/// Checks that `value` is finite and > 0.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<f64, Error> {
    let value = finite(name, value)?;
    if value > 0.0 {
        Ok(value)
    } else {
        Err(Error::NotPositive { name, value })
    }
}

/// Checks that `value` is finite and >= 0.
pub(crate) fn non_negative(name: &'static str, value: f64) -> Result<f64, Error> {
    let value = finite(name, value)?;
    if value >= 0.0 {
        Ok(value)
    } else {
        Err(Error::Negative { name, value })
    }
}

/// Checks that `value` is finite and within `[min, max]`.
pub(crate) fn in_range(name: &'static str, value: f64, min: f64, max: f64) -> Result<f64, Error> {
    let value = finite(name, value)?;
    if (min..=max).contains(&value) {
        Ok(value)
    } else {
        Err(Error::OutOfRange {
            name,
            value,
            min,
            max,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn helpers_name_the_rule_broken() {
        assert!(matches!(
            finite("x", f64::NAN),
            Err(Error::NotFinite { name: "x", .. })
        ));
        assert!(matches!(
            positive("x", 0.0),
            Err(Error::NotPositive { name: "x", .. })
        ));
        assert!(matches!(
            non_negative("x", -1e-300),
            Err(Error::Negative { name: "x", .. })
        ));
        assert!(matches!(
            in_range("x", 91.0, -90.0, 90.0),
            Err(Error::OutOfRange { name: "x", .. })
        ));
        assert!(in_range("x", 90.0, -90.0, 90.0).is_ok());
        assert!(non_negative("x", f64::INFINITY).is_err());
        let msg = positive("sensor_radius_m", -2.0)
            .map(|_| ())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            msg.contains("sensor_radius_m") && msg.contains("> 0"),
            "{msg}"
        );
    }
}
