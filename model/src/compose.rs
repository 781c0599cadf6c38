//! Block composition of discrete (and continuous) systems: series, parallel, append, stack,
//! output selection, feedback, and the general `connect` they are all built on.
//!
//! Only control inputs are wired; noise inputs of the blocks stay external, stacked in block
//! order (their covariances / intensities block-diagonally), and reach the outputs through
//! the interconnection like any other signal.

use nalgebra::DMatrix;

use crate::error::{Error, Result};
use crate::ss::{ContinuousSs, DiscreteSs};
use crate::validate;

/// Relative tolerance on equal sampling intervals of composed systems.
const DT_TOL: f64 = 1e-12;

fn block_diag(ms: &[&DMatrix<f64>]) -> DMatrix<f64> {
    let rows = ms.iter().map(|m| m.nrows()).sum();
    let cols = ms.iter().map(|m| m.ncols()).sum();
    let mut out = DMatrix::zeros(rows, cols);
    let (mut r, mut c) = (0, 0);
    for m in ms {
        out.view_mut((r, c), (m.nrows(), m.ncols())).copy_from(m);
        r += m.nrows();
        c += m.ncols();
    }
    out
}

/// The matrices of one system in the order `[F, B, H, D, G, J, Q]` (a continuous system's
/// `[A, B, C, D, G, 0, W]`: it has no noise feed-through).
type Parts<'a> = [&'a DMatrix<f64>; 7];

