//! Shared input checks used by every constructor (shape, finiteness, symmetry, PSD, scalars).
//! Also the one way a deserialised value reaches its type: through its checking constructor.

/// Deserialisation through the type's checking constructor, so that a file can never bypass
/// its checks: `deserialize_via! { Type, Raw { a: A, b: B }, |r| Type::new(r.a, r.b) }`
/// declares `Raw`, the plain mirror serde fills (the same field names and types), and
/// `TryFrom<Raw> for Type`, which builds the value by the constructor, with the `Error` and
/// `Result` the calling module names (this crate's). `Type` carries
/// `#[serde(try_from = "Raw")]`.
macro_rules! deserialize_via {
    ($ty:ty, $raw:ident { $($field:ident: $fty:ty),* $(,)? }, |$r:ident| $build:expr) => {
        #[derive(serde::Deserialize)]
        struct $raw {
            $($field: $fty),*
        }

        impl TryFrom<$raw> for $ty {
            type Error = Error;
            fn try_from($r: $raw) -> Result<Self> {
                $build
            }
        }
    };
}

use nalgebra::DMatrix;

use crate::error::{Error, Result};

/// The workspace's one tolerance policy (its home is `numerics`, shared with `kalman` and
/// `wls`), relative to the matrix's own scale: symmetric when `max|Mᵢⱼ − Mⱼᵢ| ≤ SYMMETRY_TOL ·
/// max|M|` (then symmetrised), PSD when the smallest eigenvalue of the symmetric part is
/// `≥ −PSD_TOL · max|λ|`. Scaling a matrix by any positive factor — a change of units —
/// never changes the verdict.
pub use numerics::{PSD_TOL, SYMMETRY_TOL};

pub(crate) fn finite(name: &'static str, m: &DMatrix<f64>) -> Result<()> {
    for c in 0..m.ncols() {
        for r in 0..m.nrows() {
            let v = m[(r, c)];
            if !v.is_finite() {
                return Err(Error::NonFiniteMatrix {
                    name,
                    row: r,
                    col: c,
                    value: v,
                });
            }
        }
    }
    Ok(())
}

pub(crate) fn square(name: &'static str, m: &DMatrix<f64>) -> Result<usize> {
    if m.nrows() != m.ncols() {
        return Err(Error::NotSquare {
            name,
            rows: m.nrows(),
            cols: m.ncols(),
        });
    }
    finite(name, m)?;
    Ok(m.nrows())
}

pub(crate) fn shape(
    name: &'static str,
    m: &DMatrix<f64>,
    rows: usize,
    cols: usize,
    rule: &'static str,
) -> Result<()> {
    if m.nrows() != rows || m.ncols() != cols {
        return Err(Error::DimensionMismatch {
            name,
            rows: m.nrows(),
            cols: m.ncols(),
            expected_rows: rows,
            expected_cols: cols,
            rule,
        });
    }
    finite(name, m)
}

/// Square, finite, symmetric (to [`SYMMETRY_TOL`]) and PSD (to [`PSD_TOL`]).
pub(crate) fn covariance(
    name: &'static str,
    m: &DMatrix<f64>,
    n: usize,
    rule: &'static str,
) -> Result<()> {
    shape(name, m, n, n, rule)?;
    if n == 0 {
        return Ok(());
    }
    let scale = m.amax();
    let mut asym: f64 = 0.0;
    for i in 0..n {
        for j in 0..i {
            asym = asym.max((m[(i, j)] - m[(j, i)]).abs());
        }
    }
    if asym > numerics::symmetry_tolerance(scale) {
        return Err(Error::NotSymmetric {
            name,
            asymmetry: asym,
        });
    }
    let sym = symmetrize(m);
    let eig = sym.symmetric_eigenvalues();
    let min_eig = eig.min();
    if min_eig < -numerics::psd_tolerance(eig.amax()) {
        return Err(Error::NotPositiveSemiDefinite {
            name,
            min_eigenvalue: min_eig,
        });
    }
    Ok(())
}

/// A scalar that must be finite and strictly positive.
pub(crate) fn positive(name: &'static str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(Error::InvalidParameter {
            name,
            value: v,
            rule: "finite and > 0",
        })
    }
}

/// A scalar that must be finite and ≥ 0.
pub(crate) fn non_negative(name: &'static str, v: f64) -> Result<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(Error::InvalidParameter {
            name,
            value: v,
            rule: "finite and ≥ 0",
        })
    }
}

/// A scalar that must be finite.
pub(crate) fn finite_scalar(name: &'static str, v: f64) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::InvalidParameter {
            name,
            value: v,
            rule: "finite",
        })
    }
}

/// Makes a square matrix exactly symmetric: (M + Mᵀ)/2, by `numerics::symmetrise`.
pub(crate) fn symmetrize(m: &DMatrix<f64>) -> DMatrix<f64> {
    let mut s = m.clone();
    numerics::symmetrise(s.as_mut_slice(), m.nrows());
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn covariance_checks() {
        let ok = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        assert!(covariance("Q", &ok, 2, "test").is_ok());
        // Singular PSD is fine.
        let sing = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert!(covariance("Q", &sing, 2, "test").is_ok());
        let indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert!(matches!(
            covariance("Q", &indefinite, 2, "test"),
            Err(Error::NotPositiveSemiDefinite { name: "Q", .. })
        ));
        assert!(covariance("Q", &DMatrix::zeros(0, 0), 0, "test").is_ok());
    }

    #[test]
    fn scalar_checks() {
        assert!(positive("dt", 0.1).is_ok());
        assert!(positive("dt", 0.0).is_err());
        assert!(non_negative("v", 0.0).is_ok());
        assert!(non_negative("v", f64::INFINITY).is_err());
        assert!(finite_scalar("phi", f64::NAN).is_err());
    }
}