/// The interconnection kernel. Appended blocks: `x⁺ = Fa x + Ba v + Ga w`,
/// `y = Ha x + Da v + Ja w`; wiring `v = K y + E u`, external outputs `z = P y + Qd u`.
/// Solving `(I − Da K) y = Ha x + Da E u + Ja w` removes the algebraic part.
fn connect_parts(
    blocks: &[Parts<'_>],
    k: &DMatrix<f64>,
    e: &DMatrix<f64>,
    p: &DMatrix<f64>,
    qd: &DMatrix<f64>,
) -> Result<[DMatrix<f64>; 7]> {
    let [fa, ba, ha, da, ga, ja, qa] =
        std::array::from_fn(|i| block_diag(&blocks.iter().map(|b| b[i]).collect::<Vec<_>>()));
    let (nv, ny) = (ba.ncols(), ha.nrows());
    validate::shape("K", k, nv, ny, "K must be (block inputs)×(block outputs)")?;
    validate::shape("E", e, nv, e.ncols(), "E must have one row per block input")?;
    validate::shape(
        "P",
        p,
        p.nrows(),
        ny,
        "P must have one column per block output",
    )?;
    validate::shape(
        "Qd",
        qd,
        p.nrows(),
        e.ncols(),
        "Qd must be (rows of P)×(columns of E)",
    )?;
    let l = DMatrix::<f64>::identity(ny, ny) - &da * k;
    let lu = l.lu();
    let singular = Error::Singular {
        name: "I − D·K",
        context: "the interconnection has an ill-posed algebraic loop",
    };
    let hy = lu.solve(&ha).ok_or(singular.clone())?;
    let dy = lu.solve(&(&da * e)).ok_or(singular.clone())?;
    let jy = lu.solve(&ja).ok_or(singular)?;
    let f = &fa + &ba * k * &hy;
    let b = &ba * (k * &dy + e);
    let g = &ga + &ba * k * &jy;
    let h = p * &hy;
    let d = p * &dy + qd;
    let j = p * &jy;
    for (name, m) in [
        ("F", &f),
        ("B", &b),
        ("G", &g),
        ("H", &h),
        ("D", &d),
        ("J", &j),
    ] {
        validate::finite(name, m)?;
    }
    Ok([f, b, h, d, g, j, qa])
}

fn common_dt(blocks: &[&DiscreteSs]) -> Result<f64> {
    let first = blocks.first().map_or(1.0, |b| b.dt());
    for b in blocks {
        if (b.dt() - first).abs() > DT_TOL * first {
            return Err(Error::SampleTimeMismatch {
                first,
                second: b.dt(),
            });
        }
    }
    Ok(first)
}

/// General interconnection of discrete blocks (like MATLAB's `connect`).
///
/// The blocks are appended (states and noise inputs in block order). Their control inputs
/// `v` (all blocks' inputs stacked) are wired as `v = K·y + E·u` from their outputs `y` (all
/// blocks' outputs stacked) and the new external inputs `u`; the new outputs are
/// `z = P·y + Qd·u`, with `K` = `loop_gain`, `E` = `input_map`, `P` = `output_map` and
/// `Qd` = `feedthrough` (the letters of the wiring, named as in errors; not the covariances
/// of the workspace's notation). Algebraic loops through the feed-throughs are solved exactly.
///
/// # Errors
/// [`Error::DimensionMismatch`] for wiring matrices of the wrong shape,
/// [`Error::SampleTimeMismatch`], [`Error::Singular`] for an ill-posed algebraic loop.
///
/// # Example
/// ```
/// use model::nalgebra::{DMatrix, dmatrix};
/// use model::{DiscreteSs, connect};
///
/// // Two gains in series, y = 3·(2·u), written as a wiring: v₂ = y₁, v₁ = u, z = y₂.
/// // A static gain y = g·u: no states, one input, one output.
/// let gain = |g: f64| {
///     let (f, b, h) = (DMatrix::zeros(0, 0), DMatrix::zeros(0, 1), DMatrix::zeros(1, 0));
///     DiscreteSs::new(f, b, h, dmatrix![g], 0.1)
/// };
/// let (g1, g2) = (gain(2.0)?, gain(3.0)?);
/// let k = dmatrix![0.0, 0.0; 1.0, 0.0]; // v = K y
/// let e = dmatrix![1.0; 0.0];           //   + E u
/// let p = dmatrix![0.0, 1.0];           // z = P y
/// let loop_ = connect(&[&g1, &g2], &k, &e, &p, &dmatrix![0.0])?;
/// assert!((loop_.d()[(0, 0)] - 6.0).abs() < 1e-12);
/// # Ok::<(), model::Error>(())
/// ```
pub fn connect(
    blocks: &[&DiscreteSs],
    loop_gain: &DMatrix<f64>,
    input_map: &DMatrix<f64>,
    output_map: &DMatrix<f64>,
    feedthrough: &DMatrix<f64>,
) -> Result<DiscreteSs> {
    let dt = common_dt(blocks)?;
    let parts: Vec<Parts> = blocks
        .iter()
        .map(|s| [s.f(), s.b(), s.h(), s.d(), s.g(), s.j(), s.q()])
        .collect();
    let [f, b, h, d, g, j, q] =
        connect_parts(&parts, loop_gain, input_map, output_map, feedthrough)?;
    DiscreteSs::new(f, b, h, d, dt)?.with_noise(g, j, validate::symmetrize(&q))
}

/// [`connect`] for continuous blocks (same algebra; continuous models have no noise
/// feed-through, and the wiring must not create one: blocks' `D` only routes control inputs).
///
/// # Errors
/// As [`connect`] (without the sampling-interval check).
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
/// use model::{ContinuousSs, connect_continuous};
///
/// // An integrator 1/s closed in unit negative feedback: ẋ = −x + u.
/// let int = ContinuousSs::new(dmatrix![0.0], dmatrix![1.0], dmatrix![1.0], dmatrix![0.0])?;
/// let (k, e, p, qd) = (dmatrix![-1.0], dmatrix![1.0], dmatrix![1.0], dmatrix![0.0]);
/// let closed = connect_continuous(&[&int], &k, &e, &p, &qd)?;
/// assert!((closed.a()[(0, 0)] + 1.0).abs() < 1e-12);
/// # Ok::<(), model::Error>(())
/// ```
pub fn connect_continuous(
    blocks: &[&ContinuousSs],
    loop_gain: &DMatrix<f64>,
    input_map: &DMatrix<f64>,
    output_map: &DMatrix<f64>,
    feedthrough: &DMatrix<f64>,
) -> Result<ContinuousSs> {
    let no_j: Vec<DMatrix<f64>> = blocks
        .iter()
        .map(|s| DMatrix::zeros(s.n_outputs(), s.n_noise()))
        .collect();
    let parts: Vec<Parts> = blocks
        .iter()
        .zip(&no_j)
        .map(|(s, j)| [s.a(), s.b(), s.c(), s.d(), s.g(), j, s.w()])
        .collect();
    let [a, b, c, d, g, _, w] =
        connect_parts(&parts, loop_gain, input_map, output_map, feedthrough)?;
    ContinuousSs::new(a, b, c, d)?.with_noise(g, validate::symmetrize(&w))
}

fn sel(rows: usize, cols: usize, r0: usize, c0: usize, size: usize) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(rows, cols);
    for i in 0..size {
        m[(r0 + i, c0 + i)] = 1.0;
    }
    m
}

/// Series connection `s1 → s2`: the outputs of `s1` drive the inputs of `s2`; states
/// `[x1; x2]`, noise `[w1; w2]`.
///
/// # Errors
/// [`Error::DimensionMismatch`] when `s1` has a different number of outputs than `s2` has
/// inputs; [`Error::SampleTimeMismatch`].
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
/// use model::{DiscreteSs, series};
///
/// let lag = DiscreteSs::new(dmatrix![0.5], dmatrix![1.0], dmatrix![1.0], dmatrix![0.0], 1.0)?;
/// let both = series(&lag, &lag)?;
/// assert_eq!(both.n_states(), 2);
/// // DC gain of each is 1/(1 − 0.5) = 2, of the cascade 4.
/// let i_f = model::nalgebra::DMatrix::identity(2, 2) - both.f();
/// let dc = both.h() * i_f.lu().solve(both.b()).expect("stable");
/// assert!((dc[(0, 0)] - 4.0).abs() < 1e-12);
/// # Ok::<(), model::Error>(())
/// ```
pub fn series(s1: &DiscreteSs, s2: &DiscreteSs) -> Result<DiscreteSs> {
    let (l1, m1, l2, m2) = (s1.n_inputs(), s1.n_outputs(), s2.n_inputs(), s2.n_outputs());
    if m1 != l2 {
        return Err(Error::DimensionMismatch {
            name: "B (second system)",
            rows: s2.n_states(),
            cols: l2,
            expected_rows: s2.n_states(),
            expected_cols: m1,
            rule: "series: inputs of the second system = outputs of the first",
        });
    }
    let k = sel(l1 + l2, m1 + m2, l1, 0, m1);
    let e = sel(l1 + l2, l1, 0, 0, l1);
    let p = sel(m2, m1 + m2, 0, m1, m2);
    connect(&[s1, s2], &k, &e, &p, &DMatrix::zeros(m2, l1))
}

fn same_io(
    s1: &DiscreteSs,
    s2: &DiscreteSs,
    inputs: bool,
    outputs: bool,
    what: &'static str,
) -> Result<()> {
    if inputs && s1.n_inputs() != s2.n_inputs() {
        return Err(Error::DimensionMismatch {
            name: "B (second system)",
            rows: s2.n_states(),
            cols: s2.n_inputs(),
            expected_rows: s2.n_states(),
            expected_cols: s1.n_inputs(),
            rule: what,
        });
    }
    if outputs && s1.n_outputs() != s2.n_outputs() {
        return Err(Error::DimensionMismatch {
            name: "H (second system)",
            rows: s2.n_outputs(),
            cols: s2.n_states(),
            expected_rows: s1.n_outputs(),
            expected_cols: s2.n_states(),
            rule: what,
        });
    }
    Ok(())
}

/// Parallel connection: same input to both, outputs added (`y = y1 + y2`).
///
/// # Errors
/// [`Error::DimensionMismatch`] unless both have the same numbers of inputs and outputs;
/// [`Error::SampleTimeMismatch`].
///
/// # Example
/// ```
/// use model::nalgebra::{DMatrix, dmatrix};
/// use model::{DiscreteSs, parallel};
///
/// // A static gain y = g·u: no states, one input, one output.
/// let gain = |g: f64| {
///     let (f, b, h) = (DMatrix::zeros(0, 0), DMatrix::zeros(0, 1), DMatrix::zeros(1, 0));
///     DiscreteSs::new(f, b, h, dmatrix![g], 1.0)
/// };
/// let sum = parallel(&gain(2.0)?, &gain(3.0)?)?;
/// assert!((sum.d()[(0, 0)] - 5.0).abs() < 1e-15);
/// # Ok::<(), model::Error>(())
/// ```
pub fn parallel(s1: &DiscreteSs, s2: &DiscreteSs) -> Result<DiscreteSs> {
    same_io(
        s1,
        s2,
        true,
        true,
        "parallel: both systems need the same inputs and outputs",
    )?;
    let (l, m) = (s1.n_inputs(), s1.n_outputs());
    let k = DMatrix::zeros(2 * l, 2 * m);
    let mut e = sel(2 * l, l, 0, 0, l);
    e.view_mut((l, 0), (l, l)).fill_with_identity();
    let mut p = sel(m, 2 * m, 0, 0, m);
    p.view_mut((0, m), (m, m)).fill_with_identity();
    connect(&[s1, s2], &k, &e, &p, &DMatrix::zeros(m, l))
}

/// Stacking of outputs: same input to both, outputs `[y1; y2]`.
///
/// # Errors
/// [`Error::DimensionMismatch`] unless both have the same number of inputs;
/// [`Error::SampleTimeMismatch`].
///
/// # Example
/// ```
/// use model::nalgebra::{DMatrix, dmatrix};
/// use model::{DiscreteSs, stack};
///
/// // A static gain y = g·u: no states, one input, one output.
/// let gain = |g: f64| {
///     let (f, b, h) = (DMatrix::zeros(0, 0), DMatrix::zeros(0, 1), DMatrix::zeros(1, 0));
///     DiscreteSs::new(f, b, h, dmatrix![g], 1.0)
/// };
/// let both = stack(&gain(2.0)?, &gain(3.0)?)?;
/// assert!((both.d() - dmatrix![2.0; 3.0]).norm() < 1e-15);
/// # Ok::<(), model::Error>(())
/// ```
pub fn stack(s1: &DiscreteSs, s2: &DiscreteSs) -> Result<DiscreteSs> {
    same_io(
        s1,
        s2,
        true,
        false,
        "stack: both systems need the same inputs",
    )?;
    let (l, m1, m2) = (s1.n_inputs(), s1.n_outputs(), s2.n_outputs());
    let k = DMatrix::zeros(2 * l, m1 + m2);
    let mut e = sel(2 * l, l, 0, 0, l);
    e.view_mut((l, 0), (l, l)).fill_with_identity();
    let p = DMatrix::identity(m1 + m2, m1 + m2);
    connect(&[s1, s2], &k, &e, &p, &DMatrix::zeros(m1 + m2, l))
}

/// Block-diagonal append: inputs `[u1; u2]`, outputs `[y1; y2]`, no coupling.
///
/// # Errors
/// [`Error::SampleTimeMismatch`].
///
/// # Example
/// ```
/// use model::nalgebra::{DMatrix, dmatrix};
/// use model::{DiscreteSs, append};
///
/// // A static gain y = g·u: no states, one input, one output.
/// let gain = |g: f64| {
///     let (f, b, h) = (DMatrix::zeros(0, 0), DMatrix::zeros(0, 1), DMatrix::zeros(1, 0));
///     DiscreteSs::new(f, b, h, dmatrix![g], 1.0)
/// };
/// let diag = append(&gain(2.0)?, &gain(3.0)?)?;
/// assert!((diag.d() - dmatrix![2.0, 0.0; 0.0, 3.0]).norm() < 1e-15);
/// # Ok::<(), model::Error>(())
/// ```
pub fn append(s1: &DiscreteSs, s2: &DiscreteSs) -> Result<DiscreteSs> {
    let (l, m) = (
        s1.n_inputs() + s2.n_inputs(),
        s1.n_outputs() + s2.n_outputs(),
    );
    connect(
        &[s1, s2],
        &DMatrix::zeros(l, m),
        &DMatrix::identity(l, l),
        &DMatrix::identity(m, m),
        &DMatrix::zeros(m, l),
    )
}

/// Keeps the outputs listed in `outputs`, in that order (repeats allowed).
///
/// # Errors
/// [`Error::IndexOutOfRange`] for an index ≥ the number of outputs.
///
/// # Example
/// ```
/// use model::nalgebra::{DMatrix, dmatrix};
/// use model::{DiscreteSs, select_outputs};
///
/// let h = dmatrix![1.0; 2.0; 3.0];
/// let s = DiscreteSs::new(dmatrix![0.5], dmatrix![1.0], h, DMatrix::zeros(3, 1), 1.0)?;
/// let picked = select_outputs(&s, &[2, 0])?;
/// assert!((picked.h() - dmatrix![3.0; 1.0]).norm() < 1e-15);
/// assert!(select_outputs(&s, &[3]).is_err()); // out of range: a typed error
/// # Ok::<(), model::Error>(())
/// ```
pub fn select_outputs(s: &DiscreteSs, outputs: &[usize]) -> Result<DiscreteSs> {
    let m = s.n_outputs();
    let mut p = DMatrix::zeros(outputs.len(), m);
    for (row, &i) in outputs.iter().enumerate() {
        if i >= m {
            return Err(Error::IndexOutOfRange {
                name: "output",
                index: i,
                len: m,
            });
        }
        p[(row, i)] = 1.0;
    }
    let l = s.n_inputs();
    connect(
        &[s],
        &DMatrix::zeros(l, m),
        &DMatrix::identity(l, l),
        &p,
        &DMatrix::zeros(outputs.len(), l),
    )
}

/// Feedback loop: `u1 = u + sign·y2`, `u2 = y1`, output `y1`. `sign = −1.0` is negative
/// feedback. States `[x1; x2]`.
///
/// # Errors
/// [`Error::DimensionMismatch`] unless `s2` maps the outputs of `s1` back to its inputs;
/// [`Error::Singular`] when `I − sign·D1·D2` is singular (ill-posed loop);
/// [`Error::SampleTimeMismatch`].
///
/// # Example
/// ```
/// use model::nalgebra::{DMatrix, dmatrix};
/// use model::{DiscreteSs, feedback};
///
/// // Accumulator x_{k+1} = x_k + u_k in negative feedback through a gain of 0.5:
/// // the loop x_{k+1} = 0.5 x_k + u_k is stable.
/// let acc = DiscreteSs::new(dmatrix![1.0], dmatrix![1.0], dmatrix![1.0], dmatrix![0.0], 1.0)?;
/// let (e0, e1, e2) = (DMatrix::zeros(0, 0), DMatrix::zeros(0, 1), DMatrix::zeros(1, 0));
/// let k = DiscreteSs::new(e0, e1, e2, dmatrix![0.5], 1.0)?;
/// let closed = feedback(&acc, &k, -1.0)?;
/// assert!((closed.f()[(0, 0)] - 0.5).abs() < 1e-15);
/// # Ok::<(), model::Error>(())
/// ```
pub fn feedback(s1: &DiscreteSs, s2: &DiscreteSs, sign: f64) -> Result<DiscreteSs> {
    validate::finite_scalar("sign", sign)?;
    let (l1, m1) = (s1.n_inputs(), s1.n_outputs());
    if s2.n_inputs() != m1 || s2.n_outputs() != l1 {
        return Err(Error::DimensionMismatch {
            name: "D (feedback system)",
            rows: s2.n_outputs(),
            cols: s2.n_inputs(),
            expected_rows: l1,
            expected_cols: m1,
            rule: "feedback: the loop system maps outputs of the first back to its inputs",
        });
    }
    let mut k = DMatrix::zeros(l1 + m1, m1 + l1);
    k.view_mut((0, m1), (l1, l1))
        .copy_from(&(DMatrix::<f64>::identity(l1, l1) * sign));
    k.view_mut((l1, 0), (m1, m1)).fill_with_identity();
    let e = sel(l1 + m1, l1, 0, 0, l1);
    let p = sel(m1, m1 + l1, 0, 0, m1);
    connect(&[s1, s2], &k, &e, &p, &DMatrix::zeros(m1, l1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_diag_places_blocks() {
        let a = DMatrix::from_element(1, 2, 1.0);
        let b = DMatrix::from_element(2, 1, 2.0);
        let e = DMatrix::<f64>::zeros(0, 3);
        let m = block_diag(&[&a, &e, &b]);
        assert_eq!(m.shape(), (3, 6));
        assert!((m[(0, 1)] - 1.0).abs() < 1e-15 && (m[(2, 5)] - 2.0).abs() < 1e-15);
        assert!(m[(0, 5)].abs() < 1e-15);
    }

    #[test]
    fn series_of_static_gains_multiplies() {
        let g = |k: f64| {
            DiscreteSs::new(
                DMatrix::zeros(0, 0),
                DMatrix::zeros(0, 1),
                DMatrix::zeros(1, 0),
                DMatrix::from_element(1, 1, k),
                0.1,
            )
            .expect("valid")
        };
        let s = series(&g(2.0), &g(3.0)).expect("ok");
        assert!((s.d()[(0, 0)] - 6.0).abs() < 1e-15);
        let f = feedback(&g(2.0), &g(0.5), -1.0).expect("ok");
        assert!((f.d()[(0, 0)] - 1.0).abs() < 1e-15, "2/(1 + 2·0.5)");
    }
}
